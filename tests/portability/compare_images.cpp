// Compares two folders of rendered images file by file (issue 33, the GPU check): for every .exr in
// the first folder, max and mean |Δ| over RGBA against the file of the same name in the second.
//
//   sombra_compare_images DEVICE_DIR REFERENCE_DIR [--max-abs X]
//
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

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3 && !(argc == 5 && std::string(argv[3]) == "--max-abs")) {
        std::fprintf(stderr, "usage: sombra_compare_images DEVICE_DIR REFERENCE_DIR [--max-abs X]\n");
        return 2;
    }
    const fs::path device_dir = argv[1], reference_dir = argv[2];
    const double max_abs = argc == 5 ? std::stod(argv[4]) : INFINITY;
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
