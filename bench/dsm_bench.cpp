// sombra_bench_dsm — deep shadow maps against the shadow-ray baseline and no shadows, in one run:
// per DSM resolution × ε, the generation time (count, prefix sum, write), the camera-pass time,
// nodes per texel, memory used / wasted, and the transmittance error against the brute-force
// reference (sombra::reference_transmittance). The analogue on this device of Hadwiger 2006
// Table 1 and Knecht 2011 Tables 5.1/5.3 and 5.8–5.10. Error against time over every technique:
// sombra_bench_error. See bench/README.md.
#include <CLI/CLI.hpp>
#include "host/guarded_main.h"
#include "bench_util.h"
#include <CL/opencl.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include "sombra/sombra.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::forget_preparation;
using sombra::bench::random_points;
using sombra::bench::reference_values;
using sombra::bench::median;
using sombra::bench::sci;
using sombra::bench::shortest;
using sombra::bench::write_file;

// DSM storage backends benchmarked by default, one row set each (--storages overrides).
const std::vector<std::string> kDsmStorages = {"atlas", "chunked"};

// Sets RenderOptions::dsm_storage when it exists (and takes a name); otherwise only "compact".
template <class O>
auto set_dsm_storage(O& options, const std::string& name, int) -> decltype(options.dsm.storage = name, void()) {
    options.dsm.storage = name;
}
template <class O>
void set_dsm_storage(O&, const std::string& name, long) {
    if (name != "compact") throw sombra::Error("DSM storage '" + name + "': this build has only compact storage");
}

struct BenchOptions {
    std::string scene = SOMBRA_DEFAULT_SCENE;
    std::vector<int> resolutions{128, 256, 512};
    std::vector<float> epsilons{0.01f, 0.02f, 0.05f, 0.06f, 0.1f, 0.2f};
    int width = 256, height = 256;
    int runs = 3;
    int points = 2000;
    unsigned seed = 7;  // of the random points
    int light = 0;
    std::string device = "auto";
    std::string out_dir;
    std::vector<std::string> storages = kDsmStorages;
    int lanes_resolution = -1;  // resolution of the 1-lane vs 8-lane comparison; -1: the largest, 0: none
    std::vector<std::string> speed_scenes;  // --speed: only the lookup and generation speed tables
    std::vector<std::string> lookups = {"packed", "native"};  // --speed: RenderOptions::dsm_lookup, side by side
};

struct Row {
    std::string shadows;  // "none", "rays", "dsm"
    std::string storage;  // DSM rows only
    int resolution = 0;
    float epsilon = 0;
    std::map<std::string, double> dsm_stage_ms;  // median per dsm_* stage (DSM rows)
    double generation_ms = 0;                    // median of the per-run sum of the dsm_* stages
    double render_ms = 0;                                                      // median camera_pass
    double mean_nodes = 0;
    unsigned max_nodes = 0;
    int views = 0;
    unsigned long long nodes = 0, bytes_used = 0, bytes_wasted = 0;
    bool has_error = false;
    double mean_error = 0, max_error = 0;  // |T − T_reference| over the points, light --light
    bool is_dsm() const { return shadows == "dsm"; }
    double total_ms() const { return generation_ms + render_ms; }  // what a frame costs (DSM rebuilt per frame)
};

void measure_error(sombra::Context& context, const sombra::Scene& scene, int light, const std::vector<sombra::Vec3>& points,
                   const std::vector<double>& reference, const sombra::RenderOptions& options, Row& row) {
    sombra::ShadowQuery q = sombra::shadow_transmittance(context, scene, light, points, options);
    double sum = 0, max_diff = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        double d = std::fabs(q.transmittance[i] - reference[i]);
        if (!(d <= max_diff)) max_diff = d;  // a NaN makes the maximum NaN
        sum += d;
    }
    row.has_error = true;
    row.mean_error = sum / double(std::max<std::size_t>(points.size(), 1));
    row.max_error = max_diff;
}

