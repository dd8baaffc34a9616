/* sombra — ray traversal as homogeneous segments (Knecht §3.1.2, docs/architecture.md "Data flow"), for a
 * packet of SOMBRA_LANES rays marched in lockstep (lanes.h).
 *
 * The boundaries of every volume's box along a ray cut it into segments; inside one segment the
 * set of active volumes does not change, and it is marched at the smallest step of those volumes.
 * Within a segment, bricks whose value range maps to zero opacity are skipped (Hadwiger §3,
 * brick min/max). Each lane follows its own segments; lanes only share the loop.
 *
 * Written once for every pass as a cursor: a pass calls segment_cursor_next() in a loop and does
 * its own work per point; nested traversals (shadow rays from a camera sample) need nothing more.
 *     SegmentCursor cursor;
 *     segment_cursor_init(&cursor, &ray, volume_count, jitter, lanes);
 *     lmask sampling;
 *     while (lany(sampling = segment_cursor_next(&cursor, &ray, volumes, volume_count, occupancy))) {
 *         … cursor.t, cursor.delta, cursor.active …
 *         cursor.alive &= go_on | !sampling;   // early termination
 *     }
 *
 * Exact intervals: the points of a segment [t_start, t_end] are its start, the samples
 * t_start + (k + jitter)·step strictly inside it, and its end. Each point closes the interval
 * from the previous point, of length cursor.delta (0 at a segment's start point, a whole step
 * between two samples, the part inside the segment at both ends, at a surface, a polyhedral bound
 * and the ray's t_max), so a pass that integrates over the intervals (interval_optical_depth)
 * counts exactly the length of medium that lies on the ray — never a whole step for a part. */
#ifndef SOMBRA_TRAVERSAL_H
#define SOMBRA_TRAVERSAL_H
#include "volume_sample.h"
#include "ray_triangle.h"

/* Rays expressed in the world and in each volume's voxel space (affine maps keep t). */
typedef struct {
    lfloat3 origin, dir; /* world */
    lfloat3 vox_origin[SOMBRA_VOLUME_SLOTS];
    lfloat3 vox_dir[SOMBRA_VOLUME_SLOTS];
    lfloat t_enter[SOMBRA_VOLUME_SLOTS], t_exit[SOMBRA_VOLUME_SLOTS]; /* missed: both +∞ */
} VolumeRay;

/* Slab test of every lane's ray against the box [lo, hi]; returns (t_near, t_far), empty when
 * t_near > t_far. Lanes parallel to a slab and outside it miss. */
static inline void intersect_box(lfloat3 o, lfloat3 d, lfloat3 lo, lfloat3 hi, lfloat* t_near, lfloat* t_far) {
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
#include "bvh.h" /* walks hierarchies with intersect_box */

/* Fills ray for t in [t_min, t_max]; a volume's box is [-0.5, dims - 0.5] in voxel space. */
static inline void make_volume_ray(VolumeRay* ray, __global const VolumeGpu* volumes, uint volume_count, lfloat3 origin,
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
#ifdef SOMBRA_VOLUME_CLIP
        lfloat c0, c1;
        intersect_box(origin, dir, l3_splat(v->clip_min.xyz), l3_splat(v->clip_max.xyz), &c0, &c1);
        t0 = fmax(t0, c0);
        t1 = fmin(t1, c1);
#endif
        lmask missed = !(t0 < t1);
        ray->vox_origin[i] = o;
        ray->vox_dir[i] = d;
        ray->t_enter[i] = select(t0, (lfloat)(INFINITY), missed);
        ray->t_exit[i] = select(t1, (lfloat)(INFINITY), missed);
    }
}

/* The ray misses every volume whose bit in `mask` is clear (a cluster's map holds its member
 * volumes only, Knecht §3.4.3). */
static inline void volume_ray_only(VolumeRay* ray, uint volume_count, uint mask) {
    for (uint i = 0; i < volume_count; ++i)
        if (!(mask & (1u << i))) ray->t_enter[i] = ray->t_exit[i] = (lfloat)(INFINITY);
}

static inline lfloat3 ray_voxel_point(const VolumeRay* ray, uint i, lfloat t) { return l3_mad(ray->vox_dir[i], t, ray->vox_origin[i]); }

