// sombra_bench_error — every shadow technique over its quality knobs on one scene, with the shadow
// cache on and off: error against run time. Per configuration the median build, cache-fill, camera
// and first-frame times; the image error against a converged reference image (shadow rays at a
// fine step, kept on disk); the point error against sombra::reference_transmittance. Writes a
// Markdown table, a CSV and a log-log Pareto plot (bench/plot_error_pareto.py). See bench/README.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <thread>

#include "bench_util.h"
#include "host/guarded_main.h"
#include "sombra/sombra.h"

namespace {

using sombra::RenderOptions;
using sombra::ShadowTechnique;
using sombra::bench::fixed;
using sombra::bench::median;
using sombra::bench::sci;
using sombra::bench::shortest;

enum class SweepSize { Quick, Default, Full };

// The knob values of one sweep size.
struct Sweep {
    std::vector<int> resolutions;  // dsm and shadowmap
    std::vector<float> epsilons;
    // DSM generation step factors (RenderOptions::dsm_step) besides 1: default and quick at every
    // resolution with the smallest ε; full: in the product.
    std::vector<float> dsm_steps;
    // Default and quick: resolution × ε with atlas / no pre-filter, then each other storage and
    // pre-filter at one point (the smallest resolution and ε). Full: the whole product.
    bool dsm_product = false;
    std::vector<std::string> storages, prefilters;
    std::vector<float> ray_steps, box_widths, gauss_widths, ao_widths, cone_angles;  // lowpass: box and gauss W
};

Sweep make_sweep(SweepSize size) {
    const std::vector<std::string> all_storages = sombra::dsm_storage_names();
    const std::vector<std::string> all_prefilters = sombra::render_option_values("dsm_prefilter");
    switch (size) {
    case SweepSize::Quick:
        return {{128, 256}, {0.02f}, {2}, false, {"compact"}, {"box"}, {2, 1}, {3}, {}, {7}, {10}};
    case SweepSize::Full:
        return {{128, 256, 512, 1024}, {0.005f, 0.01f, 0.02f, 0.05f, 0.1f, 0.2f}, {1.5f, 2, 4}, true, all_storages, all_prefilters,
                {8, 4, 2, 1, 0.5f}, {1, 2, 3, 5, 7, 11, 15, 23}, {1, 2, 3, 5, 7, 11, 15, 23}, {1, 3, 7, 15, 31},
                {2.5f, 5, 10, 20, 40}};
    case SweepSize::Default:
        break;
    }
    return {{128, 256, 512}, {0.01f, 0.1f}, {2}, false, all_storages, all_prefilters, {2, 1, 0.5f}, {1, 3, 9}, {3, 9}, {3, 9}, {5, 15}};
}

// One technique at one setting of its knobs (the shadow cache is chosen per measurement).
struct Variant {
    std::string setting;  // e.g. "256² ε=0.02 chunked"
    RenderOptions options;
};

std::vector<Variant> make_variants(const Sweep& sweep, const RenderOptions& base) {
    std::vector<Variant> variants;
    auto add = [&](ShadowTechnique technique, const std::string& setting, auto&& set) {
        Variant v{setting, base};
        v.options.shadows = technique;
        set(v.options);
        variants.push_back(v);
    };
    add(ShadowTechnique::None, "–", [](RenderOptions&) {});
    for (float step : sweep.ray_steps)
        add(ShadowTechnique::Rays, "step ×" + shortest(step), [&](RenderOptions& o) { o.rays.step = step; });
    auto add_dsm = [&](int resolution, float epsilon, const std::string& storage, const std::string& prefilter, float step) {
        std::string setting = std::to_string(resolution) + "² ε=" + shortest(epsilon);
        if (step != 1.f) setting += " step ×" + shortest(step);
        if (storage != "atlas") setting += " " + storage;
        if (prefilter != "none") setting += " prefilter " + prefilter;
        add(ShadowTechnique::Dsm, setting, [&](RenderOptions& o) {
            o.dsm.resolution = resolution, o.dsm.epsilon = epsilon, o.dsm.storage = storage, o.dsm.prefilter = prefilter;
            o.dsm.step = step;
        });
    };
    std::vector<float> all_steps{1.f};
    all_steps.insert(all_steps.end(), sweep.dsm_steps.begin(), sweep.dsm_steps.end());
    for (int resolution : sweep.resolutions)
        for (float epsilon : sweep.epsilons)
            if (sweep.dsm_product) {
                for (const std::string& storage : sweep.storages)
                    for (const std::string& prefilter : sweep.prefilters)
                        for (float step : all_steps) add_dsm(resolution, epsilon, storage, prefilter, step);
            } else {
                add_dsm(resolution, epsilon, "atlas", "none", 1.f);
            }
    if (!sweep.dsm_product) {  // the generation steps at the smallest ε, the other storages and pre-filters at one point
        float epsilon = *std::min_element(sweep.epsilons.begin(), sweep.epsilons.end());
        for (int resolution : sweep.resolutions)
            for (float step : sweep.dsm_steps) add_dsm(resolution, epsilon, "atlas", "none", step);
        int resolution = *std::min_element(sweep.resolutions.begin(), sweep.resolutions.end());
        for (const std::string& storage : sweep.storages)
            if (storage != "atlas") add_dsm(resolution, epsilon, storage, "none", 1.f);
        for (const std::string& prefilter : sweep.prefilters)
            if (prefilter != "none") add_dsm(resolution, epsilon, "atlas", prefilter, 1.f);
    }
    for (int resolution : sweep.resolutions)
        add(ShadowTechnique::ShadowMap, std::to_string(resolution) + "²", [&](RenderOptions& o) { o.dsm.resolution = resolution; });
    for (const auto& [kernel, widths] : {std::pair{"box", sweep.box_widths}, std::pair{"gauss", sweep.gauss_widths}})
        for (float width : widths)
            add(ShadowTechnique::Lowpass, "W=" + shortest(width) + " " + kernel, [&](RenderOptions& o) {
                o.sat.filter_width = width, o.sat.filter_kernel = kernel;
            });
    for (float width : sweep.ao_widths)
        add(ShadowTechnique::Ao, "W=" + shortest(width), [&](RenderOptions& o) { o.sat.filter_width = width; });
    for (float angle : sweep.cone_angles)
        add(ShadowTechnique::Cone, shortest(angle) + "°", [&](RenderOptions& o) { o.sat.cone_angle_deg = angle; });
    return variants;
}

// Times of one configuration: medians over the timed renders, each from nothing prepared.
struct Times {
    double build_ms = 0;       // the technique's data: dsm_*, sat_* / ssat_* stages, the shadow rays' BVH
    double cache_fill_ms = 0;  // stage "shadow_cache"
    double camera_ms = 0;      // camera_* stages (with meshes: raster and fragments too)
    double first_frame_ms = 0; // every stage but program_build: what the first frame costs
};

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

Times times_of(const sombra::RenderStats& stats) {
    Times t;
    for (const auto& [stage, ms] : stats.stage_ms) {
        if (stage == "program_build") continue;  // once per process and set of defines
        t.first_frame_ms += ms;
        if (stage == "shadow_cache") t.cache_fill_ms += ms;
        else if (starts_with(stage, "camera_")) t.camera_ms += ms;
        else if (starts_with(stage, "dsm_") || starts_with(stage, "sat_") || starts_with(stage, "ssat_") || stage == "bvh_build")
            t.build_ms += ms;
    }
    return t;
}

struct ErrorPair {
    double mean = 0, tail = 0;  // image: mean and 95th percentile; points: mean and max
};

// Per pixel the largest |ΔR|, |ΔG|, |ΔB|; the mean and the 95th percentile over all pixels.
ErrorPair image_error(const sombra::Image& image, const sombra::Image& reference) {
    std::vector<double> diffs;
    for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
        double d = 0;
        for (int c = 0; c < 3; ++c) d = std::max(d, double(std::fabs(image.rgba[i + c] - reference.rgba[i + c])));
        diffs.push_back(std::isfinite(d) ? d : INFINITY);
    }
    ErrorPair e;
    for (double d : diffs) e.mean += d / double(diffs.size());
    std::size_t at = std::min(diffs.size() - 1, std::size_t(std::ceil(0.95 * double(diffs.size()))) - 1);
    std::nth_element(diffs.begin(), diffs.begin() + std::ptrdiff_t(at), diffs.end());
    e.tail = diffs[at];
    return e;
}

