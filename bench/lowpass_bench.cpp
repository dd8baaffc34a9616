// sombra_bench_lowpass — the analogue of Ament et al. 2014 Table 1 on this device: per shadow
// method (single scattering = shadow rays, SAT ambient occlusion, SAT cone shadows, low-pass
// filtered shadows with box and Gaussian kernels) the SAT memory, the time to rebuild the shadow
// data after a transfer-function change and after a light move, the camera-pass time, and the
// transmittance error against shadow rays; then the time against the filter width. Markdown and
// CSV into --out. Times: OpenCL profiling events, medians of --runs after a warm-up.
#include <CLI/CLI.hpp>
#include "host/guarded_main.h"
#include "bench_util.h"

#include <cmath>
#include <iostream>
#include <map>

#include "sombra/sombra.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;
using sombra::bench::sci;

struct BenchOptions {
    std::string scene = SOMBRA_DEFAULT_SCENE;
    int width = 256, height = 256, runs = 2, points = 1000;
    float filter = 7.f, cone_deg = 10.f;
    std::vector<float> widths{1, 3, 5, 7, 9, 11, 15};
    std::string device = "auto", out_dir;
    std::string lights = "scene";  // scene, ortho3 (3 orthodirectional lights), point2 (2 point lights)
    std::string tag;               // suffix of the output files
};

// Ament Table 1's light set-ups in place of the scene's lights: three orthodirectional lights
// (one CSAT), or two point lights outside the data (two SSATs), placed around the camera's target.
void set_lights(sombra::Scene& scene, const std::string& setup) {
    if (setup == "scene") return;
    const sombra::Camera& c = scene.camera;
    sombra::Vec3 target = c.look_at;
    float distance = std::sqrt((c.position[0] - target[0]) * (c.position[0] - target[0]) +
                               (c.position[1] - target[1]) * (c.position[1] - target[1]) +
                               (c.position[2] - target[2]) * (c.position[2] - target[2]));
    scene.lights.clear();
    sombra::Light l;
    l.intensity = 0.6f;
    if (setup == "ortho3") {
        l.type = sombra::LightType::Directional;
        for (sombra::Vec3 d : {sombra::Vec3{1, 0, 0}, sombra::Vec3{0, 1, 0}, sombra::Vec3{0, 0, -1}}) {
            l.direction = d;
            scene.lights.push_back(l);
        }
    } else if (setup == "point2") {
        l.type = sombra::LightType::Point;
        for (float side : {-1.f, 1.f}) {
            l.position = {target[0] + side * 0.5f * distance, target[1] - 0.5f * distance, target[2] + 0.4f * distance};
            scene.lights.push_back(l);
        }
    } else {
        throw sombra::Error("--lights: expected scene, ortho3 or point2, got '" + setup + "'");
    }
}

struct Method {
    std::string name;
    sombra::ShadowTechnique technique;
    std::string kernel = "box";
};

struct Row {
    std::string method;
    float filter = 0;
    double sat_mb = 0, tf_change_ms = 0, light_move_ms = 0, render_ms = 0;
    double uncached_render_ms = 0;  // the SAT methods without the shadow cache (per-sample tables)
    // what the granular first pass rebuilt (medians): tables and cache entries after a TF change
    // and after one light moved
    double tf_tables = 0, tf_entries = 0, move_tables = 0, move_entries = 0;
    double mean_error = 0, max_error = 0;  // |T − T_shadow rays| over the points and lights
};

// Sum of the stages that (re)build shadow data: the SATs (sat_*, ssat_*) and the shadow cache
// (Ament Alg. 1's first pass).
double rebuild_ms(const sombra::RenderStats& stats) {
    double sum = 0;
    for (const auto& [stage, ms] : stats.stage_ms)
        if (stage.rfind("sat_", 0) == 0 || stage.rfind("ssat_", 0) == 0 || stage == "shadow_cache") sum += ms;
    return sum;
}

// A copy of the scene with the transfer functions' opacities scaled by `f` (a TF change).
sombra::Scene with_opacity(sombra::Scene scene, float f) {
    for (auto& vi : scene.volumes)
        for (auto& point : vi.transfer_function.opacity_points) point.alpha *= f;
    return scene;
}

// A copy with light `k` turned by a small angle about z around the camera's target (a light move:
// Ament Alg. 1 rebuilds that light's table, if it has its own, and its cache entries).
sombra::Scene with_light_turned(sombra::Scene scene, std::size_t k, float radians) {
    float c = std::cos(radians), s = std::sin(radians);
    const sombra::Vec3 o = scene.camera.look_at;
    auto turn = [&](sombra::Vec3& v, float w) {
        float x = v[0] - w * o[0], y = v[1] - w * o[1];
        v = {c * x - s * y + w * o[0], s * x + c * y + w * o[1], v[2]};
    };
    sombra::Light& l = scene.lights.at(k);
    turn(l.direction, 0.f), turn(l.position, 1.f);
    return scene;
}

