// sombra — the shadow cache (render.h ShadowCacheMode): the EG 2009 course's "3D texture caching"
// and Ament et al. 2014 Alg. 1 for every technique. Per volume and light a lattice of the shadow
// term over the volume's voxels, filled by the technique itself (render.cl shadow_cache_fill) and
// kept on the Context; an entry is refilled only when its key changes. The camera pass reads it
// trilinearly (render.cl cached_shadow). Its surface part holds the term per mesh triangle corner
// and light (render.cl surface_shadow_cache_fill), which surface fragments interpolate
// barycentrically (surfaces.h composite_surface).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>

#include "host/kernel_args.h"
#include "host/tiled_launch.h"
#include "render/preparation.h"
#include "shadows/light_reach.h"
#include "sombra/error.h"
#include "sombra/options.h"

namespace sombra::pipeline {

std::size_t lattice_points(const ShadowCacheGpu& c) { return std::size_t(c.dims.s[0]) * std::size_t(c.dims.s[1]) * std::size_t(c.dims.s[2]); }

namespace {

// Words of a lattice's bit masks (ShadowCacheGpu.mark_row_words per row of y and z).
std::size_t mask_words(const ShadowCacheGpu& c) { return std::size_t(c.mark_row_words) * std::size_t(c.dims.s[1]) * std::size_t(c.dims.s[2]); }

constexpr std::size_t kSurfacePoints = std::size_t(1) << 22;      // the surface part's, over all meshes (64 MiB + 4 MiB per light)
constexpr int kSurfaceMaxSubdivision = 1024;                        // lattice intervals along a triangle's edge
constexpr int kSurfaceRowPoints = 1024;                              // rows of the surface fill's launch
// auto's probe fills blocks of 2 × 2 neighbouring lattice rows (y, z) every 64 rows along y and z
// first (1/1024 of the points), every 32 rows unless that already decided (1/256), on close calls
// 4 × 4 every 32 (1/64)
constexpr int kProbeBlock = 2, kProbeCloseCallBlock = 4, kProbeCoarseStride = 64, kProbeBlockStride = 32;
// along each axis of a lattice, however small, while it holds at most 4 × (block / stride)² of its
// points (probe_lattices)
constexpr int kProbeMinBlocks = 4;
constexpr double kProbeMaxShare = 4;
// A decision from the coarse fill alone needs one side to cost 3 times the other (twice after the
// finer fills).
constexpr double kProbeCoarseClear = 3, kProbeClear = 2;
// The camera pass's scout, a launch's rows with a quarter of its packets (1/256 of a 256² image),
// decides for the cache when the per-sample pass costs 3 times the coarse fill and the cached pass.
constexpr double kProbeScoutClear = 3, kProbeHalfScoutClear = 6, kProbeQuarterScoutClear = 8;  // (its first half or three quarters at 6×, first quarter at 8×)
constexpr int kProbeScoutThinning = 4;
// and renders 16 image rows a launch, every 4th packet of each (the pixels of 4 rows; of images
// under 256 rows every (4 · 256 / height)th: 1/64 of the image), at most 4 launches
constexpr int kProbeRowsPerLaunch = 16, kProbePacketStride = 4, kProbeLaunches = 4;
// where marking is a close call on the marked share (marked_share_pays), the per-sample pass again
// on a band of whole rows in the image's middle, one in 64 of its rows
constexpr int kWholeRowBand = 64;
constexpr double kProbeBandClear = 1.25;  // a close call closer than this measures the per-sample pass on the band
constexpr double kProbeBandAgrees = 1.6;  // whose estimate replaces the launches' within this factor of theirs
// its rows run while they fit the larger of the probe's budget and this many times the band's
// share of the per-sample pass (two_smokes_wall's cone at 256²: the middle rows, in both smokes,
// cost 6.5× the average row, 11 ms on a 101 ms frame; bench/README.md "The band's allowance")
constexpr double kProbeBandOverrun = 2;
constexpr double kProbeWarmupMs = 10;                        // before its first fill, ≥ 10 ms of untimed fills
constexpr int kProbeWarmupLaunches = 8;                      // (or 8 launches)
constexpr double kProbeBudget = 0.05;                        // beyond its first launch, at most 5 % of the cheaper frame
constexpr std::size_t kRememberedChoices = 4096;            // auto's choices kept per process (the oldest go first)

double triangle_longest_edge(const SurfaceTriangleGpu& t) {
    const cl_float4* c[3] = {&t.corner, &t.corner1, &t.corner2};
    double longest = 0;
    for (int e = 0; e < 3; ++e) {
        const cl_float4 &a = *c[e], &b = *c[(e + 1) % 3];
        longest = std::max(longest, std::hypot(double(a.s[0]) - b.s[0], double(a.s[1]) - b.s[1], double(a.s[2]) - b.s[2]));
    }
    return longest;
}

// The lattice of a volume: its voxels, the longest axis halved until at most kShadowCachePoints.
std::array<int, 3> cache_lattice(const std::array<int, 3>& dims) {
    std::array<int, 3> n = dims;
    while (std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]) > kShadowCachePoints) {
        int& longest = *std::max_element(n.begin(), n.end());
        longest = (longest + 1) / 2;
    }
    return n;
}


// Entry (volume i, light m) of the cache: its lattice, its place in the values, the volume's
// voxel → world rows.
std::vector<ShadowCacheGpu> cache_layout(const Scene& scene, const packing::PackedScene& packed, bool light_columns) {
    std::vector<ShadowCacheGpu> table;
    std::size_t total = 0, words = 0;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const std::array<int, 3>& dims = scene.volumes[i].volume->dims;
        std::array<int, 3> n = cache_lattice(dims);
        for (std::size_t m = 0; m < scene.lights.size(); ++m) {
            ShadowCacheGpu c{};
            for (std::size_t a = 0; a < 3; ++a) {
                c.dims.s[a] = n[a];
                c.spacing.s[a] = n[a] > 1 ? float(dims[a] - 1) / float(n[a] - 1) : 1.f;
            }
            for (std::size_t r = 0; r < 3; ++r)
                for (std::size_t k = 0; k < 4; ++k) c.voxel_to_world[r].s[k] = packed.voxel_to_world[i][4 * r + k];
            // a sample reads the points of its lattice cell; it is shaded after pre-integrating one
            // step (≤ step_voxels voxels on every axis) and interpolates its voxel's corners
            c.reach = std::max({c.spacing.s[0], c.spacing.s[1], c.spacing.s[2]}) + scene.volumes[i].step_voxels + 1.f;
            c.row_block = c.row_block_stride = 1;  // evenly spaced points (the probe's come in blocks)
            set_volume_lattice_map(c);
            if (light_columns) {
                if (std::optional<ShadowCacheGpu> g = light_lattice(c, packed.volumes[i], packed.lights[m], scene.volumes[i].step_voxels)) c = *g;
            }
            c.offset = cl_uint(total);
            total += lattice_points(c);
            c.mark_row_words = cl_uint((c.dims.s[0] + 31) / 32);  // the visible fill's masks: rows start on a word
            c.mark_offset = cl_uint(words);
            words += mask_words(c);
            if (total > 0xffffffffull) throw Error("shadow cache: more than 2^32 entries");
            table.push_back(c);
        }
    }
    return table;
}

// What an entry's values depend on when the technique gives no finer keys: the technique and its
// options, the placement of every volume and the meshes (a light's deep shadow maps are fitted to
// them all), the entry's light and the technique's data for it (light_data_key), the jitter seed (shadow rays start at jittered points), and the
// content (voxels, transfer function, step) of its volume and of each volume that can reach it —
// whose box, grown by four texels of a map fitted to the scene (bilinear lookups, pre-filtering)
// and two steps, lies between the entry's volume and the light.
std::string common_key(const PreparedScene& p, const RenderOptions& options) {
    const SceneKeys& k = p.keys;
    std::string common = std::string(shadow_technique_name(options.shadows)) + " seed " + std::to_string(options.jitter_seed) +
                         " | options " + k.options + " | meshes " + k.surfaces() + " | placement";
    for (const std::string& placement : k.volume_placement) common += " " + placement;
    return common;
}

// How far a light's view fitted to the box `all` reaches: the box's diagonal, or a positional
// light's distance to its farthest corner if longer.
double light_reach(const shadows::WorldBox& all, const LightGpu& light) {
    double reach = all.diagonal();
    if (light.type != SOMBRA_LIGHT_DIRECTIONAL)
        for (int c = 0; c < 8; ++c) {
            const shadows::D3 corner{(c & 1 ? all.hi : all.lo)[0], (c & 2 ? all.hi : all.lo)[1], (c & 4 ? all.hi : all.lo)[2]};
            reach = std::max(reach, std::hypot(corner[0] - light.position.s[0], corner[1] - light.position.s[1], corner[2] - light.position.s[2]));
        }
    return reach;
}

std::vector<std::string> generic_keys(const Scene& scene, const PreparedScene& p, const techniques::ShadowModule& technique,
                                      const RenderOptions& options) {
    const SceneKeys& k = p.keys;
    std::string common = common_key(p, options);
    std::vector<shadows::WorldBox> boxes = shadows::volume_boxes(p.packed);
    shadows::WorldBox all;
    double step = 0;
    for (std::size_t j = 0; j < boxes.size(); ++j) all.add(boxes[j].lo), all.add(boxes[j].hi), step = std::max(step, double(p.packed.volumes[j].step));
    std::vector<std::string> keys;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i)
        for (std::size_t m = 0; m < scene.lights.size(); ++m) {
            const LightGpu& light = p.packed.lights[m];
            double reach = light_reach(all, light);  // a positional light's map spans its distance to the farthest corner
            // a texel of a view of ≤ 120° (a cluster's focused view, clustering.cpp's kMaxFocusTan;
            // a cube face 90°) spans ≤ (2π/3)·reach / resolution
            double margin = 4 * 2.1 * reach / std::max(options.dsm.resolution, 1) + 2 * step;
            std::string key = common + " | light " + p.light_keys[m] + " " + technique.light_data_key(m) + " | volume " + std::to_string(i) + " " + k.volume(i);
            for (std::size_t j = 0; j < scene.volumes.size(); ++j)
                if (j != i && shadows::between_light_and(boxes[i], boxes[j].grown(margin), light))
                    key += " | " + std::to_string(j) + " " + k.volume(j);
            keys.push_back(key);
        }
    return keys;
}

// The share of volume i's bricks that may be visible under its transfer function.
double visible_brick_fraction(const packing::PackedScene& packed, std::size_t i) {
    const VolumeGpu& v = packed.volumes[i];
    std::size_t bricks = std::size_t(v.brick_dims.s[0]) * v.brick_dims.s[1] * v.brick_dims.s[2];
    auto first = packed.occupancy.begin() + std::ptrdiff_t(v.brick_offset);
    return bricks ? double(std::count(first, first + std::ptrdiff_t(bricks), cl_uchar(1))) / double(bricks) : 0.0;
}

// Intervals along a triangle's edges whose longest edge is `edge` at lattice spacing `spacing`.
int triangle_subdivision(double edge, double spacing) {
    return int(std::clamp(std::ceil(edge / spacing), 1.0, double(kSurfaceMaxSubdivision)));
}

std::size_t triangle_points(int k) { return std::size_t(k + 1) * std::size_t(k + 2) / 2; }

// The surface part's points: per mesh triangle a barycentric lattice of k + 1 points along each
// edge (k = 1: its corners), point (i, j) at barycentric weights (1 − (i + j)/k, i/k, j/k) of
// corners 0, 1, 2, with the normal interpolated and normalized as composite_surface interpolates
// it there. k: the triangle's longest edge over the spacing `spacing`, so that big triangles (a
// floor, a table) resolve the shadows falling across them as finely as the meshes' own triangles.
void make_surface_points(SurfaceShadowCache& s, const std::vector<SurfaceTriangleGpu>& triangles, double spacing) {
    s.points.clear(), s.triangles.clear();
    s.triangles.reserve(2 * triangles.size());
    for (const SurfaceTriangleGpu& t : triangles) {
        const cl_float4* corner[3] = {&t.corner, &t.corner1, &t.corner2};
        int k = triangle_subdivision(triangle_longest_edge(t), spacing);
        s.triangles.push_back(cl_uint(s.points.size() / 2)), s.triangles.push_back(cl_uint(k));
        for (int j = 0; j <= k; ++j)
            for (int i = 0; i + j <= k; ++i) {
                float v = float(i) / float(k), w = float(j) / float(k), u = 1.f - v - w;
                float p[3], n[3];
                for (int a = 0; a < 3; ++a) {
                    p[a] = u * corner[0]->s[a] + v * corner[1]->s[a] + w * corner[2]->s[a];
                    n[a] = u * t.normal[0].s[a] + v * t.normal[1].s[a] + w * t.normal[2].s[a];
                }
                float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                if (len > 1e-12f) {
                    for (float& x : n) x /= len;
                } else {  // the face normal, as the fragment falls back to
                    float e1[3], e2[3];
                    for (int a = 0; a < 3; ++a) e1[a] = t.corner1.s[a] - t.corner.s[a], e2[a] = t.corner2.s[a] - t.corner.s[a];
                    float c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
                    float cl = std::max(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), 1e-30f);
                    for (int a = 0; a < 3; ++a) n[a] = c[a] / cl;
                }
                s.points.push_back(cl_float4{{p[0], p[1], p[2], 1.f}});
                s.points.push_back(cl_float4{{n[0], n[1], n[2], 0.f}});
            }
    }
}

// The lattices' spacing: the meshes' median triangle edge (their own tessellation), grown while
// the points would pass kSurfacePoints; and the points make_surface_points makes at it, counted
// without making them.
struct SurfaceLattice {
    double spacing;
    std::size_t points;
};