#ifdef SOMBRA_SKIP_EMPTY
/* Lanes whose sample at t lies in an empty brick of every active volume; for them *t_resume is
 * where the ray leaves the first of the empty cubes around those bricks (all samples before it
 * are empty too). For the other lanes of `lanes`, *t_occupied is where it leaves the cube of
 * occupied bricks around the occupied brick their sample lies in (samples before it are not
 * empty either). The cubes: a brick's distance byte (scene_upload.h brick_distances, after the
 * volume's flags) r or 128 + r says that the (2r − 1)³ bricks centred on it are of its kind. */
static inline lmask in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* volumes, uint volume_count,
                             const VolumeRay* ray, luint active, lfloat t, lmask lanes, lfloat* t_resume,
                             lfloat* t_occupied) {
    lmask empty = lanes;
    lfloat t_exit = (lfloat)(INFINITY);
    lfloat occupied_exit = (lfloat)(-INFINITY);
    for (uint i = 0; i < volume_count; ++i) {
        lmask here = empty & ((active & (1u << i)) != 0);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &volumes[i];
        lfloat3 p = ray_voxel_point(ray, i, select((lfloat)(0.0f), t, here));
        lint bx = lmin(LCONVERT_INT(clamp_index(p.x, (float)(v->dims.x - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.x - 1);
        lint by = lmin(LCONVERT_INT(clamp_index(p.y, (float)(v->dims.y - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.y - 1);
        lint bz = lmin(LCONVERT_INT(clamp_index(p.z, (float)(v->dims.z - 1))) / SOMBRA_BRICK_SIZE, v->brick_dims.z - 1);
        int distances = (int)v->brick_offset + v->brick_dims.x * v->brick_dims.y * v->brick_dims.z;
        lint brick = distances + bx + v->brick_dims.x * (by + v->brick_dims.y * bz);
#define SOMBRA_DISTANCE_LANE(c) (int)occupancy[LC(brick, c)]
        lint distance = LFROM_LANES_AS(lint, SOMBRA_DISTANCE_LANE);
#undef SOMBRA_DISTANCE_LANE
        lmask full = here & (distance >= 128);
        empty &= !full;
        /* the cube of bricks of the same kind around it, in voxels */
        lint reach = (distance & 127) - 1;
        lfloat3 lo = l3(LCONVERT_FLOAT((bx - reach) * SOMBRA_BRICK_SIZE), LCONVERT_FLOAT((by - reach) * SOMBRA_BRICK_SIZE),
                        LCONVERT_FLOAT((bz - reach) * SOMBRA_BRICK_SIZE));
        lfloat size = LCONVERT_FLOAT((2 * reach + 1) * SOMBRA_BRICK_SIZE);
        lfloat3 hi = l3(lo.x + size, lo.y + size, lo.z + size);
        lfloat t0, t1;
        intersect_box(ray->vox_origin[i], ray->vox_dir[i], lo, hi, &t0, &t1);
        t_exit = select(t_exit, fmin(t_exit, t1), here);
        occupied_exit = select(occupied_exit, t1, full);
    }
    *t_resume = t_exit;
    *t_occupied = occupied_exit;
    return empty;
}
#endif

/* Where each lane is on its ray: the box bounds sorted, the current segment (its span, step and
 * active volumes) and the sample index k in it. With SOMBRA_HAS_MESHES the segment boundaries are
 * the box bounds merged in depth order with the ray's events (Knecht §3.1.2, §4.1.2): surface
 * fragments, handed to the pass at their depth (c->surface), and polyhedral-bound crossings, which
 * toggle their volume's inside bit. Events come from a pixel's sorted fragment list (camera pass,
 * DSM generation: segment_cursor_use_fragments) or, for shadow rays, from crossing the bound
 * triangles brute force (segment_cursor_use_bound_triangles). Without events (volume-only scenes)
 * the same code walks the box bounds alone. */
#define SOMBRA_NO_EVENT 0xffffffffu
enum { SOMBRA_EVENTS_NONE = 0, SOMBRA_EVENTS_FRAGMENTS = 1, SOMBRA_EVENTS_TRIANGLES = 2 };

typedef struct {
    lfloat bounds[2 * SOMBRA_VOLUME_SLOTS];
    uint bound_count;
    lmask alive;     /* lanes whose ray goes on; a pass clears lanes to stop them */
    lint next_bound; /* the first box bound not passed yet */
    lfloat t_start, t_end;
    lfloat step;     /* of the current segment: the smallest step of its active volumes × step_scale */
    float step_scale; /* 1, the shadow rays' RenderOptions::shadow_ray_step (shadow_ray.h) or DSM generation's dsm_step */
    luint active;    /* bit i: volume i is active in the current segment */
    lint phase;      /* 0: the segment's start point comes next; 1: its samples; 2: its end point was the last */
    lint k;          /* index of the last sample in the segment: an integer, so that it never stalls */
    lfloat jitter;
    lfloat t;        /* the current point (start, t_start + (k + jitter) · step, resume or end) or surface */
    lfloat delta;    /* length of the interval the current point closes: t − the previous point (0: a start) */
    lmask full_step; /* the interval is a whole step between two consecutive samples (delta = step) */
    lmask last_was_sample; /* the previous point was a sample reached by stepping */
    lmask resuming;  /* brick skipping: the next point is resume_t, where the empty bricks end */
    lfloat occupied_until; /* brick skipping: samples before it lie in the occupied bricks the last test found */
    lmask empty_interval; /* the current point closes an interval through empty bricks only: σ = 0 */
    lfloat resume_t;
#ifdef SOMBRA_HAS_MESHES
    lmask surface;   /* lanes whose event at t is the surface fragment surface_fragment[lane] */
    uint surface_fragment[SOMBRA_LANES];
    int source;      /* SOMBRA_EVENTS_* */
    uint pending[SOMBRA_LANES]; /* the event that ends the current segment, or SOMBRA_NO_EVENT */
    uint next[SOMBRA_LANES], end[SOMBRA_LANES]; /* fragments: the next one and the list's end */
    __global const FragmentGpu* fragments;
    __global const ScreenTriangleGpu* screen;
    /* triangles: every bound triangle (corner.w: its volume) in BVH order and the hierarchy, the
     * last crossing passed (t, index) and the ray's end */
    __global const SurfaceTriangleGpu* triangles;
    __global const BvhNodeGpu* bvh;
    uint bvh_nodes;
    float last_t[SOMBRA_LANES];
    uint last_triangle[SOMBRA_LANES];
    lfloat t_max;
    luint inside;    /* bit i: inside volume i's polyhedral bound (always set for box-bounded ones) */
#endif
} SegmentCursor;

static inline void segment_cursor_init(SegmentCursor* c, const VolumeRay* ray, uint volume_count, lfloat jitter, lmask lanes) {
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
    c->next_bound = (lint)(0);
    c->t_start = c->t_end = (lfloat)(0.0f); /* rays start at t = 0: the first segment ends at the first bound */
    c->step = (lfloat)(1.0f);
    c->step_scale = 1.0f;
    c->active = (luint)(0u);
    c->phase = (lint)(2); /* the first call moves on to the first segment */
    c->k = (lint)(-1);
    c->jitter = jitter;
    c->t = c->delta = c->resume_t = (lfloat)(0.0f);
    c->occupied_until = (lfloat)(-INFINITY);
    c->full_step = c->last_was_sample = c->resuming = c->empty_interval = (lmask)(0);
#ifdef SOMBRA_HAS_MESHES
    c->surface = (lmask)(0);
    c->source = SOMBRA_EVENTS_NONE;
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) c->pending[lane] = SOMBRA_NO_EVENT;
    c->inside = (luint)(0xffffffffu);
#endif
}

#ifdef SOMBRA_HAS_MESHES
/* Volumes with a polyhedral bound: their inside bit starts cleared, and each bound crossing in
 * front of the ray's start toggles it (parity: odd ⇒ the start lies inside the closed mesh). */
static inline luint box_bounded_volumes(__global const VolumeGpu* volumes, uint volume_count) {
    uint bounded = 0u;
    for (uint i = 0; i < volume_count; ++i)
        if (volumes[i].bound_count > 0u) bounded |= 1u << i;
    return (luint)(~bounded);
}

/* Events from each lane's sorted fragment list: fragments [first[pixel], first[pixel + 1]) of
 * its pixel (lanes outside `lanes` get none). */
static inline void segment_cursor_use_fragments(SegmentCursor* c, __global const VolumeGpu* volumes, uint volume_count,
                                         __global const uint* fragment_first, __global const FragmentGpu* fragments,
                                         __global const ScreenTriangleGpu* screen, const uint* pixel, lmask lanes) {
    c->source = SOMBRA_EVENTS_FRAGMENTS;
    c->fragments = fragments;
    c->screen = screen;
    int in[SOMBRA_LANES];
    uint parity[SOMBRA_LANES];
    LSTORE(lanes, in);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) {
        c->next[lane] = fragment_first[pixel[lane]];
        c->end[lane] = in[lane] ? fragment_first[pixel[lane] + 1] : c->next[lane];
        parity[lane] = 0u;
        for (uint f = c->next[lane]; f < c->end[lane]; ++f) {
            __global const ScreenTriangleGpu* tri = &screen[fragments[f].triangle];
            if (tri->flags & SOMBRA_TRI_BOUND) parity[lane] ^= 1u << tri->mesh;
        }
    }
    c->inside = box_bounded_volumes(volumes, volume_count) | LLOAD(parity);
}

/* Events from crossing the bound triangles along the ray, 0 < t < t_max, found through their BVH
 * (cl/bvh.h) in (t, triangle) order; the inside bits from the parity of all crossings at t > 0
 * (to infinity). */
static inline void segment_cursor_use_bound_triangles(SegmentCursor* c, const VolumeRay* ray, __global const VolumeGpu* volumes,
                                               uint volume_count, __global const SurfaceTriangleGpu* triangles,
                                               __global const BvhNodeGpu* bvh, uint bvh_nodes, lfloat t_max, lmask lanes) {
    c->source = SOMBRA_EVENTS_TRIANGLES;
    c->triangles = triangles;
    c->bvh = bvh;
    c->bvh_nodes = bvh_nodes;
    c->t_max = t_max;
    luint parity = (luint)(0u);
    BvhWalk walk;
    bvh_walk_init(&walk, bvh_nodes);
    uint first, count;
    while (bvh_walk_next(&walk, bvh, ray->origin, ray->dir, (lfloat)(0.0f), (lfloat)(INFINITY), lanes, &first, &count))
        for (uint i = first; i < first + count; ++i) {
            __global const SurfaceTriangleGpu* tri = &triangles[i];
            lfloat t = ray_triangle_t(ray->origin, ray->dir, tri->corner.xyz, tri->corner1.xyz, tri->corner2.xyz, lanes);
            parity ^= select((luint)(0u), (luint)(1u << (uint)tri->corner.w), t > 0.0f & t < INFINITY);
        }
    c->inside = box_bounded_volumes(volumes, volume_count) | parity;
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) c->last_t[lane] = 0.0f, c->last_triangle[lane] = SOMBRA_NO_EVENT;
}

/* Depth of each lane's next event (+∞: none) in `lanes`; *which gets its fragment or triangle. */
static inline lfloat cursor_peek_event(const SegmentCursor* c, const VolumeRay* ray, lmask lanes, uint* which) {
    float depth[SOMBRA_LANES];
    if (c->source == SOMBRA_EVENTS_TRIANGLES) {
        /* the first crossing after the last one passed, in (t, index) order (ties at one t, e.g.
         * an edge shared by two triangles, are each passed once, as the parity counted them) */
        lfloat last_t = LLOAD(c->last_t), best = (lfloat)(INFINITY);
        luint last_i = LLOAD(c->last_triangle), best_i = (luint)(SOMBRA_NO_EVENT);
        BvhWalk walk;
        bvh_walk_init(&walk, c->bvh_nodes);
        uint first, count;
        /* only boxes between the last crossing and the nearest one found so far */
        while (bvh_walk_next(&walk, c->bvh, ray->origin, ray->dir, last_t, fmin(best, c->t_max), lanes, &first, &count))
            for (uint i = first; i < first + count; ++i) {
                __global const SurfaceTriangleGpu* tri = &c->triangles[i];
                lfloat t = ray_triangle_t(ray->origin, ray->dir, tri->corner.xyz, tri->corner1.xyz, tri->corner2.xyz, lanes);
                lmask after = (t > last_t) | ((t == last_t) & ((luint)(i) > last_i));
                lmask better = after & ((t < best) | ((t == best) & ((luint)(i) < best_i))) & (t < c->t_max);
                best = select(best, t, better);
                best_i = select(best_i, (luint)(i), better);
            }
        LSTORE(best, depth);
        LSTORE(best_i, which);
        return best;
    }
    int in[SOMBRA_LANES];
    LSTORE(lanes, in);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) {
        int any = c->source == SOMBRA_EVENTS_FRAGMENTS && in[lane] && c->next[lane] < c->end[lane];
        which[lane] = any ? c->next[lane] : SOMBRA_NO_EVENT;
        depth[lane] = any ? c->fragments[c->next[lane]].depth : INFINITY;
    }
    return LLOAD(depth);
}

/* Lanes `moving` begin a new segment: in lanes `take` it ends at their next event (taken from the
 * source), in the others at a box bound. */
static inline void cursor_take_event(SegmentCursor* c, lmask moving, lmask take, const uint* which, lfloat depth) {
    int move[SOMBRA_LANES], taken[SOMBRA_LANES];
    float t[SOMBRA_LANES];
    LSTORE(moving, move);
    LSTORE(take, taken);
    LSTORE(depth, t);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) {
        if (!move[lane]) continue;
        c->pending[lane] = taken[lane] ? which[lane] : SOMBRA_NO_EVENT;
        if (!taken[lane]) continue;
        if (c->source == SOMBRA_EVENTS_TRIANGLES) c->last_t[lane] = t[lane], c->last_triangle[lane] = which[lane];
        else c->next[lane] += 1u;
    }
}

/* Passes the events that end the segments of `lanes`: a bound toggles its volume's inside bit;
 * returns the lanes whose event is a surface fragment (kept in surface_fragment). */
static inline lmask cursor_pass_events(SegmentCursor* c, lmask lanes) {
    int pass[SOMBRA_LANES], surface[SOMBRA_LANES];
    uint toggle[SOMBRA_LANES];
    LSTORE(lanes, pass);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) {
        uint e = c->pending[lane];
        surface[lane] = 0, toggle[lane] = 0u;
        if (!pass[lane] || e == SOMBRA_NO_EVENT) continue;
        c->pending[lane] = SOMBRA_NO_EVENT;
        if (c->source == SOMBRA_EVENTS_TRIANGLES) {
            toggle[lane] = 1u << (uint)c->triangles[e].corner.w;
            continue;
        }
        __global const ScreenTriangleGpu* tri = &c->screen[c->fragments[e].triangle];
        if (tri->flags & SOMBRA_TRI_BOUND) {
            toggle[lane] = 1u << tri->mesh;
        } else {
            surface[lane] = -1; /* vector-mask convention; LLOAD makes it a lane mask */
            c->surface_fragment[lane] = e;
        }
    }
    c->inside ^= LLOAD(toggle);
    return LLOAD(surface);
}
#endif

