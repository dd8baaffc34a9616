/* sombra — ray traversal as homogeneous segments (Knecht §3.1.2, DESIGN.md "Data flow"), for a
 * packet of SOMBRA_LANES rays marched in lockstep (lanes.h).
 *
 * The boundaries of every volume's box along a ray cut it into segments; inside one segment the
 * set of active volumes does not change, and it is marched at the smallest step of those volumes.
 * Within a segment, bricks whose value range maps to zero opacity are skipped (Hadwiger §3,
 * brick min/max). Each lane follows its own segments; lanes only share the loop. This file is
 * written once and serves every pass: the including kernel defines `typedef … VisitState;`
 * before including it and then implements visit_sample(), declared below. */
#ifndef SOMBRA_TRAVERSAL_H
#define SOMBRA_TRAVERSAL_H
#include "volume_sample.h"

/* Rays expressed in the world and in each volume's voxel space (affine maps keep t). */
typedef struct {
    lfloat3 origin, dir; /* world */
    lfloat3 vox_origin[SOMBRA_MAX_VOLUMES];
    lfloat3 vox_dir[SOMBRA_MAX_VOLUMES];
    lfloat t_enter[SOMBRA_MAX_VOLUMES], t_exit[SOMBRA_MAX_VOLUMES]; /* missed: both +∞ */
} VolumeRay;

/* Called for the lanes in `sampling` (a mask) at their parameters t; `active` has bit i set
 * for each volume i whose box contains the lane's sample. Returns the lanes that go on: a lane
 * left out of the result stops (early ray termination). */
lmask visit_sample(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray, lfloat t, lfloat step, luint active,
                   lmask sampling);

/* Slab test of every lane's ray against the box [lo, hi]; returns (t_near, t_far), empty when
 * t_near > t_far. Lanes parallel to a slab and outside it miss. */
inline void intersect_box(lfloat3 o, lfloat3 d, lfloat3 lo, lfloat3 hi, lfloat* t_near, lfloat* t_far) {
    lfloat t0 = (lfloat)(-INFINITY), t1 = (lfloat)(INFINITY);
    lfloat oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z}, la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
    for (int axis = 0; axis < 3; ++axis) {
        lmask parallel = fabs(da[axis]) < 1e-30f;
        lmask outside = parallel & ((oa[axis] < la[axis]) | (oa[axis] > ha[axis]));
        lfloat inv = 1.0f / select(da[axis], (lfloat)(1.0f), parallel);
        lfloat ta = (la[axis] - oa[axis]) * inv, tb = (ha[axis] - oa[axis]) * inv;
        t0 = select(fmax(t0, fmin(ta, tb)), t0, parallel);
        t1 = select(fmin(t1, fmax(ta, tb)), t1, parallel);
        t0 = select(t0, (lfloat)(INFINITY), outside);
        t1 = select(t1, (lfloat)(-INFINITY), outside);
    }
    *t_near = t0;
    *t_far = t1;
}

/* Fills ray for t in [t_min, t_max]; a volume's box is [-0.5, dims - 0.5] in voxel space. */
inline void make_volume_ray(VolumeRay* ray, __global const VolumeGpu* volumes, uint volume_count, lfloat3 origin,
                            lfloat3 dir, lfloat t_min, lfloat t_max) {
    ray->origin = origin;
    ray->dir = dir;
    for (uint i = 0; i < volume_count; ++i) {
        __global const VolumeGpu* v = &volumes[i];
        lfloat3 o = to_voxel_point(v, origin), d = to_voxel_direction(v, dir);
        lfloat3 lo = l3_splat((float3)(-0.5f));
        lfloat3 hi = l3_splat(convert_float3(v->dims.xyz) - 0.5f);
        lfloat t0, t1;
        intersect_box(o, d, lo, hi, &t0, &t1);
        t0 = fmax(t0, t_min);
        t1 = fmin(t1, t_max);
        lmask missed = !(t0 < t1);
        ray->vox_origin[i] = o;
        ray->vox_dir[i] = d;
        ray->t_enter[i] = select(t0, (lfloat)(INFINITY), missed);
        ray->t_exit[i] = select(t1, (lfloat)(INFINITY), missed);
    }
}

inline lfloat3 ray_voxel_point(const VolumeRay* ray, uint i, lfloat t) { return l3_mad(ray->vox_dir[i], t, ray->vox_origin[i]); }

#ifdef SOMBRA_SKIP_EMPTY
/* Lanes whose sample at t lies in an empty brick of every active volume; for them *t_resume is
 * where the first of those bricks ends along the ray (all samples before it are empty too). */
