// sombra_bench_cache_auto — does `--shadow-cache auto` ever make a frame slower (issue 29 item 5)?
// For every scene × technique × image size: one frame on a fresh Context (nothing kept: the
// preparation, the technique's build, the cache fill if any, the camera pass) with the cache off,
// on and auto; auto's frame against the faster of on and off, twice: auto's first run of the frame
// (no history: it probes) and auto after `--learn` earlier runs of the frame recorded their times
// (src/render/shadow_cache_history.h; what a user's later runs of the same frame get). Programs
// come from the on-disk program cache (a 16² frame of every variant first), so compiling is not
// what is timed. The history lives in a folder of the bench's own, emptied per cell.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>

#include "bench_util.h"
#include "sombra/render.h"
#include "sombra/scene.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;

struct Frame {
    double ms = 0;
    bool cache_used = false;
};

// The history folder (SOMBRA_AUTO_HISTORY, set by main) emptied: auto's next frame is its first.
void forget_history() {
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator(std::getenv("SOMBRA_AUTO_HISTORY"), error))
        std::filesystem::remove(entry.path(), error);
}

// `repeats` frames, each on a fresh Context with auto's remembered choices forgotten (a first
// frame of the process) and, unless `keep_history`, with no history (a first run of the frame:
// auto probes); the median wall time of render().
Frame first_frame(const std::string& device, const sombra::Scene& scene, const sombra::RenderOptions& options, int repeats,
                  bool keep_history = false) {
    std::vector<double> ms;
    Frame frame;
    for (int r = 0; r < repeats; ++r) {
        if (!keep_history) forget_history();
        sombra::forget_shadow_cache_choices();
        sombra::Context context(device);
        auto start = std::chrono::steady_clock::now();
        sombra::RenderResult result = sombra::render(context, scene, options);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
        frame.cache_used = result.stats.shadow_cache_used;
    }
    frame.ms = median(ms);
    return frame;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app("sombra_bench_cache_auto: the shadow cache's auto against the faster of on and off, one frame per fresh Context");
    std::vector<std::string> scenes;
    for (const auto& entry : std::filesystem::directory_iterator(SOMBRA_DATA_DIR "/scenes"))
        if (entry.path().extension() == ".json") scenes.push_back(entry.path().string());
    std::sort(scenes.begin(), scenes.end());
    std::vector<std::string> techniques = {"dsm", "shadowmap", "rays", "lowpass", "ao", "cone"};
    std::vector<int> sizes = {128, 256, 512};
    int repeats = 3, learn = 3;
    double slow_ms = 4000;
    std::string device = "auto", out;
    app.add_option("--scene", scenes, "scene files (default: every data/scenes/*.json)");
    app.add_option("--shadows", techniques, "techniques")->capture_default_str();
    app.add_option("--size", sizes, "image widths and heights")->capture_default_str();
    app.add_option("--repeats", repeats, "frames per cell and mode (medians), 1 where the off frame takes over --slow-ms")->capture_default_str();
    app.add_option("--learn", learn, "auto's runs of a frame before its learned frames are timed")->capture_default_str();
    app.add_option("--slow-ms", slow_ms, "a cell whose off frame takes longer is timed once per mode")->capture_default_str();
    app.add_option("--device", device, "OpenCL device")->capture_default_str();
    app.add_option("--out", out, "also write the Markdown table here");
    CLI11_PARSE(app, argc, argv);
    const std::string history = (std::filesystem::temp_directory_path() / "sombra-bench-cache-auto-history").string();
    std::filesystem::create_directories(history);
    setenv("SOMBRA_AUTO_HISTORY", history.c_str(), 1);

    std::ostringstream table;
    table << "| scene | technique | size | off ms | on ms | auto first ms | chose | ÷ faster | auto learned ms | chose | ÷ faster |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|\n";
    double worst = 0, worst_learned = 0;
    int cells = 0, within = 0, within_learned = 0;
    for (const std::string& path : scenes) {
        const sombra::Scene scene = sombra::load_scene(path);
        const std::string scene_name = std::filesystem::path(path).stem().string();
        for (const std::string& technique : techniques) {
            auto options_for = [&](const char* cache, int size) {
                sombra::RenderOptions o;
                sombra::set_render_option(o, "shadows", technique);
                sombra::set_render_option(o, "shadow_cache", cache);
                o.width = size, o.height = std::max(1, int(std::lround(double(size) * scene.height / scene.width)));
                return o;
            };
            try {
                for (const char* mode : {"off", "on", "auto"}) first_frame(device, scene, options_for(mode, 16), 1);  // programs into the cache
            } catch (const sombra::Error& refused) {  // a technique that does not take the scene (polyhedral bounds and low-pass)
                std::ostringstream row;
                row << "| " << scene_name << " | " << technique << " | all | not supported: " << refused.what() << " | | | | |\n";
                std::cout << row.str() << std::flush;
                table << row.str();
                continue;
            }
            for (int size : sizes) {
                Frame off = first_frame(device, scene, options_for("off", size), 1);
                const int n = off.ms > slow_ms ? 1 : repeats;
                if (n > 1) off = first_frame(device, scene, options_for("off", size), n);
                const Frame on = first_frame(device, scene, options_for("on", size), n);
                const Frame automatic = first_frame(device, scene, options_for("auto", size), n);
                forget_history();
                for (int k = 0; k < learn; ++k) first_frame(device, scene, options_for("auto", size), 1, true);
                const Frame learned = first_frame(device, scene, options_for("auto", size), n, true);
                const double ratio = automatic.ms / std::min(on.ms, off.ms), ratio_learned = learned.ms / std::min(on.ms, off.ms);
                worst = std::max(worst, ratio), ++cells, within += ratio <= 1.10;
                worst_learned = std::max(worst_learned, ratio_learned), within_learned += ratio_learned <= 1.10;
                std::ostringstream row;
                row << "| " << scene_name << " | " << technique << " | " << size << " | " << fixed(off.ms, 0) << " | " << fixed(on.ms, 0)
                    << " | " << fixed(automatic.ms, 0) << " | " << (automatic.cache_used ? "on" : "off") << " | " << fixed(ratio, 2)
                    << " | " << fixed(learned.ms, 0) << " | " << (learned.cache_used ? "on" : "off") << " | " << fixed(ratio_learned, 2)
                    << " |\n";
                std::cout << row.str() << std::flush;
                table << row.str();
            }
        }
    }
    std::ostringstream summary;
    summary << "\nauto's first run: " << within << " of " << cells << " cells within 1.10× of the faster mode; worst " << fixed(worst, 2)
            << "×\nauto after " << learn << " runs: " << within_learned << " of " << cells << " cells within 1.10×; worst "
            << fixed(worst_learned, 2) << "×\n";
    table << summary.str();
    std::cout << summary.str();
    if (!out.empty()) std::ofstream(out) << table.str();
    return 0;
}