/* Moves every live lane to its next point or event, front to back: the segment's start point,
 * its samples, its end point, then the next non-empty segment; a sample in empty bricks of every
 * active volume makes the next point the bricks' end (the interval between has σ = 0: the
 * bricks' value range maps to zero extinction). Returns the lanes that have a point at c->t and,
 * with meshes, the lanes c->surface whose surface fragment lies at c->t; no lane once every ray
 * is done. */
static inline lmask segment_cursor_next(SegmentCursor* c, const VolumeRay* ray, __global const VolumeGpu* volumes,
                                 uint volume_count, __global const uchar* occupancy) {
    /* lanes whose last point ended their segment (or that handed over a surface) move on to their
     * next non-empty segment */
    lmask exhausted = c->alive & (c->phase == 2);
#ifdef SOMBRA_HAS_MESHES
    c->surface = (lmask)(0);
#endif
    while (lany(exhausted)) {
#ifdef SOMBRA_HAS_MESHES
        /* the event at the end of the segment: bounds toggle, surfaces go to the pass */
        lmask surface = cursor_pass_events(c, exhausted);
        c->surface |= surface;
        c->phase = select(c->phase, (lint)(2), surface); /* the next call moves on past the surface */
        exhausted &= !surface;
        if (!lany(exhausted)) break;
#endif
        lfloat next_box = (lfloat)(INFINITY);
        for (uint s = 0; s < c->bound_count; ++s) next_box = select(next_box, c->bounds[s], exhausted & (c->next_bound == (int)s));
        lfloat next_end = next_box;
#ifdef SOMBRA_HAS_MESHES
        uint which[SOMBRA_LANES];
        lfloat next_event = cursor_peek_event(c, ray, exhausted, which);
        lmask take = exhausted & (next_event < next_box); /* a tie: the box bound first */
        cursor_take_event(c, exhausted, take, which, next_event);
        next_end = fmin(next_box, next_event);
#else
        lmask take = (lmask)(0);
#endif
        /* nothing finite ahead: every later segment is empty */
        lmask finished = exhausted & !(next_end < INFINITY);
        c->alive &= !finished;
        exhausted &= !finished;
        if (!lany(exhausted)) break;
        c->next_bound = select(c->next_bound, c->next_bound + 1, exhausted & !take);
        c->t_start = select(c->t_start, c->t_end, exhausted);
        c->t_end = select(c->t_end, next_end, exhausted);
        lfloat mid = 0.5f * (c->t_start + c->t_end);
        lfloat new_step = (lfloat)(INFINITY);
        luint new_active = (luint)(0u);
        for (uint i = 0; i < volume_count; ++i) {
            lmask inside = (ray->t_enter[i] <= mid) & (mid < ray->t_exit[i]);
#ifdef SOMBRA_HAS_MESHES
            inside &= (c->inside & (1u << i)) != 0u; /* box AND polyhedral bound */
#endif
            new_active |= select((luint)(0u), (luint)(1u << i), inside);
            new_step = select(new_step, fmin(new_step, volumes[i].step), inside);
        }
        c->active = select(c->active, new_active, exhausted);
        c->step = select(c->step, select(new_step * c->step_scale, (lfloat)(1.0f), new_active == 0u), exhausted);
        /* the first sample lies strictly after the start point (k = 0, or 1 without jitter) */
        c->k = select(c->k, select((lint)(-1), (lint)(0), c->jitter <= 0.0f), exhausted);
        c->phase = select(c->phase, (lint)(0), exhausted);
        c->resuming &= !exhausted;
        c->occupied_until = select(c->occupied_until, (lfloat)(-INFINITY), exhausted); /* new active volumes */
        /* empty segments (no active volume, zero length) are passed at once */
        exhausted &= (new_active == 0u) | !(c->t_end > c->t_start);
    }
    lmask moving = c->alive;
#ifdef SOMBRA_HAS_MESHES
    moving &= !c->surface;
    c->t = select(c->t, c->t_end, c->surface); /* a surface lies where its segment ends */
#endif
    if (!lany(moving)) {
#ifdef SOMBRA_HAS_MESHES
        return c->surface; /* surfaces only */
#else
        return moving;
#endif
    }
    lmask starting = moving & (c->phase == 0);
    lmask resuming = moving & c->resuming & !starting;
    lmask stepping = moving & !starting & !resuming;
    c->k = select(c->k, c->k + 1, stepping);
    lfloat t = c->t_start + (LCONVERT_FLOAT(c->k) + c->jitter) * c->step;
    t = select(t, c->resume_t, resuming);
    t = select(t, c->t_start, starting);
    lmask ending = moving & !starting & (t >= c->t_end);
    t = select(t, c->t_end, ending);
    lmask sample = stepping & !ending;
    c->full_step = sample & c->last_was_sample;
    c->empty_interval = resuming; /* from the sample in the first empty brick to where they end */
    c->delta = select(c->delta, select(select(t - c->t, c->step, c->full_step), (lfloat)(0.0f), starting), moving);
    c->last_was_sample = select(c->last_was_sample, sample, moving);
    c->t = select(c->t, t, moving);
    c->phase = select(select(c->phase, (lint)(1), starting), (lint)(2), ending);
    c->resuming &= !moving;
#ifdef SOMBRA_SKIP_EMPTY
    /* a sample still inside the cube of occupied bricks the last test found is not tested again
     * (a rounding at the cube's face at worst tests one sample more or samples one empty one) */
    lfloat t_resume, t_occupied;
    lmask test = sample & !(t < c->occupied_until);
    lmask skip = in_empty_bricks(occupancy, volumes, volume_count, ray, c->active, t, test, &t_resume, &t_occupied);
    c->occupied_until = select(c->occupied_until, t_occupied, test & !skip);
    skip &= t_resume > t; /* NaN and ±∞ (a ray parallel to a brick face, outside it) skip nothing */
    skip &= t_resume < INFINITY;
    /* a run of empty bricks is one interval: while the brick the ray enters at t_resume (tested
     * just past its face) is empty too, the resume point moves to its exit */
    lmask hopping = skip & (t_resume < c->t_end);
    for (int hop = 0; hop < 64 && lany(hopping); ++hop) {
        lfloat t_probe = select(t, t_resume + 1e-3f * c->step, hopping), t_exit, t_full;
        lmask empty = in_empty_bricks(occupancy, volumes, volume_count, ray, c->active, t_probe, hopping, &t_exit, &t_full);
        hopping = empty & (t_exit > t_resume) & (t_exit < INFINITY);
        t_resume = select(t_resume, t_exit, hopping);
        hopping &= t_resume < c->t_end;
    }
    c->resuming |= skip;
    c->resume_t = select(c->resume_t, t_resume, skip);
    /* the sample after the resume point: the first k with t_start + (k + jitter)·step > t_resume
     * (fmin keeps the conversion to int defined) */
    lfloat resume_index = fmin(floor((t_resume - c->t_start) / c->step - c->jitter) + 1.0f, 1.0e9f);
    c->k = select(c->k, max(c->k, LCONVERT_INT(select((lfloat)(0.0f), resume_index, skip)) - 1), skip);
#endif
#ifdef SOMBRA_HAS_MESHES
    return moving | c->surface;
#else
    return moving;
#endif
}

