// sombra_bench_cache_auto — does `--shadow-cache auto` ever make a frame slower (issue 29 item 5)?
// For every scene × technique × image size: one frame on a fresh Context (nothing kept: the
// preparation, the technique's build, the cache fill if any, the camera pass) with the cache off,
// on and auto; auto's frame against the faster of on and off, twice: auto's first run of the frame
// (no history: it probes) and auto after `--learn` earlier runs of the frame recorded their times
// (src/render/shadow_cache_history.h; what a user's later runs of the same frame get). Programs
// come from the on-disk program cache (a 16² frame of every variant first), so compiling is not
// what is timed. A cell's frames run in rounds (off, on, auto first, auto learned), as many as
// make about --cell-ms of off frames, and each column is the median of its round's frames.
// --noise adds a second off and a second on frame to each round: off again ÷ off is what the bench
// alone makes of two runs of one mode, and the faster mode's second frames ÷ the faster column are
// what a chooser with no probe that always took the faster mode would show against the same
// columns (the yardstick for auto's 1.10×: the faster of two noisy columns is the lower of two
// draws, so that even that chooser comes out above 1 where on and off are close).
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>

#include "bench_util.h"
#include "sombra/render.h"
#include "sombra/scene.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;

// Auto's history lives in two folders of the bench's own: one emptied before each of auto's first
// runs, one that keeps what the learning runs and the learned frames recorded.
struct HistoryFolders {
    std::string first, learned;
};

void use_history(const std::string& folder) { setenv("SOMBRA_AUTO_HISTORY", folder.c_str(), 1); }

void empty_folder(const std::string& folder) {
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator(folder, error)) std::filesystem::remove(entry.path(), error);
}

// A frame's wall time and whether it filled the volume lattices.
struct Frame {
    double ms = 0;
    bool cache_used = false;
};

// --estimates: each frame's line on stderr, auto's estimates next to the kernel times the frame took
bool print_estimates = false;

double stage_ms(const sombra::RenderStats& stats, const char* stage) {
    const auto found = stats.stage_ms.find(stage);
    return found == stats.stage_ms.end() ? 0 : found->second;
}

// One frame on a fresh Context with auto's remembered choices forgotten (a first frame of the
// process): the wall time of render().
Frame one_frame(const std::string& device, const sombra::Scene& scene, const sombra::RenderOptions& options) {
    sombra::forget_shadow_cache_choices();
    sombra::Context context(device);
    const auto start = std::chrono::steady_clock::now();
    const sombra::RenderResult result = sombra::render(context, scene, options);
    // the volume lattices' part (what auto chooses; the meshes' surface part follows its own counts)
    const bool volumes_cached = result.stats.shadow_cache_used && result.stats.shadow_cache_entries_built + result.stats.shadow_cache_entries_reused > 0;
    if (print_estimates) {
        const sombra::RenderStats& s = result.stats;
        std::cerr << "  " << sombra::render_option_value(options, "shadow_cache") << (volumes_cached ? " (cache)" : " (no cache)")
                  << ": kernels fill " << fixed(stage_ms(s, "shadow_cache"), 1) << " camera pass " << fixed(stage_ms(s, "camera_pass"), 1);
        if (s.shadow_cache_probe_ms > 0)
            std::cerr << "; estimated fill " << fixed(s.shadow_cache_estimated_fill_ms, 1) << " cached pass "
                      << fixed(s.shadow_cache_estimated_cached_ms, 1) << " per-sample pass " << fixed(s.shadow_cache_estimated_per_sample_ms, 1)
                      << " probe " << fixed(s.shadow_cache_probe_ms, 1);
        std::cerr << "\n";
    }
    return {std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(), volumes_cached};
}

// A cell's four columns, `rounds` frames each, interleaved round by round (off, on, auto's first
// run, auto learned, and with --noise off and on again), so that a change of load on the machine
// falls on every column alike; medians, and the mode the median-th frame of each auto column chose.
struct Cell {
    Frame off, on, first, learned, off_again, on_again;
};

