// sombra — the shadow cache (render.h ShadowCacheMode): the EG 2009 course's "3D texture caching"
// and Ament et al. 2014 Alg. 1 for every technique. Per volume and light a lattice of the shadow
// term over the volume's voxels, filled by the technique itself (render.cl shadow_cache_fill) and
// kept on the Context; an entry is refilled only when its key changes. The camera pass reads it
// trilinearly (render.cl cached_shadow).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "host/kernel_args.h"
#include "host/tiled_launch.h"
#include "render/preparation.h"
#include "shadows/light_reach.h"
#include "sombra/error.h"

namespace sombra::pipeline {
namespace {

constexpr std::size_t kShadowCachePoints = std::size_t(1) << 23;  // per volume and light (32 MiB)

// The lattice of a volume: its voxels, the longest axis halved until at most kShadowCachePoints.
std::array<int, 3> cache_lattice(const std::array<int, 3>& dims) {
    std::array<int, 3> n = dims;
    while (std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]) > kShadowCachePoints) {
        int& longest = *std::max_element(n.begin(), n.end());
        longest = (longest + 1) / 2;
    }
    return n;
}

std::size_t lattice_points(const ShadowCacheGpu& c) { return std::size_t(c.dims.s[0]) * std::size_t(c.dims.s[1]) * std::size_t(c.dims.s[2]); }

// Entry (volume i, light m) of the cache: its lattice, its place in the values, the volume's
// voxel → world rows.
std::vector<ShadowCacheGpu> cache_layout(const Scene& scene, const packing::PackedScene& packed) {
    std::vector<ShadowCacheGpu> table;
    std::size_t total = 0;
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
            c.offset = cl_uint(total);
            total += lattice_points(c);
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
std::vector<std::string> generic_keys(const Scene& scene, const PreparedScene& p, const techniques::ShadowModule& technique,
                                      const RenderOptions& options) {
    const SceneKeys& k = p.keys;
    std::string common = std::string(shadow_technique_name(options.shadows)) + " seed " + std::to_string(options.jitter_seed) +
                         " | options " + k.options + " | meshes " + k.meshes + " | placement";
    for (const std::string& placement : k.volume_placement) common += " " + placement;
    std::vector<shadows::WorldBox> boxes = shadows::volume_boxes(p.packed);
    shadows::WorldBox all;
    double step = 0;
    for (std::size_t j = 0; j < boxes.size(); ++j) all.add(boxes[j].lo), all.add(boxes[j].hi), step = std::max(step, double(p.packed.volumes[j].step));
    std::vector<std::string> keys;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i)
        for (std::size_t m = 0; m < scene.lights.size(); ++m) {
            const LightGpu& light = p.packed.lights[m];
            double reach = all.diagonal();  // a positional light's map spans its distance to the farthest corner
            if (light.type != SOMBRA_LIGHT_DIRECTIONAL)
                for (int c = 0; c < 8; ++c) {
                    const shadows::D3 corner{(c & 1 ? all.hi : all.lo)[0], (c & 2 ? all.hi : all.lo)[1], (c & 4 ? all.hi : all.lo)[2]};
                    reach = std::max(reach, std::hypot(corner[0] - light.position.s[0], corner[1] - light.position.s[1],
                                                       corner[2] - light.position.s[2]));
                }
            // a texel of a view of ≤ 90° fitted to the scene spans ≤ (π/2)·reach / resolution
            double margin = 4 * 1.6 * reach / std::max(options.dsm_resolution, 1) + 2 * step;
            std::string key = common + " | light " + p.light_keys[m] + " " + technique.light_data_key(m) + " | volume " + std::to_string(i) + " " + k.volume_content[i];
            for (std::size_t j = 0; j < scene.volumes.size(); ++j)
                if (j != i && shadows::between_light_and(boxes[i], boxes[j].grown(margin), light))
                    key += " | " + std::to_string(j) + " " + k.volume_content[j];
            keys.push_back(key);
        }
    return keys;
}

