// sombra — deep shadow maps as scanline deep OpenEXR files (shadows.h: write_deep_exr, read_deep_exr;
// docs/deep_exr.md).
//
// One point sample per DSM node, in depth order, with float channels A (the node's own alpha, so
// that OpenEXR's front-to-back compositing gives the accumulated opacity), Z (depth) and ZBack
// (= Z). Header: the light's name ("sombra:light"), the format version ("sombra:format" = 2; files
// without it but with "sombra:light" are sombra's older ones, whose A was the accumulated opacity),
// worldToCamera and worldToNDC. Scanline, not tiled: Nuke reads only scanline deep EXR.
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "scene/byte_cursor.h"
#include "scene/input_file.h"
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/shadows.h"

namespace sombra {
namespace {

// A NUL-terminated attribute or type name of an OpenEXR header, at most `max` characters.
std::string exr_name(detail::ByteCursor& c, std::size_t max, const char* field) {
    std::string name;
    for (char ch = c.get<char>(field); ch != '\0'; ch = c.get<char>(field)) {
        if (name.size() == max) c.fail(field, "a name longer than " + std::to_string(max) + " characters");
        name += ch;
    }
    return name;
}

// The bytes OpenEXR 3.1 reads for an attribute of a known fixed-size type (it reads them whatever
// size the file declares, so a size that differs desynchronises the header); 0: not a fixed type.
std::uint64_t exr_fixed_size(const std::string& type) {
    static const std::pair<const char*, std::uint64_t> kSizes[] = {
        {"int", 4},         {"float", 4},      {"double", 8},    {"box2i", 16},         {"box2f", 16},    {"v2i", 8},
        {"v2f", 8},         {"v2d", 16},       {"v3i", 12},      {"v3f", 12},           {"v3d", 24},      {"m33f", 36},
        {"m33d", 72},       {"m44f", 64},      {"m44d", 128},    {"compression", 1},    {"lineOrder", 1}, {"envmap", 1},
        {"deepImageState", 1}, {"chromaticities", 32}, {"keycode", 28}, {"rational", 8}, {"tiledesc", 9},  {"timecode", 8}};
    for (const auto& [name, bytes] : kSizes)
        if (type == name) return bytes;
    return 0;
}

// One attribute's value, read as OpenEXR reads its type: fixed types their size, a channel list
// entry by entry up to its NUL, a preview its width × height pixels; every other type (string,
// opaque, …) exactly the declared size. The declared size must be what OpenEXR will consume.
void check_exr_value(detail::ByteCursor& c, const std::string& name, const std::string& type, std::uint64_t size,
                     std::size_t max_name) {
    const std::string field = "attribute " + name + " (" + type + ")";
    const std::uint64_t start = c.at();
    if (const std::uint64_t fixed = exr_fixed_size(type)) {
        if (size != fixed) c.fail(field, "a size of " + std::to_string(size) + " bytes (the type has " + std::to_string(fixed) + ")");
        c.skip(size, field.c_str());
    } else if (type == "chlist") {
        for (std::string channel = exr_name(c, max_name, field.c_str()); !channel.empty();
             channel = exr_name(c, max_name, field.c_str())) {
            // pixel type (UINT, HALF, FLOAT), pLinear, 3 reserved bytes, x and y sampling (≥ 1)
            const std::int32_t type_code = c.get<std::int32_t>(field.c_str());
            c.skip(4, field.c_str());
            const std::int32_t x_sampling = c.get<std::int32_t>(field.c_str()), y_sampling = c.get<std::int32_t>(field.c_str());
            if (type_code < 0 || type_code > 2) c.fail(field, "channel " + channel + ": pixel type " + std::to_string(type_code));
            if (x_sampling < 1 || y_sampling < 1) c.fail(field, "channel " + channel + ": sampling below 1");
        }
    } else if (type == "preview") {
        const std::uint64_t width = c.get<std::uint32_t>(field.c_str()), height = c.get<std::uint32_t>(field.c_str());
        if (8 + width * height * 4 != size)
            c.fail(field, std::to_string(width) + " × " + std::to_string(height) + " pixels in " + std::to_string(size) + " bytes");
        c.skip(width * height * 4, field.c_str());
    } else {
        c.skip(size, field.c_str());
    }
    if (c.at() - start != size)
        c.fail(field, "a value of " + std::to_string(c.at() - start) + " bytes, declared " + std::to_string(size));
}

// The header values the chunk walk needs, kept as the header walk passes them.
struct ExrLayout {
    std::string type;                    // "deepscanline", "deeptile", "scanlineimage", … ("" if absent)
    int compression = -1;                // 0 none, 1 rle, 2 zips, …
    std::int32_t box[4] = {0, 0, -1, -1};  // dataWindow: xmin, ymin, xmax, ymax
    std::int64_t chunk_count = -1;       // -1: not given
    std::uint64_t sample_bytes = 0;      // bytes per deep sample: the channels' sizes summed
    bool has_data_window = false;
};

// Keeps the values of the attributes the chunk walk needs (their bytes were just checked).
void keep_exr_value(detail::ByteCursor& c, const std::string& name, const std::string& type, std::uint64_t size,
                    ExrLayout& layout) {
    static const std::pair<const char*, const char*> kKept[] = {
        {"type", "string"}, {"compression", "compression"}, {"dataWindow", "box2i"}, {"chunkCount", "int"}, {"channels", "chlist"}};
    const auto kept = std::find_if(std::begin(kKept), std::end(kKept), [&](const auto& k) { return name == k.first; });
    if (kept == std::end(kKept)) return;
    if (type != kept->second) c.fail("attribute " + name, "of type " + type + " (OpenEXR's is " + kept->second + ")");
    c.rewind(size);
    std::string bytes(size, '\0');
    c.read(bytes.data(), size, name.c_str());
    auto int32_at = [&](std::size_t at) {
        std::int32_t v;
        std::memcpy(&v, bytes.data() + at, 4);
        return v;
    };
    if (name == "type") layout.type = bytes.substr(0, bytes.find('\0'));
    if (name == "compression") layout.compression = static_cast<unsigned char>(bytes[0]);
    if (name == "chunkCount" && size == 4) layout.chunk_count = int32_at(0);
    if (name == "dataWindow" && size == 16) {
        for (int i = 0; i < 4; ++i) layout.box[i] = int32_at(std::size_t(i) * 4);
        layout.has_data_window = true;
    }
    if (name == "channels")  // name NUL, pixel type, pLinear + 3 reserved, x and y sampling (walked already)
        for (std::size_t at = 0; at < bytes.size() && bytes[at] != '\0';) {
            at = bytes.find('\0', at) + 1;
            if (at == 0 || at + 16 > bytes.size()) c.fail("attribute channels", "a channel cut short");
            layout.sample_bytes += int32_at(at) == 1 ? 2 : 4;  // HALF 2 bytes; UINT and FLOAT 4
            at += 16;
        }
}

// OpenEXR's header walked before OpenEXR reads it (its attribute sizes come from the file, and
// OpenEXR allocates them as given): the magic number, then each header's attributes — name, type,
// a value of its declared size, read as OpenEXR reads its type — up to the NUL that ends it
// (OpenEXR file layout, "Header"). Returns the values the chunk walk needs; the cursor stands at
// the offset table.
ExrLayout check_exr_header(detail::ByteCursor& c) {
    c.where = "OpenEXR header: ";
    if (c.get<std::uint32_t>("magic number") != 20000630u) c.fail("magic number", "not a deep OpenEXR file (not OpenEXR at all)");
    const std::uint32_t version = c.get<std::uint32_t>("version");
    const std::size_t max_name = (version & 0x400u) ? 255 : 31;  // bit 10: long names
    if (version & 0x1000u)  // bit 12: multi-part
        c.fail("version", "a multi-part file: sombra reads single-part scanline deep OpenEXR (what it writes)");
    ExrLayout layout;
    std::string name = exr_name(c, max_name, "attribute name");
    for (int attribute = 0; !name.empty(); ++attribute) {
        if (attribute == 4096) c.fail("attributes", "more than 4096 in one header");
        const std::string type = exr_name(c, max_name, ("attribute " + name + " type").c_str());
        const std::int32_t length = c.get<std::int32_t>("attribute size");
        if (length < 0) c.fail("attribute " + name, "a negative size");
        c.need(std::uint64_t(length), "attribute " + name);
        check_exr_value(c, name, type, std::uint64_t(length), max_name);
        keep_exr_value(c, name, type, std::uint64_t(length), layout);
        name = exr_name(c, max_name, "attribute name");
    }
    return layout;
}

// The most a compressed block can expand: zlib's deflate (zips) at most 1032:1; OpenEXR's RLE
// 64:1 (a run of up to 128 bytes in 2); none: stored as is.
std::uint64_t max_expansion(int compression) { return compression == 2 ? 1032 : compression == 1 ? 64 : 1; }

// The chunks of a single-part scanline deep file walked before OpenEXR reads them (OpenEXR
// allocates each chunk's packed sizes as the chunk declares them): the offset table, then at each
// offset the chunk's line, its packed sample-count table, packed and unpacked data sizes — inside
// the file, each line once, and no more data than its codec can give (OpenEXR file layout,
// "Deep Scan Line Chunk").
void check_exr_chunks(detail::ByteCursor& c, const ExrLayout& layout) {
    c.where = "OpenEXR chunks: ";
    if (layout.type != "deepscanline")
        c.fail("type", layout.type == "deeptile"
                           ? std::string("deep tiled: sombra reads scanline deep OpenEXR (what it writes, and what Nuke reads)")
                           : "not a deep OpenEXR file (type \"" + layout.type + "\")");
    if (layout.compression < 0 || layout.compression > 2)
        c.fail("compression", "deep OpenEXR allows none, rle and zips, got code " + std::to_string(layout.compression));
    if (!layout.has_data_window) c.fail("dataWindow", "missing");
    const std::int64_t width = std::int64_t(layout.box[2]) - layout.box[0] + 1, height = std::int64_t(layout.box[3]) - layout.box[1] + 1;
    if (width < 1 || height < 1 || width > limits::kMaxImageSide || height > limits::kMaxImageSide)
        c.fail("dataWindow", std::to_string(width) + " × " + std::to_string(height) + " pixels (each side in [1, " +
                                 std::to_string(limits::kMaxImageSide) + "])");
    if (layout.chunk_count >= 0 && layout.chunk_count != height)
        c.fail("chunkCount", std::to_string(layout.chunk_count) + ", the data window has " + std::to_string(height) + " lines");
    if (layout.sample_bytes == 0) c.fail("channels", "none");

    std::vector<std::uint64_t> offsets(std::size_t(height), 0);
    c.read(offsets.data(), offsets.size() * sizeof(std::uint64_t), "offset table");
    const std::uint64_t table_end = c.at(), file_size = c.at() + c.left();
    const std::uint64_t count_table_bytes = std::uint64_t(width) * 4;  // one line per chunk
    std::vector<bool> line_seen(std::size_t(height), false);
    for (std::size_t chunk = 0; chunk < offsets.size(); ++chunk) {
        const std::string field = "chunk " + std::to_string(chunk);
        const std::uint64_t offset = offsets[chunk];
        if (offset < table_end || offset > file_size || file_size - offset < 28)
            c.fail(field, "offset " + std::to_string(offset) + " outside the file's data (" + std::to_string(table_end) + " to " +
                              std::to_string(file_size) + " bytes)");
        c.seek(offset, field.c_str());
        const std::int32_t y = c.get<std::int32_t>(field.c_str());
        const std::uint64_t packed_table = c.get<std::uint64_t>(field.c_str()), packed_data = c.get<std::uint64_t>(field.c_str()),
                            unpacked_data = c.get<std::uint64_t>(field.c_str());
        if (y < layout.box[1] || y > layout.box[3] || line_seen[std::size_t(std::int64_t(y) - layout.box[1])])
            c.fail(field, "line " + std::to_string(y) + " outside the data window or given twice");
        line_seen[std::size_t(std::int64_t(y) - layout.box[1])] = true;
        if (packed_table > count_table_bytes)
            c.fail(field, "a sample-count table of " + std::to_string(packed_table) + " bytes (a line has " +
                              std::to_string(count_table_bytes) + ")");
        c.need(packed_table, field + " sample-count table");
        c.skip(packed_table, field.c_str());
        c.need(packed_data, field + " data");
        if (packed_data > unpacked_data || unpacked_data > packed_data * max_expansion(layout.compression))
            c.fail(field, std::to_string(packed_data) + " packed bytes cannot give " + std::to_string(unpacked_data) +
                              " unpacked ones with this compression");
        if (unpacked_data % layout.sample_bytes != 0)
            c.fail(field, "unpacked data of " + std::to_string(unpacked_data) + " bytes, not whole samples of " +
                              std::to_string(layout.sample_bytes) + " bytes");
    }
}

constexpr const char* kLightAttribute = "sombra:light";
constexpr const char* kFormatAttribute = "sombra:format";
constexpr int kFormat = 2;  // 2: per-sample alpha; sombra's older files (no attribute): accumulated
constexpr const char* kDepthAttribute = "sombra:depth";
// How opacity goes between two nodes: absent or "opacity": linearly (Knecht Eq. 3.7); "optical
// depth": τ = −ln(1 − opacity) linearly (maps built with DsmOptions::error "relative").
constexpr const char* kInterpolationAttribute = "sombra:interpolation";
constexpr const char* kDepthConvention =
    "Z = ZBack: distance from the light along the texel's ray (directional lights: camera-space z, from the near plane)";
// OpenImageIO's names of OpenEXR's worldToCamera and worldToNDC (Imath order: row vectors)
constexpr const char* kMatrixAttributes[2] = {"worldtocamera", "worldtoNDC"};

std::string texel_name(const DeepShadowMap& map, std::size_t texel) {
    return "texel (" + std::to_string(texel % std::size_t(map.width)) + ", " +
           std::to_string(texel / std::size_t(map.width)) + ")";
}

// Every invariant of shadows.h's DeepShadowMap that the file format relies on.
void validate(const DeepShadowMap& map, const std::string& path) {
    if (map.width < 1) throw file_error(path, "width", "must be >= 1, got " + std::to_string(map.width));
    if (map.height < 1) throw file_error(path, "height", "must be >= 1, got " + std::to_string(map.height));
    const std::uint64_t texels = std::uint64_t(map.width) * std::uint64_t(map.height);
    if (map.first.size() != texels + 1)
        throw file_error(path, "first", "has " + std::to_string(map.first.size()) + " offsets, expected width·height + 1 = " +
                                            std::to_string(texels + 1));
    if (map.first.front() != 0) throw file_error(path, "first[0]", "must be 0, got " + std::to_string(map.first.front()));
    for (std::size_t i = 1; i < map.first.size(); ++i)
        if (map.first[i] < map.first[i - 1])
            throw file_error(path, "first[" + std::to_string(i) + "]",
                             "offsets must not decrease (" + std::to_string(map.first[i]) + " < " +
                                 std::to_string(map.first[i - 1]) + ")");
    if (map.first.back() != map.nodes.size())
        throw file_error(path, "first", "last offset " + std::to_string(map.first.back()) + " != node count " +
                                            std::to_string(map.nodes.size()));
    for (std::size_t i = 0; i < map.nodes.size(); ++i) {
        if (!std::isfinite(map.nodes[i].depth))
            throw file_error(path, "nodes[" + std::to_string(i) + "].depth", "not finite");
        if (!std::isfinite(map.nodes[i].opacity))
            throw file_error(path, "nodes[" + std::to_string(i) + "].opacity", "not finite");
    }
    for (std::size_t texel = 0; texel < texels; ++texel)
        for (std::uint32_t n = map.first[texel] + 1; n < map.first[texel + 1]; ++n)
            if (map.nodes[n].depth < map.nodes[n - 1].depth)
                throw file_error(path, "nodes[" + std::to_string(n) + "].depth",
                                 "not sorted by depth in " + texel_name(map, texel) + " (" +
                                     std::to_string(map.nodes[n].depth) + " < " + std::to_string(map.nodes[n - 1].depth) + ")");
}

// Removes the temporary file unless release() was called (the rename succeeded).
class TemporaryFile {
public:
    explicit TemporaryFile(std::string path) : path_(std::move(path)) {}
    ~TemporaryFile() {
        if (!path_.empty()) {
            std::error_code ec;
            std::filesystem::remove(path_, ec);
        }
    }
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    void release() { path_.clear(); }

private:
    std::string path_;
};

std::array<float, 16> transposed(const std::array<float, 16>& m) {
    std::array<float, 16> t{};
    for (std::size_t r = 0; r < 4; ++r)
        for (std::size_t c = 0; c < 4; ++c) t[c * 4 + r] = m[r * 4 + c];
    return t;
}

int channel_index(const OIIO::ImageSpec& spec, const std::string& name) {
    for (int c = 0; c < spec.nchannels; ++c)
        if (spec.channelnames[std::size_t(c)] == name) return c;
    return -1;
}

}  // namespace

void write_deep_exr(const DeepShadowMap& map, const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (extension != ".exr") throw Error(path + ": a deep shadow map is written as OpenEXR: the name must end in .exr");
    validate(map, path);

    OIIO::ImageSpec spec(map.width, map.height, 3, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"A", "Z", "ZBack"};
    spec.alpha_channel = 0;
    spec.z_channel = 1;
    spec.deep = true;
    spec.attribute("compression", "zips");  // deep EXR allows none, rle and zips only
    spec.attribute(kLightAttribute, map.light_name);
    spec.attribute(kFormatAttribute, kFormat);
    spec.attribute(kDepthAttribute, kDepthConvention);
    spec.attribute(kInterpolationAttribute,
                   map.interpolation == DeepShadowMap::Interpolation::OpticalDepth ? "optical depth" : "opacity");
    const std::array<float, 16>* matrices[2] = {&map.world_to_camera, &map.world_to_ndc};
    for (int m = 0; m < 2; ++m) {
        const std::array<float, 16> imath = transposed(*matrices[m]);
        spec.attribute(kMatrixAttributes[m], OIIO::TypeMatrix, imath.data());
    }

    OIIO::DeepData deep;
    deep.init(spec);
    const std::size_t texels = std::size_t(map.width) * std::size_t(map.height);
    for (std::size_t texel = 0; texel < texels; ++texel)
        deep.set_samples(int64_t(texel), int(map.first[texel + 1] - map.first[texel]));
    for (std::size_t texel = 0; texel < texels; ++texel) {
        // V of the samples written so far, as front-to-back compositing of the stored alphas gives it
        double transmittance = 1.0;
        for (std::uint32_t n = map.first[texel]; n < map.first[texel + 1]; ++n) {
            const int s = int(n - map.first[texel]);
            const double visibility = std::clamp(1.0 - double(map.nodes[n].opacity), 0.0, 1.0);
            const float alpha = transmittance > 0.0 ? float(std::clamp(1.0 - visibility / transmittance, 0.0, 1.0)) : 1.f;
            transmittance *= 1.0 - double(alpha);
            deep.set_deep_value(int64_t(texel), 0, s, alpha);
            deep.set_deep_value(int64_t(texel), 1, s, map.nodes[n].depth);
            deep.set_deep_value(int64_t(texel), 2, s, map.nodes[n].depth);  // ZBack = Z: point samples
        }
    }

    // Write under a temporary name next to the target (ending in .exr so OpenImageIO picks the EXR
    // writer), then rename: a failed write leaves no file behind.
    const std::string temporary = path + ".part.exr";
    TemporaryFile guard(temporary);
    {
        auto out = OIIO::ImageOutput::create("openexr");
        if (!out) throw Error(path + ": OpenImageIO has no OpenEXR writer (" + OIIO::geterror() + ")");
        if (!out->supports("deepdata")) throw Error(path + ": OpenImageIO's OpenEXR writer does not support deep data");
        const bool ok = out->open(temporary, spec) && out->write_deep_image(deep) && out->close();
        if (!ok) throw Error(path + ": cannot write deep EXR (" + out->geterror() + ")");
    }
    std::error_code ec;
    std::filesystem::rename(temporary, path, ec);
    if (ec) throw Error(path + ": cannot write deep EXR (" + ec.message() + ")");
    guard.release();
}

DeepShadowMap read_deep_exr(const std::string& path) {
    // a regular file (never a FIFO or device, which would block), noted as an input
    {
        detail::ByteCursor c(path, detail::regular_file_size(path));
        check_exr_chunks(c, check_exr_header(c));
    }
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::string why = OIIO::geterror();
        throw Error(path + ": cannot read deep EXR (" + (why.empty() ? std::string("cannot open") : why) + ")");
    }
    const OIIO::ImageSpec spec = in->spec();
    if (std::string(in->format_name()) != "openexr" || !spec.deep)
        throw Error(path + ": not a deep OpenEXR file (format " + std::string(in->format_name()) +
                    (spec.deep ? ", deep" : ", not deep") + ")");
    const int a_channel = channel_index(spec, "A"), z_channel = channel_index(spec, "Z");
    const int zback_channel = channel_index(spec, "ZBack");
    if (a_channel < 0 || z_channel < 0) throw file_error(path, "channels", "needs channels A and Z");
    if (spec.width < 1 || spec.height < 1)
        throw file_error(path, "size", "empty image (" + std::to_string(spec.width) + "x" + std::to_string(spec.height) + ")");

