/* sombra — camera pass: ray casting through homogeneous segments, classification, gradient,
 * Phong, front-to-back compositing (Knecht Eq. 3.10–3.11), early ray termination. A work-item
 * renders SOMBRA_LANES neighbouring pixels of one row as a packet (lanes.h).
 * Defines: SOMBRA_LANES (1 on GPUs, 8 or 16 on CPUs), SOMBRA_VOLUME_SLOTS (volumes in the scene),
 * SOMBRA_USE_IMAGES (3D image atlas instead of a buffer), SOMBRA_SOBEL (Sobel gradients),
 * SOMBRA_SKIP_EMPTY (brick skipping), SOMBRA_HAS_LIGHTS (any light in the scene),
 * SOMBRA_SHADOW_RAYS (shadow term by marching towards each light), SOMBRA_SHADOW_DSM (shadow term
 * from deep shadow maps), SOMBRA_SHADOW_BINARY (with SOMBRA_SHADOW_DSM: binary shadow maps),
 * SOMBRA_SHADOW_LOWPASS (low-pass filtered shadows from light-aligned summed-area tables; with
 * SOMBRA_LOWPASS_GAUSS Gaussian filtered; with SOMBRA_LOWPASS_AO or SOMBRA_LOWPASS_CONE the SAT
 * ambient-occlusion or cone-shadow baselines on one volume-aligned table),
 * SOMBRA_LOWPASS_CACHED (with SOMBRA_SHADOW_LOWPASS: the shadow term read from the shadow cache),
 * SOMBRA_HAS_MESHES (per-pixel fragment lists of surfaces and polyhedral volume bounds merged
 * into the segment cursor's boundaries, traversal.h; surfaces composited at their depth:
 * surfaces.h; with SOMBRA_SHADOW_RAYS shadow rays also cross the mesh triangles),
 * SOMBRA_HAS_BOUNDS (with SOMBRA_SHADOW_RAYS: some volume has a polyhedral bound, whose triangles
 * shadow rays cross; the other passes see the bounds as fragments). */
#include "shared/types.h"
#include "shared/hash.h"
#include "lanes.h"
#include "volume_sample.h"
#include "shading.h"
#include "traversal.h"
#ifdef SOMBRA_SHADOW_DSM
#include "dsm_view.h"
#include "dsm_storage.h"
#endif
#ifdef SOMBRA_SHADOW_LOWPASS
#include "lowpass.h"
#ifdef SOMBRA_LOWPASS_CACHED
#define LOWPASS_PARAMS , __global const ulong* sat, __global const SatGridGpu* sat_grids, __global const SsatGridGpu* ssat_grids, \
                         __global const float* shadow_cache, __global const ShadowCacheGpu* shadow_cache_table
#else
#define LOWPASS_PARAMS , __global const ulong* sat, __global const SatGridGpu* sat_grids, __global const SsatGridGpu* ssat_grids
#endif
#else
#define LOWPASS_PARAMS
#endif
#if defined(SOMBRA_SHADOW_RAYS) && defined(SOMBRA_HAS_MESHES)
#define SOMBRA_SHADOW_RAY_MESHES /* shadow rays are attenuated by the world-space triangles */
#define SHADOW_MESH_PARAMS , __global const SurfaceTriangleGpu *shadow_triangles, __global const BvhNodeGpu *shadow_bvh, \
                           uint shadow_bvh_nodes
#define SHADOW_MESH_STATE_INIT(s) \
    (s).shadow_triangles = shadow_triangles, (s).shadow_bvh = shadow_bvh, (s).shadow_bvh_nodes = shadow_bvh_nodes;
#else
#define SHADOW_MESH_PARAMS
#define SHADOW_MESH_STATE_INIT(s)
#endif
#ifdef SOMBRA_HAS_BOUNDS
/* every volume's bound triangles in BVH order (corner.w: the volume) and the hierarchy's nodes */
#define BOUND_PARAMS , __global const SurfaceTriangleGpu *bound_triangles, __global const BvhNodeGpu *bound_bvh, uint bound_bvh_nodes
#define BOUND_STATE_INIT(s) (s).bound_triangles = bound_triangles, (s).bound_bvh = bound_bvh, (s).bound_bvh_nodes = bound_bvh_nodes;
#else
#define BOUND_PARAMS
#define BOUND_STATE_INIT(s)
#endif

