// sombra_bench_cache — the shadow cache (render.h ShadowCacheMode) for every technique: with the
// lights fixed and the camera moving, the camera pass reading the cache against the unshadowed pass
// and against per-sample evaluation, the cache's fill time, and the difference the cache makes to
// the image. Per scene, every variant renders each camera pose in turn (one Context per variant,
// so each keeps its own preparation and cache); medians over the poses after a warm-up.
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <map>

#include <CLI/CLI.hpp>

#include "bench_util.h"
#include "render/preparation.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;
using sombra::bench::sci;

// The camera turned by `degrees` about the vertical through its look-at point (the scene's up).
sombra::Scene orbit(sombra::Scene scene, float degrees) {
    sombra::Camera& c = scene.camera;
    sombra::Vec3 axis = c.up;
    float n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (float& a : axis) a /= n;
    sombra::Vec3 v{c.position[0] - c.look_at[0], c.position[1] - c.look_at[1], c.position[2] - c.look_at[2]};
    float r = degrees * 3.14159265f / 180.f, cs = std::cos(r), sn = std::sin(r);
    float d = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    sombra::Vec3 cross{axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2], axis[0] * v[1] - axis[1] * v[0]};
    for (int a = 0; a < 3; ++a) c.position[a] = c.look_at[a] + v[a] * cs + cross[a] * sn + axis[a] * d * (1 - cs);
    return scene;
}

double wall_ms(const std::function<void()>& f) {
    auto start = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

struct Variant {
    std::string name;
    sombra::RenderOptions options;
    std::unique_ptr<sombra::Context> context;
    sombra::RenderResult first;                 // the warm-up frame: builds, fills the cache
    std::vector<double> camera_ms, frame_ms;    // per pose after the warm-up
    sombra::Image first_pose;  // compared across variants: every variant renders pose 1
};

double mean_abs_difference(const sombra::Image& a, const sombra::Image& b, double* max_abs) {
    double sum = 0;
    *max_abs = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        double d = std::abs(double(a.rgba[i]) - double(b.rgba[i]));
        sum += d, *max_abs = std::max(*max_abs, d);
    }
    return sum / double(a.rgba.size() / 4 * 3);
}

// The cache's value at voxel point v of entry e: trilinear over its lattice, as render.cl's
// cached_shadow reads it.
double cached_value(const sombra::pipeline::ShadowCache& cache, const std::vector<float>& values, std::size_t e, const float v[3]) {
    const ShadowCacheGpu& c = cache.layout[e];
    int i0[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        double q = std::clamp(double(v[a]) / c.spacing.s[a], 0.0, double(c.dims.s[a] - 1));
        i0[a] = std::min(int(q), std::max(c.dims.s[a] - 2, 0));
        f[a] = c.dims.s[a] > 1 ? q - i0[a] : 0.0;
    }
    double sum = 0;
    for (int corner = 0; corner < 8; ++corner) {
        double w = 1;
        std::size_t index = c.offset;
        std::size_t stride = 1;
        for (int a = 0; a < 3; ++a) {
            int bit = (corner >> a) & 1;
            w *= bit ? f[a] : 1 - f[a];
            index += std::size_t(std::min(i0[a] + bit, c.dims.s[a] - 1)) * stride;
            stride *= std::size_t(c.dims.s[a]);
        }
        sum += w * values[index];
    }
    return sum;
}