/* Density of volume i at the cursor's point (trilinear, voxel space) in lanes `here`. */
static inline lfloat density_at_point(VOLUME_DATA_PARAM, __global const VolumeGpu* v, const VolumeRay* ray, uint i, lfloat t) {
    return sample_density(volume_data, v, ray_voxel_point(ray, i, t));
}

/* Mean extinction of volume i over the interval the cursor's point closes: pre-integrated
 * (volume_sample.h) between the density at the previous point, *front, and `density` at this
 * one; *front becomes `density` in lanes `here`. A start point (delta 0) only sets *front. */
static inline lfloat interval_sigma(__global const float* tf_tables, __global const VolumeGpu* v, lfloat density, lfloat* front,
                             lmask here) {
    lfloat sigma = preintegrated_sigma(tf_tables, v, *front, density);
    *front = select(*front, density, here);
    return select((lfloat)(0.0f), sigma, here);
}

/* ∫σ of volume i over [t0, t1] (at most one voxel along every axis), the density `front` at t0
 * and `back` at t1, split where the ray crosses a voxel-centre plane (integer voxel coordinate,
 * one per axis at most), where the trilinear density has its kinks: between the crossings it is
 * nearly linear and the pre-integrated σ of each piece is its exact mean. */
static inline lfloat voxel_piece_depth(VOLUME_DATA_PARAM, __global const VolumeGpu* v, __global const float* tf_tables,
                                const VolumeRay* ray, uint i, lfloat t0, lfloat t1, lfloat front, lfloat back, lmask here) {
    lfloat3 o = ray->vox_origin[i], d = ray->vox_dir[i];
    lfloat oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z}, crossing[3];
    for (int a = 0; a < 3; ++a) {
        lfloat f0 = floor(mad(da[a], t0, oa[a])), f1 = floor(mad(da[a], t1, oa[a]));
        lfloat tc = (fmax(f0, f1) - oa[a]) / select(da[a], (lfloat)(1.0f), da[a] == 0.0f);
        crossing[a] = select((lfloat)(INFINITY), tc, here & (f0 != f1) & (tc > t0) & (tc < t1));
    }
    for (int j = 0; j < 2; ++j) /* sort the three (∞: none) */
        for (int a = 0; a < 2 - j; ++a) {
            lfloat lo = fmin(crossing[a], crossing[a + 1]), hi = fmax(crossing[a], crossing[a + 1]);
            crossing[a] = lo, crossing[a + 1] = hi;
        }
    lfloat depth = (lfloat)(0.0f), t = t0, density = front;
    for (int j = 0; j < 3; ++j) {
        lmask crosses = crossing[j] < INFINITY;
        if (!lany(crosses)) break;
        lfloat tc = select(t, crossing[j], crosses);
        lfloat dc = density_at_point(volume_data, v, ray, i, tc);
        depth += select((lfloat)(0.0f), preintegrated_sigma(tf_tables, v, density, dc) * (tc - t), crosses);
        t = tc;
        density = select(density, dc, crosses);
    }
    return depth + preintegrated_sigma(tf_tables, v, density, back) * (t1 - t);
}

