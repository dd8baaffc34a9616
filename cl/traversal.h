/* sombra — ray traversal as homogeneous segments (Knecht §3.1.2, DESIGN.md "Data flow").
 *
 * The boundaries of every volume's box along a ray cut it into segments; inside one segment the
 * set of active volumes does not change, and it is marched at the smallest step of those volumes.
 * Within a segment, bricks whose value range maps to zero opacity are skipped (Hadwiger §3,
 * brick min/max). This file is written once and serves every pass: the including kernel defines
 * `typedef … VisitState;` before including it and then implements visit_sample(), declared
 * below, which returns false to stop the ray (early ray termination). */
#ifndef SOMBRA_TRAVERSAL_H
#define SOMBRA_TRAVERSAL_H
#include "volume_sample.h"

/* A ray expressed in the world and in each volume's voxel space (affine maps keep t). */
typedef struct {
    float3 origin, dir; /* world */
    float3 vox_origin[SOMBRA_MAX_VOLUMES];
    float3 vox_dir[SOMBRA_MAX_VOLUMES];
    float t_enter[SOMBRA_MAX_VOLUMES], t_exit[SOMBRA_MAX_VOLUMES]; /* empty interval: enter ≥ exit */
} VolumeRay;

/* Called for every sample that is not skipped; `active` has bit i set for each volume i whose
 * box contains the sample. */
bool visit_sample(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray, float t, float step, uint active);

/* Slab test against the box [lo, hi] in voxel space; axis-parallel rays outside a slab miss. */
inline float2 intersect_box(float3 o, float3 d, float3 lo, float3 hi) {
    float t0 = -INFINITY, t1 = INFINITY;
    for (int axis = 0; axis < 3; ++axis) {
        float oa = axis == 0 ? o.x : (axis == 1 ? o.y : o.z);
        float da = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
        float la = axis == 0 ? lo.x : (axis == 1 ? lo.y : lo.z);
        float ha = axis == 0 ? hi.x : (axis == 1 ? hi.y : hi.z);
        if (fabs(da) < 1e-30f) {
            if (oa < la || oa > ha) return (float2)(INFINITY, -INFINITY);
        } else {
            float ta = (la - oa) / da, tb = (ha - oa) / da;
            t0 = fmax(t0, fmin(ta, tb));
            t1 = fmin(t1, fmax(ta, tb));
        }
    }
    return (float2)(t0, t1);
}

/* Fills ray for t in [t_min, t_max]; a volume's box is [-0.5, dims - 0.5] in voxel space. */
inline void make_volume_ray(VolumeRay* ray, __global const VolumeGpu* volumes, uint volume_count,
                            float3 origin, float3 dir, float t_min, float t_max) {
    ray->origin = origin;
    ray->dir = dir;
    for (uint i = 0; i < volume_count; ++i) {
        __global const VolumeGpu* v = &volumes[i];
        float3 o = to_voxel_point(v, origin), d = to_voxel_direction(v, dir);
        float2 span = intersect_box(o, d, (float3)(-0.5f), convert_float3(v->dims.xyz) - 0.5f);
        ray->vox_origin[i] = o;
        ray->vox_dir[i] = d;
        ray->t_enter[i] = fmax(span.x, t_min);
        ray->t_exit[i] = fmin(span.y, t_max);
    }
}

#ifdef SOMBRA_SKIP_EMPTY
/* True when the sample at t lies in an empty brick of every active volume; then *t_resume is
 * where the first of those bricks ends along the ray (all samples before it are empty too). */
inline bool in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* volumes,
                            const VolumeRay* ray, uint active, float t, float* t_resume) {
    float t_exit = INFINITY;
    for (uint i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        if (!(active & (1u << i))) continue;
        __global const VolumeGpu* v = &volumes[i];
        float3 p = clamp(ray->vox_origin[i] + t * ray->vox_dir[i], (float3)(0.0f), convert_float3(v->dims.xyz) - 1.0f);
        int3 b = min(convert_int3(p) / SOMBRA_BRICK_SIZE, v->brick_dims.xyz - 1);
        if (occupancy[v->brick_offset + b.x + v->brick_dims.x * (b.y + v->brick_dims.y * b.z)]) return false;
        float3 lo = convert_float3(b * SOMBRA_BRICK_SIZE);
        float2 span = intersect_box(ray->vox_origin[i], ray->vox_dir[i], lo, lo + (float)SOMBRA_BRICK_SIZE);
        t_exit = fmin(t_exit, span.y);
    }
    *t_resume = t_exit;
    return true;
}
#endif

/* Marches every homogeneous segment of ray front to back, calling visit_sample at
 * t_k = segment start + (k + jitter) · step. */
inline void traverse_segments(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray, __global const VolumeGpu* volumes,
                              uint volume_count, __global const uchar* occupancy, float jitter) {
    /* segment boundaries: all enter/exit values, sorted (≤ 2·SOMBRA_MAX_VOLUMES, insertion sort) */
    float bounds[2 * SOMBRA_MAX_VOLUMES];
    uint n = 0;
    for (uint i = 0; i < volume_count; ++i) {
        if (!(ray->t_enter[i] < ray->t_exit[i])) continue;
        bounds[n++] = ray->t_enter[i];
        bounds[n++] = ray->t_exit[i];
    }
    for (uint i = 1; i < n; ++i) {
        float b = bounds[i];
        uint j = i;
        for (; j > 0 && bounds[j - 1] > b; --j) bounds[j] = bounds[j - 1];
        bounds[j] = b;
    }
    for (uint s = 0; s + 1 < n; ++s) {
        float t_start = bounds[s], t_end = bounds[s + 1];
        if (!(t_end > t_start)) continue;
        float t_mid = 0.5f * (t_start + t_end);
        uint active = 0;
        float step = INFINITY;
        for (uint i = 0; i < volume_count; ++i) {
            if (ray->t_enter[i] <= t_mid && t_mid < ray->t_exit[i]) {
                active |= 1u << i;
                step = fmin(step, volumes[i].step);
            }
        }
        if (active == 0) continue;
        for (float k = 0.0f;; k += 1.0f) {
            float t = t_start + (k + jitter) * step;
            if (t >= t_end) break;
#ifdef SOMBRA_SKIP_EMPTY
            float t_resume;
            if (in_empty_bricks(occupancy, volumes, ray, active, t, &t_resume)) {
                /* next k whose sample lies at or beyond the brick exit */
                k = fmax(k, ceil((t_resume - t_start) / step - jitter) - 1.0f);
                continue;
            }
#endif
            if (!visit_sample(volume_data, state, ray, t, step, active)) return;
        }
    }
}

#endif