/* What every sample of the camera pass reads and accumulates. */
typedef struct {
    lfloat3 radiance;      /* I_acc */
    lfloat transmittance;  /* t_acc */
    luint samples;
    lfloat3 to_viewer;
    lfloat jitter;
    __global const CameraGpu* camera;
    __global const LightGpu* lights;
    __global const VolumeGpu* volumes;
    __global const float* tf_tables;
    __global const uchar* occupancy;
#ifdef SOMBRA_SHADOW_DSM
    __global const DsmViewGpu* views;
    DSM_READ_STATE_FIELDS
#ifdef DSM_HAS_SEARCH_HINTS
    DsmSearchHint hints[SOMBRA_LIGHT_SLOTS * 4]; /* per light and bilinear corner: the last node found */
#endif
#endif
#ifdef SOMBRA_SHADOW_LOWPASS
    __global const ulong* sat;
    __global const SatGridGpu* sat_grids;
    __global const SsatGridGpu* ssat_grids;
#ifdef SOMBRA_LOWPASS_CACHED
    __global const float* shadow_cache;
    __global const ShadowCacheGpu* shadow_cache_table;
#endif
#endif
#ifdef SOMBRA_SHADOW_RAY_MESHES
    __global const SurfaceTriangleGpu* shadow_triangles; /* every mesh triangle in BVH order, corner.w = opacity */
    __global const BvhNodeGpu* shadow_bvh;               /* the hierarchy over them (src/render/bvh.h) */
    uint shadow_bvh_nodes;
#endif
#ifdef SOMBRA_HAS_BOUNDS
    __global const SurfaceTriangleGpu* bound_triangles; /* every volume's bound in BVH order, corner.w = the volume */
    __global const BvhNodeGpu* bound_bvh;
    uint bound_bvh_nodes;
#endif
} CameraState;

#ifdef SOMBRA_SHADOW_RAY_MESHES
/* Transmittance of the surfaces on the segment p + t·dir, 0 < t < t_max (|dir| = 1): Π(1 − a) over
 * every triangle it crosses (a: the mesh's opacity, corner.w), Möller–Trumbore on the triangles of
 * the BVH leaves the packet's rays cross (cl/bvh.h); lanes whose transmittance reached 0 drop out.
 * A ray in a triangle's plane (|det| ≤ 10⁻⁷ of |e1 × e2|) and a degenerate triangle (e1 × e2 = 0)
 * cross nothing: no division by zero, no NaN. */
inline lfloat surfaces_transmittance(const CameraState* state, lfloat3 p, lfloat3 dir, lfloat t_max, lmask lanes) {
    lfloat result = (lfloat)(1.0f);
    BvhWalk walk;
    bvh_walk_init(&walk, state->shadow_bvh_nodes);
    uint first, count;
    while (bvh_walk_next(&walk, state->shadow_bvh, p, dir, (lfloat)(0.0f), t_max, lanes & (result > 0.0f), &first, &count)) {
        for (uint i = first; i < first + count; ++i) {
            __global const SurfaceTriangleGpu* tri = &state->shadow_triangles[i];
            lfloat t = ray_triangle_t(p, dir, tri->corner.xyz, tri->corner1.xyz, tri->corner2.xyz, lanes);
            result = select(result, result * (1.0f - tri->corner.w), (t > 0.0f) & (t < t_max));
        }
    }
    return result;
}
#endif

#if defined(SOMBRA_SHADOW_RAYS) || defined(SOMBRA_SHADOW_LOWPASS)
/* Shadow-ray baseline: transmittance exp(−∫σ) from p to the light, marched over the same
 * segments as the camera rays, each interval pre-integrated and of its exact length (traversal.h),
 * stopping once it falls below 10⁻⁶ (course slides: shadow rays);
 * with meshes, times Π(1 − a) of the triangles crossed (surfaces_transmittance). */