// Knecht §3.2 "Deep Shadow Map Re-Generation": the maps of a moved light are regenerated, the
// others kept. Per storage: generation time of the whole set, and of the set after each light in
// turn moves a little (medians over `runs` moves), with the views regenerated.
std::string measure_regeneration(sombra::Context& context, sombra::Scene scene, const sombra::RenderOptions& base,
                                 const std::vector<std::string>& storages, int resolution, float epsilon, int runs) {
    auto generation_ms = [](const sombra::RenderStats& stats) {
        double sum = 0;
        for (const auto& [stage, ms] : stats.stage_ms)
            if (stage.rfind("dsm_", 0) == 0) sum += ms;
        return sum;
    };
    std::ostringstream table;
    table << "| storage | res | ε | all views: gen ms | moved light | views regenerated, per move | gen ms (partial moves) | ÷ all |\n"
          << "|---|---|---|---|---|---|---|---|\n";
    for (const std::string& storage : storages) {
        sombra::RenderOptions options = base;
        options.shadows = sombra::ShadowTechnique::Dsm;
        options.dsm.resolution = resolution, options.dsm.epsilon = epsilon;
        set_dsm_storage(options, storage, 0);
        std::vector<double> all;
        for (int i = 0; i <= runs; ++i) {  // the first is the warm-up
            forget_preparation(context, scene);
            double ms = generation_ms(sombra::render(context, scene, options).stats);
            if (i > 0) all.push_back(ms);
        }
        for (std::size_t light = 0; light < scene.lights.size(); ++light) {
            std::vector<double> partial;
            std::string sequence;
            for (int i = 0; i < runs; ++i) {
                scene.lights[light].position[0] += 0.01f;  // a small move: a new map all the same
                scene.lights[light].direction[0] += 0.01f;
                sombra::RenderStats stats = sombra::render(context, scene, options).stats;
                sequence += (i ? "," : "") + std::to_string(stats.dsm_views_generated);
                if (stats.dsm_views_generated < stats.dsm_views) partial.push_back(generation_ms(stats));
            }
            // a move that leaves more than half the pool superseded builds the whole set anew
            std::string moved_ms = partial.empty() ? "–" : fixed(median(partial), 1);
            std::string ratio = partial.empty() ? "–" : fixed(median(partial) / median(all), 2);
            table << "| " << storage << " | " << resolution << " | " << shortest(epsilon) << " | " << fixed(median(all), 1) << " | "
                  << light << " | " << sequence << " | " << moved_ms << " | " << ratio << " |\n";
        }
    }
    return table.str();
}

// One warm-up render, then `runs` timed ones; times are the OpenCL profiling events in the stats.
void measure_render(sombra::Context& context, const sombra::Scene& scene, const sombra::RenderOptions& options, int runs,
                    Row& row) {
    forget_preparation(context, scene);
    sombra::render(context, scene, options);  // program build, PoCL kernel cache, first enqueue
    std::vector<double> generation, render;
    std::map<std::string, std::vector<double>> stages;  // every dsm_* stage the storage backend reports
    sombra::RenderStats last;
    for (int i = 0; i < runs; ++i) {
        forget_preparation(context, scene);
        last = sombra::render(context, scene, options).stats;
        if (row.is_dsm() && !std::any_of(last.stage_ms.begin(), last.stage_ms.end(),
                                         [](const auto& stage) { return stage.first.rfind("dsm_", 0) == 0; }))
            throw sombra::Error("a DSM render reported no dsm_* stage: the maps were reused, not generated");
        render.push_back(last.stage_ms.at("camera_pass"));
        double sum = 0;
        for (const auto& [stage, ms] : last.stage_ms)
            if (stage.rfind("dsm_", 0) == 0) stages[stage].push_back(ms), sum += ms;
        generation.push_back(sum);
    }
    row.render_ms = median(render);
    if (row.is_dsm()) {
        for (const auto& [stage, ms] : stages) row.dsm_stage_ms[stage] = median(ms);
        row.generation_ms = median(generation);
        row.views = last.dsm_views, row.nodes = last.dsm_nodes;
        row.mean_nodes = last.dsm_mean_nodes_per_texel, row.max_nodes = last.dsm_max_nodes_per_texel;
        row.bytes_used = last.dsm_bytes_used, row.bytes_wasted = last.dsm_bytes_wasted;
    }
}