// The random points and their reference transmittance, per light.
struct PointReference {
    std::vector<sombra::Vec3> points;
    std::vector<std::vector<double>> transmittance;  // [light][point]
};

// |ΔT| over every light's points: the technique itself (shadow_transmittance never reads the cache).
ErrorPair point_error(sombra::Context& context, const sombra::Scene& scene, const PointReference& ref, const RenderOptions& options) {
    ErrorPair e;
    std::size_t count = 0;
    for (std::size_t light = 0; light < ref.transmittance.size(); ++light) {
        std::vector<double> got = options.shadows == ShadowTechnique::None  // no shadow term: T = 1
                                      ? std::vector<double>(ref.points.size(), 1.0)
                                      : sombra::shadow_transmittance(context, scene, int(light), ref.points, options).transmittance;
        for (std::size_t i = 0; i < got.size(); ++i) {
            double d = std::fabs(got[i] - ref.transmittance[light][i]);
            if (!(d <= e.tail)) e.tail = d;  // a NaN makes the maximum NaN
            e.mean += d, ++count;
        }
    }
    e.mean /= double(std::max<std::size_t>(count, 1));
    return e;
}

struct Row {
    std::string technique, setting;
    bool cache = false;       // requested On (else Off); "none" has no shadow term and no cache
    bool cache_used = false;  // RenderStats::shadow_cache_used
    RenderOptions options;
    Times times;
    ErrorPair image, point;
    bool pareto_image = false, pareto_point = false;
};