inline lfloat shadow_ray(VOLUME_DATA_PARAM, const CameraState* state, __global const LightGpu* light, lfloat3 p,
                         lmask lanes) {
    lfloat3 dir;
    lfloat t_max;
    if (light->type == SOMBRA_LIGHT_DIRECTIONAL) {
        dir = l3_splat(-light->direction.xyz);
        t_max = (lfloat)(INFINITY);
    } else {
        lfloat3 d = l3_sub(l3_splat(light->position.xyz), p);
        t_max = sqrt(l3_dot(d, d));
        dir = l3_scale(d, 1.0f / fmax(t_max, 1e-30f));
    }
    VolumeRay ray;
    make_volume_ray(&ray, state->volumes, state->camera->volume_count, p, dir, (lfloat)(0.0f), t_max);
    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, state->camera->volume_count, state->jitter, lanes);
#ifdef SOMBRA_HAS_BOUNDS /* polyhedral bounds: their crossings along the ray are segment boundaries */
    segment_cursor_use_bound_triangles(&cursor, &ray, state->volumes, state->camera->volume_count, state->bound_triangles,
                                       state->bound_bvh, state->bound_bvh_nodes, t_max, lanes);
#endif
    lfloat optical_depth = (lfloat)(0.0f);
    lfloat front[SOMBRA_VOLUME_SLOTS]; /* each volume's density at the previous point */
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) front[i] = (lfloat)(0.0f);
    lmask sampling;
    while (lany(sampling = segment_cursor_next(&cursor, &ray, state->volumes, state->camera->volume_count, state->occupancy))) {
        lfloat t = select((lfloat)(0.0f), cursor.t, sampling); /* finite positions in idle lanes */
        optical_depth += interval_optical_depth(volume_data, state->volumes, state->tf_tables, &ray, &cursor, t, front, sampling);
        cursor.alive &= !(optical_depth > 13.8155f); /* exp(−13.8) = 10⁻⁶ */
    }
    /* scalar exp per lane: the same bits as 1 lane (PoCL's vector exp may differ in the last bit) */
    float depth_lane[SOMBRA_LANES];
    LSTORE(optical_depth, depth_lane);
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) depth_lane[lane] = exp(-depth_lane[lane]);
#ifdef SOMBRA_SHADOW_RAY_MESHES
    return LLOAD(depth_lane) * surfaces_transmittance(state, p, dir, t_max, lanes);
#else
    return LLOAD(depth_lane);
#endif
}
#endif

#ifdef SOMBRA_SHADOW_LOWPASS
#ifdef SOMBRA_LOWPASS_CONE
/* Cone shadows towards one light from world point p (the cone's axis: to the light). */
inline float cone_lane(__global const ulong* sat, __global const SatGridGpu* g, __global const LightGpu* light,
                       bool directional, float3 p) {
    float3 to_light = directional ? -light->direction.xyz : light->position.xyz - p;
    float reach = directional ? INFINITY : length(to_light);
    return sat_cone_depth(sat, g, p, to_light / fmax(length(to_light), 1e-30f), reach);
}
#endif

/* Low-pass filtered shadow: exp(−τ̄) with τ̄ the box-filtered optical depth from the light's CSAT
 * (directional lights, Ament Eq. 4, 13, 15) or SSAT (point and spot lights, Eq. 24). A light
 * without a table falls back to the shadow ray. */