// DSM generation with 1-texel and 8-texel packets (RenderOptions::lanes) side by side: the same
// maps built `runs` times each, alternating, so that load from other processes hits both alike.
// Returns the median generation time (sum of the dsm_* stages) per lane count.
std::map<int, double> measure_lanes(sombra::Context& context, const sombra::Scene& scene, sombra::RenderOptions options,
                                    int runs) {
    std::map<int, std::vector<double>> times;
    for (int i = -1; i < runs; ++i)  // i = −1: warm-up (program builds)
        for (int lanes : {1, 8}) {
            options.lanes = lanes;
            forget_preparation(context, scene);
            sombra::RenderStats stats;
            sombra::build_deep_shadow_maps(context, scene, 0, options, &stats);
            double sum = 0;
            for (const auto& [stage, ms] : stats.stage_ms)
                if (stage.rfind("dsm_", 0) == 0) sum += ms;
            if (i >= 0) times[lanes].push_back(sum);
        }
    std::map<int, double> medians;
    for (const auto& [lanes, t] : times) medians[lanes] = median(t);
    return medians;
}

// --speed: per scene and storage, the camera pass with DSM lookups (per --lookups: packed, native)
// against the same pass without shadows (renders alternating none, dsm per lookup after one
// warm-up each, medians of `runs`; every DSM render generates its maps again), and the
// generation's dsm_* stages of those renders (medians). Ratios of one run are what to compare:
// the machine may be shared (bench/README.md). The compact storage is packed already: one row.
std::string measure_speed(sombra::Context& context, const BenchOptions& o) {
    int resolution = *std::max_element(o.resolutions.begin(), o.resolutions.end());
    float epsilon = o.epsilons.front();
    std::ostringstream lookup, generation;
    lookup << "DSM lookup: camera pass with --shadows dsm against --shadows none (" << o.width << "x" << o.height
           << ", DSM " << resolution << "², ε " << shortest(epsilon) << "; alternating runs, medians of " << o.runs << "):\n\n"
           << "| scene | storage | lookup | none ms | dsm ms | dsm ÷ none |\n|---|---|---|---:|---:|---:|\n";
    generation << "DSM generation per stage (the same DSM renders; " << resolution << "², ε " << shortest(epsilon) << "):\n\n"
               << "| scene | storage | lookup | stages (ms) | sum ms |\n|---|---|---|---|---:|\n";
    for (const std::string& path : o.speed_scenes) {
        sombra::Scene scene = sombra::load_scene(path);
        std::string name = std::filesystem::path(path).stem().string();
        for (const std::string& storage : o.storages) {
            sombra::RenderOptions none;
            none.shadows = sombra::ShadowTechnique::None;
            none.width = o.width, none.height = o.height;
            none.shadow_cache = sombra::ShadowCacheMode::Off;  // the lookup per sample, as the issue measures it
            std::vector<sombra::RenderOptions> runs{none};    // none, then one DSM render per lookup
            for (const std::string& lookup_name : o.lookups) {
                if (storage == "compact" && runs.size() > 1) break;
                sombra::RenderOptions dsm = none;
                dsm.shadows = sombra::ShadowTechnique::Dsm;
                dsm.dsm.resolution = resolution, dsm.dsm.epsilon = epsilon;
                set_dsm_storage(dsm, storage, 0);
                dsm.dsm.lookup = lookup_name;
                runs.push_back(dsm);
            }
            std::vector<std::vector<double>> camera_ms(runs.size()), sums(runs.size());
            std::vector<std::map<std::string, std::vector<double>>> stages(runs.size());
            for (int i = -1; i < o.runs; ++i)  // i = −1: warm-up (program builds, PoCL cache)
                for (std::size_t r = 0; r < runs.size(); ++r) {
                    forget_preparation(context, scene);
                    sombra::RenderStats stats = sombra::render(context, scene, runs[r]).stats;
                    if (i < 0) continue;
                    camera_ms[r].push_back(stats.stage_ms.at("camera_pass"));
                    double sum = 0;
                    for (const auto& [stage, ms] : stats.stage_ms)
                        if (stage.rfind("dsm_", 0) == 0) stages[r][stage].push_back(ms), sum += ms;
                    sums[r].push_back(sum);
                }
            const double none_ms = median(camera_ms[0]);
            for (std::size_t r = 1; r < runs.size(); ++r) {
                const std::string& lookup_name = runs[r].dsm.lookup;
                const double dsm_ms = median(camera_ms[r]);
                lookup << "| " << name << " | " << storage << " | " << lookup_name << " | " << fixed(none_ms, 1) << " | "
                       << fixed(dsm_ms, 1) << " | " << fixed(dsm_ms / none_ms, 2) << " |\n";
                generation << "| " << name << " | " << storage << " | " << lookup_name << " |";
                for (const auto& [stage, ms] : stages[r]) generation << " " << stage << " " << fixed(median(ms), 1) << ";";
                generation << " | " << fixed(median(sums[r]), 1) << " |\n";
                std::cout << name << " " << storage << " " << lookup_name << ": none " << fixed(none_ms, 1) << " ms, dsm "
                          << fixed(dsm_ms, 1) << " ms (" << fixed(dsm_ms / none_ms, 2) << "×), generation "
                          << fixed(median(sums[r]), 1) << " ms" << std::endl;
            }
        }
    }
    return lookup.str() + "\n" + generation.str();
}

