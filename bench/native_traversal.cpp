// sombra bench — ray traversal, line by line after cl/traversal.h and render_camera() in cl/render.cl.
#include "native_traversal.h"

#include <algorithm>
#include <cmath>

namespace sombra::bench {
namespace {

V3 normalize(V3 v) { return (1.0f / std::sqrt(dot(v, v))) * v; }

V3 to_voxel_point(const VolumeGpu& v, V3 p) {
    const cl_float4* m = v.world_to_voxel;
    return {dot(xyz(m[0]), p) + m[0].s[3], dot(xyz(m[1]), p) + m[1].s[3], dot(xyz(m[2]), p) + m[2].s[3]};
}

V3 to_voxel_direction(const VolumeGpu& v, V3 d) {
    const cl_float4* m = v.world_to_voxel;
    return {dot(xyz(m[0]), d), dot(xyz(m[1]), d), dot(xyz(m[2]), d)};
}

V3 dims_minus(const VolumeGpu& v, float d) {
    return {float(v.dims.s[0]) - d, float(v.dims.s[1]) - d, float(v.dims.s[2]) - d};
}

struct Span {
    float t0, t1;  // empty: t0 ≥ t1
};

// Slab test against the box [lo, hi] in voxel space; axis-parallel rays outside a slab miss.
Span intersect_box(V3 o, V3 d, V3 lo, V3 hi) {
    const float oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z};
    const float la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
    Span s{-INFINITY, INFINITY};
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(da[a]) < 1e-30f) {
            if (oa[a] < la[a] || oa[a] > ha[a]) return {INFINITY, -INFINITY};
        } else {
            float ta = (la[a] - oa[a]) / da[a], tb = (ha[a] - oa[a]) / da[a];
            s.t0 = std::fmax(s.t0, std::fmin(ta, tb));
            s.t1 = std::fmin(s.t1, std::fmax(ta, tb));
        }
    }
    return s;
}

}  // namespace

V3 camera_ray_dir(const CameraGpu& camera, unsigned x, unsigned y) {
    float sx = ((float(x) + 0.5f) / float(camera.width)) * 2.0f - 1.0f;
    float sy = 1.0f - ((float(y) + 0.5f) / float(camera.height)) * 2.0f;
    return normalize(xyz(camera.forward) + sx * xyz(camera.right) + sy * xyz(camera.up));
}

// make_volume_ray() with t in [0, ∞), then the sorted segment boundaries of traverse_segments().
void RayTraversal::begin(const TraversalScene& scene, V3 o, V3 d, float jitter) {
    origin = o, dir = d, jitter_ = jitter;
    bound_count_ = 0;
    for (unsigned i = 0; i < scene.volume_count; ++i) {
        const VolumeGpu& v = scene.volumes[i];
        vox_origin[i] = to_voxel_point(v, o);
        vox_dir[i] = to_voxel_direction(v, d);
        Span span = intersect_box(vox_origin[i], vox_dir[i], V3{-0.5f, -0.5f, -0.5f}, dims_minus(v, 0.5f));
        t_enter_[i] = std::fmax(span.t0, 0.0f);
        t_exit_[i] = std::fmin(span.t1, INFINITY);
        if (!(t_enter_[i] < t_exit_[i])) continue;
        bounds_[bound_count_++] = t_enter_[i];
        bounds_[bound_count_++] = t_exit_[i];
    }
    std::sort(bounds_, bounds_ + bound_count_);  // the kernel's insertion sort gives the same order
    next_bound_ = 0;
    in_segment_ = enter_next_segment(scene);
}

// Next non-empty segment [t_start, t_end): its active volumes and step (smallest of theirs).
bool RayTraversal::enter_next_segment(const TraversalScene& scene) {
    while (next_bound_ + 1 < bound_count_) {
        unsigned s = next_bound_++;
        t_start_ = bounds_[s], t_end_ = bounds_[s + 1];
        if (!(t_end_ > t_start_)) continue;
        float t_mid = 0.5f * (t_start_ + t_end_);
        active = 0;
        step = INFINITY;
        for (unsigned i = 0; i < scene.volume_count; ++i) {
            if (t_enter_[i] <= t_mid && t_mid < t_exit_[i]) {
                active |= 1u << i;
                step = std::fmin(step, scene.volumes[i].step);
            }
        }
        if (active == 0) continue;
        k_ = 0.0f;
        return true;
    }
    return false;
}

// True when the sample at t lies in an empty brick of every active volume; then t_resume is
// where the first of those bricks ends along the ray.
bool RayTraversal::in_empty_bricks(const TraversalScene& scene, float t, float& t_resume) const {
    float t_exit = INFINITY;
    for (unsigned i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        if (!(active & (1u << i))) continue;
        const VolumeGpu& v = scene.volumes[i];
        V3 p = vox_origin[i] + t * vox_dir[i];
        V3 hi = dims_minus(v, 1.0f);
        p = {std::clamp(p.x, 0.0f, hi.x), std::clamp(p.y, 0.0f, hi.y), std::clamp(p.z, 0.0f, hi.z)};
        int bx = std::min(int(p.x) / SOMBRA_BRICK_SIZE, v.brick_dims.s[0] - 1);
        int by = std::min(int(p.y) / SOMBRA_BRICK_SIZE, v.brick_dims.s[1] - 1);
        int bz = std::min(int(p.z) / SOMBRA_BRICK_SIZE, v.brick_dims.s[2] - 1);
        if (scene.occupancy[v.brick_offset + bx + v.brick_dims.s[0] * (by + v.brick_dims.s[1] * bz)]) return false;
        V3 lo{float(bx * SOMBRA_BRICK_SIZE), float(by * SOMBRA_BRICK_SIZE), float(bz * SOMBRA_BRICK_SIZE)};
        float size = float(SOMBRA_BRICK_SIZE);
        t_exit = std::fmin(t_exit, intersect_box(vox_origin[i], vox_dir[i], lo, lo + V3{size, size, size}).t1);
    }
    t_resume = t_exit;
    return true;
}

// The body of traverse_segments()' sample loop: t_k = t_start + (k + jitter)·step, skipping
// samples in empty bricks (next k whose sample lies at or beyond the brick exit).
bool RayTraversal::next_sample(const TraversalScene& scene, float& t) {
    while (in_segment_) {
        float tk = t_start_ + (k_ + jitter_) * step;
        if (tk >= t_end_) {
            in_segment_ = enter_next_segment(scene);
            continue;
        }
        float t_resume;
        if (scene.skip_empty && in_empty_bricks(scene, tk, t_resume)) {
            k_ = std::fmax(k_, std::ceil((t_resume - t_start_) / step - jitter_) - 1.0f) + 1.0f;
            continue;
        }
        k_ += 1.0f;
        t = tk;
        return true;
    }
    return false;
}

}  // namespace sombra::bench
