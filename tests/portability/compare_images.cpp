// Compares two folders of rendered images file by file (issue 33, the GPU check): for every .exr in
// the first folder, max and mean |Δ| over RGBA against the file of the same name in the second.
//
//   sombra_compare_images DEVICE_DIR REFERENCE_DIR [--max-abs X] [--side-by-side DIR]
//
// --side-by-side DIR: for each pair a PNG of the device's image, the reference's and 10 × |Δ|, to look at.
// scripts/gpu-check.sh renders on a machine without PoCL or the Python module (a lent GPU machine
// has neither) and compares here, where PoCL renders the same files; compare_devices.py does the
// same in one process where both devices are on one machine. A file missing from either folder is
// a failure (a render refused on one device only); non-finite values are a failure. Exit 1 on a
// failure or when the largest max |Δ| exceeds --max-abs (no bound: only reported).
#include <sombra/render.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>

namespace fs = std::filesystem;

namespace {

std::set<std::string> exr_names(const fs::path& dir) {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir))
        if (entry.path().extension() == ".exr") names.insert(entry.path().filename().string());
    return names;
}

// device | reference | 10 × |Δ| in one row (RGB; alpha 1)
void write_side_by_side(const sombra::Image& a, const sombra::Image& b, const std::string& path) {
    sombra::Image row;
    row.width = 3 * a.width;
    row.height = a.height;
    row.rgba.assign(std::size_t(row.width) * row.height * 4, 1.f);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const std::size_t at = (std::size_t(y) * a.width + x) * 4 + c;
                const std::size_t out = (std::size_t(y) * row.width + x) * 4 + c;
                row.rgba[out] = a.rgba[at];
                row.rgba[out + 4 * std::size_t(a.width)] = b.rgba[at];
                row.rgba[out + 8 * std::size_t(a.width)] = std::min(1.f, 10.f * std::fabs(a.rgba[at] - b.rgba[at]));
            }
    sombra::write_image(row, path);
}

}  // namespace

int main(int argc, char** argv) {
    double max_abs = INFINITY;
    std::string side_by_side;
    bool usage = argc < 3;
    for (int i = 3; i < argc && !usage; i += 2) {
        const std::string flag = argv[i];
        if (i + 1 >= argc) usage = true;
        else if (flag == "--max-abs") max_abs = std::stod(argv[i + 1]);
        else if (flag == "--side-by-side") side_by_side = argv[i + 1];
        else usage = true;
    }
    if (usage) {
        std::fprintf(stderr, "usage: sombra_compare_images DEVICE_DIR REFERENCE_DIR [--max-abs X] [--side-by-side DIR]\n");
        return 2;
    }
    const fs::path device_dir = argv[1], reference_dir = argv[2];
    if (!side_by_side.empty()) fs::create_directories(side_by_side);
    int failures = 0, compared = 0;
    double worst = 0, mean_sum = 0;
    try {
        const auto device_names = exr_names(device_dir), reference_names = exr_names(reference_dir);
        for (const auto& name : reference_names)
            if (!device_names.count(name)) {
                std::printf("%-32s only in %s\n", name.c_str(), reference_dir.c_str());
                ++failures;
            }
        std::printf("%-32s %9s %10s\n", "image", "max |Δ|", "mean |Δ|");
        for (const auto& name : device_names) {
            if (!reference_names.count(name)) {
                std::printf("%-32s only in %s\n", name.c_str(), device_dir.c_str());
                ++failures;
                continue;
            }
            const sombra::Image a = sombra::read_image((device_dir / name).string());
            const sombra::Image b = sombra::read_image((reference_dir / name).string());
            if (a.width != b.width || a.height != b.height) {
                std::printf("%-32s sizes differ: %dx%d against %dx%d\n", name.c_str(), a.width, a.height, b.width, b.height);
                ++failures;
                continue;
            }
            double max_d = 0, sum = 0;
            bool finite = true;
            for (size_t i = 0; i < a.rgba.size(); ++i) {
                finite = finite && std::isfinite(a.rgba[i]) && std::isfinite(b.rgba[i]);
                const double d = std::fabs(double(a.rgba[i]) - double(b.rgba[i]));
                max_d = std::max(max_d, d);
                sum += d;
            }
            const double mean = a.rgba.empty() ? 0 : sum / double(a.rgba.size());
            if (!finite) ++failures;
            worst = std::max(worst, max_d);
            mean_sum += mean;
            ++compared;
            std::printf("%-32s %9.2e %10.2e%s\n", name.c_str(), max_d, mean, !finite ? "   non-finite values" : max_d > 0.02 ? "   <- differs" : "");
            if (!side_by_side.empty()) write_side_by_side(a, b, (fs::path(side_by_side) / name).replace_extension(".png").string());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sombra_compare_images: %s\n", e.what());
        return 1;
    }
    std::printf("%d images compared: largest max |Δ| %.3g, mean |Δ| %.3g; %d failures\n", compared, worst,
                compared ? mean_sum / compared : 0.0, failures);
    if (worst > max_abs) {
        std::printf("FAIL largest max |Δ| %.3g > %g\n", worst, max_abs);
        ++failures;
    }
    return failures ? 1 : 0;
}