const Row* find_row(const std::vector<Row>& rows, const std::string& shadows) {
    for (const Row& r : rows)
        if (r.shadows == shadows) return &r;
    return nullptr;
}

// The dsm_* stages reported by any row: the compact storage's count, prefix sum and write passes
// first, then whatever other backends add, by name.
std::vector<std::string> stage_columns(const std::vector<Row>& rows) {
    std::vector<std::string> columns = {"dsm_count", "dsm_prefix_sum", "dsm_write"}, seen;
    for (const Row& r : rows)
        for (const auto& [stage, ms] : r.dsm_stage_ms)
            if (std::find(seen.begin(), seen.end(), stage) == seen.end()) seen.push_back(stage);
    columns.erase(std::remove_if(columns.begin(), columns.end(),
                                 [&](const std::string& c) { return std::find(seen.begin(), seen.end(), c) == seen.end(); }),
                  columns.end());
    std::sort(seen.begin(), seen.end());
    for (const std::string& stage : seen)
        if (std::find(columns.begin(), columns.end(), stage) == columns.end()) columns.push_back(stage);
    return columns;
}

std::string markdown_table(const std::vector<Row>& rows) {
    const Row* rays = find_row(rows, "rays");
    std::vector<std::string> stages = stage_columns(rows);
    std::ostringstream s;
    s << "| shadows | storage | res | ε |";
    for (const std::string& stage : stages) s << " " << stage << " ms |";
    s << " DSM gen ms | render ms | render ÷ rays | gen + render ms | nodes/texel mean | max | bytes used | bytes wasted"
         " | mean \\|ΔT\\| | max \\|ΔT\\| | mean \\|ΔT\\| ÷ rays |\n|---|---|---:|---:|";
    for (std::size_t i = 0; i < stages.size() + 11; ++i) s << "---:|";
    s << "\n";
    for (const Row& r : rows) {
        std::string na = "–";
        s << "| " << (r.is_dsm() ? "DSM" : r.shadows == "rays" ? "shadow rays" : "none") << " | "
          << (r.is_dsm() ? r.storage : na) << " | " << (r.is_dsm() ? std::to_string(r.resolution) : na) << " | "
          << (r.is_dsm() ? shortest(r.epsilon) : na) << " | ";
        for (const std::string& stage : stages)
            s << (r.dsm_stage_ms.count(stage) ? fixed(r.dsm_stage_ms.at(stage), 2) : na) << " | ";
        s << (r.is_dsm() ? fixed(r.generation_ms, 1) : na) << " | " << fixed(r.render_ms, 1) << " | " << (rays ? fixed(r.render_ms / rays->render_ms, 2) : na) << " | "
          << fixed(r.total_ms(), 1) << " | ";
        if (r.is_dsm())
            s << fixed(r.mean_nodes, 3) << " | " << r.max_nodes << " | " << r.bytes_used << " | " << r.bytes_wasted << " | ";
        else
            s << na << " | " << na << " | " << na << " | " << na << " | ";
        if (r.has_error)
            s << sci(r.mean_error) << " | " << sci(r.max_error) << " | "
              << (rays && rays->mean_error > 0 ? fixed(r.mean_error / rays->mean_error, 2) : na) << " |\n";
        else
            s << na << " | " << na << " | " << na << " |\n";
    }
    return s.str();
}