inline lfloat lowpass_shadow(VOLUME_DATA_PARAM, const CameraState* state, uint light_index, lfloat3 p, lmask lanes) {
    __global const SatGridGpu* g = &state->sat_grids[light_index];
    __global const SsatGridGpu* sphere = &state->ssat_grids[light_index];
    lfloat depth;
#if defined(SOMBRA_LOWPASS_AO)
#define SOMBRA_LOWPASS_LANE(c) sat_ambient_depth(state->sat, g, (float3)(LC(p.x, c), LC(p.y, c), LC(p.z, c)))
    depth = LFROM_LANES(SOMBRA_LOWPASS_LANE);
#undef SOMBRA_LOWPASS_LANE
#elif defined(SOMBRA_LOWPASS_CONE)
    __global const LightGpu* light = &state->lights[light_index];
    bool directional = light->type == SOMBRA_LIGHT_DIRECTIONAL;
#define SOMBRA_CONE_LANE(c) cone_lane(state->sat, g, light, directional, (float3)(LC(p.x, c), LC(p.y, c), LC(p.z, c)))
    depth = LFROM_LANES(SOMBRA_CONE_LANE);
#undef SOMBRA_CONE_LANE
#else
    if (g->dims.w != 0) {
#define SOMBRA_LOWPASS_LANE(c) csat_filtered_depth(state->sat, g, (float3)(LC(p.x, c), LC(p.y, c), LC(p.z, c)))
        depth = LFROM_LANES(SOMBRA_LOWPASS_LANE);
#undef SOMBRA_LOWPASS_LANE
    } else if (sphere->dims.w != 0) {
#define SOMBRA_LOWPASS_LANE(c) ssat_filtered_depth(state->sat, sphere, (float3)(LC(p.x, c), LC(p.y, c), LC(p.z, c)))
        depth = LFROM_LANES(SOMBRA_LOWPASS_LANE);
#undef SOMBRA_LOWPASS_LANE
    } else {
        return shadow_ray(volume_data, state, &state->lights[light_index], p, lanes);
    }
#endif
    return exp(-depth);
}
#endif

#ifdef SOMBRA_SHADOW_DSM
/* α of one texel at depth z: V'(z) (Knecht Eq. 3.7), or with SOMBRA_SHADOW_BINARY the binary
 * shadow-map baseline: fully shadowed behind the depth where the texel's opacity reaches 1/2
 * (the depth a classic shadow map stores), lit before it. */
#ifdef DSM_HAS_SEARCH_HINTS
#define DSM_HINT_PARAM , DsmSearchHint* hint
#define DSM_HINT_ARG(h) , (h)
#define DSM_TEXEL_OPACITY(v, x, y, z) dsm_texel_opacity_hinted(DSM_READ_ARGS, v, x, y, z, hint)
#else
#define DSM_HINT_PARAM
#define DSM_HINT_ARG(h)
#define DSM_TEXEL_OPACITY(v, x, y, z) dsm_texel_opacity(DSM_READ_ARGS, v, x, y, z)
#endif
inline lfloat texel_attenuation(DSM_READ_PARAMS, __global const DsmViewGpu* v, lint x, lint y, lfloat z DSM_HINT_PARAM) {
    lfloat alpha = DSM_TEXEL_OPACITY(v, x, y, z);
#ifdef SOMBRA_SHADOW_BINARY
    alpha = select((lfloat)(0.0f), (lfloat)(1.0f), alpha >= 0.5f);
#endif
    return alpha;
}

inline void init_search_hints(CameraState* state) {
#ifdef DSM_HAS_SEARCH_HINTS
    for (int i = 0; i < SOMBRA_LIGHT_SLOTS * 4; ++i) state->hints[i].texel = (lint)(-1);
#endif
}

/* Transmittance 1 − α to the light from its deep shadow maps: the view that covers p (a point
 * light's cube face, found by projection), V'(depth) of the four nearest texels filtered
 * bilinearly (Knecht Eq. 3.7, 4.18–4.19). Points no view covers are lit. */
