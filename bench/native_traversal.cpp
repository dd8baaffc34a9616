// sombra bench — ray traversal, line by line after cl/traversal.h (make_volume_ray,
// segment_cursor_next, in_empty_bricks) and render_camera() in cl/render.cl, for one ray.
#include "native_traversal.h"

#include <algorithm>
#include <cmath>

namespace sombra::bench {
namespace {

V3 normalize(V3 v) { return (1.0f / std::sqrt(dot(v, v))) * v; }

V3 to_voxel_point(const VolumeGpu& v, V3 p) {
    const cl_float4* m = v.world_to_voxel;
    return {dot(p, xyz(m[0])) + m[0].s[3], dot(p, xyz(m[1])) + m[1].s[3], dot(p, xyz(m[2])) + m[2].s[3]};
}

V3 to_voxel_direction(const VolumeGpu& v, V3 d) {
    const cl_float4* m = v.world_to_voxel;
    return {dot(d, xyz(m[0])), dot(d, xyz(m[1])), dot(d, xyz(m[2]))};
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
            float inv = 1.0f / da[a];  // as the kernel: a reciprocal, then products
            float ta = (la[a] - oa[a]) * inv, tb = (ha[a] - oa[a]) * inv;
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
    V3 f = xyz(camera.forward) + sy * xyz(camera.up);  // the kernel's order of the sums
    return normalize(f + sx * xyz(camera.right));
}

// make_volume_ray() with t in [0, ∞), then the sorted box bounds of segment_cursor_init().
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
        if (!(t_enter_[i] < t_exit_[i])) {  // missed: never active, no bound
            t_enter_[i] = t_exit_[i] = INFINITY;
            continue;
        }
        bounds_[bound_count_++] = t_enter_[i];
        bounds_[bound_count_++] = t_exit_[i];
    }
    std::sort(bounds_, bounds_ + bound_count_);  // the kernel's sorting network gives the same order
    next_bound_ = 0;
    phase_ = Phase::Ended;  // the first next_point() enters the first segment
    resuming_ = last_was_sample_ = empty_interval = false;
    t = delta = 0.0f;
}

// Next non-empty segment [t_start, t_end]: its active volumes and step (smallest of theirs).
// Before the first bound no volume is active, so starting at the first bound skips nothing.
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
        k_ = jitter_ <= 0.0f ? 0 : -1;  // the first sample lies strictly after the start point
        phase_ = Phase::Start;
        resuming_ = false;
        return true;
    }
    return false;
}

// True when the sample at t lies in an empty brick of every active volume; then t_resume is
// where the ray leaves the first of the cubes of empty bricks around them (the distance bytes
// after a volume's flags, packing::brick_distances: r, the (2r − 1)³ bricks around of its kind).
bool RayTraversal::in_empty_bricks(const TraversalScene& scene, float t_sample, float& t_resume) const {
    float t_exit = INFINITY;
    for (unsigned i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        if (!(active & (1u << i))) continue;
        const VolumeGpu& v = scene.volumes[i];
        V3 p = vox_origin[i] + t_sample * vox_dir[i];
        V3 hi = dims_minus(v, 1.0f);
        p = {std::clamp(p.x, 0.0f, hi.x), std::clamp(p.y, 0.0f, hi.y), std::clamp(p.z, 0.0f, hi.z)};
        int bx = std::min(int(p.x) / SOMBRA_BRICK_SIZE, v.brick_dims.s[0] - 1);
        int by = std::min(int(p.y) / SOMBRA_BRICK_SIZE, v.brick_dims.s[1] - 1);
        int bz = std::min(int(p.z) / SOMBRA_BRICK_SIZE, v.brick_dims.s[2] - 1);
        const std::size_t distances = v.brick_offset + std::size_t(v.brick_dims.s[0]) * v.brick_dims.s[1] * v.brick_dims.s[2];
        const int distance = scene.occupancy[distances + bx + v.brick_dims.s[0] * (by + v.brick_dims.s[1] * bz)];
        if (distance >= 128) return false;
        const int reach = distance - 1;
        V3 lo{float((bx - reach) * SOMBRA_BRICK_SIZE), float((by - reach) * SOMBRA_BRICK_SIZE), float((bz - reach) * SOMBRA_BRICK_SIZE)};
        float size = float((2 * reach + 1) * SOMBRA_BRICK_SIZE);
        t_exit = std::fmin(t_exit, intersect_box(vox_origin[i], vox_dir[i], lo, lo + V3{size, size, size}).t1);
    }
    t_resume = t_exit;
    return true;
}

// After a sample in empty bricks of every active volume: the next point is where the run of empty
// bricks ends (each next brick tested just past the previous one's exit face, at most 64 hops,
// not beyond the segment), and the sample after it is the first one beyond that point.
void RayTraversal::skip_empty_bricks(const TraversalScene& scene) {
    float t_resume;
    if (!in_empty_bricks(scene, t, t_resume)) return;
    if (!(t_resume > t) || !(t_resume < INFINITY)) return;  // NaN and ±∞ skip nothing
    bool hopping = t_resume < t_end_;
    for (int hop = 0; hop < 64 && hopping; ++hop) {
        float t_exit;
        hopping = in_empty_bricks(scene, t_resume + 1e-3f * step, t_exit) && t_exit > t_resume && t_exit < INFINITY;
        if (hopping) t_resume = t_exit;
        hopping = hopping && t_resume < t_end_;
    }
    resuming_ = true;
    resume_t_ = t_resume;
    float resume_index = std::fmin(std::floor((t_resume - t_start_) / step - jitter_) + 1.0f, 1.0e9f);
    k_ = std::max(k_, int(resume_index) - 1);
}

// segment_cursor_next() for one lane: start point (delta 0), samples (delta = step between two
// samples), the resume point after empty bricks, the end point (the part of a step inside the
// segment), then the next segment.
bool RayTraversal::next_point(const TraversalScene& scene) {
    if (phase_ == Phase::Ended && !enter_next_segment(scene)) return false;
    bool starting = phase_ == Phase::Start;
    bool resuming = resuming_ && !starting;
    bool stepping = !starting && !resuming;
    if (stepping) ++k_;
    float t_next = starting ? t_start_ : resuming ? resume_t_ : t_start_ + (float(k_) + jitter_) * step;
    bool ending = !starting && t_next >= t_end_;
    if (ending) t_next = t_end_;
    bool sample = stepping && !ending;
    bool full_step = sample && last_was_sample_;
    empty_interval = resuming;
    delta = starting ? 0.0f : full_step ? step : t_next - t;
    last_was_sample_ = sample;
    t = t_next;
    if (starting) phase_ = Phase::Samples;
    if (ending) phase_ = Phase::Ended;
    resuming_ = false;
    if (scene.skip_empty && sample) skip_empty_bricks(scene);
    return true;
}

}  // namespace sombra::bench
