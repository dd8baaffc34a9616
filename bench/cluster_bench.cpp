// sombra_bench_clusters — clustered deep shadow maps (Knecht 2011 §3.4) against one map per light
// view, in one run:
//  1. Quality at equal memory (Knecht Fig. 5.5–5.7): cup_array seen from close to one cup, from an
//     oblique pose and from the scene's own (far) camera. One query per pixel of a coarse grid at
//     the first visible point — the first mesh hit of a host ray cast, or the first sample of a
//     steam volume where the accumulated opacity passes ½ — offset towards the camera; the
//     technique's transmittance there (sombra::shadow_transmittance, the camera pass's kernel
//     code) against sombra::reference_transmittance, per light: mean and 95th percentile |ΔT| over
//     all pixels and over the nearest third of them. The same points for every variant.
//  2. Tables 5.2 / 5.4 analogue: DSM resolution × clustering on/off × storage backend: clustering
//     time, generation time, camera-pass time, bytes used (medians of OpenCL profiling events;
//     the prepared scene is dropped before every render, so each one clusters and builds anew).
//  3. Optionally (--images DIR) renders of one pose (--image-pose; the close one by default), unclustered and clustered, side by side
//     with a zoomed crop, and per-pixel |ΔT| maps of the quality grid.
// See bench/README.md ("Clustered deep shadow maps") and bench/results/clusters.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <thread>

#include "bench_util.h"
#include "geometry/scene_upload.h"
#include "host/guarded_main.h"
#include "sombra/sombra.h"

namespace {

using sombra::Vec3;
using sombra::bench::fixed;
using sombra::bench::forget_preparation;
using sombra::bench::median;
using sombra::bench::sci;

// ---- small vector helpers (float, world units) ----

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 operator*(float s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
Vec3 normalized(const Vec3& a) { return (1.f / std::sqrt(dot(a, a))) * a; }

Vec3 transformed(const std::array<float, 16>& m, const std::array<float, 3>& p) {
    Vec3 r;
    for (int i = 0; i < 3; ++i) r[i] = m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3];
    return r;
}

// Entry and exit parameters of origin + t·dir through the box [lo, hi] (slab method); empty: t1 < t0.
std::pair<float, float> slab(const Vec3& origin, const Vec3& dir, const Vec3& lo, const Vec3& hi) {
    float t0 = 0.f, t1 = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a) {
        float inv = 1.f / dir[a];  // ±inf for an axis-parallel ray: the comparisons still hold
        float ta = (lo[a] - origin[a]) * inv, tb = (hi[a] - origin[a]) * inv;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    }
    return {t0, t1};
}

// ---- the host ray caster: first mesh hit, then the steam in front of it ----

struct WorldMesh {
    std::vector<std::array<Vec3, 3>> triangles;
    Vec3 lo{}, hi{};
};

std::vector<WorldMesh> world_meshes(const sombra::Scene& scene) {
    std::vector<WorldMesh> out;
    for (const sombra::MeshInstance& mi : scene.meshes) {
        WorldMesh w;
        w.lo = {INFINITY, INFINITY, INFINITY}, w.hi = {-INFINITY, -INFINITY, -INFINITY};
        for (const auto& t : mi.mesh->triangles) {
            std::array<Vec3, 3> tri;
            for (int c = 0; c < 3; ++c) {
                tri[c] = transformed(mi.transform, mi.mesh->positions[t[c]]);
                for (int a = 0; a < 3; ++a) w.lo[a] = std::min(w.lo[a], tri[c][a]), w.hi[a] = std::max(w.hi[a], tri[c][a]);
            }
            w.triangles.push_back(tri);
        }
        out.push_back(std::move(w));
    }
    return out;
}

// Möller–Trumbore, both faces: t of the hit or +inf.
float ray_triangle(const Vec3& o, const Vec3& d, const std::array<Vec3, 3>& tri) {
    Vec3 e1 = tri[1] - tri[0], e2 = tri[2] - tri[0], p = cross(d, e2);
    float det = dot(e1, p);
    if (std::fabs(det) < 1e-12f) return INFINITY;
    float inv = 1.f / det;
    Vec3 s = o - tri[0];
    float u = dot(s, p) * inv;
    if (u < 0.f || u > 1.f) return INFINITY;
    Vec3 q = cross(s, e1);
    float v = dot(d, q) * inv;
    if (v < 0.f || u + v > 1.f) return INFINITY;
    float t = dot(e2, q) * inv;
    return t > 0.f ? t : INFINITY;
}