SurfaceLattice surface_lattice(const std::vector<SurfaceTriangleGpu>& triangles) {
    std::vector<double> longest;
    for (const SurfaceTriangleGpu& t : triangles) longest.push_back(triangle_longest_edge(t));
    std::nth_element(longest.begin(), longest.begin() + std::ptrdiff_t(longest.size() / 2), longest.end());
    double spacing = std::max(longest[longest.size() / 2], 1e-12);
    for (;;) {
        std::size_t points = 0;
        for (double edge : longest) points += triangle_points(triangle_subdivision(edge, spacing));
        if (points <= kSurfacePoints) return {spacing, points};
        spacing *= 1.25;
    }
}

// The surface part's keys, per light: what a lattice entry's generic key holds (generic_keys) with
// every volume's content, as any volume may shadow a surface.
std::vector<std::string> surface_keys(const Scene& scene, const PreparedScene& p, const techniques::ShadowModule& technique,
                                      const RenderOptions& options) {
    std::string common = common_key(p, options) + " | volumes";
    for (std::size_t i = 0; i < p.keys.volume_content.size(); ++i) common += " | " + p.keys.volume(i);
    std::vector<std::string> keys;
    for (std::size_t m = 0; m < scene.lights.size(); ++m)
        keys.push_back(common + " | light " + p.light_keys[m] + " " + technique.light_data_key(m));
    return keys;
}

}  // namespace

std::vector<float> surface_bias_distances(const PreparedScene& p) {
    shadows::WorldBox all;
    for (const shadows::WorldBox& b : shadows::volume_boxes(p.packed)) all.add(b.lo), all.add(b.hi);
    for (const SurfaceTriangleGpu& t : p.packed_surfaces.triangles)
        for (const cl_float4* c : {&t.corner, &t.corner1, &t.corner2}) all.add({c->s[0], c->s[1], c->s[2]});
    std::vector<float> distances;
    for (const LightGpu& light : p.packed.lights) distances.push_back(float(light_reach(all, light)));
    return distances;
}

namespace {

// What one frame does with the volume lattices: the layout, each entry's key and whether it is
// stale (its key changed or the layout did), and whether the cache is used at all.
struct VolumePlan {
    std::vector<ShadowCacheGpu> layout;
    std::vector<std::string> keys;
    std::vector<bool> stale;
    bool same_layout = false, use = false;
    double points_to_fill = 0;  // the stale entries' points near possibly visible bricks (the marked share's whole)
};

// The lattice points to fill (near possibly visible bricks: the fill skips the others; stats);
// whether the cache is used is decided here only when the mode is On or nothing is stale (reading
// costs less than evaluating): auto otherwise measures (probe_volume_costs).
VolumePlan plan_volume_entries(host::Runtime& runtime, const Scene& scene, const Prepared& prepared, const RenderOptions& options,
                               const ShadowCache& cache, RenderStats& stats) {
    const PreparedScene& p = prepared.scene;
    const std::size_t lights = scene.lights.size();
    VolumePlan plan;
    // light lattices: not across polyhedral bounds (a piece of a column starting inside a bound)
    plan.layout = cache_layout(scene, p.packed, prepared.technique.fills_light_columns(options) && p.packed.bound_triangles.empty());
    plan.keys = prepared.technique.shadow_cache_keys({runtime, scene, p.packed, p.packed_surfaces, p.device, options, p.use_images});
    if (plan.keys.empty()) plan.keys = generic_keys(scene, p, prepared.technique, options);
    plan.same_layout = cache.layout.size() == plan.layout.size() &&
                       std::equal(plan.layout.begin(), plan.layout.end(), cache.layout.begin(),
                                  [](const ShadowCacheGpu& a, const ShadowCacheGpu& b) { return std::memcmp(&a, &b, sizeof a) == 0; });
    // an entry whose lattice is the same but for its place in the buffers is kept (a moved light's
    // new light lattice moves the others': prepare_volume_fill copies them over)
    auto same_lattice = [](ShadowCacheGpu a, ShadowCacheGpu b) {
        a.offset = b.offset, a.mark_offset = b.mark_offset;
        return std::memcmp(&a, &b, sizeof a) == 0;
    };
    plan.stale.assign(plan.layout.size(), true);
    for (std::size_t e = 0; e < plan.layout.size() && cache.layout.size() == plan.layout.size(); ++e)
        plan.stale[e] = !same_lattice(cache.layout[e], plan.layout[e]) || cache.keys[e] != plan.keys[e];
    double to_fill = 0;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        double visible = visible_brick_fraction(p.packed, i);
        for (std::size_t m = 0; m < lights; ++m)
            if (plan.stale[i * lights + m]) to_fill += visible * double(lattice_points(plan.layout[i * lights + m]));
    }
    plan.points_to_fill = to_fill;
    stats.shadow_cache_points_to_fill = static_cast<unsigned long long>(to_fill);
    stats.shadow_cache_light_lattices = int(std::count_if(plan.layout.begin(), plan.layout.end(), [](const ShadowCacheGpu& c) { return c.column_axes.s[3] != 0; }));
    plan.use = options.shadow_cache == ShadowCacheMode::On || to_fill == 0;
    return plan;
}

// The surface points: a light's entry is stale when its key changed or the meshes did. Auto:
// surface_shadow_cache_pays, by the points to fill and the fragments the frame would evaluate.
struct SurfacePlan {
    std::vector<std::string> keys;
    std::vector<bool> stale;
    bool use = false;
};

SurfacePlan plan_surface_entries(const Scene& scene, const Prepared& prepared, const RenderOptions& options,
                                 std::size_t surface_fragments, SurfaceShadowCache& sc, RenderStats& stats) {
    const PreparedScene& p = prepared.scene;
    const std::size_t lights = scene.lights.size();
    // the points are counted here and made only when the part is filled: a frame that leaves the
    // part off (auto) does not pay for making them (0.74 M points on the cups)
    if (sc.points_key != p.keys.surfaces() || sc.source_triangles != p.packed_surfaces.triangles.size()) {
        sc = SurfaceShadowCache();
        const SurfaceLattice lattice = surface_lattice(p.packed_surfaces.triangles);
        sc.spacing = lattice.spacing, sc.planned_points = lattice.points;
        sc.source_triangles = p.packed_surfaces.triangles.size();
        sc.points_key = p.keys.surfaces();
    }
    SurfacePlan plan;
    plan.keys = surface_keys(scene, p, prepared.technique, options);
    plan.stale.assign(lights, true);
    for (std::size_t m = 0; m < lights && sc.keys.size() == lights; ++m) plan.stale[m] = sc.keys[m] != plan.keys[m];
    const double stale_lights = double(std::count(plan.stale.begin(), plan.stale.end(), true));
    stats.shadow_cache_surface_points = sc.point_count();
    stats.shadow_cache_surface_points_to_fill = static_cast<unsigned long long>(stale_lights * double(sc.point_count()));
    stats.shadow_cache_estimated_fragments = static_cast<unsigned long long>(double(surface_fragments) * double(lights));
    plan.use = options.shadow_cache == ShadowCacheMode::On ||
               surface_shadow_cache_pays(stale_lights * double(sc.point_count()), double(surface_fragments) * double(lights));
    return plan;
}

// How the fills launch: the camera pass's program (the fills read no cache), the camera, the
// scene and the technique's parameters.
struct FillLaunch {
    host::Runtime& runtime;
    const Scene& scene;
    const Prepared& prepared;
    const RenderOptions& options;
    cl::Program& program;
    cl::Buffer camera;
    int lanes;
    cl::Buffer no_mask;  // bound as shadow_cache_fill's fill_mask where its fill_mode reads none
    int width, height;
    const surfaces::ViewFragments* fragments;  // the frame's (mesh scenes; else null)
};

// The fills' launch for a frame: its camera (jittered as the frame's) and the camera pass's
// program (reading the surface part when `surface_reads`).
FillLaunch fill_launch(host::Runtime& runtime, const Scene& scene, const Prepared& prepared, const RenderOptions& options, int lanes,
                       bool surface_reads, int width, int height, const surfaces::ViewFragments* fragments) {
    CameraGpu camera = packing::pack_camera(scene, width, height);
    camera.jitter_seed = options.jitter_seed;  // the fills' shadow rays start where the camera pass's would
    return FillLaunch{runtime, scene, prepared, options,
                      runtime.program("render.cl", camera_pass_defines(scene, options, prepared, lanes, surface_reads)),
                      host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera"), lanes,
                      host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(cl_uint), nullptr, "no points to fill"), width, height,
                      fragments};
}

// Which points of a lattice shadow_cache_fill evaluates (its fill_mode): every point a sample can
// read; those of a mask (the visible fill's need); those a sample can read outside a mask (the
// rest of an entry, after its filled points).
enum class FillMode : cl_uint { All = 0, Marked = 1, Rest = 2 };

// Rows first … first + count − 1 of a lattice (row y + dims.y · z: its points along x).
struct RowRange {
    int first = 0, count = 0;
};

// A fill launch's rows: a volume lattice's rows along x; a light lattice's rows of columns (y).
RowRange all_rows(const ShadowCacheGpu& c) { return {0, c.column_axes.s[3] ? c.dims.s[1] : c.dims.s[1] * c.dims.s[2]}; }

// The fill kernels of a program: shadow_cache_fill for volume lattices, shadow_cache_fill_columns
// (only in techniques that define it, cl/techniques/rays.h) for light lattices.
struct FillKernels {
    cl::Program& program;
    std::optional<cl::Kernel> volume, columns;
    cl::Kernel& of(const ShadowCacheGpu& c) {
        std::optional<cl::Kernel>& k = c.column_axes.s[3] ? columns : volume;
        if (!k) k = cl::Kernel(program, c.column_axes.s[3] ? "shadow_cache_fill_columns" : "shadow_cache_fill");
        return *k;
    }
};

// The points of `words` (an entry's whole mask, ShadowCacheGpu.mark_offset) in launch rows `r`.
unsigned long long mask_points_in_rows(const std::vector<cl_uint>& words, const ShadowCacheGpu& c, RowRange r) {
    unsigned long long points = 0;
    const int planes = c.column_axes.s[3] ? c.dims.s[2] : 1, rows_per_plane = all_rows(c).count;
    for (int z = 0; z < planes; ++z)
        for (int row = r.first; row < r.first + r.count; ++row)
            for (std::size_t w = 0; w < c.mark_row_words; ++w)
                points += unsigned(__builtin_popcount(words[(std::size_t(z) * std::size_t(rows_per_plane) + std::size_t(row)) * c.mark_row_words + w]));
    return points;
}

}  // namespace

std::size_t marked_corner_points(const std::vector<cl_uint>& marks, const ShadowCacheGpu& c, std::vector<cl_uint>* cover_words) {
    std::size_t points = 0;
    const std::size_t dims_y = std::size_t(c.dims.s[1]), rows = dims_y * std::size_t(c.dims.s[2]), row_words = c.mark_row_words;
    for (std::size_t row = 0; row < rows; ++row) {
        const bool y_above = row % dims_y > 0, z_above = row >= dims_y;
        const std::size_t neighbours[4] = {row, y_above ? row - 1 : row, z_above ? row - dims_y : row, y_above && z_above ? row - 1 - dims_y : row};
        for (std::size_t w = 0; w < row_words; ++w) {
            cl_uint here = 0, before = 0;
            for (std::size_t r : neighbours) {
                const cl_uint* words = &marks[c.mark_offset + r * row_words];
                here |= words[w];
                if (w > 0) before |= words[w - 1];
            }
            const unsigned in_word = unsigned(std::min<long>(32, long(c.dims.s[0]) - 32 * long(w)));
            const cl_uint cover = (here | (here << 1) | (before >> 31)) & (in_word >= 32 ? 0xffffffffu : (1u << in_word) - 1u);
            points += std::size_t(__builtin_popcount(cover));
            if (cover_words) (*cover_words)[c.mark_offset + row * row_words + w] = cover;
        }
    }
    return points;
}

