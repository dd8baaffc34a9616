// sombra bench — the camera pass's ray traversal (cl/traversal.h) in C++: camera rays, slab tests,
// homogeneous segments, exact intervals, chained brick skipping. Compiled without -ffast-math: like
// the kernel it relies on ±INFINITY (empty intervals, "no exit yet"), which -ffinite-math-only
// would make undefined.
#pragma once
#include "shared/types.h"

namespace sombra::bench {

struct V3 {
    float x, y, z;
};
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator-(V3 a) { return {-a.x, -a.y, -a.z}; }
inline V3 operator*(float s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline V3 operator*(V3 a, V3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 xyz(const cl_float4& v) { return {v.s[0], v.s[1], v.s[2]}; }

// What the traversal reads of a packed scene (pack_scene()).
struct TraversalScene {
    const VolumeGpu* volumes = nullptr;
    unsigned volume_count = 0;
    const cl_uchar* occupancy = nullptr;  // brick flags, then distance bytes (PackedScene::occupancy)
    bool skip_empty = true;               // SOMBRA_SKIP_EMPTY
};

// render_camera(): the pinhole ray through the centre of pixel (x, y), normalised.
V3 camera_ray_dir(const CameraGpu& camera, unsigned x, unsigned y);

// make_volume_ray() + SegmentCursor as a resumable state machine for one ray: next_point() moves
// to every point segment_cursor_next() yields, in the same order — each segment's start point,
// its samples t_start + (k + jitter)·step strictly inside it, its end point, and the end of a
// chain of empty bricks after a sample in the first of them. A caller can march one ray (scalar
// path) or keep many rays in flight and shade their points in batches (SIMD path); it stops early
// on ray termination simply by not asking again.
class RayTraversal {
public:
    void begin(const TraversalScene& scene, V3 origin, V3 dir, float jitter);
    bool next_point(const TraversalScene& scene);  // false: the ray has left every box

    // The interval [t − delta, t] the point closes holds medium: not a start point (delta 0) and
    // not the end of a run of empty bricks (σ = 0 there by the bricks' value range).
    bool closes_medium() const { return delta > 0.0f && !empty_interval; }

    V3 origin, dir;  // world
    V3 vox_origin[SOMBRA_MAX_VOLUMES], vox_dir[SOMBRA_MAX_VOLUMES];
    float step = 0;       // of the current segment (smallest step of its volumes)
    unsigned active = 0;  // bit i: volume i's box contains the current segment
    float t = 0;          // the current point
    float delta = 0;      // length of the interval it closes (cursor.delta)
    bool empty_interval = false;

private:
    bool enter_next_segment(const TraversalScene& scene);
    bool in_empty_bricks(const TraversalScene& scene, float t, float& t_resume) const;
    void skip_empty_bricks(const TraversalScene& scene);

    float t_enter_[SOMBRA_MAX_VOLUMES], t_exit_[SOMBRA_MAX_VOLUMES];
    float bounds_[2 * SOMBRA_MAX_VOLUMES];
    unsigned bound_count_ = 0, next_bound_ = 0;
    enum class Phase { Start, Samples, Ended } phase_ = Phase::Ended;
    int k_ = 0;                      // index of the last sample in the segment
    bool last_was_sample_ = false;   // the previous point was a sample reached by stepping
    bool resuming_ = false;          // the next point is resume_t_, where the empty bricks end
    float resume_t_ = 0;
    float t_start_ = 0, t_end_ = 0, jitter_ = 0;
};

}  // namespace sombra::bench