float first_mesh_hit(const std::vector<WorldMesh>& meshes, const Vec3& o, const Vec3& d) {
    float best = INFINITY;
    for (const WorldMesh& m : meshes) {
        auto [t0, t1] = slab(o, d, m.lo, m.hi);
        if (t1 < t0 || t0 >= best) continue;
        for (const auto& tri : m.triangles) best = std::min(best, ray_triangle(o, d, tri));
    }
    return best;
}

// Trilinear sample at continuous voxel coordinates (centres at integers), clamped to the edges.
float trilinear(const sombra::Volume& v, const Vec3& x) {
    int lo[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
        float c = std::clamp(x[a], 0.f, float(v.dims[a] - 1));
        lo[a] = std::min(int(c), std::max(v.dims[a] - 2, 0));
        f[a] = v.dims[a] > 1 ? c - float(lo[a]) : 0.f;
    }
    float sum = 0;
    for (int corner = 0; corner < 8; ++corner) {
        float w = 1;
        int i[3];
        for (int a = 0; a < 3; ++a) {
            int bit = (corner >> a) & 1;
            w *= bit ? f[a] : 1 - f[a];
            i[a] = std::min(lo[a] + bit, v.dims[a] - 1);
        }
        sum += w * v.at(i[0], i[1], i[2]);
    }
    return sum;
}

// Where along the camera ray (before t_limit) the steam's accumulated opacity first exceeds ½:
// the volumes' boxes in order of entry (they do not overlap in cup_array; overlapping ones would
// be marched one after the other), each marched at its own camera step with σ = −ln(1 − α)/unit.
// +inf when the ray keeps more than half its transmittance. Polyhedral bounds are ignored.
float half_opacity_depth(const sombra::Scene& scene, const sombra::packing::PackedScene& packed, const Vec3& o, const Vec3& d,
                         float t_limit) {
    struct Span {
        float t0, t1;
        std::size_t volume;
    };
    std::vector<Span> spans;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeGpu& g = packed.volumes[i];
        Vec3 vo, vd;  // the ray in voxel coordinates (same parameter t)
        for (int r = 0; r < 3; ++r) {
            const auto& row = g.world_to_voxel[r].s;
            vo[r] = row[0] * o[0] + row[1] * o[1] + row[2] * o[2] + row[3];
            vd[r] = row[0] * d[0] + row[1] * d[1] + row[2] * d[2];
        }
        Vec3 hi{float(g.dims.s[0]) - 0.5f, float(g.dims.s[1]) - 0.5f, float(g.dims.s[2]) - 0.5f};
        auto [t0, t1] = slab(vo, vd, {-0.5f, -0.5f, -0.5f}, hi);
        t1 = std::min(t1, t_limit);
        if (t1 > t0) spans.push_back({t0, t1, i});
    }
    std::sort(spans.begin(), spans.end(), [](const Span& a, const Span& b) { return a.t0 < b.t0; });
    double transmittance = 1;
    for (const Span& s : spans) {
        const sombra::VolumeInstance& vi = scene.volumes[s.volume];
        const VolumeGpu& g = packed.volumes[s.volume];
        float unit = vi.opacity_unit > 0 ? vi.opacity_unit : g.step / std::max(vi.step_voxels, 1e-6f);
        for (float t = s.t0 + 0.5f * g.step; t < s.t1; t += g.step) {
            Vec3 p = o + t * d, x;
            for (int r = 0; r < 3; ++r) {
                const auto& row = g.world_to_voxel[r].s;
                x[r] = row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + row[3];
            }
            double alpha = std::clamp(double(vi.transfer_function.opacity(trilinear(*vi.volume, x))), 0.0, 0.999999);
            transmittance *= std::exp(std::log1p(-alpha) * g.step / unit);
            if (transmittance < 0.5) return t;
        }
    }
    return INFINITY;
}

// One query point per grid pixel that sees something.
struct ViewPoints {
    std::vector<Vec3> points;
    std::vector<float> depth;       // distance from the camera
    std::vector<int> pixel;         // y·width + x
    std::vector<bool> in_volume;    // the steam's ½-opacity point, else a mesh surface
    int width = 0, height = 0;
    float near_depth = 0;           // depths ≤ this: the nearest third
};

