// sombra bench — the cost of running long kernels in bands of rows (host/tiled_launch.h), so that
// progress is real: each long stage in one launch (Runtime::set_launch_tiles(1)) against the bands
// sized by time (0, the default), in one run, alternating, after a warm-up of each. Times are the
// stages' wall clocks from the progress reports (host work and waits between bands included).
#include <CLI/CLI.hpp>

#include <iostream>
#include <map>

#include "bench_util.h"
#include "host/runtime.h"

namespace {

struct Case {
    std::string name;
    std::vector<std::string> stages;  // timed
    sombra::RenderOptions options;
};

struct StageRun {
    double ms = 0;
    int launches = 0;  // reports between the stage's first and last: one per band
};

std::map<std::string, StageRun> run_once(sombra::Context& context, const sombra::Scene& scene, const Case& c, int tiles) {
    context.runtime().set_launch_tiles(tiles);
    context.release_prepared_scenes();  // every stage runs again
    std::map<std::string, StageRun> run;
    sombra::RenderOptions options = c.options;
    options.progress = [&](const sombra::ProgressReport& r) {
        if (r.done) run[r.stage].ms += r.elapsed_ms;
        else if (r.fraction > 0) ++run[r.stage].launches;
    };
    sombra::render(context, scene, options);
    return run;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sombra bench: long kernels in one launch vs in bands of rows"};
    std::string scene_path = SOMBRA_DEFAULT_SCENE, device = "auto", out;
    int runs = 5, size = 192;
    app.add_option("--scene", scene_path, "scene file");
    app.add_option("--runs", runs, "timed runs per mode (after one warm-up each)");
    app.add_option("--size", size, "image side of the camera-pass case");
    std::string kernel = "box";  // box: the cheaper lookups make the cache's bands count more
    app.add_option("--filter-kernel", kernel, "low-pass case: box or gauss")->check(CLI::IsMember({"box", "gauss"}));
    app.add_option("--device", device, "auto, cpu, gpu or an index");
    app.add_option("--out", out, "folder for tiled_launch.md");
    CLI11_PARSE(app, argc, argv);

    sombra::Context context(device);
    sombra::Scene scene = sombra::load_scene(scene_path);
    sombra::RenderOptions small;  // the shadow stages' cases: a small image, so the camera pass is short
    small.width = small.height = 32;
    std::vector<Case> cases;
    {
        sombra::RenderOptions o;
        o.width = o.height = size;
        o.shadows = sombra::ShadowTechnique::Rays;
        cases.push_back({"shadow rays, " + std::to_string(size) + "²", {"camera pass"}, o});
        o = small;
        o.shadows = sombra::ShadowTechnique::Dsm;
        o.dsm.resolution = 512;
        cases.push_back({"DSM 512², atlas", {"deep shadow maps"}, o});
        o.shadows = sombra::ShadowTechnique::Lowpass;
        o.sat.filter_width = 7;
        o.sat.filter_kernel = kernel;
        o.sat.max_entries = std::size_t(1) << 20;
        cases.push_back({"lowpass W 7 " + kernel + ", 2^20 entries", {"summed-area tables", "shadow cache"}, o});
    }

    std::ostringstream table;
    table << "| case | stage | one launch (ms) | bands (ms) | bands | cost |\n|---|---|---|---|---|---|\n";
    for (const Case& c : cases) {
        run_once(context, scene, c, 1), run_once(context, scene, c, 0);  // warm-up: programs built, memory touched
        std::map<std::string, std::vector<double>> one, banded;
        std::map<std::string, int> launches;
        for (int r = 0; r < runs; ++r) {
            for (auto& [stage, s] : run_once(context, scene, c, 1)) one[stage].push_back(s.ms);
            for (auto& [stage, s] : run_once(context, scene, c, 0)) banded[stage].push_back(s.ms), launches[stage] = s.launches;
        }
        for (const std::string& stage : c.stages) {
            double a = sombra::bench::median(one[stage]), b = sombra::bench::median(banded[stage]);
            table << "| " << c.name << " | " << stage << " | " << sombra::bench::fixed(a, 0) << " | " << sombra::bench::fixed(b, 0)
                  << " | " << launches[stage] << " | " << sombra::bench::fixed(100 * (b - a) / a, 1) << " % |\n";
            std::cout << c.name << ", " << stage << ": one launch " << sombra::bench::fixed(a, 0) << " ms, " << launches[stage]
                      << " bands " << sombra::bench::fixed(b, 0) << " ms (medians of " << runs << ")" << std::endl;
        }
    }
    std::cout << "\n" << table.str();
    if (!out.empty()) sombra::bench::write_file(std::filesystem::path(out) / "tiled_launch.md", table.str());
    return 0;
}