// The median time of `frames`, with the mode of the frame at the median's place.
Frame median_frame(std::vector<Frame> frames) {
    std::vector<double> ms;
    for (const Frame& f : frames) ms.push_back(f.ms);
    std::nth_element(frames.begin(), frames.begin() + frames.size() / 2, frames.end(), [](const Frame& a, const Frame& b) { return a.ms < b.ms; });
    return {median(ms), frames[frames.size() / 2].cache_used};
}

Cell time_cell(const std::string& device, const sombra::Scene& scene, const std::function<sombra::RenderOptions(const char*)>& options,
               int rounds, int learn, const HistoryFolders& history, bool noise) {
    empty_folder(history.learned);
    use_history(history.learned);
    for (int k = 0; k < learn; ++k) one_frame(device, scene, options("auto"));
    std::vector<Frame> off, on, first, learned, off_again, on_again;
    for (int r = 0; r < rounds; ++r) {
        off.push_back(one_frame(device, scene, options("off")));
        on.push_back(one_frame(device, scene, options("on")));
        empty_folder(history.first);
        use_history(history.first);
        first.push_back(one_frame(device, scene, options("auto")));
        use_history(history.learned);
        learned.push_back(one_frame(device, scene, options("auto")));
        if (noise) off_again.push_back(one_frame(device, scene, options("off")));
        if (noise) on_again.push_back(one_frame(device, scene, options("on")));
    }
    return {median_frame(off), median_frame(on), median_frame(first), median_frame(learned), noise ? median_frame(off_again) : Frame(),
            noise ? median_frame(on_again) : Frame()};
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
    int repeats = 3, max_repeats = 15, learn = 6;
    double slow_ms = 4000, cell_ms = 2000;
    std::string device = "auto", out;
    bool noise = false;
    app.add_option("--scene", scenes, "scene files (default: every data/scenes/*.json)");
    app.add_option("--shadows", techniques, "techniques")->capture_default_str();
    app.add_option("--size", sizes, "image widths and heights")->capture_default_str();
    app.add_option("--repeats", repeats, "the fewest frames per cell and mode (medians), 1 where the off frame takes over --slow-ms")
        ->capture_default_str();
    app.add_option("--max-repeats", max_repeats, "the most frames per cell and mode")->capture_default_str();
    app.add_option("--cell-ms", cell_ms, "frames per cell and mode: enough for about this many ms of off frames")->capture_default_str();
    app.add_option("--learn", learn, "auto's runs of a frame before its learned frames are timed")->capture_default_str();
    app.add_option("--slow-ms", slow_ms, "a cell whose off frame takes longer is timed once per mode")->capture_default_str();
    app.add_option("--device", device, "OpenCL device")->capture_default_str();
    app.add_option("--out", out, "also write the Markdown table here");
    app.add_flag("--estimates", print_estimates, "each frame's kernel times and auto's estimates on stderr");
    app.add_flag("--noise", noise,
                 "a second off and on frame per round: off again ÷ off, the bench's own spread, and the faster mode again ÷ the faster");
    CLI11_PARSE(app, argc, argv);
    const std::filesystem::path history_root = std::filesystem::temp_directory_path() / "sombra-bench-cache-auto-history";
    const HistoryFolders history{(history_root / "first").string(), (history_root / "learned").string()};
    std::filesystem::create_directories(history.first);
    std::filesystem::create_directories(history.learned);

    std::ostringstream table;
    table << "| scene | technique | size | off ms | on ms | auto first ms | chose | ÷ faster | auto learned ms | chose | ÷ faster | frames |"
          << (noise ? " off again ÷ off | faster again ÷ faster |\n" : "\n") << "|---|---|---|---|---|---|---|---|---|---|---|---|"
          << (noise ? "---|---|\n" : "\n");
    double worst = 0, worst_learned = 0, worst_again = 0, worst_faster_again = 0;
    int cells = 0, within = 0, within_learned = 0, within_again = 0, within_faster_again = 0;
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
                use_history(history.first);
                for (const char* mode : {"off", "on", "auto"}) one_frame(device, scene, options_for(mode, 16));  // programs into the cache
            } catch (const sombra::Error& refused) {  // a technique that does not take the scene (polyhedral bounds and low-pass)
                std::ostringstream row;
                row << "| " << scene_name << " | " << technique << " | all | not supported: " << refused.what() << " | | | | |\n";
                std::cout << row.str() << std::flush;
                table << row.str();
                continue;
            }
            for (int size : sizes) {
                // rounds: enough for about --cell-ms of off frames (short frames vary by ± 10–25 ms
                // between runs on 2 busy cores), at least --repeats, at most --max-repeats; one
                // where the off frame takes over --slow-ms
                const double off_ms = one_frame(device, scene, options_for("off", size)).ms;
                const int rounds = off_ms > slow_ms ? 1 : std::clamp(int(std::ceil(cell_ms / off_ms)), repeats, std::max(repeats, max_repeats));
                const Cell cell = time_cell(device, scene, [&](const char* mode) { return options_for(mode, size); }, rounds, learn, history, noise);
                const Frame &off = cell.off, &on = cell.on, &automatic = cell.first, &learned = cell.learned;
                const double ratio = automatic.ms / std::min(on.ms, off.ms), ratio_learned = learned.ms / std::min(on.ms, off.ms);
                worst = std::max(worst, ratio), ++cells, within += ratio <= 1.10;
                worst_learned = std::max(worst_learned, ratio_learned), within_learned += ratio_learned <= 1.10;
                const double ratio_again = cell.off_again.ms / off.ms;
                worst_again = std::max(worst_again, ratio_again), within_again += ratio_again <= 1.10;
                // the chooser with no probe that always takes the faster mode, its second frames
                const double ratio_faster_again = (off.ms <= on.ms ? cell.off_again.ms : cell.on_again.ms) / std::min(on.ms, off.ms);
                worst_faster_again = std::max(worst_faster_again, ratio_faster_again), within_faster_again += ratio_faster_again <= 1.10;
                std::ostringstream row;
                row << "| " << scene_name << " | " << technique << " | " << size << " | " << fixed(off.ms, 0) << " | " << fixed(on.ms, 0)
                    << " | " << fixed(automatic.ms, 0) << " | " << (automatic.cache_used ? "on" : "off") << " | " << fixed(ratio, 2)
                    << " | " << fixed(learned.ms, 0) << " | " << (learned.cache_used ? "on" : "off") << " | " << fixed(ratio_learned, 2)
                    << " | " << rounds << " |";
                if (noise) row << " " << fixed(ratio_again, 2) << " | " << fixed(ratio_faster_again, 2) << " |";
                row << "\n";
                std::cout << row.str() << std::flush;
                table << row.str();
            }
        }
    }
    std::ostringstream summary;
    summary << "\nauto's first run: " << within << " of " << cells << " cells within 1.10× of the faster mode; worst " << fixed(worst, 2)
            << "×\nauto after " << learn << " runs: " << within_learned << " of " << cells << " cells within 1.10×; worst "
            << fixed(worst_learned, 2) << "×\n";
    if (noise) {
        summary << "off again against off: " << within_again << " of " << cells << " cells within 1.10×; worst " << fixed(worst_again, 2) << "×\n";
        summary << "the faster mode again against the faster (a chooser with no probe that is never wrong): " << within_faster_again << " of "
                << cells << " cells within 1.10×; worst " << fixed(worst_faster_again, 2) << "×\n";
    }
    table << summary.str();
    std::cout << summary.str();
    if (!out.empty()) std::ofstream(out) << table.str();
    return 0;
}