inline lfloat dsm_shadow(CameraState* state, uint light_index, lfloat3 p, lmask lanes) {
    __global const LightGpu* light = &state->lights[light_index];
#ifdef DSM_HAS_SEARCH_HINTS
    DsmSearchHint* hints = &state->hints[4 * light_index];
#endif
    lfloat alpha = (lfloat)(0.0f);
    lmask done = !lanes;
    for (uint i = 0; i < light->view_count; ++i) {
        __global const DsmViewGpu* v = &state->views[light->view_first + i];
        lfloat u, w, depth;
        lmask covered = dsm_view_project(v, p, &u, &w, &depth) & !done;
        if (!lany(covered)) continue;
        u = select((lfloat)(0.0f), u, covered); /* finite texel indices in every lane */
        w = select((lfloat)(0.0f), w, covered);
        lfloat u0 = floor(u), w0 = floor(w), fu = u - u0, fw = w - w0;
        int last = (int)v->resolution - 1;
        lint x0 = clamp(LCONVERT_INT(u0), 0, last), x1 = clamp(LCONVERT_INT(u0) + 1, 0, last);
        lint y0 = clamp(LCONVERT_INT(w0), 0, last), y1 = clamp(LCONVERT_INT(w0) + 1, 0, last);
        lfloat a00 = texel_attenuation(DSM_READ_ARGS_OF(state), v, x0, y0, depth DSM_HINT_ARG(&hints[0]));
        lfloat a10 = texel_attenuation(DSM_READ_ARGS_OF(state), v, x1, y0, depth DSM_HINT_ARG(&hints[1]));
        lfloat a01 = texel_attenuation(DSM_READ_ARGS_OF(state), v, x0, y1, depth DSM_HINT_ARG(&hints[2]));
        lfloat a11 = texel_attenuation(DSM_READ_ARGS_OF(state), v, x1, y1, depth DSM_HINT_ARG(&hints[3]));
        alpha = select(alpha, mix(mix(a00, a10, fu), mix(a01, a11, fu), fw), covered);
        done |= covered;
    }
    return 1.0f - alpha;
}
#endif

#if defined(SOMBRA_SHADOW_RAYS) || defined(SOMBRA_SHADOW_DSM) || defined(SOMBRA_SHADOW_LOWPASS)
/* Transmittance from p to light m by the technique the program was built for: volume samples and
 * surface fragments (surfaces.h) read the same shadow term. */
inline lfloat light_transmittance(VOLUME_DATA_PARAM, CameraState* state, uint m, lfloat3 p, lmask lanes) {
#if defined(SOMBRA_SHADOW_LOWPASS)
    return lowpass_shadow(volume_data, state, m, p, lanes);
#elif defined(SOMBRA_SHADOW_RAYS)
    return shadow_ray(volume_data, state, &state->lights[m], p, lanes);
#else
    return dsm_shadow(state, m, p, lanes);
#endif
}
#endif

#ifdef SOMBRA_LOWPASS_CACHED
/* The shadow term of light m at voxel point pv of volume i, read trilinearly from the shadow
 * cache (Ament Alg. 1, second pass) instead of evaluating the SATs per sample. */
inline lfloat cached_shadow(const CameraState* state, uint i, uint m, lfloat3 pv) {
    __global const ShadowCacheGpu* c = &state->shadow_cache_table[i * state->camera->light_count + m];
    lfloat qx = clamp(pv.x / c->spacing.x, 0.0f, (float)(c->dims.x - 1));
    lfloat qy = clamp(pv.y / c->spacing.y, 0.0f, (float)(c->dims.y - 1));
    lfloat qz = clamp(pv.z / c->spacing.z, 0.0f, (float)(c->dims.z - 1));
    lfloat bx = floor(qx), by = floor(qy), bz = floor(qz);
    lfloat fx = qx - bx, fy = qy - by, fz = qz - bz;
    lint x0 = LCONVERT_INT(bx), y0 = LCONVERT_INT(by), z0 = LCONVERT_INT(bz);
    lint x1 = min(x0 + 1, c->dims.x - 1), y1 = min(y0 + 1, c->dims.y - 1), z1 = min(z0 + 1, c->dims.z - 1);
    int sy = c->dims.x, sz = c->dims.x * c->dims.y, base = (int)c->offset;
#define CACHE_AT(x, y, z) gather(state->shadow_cache, base + (x) + (y) * sy + (z) * sz)
    lfloat c00 = mix(CACHE_AT(x0, y0, z0), CACHE_AT(x1, y0, z0), fx), c10 = mix(CACHE_AT(x0, y1, z0), CACHE_AT(x1, y1, z0), fx);
    lfloat c01 = mix(CACHE_AT(x0, y0, z1), CACHE_AT(x1, y0, z1), fx), c11 = mix(CACHE_AT(x0, y1, z1), CACHE_AT(x1, y1, z1), fx);
#undef CACHE_AT
    return mix(mix(c00, c10, fy), mix(c01, c11, fy), fz);
}
#endif