// `offset`: the fraction of the meshes' box diagonal by which each point moves back towards the
// camera (onto the lit side of a surface, away from its own depth in the maps).
ViewPoints visible_points(const sombra::Scene& scene, int width, int height, float offset_fraction) {
    const std::vector<WorldMesh> meshes = world_meshes(scene);
    const sombra::packing::PackedScene packed = sombra::packing::pack_scene(scene);
    const CameraGpu cam = sombra::packing::pack_camera(scene, width, height);
    Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const WorldMesh& m : meshes)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], m.lo[a]), hi[a] = std::max(hi[a], m.hi[a]);
    const float offset = offset_fraction * std::sqrt(dot(hi - lo, hi - lo));
    const Vec3 origin = scene.camera.position;
    ViewPoints v;
    v.width = width, v.height = height;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            // the kernel's pinhole camera through the pixel centres (cl/render.cl)
            float sx = ((float(x) + 0.5f) / float(width)) * 2.f - 1.f, sy = 1.f - ((float(y) + 0.5f) / float(height)) * 2.f;
            Vec3 d;
            for (int a = 0; a < 3; ++a) d[a] = cam.forward.s[a] + sy * cam.up.s[a] + sx * cam.right.s[a];
            d = normalized(d);
            float t_mesh = first_mesh_hit(meshes, origin, d);
            float t_steam = half_opacity_depth(scene, packed, origin, d, t_mesh);
            float t = std::min(t_mesh, t_steam);
            if (!std::isfinite(t)) continue;
            v.points.push_back(origin + std::max(t - offset, 0.f) * d);
            v.depth.push_back(t);
            v.pixel.push_back(y * width + x);
            v.in_volume.push_back(t_steam < t_mesh);
        }
    std::vector<float> sorted = v.depth;
    std::sort(sorted.begin(), sorted.end());
    v.near_depth = sorted.empty() ? 0.f : sorted[sorted.size() / 3];
    return v;
}

// ---- viewpoints ----

struct Viewpoint {
    std::string name;
    sombra::Camera camera;
};

sombra::Camera camera(const Vec3& position, const Vec3& look_at, float fov) {
    sombra::Camera c;
    c.position = position, c.look_at = look_at, c.up = {0, 0, 1}, c.fov_y_deg = fov;
    return c;
}

// (a) close to cup_3 (31, −93), its own and its steam's spot-light shadows falling towards the
// camera; (b) oblique and low across the array from its +x, −y corner, where the spot light's
// shadows fall towards the camera too; (c) the scene's own overview.
std::vector<Viewpoint> viewpoints(const sombra::Scene& scene) {
    return {{"a close", camera({95, -175, 55}, {35, -95, 8}, 45)},
            {"b oblique", camera({240, -215, 40}, {0, 0, 10}, 40)},
            {"c far", scene.camera}};
}

// ---- variants ----

struct Variant {
    int clusters = 0, resolution = 1024;
    std::string label() const {
        return (clusters ? std::to_string(clusters) + " clusters × " : "1 map/view × ") + std::to_string(resolution) + "²";
    }
};

std::vector<Variant> parse_variants(const std::vector<std::string>& specs) {
    std::vector<Variant> out;
    for (const std::string& s : specs) {
        auto x = s.find('x');
        if (x == std::string::npos) throw sombra::Error("--variants: '" + s + "' is not MxRES (e.g. 4x512)");
        out.push_back({std::stoi(s.substr(0, x)), std::stoi(s.substr(x + 1))});
    }
    return out;
}

sombra::RenderOptions dsm_options(const Variant& v, int width, int height, const std::string& storage) {
    sombra::RenderOptions o;
    o.width = width, o.height = height;
    o.shadows = sombra::ShadowTechnique::Dsm;
    o.dsm.resolution = v.resolution;
    o.dsm.clusters = v.clusters;
    o.dsm.storage = storage;
    return o;
}

// ---- 1. quality ----

// lit: the points the reference sees lit (T ≥ 0.99), where any error is false shadow (acne);
// shadowed: the others.
struct ErrorStats {
    double mean = 0, p95 = 0, near_mean = 0, near_p95 = 0, lit_mean = 0, shadowed_mean = 0, max = 0;
    std::size_t lit = 0, gross = 0;  // gross: |ΔT| > 0.5
};

double percentile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5))];
}

double mean_of(const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0 : s / double(v.size());
}