// One warm-up render (program builds, first touch), then `runs` renders from nothing prepared.
void measure(sombra::Context& context, const sombra::Scene& scene, const sombra::Image& reference, int runs, Row& row) {
    sombra::bench::forget_preparation(context, scene);
    sombra::render(context, scene, row.options);
    std::vector<Times> all;
    sombra::RenderResult last;
    for (int i = 0; i < runs; ++i) {
        sombra::bench::forget_preparation(context, scene);
        last = sombra::render(context, scene, row.options);
        all.push_back(times_of(last.stats));
    }
    auto median_of = [&](double Times::*field) {
        std::vector<double> v;
        for (const Times& t : all) v.push_back(t.*field);
        return median(v);
    };
    row.times = {median_of(&Times::build_ms), median_of(&Times::cache_fill_ms), median_of(&Times::camera_ms),
                 median_of(&Times::first_frame_ms)};
    row.cache_used = last.stats.shadow_cache_used;
    row.image = image_error(last.image, reference);
}

// Marks the rows no other candidate beats in both first-frame time and `error` (ties: both stay).
template <class ErrorOf>
void mark_pareto(const std::vector<Row*>& candidates, ErrorOf error, bool Row::*flag) {
    for (Row* r : candidates)
        r->*flag = std::none_of(candidates.begin(), candidates.end(), [&](const Row* o) {
            double ot = o->times.first_frame_ms, rt = r->times.first_frame_ms, oe = error(*o), re = error(*r);
            return ot <= rt && oe <= re && (ot < rt || oe < re);
        });
}