namespace {

// shadow_cache_fill's arguments for entry e of `table` into `values`, by the launch's technique,
// for the points `mode` and `mask` select.
void bind_fill(const FillLaunch& launch, cl::Kernel& kernel, std::size_t e, const cl::Buffer& table,
               const cl::Buffer& values, FillMode mode = FillMode::All, const cl::Buffer* mask = nullptr) {
    host::KernelArgs args{kernel};
    bind_scene(args, launch.prepared.scene, launch.camera);
    args("cache_entry", cl_uint(e))("shadow_cache_table", table)("shadow_cache", values);
    args("fill_mode", cl_uint(mode))("fill_mask", mask ? *mask : launch.no_mask);
    launch.prepared.technique.bind(args, launch.runtime, launch.options);
    args.done();
}

// shadow_cache_fill of entry e of `table` (lattice c) into `values`, by the launch's technique, of
// the points `mode` and `mask` select in `rows` (default: all), in bands; returns the kernel time.
// The frame's fill and auto's probe warm-up run it.
double fill_lattice(const FillLaunch& launch, FillKernels& kernels, std::size_t e, const ShadowCacheGpu& c,
                    const cl::Buffer& table, const cl::Buffer& values, FillMode mode = FillMode::All, const cl::Buffer* mask = nullptr,
                    std::optional<RowRange> rows = std::nullopt) {
    cl::Kernel& kernel = kernels.of(c);
    bind_fill(launch, kernel, e, table, values, mode, mask);
    const RowRange r = rows.value_or(all_rows(c));
    return host::run_packets(launch.runtime, kernel, c.dims.s[0], r.count, launch.lanes, 1, r.first);
}

// The marking pass over the rows of `camera` (the frame's CameraGpu, or one of its rows' launches:
// first_row, row_stride): the camera pass, marking the lattice cells its samples read in
// cache.marks (added to the marks there) instead of reading them; the surfaces read what the
// frame's read. Returns its kernel time; *samples (if given): the camera samples of its rows.
double run_marking_pass(const FillLaunch& launch, ShadowCache& cache, const SurfaceShadowCache* surface_cache, const CameraGpu& camera,
                        double* samples = nullptr) {
    host::Runtime& runtime = launch.runtime;
    CameraPassReads marking;
    marking.fragments = launch.fragments;
    marking.surface_cache = surface_cache;
    marking.volume_cache_table = &cache.table, marking.volume_cache_marks = &cache.marks;
    const std::size_t pixels = std::size_t(launch.width) * std::size_t(launch.height);
    cl::Buffer image = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_float4), nullptr, "marking pass image");
    cl::Buffer counts = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_uint), nullptr, "marking pass samples");
    const double ms = host::in_stage(runtime.progress(), "shadow cache marking", 1, [&] {
        return run_camera_pass(runtime, launch.scene, launch.prepared, launch.options, launch.lanes, camera, marking, image, counts);
    });
    if (samples) {  // its rows, one after another (render.cl render_camera)
        const cl_uint stride = std::max(camera.row_stride, cl_uint(1));
        const std::size_t rows = camera.first_row < camera.height ? (camera.height - camera.first_row + stride - 1) / stride : 0;
        std::vector<cl_uint> counts_read(rows * std::size_t(launch.width));
        if (!counts_read.empty())
            runtime.queue().enqueueReadBuffer(counts, CL_TRUE, 0, counts_read.size() * sizeof(cl_uint), counts_read.data());
        *samples = std::accumulate(counts_read.begin(), counts_read.end(), 0.0);
    }
    return ms;
}

// The visible fill's first steps: the marking pass over the frame, then per entry in `entries`
// the points needed (shadow_cache_need). Returns the points per entry; *image_samples: the frame's
// camera samples.
std::vector<cl_uint> mark_needed_points(const FillLaunch& launch, ShadowCache& cache, const std::vector<bool>& entries,
                                        const SurfaceShadowCache* surface_cache, RenderStats& stats, double* image_samples) {
    host::Runtime& runtime = launch.runtime;
    runtime.queue().enqueueFillBuffer(cache.marks, cl_uint(0), 0, cache.mark_words * sizeof(cl_uint));
    double ms = run_marking_pass(launch, cache, surface_cache, frame_camera(launch.scene, launch.options, launch.width, launch.height),
                                 image_samples);
    std::vector<cl_uint> needed(cache.layout.size(), 0);
    cl::Kernel kernel(launch.program, "shadow_cache_need");
    for (std::size_t e = 0; e < cache.layout.size(); ++e) {
        if (!entries[e]) continue;
        const ShadowCacheGpu& c = cache.layout[e];
        runtime.queue().enqueueFillBuffer(cache.need_count, cl_uint(0), 0, sizeof(cl_uint));
        host::KernelArgs args{kernel};
        args("shadow_cache_table", cache.table)("cache_entry", cl_uint(e))("shadow_cache_marks", cache.marks);
        args("shadow_cache_filled", cache.filled)("shadow_cache_need", cache.need)("need_count", cache.need_count);
        args.done();
        ms += host::run_tiled(runtime, kernel, cl::NDRange(c.mark_row_words, std::size_t(c.dims.s[1]) * std::size_t(c.dims.s[2])),
                              cl::NullRange);
        runtime.queue().enqueueReadBuffer(cache.need_count, CL_TRUE, 0, sizeof(cl_uint), &needed[e]);
    }
    stats.stage_ms["shadow_cache_mark"] = ms;
    return needed;
}

// What the frame's volume fill evaluates per entry: nothing (filled), what the frame reads (a
// stale entry, with the visible fill: its points needed, mark_needed_points), every point (a
// stale entry otherwise) or the rest (an entry filled for an earlier view only: it is completed,
// so that later camera moves read a filled lattice without marking passes).
struct VolumeFill {
    bool prepared = false;
    std::vector<std::optional<FillMode>> mode;
    std::vector<cl_uint> needed;
    std::vector<std::vector<RowRange>> done;  // per entry, in order: rows auto's measurement filled (measure_marked_fill)
    double image_samples = 0;  // the frame's camera samples, as the marking pass counted them
    unsigned long long needed_points() const { return std::accumulate(needed.begin(), needed.end(), 0ull); }
};

// Sets a cache's values, made and not yet set (ShadowCache.values_undefined), to 1.
void define_values(host::Runtime& runtime, ShadowCache& cache) {
    if (!cache.values_undefined) return;
    const ShadowCacheGpu& last = cache.layout.back();
    runtime.queue().enqueueFillBuffer(cache.values, 1.0f, 0, (last.offset + lattice_points(last)) * sizeof(float));
    cache.values_undefined = false;
}

// Makes the lattices (new ones when the layout changed), empties the stale entries and, with
// `visible`, marks what the frame reads of them.
VolumeFill prepare_volume_fill(const FillLaunch& launch, ShadowCache& cache, const VolumePlan& plan, bool visible,
                               const SurfaceShadowCache* surface_cache, RenderStats& stats) {
    host::Runtime& runtime = launch.runtime;
    if (!plan.same_layout) {  // other volumes or lights, or a light lattice's size: new lattices
        ShadowCache fresh;
        fresh.surfaces = std::move(cache.surfaces);
        fresh.volumes_used = cache.volumes_used, fresh.surfaces_used = cache.surfaces_used;
        fresh.history_pending = std::move(cache.history_pending);
        const bool keeps = std::count(plan.stale.begin(), plan.stale.end(), false) > 0;
        ShadowCache old = std::move(cache);  // freed before the new buffers are made, unless entries are kept
        if (!keeps) old = ShadowCache();
        cache = std::move(fresh);
        cache.layout = plan.layout;
        cache.keys.assign(plan.layout.size(), std::string());
        cache.complete.assign(plan.layout.size(), false);
        cache.filled_view.assign(plan.layout.size(), std::string());
        const ShadowCacheGpu& last = plan.layout.back();
        const std::size_t total = last.offset + lattice_points(last);
        cache.mark_words = last.mark_offset + mask_words(last);
        cache.values = host::make_buffer(runtime, CL_MEM_READ_WRITE, total * sizeof(float), nullptr, "shadow cache");
        cache.table = host::make_buffer(runtime, CL_MEM_READ_ONLY, plan.layout.size() * sizeof(ShadowCacheGpu), plan.layout.data(),
                                        "shadow cache table");
        const std::size_t mask_bytes = cache.mark_words * sizeof(cl_uint);
        cache.marks = host::make_buffer(runtime, CL_MEM_READ_WRITE, mask_bytes, nullptr, "shadow cache marks");
        cache.filled = host::make_buffer(runtime, CL_MEM_READ_WRITE, mask_bytes, nullptr, "shadow cache filled points");
        cache.need = host::make_buffer(runtime, CL_MEM_READ_WRITE, mask_bytes, nullptr, "shadow cache points to fill");
        cache.need_count = host::make_buffer(runtime, CL_MEM_READ_WRITE, sizeof(cl_uint), nullptr, "shadow cache points to fill count");
        // never read unfilled; defined anyway, before the first fill (define_values): the 5 ms of
        // setting bounded_smoke's 11 MB went to waste where auto's share estimate made the
        // lattices and the frame then evaluated per sample (bench/README.md "Marked points on
        // marched paths"); at once where kept entries are copied in
        cache.values_undefined = true;
        if (keeps) define_values(runtime, cache);
        cache.bytes = total * sizeof(float) + 3 * mask_bytes;
        // the kept entries' values and filled points, copied over
        for (std::size_t e = 0; e < plan.layout.size() && keeps; ++e) {
            if (plan.stale[e]) continue;
            const ShadowCacheGpu &from = old.layout[e], &to = plan.layout[e];
            runtime.queue().enqueueCopyBuffer(old.values, cache.values, from.offset * sizeof(float), to.offset * sizeof(float),
                                              lattice_points(to) * sizeof(float));
            runtime.queue().enqueueCopyBuffer(old.filled, cache.filled, from.mark_offset * sizeof(cl_uint), to.mark_offset * sizeof(cl_uint),
                                              mask_words(to) * sizeof(cl_uint));
            cache.keys[e] = old.keys[e], cache.complete[e] = old.complete[e], cache.filled_view[e] = old.filled_view[e];
        }
        if (keeps) runtime.queue().finish();  // before the old buffers go
    }
    // stale entries start empty; incomplete ones filled for another view are completed (the same
    // view again reads only what it filled: the same samples). The samples that read entry e
    // depend on the camera, on its light (a sample on the side away from the light reads nothing:
    // light_term_possible, cl/shading.h) and on everything in front of them (the scene's key): its
    // view is all three, so a moved light or a more transparent volume in front completes it.
    const CameraGpu camera = frame_camera(launch.scene, launch.options, launch.width, launch.height);
    const std::string frame_view = std::string(reinterpret_cast<const char*>(&camera), sizeof camera) + " | " + launch.prepared.scene.key;
    // entry e is (volume e / lights, light e % lights): a scene without lights has no entries
    auto entry_view = [&](std::size_t e) {
        return frame_view + " | light " + launch.prepared.scene.light_keys[e % launch.scene.lights.size()];
    };
    VolumeFill fill;
    fill.prepared = true;
    fill.mode.assign(plan.layout.size(), std::nullopt);
    std::vector<bool> marked(plan.layout.size(), false);
    for (std::size_t e = 0; e < plan.layout.size(); ++e) {
        if (plan.stale[e]) {
            cache.keys[e].clear();  // an entry half filled when a launch throws is not kept
            cache.complete[e] = false;
            const ShadowCacheGpu& c = plan.layout[e];
            runtime.queue().enqueueFillBuffer(cache.filled, cl_uint(0), c.mark_offset * sizeof(cl_uint), mask_words(c) * sizeof(cl_uint));
        }
        const std::string view = entry_view(e);
        if (plan.stale[e]) fill.mode[e] = visible ? FillMode::Marked : FillMode::All;
        else if (!cache.complete[e] && cache.filled_view[e] != view) fill.mode[e] = FillMode::Rest;
        marked[e] = fill.mode[e] == FillMode::Marked;
        if (marked[e]) cache.filled_view[e] = view;
    }
    if (std::count(marked.begin(), marked.end(), true) > 0) {
        fill.needed = mark_needed_points(launch, cache, marked, surface_cache, stats, &fill.image_samples);
        stats.shadow_cache_visible_fill = true;
        stats.shadow_cache_points_marked = fill.needed_points();
    }
    return fill;
}

// Auto's estimate of the share of the stale entries' points that the frame's marking pass would
// find, before it decides to run that pass: the pass costs about a cached camera pass, which the
// frame wastes when the points it finds then cost more to fill than evaluating per sample saves
// (the smoke's cone at 128²: 58 % of the points; the MRI's shadow rays, where marking pays: 8 %).
// The marking pass runs over one row of every kShareRowStride (from the middle of each stride),
// then over the next row of each: the first finds n₁ points a row, the second n₂ more (the points
// a row shares with its neighbour: a lattice cell spans about 1–2 image rows at 128²), counted on
// the host (marked_corner_points; the need step over a whole lattice took 6–10 ms, the two passes
// 1–1.3 ms each). The frame's rows find about n₁ + (kShareRowStride − 1) n₂ a stride (bench/
// README.md "The marked share, sampled": 0.74–1.09× the marking pass's count on six shipped
// cells at 128²; 1.6× on the tests' coarse lattice, whose cells span several rows).
// Makes the lattices (prepare_volume_fill, unmarked); leaves its marks, which the frame's marking
// pass clears. Returns the share (−1 where it makes nothing: images under 4 strides of rows, no
// stale entry), and the points the sampled rows need (the need step's cover of their marks, a
// whole need buffer: auto's probe fills them on its blocks) with their count, and the image's
// camera samples (its rows' count, scaled to the image's rows); *ms: the passes' kernel time.
constexpr int kShareRowStride = 32;
struct SampledMarks {
    double share = -1;
    double sampled_points = 0;  // the points the sampled rows need, set in `cover`
    std::vector<cl_uint> cover;
    double image_samples = 0;  // the frame's camera samples, estimated from the sampled rows'
};

SampledMarks estimate_marked_share(const FillLaunch& launch, ShadowCache& cache, const VolumePlan& plan,
                                   const SurfaceShadowCache* surface_cache, double points_to_fill, double* ms) {
    *ms = 0;
    const int height = launch.height, stride = std::min(kShareRowStride, height / 4);
    if (stride < 2 || points_to_fill <= 0 || std::count(plan.stale.begin(), plan.stale.end(), true) == 0) return {};
    RenderStats scratch;
    prepare_volume_fill(launch, cache, plan, false, surface_cache, scratch);
    host::Runtime& runtime = launch.runtime;
    runtime.queue().enqueueFillBuffer(cache.marks, cl_uint(0), 0, cache.mark_words * sizeof(cl_uint));
    std::vector<cl_uint> marks(cache.mark_words);
    SampledMarks sampled;
    sampled.cover.assign(cache.mark_words, 0);
    auto points_marked = [&] {
        runtime.queue().enqueueReadBuffer(cache.marks, CL_TRUE, 0, marks.size() * sizeof(cl_uint), marks.data());
        double points = 0;
        for (std::size_t e = 0; e < plan.layout.size(); ++e)
            if (plan.stale[e]) points += double(marked_corner_points(marks, plan.layout[e], &sampled.cover));
        return points;
    };
    CameraGpu rows = frame_camera(launch.scene, launch.options, launch.width, height);
    rows.row_stride = cl_uint(stride), rows.first_row = cl_uint(stride / 2 - 1);
    const int first_rows = (height - int(rows.first_row) + stride - 1) / stride;
    double first_samples = 0, next_samples = 0;
    *ms += run_marking_pass(launch, cache, surface_cache, rows, &first_samples);
    const double first = points_marked();
    rows.first_row += 1;
    const int next_rows = (height - int(rows.first_row) + stride - 1) / stride;
    *ms += run_marking_pass(launch, cache, surface_cache, rows, &next_samples);
    const double both = points_marked();
    sampled.image_samples = (first_samples + next_samples) / double(std::max(first_rows + next_rows, 1)) * double(height);
    const double per_first_row = first / std::max(first_rows, 1), per_next_row = (both - first) / std::max(next_rows, 1);
    const double points = double(height) / stride * (per_first_row + (stride - 1) * per_next_row);
    sampled.sampled_points = both;
    sampled.share = std::clamp(points / points_to_fill, 0.0, 1.0);
    return sampled;
}