ErrorStats error_stats(const ViewPoints& v, const std::vector<double>& technique, const std::vector<double>& reference) {
    std::vector<double> all, near, lit, shadowed;
    ErrorStats e;
    for (std::size_t i = 0; i < technique.size(); ++i) {
        double d = std::abs(technique[i] - reference[i]);
        all.push_back(d);
        if (v.depth[i] <= v.near_depth) near.push_back(d);
        (reference[i] >= 0.99 ? lit : shadowed).push_back(d);
        e.max = std::max(e.max, d);
        e.gross += d > 0.5;
    }
    e.mean = mean_of(all), e.p95 = percentile(all, 0.95), e.near_mean = mean_of(near), e.near_p95 = percentile(near, 0.95);
    e.lit_mean = mean_of(lit), e.shadowed_mean = mean_of(shadowed), e.lit = lit.size();
    return e;
}

// |ΔT| per grid pixel as a grey image (white = 0.5 or more; background blue), for --images.
void write_error_map(const ViewPoints& v, const std::vector<double>& technique, const std::vector<double>& reference,
                     const std::string& path) {
    sombra::Image image;
    image.width = v.width, image.height = v.height;
    image.rgba.assign(std::size_t(v.width * v.height) * 4, 0.f);
    for (std::size_t p = 0; p < image.rgba.size(); p += 4) image.rgba[p + 2] = 0.15f, image.rgba[p + 3] = 1.f;
    for (std::size_t i = 0; i < technique.size(); ++i) {
        float g = float(std::min(1.0, 2.0 * std::abs(technique[i] - reference[i])));
        float* px = &image.rgba[std::size_t(v.pixel[i]) * 4];
        px[0] = px[1] = px[2] = g;
    }
    sombra::write_image(image, path);
}

struct QualityRow {
    std::string viewpoint, light, variant;
    std::size_t points = 0, volume_points = 0, near_points = 0;
    int views = 0;
    unsigned long long texels = 0, bytes = 0;
    ErrorStats error;
};

std::string quality_table(const std::vector<QualityRow>& rows) {
    std::ostringstream s;
    s << "| viewpoint | light | variant | views | texels | bytes used (all lights) | points (steam) | near | lit | mean ΔT | p95 ΔT | near mean "
         "| near p95 | lit mean | shadowed mean | max | points ΔT > 0.5 |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const QualityRow& r : rows)
        s << "| " << r.viewpoint << " | " << r.light << " | " << r.variant << " | " << r.views << " | " << r.texels << " | " << r.bytes << " | "
          << r.points << " (" << r.volume_points << ") | " << r.near_points << " | " << r.error.lit << " | "
          << fixed(r.error.mean, 4) << " | " << fixed(r.error.p95, 4) << " | " << fixed(r.error.near_mean, 4) << " | "
          << fixed(r.error.near_p95, 4) << " | " << fixed(r.error.lit_mean, 4) << " | " << fixed(r.error.shadowed_mean, 4) << " | "
          << fixed(r.error.max, 3) << " | " << r.error.gross << " |\n";
    return s.str();
}

// The scene as seen from one viewpoint: the clusters follow the camera (objects that cannot shadow
// what it sees are left out), and the camera's aspect is the grid's.
sombra::Scene posed(sombra::Scene scene, const sombra::Camera& camera, int width, int height) {
    scene.camera = camera;
    scene.width = width, scene.height = height;
    return scene;
}

std::string light_name(const sombra::Scene& scene, std::size_t light) {
    const char* type = scene.lights[light].type == sombra::LightType::Spot    ? "spot "
                       : scene.lights[light].type == sombra::LightType::Point ? "point "
                                                                              : "directional ";
    return type + std::to_string(light);
}

// One line per light: its clusters (members, views and their fields of view) and the objects left out.
std::string describe_clusters(const sombra::Scene& scene, const sombra::RenderStats& stats) {
    std::ostringstream s;
    for (std::size_t light = 0; light < scene.lights.size(); ++light) {
        s << "  - " << light_name(scene, light) << ":";
        for (const auto& c : stats.dsm_clusters) {
            if (c.light != int(light)) continue;
            s << " [" << c.members.size() << " objects" << (c.members.size() == 1 ? " (" + c.members[0] + ")" : "") << ":";
            for (const auto& v : c.views)
                s << " " << (v.orthographic ? fixed(2 * v.half_width, 0) + "×" + fixed(2 * v.half_height, 0)
                                            : fixed(v.fov_x_deg, 0) + "°×" + fixed(v.fov_y_deg, 0) + "°");
            s << "]";
        }
        if (light < stats.dsm_ignored_objects.size()) s << "; left out: " << stats.dsm_ignored_objects[light].size();
        s << "\n";
    }
    return s.str();
}