inline lmask in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* volumes, uint volume_count,
                             const VolumeRay* ray, luint active, lfloat t, lmask lanes, lfloat* t_resume) {
    lmask empty = lanes;
    lfloat t_exit = (lfloat)(INFINITY);
    for (uint i = 0; i < volume_count; ++i) {
        lmask here = empty & ((active & (1u << i)) != 0);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &volumes[i];
        lfloat3 p = ray_voxel_point(ray, i, select((lfloat)(0.0f), t, here));
        lint bx = min(LCONVERT_INT(clamp(p.x, 0.0f, (float)(v->dims.x - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.x - 1);
        lint by = min(LCONVERT_INT(clamp(p.y, 0.0f, (float)(v->dims.y - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.y - 1);
        lint bz = min(LCONVERT_INT(clamp(p.z, 0.0f, (float)(v->dims.z - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.z - 1);
        lint brick = (int)v->brick_offset + bx + v->brick_dims.x * (by + v->brick_dims.y * bz);
#define SOMBRA_OCCUPIED_LANE(c) (float)occupancy[LC(brick, c)]
        lfloat occupied = LFROM_LANES(SOMBRA_OCCUPIED_LANE);
#undef SOMBRA_OCCUPIED_LANE
        empty &= !(here & (occupied != 0.0f));
        lfloat3 lo = l3(LCONVERT_FLOAT(bx * SOMBRA_BRICK_SIZE), LCONVERT_FLOAT(by * SOMBRA_BRICK_SIZE),
                        LCONVERT_FLOAT(bz * SOMBRA_BRICK_SIZE));
        lfloat3 hi = l3(lo.x + SOMBRA_BRICK_SIZE, lo.y + SOMBRA_BRICK_SIZE, lo.z + SOMBRA_BRICK_SIZE);
        lfloat t0, t1;
        intersect_box(ray->vox_origin[i], ray->vox_dir[i], lo, hi, &t0, &t1);
        t_exit = select(t_exit, fmin(t_exit, t1), here);
    }
    *t_resume = t_exit;
    return empty;
}
#endif

/* Marches every homogeneous segment of each lane's ray front to back, calling visit_sample at
 * t_k = segment start + (k + jitter) · step. `lanes` masks the lanes that carry a ray. */
inline void traverse_segments(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray,
                              __global const VolumeGpu* volumes, uint volume_count,
                              __global const uchar* occupancy, lfloat jitter, lmask lanes) {
    /* segment boundaries: all enter/exit values, sorted per lane by a compare-exchange network
     * (missed volumes are +∞ and sort last) */
    lfloat bounds[2 * SOMBRA_MAX_VOLUMES];
    uint n = 2 * volume_count;
    for (uint i = 0; i < volume_count; ++i) {
        bounds[2 * i] = ray->t_enter[i];
        bounds[2 * i + 1] = ray->t_exit[i];
    }
    for (uint i = 0; i + 1 < n; ++i)
        for (uint j = 0; j + 1 < n - i; ++j) {
            lfloat a = bounds[j], b = bounds[j + 1];
            bounds[j] = fmin(a, b);
            bounds[j + 1] = fmax(a, b);
        }

    lmask alive = lanes;
    lint segment = (lint)(-1);
    lfloat t_start = (lfloat)(0.0f), t_end = (lfloat)(0.0f), step = (lfloat)(1.0f);
    lint k = (lint)(0); /* sample index in the segment: an integer, so that it never stalls */
    luint active = (luint)(0u);
    for (;;) {
        lfloat t = t_start + (LCONVERT_FLOAT(k) + jitter) * step;
        /* lanes past their segment's end move on to their next non-empty segment */
        lmask exhausted = alive & (t >= t_end);
        while (lany(exhausted)) {
            segment = select(segment, segment + 1, exhausted);
            lmask finished = exhausted & (segment >= (int)n - 1);
            alive &= !finished;
            exhausted &= !finished;
            if (!lany(exhausted)) break;
            for (uint s = 0; s + 1 < n; ++s) {
                lmask pick = exhausted & (segment == (int)s);
                t_start = select(t_start, bounds[s], pick);
                t_end = select(t_end, bounds[s + 1], pick);
            }
            lfloat mid = 0.5f * (t_start + t_end);
            lfloat new_step = (lfloat)(INFINITY);
            luint new_active = (luint)(0u);
            for (uint i = 0; i < volume_count; ++i) {
                lmask inside = (ray->t_enter[i] <= mid) & (mid < ray->t_exit[i]);
                new_active |= select((luint)(0u), (luint)(1u << i), inside);
                new_step = select(new_step, fmin(new_step, volumes[i].step), inside);
            }
            active = select(active, new_active, exhausted);
            step = select(step, select(new_step, (lfloat)(1.0f), new_active == 0u), exhausted);
            k = select(k, (lint)(0), exhausted);
            t = t_start + (LCONVERT_FLOAT(k) + jitter) * step;
            /* empty segments (no active volume, zero length, or +∞ bounds) are exhausted at once */
            exhausted &= (t >= t_end) | (new_active == 0u) | !(t_end > t_start);
        }
        if (!lany(alive)) return;
        lmask sampling = alive;
#ifdef SOMBRA_SKIP_EMPTY
        lfloat t_resume;
        lmask skip = in_empty_bricks(occupancy, volumes, volume_count, ray, active, t, alive, &t_resume);
        /* next k whose sample lies at or beyond the brick exit (one is added below) */
        lfloat resume_index = fmin(ceil((t_resume - t_start) / step - jitter), 1.0e9f); /* finite for convert */
        k = select(k, max(k, LCONVERT_INT(resume_index) - 1), skip);
        sampling &= !skip;
#endif
        if (lany(sampling)) alive &= visit_sample(volume_data, state, ray, t, step, active, sampling) | !sampling;
        k += 1;
    }
}

#endif