std::string csv_table(const std::vector<Row>& rows) {
    std::vector<std::string> stages = stage_columns(rows);
    std::ostringstream s;
    s << "shadows,storage,resolution,epsilon,";
    for (const std::string& stage : stages) s << stage << "_ms,";
    s << "dsm_generation_ms,render_ms,total_ms,dsm_views,dsm_nodes,mean_nodes_per_texel,max_nodes_per_texel,bytes_used,bytes_wasted,mean_abs_error,"
         "max_abs_error\n";
    for (const Row& r : rows) {
        s << r.shadows << ',' << r.storage << ',' << (r.is_dsm() ? std::to_string(r.resolution) : "") << ','
          << (r.is_dsm() ? shortest(r.epsilon) : "") << ',';
        for (const std::string& stage : stages)
            s << (r.dsm_stage_ms.count(stage) ? fixed(r.dsm_stage_ms.at(stage), 3) : "") << ',';
        s << (r.is_dsm() ? fixed(r.generation_ms, 3) : "") << ',';
        s << fixed(r.render_ms, 3) << ',' << fixed(r.total_ms(), 3) << ',';
        if (r.is_dsm())
            s << r.views << ',' << r.nodes << ',' << fixed(r.mean_nodes, 5) << ',' << r.max_nodes << ',' << r.bytes_used
              << ',' << r.bytes_wasted << ',';
        else
            s << ",,,,,,";
        if (r.has_error) s << std::setprecision(6) << r.mean_error << ',' << r.max_error;
        else s << ',';
        s << '\n';
    }
    return s.str();
}