// Per viewpoint and offset, the visible points and each light's reference there; per variant one
// build (the prepared scene is dropped first), then every light's and offset's queries on it.
struct Quality {
    std::vector<std::vector<QualityRow>> rows;  // per offset
    std::string clusters;                       // describe_clusters per viewpoint and clustered variant
};

Quality measure_quality(sombra::Context& context, const sombra::Scene& scene, const std::vector<Variant>& variants, int grid_width,
                        int grid_height, const std::vector<float>& offsets, const std::string& poses, const std::string& map_dir) {
    Quality out;
    out.rows.resize(offsets.size());
    for (const Viewpoint& vp : viewpoints(scene)) {
        if (poses.find(vp.name[0]) == std::string::npos) continue;
        sombra::Scene s = posed(scene, vp.camera, grid_width, grid_height);
        std::vector<ViewPoints> points;
        std::vector<std::vector<std::vector<double>>> reference;  // [offset][light][point]
        for (float offset : offsets) {
            points.push_back(visible_points(s, grid_width, grid_height, offset));
            reference.emplace_back();
            for (std::size_t light = 0; light < s.lights.size(); ++light)
                reference.back().push_back(sombra::bench::reference_values(s, int(light), points.back().points));
        }
        for (const Variant& variant : variants) {
            forget_preparation(context, s);  // each variant clusters and builds for this pose
            const sombra::RenderOptions options = dsm_options(variant, grid_width, grid_height, "atlas");
            for (std::size_t k = 0; k < offsets.size(); ++k) {
                const ViewPoints& v = points[k];
                std::size_t volume_points = std::count(v.in_volume.begin(), v.in_volume.end(), true), near_points = 0;
                for (float d : v.depth) near_points += d <= v.near_depth;
                for (std::size_t light = 0; light < s.lights.size(); ++light) {
                    sombra::ShadowQuery q = sombra::shadow_transmittance(context, s, int(light), v.points, options);
                    if (k == 0 && light == 0 && variant.clusters > 0)
                        out.clusters += "- " + vp.name + ", " + variant.label() + ":\n" + describe_clusters(s, q.stats);
                    QualityRow r{vp.name, light_name(s, light), variant.label(), v.points.size(), volume_points, near_points, 0, 0, 0, {}};
                    // this light's views: the clusters' (the stats list them per light), or 1 / 6
                    for (const auto& c : q.stats.dsm_clusters) r.views += c.light == int(light) ? int(c.views.size()) : 0;
                    if (variant.clusters == 0) r.views = s.lights[light].type == sombra::LightType::Point ? 6 : 1;
                    r.texels = (unsigned long long)r.views * (unsigned long long)variant.resolution * (unsigned long long)variant.resolution;
                    r.bytes = q.stats.dsm_bytes_used;  // all lights' maps
                    r.error = error_stats(v, q.transmittance, reference[k][light]);
                    out.rows[k].push_back(r);
                    std::cout << vp.name << ", offset " << offsets[k] << ", " << r.light << ", " << r.variant << ": mean "
                              << fixed(r.error.mean, 4) << ", near mean " << fixed(r.error.near_mean, 4) << ", lit mean "
                              << fixed(r.error.lit_mean, 4) << ", shadowed mean " << fixed(r.error.shadowed_mean, 4) << std::endl;
                    if (!map_dir.empty())
                        write_error_map(v, q.transmittance, reference[k][light],
                                        map_dir + "/cluster_error_" + vp.name.substr(0, 1) + "_offset" + std::to_string(k) + "_light" + std::to_string(light) +
                                            "_m" + std::to_string(variant.clusters) + "_r" + std::to_string(variant.resolution) + ".png");
                }
            }
        }
    }
    return out;
}

// ---- 2. timing ----

struct TimingRow {
    int resolution = 0, clusters = 0;
    std::string storage;
    int views = 0;
    double clustering_ms = 0, generation_ms = 0, camera_ms = 0, wall_ms = 0;
    unsigned long long bytes = 0;
};