    OIIO::DeepData deep;
    if (!in->read_native_deep_image(0, 0, deep)) throw Error(path + ": cannot read deep EXR (" + in->geterror() + ")");

    DeepShadowMap map;
    map.width = spec.width;
    map.height = spec.height;
    map.light_name = spec.get_string_attribute(kLightAttribute);
    const std::string interpolation = spec.get_string_attribute(kInterpolationAttribute, "opacity");
    if (interpolation != "opacity" && interpolation != "optical depth")
        throw file_error(path, kInterpolationAttribute, "'" + interpolation + "' (opacity or optical depth)");
    if (interpolation == "optical depth") map.interpolation = DeepShadowMap::Interpolation::OpticalDepth;
    std::array<float, 16>* matrices[2] = {&map.world_to_camera, &map.world_to_ndc};
    for (int m = 0; m < 2; ++m)
        if (const OIIO::ParamValue* p = spec.find_attribute(kMatrixAttributes[m], OIIO::TypeMatrix)) {
            std::array<float, 16> imath{};
            std::copy_n(static_cast<const float*>(p->data()), 16, imath.begin());
            *matrices[m] = transposed(imath);
        }
    // sombra's files before format 2 hold the accumulated opacity in A
    const bool accumulated = spec.find_attribute(kLightAttribute) && spec.get_int_attribute(kFormatAttribute, 1) < 2;
    const std::size_t texels = std::size_t(map.width) * std::size_t(map.height);
    if (std::size_t(deep.pixels()) != texels)
        throw file_error(path, "deep data", "has " + std::to_string(deep.pixels()) + " pixels, expected " + std::to_string(texels));
    map.first.assign(texels + 1, 0);
    for (std::size_t texel = 0; texel < texels; ++texel) {
        const int64_t pixel = int64_t(texel);
        const int samples = deep.samples(pixel);
        if (accumulated) {
            for (int s = 0; s < samples; ++s)
                map.nodes.push_back({deep.deep_value(pixel, z_channel, s), deep.deep_value(pixel, a_channel, s)});
        } else {
            deep.sort(pixel);  // OpenEXR does not require depth order
            double transmittance = 1.0, previous_back = -INFINITY;
            for (int s = 0; s < samples; ++s) {
                const float front = deep.deep_value(pixel, z_channel, s), alpha = deep.deep_value(pixel, a_channel, s);
                const float back = zback_channel < 0 ? front : deep.deep_value(pixel, zback_channel, s);
                const std::string field = texel_name(map, texel) + " sample " + std::to_string(s);
                if (!(alpha >= 0.f && alpha <= 1.f))
                    throw file_error(path, field + " A", "must lie in [0, 1], got " + std::to_string(alpha));
                if (!(back >= front)) throw file_error(path, field + " ZBack", "must be >= Z, got " + std::to_string(back));
                if (front < previous_back)
                    throw file_error(path, field + " Z", "overlaps the sample before it (ends at " + std::to_string(previous_back) +
                                                              "): sombra reads point samples or disjoint volumetric ones");
                // a volumetric sample: opacity goes linearly (as between DSM nodes) from its front to its back
                if (back > front) map.nodes.push_back({front, float(1.0 - transmittance)});
                transmittance *= 1.0 - double(alpha);
                map.nodes.push_back({back, float(1.0 - transmittance)});
                previous_back = back;
            }
        }
        map.first[texel + 1] = std::uint32_t(map.nodes.size());
    }
    validate(map, path);  // a file from elsewhere must still be a valid map (finite, depth-sorted)
    return map;
}

}  // namespace sombra