/* The most pieces a stiff interval is cut into (a longer interval, e.g. a step of 16 voxels, keeps
 * its last piece longer than a voxel). */
#define SOMBRA_STIFF_MAX_PIECES 16

/* ∫σ of volume i over [t0, t1], the density `front` at t0 and `back` at t1, in pieces of at most one voxel along every axis, each
 * split at the voxel-centre planes it crosses (voxel_piece_depth) — a peak between two samples is
 * then sampled, not cut off (a one-voxel wall: the tent of its value along the ray is linear
 * between the crossings). interval_volume_depth: this for stiff volumes, else one pre-integrated
 * interval. */
static inline lfloat split_interval_depth(VOLUME_DATA_PARAM, __global const VolumeGpu* v, __global const float* tf_tables,
                                   const VolumeRay* ray, uint i, lfloat t0, lfloat t1, lfloat front, lfloat back, lmask here) {
    lfloat3 span = l3_scale(ray->vox_dir[i], t1 - t0);
    lfloat longest = fmax(fabs(span.x), fmax(fabs(span.y), fabs(span.z)));
    lint pieces = lclamp(LCONVERT_INT(ceil(select((lfloat)(1.0f), longest, here) - 1e-3f)), 1, SOMBRA_STIFF_MAX_PIECES);
    lfloat length = (t1 - t0) / LCONVERT_FLOAT(pieces);
    lfloat depth = (lfloat)(0.0f), t = t0, density = front;
    for (int j = 1; j < SOMBRA_STIFF_MAX_PIECES; ++j) {
        lmask more = here & (pieces > j);
        if (!lany(more)) break;
        lfloat tb = select(t, t0 + LCONVERT_FLOAT((lint)(j)) * length, more);
        lfloat db = density_at_point(volume_data, v, ray, i, tb);
        depth += select((lfloat)(0.0f), voxel_piece_depth(volume_data, v, tf_tables, ray, i, t, tb, density, db, more), more);
        t = tb;
        density = select(density, db, more);
    }
    return depth + voxel_piece_depth(volume_data, v, tf_tables, ray, i, t, t1, density, back, here);
}