// The row of one variant from its timed renders (each clustered and built anew).
TimingRow timing_row(const sombra::RenderOptions& options, const std::vector<sombra::bench::TimedRender>& renders) {
    std::vector<double> clustering, generation, camera, wall;
    for (const sombra::bench::TimedRender& timed : renders) {
        const sombra::RenderStats& stats = timed.stats;
        wall.push_back(timed.wall_ms);
        double gen = 0;
        for (const auto& [stage, ms] : stats.stage_ms)
            if (stage.rfind("dsm_", 0) == 0 && stage != "dsm_clustering") gen += ms;
        if (gen == 0 || stats.dsm_views_generated == 0) throw sombra::Error("a timed render built no deep shadow map");
        generation.push_back(gen);
        camera.push_back(stats.stage_ms.at("camera_pass"));
        clustering.push_back(stats.stage_ms.count("dsm_clustering") ? stats.stage_ms.at("dsm_clustering") : 0.0);
    }
    TimingRow r;
    r.resolution = options.dsm.resolution, r.clusters = options.dsm.clusters, r.storage = options.dsm.storage;
    r.views = renders.back().stats.dsm_views, r.bytes = renders.back().stats.dsm_bytes_used;
    r.clustering_ms = median(clustering), r.generation_ms = median(generation), r.camera_ms = median(camera), r.wall_ms = median(wall);
    return r;
}

// Every variant warmed up once, then `runs` rounds in which each renders once, building anew:
// the variants side by side in time, so that the load of a shared machine reaches them alike.
std::vector<TimingRow> measure_timing(sombra::Context& context, const sombra::Scene& scene,
                                      const std::vector<sombra::RenderOptions>& variants, int runs) {
    std::vector<std::vector<sombra::bench::TimedRender>> renders(variants.size());
    for (const sombra::RenderOptions& o : variants) sombra::bench::fresh_renders(context, scene, o, 0);
    for (int run = 0; run < runs; ++run)
        for (std::size_t v = 0; v < variants.size(); ++v) {
            renders[v].push_back(sombra::bench::fresh_renders(context, scene, variants[v], 1, false).front());
            const sombra::RenderStats& st = renders[v].back().stats;
            std::cout << "run " << run + 1 << ", " << variants[v].dsm.resolution << "² "
                      << (variants[v].dsm.clusters ? std::to_string(variants[v].dsm.clusters) + " clusters" : "unclustered")
                      << " " << variants[v].dsm.storage << ": camera " << fixed(st.stage_ms.at("camera_pass"), 1) << " ms, wall "
                      << fixed(renders[v].back().wall_ms, 0) << " ms" << std::endl;
        }
    std::vector<TimingRow> rows;
    for (std::size_t v = 0; v < variants.size(); ++v) rows.push_back(timing_row(variants[v], renders[v]));
    return rows;
}

std::string timing_table(const std::vector<TimingRow>& rows) {
    std::ostringstream s;
    s << "| DSM res | clusters | storage | views | clustering ms | generation ms | camera pass ms | wall ms | bytes used |\n"
         "|---:|---:|---|---:|---:|---:|---:|---:|---:|\n";
    for (const TimingRow& r : rows)
        s << "| " << r.resolution << " | " << (r.clusters ? std::to_string(r.clusters) : "off") << " | " << r.storage << " | "
          << r.views << " | " << fixed(r.clustering_ms, 2) << " | " << fixed(r.generation_ms, 1) << " | " << fixed(r.camera_ms, 1)
          << " | " << fixed(r.wall_ms, 0) << " | " << r.bytes << " |\n";
    return s.str();
}

// ---- 3. images ----

// Copies the w × h block of `from` at (x0, y0), scaled by `zoom` (nearest), to `to` at (tx, ty).
void blit(const sombra::Image& from, int x0, int y0, int w, int h, int zoom, sombra::Image& to, int tx, int ty) {
    for (int y = 0; y < h * zoom; ++y)
        for (int x = 0; x < w * zoom; ++x) {
            int sx = std::clamp(x0 + x / zoom, 0, from.width - 1), sy = std::clamp(y0 + y / zoom, 0, from.height - 1);
            int dx = tx + x, dy = ty + y;
            if (dx < 0 || dy < 0 || dx >= to.width || dy >= to.height) continue;
            std::copy_n(&from.rgba[std::size_t(sy * from.width + sx) * 4], 4, &to.rgba[std::size_t(dy * to.width + dx) * 4]);
        }
}

