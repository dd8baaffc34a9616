/* sombra — the shadow-ray march (course slides: shadow rays): transmittance exp(−∫σ) from a
 * point to a light over the same segments as the camera rays, each interval pre-integrated and
 * of its exact length (traversal.h), stopping once it falls below 10⁻⁶. Used by the "rays"
 * technique and as the low-pass technique's fallback for lights without a table.
 * With SOMBRA_SHADOW_RAY_MESHES the rays also cross the world-space mesh triangles, with
 * SOMBRA_HAS_BOUNDS the polyhedral volume bounds (both set by techniques/rays.h). With
 * SOMBRA_SHADOW_RAY_STEP (src/techniques/rays.cpp) they march at that factor of the volumes' step. */
#ifndef SOMBRA_SHADOW_RAY_H
#define SOMBRA_SHADOW_RAY_H
#include "scene_refs.h"
#include "traversal.h" /* with volume_sample.h, bvh.h and ray_triangle.h */

/* The triangles shadow rays cross besides the volumes. */
typedef struct {
#ifdef SOMBRA_SHADOW_RAY_MESHES
    __global const SurfaceTriangleGpu* shadow_triangles; /* every mesh triangle in BVH order, corner.w = opacity */
    __global const BvhNodeGpu* shadow_bvh;               /* the hierarchy over them (src/geometry/bvh.h) */
    uint shadow_bvh_nodes;
#endif
#ifdef SOMBRA_HAS_BOUNDS
    __global const SurfaceTriangleGpu* bound_triangles; /* every volume's bound in BVH order, corner.w = the volume */
    __global const BvhNodeGpu* bound_bvh;
    uint bound_bvh_nodes;
#endif
    char unused;
} ShadowRayGeometry;

#ifdef SOMBRA_SHADOW_RAY_MESHES
/* Transmittance of the surfaces on the segment p + t·dir, 0 < t < t_max (|dir| = 1): Π(1 − a) over
 * every triangle it crosses (a: the mesh's opacity, corner.w), Möller–Trumbore on the triangles of
 * the BVH leaves the packet's rays cross (cl/bvh.h); lanes whose transmittance reached 0 drop out.
 * A ray in a triangle's plane (|det| ≤ 10⁻⁷ of |e1 × e2|) and a degenerate triangle (e1 × e2 = 0)
 * cross nothing: no division by zero, no NaN. */
static inline lfloat surfaces_transmittance(const ShadowRayGeometry* g, lfloat3 p, lfloat3 dir, lfloat t_max, lmask lanes) {
    lfloat result = (lfloat)(1.0f);
    BvhWalk walk;
    bvh_walk_init(&walk, g->shadow_bvh_nodes);
    uint first, count;
    while (bvh_walk_next(&walk, g->shadow_bvh, p, dir, (lfloat)(0.0f), t_max, lanes & (result > 0.0f), &first, &count)) {
        for (uint i = first; i < first + count; ++i) {
            __global const SurfaceTriangleGpu* tri = &g->shadow_triangles[i];
            lfloat t = ray_triangle_t(p, dir, tri->corner.xyz, tri->corner1.xyz, tri->corner2.xyz, lanes);
            result = select(result, result * (1.0f - tri->corner.w), (t > 0.0f) & (t < t_max));
        }
    }
    return result;
}
#endif

/* The ray from p to the light: its unit direction and length (INFINITY for a directional light). */
static inline void ray_to_light(__global const LightGpu* light, lfloat3 p, lfloat3* dir, lfloat* t_max) {
    if (light->type == SOMBRA_LIGHT_DIRECTIONAL) {
        *dir = l3_splat(-light->direction.xyz);
        *t_max = (lfloat)(INFINITY);
    } else {
        lfloat3 d = l3_sub(l3_splat(light->position.xyz), p);
        *t_max = sqrt(l3_dot(d, d));
        *dir = l3_scale(d, 1.0f / fmax(*t_max, 1e-30f));
    }
}

/* Transmittance along p + t·dir, 0 < t < t_max (|dir| = 1; with meshes, times
 * surfaces_transmittance): the shadow ray to the light, or a piece of one (the light lattices'
 * columns, render.cl shadow_cache_fill_columns). */
static inline lfloat segment_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, const ShadowRayGeometry* geometry, lfloat3 p,
                                           lfloat3 dir, lfloat t_max, lmask lanes) {
    uint volume_count = scene->camera->volume_count;
    VolumeRay ray;
    make_volume_ray(&ray, scene->volumes, volume_count, p, dir, (lfloat)(0.0f), t_max);
    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, volume_count, scene->jitter, lanes);
#ifdef SOMBRA_SHADOW_RAY_STEP /* RenderOptions::shadow_ray_step (techniques/rays.h only) */
    cursor.step_scale = SOMBRA_SHADOW_RAY_STEP;
#endif
#ifdef SOMBRA_HAS_BOUNDS /* polyhedral bounds: their crossings along the ray are segment boundaries */
    segment_cursor_use_bound_triangles(&cursor, &ray, scene->volumes, volume_count, geometry->bound_triangles,
                                       geometry->bound_bvh, geometry->bound_bvh_nodes, t_max, lanes);
#endif
    lfloat optical_depth = (lfloat)(0.0f);
    lfloat front[SOMBRA_VOLUME_SLOTS]; /* each volume's density at the previous point */
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) front[i] = (lfloat)(0.0f);
    lmask sampling;
    while (lany(sampling = segment_cursor_next(&cursor, &ray, scene->volumes, volume_count, scene->occupancy))) {
        lfloat t = select((lfloat)(0.0f), cursor.t, sampling); /* finite positions in idle lanes */
        optical_depth += interval_optical_depth(volume_data, scene->volumes, scene->tf_tables, &ray, &cursor, t, front, sampling);
        cursor.alive &= !(optical_depth > SOMBRA_OPAQUE_DEPTH);
    }
    /* scalar exp per lane: the same bits as 1 lane (PoCL's vector exp may differ in the last bit) */
    float depth_lane[SOMBRA_LANES];
    LSTORE(optical_depth, depth_lane);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) depth_lane[lane] = exp(-depth_lane[lane]);
#ifdef SOMBRA_SHADOW_RAY_MESHES
    return LLOAD(depth_lane) * surfaces_transmittance(geometry, p, dir, t_max, lanes);
#else
    return LLOAD(depth_lane);
#endif
}

/* Transmittance from p to the light. */
static inline lfloat shadow_ray(VOLUME_DATA_PARAM, const SceneRefs* scene, const ShadowRayGeometry* geometry,
                                __global const LightGpu* light, lfloat3 p, lmask lanes) {
    lfloat3 dir;
    lfloat t_max;
    ray_to_light(light, p, &dir, &t_max);
    return segment_transmittance(volume_data, scene, geometry, p, dir, t_max, lanes);
}
#endif
