/* sombra — ray traversal as homogeneous segments (Knecht §3.1.2, DESIGN.md "Data flow"), for a
 * packet of SOMBRA_LANES rays marched in lockstep (lanes.h).
 *
 * The boundaries of every volume's box along a ray cut it into segments; inside one segment the
 * set of active volumes does not change, and it is marched at the smallest step of those volumes.
 * Within a segment, bricks whose value range maps to zero opacity are skipped (Hadwiger §3,
 * brick min/max). Each lane follows its own segments; lanes only share the loop.
 *
 * Written once for every pass as a cursor: a pass calls segment_cursor_next() in a loop and does
 * its own work per sample; nested traversals (shadow rays from a camera sample) need nothing more.
 *     SegmentCursor cursor;
 *     segment_cursor_init(&cursor, &ray, volume_count, jitter, lanes);
 *     lmask sampling;
 *     while (lany(sampling = segment_cursor_next(&cursor, &ray, volumes, volume_count, occupancy))) {
 *         … cursor.t, cursor.step, cursor.active …
 *         cursor.alive &= go_on | !sampling;   // early termination
 *     } */
#ifndef SOMBRA_TRAVERSAL_H
#define SOMBRA_TRAVERSAL_H
#include "volume_sample.h"

/* Rays expressed in the world and in each volume's voxel space (affine maps keep t). */
typedef struct {
    lfloat3 origin, dir; /* world */
    lfloat3 vox_origin[SOMBRA_VOLUME_SLOTS];
    lfloat3 vox_dir[SOMBRA_VOLUME_SLOTS];
    lfloat t_enter[SOMBRA_VOLUME_SLOTS], t_exit[SOMBRA_VOLUME_SLOTS]; /* missed: both +∞ */
} VolumeRay;

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

/* Where each lane is on its ray: the sorted segment boundaries, the current segment (its span,
 * step and active volumes) and the sample index k in it. */
typedef struct {
    lfloat bounds[2 * SOMBRA_VOLUME_SLOTS];
    uint bound_count;
    lmask alive;     /* lanes whose ray goes on; a pass clears lanes to stop them */
    lint segment;
    lfloat t_start, t_end;
    lfloat step;     /* of the current segment: the smallest step of its active volumes */
    luint active;    /* bit i: volume i is active in the current segment */
    lint k;          /* sample index in the segment: an integer, so that it never stalls */
    lfloat jitter;
    lfloat t;        /* parameter of the current sample: t_start + (k + jitter) · step */
} SegmentCursor;

inline void segment_cursor_init(SegmentCursor* c, const VolumeRay* ray, uint volume_count, lfloat jitter, lmask lanes) {
    /* all enter/exit values, sorted per lane by a compare-exchange network (missed volumes are
     * +∞ and sort last) */
    uint n = 2 * volume_count;
    for (uint i = 0; i < volume_count; ++i) {
        c->bounds[2 * i] = ray->t_enter[i];
        c->bounds[2 * i + 1] = ray->t_exit[i];
    }
    for (uint i = 0; i + 1 < n; ++i)
        for (uint j = 0; j + 1 < n - i; ++j) {
            lfloat a = c->bounds[j], b = c->bounds[j + 1];
            c->bounds[j] = fmin(a, b);
            c->bounds[j + 1] = fmax(a, b);
        }
    c->bound_count = n;
    c->alive = lanes;
    c->segment = (lint)(-1);
    c->t_start = c->t_end = (lfloat)(0.0f);
    c->step = (lfloat)(1.0f);
    c->active = (luint)(0u);
    c->k = (lint)(-1);
    c->jitter = jitter;
}

/* Moves every live lane to its next sample, front to back: next k, else the next non-empty
 * segment; skips samples in empty bricks. Returns the lanes that sample at c->t (possibly after
 * several steps of skipping), or no lane once every ray is done. */
inline lmask segment_cursor_next(SegmentCursor* c, const VolumeRay* ray, __global const VolumeGpu* volumes,
                                 uint volume_count, __global const uchar* occupancy) {
    for (;;) {
        c->k += 1;
        lfloat t = c->t_start + (LCONVERT_FLOAT(c->k) + c->jitter) * c->step;
        /* lanes past their segment's end move on to their next non-empty segment */
        lmask exhausted = c->alive & (t >= c->t_end);
        while (lany(exhausted)) {
            c->segment = select(c->segment, c->segment + 1, exhausted);
            lmask finished = exhausted & (c->segment >= (int)c->bound_count - 1);
            c->alive &= !finished;
            exhausted &= !finished;
            if (!lany(exhausted)) break;
            for (uint s = 0; s + 1 < c->bound_count; ++s) {
                lmask pick = exhausted & (c->segment == (int)s);
                c->t_start = select(c->t_start, c->bounds[s], pick);
                c->t_end = select(c->t_end, c->bounds[s + 1], pick);
            }
            lfloat mid = 0.5f * (c->t_start + c->t_end);
            lfloat new_step = (lfloat)(INFINITY);
            luint new_active = (luint)(0u);
            for (uint i = 0; i < volume_count; ++i) {
                lmask inside = (ray->t_enter[i] <= mid) & (mid < ray->t_exit[i]);
                new_active |= select((luint)(0u), (luint)(1u << i), inside);
                new_step = select(new_step, fmin(new_step, volumes[i].step), inside);
            }
            c->active = select(c->active, new_active, exhausted);
            c->step = select(c->step, select(new_step, (lfloat)(1.0f), new_active == 0u), exhausted);
            c->k = select(c->k, (lint)(0), exhausted);
            t = c->t_start + (LCONVERT_FLOAT(c->k) + c->jitter) * c->step;
            /* empty segments (no active volume, zero length, or +∞ bounds) are exhausted at once */
            exhausted &= (t >= c->t_end) | (new_active == 0u) | !(c->t_end > c->t_start);
        }
        if (!lany(c->alive)) return c->alive;
        c->t = t;
        lmask sampling = c->alive;
#ifdef SOMBRA_SKIP_EMPTY
        lfloat t_resume;
        lmask skip = in_empty_bricks(occupancy, volumes, volume_count, ray, c->active, t, c->alive, &t_resume);
        /* the next call samples at the first k at or beyond the brick exit */
        /* fmax/fmin also map NaN and ±∞ (a ray parallel to a brick face, outside it) into range:
         * converting them to int is undefined */
        lfloat resume_index = fmin(fmax(ceil((t_resume - c->t_start) / c->step - c->jitter), -1.0f), 1.0e9f);
        c->k = select(c->k, max(c->k, LCONVERT_INT(resume_index) - 1), skip);
        sampling &= !skip;
#endif
        if (lany(sampling)) return sampling;
    }
}

/* Extinction σ of every active volume at t, summed (an overlap blends by extinction); 0 in lanes
 * outside `sampling`. Callers keep t finite in every lane. */
inline lfloat extinction_at(VOLUME_DATA_PARAM, __global const VolumeGpu* volumes, __global const float* tf_tables,
                            const VolumeRay* ray, lfloat t, luint active, lmask sampling) {
    lfloat sigma = (lfloat)(0.0f);
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) {
        lmask here = sampling & ((active & (1u << i)) != 0u);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &volumes[i];
        Classified c = classify(tf_tables, v, sample_density(volume_data, v, ray_voxel_point(ray, i, t)));
        sigma += select((lfloat)(0.0f), c.sigma, here);
    }
    return sigma;
}

#endif