// Auto's measurement of a visible fill after its marking pass: the probe's blocks of rows cost
// 1.2–4.6× more per point than the frame's visible fill, whose points lie where the camera sees
// the volume (bench/README.md "The visible fill, measured"). Per entry that needs points, its
// needed points in kMeasuredBands bands of rows spread evenly over its lattice (together about
// 1/kMeasuredShare of its rows; fewer bands an entry when there are many entries: a launch costs
// ≈ 0.14 ms on PoCL, and 8 bands of 1/256 of the rows each read the smoke's fill 1.6× high where
// 4 of 1/64 read it 1.25× high) are filled and timed; returns the whole fill's estimate, each
// entry's needed points at its measured time per point (the measurement's overall time per point
// where an entry's bands held fewer than kMeasuredMinPoints), and adds the bands to fill.done so
// that the frame's fill leaves them out. *measured_ms: the bands' kernel time.
constexpr int kMeasuredBands = 4, kMeasuredShare = 16, kMeasuredMaxLaunches = 64;
constexpr unsigned long long kMeasuredMinPoints = 256;

double measure_marked_fill(const FillLaunch& launch, ShadowCache& cache, const VolumePlan& plan, VolumeFill& fill,
                           double* measured_ms) {
    host::Runtime& runtime = launch.runtime;
    // its short launches must not make the frame's fill run unbanded, as the probe's (tiled_launch.cpp)
    const double last_launch_ms = runtime.progress().last_launch_ms;
    FillKernels kernels{launch.program, {}, {}};
    define_values(runtime, cache);
    fill.done.assign(plan.layout.size(), {});
    const std::size_t entries = std::size_t(std::count_if(fill.mode.begin(), fill.mode.end(), [](const auto& m) { return m == FillMode::Marked; }));
    const int bands_per_entry = std::clamp(kMeasuredMaxLaunches / int(std::max<std::size_t>(entries, 1)), 1, kMeasuredBands);
    std::vector<double> entry_ms(plan.layout.size(), 0);
    std::vector<unsigned long long> entry_points(plan.layout.size(), 0);
    double total_ms = 0;
    unsigned long long total_points = 0;
    for (std::size_t e = 0; e < plan.layout.size(); ++e) {
        if (fill.mode[e] != FillMode::Marked || fill.needed[e] == 0) continue;
        const ShadowCacheGpu& c = plan.layout[e];
        const int rows = all_rows(c).count;
        // bands of a multiple of 4 rows (the packets' work-groups), centred in equal parts of the rows
        const int band = std::min(rows, std::max(4, (rows / (kMeasuredShare * bands_per_entry) + 3) / 4 * 4));
        const int bands = std::min(bands_per_entry, rows / band);
        std::vector<cl_uint> words(mask_words(c));
        runtime.queue().enqueueReadBuffer(cache.need, CL_TRUE, c.mark_offset * sizeof(cl_uint), words.size() * sizeof(cl_uint), words.data());
        for (int b = 0; b < bands; ++b) {
            const int first = std::min(rows - band, int((double(b) + 0.5) * rows / bands - 0.5 * band) / 4 * 4);
            if (!fill.done[e].empty() && first < fill.done[e].back().first + fill.done[e].back().count) continue;
            const unsigned long long points = mask_points_in_rows(words, c, RowRange{first, band});
            entry_ms[e] += fill_lattice(launch, kernels, e, c, cache.table, cache.values, FillMode::Marked, &cache.need, RowRange{first, band});
            entry_points[e] += points;
            fill.done[e].push_back({first, band});
        }
        total_ms += entry_ms[e], total_points += entry_points[e];
    }
    *measured_ms = total_ms;
    runtime.progress().last_launch_ms = last_launch_ms;
    if (total_points < kMeasuredMinPoints) return -1;  // too few to tell: the probe's estimate stands
    double estimate = 0;
    for (std::size_t e = 0; e < plan.layout.size(); ++e) {
        if (fill.mode[e] != FillMode::Marked || fill.needed[e] == 0) continue;
        const double per_point = entry_points[e] >= kMeasuredMinPoints ? entry_ms[e] / double(entry_points[e])
                                                                       : total_ms / double(std::max<unsigned long long>(total_points, 1));
        estimate += per_point * double(fill.needed[e]);
    }
    return estimate;
}

// Fills the entries `fill` names (prepare_volume_fill); returns the kernel time.
double fill_volume_entries(const FillLaunch& launch, ShadowCache& cache, const VolumePlan& plan, const VolumeFill& fill,
                           RenderStats& stats) {
    host::Runtime& runtime = launch.runtime;
    const std::size_t stale_entries = std::size_t(std::count(plan.stale.begin(), plan.stale.end(), true));
    stats.shadow_cache_entries_reused += int(plan.layout.size() - stale_entries);
    double ms = 0;
    FillKernels kernels{launch.program, {}, {}};
    define_values(runtime, cache);
    const std::size_t entries = std::size_t(std::count_if(fill.mode.begin(), fill.mode.end(), [](const auto& m) { return m.has_value(); }));
    host::ProgressStage stage(runtime.progress(), "shadow cache", double(entries));
    for (std::size_t e = 0; e < plan.layout.size(); ++e) {
        if (!fill.mode[e]) continue;
        cache.keys[e].clear();
        const FillMode mode = *fill.mode[e];
        const cl::Buffer* mask = mode == FillMode::Marked ? &cache.need : mode == FillMode::Rest ? &cache.filled : nullptr;
        if (mode != FillMode::Marked || fill.needed[e] > 0) {
            // the rows around those auto's measurement filled
            int next = 0;
            const int rows = all_rows(plan.layout[e]).count;
            std::vector<RowRange> bands = e < fill.done.size() ? fill.done[e] : std::vector<RowRange>();
            bands.push_back({rows, 0});
            for (const RowRange& band : bands) {
                if (band.first > next)
                    ms += fill_lattice(launch, kernels, e, plan.layout[e], cache.table, cache.values, mode, mask, RowRange{next, band.first - next});
                next = band.first + band.count;
            }
        }
        cache.keys[e] = plan.keys[e];
        cache.complete[e] = mode != FillMode::Marked;
        if (plan.stale[e]) ++stats.shadow_cache_entries_built;
    }
    return ms;
}

// Fills the stale lights' values at the surface points (new buffers when the lights changed).
double fill_surface_entries(const FillLaunch& launch, SurfaceShadowCache& sc, const SurfacePlan& plan, std::size_t lights,
                            RenderStats& stats) {
    host::Runtime& runtime = launch.runtime;
    const std::size_t n = sc.point_count();
    if (sc.points.empty()) make_surface_points(sc, launch.prepared.scene.packed_surfaces.triangles, sc.spacing);
    if (sc.keys.size() != lights) {  // other lights: new values
        sc.keys.assign(lights, std::string());
        sc.point_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sc.points.size() * sizeof(cl_float4), sc.points.data(),
                                            "surface shadow cache points");
        sc.triangle_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sc.triangles.size() * sizeof(cl_uint), sc.triangles.data(),
                                               "surface shadow cache triangles");
        sc.values = host::make_buffer(runtime, CL_MEM_READ_WRITE, n * lights * sizeof(float), nullptr, "surface shadow cache");
        sc.bytes = n * lights * sizeof(float) + sc.points.size() * sizeof(cl_float4) + sc.triangles.size() * sizeof(cl_uint);
    }
    const std::size_t stale_lights = std::size_t(std::count(plan.stale.begin(), plan.stale.end(), true));
    stats.shadow_cache_surface_entries_reused += int(lights - stale_lights);
    if (stale_lights == 0) return 0;
    double ms = 0;
    cl::Kernel kernel(launch.program, "surface_shadow_cache_fill");
    host::ProgressStage stage(runtime.progress(), "surface shadow cache", double(stale_lights));
    const int rows = int((n + kSurfaceRowPoints - 1) / kSurfaceRowPoints);
    for (std::size_t m = 0; m < lights; ++m) {
        if (!plan.stale[m]) continue;
        sc.keys[m].clear();
        host::KernelArgs args{kernel};
        bind_scene(args, launch.prepared.scene, launch.camera);
        args("light_index", cl_uint(m))("surface_points", sc.point_buffer)("point_count", cl_uint(n));
        args("row_points", cl_uint(kSurfaceRowPoints))("surface_bias", launch.prepared.scene.surface_bias)("surface_shadow_cache", sc.values);
        launch.prepared.technique.bind(args, runtime, launch.options);
        args.done();
        ms += host::run_packets(runtime, kernel, kSurfaceRowPoints, rows, launch.lanes);
        sc.keys[m] = plan.keys[m];
        ++stats.shadow_cache_surface_entries_built;
    }
    return ms;
}

// The kernel time of one launch of a fill kernel over a table's lattices of one kind (columns:
// light lattices).
struct KindFill {
    bool columns = false;
    double ms = 0;
};

// Auto's probe fill: the small lattices of all entries of `table` (probe_lattices), each kind
// (volume, light lattices) in one launch as deep as its entries (render.cl fill_entry), into
// `values`, of the points `mode` and `mask` select. One launch per entry ran 2–8 work-groups at a time and kept the second core idle
// (bench/README.md "Where a first run's extra time goes").
std::vector<KindFill> fill_small_lattices(const FillLaunch& launch, FillKernels& kernels, const std::vector<ShadowCacheGpu>& small,
                                          const cl::Buffer& table, const cl::Buffer& values, FillMode mode = FillMode::All,
                                          const cl::Buffer* mask = nullptr) {
    std::vector<KindFill> fills;
    for (const bool columns : {false, true}) {
        std::size_t first = small.size(), last = 0;  // the kind's entries lie in first … last
        int width = 0, rows = 0;
        for (std::size_t e = 0; e < small.size(); ++e) {
            if ((small[e].column_axes.s[3] != 0) != columns) continue;
            first = std::min(first, e), last = e;
            width = std::max(width, small[e].dims.s[0]), rows = std::max(rows, all_rows(small[e]).count);
        }
        if (first > last) continue;
        cl::Kernel& kernel = kernels.of(small[first]);
        bind_fill(launch, kernel, first, table, values, mode, mask);
        cl::Event event = host::enqueue_packets(launch.runtime, kernel, width, rows, launch.lanes, int(last - first + 1));
        event.wait();
        fills.push_back({columns, host::Runtime::event_ms(event)});
    }
    return fills;
}

}  // namespace

std::vector<ShadowCacheGpu> probe_lattices(const std::vector<ShadowCacheGpu>& layout, int block, int stride, int lanes) {
    std::vector<ShadowCacheGpu> small;
    std::size_t total = 0;
    for (const ShadowCacheGpu& full : layout) {
        // a light lattice: blocks of whole columns along y, and along x every k-th packet of
        // `lanes` neighbouring columns, k · lanes columns apart as the blocks' rows are (below)
        const bool columns = full.column_axes.s[3] != 0;
        const int b = std::min({block, full.dims.s[1], columns ? block : full.dims.s[2]});
        // the probe lattice of blocks `s` rows apart (on a volume lattice), and how many blocks it
        // has along its fewest axis
        auto blocks_apart = [&](int s, int* fewest) {
            ShadowCacheGpu c = full;
            // rows from one block to the next
            const int step = std::max(b, columns ? int(std::lround(std::sqrt(double(b) * lanes) * s / b)) : s);
            *fewest = std::numeric_limits<int>::max();
            for (std::size_t a = 1; a < (columns ? 2u : 3u); ++a) {
                const int n = c.dims.s[a], blocks = std::max(1, (n - b) / step + 1);  // whole blocks inside
                if (n > b) *fewest = std::min(*fewest, blocks);
                // centred: a lattice's border rows are mostly empty space, cheap to fill
                c.block_origin.s[a] = float((n - ((blocks - 1) * step + b)) / 2) * c.spacing.s[a];
                c.dims.s[a] = blocks * b;
                c.spacing.s[a] *= float(step);
            }
            if (columns && c.dims.s[0] > lanes) {
                // (b / step) · (lanes / step) = (block / stride)², the share of the points a volume
                // lattice's blocks hold. Before, whole rows of blocks along y every stride² / b rows:
                // a small lattice's one block held 2/dims.y of its points (the cup array's 48 entries:
                // 1/16, a 37 ms probe of a 1 s fill; the CT's: 1/128), and the CT's centred block
                // estimated its fill of all points, 0.87 s, at 1.5–1.8 s
                const int n = c.dims.s[0], k = std::max(1, step / lanes);
                const int packets = (n - lanes) / (k * lanes) + 1;  // whole packets inside, centred
                *fewest = std::min(*fewest, packets);
                c.block_origin.s[0] = float((n - ((packets - 1) * k * lanes + lanes)) / 2);
                c.block_origin.s[3] = float(k * lanes);
                c.dims.s[0] = packets * lanes;
            }
            c.row_block = cl_uint(b), c.row_block_stride = cl_uint(step);
            return c;
        };
        int fewest = 0;
        ShadowCacheGpu c = blocks_apart(stride, &fewest);
        // a small lattice: blocks closer together, until kProbeMinBlocks lie along each axis (and
        // as many packets along a light lattice's x) or the probe would hold kProbeMaxShare times
        // (block / stride)² of its points. One centred block of a lattice 40–105 rows across
        // sampled its densest middle: the steaming cups' low-pass fill, 32–37 ms, was estimated
        // at 64–109 ms from one block every 64 rows, at 18–22 ms from two every 32
        // (bench/README.md "At least four blocks along each axis")
        const double max_points = kProbeMaxShare * double(block * block) / (double(stride) * stride) * double(lattice_points(full));
        for (int s = stride - 1; s >= b && fewest < kProbeMinBlocks; --s) {
            int closer_fewest = 0;
            const ShadowCacheGpu closer = blocks_apart(s, &closer_fewest);
            if (double(lattice_points(closer)) > max_points) break;
            c = closer, fewest = closer_fewest;
        }
        c.offset = cl_uint(total);  // c.reach stays: points near the same bricks are evaluated
        total += lattice_points(c);
        small.push_back(c);
    }
    return small;
}