// One pose rendered with shadow rays (the reference technique) and by the first two
// variants, side by side, and below each the crop (x, y, w, h) zoomed by width / w.
void write_close_ups(sombra::Context& context, const sombra::Scene& scene, const std::vector<Variant>& variants, int width,
                     int height, const std::vector<int>& crop, std::size_t pose, const std::string& dir) {
    const Viewpoint vp = viewpoints(scene).at(pose);
    sombra::Scene s = posed(scene, vp.camera, width, height);
    const std::string tag = vp.name.substr(0, 1);
    const int zoom = std::max(1, width / crop[2]);
    std::vector<std::pair<std::string, sombra::RenderOptions>> renders;
    sombra::RenderOptions rays = dsm_options({}, width, height, "atlas");
    rays.shadows = sombra::ShadowTechnique::Rays;
    renders.emplace_back("rays", rays);
    for (std::size_t k = 0; k < 2 && k < variants.size(); ++k)
        renders.emplace_back("m" + std::to_string(variants[k].clusters) + "_r" + std::to_string(variants[k].resolution),
                             dsm_options(variants[k], width, height, "atlas"));
    sombra::Image sheet;
    sheet.width = int(renders.size()) * width, sheet.height = height + crop[3] * zoom;
    sheet.background = s.background;
    sheet.rgba.assign(std::size_t(sheet.width * sheet.height) * 4, 1.f);
    for (std::size_t k = 0; k < renders.size(); ++k) {
        forget_preparation(context, s);
        sombra::Image image = sombra::render(context, s, renders[k].second).image;
        blit(image, 0, 0, width, height, 1, sheet, int(k) * width, 0);
        blit(image, crop[0], crop[1], crop[2], crop[3], zoom, sheet, int(k) * width, height);
        for (int x = crop[0]; x < crop[0] + crop[2]; ++x)  // the crop's outline in the full view
            for (int y : {crop[1], crop[1] + crop[3] - 1})
                if (x < width && y < height) std::fill_n(&sheet.rgba[std::size_t(y * sheet.width + int(k) * width + x) * 4], 3, 1.f);
        for (int y = crop[1]; y < crop[1] + crop[3]; ++y)
            for (int x : {crop[0], crop[0] + crop[2] - 1})
                if (x < width && y < height) std::fill_n(&sheet.rgba[std::size_t(y * sheet.width + int(k) * width + x) * 4], 3, 1.f);
    }
    sombra::write_image(sheet, dir + "/cup_array_clusters_pose_" + tag + ".png");
}