// The converged reference image: shadow rays at a fine step, cache off; read from `path` when a
// file of this size is there, else rendered and written.
sombra::Image reference_image(sombra::Context& context, const sombra::Scene& scene, RenderOptions options, float step,
                              const std::filesystem::path& path) {
    if (std::filesystem::exists(path)) {
        sombra::Image image = sombra::read_image(path.string());
        if (image.width == options.width && image.height == options.height) {
            for (std::size_t i = 0; i < image.rgba.size(); i += 4)  // EXR holds it without the background
                for (int c = 0; c < 3; ++c) image.rgba[i + c] += (1.f - image.rgba[i + 3]) * scene.background[std::size_t(c)];
            std::cout << "reference: " << path.string() << " (reused; delete it after a change to the renderer)\n";
            return image;
        }
    }
    options.shadows = ShadowTechnique::Rays;
    options.rays.step = step;
    options.shadow_cache = sombra::ShadowCacheMode::Off;
    sombra::RenderResult r = sombra::render(context, scene, options);
    sombra::write_image(r.image, path.string());
    std::cout << "reference: " << path.string() << " (shadow rays, step ×" << shortest(step) << ", cache off: "
              << fixed(r.stats.stage_ms["camera_pass"] / 1000, 1) << " s)\n";
    return r.image;
}

std::string cache_text(const Row& r) {
    if (r.technique == "none") return "–";
    return std::string(r.cache ? "on" : "off") + (r.cache != r.cache_used ? " (not used)" : "");
}

std::string markdown_table(const std::vector<Row>& rows) {
    std::ostringstream s;
    s << "| technique | setting | cache | build ms | cache fill ms | camera ms | first frame ms | image mean \\|ΔRGB\\| | "
         "image p95 \\|ΔRGB\\| | point mean \\|ΔT\\| | point max \\|ΔT\\| | Pareto |\n"
      << "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const Row& r : rows) {
        std::string pareto = r.pareto_image ? "image" : "";
        if (r.pareto_point) pareto += pareto.empty() ? "point" : ", point";
        s << "| " << r.technique << " | " << r.setting << " | " << cache_text(r) << " | " << fixed(r.times.build_ms, 1) << " | "
          << fixed(r.times.cache_fill_ms, 1) << " | " << fixed(r.times.camera_ms, 1) << " | " << fixed(r.times.first_frame_ms, 1)
          << " | " << sci(r.image.mean) << " | " << sci(r.image.tail) << " | " << sci(r.point.mean) << " | " << sci(r.point.tail)
          << " | " << (pareto.empty() ? "" : "**" + pareto + "**") << " |\n";
    }
    return s.str();
}

std::string csv_table(const std::vector<Row>& rows) {
    std::ostringstream s;
    s << "technique,setting,shadow_cache,cache_used,dsm_resolution,dsm_epsilon,dsm_storage,dsm_prefilter,dsm_step,ray_step,filter_width,"
         "filter_kernel,cone_angle_deg,build_ms,cache_fill_ms,camera_ms,first_frame_ms,image_mean,image_p95,point_mean,point_max,"
         "pareto_image,pareto_point\n";
    s.precision(6);
    for (const Row& r : rows) {
        const RenderOptions& o = r.options;
        s << r.technique << ",\"" << r.setting << "\"," << (r.technique == "none" ? "" : r.cache ? "on" : "off") << ','
          << r.cache_used << ',' << o.dsm.resolution << ',' << o.dsm.epsilon << ',' << o.dsm.storage << ',' << o.dsm.prefilter << ',' << o.dsm.step << ','
          << o.rays.step << ',' << o.sat.filter_width << ',' << o.sat.filter_kernel << ',' << o.sat.cone_angle_deg << ','
          << r.times.build_ms << ',' << r.times.cache_fill_ms << ',' << r.times.camera_ms << ',' << r.times.first_frame_ms << ','
          << r.image.mean << ',' << r.image.tail << ',' << r.point.mean << ',' << r.point.tail << ',' << r.pareto_image << ','
          << r.pareto_point << '\n';
    }
    return s.str();
}

