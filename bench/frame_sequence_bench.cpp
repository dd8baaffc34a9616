// sombra_bench_frame_sequence — does a frame run slower after other frames of the same process?
// A library user (Python, the viewer, the benches) renders many frames in one process, each on a
// Context of its own or not; the CLI renders one. Kernels share their worker threads' stacks and
// the process's heap, so that a kernel reading what it never wrote (a vector's padding lane) can
// run at a speed set by the frames before it: the cone technique's pass ran 1.4× slower after any
// frame that had built deep shadow maps or filled the shadow cache (bench/README.md
// "sombra_bench_frame_sequence").
//
// For every scene × technique: the camera pass of `--repeats` frames (fresh Context each, shadow
// cache off) before and after a run of other frames (every technique with the cache on and off at
// 16², which build, fill and read everything once), their medians side by side, and whether the
// frames' images are the same bit for bit. Frames are timed by their camera pass's kernel time
// (profiling events), which a process's state may change and nothing else in the frame does.
#include <iostream>

#include <CLI/CLI.hpp>

#include "bench_util.h"
#include "sombra/render.h"
#include "sombra/scene.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;

struct Frame {
    double camera_ms = 0;
    std::vector<float> image;  // rgba
};

Frame one_frame(const std::string& device, const sombra::Scene& scene, const std::string& technique, const std::string& cache, int size) {
    sombra::forget_shadow_cache_choices();
    sombra::Context context(device);
    sombra::RenderOptions options;
    sombra::set_render_option(options, "shadows", technique);
    sombra::set_render_option(options, "shadow_cache", cache);
    options.width = size, options.height = std::max(1, int(std::lround(double(size) * scene.height / scene.width)));
    const sombra::RenderResult result = sombra::render(context, scene, options);
    return {result.stats.stage_ms.at("camera_pass"), result.image.rgba};
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sombra_bench_frame_sequence: a frame's camera pass before and after other frames of the same process"};
    std::vector<std::string> scenes, techniques = {"dsm", "shadowmap", "rays", "lowpass", "ao", "cone"};
    int size = 128, repeats = 3;
    std::string device = "auto";
    app.add_option("--scene", scenes, "scene files")->required();
    app.add_option("--shadows", techniques, "techniques")->capture_default_str();
    app.add_option("--size", size, "image width (the height follows the scene's aspect)")->capture_default_str();
    app.add_option("--repeats", repeats, "frames timed before and after")->capture_default_str()->check(CLI::Range(1, 100));
    app.add_option("--device", device, "OpenCL device")->capture_default_str();
    CLI11_PARSE(app, argc, argv);
    std::cout << "| scene | technique | size | camera pass before ms | after ms | after ÷ before | same image |\n|---|---|---|---|---|---|---|\n";
    double worst = 0;
    for (const std::string& path : scenes) {
        const sombra::Scene scene = sombra::load_scene(path);
        const std::string name = std::filesystem::path(path).stem().string();
        for (const std::string& technique : techniques) {
            std::vector<float> first_image;
            bool same = true;  // every frame's image equals the first's, bit for bit (no NaN in an image)
            auto timed = [&](std::vector<double>& ms) {
                for (int r = 0; r < repeats; ++r) {
                    Frame frame = one_frame(device, scene, technique, "off", size);
                    ms.push_back(frame.camera_ms);
                    if (first_image.empty()) first_image = std::move(frame.image);
                    else same = same && frame.image == first_image;
                }
            };
            std::vector<double> before, after;
            try {
                timed(before);
            } catch (const sombra::Error& refused) {  // polyhedral bounds and the SAT techniques
                std::cout << "| " << name << " | " << technique << " | " << size << " | not supported: " << refused.what() << " | | | |\n";
                continue;
            }
            for (const std::string& other : techniques)
                for (const char* cache : {"on", "off"}) try {
                        one_frame(device, scene, other, cache, 16);
                    } catch (const sombra::Error&) {  // a technique that does not take the scene
                    }
            timed(after);
            const double ratio = median(after) / median(before);
            worst = std::max(worst, ratio);
            std::cout << "| " << name << " | " << technique << " | " << size << " | " << fixed(median(before), 1) << " | "
                      << fixed(median(after), 1) << " | " << fixed(ratio, 2) << " | " << (same ? "yes" : "no") << " |\n"
                      << std::flush;
        }
    }
    std::cout << "worst after ÷ before: " << fixed(worst, 2) << "\n";
    return 0;
}