int run(int argc, char** argv) {
    std::string scene_path = SOMBRA_DATA_DIR "/scenes/cup_array.json", device = "auto", out, image_dir, map_dir, poses = "abc";
    std::vector<std::string> variant_specs{"0x1024", "4x512", "2x724"};
    std::vector<int> resolutions{256, 512, 1024};
    std::vector<std::string> storages{"atlas", "chunked"};
    std::vector<float> offsets{1e-3f, 1e-2f};
    int grid_width = 96, grid_height = 64, width = 240, height = 160, runs = 3, clusters = 4;
    int image_width = 360, image_height = 240, image_pose = 0;
    std::vector<int> crop{112, 127, 180, 112};
    bool quick = false, no_quality = false, no_timing = false;
    CLI::App app{"sombra clustered deep shadow maps (Knecht §3.4): quality at equal memory and build/render times"};
    app.add_option("--scene", scene_path, "scene file")->capture_default_str();
    app.add_option("--variants", variant_specs, "quality variants CLUSTERSxRESOLUTION (0: one map per light view)")
        ->delimiter(',')
        ->capture_default_str();
    app.add_option("--grid-width", grid_width, "quality grid pixels across")->capture_default_str()->check(CLI::Range(1, 4096));
    app.add_option("--grid-height", grid_height, "quality grid pixels down")->capture_default_str()->check(CLI::Range(1, 4096));
    app.add_option("--offsets", offsets, "quality: offsets of the points towards the camera, fractions of the meshes' box diagonal")
        ->delimiter(',')
        ->capture_default_str();
    app.add_option("--resolutions", resolutions, "timing: DSM resolutions")->delimiter(',')->capture_default_str();
    app.add_option("--clusters", clusters, "timing: clusters of the clustered rows")->capture_default_str()->check(CLI::Range(1, 64));
    app.add_option("--storages", storages, "timing: DSM storage backends")->delimiter(',')->capture_default_str();
    app.add_option("--width", width, "timing: image width")->capture_default_str()->check(CLI::Range(1, 16384));
    app.add_option("--height", height, "timing: image height")->capture_default_str()->check(CLI::Range(1, 16384));
    app.add_option("--runs", runs, "timing: timed renders per row after one warm-up")->capture_default_str()->check(CLI::PositiveNumber);
    app.add_flag("--quick", quick, "48×32 grid, variants 0x1024,4x512, resolutions 256,512, atlas only, 2 runs");
    app.add_flag("--no-quality", no_quality, "skip part 1");
    app.add_flag("--no-timing", no_timing, "skip part 2");
    app.add_option("--poses", poses, "quality: the poses, by letter (a close, b oblique, c far)")->capture_default_str();
    app.add_option("--images", image_dir, "write a sheet of one pose rendered with rays and the first two variants here");
    app.add_option("--error-maps", map_dir, "write the quality grid's per-pixel |ΔT| maps here (white: 0.5 or more)");
    app.add_option("--image-width", image_width, "renders for --images")->capture_default_str();
    app.add_option("--image-height", image_height, "renders for --images")->capture_default_str();
    app.add_option("--image-pose", image_pose, "pose of the --images renders: 0 close, 1 oblique, 2 far")->capture_default_str()->check(CLI::Range(0, 2));
    app.add_option("--crop", crop, "close-up x,y,w,h in the --images renders")->delimiter(',')->expected(4)->capture_default_str();
    app.add_option("--device", device, "OpenCL device")->capture_default_str();
    app.add_option("--out", out, "also write the Markdown tables here");
    CLI11_PARSE(app, argc, argv);
    if (quick) {
        grid_width = 48, grid_height = 32, variant_specs = {"0x1024", "4x512"}, resolutions = {256, 512}, storages = {"atlas"};
        runs = 2;
    }
    const std::vector<Variant> variants = parse_variants(variant_specs);
    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);

    const sombra::Scene scene = sombra::load_scene(scene_path);
    sombra::Context context(device);
    std::ostringstream report;
    report << "command: `" << command << "`  \ndevice: " << context.device().name << " [" << context.device().platform << "], "
           << std::thread::hardware_concurrency() << " cores\n\n";
    for (const std::string& dir : {image_dir, map_dir})
        if (!dir.empty()) std::filesystem::create_directories(dir);
    if (!no_quality) {
        Quality q = measure_quality(context, scene, variants, grid_width, grid_height, offsets, poses, map_dir);
        for (std::size_t k = 0; k < offsets.size(); ++k) {
            report << "Quality at equal memory, points offset by " << offsets[k] << " of the meshes' box diagonal towards the camera ("
                   << grid_width << "×" << grid_height
                   << " grid, one point per pixel that sees something; |ΔT| against reference_transmittance; near: the nearest "
                      "third of the points by depth; lit: the points with reference T ≥ 0.99; ΔT: the absolute difference):\n\n"
                   << quality_table(q.rows[k]) << "\n";
            std::cout << "\n" << quality_table(q.rows[k]) << std::flush;
        }
        report << "Clusters per pose (members; each view's field of view; objects left out because they cannot shadow what "
                  "the camera sees):\n\n"
               << q.clusters << "\n";
        std::cout << "\n" << q.clusters << std::flush;
    }
    if (!no_timing) {
        std::vector<sombra::RenderOptions> timed;
        for (int res : resolutions)
            for (int m : {0, clusters})
                for (const std::string& storage : storages) {
                    timed.push_back(dsm_options({m, res}, width, height, storage));
                    timed.back().shadow_cache = sombra::ShadowCacheMode::Off;  // camera pass = per-sample lookups
                }
        std::vector<TimingRow> rows = measure_timing(context, posed(scene, scene.camera, width, height), timed, runs);
        report << "Build and render times (Knecht Tables 5.2 / 5.4 analogue; the scene's own camera, " << width << "×" << height
               << ", shadow cache off; medians of " << runs
               << " rounds after 1 warm-up, each variant rendering once per round and clustering and building anew; "
                  "clustering is host wall time, the other columns OpenCL profiling times but wall ms):\n\n"
               << timing_table(rows) << "\n";
        std::cout << "\n" << timing_table(rows) << std::flush;
    }
    if (!image_dir.empty()) write_close_ups(context, scene, variants, image_width, image_height, crop, std::size_t(image_pose), image_dir);
    if (!out.empty()) sombra::bench::write_file(out, report.str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_clusters", run, argc, argv); }