bool imports_matplotlib(const std::string& python) {
    return std::system((python + " -c 'import matplotlib' >/dev/null 2>&1").c_str()) == 0;
}

// The plot, by bench/plot_error_pareto.py when the Python has matplotlib; the default `python3`
// falls back to Debian's /usr/bin/python3 (python3-matplotlib) when the first on PATH lacks it
// (a pyenv or virtual environment).
void plot(std::string python, bool python_given, const std::filesystem::path& csv, const std::filesystem::path& png,
          const std::string& title) {
    std::string later = python + " " + SOMBRA_PLOT_SCRIPT + " " + csv.string() + " " + png.string();
    if (!imports_matplotlib(python) && !python_given && imports_matplotlib("/usr/bin/python3")) python = "/usr/bin/python3";
    if (!imports_matplotlib(python)) {
        std::cout << "note: no plot: `" << python << "` cannot import matplotlib (python3-matplotlib); later: " << later << "\n";
        return;
    }
    std::string command = python + " '" + SOMBRA_PLOT_SCRIPT + "' '" + csv.string() + "' '" + png.string() + "' '" + title + "'";
    if (std::system(command.c_str()) != 0) std::cout << "note: the plot script failed: " << command << "\n";
    else std::cout << "wrote " << png.string() << "\n";
}