// The volume samples the camera pass takes in volume i, roughly: over the pixels its box covers,
// the box's volume over the pixel footprint at its centre times the step (the chords of a convex
// body integrate to its volume), at most every covered pixel marching the box's diagonal. Empty
// space skipping and early termination only lower it (the estimate leans towards the cache).
// corners: the volume's 8 world corners (shadows::scene_corners).
double estimated_samples(const CameraGpu& camera, const shadows::D3* corners, float step) {
    using shadows::D3;
    auto dot3 = [](const cl_float4& a, const D3& b) { return a.s[0] * b[0] + a.s[1] * b[1] + a.s[2] * b[2]; };
    auto norm2 = [](const cl_float4& a) { return double(a.s[0]) * a.s[0] + double(a.s[1]) * a.s[1] + double(a.s[2]) * a.s[2]; };
    double x_min = 1e30, x_max = -1e30, y_min = 1e30, y_max = -1e30;
    bool behind = false;
    D3 centre{0, 0, 0};
    for (int corner = 0; corner < 8; ++corner) {
        D3 rel;
        for (std::size_t r = 0; r < 3; ++r) centre[r] += corners[corner][r] / 8, rel[r] = corners[corner][r] - camera.position.s[r];
        double z = dot3(camera.forward, rel);
        if (z <= 1e-6) {
            behind = true;
            continue;
        }
        // NDC: the camera's right and up vectors are scaled by tan(fov/2) (·aspect)
        double x = dot3(camera.right, rel) / (z * norm2(camera.right)), y = dot3(camera.up, rel) / (z * norm2(camera.up));
        x_min = std::min(x_min, x), x_max = std::max(x_max, x), y_min = std::min(y_min, y), y_max = std::max(y_max, y);
    }
    double pixels = double(camera.width) * camera.height;
    if (!behind) {
        double covered_x = std::max(0.0, std::min(x_max, 1.0) - std::max(x_min, -1.0)) / 2;
        double covered_y = std::max(0.0, std::min(y_max, 1.0) - std::max(y_min, -1.0)) / 2;
        pixels *= covered_x * covered_y;
    }
    // the box's edges: corner 0 to corners 1, 2, 4 (scene_corners: x, y, z bits)
    D3 edge_length;
    for (std::size_t a = 0; a < 3; ++a) {
        const D3& end = corners[1 << a];
        edge_length[a] = std::hypot(end[0] - corners[0][0], end[1] - corners[0][1], end[2] - corners[0][2]);
    }
    double box_volume = edge_length[0] * edge_length[1] * edge_length[2];
    double diagonal = std::hypot(edge_length[0], edge_length[1], edge_length[2]);
    double world_step = std::max(1e-9, double(step));
    double distance = std::max(std::hypot(centre[0] - camera.position.s[0], centre[1] - camera.position.s[1], centre[2] - camera.position.s[2]),
                               0.5 * diagonal);
    double pixel_side = 2 * distance * std::sqrt(norm2(camera.up)) / camera.height;
    return std::min(box_volume / (pixel_side * pixel_side * world_step), pixels * diagonal / world_step);
}

// The share of volume i's bricks that may be visible under its transfer function.
double visible_brick_fraction(const packing::PackedScene& packed, std::size_t i) {
    const VolumeGpu& v = packed.volumes[i];
    std::size_t bricks = std::size_t(v.brick_dims.s[0]) * v.brick_dims.s[1] * v.brick_dims.s[2];
    auto first = packed.occupancy.begin() + std::ptrdiff_t(v.brick_offset);
    return bricks ? double(std::count(first, first + std::ptrdiff_t(bricks), cl_uchar(1))) / double(bricks) : 0.0;
}

}  // namespace