/* One point of all active volumes, closing the interval [t − delta, t] (traversal.h): the
 * interval's opacity α = 1 − exp(−Σ σ̄ᵢ·delta) from each volume's pre-integrated extinction σ̄ᵢ,
 * the colours shaded at t blended by σ̄ᵢ, then I_acc += I_p α t_acc; t_acc *= 1 − α (Knecht Eq.
 * 3.10–3.11). front[i]: volume i's density at the previous point. Returns the lanes whose ray
 * goes on (early ray termination). */
inline lmask shade_sample(VOLUME_DATA_PARAM, CameraState* state, const VolumeRay* ray, const SegmentCursor* cursor,
                          lfloat* front, lmask sampling) {
    lfloat t = select((lfloat)(0.0f), cursor->t, sampling); /* finite positions in idle lanes */
    lfloat3 p = l3_mad(ray->dir, t, ray->origin);
    lfloat sigma_sum = (lfloat)(0.0f);
    lfloat3 color_sum = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    uint light_count = state->camera->light_count;
    lfloat shadow[SOMBRA_LIGHT_SLOTS]; /* transmittance to each light, found once per sample */
    for (uint m = 0; m < light_count; ++m) shadow[m] = (lfloat)(1.0f);
    lmask shadows_known = (lmask)(0);
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) {
        lmask here = sampling & ((cursor->active & (1u << i)) != 0u);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &state->volumes[i];
        lfloat3 pv = ray_voxel_point(ray, i, t);
        lfloat density = sample_density(volume_data, v, pv);
        state->samples += select((luint)(0u), (luint)(1u), here);
        lfloat sigma = interval_sigma(state->tf_tables, v, density, &front[i], here);
        lmask visible = (sigma > 0.0f) & (cursor->delta > 0.0f) & !cursor->empty_interval;
        if (!lany(visible)) continue;
        Classified c = classify(state->tf_tables, v, density);
        lfloat3 normal = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
#if defined(SOMBRA_HAS_LIGHTS) && !defined(SOMBRA_SCATTERING)
        normal = normal_from_gradient(v, gradient_voxel(volume_data, v, pv));
#endif
#if defined(SOMBRA_SHADOW_RAYS) || defined(SOMBRA_SHADOW_DSM) || defined(SOMBRA_SHADOW_LOWPASS)
        lmask needed = visible & !shadows_known;
        if (lany(needed)) {
            for (uint m = 0; m < light_count; ++m) {
#ifdef SOMBRA_LOWPASS_CACHED
                lfloat transmittance_to_light = cached_shadow(state, i, m, pv);
#else
                lfloat transmittance_to_light = light_transmittance(volume_data, state, m, p, needed);
#endif
                shadow[m] = select(shadow[m], transmittance_to_light, needed);
            }
            shadows_known |= needed;
        }
#endif
#ifdef SOMBRA_SCATTERING
        lfloat3 shaded = scatter_shade(state->lights, light_count, state->camera->ambient_intensity, state->camera->phase_g, v,
                                       c.color, p, state->to_viewer, shadow);
#else
        lfloat3 shaded = phong_shade(state->lights, light_count, state->camera->ambient_intensity, v, c.color, p, normal,
                                     state->to_viewer, shadow);
#endif
        sigma = select((lfloat)(0.0f), sigma, visible);
        sigma_sum += sigma;
        color_sum = l3_mad(shaded, sigma, color_sum);
    }
    lmask lit = sigma_sum > 0.0f;
    lfloat alpha = 1.0f - exp(-sigma_sum * cursor->delta);
    lfloat weight = select((lfloat)(0.0f), alpha * state->transmittance / select((lfloat)(1.0f), sigma_sum, lit), lit);
    state->radiance = l3_mad(color_sum, weight, state->radiance);
    state->transmittance = select(state->transmittance, state->transmittance * (1.0f - alpha), lit);
    return state->transmittance > state->camera->termination_transmittance;
}