int run(int argc, char** argv) {
    std::string scene_path = SOMBRA_DEFAULT_SCENE, out_dir, device = "auto", python = "python3";
    int width = 128, height = 128, runs = 3, point_count = 300;
    unsigned seed = 7;
    float reference_step = 0.25f;
    bool quick = false, full = false;
    CLI::App app{"sombra: every shadow technique over its quality knobs, cache on and off: error against time"};
    app.add_option("--scene", scene_path, "scene file (JSON)");
    app.add_option("--width", width, "image width")->check(CLI::Range(1, 16384));
    app.add_option("--height", height, "image height")->check(CLI::Range(1, 16384));
    app.add_option("--runs", runs, "timed renders per configuration, after one warm-up (medians)")->check(CLI::PositiveNumber);
    app.add_option("--points", point_count, "random points in the volumes for the point error, per light")->check(CLI::PositiveNumber);
    app.add_option("--seed", seed, "seed of the random points");
    app.add_option("--reference-step", reference_step, "shadow-ray step factor of the reference image")->check(CLI::Range(0.01f, 1.f));
    app.add_option("--device", device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--out", out_dir, "output folder (default bench/results/error/<scene>)");
    CLI::Option* python_option = app.add_option("--python", python, "Python with matplotlib, for the plot");
    app.add_flag("--quick", quick, "a small sweep");
    app.add_flag("--full", full, "the big sweep (every DSM resolution × ε × storage × pre-filter)")->excludes("--quick");
    CLI11_PARSE(app, argc, argv);

    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
    const std::string scene_name = std::filesystem::path(scene_path).stem().string();
    const std::filesystem::path dir = out_dir.empty() ? std::filesystem::path(SOMBRA_RESULTS_DIR) / scene_name : std::filesystem::path(out_dir);
    std::filesystem::create_directories(dir);

    sombra::Scene scene = sombra::load_scene(scene_path);
    if (scene.volumes.empty() || scene.lights.empty()) throw sombra::Error(scene_path + ": needs volumes and lights");
    sombra::Context context(device);
    RenderOptions base;
    base.width = width, base.height = height;
    const SweepSize size = quick ? SweepSize::Quick : full ? SweepSize::Full : SweepSize::Default;
    std::vector<Variant> variants = make_variants(make_sweep(size), base);
    std::cout << "command:  " << command << "\n"
              << "scene:    " << scene_path << " (" << width << "x" << height << ", " << scene.volumes.size() << " volumes, "
              << scene.lights.size() << " lights)\n"
              << "device:   " << context.device().name << " [" << context.device().platform << "], "
              << std::thread::hardware_concurrency() << " cores\n"
              << "sweep:    " << (quick ? "quick" : full ? "full" : "default") << ", " << variants.size()
              << " settings, each with the shadow cache off and on; " << runs << " timed renders after a warm-up\n";

    sombra::Image reference = reference_image(context, scene, base, reference_step,
                                              dir / ("reference_" + scene_name + "_" + std::to_string(width) + "x" +
                                                     std::to_string(height) + ".exr"));
    PointReference points{sombra::bench::random_points(scene, point_count, seed), {}};
    for (std::size_t light = 0; light < scene.lights.size(); ++light)
        points.transmittance.push_back(sombra::bench::reference_values(scene, int(light), points.points));

    std::vector<Row> rows;
    for (const Variant& v : variants) {
        std::string technique = sombra::shadow_technique_name(v.options.shadows);
        ErrorPair point = point_error(context, scene, points, v.options);  // the same with the cache on or off
        for (bool cache : {false, true}) {
            if (cache && v.options.shadows == ShadowTechnique::None) continue;
            Row row{technique, v.setting, cache, false, v.options, {}, {}, point};
            row.options.shadow_cache = cache ? sombra::ShadowCacheMode::On : sombra::ShadowCacheMode::Off;
            measure(context, scene, reference, runs, row);
            std::cout << technique << " " << v.setting << " cache " << cache_text(row) << ": build " << fixed(row.times.build_ms, 1)
                      << " + fill " << fixed(row.times.cache_fill_ms, 1) << " + camera " << fixed(row.times.camera_ms, 1)
                      << " ms, first frame " << fixed(row.times.first_frame_ms, 1) << " ms; image mean " << sci(row.image.mean)
                      << " p95 " << sci(row.image.tail) << "; points mean " << sci(row.point.mean) << " max "
                      << sci(row.point.tail) << std::endl;
            rows.push_back(row);
        }
    }
    std::vector<Row*> all, cache_off;
    for (Row& r : rows) {
        all.push_back(&r);
        if (!r.cache) cache_off.push_back(&r);
    }
    mark_pareto(all, [](const Row& r) { return r.image.mean; }, &Row::pareto_image);
    mark_pareto(cache_off, [](const Row& r) { return r.point.mean; }, &Row::pareto_point);  // the technique's own error

    std::string header = "<!-- " + command + " | " + context.device().name + " | " +
                         std::to_string(std::thread::hardware_concurrency()) + " cores | " + std::to_string(width) + "x" +
                         std::to_string(height) + " | medians of " + std::to_string(runs) + " renders after a warm-up | " +
                         std::to_string(point_count) + " points per light, seed " + std::to_string(seed) + " -->\n";
    std::string note =
        "\nImage error: per pixel the largest |ΔR|, |ΔG|, |ΔB| against shadow rays at step ×" + shortest(reference_step) +
        " with the cache off, mean and 95th percentile over all pixels. Point error: |ΔT| against "
        "reference_transmittance at " + std::to_string(point_count) + " random points per light, from shadow_transmittance, "
        "which evaluates the technique itself, never the shadow cache (the same for cache on and off). Times: medians of "
        "OpenCL profiling events (host clock for host stages) over renders from nothing prepared; first frame = every "
        "stage but program_build. Pareto: no other row is both faster (first frame) and closer (image: all rows; point: "
        "cache-off rows).\n";
    std::string table = markdown_table(rows) + note;
    sombra::bench::write_file(dir / "error_table.md", header + table);
    sombra::bench::write_file(dir / "error_table.csv", csv_table(rows));
    std::cout << "\n" << table << "wrote " << (dir / "error_table.{md,csv}").string() << "\n";
    plot(python, python_option->count() > 0, dir / "error_table.csv", dir / "error_pareto.png",
         scene_name + ", " + std::to_string(width) + "×" + std::to_string(height));
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_error", run, argc, argv); }