std::array<int, 3> probe_point_in_lattice(const ShadowCacheGpu& small, const ShadowCacheGpu& full, int x, int y, int z, int lanes) {
    // across a light lattice's columns: every k-th packet, block_origin.w columns apart
    const int full_x = small.block_origin.s[3] > 0 ? int(small.block_origin.s[0]) + (x / lanes) * int(small.block_origin.s[3]) + x % lanes : x;
    // along y (and a volume lattice's z): render.cl lattice_voxel, in the full lattice's rows
    auto full_row = [&](int a, int k) {
        const int block = int(small.row_block);
        const double spacing = small.spacing.s[a];
        const double voxel = double(k / block) * spacing + double(k % block) * (spacing / double(small.row_block_stride)) + small.block_origin.s[a];
        return int(std::lround((voxel - full.block_origin.s[a]) / full.spacing.s[a]));
    };
    return {full_x, full_row(1, y), small.column_axes.s[3] ? z : full_row(2, z)};
}

std::vector<cl_uint> probe_block_marks(std::vector<ShadowCacheGpu>& small, const std::vector<ShadowCacheGpu>& layout,
                                       const std::vector<cl_uint>& frame_marks, const std::vector<bool>& entries, int lanes) {
    std::size_t words = 0;
    for (ShadowCacheGpu& c : small) {
        c.mark_row_words = cl_uint((c.dims.s[0] + 31) / 32);
        c.mark_offset = cl_uint(words);
        words += mask_words(c);
    }
    std::vector<cl_uint> marks(words, 0);
    for (std::size_t e = 0; e < small.size() && e < layout.size(); ++e) {
        if (e >= entries.size() || !entries[e]) continue;
        const ShadowCacheGpu &c = small[e], &full = layout[e];
        // each index's along its own axis (probe_point_in_lattice maps the axes apart; −1: outside)
        std::array<std::vector<int>, 3> to_full;
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < c.dims.s[a]; ++k) {
                const int f = probe_point_in_lattice(c, full, a == 0 ? k : 0, a == 1 ? k : 0, a == 2 ? k : 0, lanes)[std::size_t(a)];
                to_full[std::size_t(a)].push_back(f >= 0 && f < full.dims.s[a] ? f : -1);
            }
        for (int z = 0; z < c.dims.s[2]; ++z)
            for (int y = 0; y < c.dims.s[1]; ++y) {
                const int fy = to_full[1][std::size_t(y)], fz = to_full[2][std::size_t(z)];
                if (fy < 0 || fz < 0) continue;
                const cl_uint* full_row = &frame_marks[full.mark_offset + (std::size_t(fy) + std::size_t(full.dims.s[1]) * std::size_t(fz)) * full.mark_row_words];
                cl_uint* row = &marks[c.mark_offset + (std::size_t(y) + std::size_t(c.dims.s[1]) * std::size_t(z)) * c.mark_row_words];
                for (int x = 0; x < c.dims.s[0]; ++x) {
                    const int fx = to_full[0][std::size_t(x)];
                    if (fx >= 0 && (full_row[fx / 32] >> (fx % 32) & 1u)) row[x / 32] |= 1u << (x % 32);
                }
            }
    }
    return marks;
}

CameraGpu probe_launch_camera(CameraGpu frame, int lanes) {
    const int width = int(frame.width), height = std::max(1, int(frame.height));
    const int row_packets = std::max(1, (width + lanes - 1) / lanes);
    const int wanted_stride = kProbePacketStride * std::max(1, 256 / height);
    const int packet_stride = std::min(wanted_stride, row_packets);
    frame.first_row = 0, frame.first_packet = 0;
    frame.packet_stride = cl_uint(packet_stride);
    frame.row_stride = cl_uint(std::min(height, std::max(1, height / kProbeRowsPerLaunch) * ((wanted_stride + packet_stride - 1) / packet_stride)));
    return frame;
}

RenderedPackets::RenderedPackets(int width, int height, int lanes)
    : width_(width), lanes_(lanes), row_packets_((width + lanes - 1) / lanes) {
    bits.assign((std::size_t(row_packets_) * std::size_t(std::max(height, 0)) + 31) / 32, 0u);
}

void RenderedPackets::add(int y, int packet) {
    const std::size_t bit = std::size_t(y) * std::size_t(row_packets_) + std::size_t(packet);
    if ((bits[bit / 32] >> (bit % 32)) & 1u) return;
    bits[bit / 32] |= 1u << (bit % 32);
    pixels += unsigned(std::min(lanes_, width_ - packet * lanes_));
}

std::vector<std::array<int, 2>> camera_launch_packets(const CameraGpu& camera, int lanes) {
    std::vector<std::array<int, 2>> packets;
    const int row_packets = (int(camera.width) + lanes - 1) / lanes, stride = int(std::max(camera.packet_stride, cl_uint(1)));
    for (cl_uint row = 0, y = camera.first_row; y < camera.height; ++row, y += std::max(camera.row_stride, cl_uint(1)))
        for (int packet = int((camera.first_packet + row) % cl_uint(stride)); packet < row_packets; packet += stride)
            packets.push_back({int(y), packet});
    return packets;
}