#ifdef SOMBRA_HAS_MESHES
#include "surfaces.h"
#endif

__kernel void render_camera(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                            __global const VolumeGpu* volumes, __global const LightGpu* lights,
                            __global const CameraGpu* camera, __global float4* image, __global uint* sample_counts
#ifdef SOMBRA_SHADOW_DSM
                            , __global const DsmViewGpu* views, DSM_READ_PARAMS
#endif
                            LOWPASS_PARAMS SHADOW_MESH_PARAMS BOUND_PARAMS
#ifdef SOMBRA_HAS_MESHES
                            , SURFACE_PARAMS
#endif
) {
    uint y = get_global_id(1);
    if (y >= camera->height) return;
    lint xs = (int)(get_global_id(0) * SOMBRA_LANES) + LANE_INDEX;
    lmask lanes = xs < (int)camera->width;

    /* pinhole camera through the pixel centres */
    lfloat sx = ((LCONVERT_FLOAT(xs) + 0.5f) / camera->width) * 2.0f - 1.0f;
    float sy = 1.0f - ((y + 0.5f) / camera->height) * 2.0f;
    float3 f = camera->forward.xyz + sy * camera->up.xyz, r = camera->right.xyz;
    lfloat3 dir = l3_normalize(l3(f.x + sx * r.x, f.y + sx * r.y, f.z + sx * r.z));

    VolumeRay ray;
    make_volume_ray(&ray, volumes, camera->volume_count, l3_splat(camera->position.xyz), dir, (lfloat)(0.0f),
                    (lfloat)(INFINITY));

    CameraState state;
    state.radiance = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    state.transmittance = (lfloat)(1.0f);
    state.samples = (luint)(0u);
    state.to_viewer = l3_scale(dir, (lfloat)(-1.0f));
    state.camera = camera;
    state.lights = lights;
    state.volumes = volumes;
    state.tf_tables = tf_tables;
    state.occupancy = occupancy;
#ifdef SOMBRA_SHADOW_DSM
    state.views = views;
    DSM_READ_STATE_INIT(state);
    init_search_hints(&state);
#endif
#ifdef SOMBRA_SHADOW_LOWPASS
    state.sat = sat;
    state.sat_grids = sat_grids;
    state.ssat_grids = ssat_grids;
#ifdef SOMBRA_LOWPASS_CACHED
    state.shadow_cache = shadow_cache;
    state.shadow_cache_table = shadow_cache_table;
#endif
#endif
    SHADOW_MESH_STATE_INIT(state)
    BOUND_STATE_INIT(state)
#define SOMBRA_JITTER_LANE(c) sombra_pixel_jitter((uint)LC(xs, c), y, camera->jitter_seed)
    state.jitter = LFROM_LANES(SOMBRA_JITTER_LANE);
#undef SOMBRA_JITTER_LANE

    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, camera->volume_count, state.jitter, lanes);
#ifdef SOMBRA_HAS_MESHES /* the pixel's fragments: surfaces and volume bounds are segment boundaries */
    uint pixel[SOMBRA_LANES];
    int x_lane[SOMBRA_LANES], in_lane[SOMBRA_LANES];
    LSTORE(xs, x_lane);
    LSTORE(lanes, in_lane);
    for (int c = 0; c < SOMBRA_LANES; ++c) pixel[c] = y * camera->width + (in_lane[c] ? (uint)x_lane[c] : 0u);
    segment_cursor_use_fragments(&cursor, volumes, camera->volume_count, fragment_first, fragments, screen_triangles, pixel, lanes);