// Mean and max |ΔT| of the cached term and of the technique's own per-point term against the
// brute-force reference, at `count` random points in possibly visible bricks of the volumes
// (where camera samples are shaded and read the cache), every light. The Context holds the
// variant's filled cache.
struct PointErrors {
    double cached_mean = 0, cached_max = 0, direct_mean = 0, direct_max = 0;
};
PointErrors point_errors(sombra::Context& context, const sombra::Scene& scene, const sombra::RenderOptions& options, int count) {
    sombra::detail::KeptScenes& kept = context.kept_scenes();
    const sombra::pipeline::ShadowCache& cache = *kept.shadow_cache;
    const sombra::packing::PackedScene& packed = kept.prepared->packed;
    std::vector<float> values(cache.bytes / sizeof(float));
    context.runtime().queue().enqueueReadBuffer(cache.values, CL_TRUE, 0, cache.bytes, values.data());
    std::mt19937 rng(11);
    std::size_t lights = scene.lights.size();
    PointErrors e;
    int n = 0;
    for (std::size_t m = 0; m < lights; ++m) {
        std::vector<sombra::Vec3> points;
        std::vector<double> cached;
        while (int(points.size()) < count) {
            std::size_t i = std::uniform_int_distribution<std::size_t>(0, scene.volumes.size() - 1)(rng);
            const VolumeGpu& g = packed.volumes[i];
            float v[3];
            int brick[3];
            for (int a = 0; a < 3; ++a) {
                v[a] = std::uniform_real_distribution<float>(0.f, float(scene.volumes[i].volume->dims[std::size_t(a)] - 1))(rng);
                brick[a] = std::min(int(v[a]) / SOMBRA_BRICK_SIZE, g.brick_dims.s[a] - 1);
            }
            if (!packed.occupancy[g.brick_offset + std::size_t(brick[0] + g.brick_dims.s[0] * (brick[1] + g.brick_dims.s[1] * brick[2]))])
                continue;
            const auto& w = packed.voxel_to_world[i];
            sombra::Vec3 p;
            for (std::size_t r = 0; r < 3; ++r) p[r] = w[4 * r] * v[0] + w[4 * r + 1] * v[1] + w[4 * r + 2] * v[2] + w[4 * r + 3];
            points.push_back(p);
            cached.push_back(cached_value(cache, values, i * lights + m, v));
        }
        std::vector<double> reference = sombra::bench::reference_values(scene, int(m), points);
        std::vector<double> direct = sombra::shadow_transmittance(context, scene, int(m), points, options).transmittance;
        for (std::size_t k = 0; k < points.size(); ++k, ++n) {
            double dc = std::abs(cached[k] - reference[k]), dd = std::abs(direct[k] - reference[k]);
            e.cached_mean += dc, e.direct_mean += dd;
            e.cached_max = std::max(e.cached_max, dc), e.direct_max = std::max(e.direct_max, dd);
        }
    }
    e.cached_mean /= std::max(n, 1), e.direct_mean /= std::max(n, 1);
    return e;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app("sombra_bench_cache: the shadow cache for every technique, camera moving, lights fixed");
    std::vector<std::string> scenes = {SOMBRA_DATA_DIR "/scenes/default.json", SOMBRA_DATA_DIR "/scenes/smoke.json",
                                       SOMBRA_DATA_DIR "/scenes/cup_array.json"};
    std::vector<std::string> techniques = {"dsm", "shadowmap", "rays", "lowpass", "ao", "cone"};
    int size = 256, poses = 5, slow_poses = 1, points = 300;
    std::string device = "auto", out;
    app.add_option("--scene", scenes, "scene files")->capture_default_str();
    app.add_option("--shadows", techniques, "techniques")->capture_default_str();
    app.add_option("--size", size, "image width and height")->capture_default_str();
    app.add_option("--poses", poses, "camera poses timed after the warm-up (1° apart)")->capture_default_str();
    app.add_option("--slow-poses", slow_poses, "poses for per-sample evaluation of rays and cone (seconds each)")->capture_default_str();
    app.add_option("--device", device, "OpenCL device")->capture_default_str();
    app.add_option("--points", points, "random points per light for the error against the reference")->capture_default_str();
    app.add_option("--out", out, "also write the Markdown table here");
    CLI11_PARSE(app, argc, argv);

    std::ostringstream table;
    table << "| scene | technique | cache fill ms | camera pass cached ms (÷ none) | per sample ms (÷ none) | frame cached ms (÷ none) "
             "| image, cached vs per sample: mean / max |ΔRGB| | |ΔT| vs reference, cached: mean / max | per sample: mean / max |\n"
             "|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& path : scenes) {
        sombra::Scene scene = sombra::load_scene(path);
        std::vector<Variant> variants;
        auto add = [&](const std::string& name, const std::string& shadows, const std::string& cache) {
            Variant v;
            v.name = name;
            v.options.width = v.options.height = size;
            sombra::set_render_option(v.options, "shadows", shadows);
            sombra::set_render_option(v.options, "shadow_cache", cache);
            v.context = std::make_unique<sombra::Context>(device);
            variants.push_back(std::move(v));
        };
        add("none", "none", "off");
        for (const std::string& t : techniques) add(t + " cached", t, "on"), add(t + " per sample", t, "off");
        for (Variant& v : variants) v.first = sombra::render(*v.context, scene, v.options);  // warm-up: build, fill
        for (int pose = 1; pose <= poses; ++pose) {
            sombra::Scene moved = orbit(scene, float(pose));
            for (Variant& v : variants) {
                bool slow = v.name == "rays per sample" || v.name == "cone per sample";
                if (slow && pose > slow_poses) continue;
                sombra::RenderResult r;
                v.frame_ms.push_back(wall_ms([&] { r = sombra::render(*v.context, moved, v.options); }));
                v.camera_ms.push_back(r.stats.stage_ms.at("camera_pass"));
                if (r.stats.shadow_cache_entries_built + r.stats.shadow_cache_surface_entries_built > 0)
                    std::cerr << "warning: " << v.name << " refilled its cache on a camera move\n";
                if (pose == 1) v.first_pose = std::move(r.image);
            }
        }
        double none_camera = median(variants[0].camera_ms), none_frame = median(variants[0].frame_ms);
        std::string scene_name = std::filesystem::path(path).stem().string();
        table << "| " << scene_name << " | none | | " << fixed(none_camera, 0) << " | | " << fixed(none_frame, 0) << " | | | |\n";
        for (std::size_t k = 1; k + 1 < variants.size(); k += 2) {
            Variant& cached = variants[k];
            Variant& direct = variants[k + 1];
            double max_abs = 0;
            double mean_abs = mean_abs_difference(cached.first_pose, direct.first_pose, &max_abs);
            double fill = cached.first.stats.stage_ms.count("shadow_cache") ? cached.first.stats.stage_ms.at("shadow_cache") : 0;
            PointErrors pe = point_errors(*cached.context, orbit(scene, float(poses)), cached.options, points);
            double c = median(cached.camera_ms), d = median(direct.camera_ms), f = median(cached.frame_ms);
            table << "| " << scene_name << " | " << cached.name.substr(0, cached.name.find(' ')) << " | " << fixed(fill, 0) << " | "
                  << fixed(c, 0) << " (" << fixed(c / none_camera, 2) << "×) | " << fixed(d, 0) << " (" << fixed(d / none_camera, 2)
                  << "×) | " << fixed(f, 0) << " (" << fixed(f / none_frame, 2) << "×) | " << sci(mean_abs) << " / " << sci(max_abs)
                  << " | " << sci(pe.cached_mean) << " / " << sci(pe.cached_max) << " | " << sci(pe.direct_mean) << " / "
                  << sci(pe.direct_max) << " |\n";
        }
        std::cout << table.str() << std::flush;
    }
    if (!out.empty()) sombra::bench::write_file(out, table.str());
    return 0;
}