static inline lfloat interval_volume_depth(VOLUME_DATA_PARAM, __global const VolumeGpu* v, __global const float* tf_tables,
                                    const VolumeRay* ray, uint i, lfloat t0, lfloat t1, lfloat front, lfloat back, lmask here) {
    if (!v->stiff) return preintegrated_sigma(tf_tables, v, front, back) * (t1 - t0);
    return split_interval_depth(volume_data, v, tf_tables, ray, i, t0, t1, front, back, here);
}

/* Optical depth ∫σ over the interval [t − delta, t] the cursor's point closes, summed over the
 * active volumes (an overlap adds extinctions); front[i]: volume i's density at the previous
 * point, updated. 0 in lanes outside `sampling`. Callers keep t finite in every lane. Used by the
 * light passes (shadow rays, DSM generation); the camera pass blends colours by interval_sigma. */
static inline lfloat interval_optical_depth(VOLUME_DATA_PARAM, __global const VolumeGpu* volumes, __global const float* tf_tables,
                                     const VolumeRay* ray, const SegmentCursor* c, lfloat t, lfloat* front, lmask sampling) {
    lfloat depth = (lfloat)(0.0f);
    lfloat t0 = t - select((lfloat)(0.0f), c->delta, sampling);
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) {
        lmask here = sampling & ((c->active & (1u << i)) != 0u) & (c->delta > 0.0f) & !c->empty_interval;
        lmask starts = sampling & ((c->active & (1u << i)) != 0u);
        if (!lany(starts)) continue;
        __global const VolumeGpu* v = &volumes[i];
        lfloat back = density_at_point(volume_data, v, ray, i, t);
        if (lany(here))
            depth += select((lfloat)(0.0f),
                            interval_volume_depth(volume_data, v, tf_tables, ray, i, t0, t, front[i], back, here), here);
        front[i] = select(front[i], back, starts);
    }
    return depth;
}

#endif