int run(int argc, char** argv) {
    BenchOptions o;
    CLI::App app{"sombra deep shadow maps: generation time, render time, nodes, memory and error vs shadow rays"};
    app.add_option("--scene", o.scene, "scene file (JSON)");
    app.add_option("--resolutions", o.resolutions, "DSM texels per side, comma-separated (paper set: 256,512,1024)")
        ->delimiter(',')
        ->check(CLI::Range(1, 8192));
    app.add_option("--eps", o.epsilons, "compression error bounds ε, comma-separated")->delimiter(',')->check(CLI::Range(0.0f, 1e6f));
    app.add_option("--width", o.width, "image width")->check(CLI::Range(1, 16384));
    app.add_option("--height", o.height, "image height")->check(CLI::Range(1, 16384));
    app.add_option("--runs", o.runs, "timed renders per row, after one warm-up")->check(CLI::PositiveNumber);
    app.add_option("--points", o.points, "random points in the volumes for the transmittance error")->check(CLI::PositiveNumber);
    app.add_option("--seed", o.seed, "seed of the random points");
    app.add_option("--light", o.light, "light whose transmittance is compared with the reference")->check(CLI::NonNegativeNumber);
    app.add_option("--device", o.device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--out", o.out_dir, "write dsm_table.md, dsm_table.csv and dsm_regeneration.md into this folder");
    app.add_option("--storages", o.storages, "DSM storage backends (RenderOptions::dsm_storage), comma-separated")
        ->delimiter(',');
    app.add_option("--lanes-resolution", o.lanes_resolution,
                   "resolution of the DSM generation comparison 1 vs 8 lanes (CPU devices; default: the largest; 0: none)");
    app.add_option("--speed", o.speed_scenes,
                   "only the speed tables, for these scenes (comma-separated): DSM lookup ÷ no shadows and DSM generation "
                   "per stage, at the largest --resolutions and the first --eps, per --storages")
        ->delimiter(',');
    app.add_option("--lookups", o.lookups, "--speed: DSM lookups compared side by side (RenderOptions::dsm_lookup: packed, native)")
        ->delimiter(',')
        ->check(CLI::IsMember({"packed", "native"}));
    CLI11_PARSE(app, argc, argv);

    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);

    if (!o.speed_scenes.empty()) {
        sombra::Context context(o.device);
        std::cout << "command:  " << command << "\n"
                  << "device:   " << context.device().name << " [" << context.device().platform << "]\n"
                  << "cores:    " << std::thread::hardware_concurrency() << "\n\n";
        std::string tables = measure_speed(context, o);
        std::cout << "\n" << tables;
        if (!o.out_dir.empty()) {
            std::filesystem::create_directories(o.out_dir);
            write_file(std::filesystem::path(o.out_dir) / "dsm_speed.md", "<!-- " + command + " | " + context.device().name + " -->\n" + tables);
            std::cout << "wrote " << o.out_dir << "/dsm_speed.md\n";
        }
        return 0;
    }

    sombra::Scene scene = sombra::load_scene(o.scene);
    if (o.light >= int(scene.lights.size()))
        throw sombra::Error("--light: the scene has " + std::to_string(scene.lights.size()) + " lights");
    if (scene.volumes.empty()) throw sombra::Error(o.scene + ": no volumes to place points in");
    sombra::Context context(o.device);
    sombra::RenderOptions base;  // defaults: central differences, skipping on, t ≤ 1e-3 stops, seed 1
    base.shadows = sombra::ShadowTechnique::None;  // each row names its technique
    base.width = o.width, base.height = o.height;

    std::cout << "command:  " << command << "\n"
              << "scene:    " << o.scene << " (" << o.width << "x" << o.height << ", " << scene.lights.size()
              << " lights: every render shadows all of them)\n"
              << "device:   " << context.device().name << " [" << context.device().platform << "]\n"
              << "cores:    " << std::thread::hardware_concurrency() << "\n"
              << "runs:     " << o.runs << " timed after 1 warm-up, medians of OpenCL profiling events\n";

    auto points = random_points(scene, o.points, o.seed);
    std::vector<double> reference = reference_values(scene, o.light, points);
    std::size_t shadowed = std::count_if(reference.begin(), reference.end(), [](double t) { return t < 0.99; });
    std::cout << "error:    " << points.size() << " random points (seed " << o.seed << ") in the volumes' boxes, light "
              << o.light << "; " << shadowed << " have reference T < 0.99\n\n";

    std::vector<Row> rows;
    Row none;
    none.shadows = "none";
    measure_render(context, scene, base, o.runs, none);
    rows.push_back(none);
    std::cout << "none: render " << fixed(none.render_ms, 1) << " ms\n";

    Row rays;
    rays.shadows = "rays";
    sombra::RenderOptions ray_options = base;
    ray_options.shadows = sombra::ShadowTechnique::Rays;
    measure_render(context, scene, ray_options, o.runs, rays);
    measure_error(context, scene, o.light, points, reference, ray_options, rays);
    rows.push_back(rays);
    std::cout << "rays: render " << fixed(rays.render_ms, 1) << " ms, mean |ΔT| " << sci(rays.mean_error) << "\n";

    for (const std::string& storage : o.storages)
        for (int resolution : o.resolutions)
            for (float epsilon : o.epsilons) {
                Row r;
                r.shadows = "dsm", r.storage = storage, r.resolution = resolution, r.epsilon = epsilon;
                sombra::RenderOptions options = base;
                options.shadows = sombra::ShadowTechnique::Dsm;
                options.dsm.resolution = resolution, options.dsm.epsilon = epsilon;
                set_dsm_storage(options, storage, 0);
                measure_render(context, scene, options, o.runs, r);
                measure_error(context, scene, o.light, points, reference, options, r);
                rows.push_back(r);
                std::cout << "dsm " << storage << " " << resolution << " ε " << shortest(epsilon) << ": gen "
                          << fixed(r.generation_ms, 1) << " ms, render " << fixed(r.render_ms, 1) << " ms, nodes/texel "
                          << fixed(r.mean_nodes, 3) << " (max " << r.max_nodes << "), mean |ΔT| " << sci(r.mean_error)
                          << std::endl;
            }

    std::string table = markdown_table(rows);
    // texel packets (cl/dsm_build.cl): generation with 1 and 8 lanes in the same process
    int lanes_resolution = o.lanes_resolution < 0 ? *std::max_element(o.resolutions.begin(), o.resolutions.end())
                                                  : o.lanes_resolution;
    if (lanes_resolution > 0 && !context.device().is_gpu) {
        std::ostringstream lanes_table;
        float epsilon = std::find(o.epsilons.begin(), o.epsilons.end(), 0.02f) != o.epsilons.end() ? 0.02f : o.epsilons[0];
        lanes_table << "\nDSM generation, texels per work-item (alternating runs, medians of " << o.runs << "; res "
                    << lanes_resolution << ", ε " << shortest(epsilon) << "):\n\n"
                    << "| storage | 1 lane ms | 8 lanes ms | speed-up |\n|---|---:|---:|---:|\n";
        for (const std::string& storage : o.storages) {
            sombra::RenderOptions options = base;
            options.shadows = sombra::ShadowTechnique::Dsm;
            options.dsm.resolution = lanes_resolution, options.dsm.epsilon = epsilon;
            set_dsm_storage(options, storage, 0);
            std::map<int, double> ms = measure_lanes(context, scene, options, o.runs);
            lanes_table << "| " << storage << " | " << fixed(ms[1], 1) << " | " << fixed(ms[8], 1) << " | "
                        << fixed(ms[1] / ms[8], 2) << " |\n";
        }
        table += lanes_table.str();
    }
    std::cout << "\n" << table;
    std::string regeneration = measure_regeneration(context, scene, base, o.storages, *std::max_element(o.resolutions.begin(), o.resolutions.end()), o.epsilons.front(), o.runs);
    std::cout << "\nregeneration after a light moves (" << *std::max_element(o.resolutions.begin(), o.resolutions.end()) << "², ε " << shortest(o.epsilons.front())
              << "):\n" << regeneration;
    if (!o.out_dir.empty()) {
        std::filesystem::path dir(o.out_dir);
        std::filesystem::create_directories(dir);
        std::string header = "<!-- " + command + " | " + context.device().name + " | " +
                             std::to_string(std::thread::hardware_concurrency()) + " cores | " + std::to_string(o.width) +
                             "x" + std::to_string(o.height) + " | " + std::to_string(o.points) + " points, light " +
                             std::to_string(o.light) + " -->\n";
        write_file(dir / "dsm_table.md", header + table);
        write_file(dir / "dsm_table.csv", csv_table(rows));
        write_file(dir / "dsm_regeneration.md", header + regeneration);
        std::cout << "wrote " << o.out_dir << "/dsm_table.{csv,md}\n";
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_dsm", run, argc, argv); }