Row measure(sombra::Context& context, const sombra::Scene& scene, const BenchOptions& o, const Method& m, float filter,
            const std::vector<sombra::Vec3>& points, const std::vector<std::vector<double>>& rays) {
    sombra::RenderOptions options;
    options.width = o.width, options.height = o.height;
    options.shadows = m.technique;
    options.sat.filter_width = filter;
    options.sat.filter_kernel = m.kernel;
    options.sat.cone_angle_deg = o.cone_deg;
    // as in Ament Table 1: the SAT methods read the shadow cache (Alg. 1), SS marches per sample
    options.shadow_cache = m.technique == sombra::ShadowTechnique::Rays ? sombra::ShadowCacheMode::Off : sombra::ShadowCacheMode::On;
    Row row;
    row.method = m.name, row.filter = filter;
    std::vector<double> tf, move, render, tf_tables, tf_entries, move_tables, move_entries;
    sombra::render(context, scene, options);  // warm-up: programs, kernel cache
    for (int i = 0; i < o.runs && m.technique == sombra::ShadowTechnique::Rays; ++i)  // nothing to rebuild
        render.push_back(sombra::render(context, scene, options).stats.stage_ms.at("camera_pass"));
    for (int i = 0; i < o.runs && m.technique != sombra::ShadowTechnique::Rays; ++i) {
        // a transfer-function change: every table holds the volumes, the entries they reach
        sombra::Scene changed_tf = with_opacity(scene, i % 2 ? 1.f : 0.999f);
        sombra::RenderStats changed = sombra::render(context, changed_tf, options).stats;
        tf.push_back(rebuild_ms(changed));
        tf_tables.push_back(changed.sat_tables_built), tf_entries.push_back(changed.shadow_cache_entries_built);
        // one light moves (each in turn): its own table, if any, and its cache entries
        sombra::Scene moved_scene = with_light_turned(changed_tf, std::size_t(i) % scene.lights.size(), 0.01f * float(i + 1));
        sombra::RenderStats moved = sombra::render(context, moved_scene, options).stats;
        move.push_back(rebuild_ms(moved));
        move_tables.push_back(moved.sat_tables_built), move_entries.push_back(moved.shadow_cache_entries_built);
        sombra::RenderStats again = sombra::render(context, moved_scene, options).stats;
        render.push_back(again.stage_ms.at("camera_pass"));  // shadow data reused
        row.sat_mb = double(again.sat_bytes) / (1 << 20);
    }
    row.render_ms = median(render);
    if (!tf.empty()) {
        row.tf_change_ms = median(tf), row.light_move_ms = median(move);
        row.tf_tables = median(tf_tables), row.tf_entries = median(tf_entries);
        row.move_tables = median(move_tables), row.move_entries = median(move_entries);
    }
    if (m.technique != sombra::ShadowTechnique::Rays) {  // the uncached mode: every sample reads the tables
        sombra::RenderOptions uncached = options;
        uncached.shadow_cache = sombra::ShadowCacheMode::Off;
        std::vector<double> times;
        sombra::render(context, scene, uncached);  // warm-up
        for (int i = 0; i < o.runs; ++i) times.push_back(sombra::render(context, scene, uncached).stats.stage_ms.at("camera_pass"));
        row.uncached_render_ms = median(times);
    }
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t l = 0; l < scene.lights.size(); ++l) {
        auto t = sombra::shadow_transmittance(context, scene, int(l), points, options).transmittance;
        for (std::size_t i = 0; i < points.size(); ++i) {
            double d = std::fabs(t[i] - rays[l][i]);
            sum += d, ++count, row.max_error = std::max(row.max_error, d);
        }
    }
    row.mean_error = sum / double(std::max<std::size_t>(count, 1));
    return row;
}

std::string markdown(const std::vector<Row>& rows) {
    std::ostringstream s;
    s << "| method | filter | SAT MB | TF change ms | rebuilt on TF change | light move ms | rebuilt on light move | render ms | "
         "render ms, no cache | mean \\|ΔT\\| vs rays | max \\|ΔT\\| |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    auto rebuilt = [](double tables, double entries) { return fixed(tables, 0) + " / " + fixed(entries, 0); };
    for (const Row& r : rows)
        s << "| " << r.method << " | " << (r.filter > 0 ? fixed(r.filter, 0) : "–") << " | " << fixed(r.sat_mb, 1) << " | "
          << fixed(r.tf_change_ms, 1) << " | " << rebuilt(r.tf_tables, r.tf_entries) << " | " << fixed(r.light_move_ms, 1) << " | "
          << rebuilt(r.move_tables, r.move_entries) << " | " << fixed(r.render_ms, 1) << " | "
          << (r.uncached_render_ms > 0 ? fixed(r.uncached_render_ms, 1) : "–") << " | " << sci(r.mean_error) << " | " << sci(r.max_error) << " |\n";
    return s.str();
}