#endif
    lfloat front[SOMBRA_VOLUME_SLOTS]; /* each volume's density at the previous point */
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) front[i] = (lfloat)(0.0f);
    lmask sampling;
    while (lany(sampling = segment_cursor_next(&cursor, &ray, volumes, camera->volume_count, occupancy))) {
#ifdef SOMBRA_HAS_MESHES /* a surface at a segment boundary, in depth order with the samples */
        if (lany(cursor.surface)) {
            composite_surface(volume_data, &state, &cursor, &ray, surface_triangles, surface_materials, cursor.surface);
            cursor.alive &= (state.transmittance > camera->termination_transmittance) | !cursor.surface;
            sampling &= !cursor.surface;
            if (!lany(sampling)) continue;
        }
#endif
        cursor.alive &= shade_sample(volume_data, &state, &ray, &cursor, front, sampling) | !sampling;
    }

    float red[SOMBRA_LANES], green[SOMBRA_LANES], blue[SOMBRA_LANES], transmittance[SOMBRA_LANES];
    uint samples[SOMBRA_LANES];
    LSTORE(mad(state.transmittance, camera->background.x, state.radiance.x), red);
    LSTORE(mad(state.transmittance, camera->background.y, state.radiance.y), green);
    LSTORE(mad(state.transmittance, camera->background.z, state.radiance.z), blue);
    LSTORE(state.transmittance, transmittance);
    LSTORE(state.samples, samples);
    uint x0 = get_global_id(0) * SOMBRA_LANES;
    for (uint lane = 0; lane < SOMBRA_LANES && x0 + lane < camera->width; ++lane) {
        size_t pixel = (size_t)y * camera->width + x0 + lane;
        image[pixel] = (float4)(red[lane], green[lane], blue[lane], 1.0f - transmittance[lane]);
        sample_counts[pixel] = samples[lane];
    }
}

#if (defined(SOMBRA_SHADOW_RAYS) || defined(SOMBRA_SHADOW_DSM) || defined(SOMBRA_SHADOW_LOWPASS)) && SOMBRA_LANES == 1
/* Transmittance to light `light_index` at arbitrary world points, by the technique this program
 * was built for (sombra visibility, tests). Built with SOMBRA_LANES=1. */
__kernel void shadow_probe(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                           __global const VolumeGpu* volumes, __global const LightGpu* lights,
                           __global const CameraGpu* camera, uint light_index, __global const float4* points,
                           __global float* transmittance
#ifdef SOMBRA_SHADOW_DSM
                           , __global const DsmViewGpu* views, DSM_READ_PARAMS
#endif
                           LOWPASS_PARAMS SHADOW_MESH_PARAMS BOUND_PARAMS
) {
    size_t i = get_global_id(0);
    CameraState state;
    state.camera = camera;
    state.lights = lights;
    state.volumes = volumes;
    state.tf_tables = tf_tables;
    state.occupancy = occupancy;
    state.jitter = sombra_pixel_jitter((uint)i, 0u, camera->jitter_seed);
    SHADOW_MESH_STATE_INIT(state)
    BOUND_STATE_INIT(state)
#ifdef SOMBRA_SHADOW_DSM
    state.views = views;
    DSM_READ_STATE_INIT(state);
    init_search_hints(&state);
    transmittance[i] = dsm_shadow(&state, light_index, l3(points[i].x, points[i].y, points[i].z), 1);
#elif defined(SOMBRA_SHADOW_LOWPASS)
    state.sat = sat;
    state.sat_grids = sat_grids;
    state.ssat_grids = ssat_grids;
    transmittance[i] = lowpass_shadow(volume_data, &state, light_index, l3(points[i].x, points[i].y, points[i].z), 1);
#else
    transmittance[i] = shadow_ray(volume_data, &state, &lights[light_index], l3(points[i].x, points[i].y, points[i].z), 1);
#endif
}
#endif
