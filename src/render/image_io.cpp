#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "scene/input_file.h"
#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra {
namespace {

std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

float linear_to_srgb(float c) {
    c = std::clamp(c, 0.f, 1.f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

// 8-bit sRGB, alpha dropped: the background is already composited.
std::vector<unsigned char> srgb8(const Image& image) {
    std::vector<unsigned char> rgb(std::size_t(image.width) * image.height * 3);
    for (std::size_t i = 0, n = rgb.size() / 3; i < n; ++i)
        for (int c = 0; c < 3; ++c) rgb[i * 3 + c] = (unsigned char)std::lround(255.f * linear_to_srgb(image.rgba[i * 4 + c]));
    return rgb;
}

bool has_pixels(const Image& image) {
    return image.width >= 1 && image.height >= 1 && image.rgba.size() == std::size_t(image.width) * image.height * 4;
}

}  // namespace

std::vector<unsigned char> encode_png(const Image& image) {
    if (!has_pixels(image)) throw Error("PNG: image has no pixels");
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput memory(bytes);
    auto out = OIIO::ImageOutput::create("png");
    if (!out || !out->supports("ioproxy")) throw Error("PNG: OpenImageIO cannot write PNG to memory");
    if (!out->set_ioproxy(&memory)) throw Error("PNG: " + out->geterror());
    const std::vector<unsigned char> rgb = srgb8(image);
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
    if (!(out->open("memory.png", spec) && out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) && out->close()))
        throw Error("PNG: cannot encode image (" + out->geterror() + ")");
    return bytes;
}

void write_image(const Image& image, const std::string& path) {
    std::string ext = lower_extension(path);
    if (ext != ".png" && ext != ".exr") throw Error(path + ": output must end in .png or .exr");
    if (!has_pixels(image)) throw Error(path + ": image has no pixels");
    // Write under a temporary name next to the target, then rename: no partial file on failure.
    std::string temporary = path + ".part" + ext;
    auto out = OIIO::ImageOutput::create(temporary);
    if (!out) throw Error(path + ": OpenImageIO cannot write this format (" + OIIO::geterror() + ")");
    bool ok;
    if (ext == ".png") {
        const std::vector<unsigned char> rgb = srgb8(image);
        OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
        ok = out->open(temporary, spec) && out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) && out->close();
    } else {  // linear float RGBA, premultiplied: the background (transmittance × background) taken out
        std::vector<float> rgba = image.rgba;
        for (std::size_t i = 0; i < rgba.size(); i += 4) {
            const float transmittance = 1.f - rgba[i + 3];
            for (int c = 0; c < 3; ++c) rgba[i + c] -= transmittance * image.background[std::size_t(c)];
        }
        OIIO::ImageSpec spec(image.width, image.height, 4, OIIO::TypeDesc::FLOAT);
        ok = out->open(temporary, spec) && out->write_image(OIIO::TypeDesc::FLOAT, rgba.data()) && out->close();
    }
    if (!ok) {
        std::string message = out->geterror();
        out.reset();
        std::remove(temporary.c_str());
        throw Error(path + ": cannot write image (" + message + ")");
    }
    out.reset();
    std::error_code ec;
    std::filesystem::rename(temporary, path, ec);
    if (ec) {
        std::remove(temporary.c_str());
        throw Error(path + ": cannot write image (" + ec.message() + ")");
    }
}

Image read_image(const std::string& path) {
    detail::regular_file_size(path);  // a regular file (never a FIFO or device, which would block), noted as an input
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw Error(path + ": cannot read image (" + OIIO::geterror() + ")");
    const OIIO::ImageSpec& spec = in->spec();
    Image image;
    image.width = spec.width, image.height = spec.height;
    std::vector<float> pixels(std::size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data()))
        throw Error(path + ": cannot read image (" + in->geterror() + ")");
    image.rgba.assign(std::size_t(spec.width) * spec.height * 4, 1.f);
    for (std::size_t i = 0, n = std::size_t(spec.width) * spec.height; i < n; ++i)
        for (int c = 0; c < std::min(4, spec.nchannels); ++c) image.rgba[i * 4 + c] = pixels[i * spec.nchannels + c];
    return image;
}

}  // namespace sombra
