// sombra_bench_dsm_error — deep shadow maps with an absolute error bound (nodes hold opacity,
// |α' − α| ≤ ε) against a relative one (nodes hold optical depth, |τ' − τ| ≤ ε;
// cl/shared/dsm_value.h), over ε, on dim and bright scenes (issue 27 item 1). Per case and setting:
// the point error against sombra::reference_transmittance at random points in the volumes — the
// mean and 95th-percentile relative error where the reference T ∈ [10⁻⁴, 0.05] (dim; below 10⁻⁴
// the maps' rays have stopped), the mean absolute
// and mean signed error everywhere —, the nodes, the median DSM build time (OpenCL profiling
// events of the dsm_* stages) and the median camera pass of a render (the lookups; shadow cache
// off). A Markdown table on stdout and in --out. See bench/README.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <thread>

#include "bench_util.h"
#include "host/guarded_main.h"
#include "sombra/sombra.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;
using sombra::bench::sci;
using sombra::bench::shortest;

struct Case {
    std::string scene;
    int light = 0;
};

struct PointErrors {
    double dim_mean = 0, dim_p95 = 0, abs_mean = 0, signed_mean = 0;
    std::size_t dim_points = 0;
};

PointErrors point_errors(const std::vector<double>& reference, const std::vector<double>& value) {
    PointErrors e;
    std::vector<double> relative;
    for (std::size_t i = 0; i < reference.size(); ++i) {
        const double d = value[i] - reference[i];
        e.abs_mean += std::fabs(d) / double(reference.size());
        e.signed_mean += d / double(reference.size());
        if (reference[i] < 0.05 && reference[i] >= 1e-4) relative.push_back(std::fabs(d) / reference[i]);
    }
    e.dim_points = relative.size();
    if (!relative.empty()) {
        for (double r : relative) e.dim_mean += r / double(relative.size());
        std::sort(relative.begin(), relative.end());
        e.dim_p95 = relative[std::min(relative.size() - 1, std::size_t(0.95 * double(relative.size())))];
    }
    return e;
}

double dsm_build_ms(const sombra::RenderStats& stats) {
    double ms = 0;
    for (const auto& [stage, value] : stats.stage_ms)
        if (stage.rfind("dsm_", 0) == 0 && stage != "dsm_clustering") ms += value;
    return ms;
}

Case parse_case(const std::string& text) {
    const std::size_t colon = text.rfind(':');
    if (colon == std::string::npos) return {text, 0};
    return {text.substr(0, colon), std::stoi(text.substr(colon + 1))};
}

int run(int argc, char** argv) {
    std::vector<std::string> case_texts;
    std::vector<float> epsilons{0.04f, 0.02f, 0.01f, 0.005f, 0.002f};
    std::string out_path, device = "auto";
    int points_per_case = 2000, runs = 3, size = 128, resolution = 512;
    unsigned seed = 11;
    CLI::App app{"sombra: DSM error bound absolute vs relative (opacity vs optical depth) over ε"};
    app.add_option("--case", case_texts, "SCENE.json:LIGHT (repeatable; default: the dim and bright set of bench/README.md)");
    app.add_option("--eps", epsilons, "the ε values")->check(CLI::Range(0.f, 1.f));
    app.add_option("--points", points_per_case, "random points in the volumes, per case")->check(CLI::PositiveNumber);
    app.add_option("--runs", runs, "timed builds and renders per setting, after one warm-up (medians)")->check(CLI::PositiveNumber);
    app.add_option("--size", size, "side of the rendered image for the lookup time")->check(CLI::Range(1, 4096));
    app.add_option("--dsm-res", resolution, "deep shadow map texels per side")->check(CLI::Range(1, 8192));
    app.add_option("--seed", seed, "seed of the random points");
    app.add_option("--device", device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--out", out_path, "also write the table to this Markdown file");
    CLI11_PARSE(app, argc, argv);
    std::vector<Case> cases;
    for (const std::string& text : case_texts) cases.push_back(parse_case(text));
    if (cases.empty())
        cases = {{SOMBRA_BENCH_SCENES "/point_light_in_fog.json", 0}, {SOMBRA_DATA_SCENES "/head_in_fog.json", 2},
                 {SOMBRA_DATA_SCENES "/bounded_smoke.json", 0},     {SOMBRA_DATA_SCENES "/default.json", 1},
                 {SOMBRA_DATA_SCENES "/smoke.json", 0},             {SOMBRA_DATA_SCENES "/default.json", 0}};

    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
    sombra::Context context(device);
    std::ostringstream table;
    table << "<!-- " << command << "; " << context.device().name << ", " << std::thread::hardware_concurrency() << " cores; "
          << points_per_case << " points per case, seed " << seed << "; DSM " << resolution << "², image " << size << "², "
          << runs << " runs after a warm-up -->\n\n"
          << "| case | bound | ε | dim points | dim mean rel. err | dim p95 rel. err | mean abs. err | mean signed err | nodes | "
             "nodes / texel | build ms | camera pass ms |\n"
          << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    std::cout << table.str() << std::flush;
    for (const Case& c : cases) {
        const sombra::Scene scene = sombra::load_scene(c.scene);
        if (c.light < 0 || std::size_t(c.light) >= scene.lights.size())
            throw sombra::Error(c.scene + ": light " + std::to_string(c.light) + " does not exist");
        const std::vector<sombra::Vec3> points = sombra::bench::random_points(scene, points_per_case, seed);
        const std::vector<double> reference = sombra::bench::reference_values(scene, c.light, points);
        const std::string name = std::filesystem::path(c.scene).stem().string() + " light " + std::to_string(c.light);
        for (const char* bound : {"absolute", "relative"})
            for (float eps : epsilons) {
                sombra::RenderOptions options;
                options.shadows = sombra::ShadowTechnique::Dsm;
                options.dsm.resolution = resolution;
                options.dsm.epsilon = eps;
                options.dsm.error = bound;
                options.width = options.height = size;
                options.shadow_cache = sombra::ShadowCacheMode::Off;
                sombra::shadow_transmittance(context, scene, c.light, points, options);  // warm-up: kernel builds
                std::vector<double> build_ms;
                sombra::ShadowQuery query;
                for (int r = 0; r < runs; ++r) {
                    sombra::bench::forget_preparation(context, scene);
                    query = sombra::shadow_transmittance(context, scene, c.light, points, options);
                    build_ms.push_back(dsm_build_ms(query.stats));
                }
                std::vector<double> camera_ms;
                for (const auto& r : sombra::bench::fresh_renders(context, scene, options, runs))
                    camera_ms.push_back(r.stats.stage_ms.count("camera_pass") ? r.stats.stage_ms.at("camera_pass") : 0.0);
                const PointErrors e = point_errors(reference, query.transmittance);
                std::ostringstream row;
                row << "| " << name << " | " << bound << " | " << shortest(eps) << " | " << e.dim_points << " | "
                    << sci(e.dim_mean) << " | " << sci(e.dim_p95) << " | " << sci(e.abs_mean) << " | " << sci(e.signed_mean)
                    << " | " << query.stats.dsm_nodes << " | " << fixed(query.stats.dsm_mean_nodes_per_texel, 2) << " | "
                    << fixed(median(build_ms), 1) << " | " << fixed(median(camera_ms), 1) << " |\n";
                std::cout << row.str() << std::flush;
                table << row.str();
            }
    }
    if (!out_path.empty()) sombra::bench::write_file(out_path, table.str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_dsm_error", run, argc, argv); }