namespace {

// Auto's measurement (issue 29 item 5): what the frame's shadow terms cost both ways, from small
// runs of the real kernels before the frame. The fill: every lattice's rows along x in blocks of
// 2 × 2 neighbouring rows along y and z every 64 rows, centred (1/1024 of its points; whole rows, so that a
// packet's lanes are neighbours as in the fill), after 10 ms of untimed warm-up, the stale ones'
// time scaled by their points; unless the first camera launch then decides at 3×, again every
// 32 rows (1/256); when the result is a close call (within 2×), again in blocks of 4 × 4 (1/64)
// if that fits the budget. The camera pass: 16 image rows a launch, a sixteenth of
// the image apart, of each every 4th packet of SOMBRA_LANES neighbouring pixels (lanes as coherent
// as the frame's), staggered from row to row: the pixels of 4 rows spread over the image, where 4
// whole rows a quarter apart missed or hit a small object's band of rows (two_smokes_wall's
// shadow rays at 256²: the per-sample pass estimated at 102–106 ms against 175–195 ms). The
// launches' row offsets in van der Corput order (the middle of each sixteenth, then of each
// 32nd, …), each launch once evaluating the technique per sample and once reading the small
// lattices (a lattice costs the same to read at any size; its values are thrown away), scaled by
// the packets. It stops when one side costs twice the other, after 4 launches, or when its next
// launch would take the probe past kProbeBudget of the cheaper frame. Before the first launch, a
// scout with a quarter of its packets may decide for the cache at 3×. The per-sample launches
// write into `frame`'s image rows and note their packets in `rendered_packets` (a bit per packet
// of the image), which a frame then evaluated per sample keeps (FrameImage).
struct VolumeCosts {
    double fill_ms = 0, per_sample_ms = 0, cached_ms = 0, probe_ms = 0;
    double marked_share = -1;  // estimate_marked_share's, where the probe ran it (−1: not estimated)
    double marked_fill_ms = -1;  // the estimated share's fill: on the probe's blocks, or where paths are marched from the per-sample pass (−1: not estimated)
    double marked_points_per_sample = -1;  // where each point's path is marched: the marked points ÷ the image's samples
    bool marked_after_probe = false;  // its marking pass ran after its camera launches (else in them, if at all)
};

// `all_stages` (SOMBRA_AUTO_PROBE_ALL): every stage runs whatever the earlier ones found, each
// reported there, and two more fills, in blocks of 4 and 8 rows every 64 (bench/probe_accuracy.py).
// `mark_points` (where the frame may mark the points it reads, --shadow-cache-fill visible): the
// marking pass, returning the share of the points it found (and, given a pointer, the camera
// samples it counted). The probe runs it once, after its first launch and fill every 32 rows,
// when visible_fill_worth_marking holds, and goes on with the fill's estimates scaled by that
// share: its decision and budget then weigh the frame the cache would take (the MRI's cone
// shadows at 512²: every point's fill estimated at 3 s, the marked points' at 0.7 s; three more
// launches and a close call's fill, 160 ms of probe, had decided between the per-sample pass and
// the fill of every point, which the frame never runs).
VolumeCosts probe_volume_costs(const FillLaunch& launch, const VolumePlan& plan, int width, int height,
                               const surfaces::ViewFragments* fragments, const SurfaceShadowCache* surface_cache,
                               const std::function<double(double*)>* mark_points,
                               const std::function<SampledMarks(double*)>* estimate_share,
                               std::vector<RenderStats::ProbeStage>* all_stages, const FrameImage& frame, RenderedPackets& rendered_packets) {
    host::Runtime& runtime = launch.runtime;
    // the probe's short launches must not make the frame's long ones run unbanded (tiled_launch.cpp)
    const double last_launch_ms = runtime.progress().last_launch_ms;
    VolumeCosts costs;
    // the probe lattices (probe_lattices) filled and timed; returns the stale ones' fill time scaled
    // by their points. Blocks, not rows as far apart: a point's shadow ray reads what its
    // neighbours' read, so that evenly spread rows (every 16th) cost 1.2–1.9× as much per point as
    // the frame's fill (bench/README.md "sombra_bench_cache_auto"). The camera pass reads the last.
    cl::Buffer values, table;
    double warm_ms = 0;
    double last_fill_probe_ms = 0, last_fill_probe_share = 0;  // the last fill probe's time and (block/stride)²
    // a fill probe's launches' time scaled to the stale entries' points (per kind, by their share
    // of the kind's small lattices' points)
    auto scaled_to_stale = [&](const std::vector<KindFill>& kinds, const std::vector<ShadowCacheGpu>& small, double* kernel_ms) {
        double fill_ms = 0;
        for (const KindFill& kind : kinds) {
            *kernel_ms += kind.ms;
            double small_points = 0, stale_points = 0;
            for (std::size_t e = 0; e < small.size(); ++e) {
                if ((small[e].column_axes.s[3] != 0) != kind.columns) continue;
                small_points += double(lattice_points(small[e]));
                if (plan.stale[e]) stale_points += double(lattice_points(plan.layout[e]));
            }
            fill_ms += kind.ms * stale_points / std::max(small_points, 1.0);
        }
        return fill_ms;
    };
    auto fill_blocks = [&](int block, int stride, bool warm_up) {
        const std::vector<ShadowCacheGpu> small = probe_lattices(plan.layout, block, stride, launch.lanes);
        const std::size_t total = small.back().offset + lattice_points(small.back());
        values = host::make_buffer(runtime, CL_MEM_READ_WRITE, total * sizeof(float), nullptr, "shadow cache probe");
        table = host::make_buffer(runtime, CL_MEM_READ_ONLY, small.size() * sizeof(ShadowCacheGpu), small.data(), "shadow cache probe table");
        FillKernels kernels{launch.program, {}, {}};
        double fill_ms = 0;
        // the first milliseconds of launches after the frame's preparation run slow (smoke, rays at
        // 256²: every 16th row's 2–4 ms launches took up to 2× their later time): the first
        // small lattice's first row of blocks along z is filled untimed first (bench/README.md
        // "sombra_bench_cache_auto"; a whole probe lattice was one 22 ms launch on the CT)
        if (warm_up) {
            ShadowCacheGpu warm = small[0];
            warm.dims.s[2] = std::min(warm.dims.s[2], int(warm.row_block));
            for (int k = 0; warm_ms < kProbeWarmupMs && k < kProbeWarmupLaunches; ++k)
                warm_ms += fill_lattice(launch, kernels, 0, warm, table, values);
            costs.probe_ms += warm_ms;
        }
        double probe_ms = 0;
        fill_ms = scaled_to_stale(fill_small_lattices(launch, kernels, small, table, values), small, &probe_ms);
        costs.probe_ms += probe_ms;
        if (all_stages) all_stages->push_back({"fill", "blocks " + std::to_string(block) + " every " + std::to_string(stride), probe_ms, fill_ms});
        last_fill_probe_ms = probe_ms, last_fill_probe_share = double(block * block) / (double(stride) * stride);
        return fill_ms;
    };
    // what a fill probe of `block` × `block` rows every `stride` would take, from the last one
    auto fill_probe_ms = [&](int block, int stride) {
        return last_fill_probe_ms * double(block * block) / (double(stride) * stride) / last_fill_probe_share;
    };
    // whether one side costs `factor` times the other
    auto decided = [&](double factor) {
        const double with_cache = costs.fill_ms + costs.cached_ms;
        return costs.per_sample_ms > factor * with_cache || factor * costs.per_sample_ms < with_cache;
    };
    costs.fill_ms = fill_blocks(kProbeBlock, kProbeCoarseStride, true);
    bool fine_fill = false;  // the fill measured every kProbeBlockStride rows
    auto measure_fine_fill = [&] {
        costs.fill_ms = fill_blocks(kProbeBlock, kProbeBlockStride, false);
        fine_fill = true;
    };
    // The fill of the points a frame's marking pass would find, before it runs (marking_pays_on_share),
    // where every stale entry is a light lattice: the points the share estimate's sampled rows need
    // (SampledMarks.cover) filled on the close call's probe lattices (4 × 4 blocks every 32 rows,
    // 1/64 of the points; probe_block_marks), scaled to the lattices' points. Not the marked
    // share of every point's fill: a light lattice's column is marched from its first readable
    // point to its last needed one, so that the default scene's shadow rays at 128² filled 5.5 %
    // of the points in 0.46 of the time of every point's fill (the share's estimate: 46 ms
    // against 355 ms; the sampled rows': 164 ms, their march is shorter than all rows'; the MRI's:
    // 51, 131 and 151 ms; bench/README.md "The marked points' fill, sampled"). Not on volume
    // lattices, whose packets evaluate a shadow ray a lane: the sampled rows' points, a few a
    // packet, cost several times a frame's marked points each (bounded_smoke's shadow rays at
    // 256², estimated at 1.6× their fill, chose per sample at 2.4× the cache's frame).
    auto fill_marked_blocks = [&](const std::vector<cl_uint>& marked) -> std::optional<double> {
        for (std::size_t e = 0; e < plan.layout.size(); ++e)
            if (plan.stale[e] && !plan.layout[e].column_axes.s[3]) return std::nullopt;
        std::vector<ShadowCacheGpu> small = probe_lattices(plan.layout, kProbeCloseCallBlock, kProbeBlockStride, launch.lanes);
        const std::vector<cl_uint> marks = probe_block_marks(small, plan.layout, marked, plan.stale, launch.lanes);
        const cl::Buffer marked_table = host::make_buffer(runtime, CL_MEM_READ_ONLY, small.size() * sizeof(ShadowCacheGpu), small.data(),
                                                          "shadow cache probe table (marked)");
        const cl::Buffer mask = host::make_buffer(runtime, CL_MEM_READ_ONLY, std::max<std::size_t>(marks.size(), 1) * sizeof(cl_uint),
                                                  marks.empty() ? nullptr : marks.data(), "shadow cache probe marks");
        const std::size_t points = small.back().offset + lattice_points(small.back());
        const cl::Buffer marked_values = host::make_buffer(runtime, CL_MEM_READ_WRITE, points * sizeof(float), nullptr, "shadow cache probe (marked)");
        FillKernels kernels{launch.program, {}, {}};
        double probe_ms = 0;
        const double fill_ms =
            scaled_to_stale(fill_small_lattices(launch, kernels, small, marked_table, marked_values, FillMode::Marked, &mask), small, &probe_ms);
        costs.probe_ms += probe_ms;
        if (all_stages) all_stages->push_back({"fill", "sampled rows' marked points", probe_ms, fill_ms});
        return fill_ms;
    };
    // A technique that marches each point's own path to the light, on volume lattices (one that
    // fills light columns, on volumes with polyhedral bounds: cache_layout): a marked point lies
    // where the camera's samples do, in the medium, and its path costs what theirs do, while the
    // lattice's average point, mostly in empty space, costs far less. bounded_smoke's shadow rays:
    // marked points cost 1.8–2.0× the average point (128², 256²), 0.9–1.1× a camera sample's
    // shadow ray (the per-sample pass less the cached one, per sample). So their fill is the
    // per-sample pass's shadow time times the marked points ÷ the image's samples (both counted by
    // the marking passes: the share estimate's sampled rows, then the frame's), at the per-sample
    // pass's latest estimate. Elsewhere a point's
    // fill costs 0.6–1.0× the average point (cone, low-pass, AO, shadow maps; bench/README.md
    // "Marked points on marched paths").
    bool path_marched = launch.prepared.technique.fills_light_columns(launch.options);
    for (std::size_t e = 0; e < plan.layout.size(); ++e)
        if (plan.stale[e] && plan.layout[e].column_axes.s[3]) path_marched = false;
    // where paths are marched, the marked points ÷ the image's samples, from `share` of the points
    // to fill and the `samples` a marking pass counted; whether it was set
    auto count_path = [&](double share, double samples) {
        if (!path_marched || samples <= 0) return false;
        costs.marked_points_per_sample = share * plan.points_to_fill / samples;
        return true;
    };
    // the marked points' fill where paths are marched (once counted), at the per-sample pass's
    // latest estimate
    auto path_fill_ms = [&] { return std::max(0.0, costs.per_sample_ms - costs.cached_ms) * costs.marked_points_per_sample; };
    bool marked = false;
    double marked_ratio = 1;  // once marked, the fill estimate's share of every point's
    auto mark = [&] {
        marked = true;
        double image_samples = 0;
        const double share = (*mark_points)(&image_samples), every_point_ms = costs.fill_ms;
        const double path_ms = count_path(share, image_samples) ? path_fill_ms() : -1;
        // where paths are marched, at the per-sample pass's time; else the sampled rows' marked
        // fill, else the share of every point's
        costs.fill_ms = path_ms >= 0 ? path_ms : costs.marked_fill_ms >= 0 ? costs.marked_fill_ms : costs.fill_ms * share;
        marked_ratio = costs.fill_ms / std::max(every_point_ms, 1e-9);
    };
    const int lanes = launch.lanes, row_packets = (width + lanes - 1) / lanes;
    CameraGpu camera = probe_launch_camera(frame_camera(launch.scene, launch.options, width, height), lanes);
    const double image_packets = double(row_packets) * height;
    CameraPassReads per_sample, cached;
    per_sample.image_rows = true;  // the frame's pixels, kept when it then evaluates per sample (FrameImage)
    per_sample.fragments = cached.fragments = fragments;
    per_sample.surface_cache = cached.surface_cache = surface_cache;
    cached.volume_cache = &values, cached.volume_cache_table = &table;
    // a launch writes its rows (at most height / row_stride rounded up, more than 16 when the
    // stride rounds down) at the image's width
    const std::size_t launch_pixels = std::size_t(width) * ((std::size_t(height) + camera.row_stride - 1) / camera.row_stride);
    cl::Buffer image = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, launch_pixels * sizeof(cl_float4), nullptr, "probe rows");
    cl::Buffer counts = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, launch_pixels * sizeof(cl_uint), nullptr, "probe row samples");
    double per_sample_sum = 0, cached_sum = 0, last_launch = 0, packets_done = 0;
    // the probe's further steps must cost little against the frame either way would cost: a close
    // call is one where either choice costs about the same, so probing it long costs more than a
    // wrong choice (bench/README.md "sombra_bench_cache_auto")
    auto cheaper_frame_ms = [&] { return std::min(costs.per_sample_ms, costs.fill_ms + costs.cached_ms); };
    auto within_budget = [&](double step_ms) {
        return costs.probe_ms + per_sample_sum + cached_sum + step_ms <= kProbeBudget * cheaper_frame_ms();
    };
    auto launch_packets = [&](const CameraGpu& c) { return double(camera_launch_packets(c, lanes).size()); };
    // a per-sample launch into the frame's image rows, its packets noted
    auto run_per_sample = [&](const CameraGpu& c) {
        const double ms = run_camera_pass(runtime, launch.scene, launch.prepared, launch.options, lanes, c, per_sample, frame.image, frame.sample_counts);
        for (const auto& [y, packet] : camera_launch_packets(c, lanes)) rendered_packets.add(y, packet);
        return ms;
    };
    // the per-sample pass again, on a band of whole rows in the image's middle (1/kWholeRowBand of
    // its rows, a launch each; the frame's pixels, kept): their time per sample times the image's
    // samples as the scout's packets spread over it found them. The scout's own time per sample
    // runs high on its scattered packets (at 128² 1.4–2.4× where marking lost), the band's less
    // (0.9–1.3×; rows spread over the image, without their neighbours, 1.0–1.5×: bench/README.md
    // "The marked share, sampled"), and its rows alone would miss a small object's samples. The
    // launches below, whose per-sample pass runs 1.1–1.5× high at 128² (bench/README.md "Where
    // the first runs still miss"), are then left out
    bool per_sample_on_rows = false;
    std::vector<CameraGpu> scout_launches;  // (their samples spread over the image)
    auto per_sample_on_whole_rows = [&] {
        std::vector<CameraGpu> launches;  // a row each
        const int band = std::max(1, height / kWholeRowBand);
        for (int j = 0; j < band; ++j) {
            CameraGpu row = camera;
            row.row_stride = cl_uint(height), row.first_row = cl_uint(std::clamp(height / 2 - band / 2 + j, 0, height - 1));
            row.packet_stride = 1, row.first_packet = 0;
            launches.push_back(row);
        }
        // a row at a time, while the next one, at their average so far, fits the band's allowance
        const double allowance = std::max(kProbeBudget * cheaper_frame_ms(), kProbeBandOverrun * costs.per_sample_ms / kWholeRowBand);
        double rows_ms = 0;
        std::size_t rows_run = 0;
        for (const CameraGpu& c : launches) {
            if (rows_run > 0 && rows_ms * double(rows_run + 1) / double(rows_run) > allowance) break;
            rows_ms += run_per_sample(c);
            ++rows_run;
        }
        launches.resize(rows_run);
        costs.probe_ms += rows_ms;
        std::vector<cl_uint> counts_read(std::size_t(width) * std::size_t(height));
        runtime.queue().enqueueReadBuffer(frame.sample_counts, CL_TRUE, 0, counts_read.size() * sizeof(cl_uint), counts_read.data());
        auto samples_in = [&](int y, int packet) {
            double n = 0;
            for (int x = packet * lanes; x < std::min(width, (packet + 1) * lanes); ++x) n += counts_read[std::size_t(y) * std::size_t(width) + std::size_t(x)];
            return n;
        };
        double rows_samples = 0, rendered_samples = 0, rendered_pixels = 0;
        for (const CameraGpu& c : launches)
            for (const auto& [y, packet] : camera_launch_packets(c, lanes)) rows_samples += samples_in(y, packet);
        for (const CameraGpu& c : scout_launches.empty() ? launches : scout_launches)
            for (const auto& [y, packet] : camera_launch_packets(c, lanes)) {
                rendered_samples += samples_in(y, packet);
                rendered_pixels += std::min(lanes, width - packet * lanes);
            }
        if (rows_samples > 0 && rendered_pixels > 0) {
            costs.per_sample_ms = rows_ms / rows_samples * rendered_samples / rendered_pixels * double(width) * double(height);
            per_sample_on_rows = true;
        }
    };
    // whether marking pays on the marked share estimated from sampled rows (marked_share_pays; once
    // a frame), where `close_call_rows`: on a close call, the per-sample pass measured on whole rows
    bool share_asked = false;
    // the marked points' fill as a share of every point's: estimated on the blocks, else the marked share
    auto marking_share = [&] {
        return costs.marked_fill_ms >= 0 ? std::min(1.0, costs.marked_fill_ms / std::max(costs.fill_ms, 1e-9)) : costs.marked_share;
    };
    auto marking_pays_on_share = [&](bool close_call_rows) {
        // (not where marking pays with every point marked: the estimate could not change that)
        if (!estimate_share || marked_share_pays(1, costs.fill_ms, costs.cached_ms, costs.per_sample_ms)) return true;
        if (!share_asked) {
            double ms = 0;
            const SampledMarks sampled = (*estimate_share)(&ms);
            costs.marked_share = sampled.share;
            costs.probe_ms += ms;
            share_asked = true;
            if (sampled.share >= 0 && sampled.sampled_points > 0) {
                if (!path_marched) costs.marked_fill_ms = fill_marked_blocks(sampled.cover).value_or(-1);
                else if (count_path(sampled.share, sampled.image_samples)) costs.marked_fill_ms = path_fill_ms();
            }
        }
        const double share = marking_share();
        if (!marked_share_pays(share, costs.fill_ms, costs.cached_ms, costs.per_sample_ms)) return false;
        if (!close_call_rows || marked_share_pays(share, costs.fill_ms, costs.cached_ms, costs.per_sample_ms / kMarkedShareClear)) return true;
        per_sample_on_whole_rows();
        return marked_share_pays(share, costs.fill_ms, costs.cached_ms, costs.per_sample_ms);
    };
    // tests/test_shadow_cache.cpp: estimates the marked share and the per-sample pass on whole rows
    // here, and marks here, before the other camera launches, whatever they find
    if (estimate_share && std::getenv("SOMBRA_TEST_ESTIMATE_SHARE")) {
        marking_pays_on_share(false);
        per_sample_on_whole_rows();
    }
    if (mark_points && std::getenv("SOMBRA_TEST_MARK_IN_PROBE")) mark();
    // untimed first: one packet. A kernel's first launch in a process pays the driver's loading of
    // its code (PoCL: 1–2.5 ms), a large share of a launch of a 100–300 ms frame's 1/64
    // (two_smokes_wall's shadow rays at 256²: 3.8–5.0 ms against 2.5 ms after it); both kinds of
    // launch run the same kernel (render.cl shadow_cache_reads)
    {
        CameraGpu one = camera;
        one.row_stride = cl_uint(height), one.packet_stride = cl_uint(row_packets), one.first_row = cl_uint(height / 2);
        costs.probe_ms += run_per_sample(one);
    }
    // a scout first, where the image is wide enough: the first launch's rows, every
    // kProbeScoutThinning-th of its packets. Only the cache's side may be decided from it (as from
    // the coarse fill, at 3×): a frame whose per-sample pass costs many times the cache paid 1/64
    // of that pass to learn it (the head in fog's shadow rays at 256²: 470 ms of a 30 s pass, the
    // cache's frame 1.56 s), while a scout that misses the volumes makes the per-sample pass look
    // cheap, which the launches below then cost little to correct. Its 32–64 packets estimate the
    // pass within about ± 50 % (the CT's shadow rays at 256²: 5.2–6.5 s against 3.6 s).
    // It runs in four quarters of its rows (every 4th row, a quarter spread over the image; in the
    // order 1st, 3rd, 2nd, 4th, so that the first two are every other row), each deciding on all
    // rows so far: the first alone at kProbeQuarterScoutClear, the first two or three at
    // kProbeHalfScoutClear, all four at kProbeScoutClear. The head in fog's shadow rays at 128²:
    // its per-sample pass 11 times the cache's frame, a scout's half of 91 ms on a 1.1 s frame.
    // (Quarters of its packets would leave some empty: at 128² a row holds one scout packet.)
    bool scouted = false;
    const int scout_stride = std::min(row_packets, int(kProbeScoutThinning * camera.packet_stride));
    if (scout_stride > int(camera.packet_stride)) {
        double per_sample_scout = 0, cached_scout = 0, scout_packets = 0;
        constexpr int kQuarters = 4, quarter_order[kQuarters] = {0, 2, 1, 3};
        constexpr double clear_after[kQuarters] = {kProbeQuarterScoutClear, kProbeHalfScoutClear, kProbeHalfScoutClear, kProbeScoutClear};
        for (int piece = 0; piece < kQuarters && !scouted; ++piece) {
            CameraGpu scout = camera;
            scout.row_stride = camera.row_stride * kQuarters, scout.first_row = camera.row_stride / 2 + quarter_order[piece] * camera.row_stride;
            scout.packet_stride = cl_uint(scout_stride), scout.first_packet = cl_uint(quarter_order[piece]);
            if (scout.first_row >= cl_uint(height)) continue;  // images of a few rows (row_stride 1)
            per_sample_scout += run_per_sample(scout);
            scout_launches.push_back(scout);
            cached_scout += run_camera_pass(runtime, launch.scene, launch.prepared, launch.options, lanes, scout, cached, image, counts);
            scout_packets += launch_packets(scout);
            if (scout_packets == 0) continue;
            costs.per_sample_ms = per_sample_scout * image_packets / scout_packets, costs.cached_ms = cached_scout * image_packets / scout_packets;
            if (all_stages) {
                const std::string stage = "scout " + std::to_string(piece + 1);
                all_stages->push_back({"per_sample", stage, per_sample_scout, costs.per_sample_ms});
                all_stages->push_back({"cached", stage, cached_scout, costs.cached_ms});
                continue;
            }
            scouted = costs.per_sample_ms > clear_after[piece] * (costs.fill_ms + costs.cached_ms);
        }
        costs.probe_ms += per_sample_scout + cached_scout;
        // the cached pass on the first launch's packets, 4 (at 512² 16) times the scout's first
        // quarter (1/64 of the pass; 1/128 at 512²): the scout's launches of a few packets read both
        // passes high by about the same factor (1.1–3.7×, bench/README.md "Marking after the
        // scout"), so that before a marking pass the per-sample pass is scaled by what this finds
        bool cached_remeasured = false;
        auto remeasure_cached = [&](bool scale_per_sample) {
            CameraGpu first = camera;
            first.first_row = camera.row_stride / 2, first.first_packet = 1;
            const double cached_launch = run_camera_pass(runtime, launch.scene, launch.prepared, launch.options, lanes, first, cached, image, counts);
            const double first_packets = launch_packets(first);
            costs.probe_ms += cached_launch;
            cached_remeasured = true;
            if (first_packets == 0 || cached_launch <= 0) return;
            const double cached_ms = cached_launch * image_packets / first_packets;
            if (scale_per_sample && costs.cached_ms > 0) costs.per_sample_ms *= cached_ms / costs.cached_ms;
            costs.cached_ms = cached_ms;
        };
        // not decided by the scout, where the frame may mark and marking is worth it on the scout's
        // estimates: the cached pass again (scaling the per-sample pass), the fill every
        // kProbeBlockStride rows, the marking pass if the condition still holds, and the scout's
        // decision again, at kProbeScoutClear, on the marked points' fill. Decided so, the probe
        // skips the first launch, 1/64 of the per-sample pass (the head in fog's cone shadows at
        // 256²: 150 ms of a 246 ms probe; bench/README.md "Marking after the scout")
        if (!scouted && scout_packets > 0 && mark_points && !marked &&
            visible_fill_worth_marking(costs.fill_ms, costs.cached_ms, costs.per_sample_ms)) {
            remeasure_cached(true);
            measure_fine_fill();
            if (visible_fill_worth_marking(costs.fill_ms, costs.cached_ms, costs.per_sample_ms) && marking_pays_on_share(true)) {
                mark();
                // where paths are marched, the fill's estimate moves with the per-sample pass's
                // (path_fill_ms), so that a scout reading that pass high reads both high: the
                // launches' kProbeClear (bounded_smoke's shadow rays at 256², 2.7×: at 3× the
                // launches ran, 18 ms more probe, 1.02 → 1.12×)
                const double clear = path_marched && costs.marked_points_per_sample >= 0 ? kProbeClear : kProbeScoutClear;
                scouted = costs.per_sample_ms > clear * (costs.fill_ms + costs.cached_ms);
            }
        }
        if (scouted) {
            if (!cached_remeasured) remeasure_cached(false);
            // and, where the marking condition fails narrowly on the coarse fill (marking_close_call),
            // the fill every kProbeBlockStride rows: the MRI's shadow rays at 256² (coarse fill
            // 164–277 ms against 257–520 ms) filled every point, 1.16× the marked fill's frame
            // (bench/README.md "Marking after the scout")
            if (mark_points && !marked && !fine_fill && marking_close_call(costs.fill_ms, costs.cached_ms)) {
                measure_fine_fill();
            }
        }
    }
    std::vector<bool> done(camera.row_stride, false);
    int launches_run = 0;
    for (unsigned k = 1; !scouted && !per_sample_on_rows && k <= 4 * kProbeLaunches && packets_done < image_packets; ++k) {
        double fraction = 0;  // van der Corput: k's bits mirrored behind the binary point
        for (unsigned bits = k, weight = 2; bits; bits >>= 1, weight *= 2) fraction += double(bits & 1u) / weight;
        const cl_uint first = std::min(camera.row_stride - 1, cl_uint(fraction * camera.row_stride));
        if (done[first]) continue;
        done[first] = true;
        camera.first_row = first, camera.first_packet = cl_uint(k);
        if (packets_done > 0 && !within_budget(last_launch) && !all_stages) break;
        const double per_sample_launch = run_per_sample(camera);
        const double cached_launch = run_camera_pass(runtime, launch.scene, launch.prepared, launch.options, lanes, camera, cached, image, counts);
        per_sample_sum += per_sample_launch, cached_sum += cached_launch, last_launch = per_sample_launch + cached_launch;
        packets_done += launch_packets(camera);
        ++launches_run;
        costs.per_sample_ms = per_sample_sum * image_packets / packets_done, costs.cached_ms = cached_sum * image_packets / packets_done;
        if (all_stages) {
            const std::string stage = "launch " + std::to_string(launches_run);
            all_stages->push_back({"per_sample", stage, per_sample_sum, costs.per_sample_ms});
            all_stages->push_back({"cached", stage, cached_sum, costs.cached_ms});
        } else if (decided(fine_fill ? kProbeClear : kProbeCoarseClear)) break;
        // not decided by the coarse fill: the fill every kProbeBlockStride rows (≈ 4 × the first),
        // whatever the budget (decisions on small frames from the coarse fill alone chose the
        // slower mode more often: two_smokes_wall's AO at 128², 1.27 → 1.56×)
        if (!fine_fill) {
            measure_fine_fill();
            if (mark_points && !marked && visible_fill_worth_marking(costs.fill_ms, costs.cached_ms, costs.per_sample_ms) &&
                marking_pays_on_share(false))
                mark();
            if (decided(kProbeClear) && !all_stages) break;
        }
        if (launches_run >= kProbeLaunches) break;
    }
    // a close call: the fill again on 1/64 of the rows (4 × 4 blocks: single estimates from the
    // 1/256's few blocks spread by ± 40 %), when it fits the budget (once marked, at the marked
    // fill's share of every point's that the marking found)
    if (all_stages || (!decided(kProbeClear) && within_budget(fill_probe_ms(kProbeCloseCallBlock, kProbeBlockStride))))
        costs.fill_ms = marked_ratio * fill_blocks(kProbeCloseCallBlock, kProbeBlockStride, false);
    if (all_stages) fill_blocks(4, 64, false), fill_blocks(8, 64, false);
    // a close call within kProbeBandClear: the per-sample pass again on the band of whole rows
    // (its pixels kept when the frame evaluates per sample), unless a close call on the marked
    // share measured it. The launches' per-sample estimate runs 1.1–1.5× high at 128², the band's
    // 0.9–1.3×: teapot_fog's low-pass at 128², per sample estimated at 45–48 ms against a 33 ms
    // pass, chose the cache's 36–40 ms (bench/README.md "The per-sample band on every close call").
    // Not held to the probe's budget alone: the band is 1/64 of the per-sample pass, under 2 % of
    // either frame so close, and kept where the frame evaluates per sample; but rows in the densest
    // part of the image cost several times that, so it stops at twice its share
    // (kProbeBandOverrun).
    //
    // The band's rows can miss what the launches' rows found (the steaming cups' shadow rays at
    // 256²: 11–14 ms per sample on the band against a 93–99 ms pass, which the launches read at
    // about 95 ms), so its estimate is taken only within kProbeBandAgrees of theirs.
    // (tests/test_shadow_cache.cpp: SOMBRA_TEST_CLOSE_CALL_BAND takes every frame for a close call)
    const bool close_call = !decided(kProbeBandClear) || std::getenv("SOMBRA_TEST_CLOSE_CALL_BAND");
    if (!all_stages && !per_sample_on_rows && close_call) {
        const double launches_ms = costs.per_sample_ms;
        per_sample_on_whole_rows();
        if (costs.per_sample_ms < launches_ms / kProbeBandAgrees || costs.per_sample_ms > launches_ms * kProbeBandAgrees)
            costs.per_sample_ms = launches_ms;
    }
    // (marked where paths are marched: the fill at the per-sample pass's latest estimate)
    if (marked && path_marched && costs.marked_points_per_sample >= 0) costs.fill_ms = path_fill_ms();
    // marking after the probe, where its estimates (and the share estimated before it) say it pays
    if (mark_points && !marked && visible_fill_worth_marking(costs.fill_ms, costs.cached_ms, costs.per_sample_ms) &&
        marked_share_pays(marking_share(), costs.fill_ms, costs.cached_ms, costs.per_sample_ms)) {
        mark();
        costs.marked_after_probe = true;
    }
    costs.probe_ms += per_sample_sum + cached_sum;
    runtime.progress().last_launch_ms = last_launch_ms;
    return costs;
}