std::string csv(const std::vector<Row>& rows) {
    std::ostringstream s;
    s << "method,filter,sat_mb,tf_change_ms,tf_tables_built,tf_entries_built,light_move_ms,move_tables_built,move_entries_built,"
         "render_ms,uncached_render_ms,mean_abs_error,max_abs_error\n";
    for (const Row& r : rows)
        s << r.method << ',' << r.filter << ',' << fixed(r.sat_mb, 3) << ',' << fixed(r.tf_change_ms, 3) << ','
          << r.tf_tables << ',' << r.tf_entries << ',' << fixed(r.light_move_ms, 3) << ',' << r.move_tables << ',' << r.move_entries
          << ',' << fixed(r.render_ms, 3) << ',' << fixed(r.uncached_render_ms, 3) << ',' << r.mean_error << ',' << r.max_error << '\n';
    return s.str();
}

int run(int argc, char** argv) {
    BenchOptions o;
    CLI::App app{"sombra low-pass filtered shadows: the analogue of Ament et al. 2014 Table 1"};
    app.add_option("--scene", o.scene, "scene file (JSON)");
    app.add_option("--width", o.width, "image width")->check(CLI::Range(1, 16384));
    app.add_option("--height", o.height, "image height")->check(CLI::Range(1, 16384));
    app.add_option("--runs", o.runs, "timed repetitions per row, after one warm-up")->check(CLI::PositiveNumber);
    app.add_option("--points", o.points, "random points in the volumes for the error against shadow rays")->check(CLI::PositiveNumber);
    app.add_option("--filter", o.filter, "filter width in voxels of the method rows")->check(CLI::Range(0.f, 4096.f));
    app.add_option("--cone-angle", o.cone_deg, "cone shadows: half angle in degrees")->check(CLI::Range(0.01f, 60.f));
    app.add_option("--widths", o.widths, "filter widths of the time-vs-width rows, comma-separated")->delimiter(',');
    app.add_option("--device", o.device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--out", o.out_dir, "write lowpass_table[_TAG].md and .csv into this folder");
    app.add_option("--lights", o.lights, "scene (the scene's lights), ortho3 (3 orthodirectional) or point2 (2 point lights)");
    app.add_option("--tag", o.tag, "suffix of the output files (lowpass_table_TAG.md)");
    CLI11_PARSE(app, argc, argv);

    sombra::Scene scene = sombra::load_scene(o.scene);
    set_lights(scene, o.lights);
    sombra::Context context(o.device);
    auto points = sombra::bench::random_points(scene, o.points, 7);
    std::vector<std::vector<double>> rays;
    sombra::RenderOptions ray_options;
    ray_options.shadows = sombra::ShadowTechnique::Rays;
    for (std::size_t l = 0; l < scene.lights.size(); ++l)
        rays.push_back(sombra::shadow_transmittance(context, scene, int(l), points, ray_options).transmittance);
    using T = sombra::ShadowTechnique;
    std::vector<Method> methods = {{"SS (shadow rays)", T::Rays}, {"AO (SAT)", T::Ao}, {"CS (SAT cones)", T::Cone},
                                   {"FS box (CSAT/SSAT)", T::Lowpass}, {"FS gauss (CSAT/SSAT)", T::Lowpass, "gauss"}};
    std::vector<Row> rows, widths;
    for (const Method& m : methods) {
        rows.push_back(measure(context, scene, o, m, m.technique == T::Rays || m.technique == T::Cone ? 0.f : o.filter, points, rays));
        std::cout << markdown({rows.back()}) << std::flush;
    }
    for (float w : o.widths) widths.push_back(measure(context, scene, o, methods[3], w, points, rays));
    std::string dims;
    for (const auto& vi : scene.volumes)
        dims += (dims.empty() ? "" : " + ") + std::to_string(vi.volume->dims[0]) + "×" + std::to_string(vi.volume->dims[1]) + "×" +
                std::to_string(vi.volume->dims[2]);
    std::string text = "## Methods (" + o.scene + ", " + dims + " voxels, lights: " + o.lights + " (" +
                       std::to_string(scene.lights.size()) + "), " + std::to_string(o.width) + "×" + std::to_string(o.height) +
                       ", " + context.device().name + ")\n\n" + markdown(rows) + "\n## Low-pass box filter: time and error against the filter width\n\n" +
                       markdown(widths);
    std::cout << "\n" << text;
    if (!o.out_dir.empty()) {
        std::filesystem::create_directories(o.out_dir);
        std::string name = "lowpass_table" + (o.tag.empty() ? std::string() : "_" + o.tag);
        sombra::bench::write_file(std::filesystem::path(o.out_dir) / (name + ".md"), text);
        std::vector<Row> all = rows;
        all.insert(all.end(), widths.begin(), widths.end());
        sombra::bench::write_file(std::filesystem::path(o.out_dir) / (name + ".csv"), csv(all));
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_lowpass", run, argc, argv); }