const ShadowCache* shadow_cache_for_frame(Context& context, const Scene& scene, const Prepared& prepared,
                                          const RenderOptions& options, int width, int height, int lanes, RenderStats& stats) {
    if (options.shadow_cache == ShadowCacheMode::Off || !prepared.technique.has_shadow_term() || scene.volumes.empty() ||
        scene.lights.empty())
        return nullptr;
    host::Runtime& runtime = context.runtime();
    const PreparedScene& p = prepared.scene;
    std::vector<ShadowCacheGpu> layout = cache_layout(scene, p.packed);
    std::vector<std::string> keys =
        prepared.technique.shadow_cache_keys({runtime, scene, p.packed, p.packed_surfaces, p.device, options, p.use_images});
    if (keys.empty()) keys = generic_keys(scene, p, prepared.technique, options);
    std::unique_ptr<ShadowCache>& cache = context.kept_scenes().shadow_cache;
    bool same_layout = cache && cache->layout.size() == layout.size() &&
                       std::equal(layout.begin(), layout.end(), cache->layout.begin(), [](const ShadowCacheGpu& a, const ShadowCacheGpu& b) {
                           return std::memcmp(&a, &b, sizeof(ShadowCacheGpu)) == 0;
                       });
    std::size_t lights = scene.lights.size();
    std::vector<bool> stale(layout.size(), true);
    for (std::size_t e = 0; e < layout.size(); ++e) stale[e] = !same_layout || cache->keys[e] != keys[e];

    // Auto: a lattice point costs one evaluation of the technique, as a shaded sample does per
    // light; both happen only near possibly visible bricks (the fill skips the other points)
    double to_fill = 0, samples = 0;
    CameraGpu camera = packing::pack_camera(scene, width, height);
    double voxel_size = 0;
    std::vector<shadows::D3> corners = shadows::scene_corners(p.packed, voxel_size);
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        double visible = visible_brick_fraction(p.packed, i);
        for (std::size_t m = 0; m < lights; ++m)
            if (stale[i * lights + m]) to_fill += visible * double(lattice_points(layout[i * lights + m]));
        samples += visible * double(lights) * estimated_samples(camera, &corners[8 * i], p.packed.volumes[i].step);
    }
    stats.shadow_cache_points_to_fill = static_cast<unsigned long long>(to_fill);
    stats.shadow_cache_estimated_samples = static_cast<unsigned long long>(std::min(samples, 1.8e19));
    if (options.shadow_cache == ShadowCacheMode::Auto && to_fill >= samples) return nullptr;

    if (!same_layout) {  // other volumes or lights: a new cache
        cache.reset();
        auto fresh = std::make_unique<ShadowCache>();
        fresh->layout = layout;
        fresh->keys.assign(layout.size(), std::string());
        std::size_t total = layout.back().offset + lattice_points(layout.back());
        fresh->values = host::make_buffer(runtime, CL_MEM_READ_WRITE, total * sizeof(float), nullptr, "shadow cache");
        fresh->table = host::make_buffer(runtime, CL_MEM_READ_ONLY, layout.size() * sizeof(ShadowCacheGpu), layout.data(), "shadow cache table");
        fresh->bytes = total * sizeof(float);
        cache = std::move(fresh);
    }
    std::size_t stale_entries = std::size_t(std::count(stale.begin(), stale.end(), true));
    stats.shadow_cache_entries_reused += int(layout.size() - stale_entries);
    if (stale_entries > 0) {
        camera.jitter_seed = options.jitter_seed;  // the fill's shadow rays start where the camera pass's would
        cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
        // the camera pass's own program (one build): the fill reads no cache
        cl::Kernel kernel(runtime.program("render.cl", camera_pass_defines(scene, options, prepared, lanes, true)), "shadow_cache_fill");
        host::ProgressStage stage(runtime.progress(), "shadow cache", double(stale_entries));
        double ms = 0;
        for (std::size_t e = 0; e < layout.size(); ++e) {
            if (!stale[e]) continue;
            cache->keys[e].clear();  // an entry half filled when a launch throws is not kept
            host::KernelArgs args{kernel};
            bind_scene(args, p, camera_buffer);
            args("light_index", cl_uint(e % lights))("entry", cl_uint(e))("shadow_cache_table", cache->table)("shadow_cache", cache->values);
            prepared.technique.bind(args, runtime, options);
            args.done();
            const ShadowCacheGpu& c = layout[e];
            ms += host::run_packets(runtime, kernel, c.dims.s[0], c.dims.s[1] * c.dims.s[2], lanes);
            cache->keys[e] = keys[e];
            ++stats.shadow_cache_entries_built;
        }
        stats.stage_ms["shadow_cache"] = ms;
    }
    stats.shadow_cache_used = true;
    stats.shadow_cache_bytes = cache->bytes;
    return cache.get();
}

}  // namespace sombra::pipeline