// What auto measured (or, remembered, what the frame's first render measured) into the stats.
void report_auto_costs(const VolumeCosts& costs, RenderStats& stats) {
    stats.shadow_cache_estimated_fill_ms = costs.fill_ms;
    stats.shadow_cache_estimated_cached_ms = costs.cached_ms;
    stats.shadow_cache_estimated_per_sample_ms = costs.per_sample_ms;
    stats.shadow_cache_estimated_marked_share = costs.marked_share;
    stats.shadow_cache_estimated_marked_fill_ms = costs.marked_fill_ms;
    stats.shadow_cache_estimated_marked_points_per_sample = costs.marked_points_per_sample;
}

// Auto's choices, by everything the frame's image depends on (the_choice_key): the same frame
// rendered again in this process, on any Context, reads the cache or not as the first time did,
// so that its image is the same. Measured times differ from run to run; close calls would
// otherwise flip. Never destroyed: a static Context may render during exit.
struct AutoChoice {
    bool volumes = false, surfaces = false;
    VolumeCosts costs;  // what the first frame measured (zeros when it did not need to)
};

struct RememberedChoices {
    std::mutex mutex;  // held while a choice is made, so that two first frames make one
    std::map<std::string, AutoChoice> choices;
    std::deque<std::string> order;  // oldest first
};

RememberedChoices& remembered_choices() {
    static auto* remembered = new RememberedChoices;
    return *remembered;
}

std::string the_choice_key(host::Runtime& runtime, const Scene& scene, const PreparedScene& p, const RenderOptions& options,
                           int width, int height, int lanes) {
    std::string key = runtime.device().getInfo<CL_DEVICE_NAME>() + " | " + runtime.device().getInfo<CL_DEVICE_VERSION>() +
                      " | lanes " + std::to_string(lanes) + " | " + p.keys.content() + " | lights";
    for (const std::string& light : p.light_keys) key += " " + light;
    for (const OptionSpec& spec : render_option_specs()) key += " | " + spec.key + "=" + option_value_text(spec.get(options));
    CameraGpu camera = frame_camera(scene, options, width, height);
    return key + " | camera " + std::string(reinterpret_cast<const char*>(&camera), sizeof camera);
}

}  // namespace

const ShadowCache* shadow_cache_for_frame(Context& context, const Scene& scene, const Prepared& prepared,
                                          const RenderOptions& options, int width, int height, int lanes,
                                          const surfaces::ViewFragments* fragments, FrameImage& frame, RenderStats& stats) {
    const PreparedScene& p = prepared.scene;
    const bool has_surfaces = !p.packed_surfaces.triangles.empty();
    if (options.shadow_cache == ShadowCacheMode::Off || !prepared.technique.has_shadow_term() ||
        (scene.volumes.empty() && !has_surfaces) || scene.lights.empty())
        return nullptr;
    host::Runtime& runtime = context.runtime();
    std::unique_ptr<ShadowCache>& cache = context.kept_scenes().shadow_cache;
    if (!cache) cache = std::make_unique<ShadowCache>();
    cache->history_pending.reset();
    const std::size_t lights = scene.lights.size();
    VolumePlan volumes = scene.volumes.empty() ? VolumePlan() : plan_volume_entries(runtime, scene, prepared, options, *cache, stats);
    SurfacePlan surfaces = has_surfaces ? plan_surface_entries(scene, prepared, options, fragments ? fragments->fragments.stats.fragments : 0, cache->surfaces, stats)
                                        : SurfacePlan();
    // auto: the choice remembered for this frame, else this one's (the plans' counts and, when the
    // volume lattices need filling, a measurement), remembered
    const bool automatic = options.shadow_cache == ShadowCacheMode::Auto;
    std::unique_lock<std::mutex> choosing;
    std::string choice_key;
    bool measure = false;
    bool history_marks = true;  // a choice from the history: whether the fill marks, as the timed runs did
    if (automatic) {
        RememberedChoices& remembered = remembered_choices();
        choosing = std::unique_lock<std::mutex>(remembered.mutex);
        choice_key = the_choice_key(runtime, scene, p, options, width, height, lanes);
        if (auto found = remembered.choices.find(choice_key); found != remembered.choices.end()) {
            volumes.use = found->second.volumes, surfaces.use = found->second.surfaces;
            stats.shadow_cache_auto_remembered = true;
            report_auto_costs(found->second.costs, stats);
            choosing.unlock();
        } else {
            measure = !scene.volumes.empty() && !volumes.use;
            // a fill of every entry (a fresh Context's frame) is what other processes timed: their
            // history may choose without a probe (shadow_cache_history.h)
            if (measure && std::all_of(volumes.stale.begin(), volumes.stale.end(), [](bool stale) { return stale; })) {
                std::optional<AutoHistory> history = load_auto_history(choice_key);
                const HistoryChoice chosen = choose_from_history(history);
                if (chosen != HistoryChoice::Probe) {
                    measure = false, volumes.use = chosen == HistoryChoice::On, history_marks = history->mark_fill;
                    stats.shadow_cache_auto_history = true;
                    stats.shadow_cache_history_on_ms = history->on_ms, stats.shadow_cache_history_off_ms = history->off_ms;
                }
                cache->history_pending = ShadowCache::PendingHistory{choice_key, history.value_or(AutoHistory()), std::chrono::steady_clock::now()};
            }
        }
    }
    auto remember = [&](const VolumeCosts& costs) {
        if (!choosing.owns_lock()) return;
        RememberedChoices& remembered = remembered_choices();
        if (remembered.order.size() >= kRememberedChoices) {
            remembered.choices.erase(remembered.order.front());
            remembered.order.pop_front();
        }
        remembered.choices[choice_key] = AutoChoice{volumes.use, surfaces.use, costs};
        remembered.order.push_back(choice_key);
        choosing.unlock();
    };
    cache->volumes_used = volumes.use, cache->surfaces_used = surfaces.use;
    if (!volumes.use && !surfaces.use && !measure) {
        remember(VolumeCosts());
        return nullptr;
    }

    // the program of the frame's camera pass (it reads the volume lattices or not per launch; the
    // fills read no cache: any variant fills alike)
    const FillLaunch launch = fill_launch(runtime, scene, prepared, options, lanes, surfaces.use, width, height, fragments);
    const bool may_mark = options.shadow_cache_fill == ShadowCacheFill::Visible;
    bool mark_for_fill = may_mark && history_marks;  // the frame's fill, when the cache is read and not yet marked
    const SurfaceShadowCache* surface_reads = surfaces.use ? &cache->surfaces : nullptr;
    VolumeFill fill;
    double ms = 0;
    // the lattices, once made (auto's estimate_marked_share), are not made again
    bool layout_made = false;
    auto plan_now = [&] {
        VolumePlan plan = volumes;
        plan.same_layout = volumes.same_layout || layout_made;
        return plan;
    };
    if (surfaces.use) ms += fill_surface_entries(launch, cache->surfaces, surfaces, lights, stats);
    if (measure) {  // a probe's passes read the surface part as the frame will
        const auto probe_start = std::chrono::steady_clock::now();
        const bool all_stages = std::getenv("SOMBRA_AUTO_PROBE_ALL") != nullptr;
        // the visible fill's marking pass, where it may pay (visible_fill_worth_marking;
        // bench/README.md "With the visible fill"), in the probe or after it; the fill is then
        // estimated for the points it found, at the probe's cost per point, or measured
        // (measure_marked_fill)
        bool marked = false;
        double marking_ms = 0, measured_fill_ms = 0;
        const std::function<SampledMarks(double*)> estimate_share = [&](double* share_ms) {
            SampledMarks sampled = estimate_marked_share(launch, *cache, plan_now(), surface_reads, double(stats.shadow_cache_points_to_fill), share_ms);
            if (sampled.share >= 0) layout_made = true;  // (not estimated: nothing made)
            return sampled;
        };
        const std::function<double(double*)> mark_points = [&](double* image_samples) {
            const auto start = std::chrono::steady_clock::now();
            marked = true;
            fill = prepare_volume_fill(launch, *cache, plan_now(), true, surface_reads, stats);
            marking_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            if (image_samples) *image_samples = fill.image_samples;
            return std::min(1.0, double(fill.needed_points()) / std::max(1.0, double(stats.shadow_cache_points_to_fill)));
        };
        RenderedPackets rendered_packets(width, height, lanes);  // those the probe rendered per sample into the frame's image
        VolumeCosts costs = probe_volume_costs(launch, volumes, width, height, fragments, surface_reads,
                                               may_mark && !all_stages ? &mark_points : nullptr, may_mark && !all_stages ? &estimate_share : nullptr,
                                               all_stages ? &stats.shadow_cache_probe_stages : nullptr, frame, rendered_packets);
        const auto probe_end = std::chrono::steady_clock::now();
        const double marking_in_probe_ms = marking_ms;
        // tests/test_shadow_cache.cpp: mark, measure and read the cache whatever the probe found
        const bool test_measure = std::getenv("SOMBRA_TEST_MEASURE_FILL") != nullptr;
        if (marked) stats.shadow_cache_auto_marked = costs.marked_after_probe ? "after probe" : "in probe";
        if (may_mark && !marked && test_measure) {
            costs.fill_ms *= mark_points(nullptr);
            stats.shadow_cache_auto_marked = "after probe";
        }
        if (marked) {
            // a close call by the probe's estimate for the marked points: the visible fill measured
            // on a part of its points decides
            if (marked_fill_worth_measuring(costs.fill_ms, costs.cached_ms, costs.per_sample_ms) || test_measure) {
                const double measured = measure_marked_fill(launch, *cache, volumes, fill, &measured_fill_ms);
                if (measured >= 0) costs.fill_ms = measured;
                stats.stage_ms["shadow_cache_measure"] = measured_fill_ms;
            }
        }
        volumes.use = shadow_cache_pays(costs.fill_ms, costs.cached_ms, costs.per_sample_ms) || (test_measure && marked);
        // per sample: the frame keeps the pixels the probe rendered per sample, as the frame renders
        // them (the same program and image rows; tests/test_shadow_cache.cpp)
        if (!volumes.use) {
            frame.rendered_packets = host::make_buffer(runtime, CL_MEM_READ_ONLY, rendered_packets.bits.size() * sizeof(cl_uint),
                                                       rendered_packets.bits.data(), "packets the probe rendered");
            stats.shadow_cache_probe_pixels_kept = rendered_packets.pixels;
        }
        // where marking cannot pay, the frame fills every point (teapot_fog's DSM at 256²: a
        // marking pass of 50 ms before a fill of 6 ms, where a fill of all points takes 10–17 ms)
        mark_for_fill = may_mark && marking_may_pay(costs.fill_ms, costs.cached_ms);
        if (volumes.use) ms += measured_fill_ms;  // the frame's fill: its bands are filled
        else if (measured_fill_ms > 0) costs.probe_ms += measured_fill_ms;
        if (cache->history_pending) {
            // unmarked, a visible fill (where the frame marks) may need as little as a quarter of the points: the
            // history's estimate is that one, so that a later run measures the cache when it may
            // pay (the MRI's shadow rays at 256²: fill of all points 5.6 s, visible fill 0.9 s, per
            // sample 1.5 s). Not the marking condition's eighth (kVisibleFillBound): the history
            // tries the cache only where a fill of a quarter of the points could pay
            cache->history_pending->history.estimated_on_ms = (mark_for_fill && !marked ? costs.fill_ms / 4 : costs.fill_ms) + costs.cached_ms;
            cache->history_pending->history.estimated_off_ms = costs.per_sample_ms;
            cache->history_pending->history.mark_fill = marked || mark_for_fill;
            // not the mode's time: the probe, and its marking pass when the cache is then left off
            // (a marking pass in the probe is the cache's frame's)
            cache->history_pending->probe_ms =
                volumes.use ? std::chrono::duration<double, std::milli>(probe_end - probe_start).count() - marking_in_probe_ms
                            : std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - probe_start).count();
        }
        stats.shadow_cache_probe_ms = costs.probe_ms;
        report_auto_costs(costs, stats);
        stats.stage_ms["shadow_cache_probe"] = costs.probe_ms;
        cache->volumes_used = volumes.use;
        remember(costs);
        if (!volumes.use && !surfaces.use) return nullptr;
    } else {
        remember(VolumeCosts());
    }
    if (volumes.use) {
        if (!fill.prepared) fill = prepare_volume_fill(launch, *cache, plan_now(), mark_for_fill, surface_reads, stats);
        ms += fill_volume_entries(launch, *cache, volumes, fill, stats);
    }
    if (ms > 0 || stats.shadow_cache_entries_built + stats.shadow_cache_surface_entries_built > 0) stats.stage_ms["shadow_cache"] = ms;
    stats.shadow_cache_used = true;
    stats.shadow_cache_surfaces_used = surfaces.use;
    stats.shadow_cache_bytes = (volumes.use ? cache->bytes : 0) + (surfaces.use ? cache->surfaces.bytes : 0);
    return cache.get();
}

std::vector<float> probe_fill_values(Context& context, const Scene& scene, const RenderOptions& options, int block, int stride,
                                     bool one_launch) {
    RenderStats stats;
    const Prepared prepared = prepare(context, scene, options, stats);
    host::Runtime& runtime = context.runtime();
    const int width = options.width > 0 ? options.width : scene.width, height = options.height > 0 ? options.height : scene.height;
    const int lanes = host::packet_lanes(runtime, options.lanes);
    const VolumePlan plan = plan_volume_entries(runtime, scene, prepared, options, ShadowCache(), stats);
    const FillLaunch launch = fill_launch(runtime, scene, prepared, options, lanes, false, width, height, nullptr);
    const std::vector<ShadowCacheGpu> small = probe_lattices(plan.layout, block, stride, lanes);
    std::vector<float> values(small.back().offset + lattice_points(small.back()), -1.f);
    cl::Buffer value_buffer = host::make_buffer(runtime, CL_MEM_READ_WRITE, values.size() * sizeof(float), values.data(), "probe values");
    cl::Buffer table = host::make_buffer(runtime, CL_MEM_READ_ONLY, small.size() * sizeof(ShadowCacheGpu), small.data(), "probe table");
    FillKernels kernels{launch.program, {}, {}};
    if (one_launch) {
        fill_small_lattices(launch, kernels, small, table, value_buffer);
    } else {
        for (std::size_t e = 0; e < small.size(); ++e) fill_lattice(launch, kernels, e, small[e], table, value_buffer);
    }
    runtime.queue().enqueueReadBuffer(value_buffer, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    return values;
}

void record_auto_history(Context& context, const RenderStats& stats) {
    std::unique_ptr<ShadowCache>& cache = context.kept_scenes().shadow_cache;
    if (!cache || !cache->history_pending) return;
    const ShadowCache::PendingHistory pending = std::move(*cache->history_pending);
    cache->history_pending.reset();
    // what the modes differ by, in wall time (the cache's buffers, marking, fills and the camera
    // pass; host work too, which kernel times leave out and small frames feel): from the choice
    // to the end of the camera pass, less the probe
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - pending.started).count() - pending.probe_ms;
    // a run that took far longer than its kernels compiled code on the way: not recorded, the
    // next run measures its mode again (history_run_compiled)
    double kernel_ms = 0;
    for (const char* stage : {"shadow_cache", "shadow_cache_mark", "camera_pass"})
        if (auto found = stats.stage_ms.find(stage); found != stats.stage_ms.end()) kernel_ms += found->second;
    if (history_run_compiled(ms, kernel_ms)) return;
    store_auto_history(pending.key, with_measurement(pending.history, cache->volumes_used, ms));
}

}  // namespace sombra::pipeline

namespace sombra {

void forget_shadow_cache_choices() {
    pipeline::RememberedChoices& remembered = pipeline::remembered_choices();
    std::lock_guard<std::mutex> lock(remembered.mutex);
    remembered.choices.clear();
    remembered.order.clear();
}

}  // namespace sombra
