/* sombra — camera pass: ray casting through homogeneous segments, classification, gradient,
 * Phong, front-to-back compositing (Knecht Eq. 3.10–3.11), early ray termination. A work-item
 * renders SOMBRA_LANES neighbouring pixels of one row as a packet (lanes.h). The shadow term of
 * each light comes from the program's shadow technique (techniques/technique.h), or, in a launch
 * with shadow_cache_reads set, from the shadow cache it filled.
 * Defines: SOMBRA_LANES (1 on GPUs, 8 or 16 on CPUs), SOMBRA_VOLUME_SLOTS (volumes in the scene),
 * SOMBRA_LIGHT_SLOTS (lights), SOMBRA_USE_IMAGES (3D image atlas instead of a buffer),
 * SOMBRA_SOBEL (Sobel gradients), SOMBRA_SKIP_EMPTY (brick skipping), SOMBRA_HAS_LIGHTS (any light
 * in the scene), SOMBRA_SCATTERING (single scattering instead of Phong), SOMBRA_TECHNIQUE_<NAME>
 * (the shadow technique and its own defines: src/techniques/), SOMBRA_SHADOW_CACHE_MARK (the visible
 * fill's marking pass: the cached pass's samples, marking the lattice cells they would read,
 * shading nothing), SOMBRA_HAS_MESHES (per-pixel fragment lists of surfaces and
 * polyhedral volume bounds merged into the segment cursor's boundaries, traversal.h; surfaces
 * composited at their depth: surfaces.h), SOMBRA_SURFACE_SHADOW_CACHE (surface fragments read the
 * shadow term from the surface shadow cache, surfaces.h). The host binds the kernels' arguments by these names
 * (src/host/kernel_args.h). */
#include "shared/types.h"
#include "shared/hash.h"
#include "lanes.h"
#include "volume_sample.h"
#include "shading.h"
#include "traversal.h"
#include "scene_refs.h"
#include "techniques/technique.h"
/* SOMBRA_SHADOW_CACHE: the camera pass can read the shadow cache — in every program whose technique
 * has a shadow term, chosen per launch by shadow_cache_reads, so that a frame evaluating per sample,
 * one reading the cache and auto's probe of both load one program — or mark it (the marking pass). */
#if defined(SOMBRA_SHADOW_CACHE_MARK) || SHADOW_TERM
#define SOMBRA_SHADOW_CACHE
#endif
#ifdef SOMBRA_SHADOW_CACHE_MARK
#define SHADOW_CACHE_PARAMS , __global uint *shadow_cache_marks, __global const ShadowCacheGpu *shadow_cache_table
#elif defined(SOMBRA_SHADOW_CACHE)
#define SHADOW_CACHE_PARAMS , __global const float *shadow_cache, __global const ShadowCacheGpu *shadow_cache_table, uint shadow_cache_reads
#else
#define SHADOW_CACHE_PARAMS
#endif
#ifdef SOMBRA_SURFACE_SHADOW_CACHE
#define SURFACE_SHADOW_CACHE_PARAMS , __global const float *surface_shadow_cache, __global const uint *surface_cache_triangles
#else
#define SURFACE_SHADOW_CACHE_PARAMS
#endif

/* What every sample of the camera pass reads and accumulates. */
typedef struct {
    lfloat3 radiance;      /* I_acc */
    lfloat transmittance;  /* t_acc */
    luint samples;
    lfloat3 to_viewer;
    SceneRefs scene;
    ShadowState shadow;
#ifdef SOMBRA_SHADOW_CACHE
    __global const ShadowCacheGpu* shadow_cache_table;
#ifdef SOMBRA_SHADOW_CACHE_MARK
    __global uint* shadow_cache_marks;
    uint last_mark_word[SOMBRA_LIGHT_SLOTS][SOMBRA_LANES], last_mark_bit[SOMBRA_LIGHT_SLOTS][SOMBRA_LANES]; /* per light and lane */
#else
    __global const float* shadow_cache;
    uint shadow_cache_reads; /* 1: the shadow term read from shadow_cache; 0: evaluated per sample */
#endif
#endif
#ifdef SOMBRA_SURFACE_SHADOW_CACHE
    __global const float* surface_shadow_cache;  /* point · light_count + light */
    __global const uint* surface_cache_triangles; /* per source triangle: first point, subdivision k */
#endif
} CameraState;

#if SHADOW_TERM
/* Transmittance from p to light m by the program's technique: volume samples and surface
 * fragments (surfaces.h) read the same shadow term. */
static inline lfloat light_transmittance(VOLUME_DATA_PARAM, CameraState* state, uint m, lfloat3 p, lmask lanes) {
    return shadow_transmittance(volume_data, &state->scene, &state->shadow, m, p, lanes);
}
#endif

/* dot(row, (pv, 1)): a row of an affine map (ShadowCacheGpu.voxel_to_lattice, voxel_to_world). */
static inline lfloat lattice_row(float4 row, lfloat3 pv) { return mad(pv.x, row.x, mad(pv.y, row.y, mad(pv.z, row.z, row.w))); }

#ifdef SOMBRA_SHADOW_CACHE
/* The lattice cell of cache entry c around voxel point pv: its first corner and the trilinear
 * weights of the far corners (the cached read's, and the marking pass's). */
typedef struct {
    lint x0, y0, z0;
    lfloat fx, fy, fz;
} LatticeCell;

static inline LatticeCell lattice_cell(__global const ShadowCacheGpu* c, lfloat3 pv) {
    /* ShadowCacheGpu.voxel_to_lattice: w is 1 but in a point light's lattice */
    const lfloat inv_w = 1.0f / lattice_row(c->voxel_to_lattice[3], pv);
    lfloat qx = clamp_index(lattice_row(c->voxel_to_lattice[0], pv) * inv_w, (float)(c->dims.x - 1));
    lfloat qy = clamp_index(lattice_row(c->voxel_to_lattice[1], pv) * inv_w, (float)(c->dims.y - 1));
    lfloat qz = clamp_index(lattice_row(c->voxel_to_lattice[2], pv), (float)(c->dims.z - 1));
    lfloat bx = floor(qx), by = floor(qy), bz = floor(qz);
    LatticeCell cell = {LCONVERT_INT(bx), LCONVERT_INT(by), LCONVERT_INT(bz), qx - bx, qy - by, qz - bz};
    return cell;
}

#ifdef SOMBRA_SHADOW_CACHE_MARK
/* The marking pass of the visible fill: sets the bit of the cell (its first corner) whose points a
 * cached read of light m at voxel point pv of volume i interpolates, in the lanes `needed`;
 * shadow_cache_need adds the cell's other corners. A lane skips the cell it marked last for m. */
static inline void mark_cached_cell(CameraState* state, uint i, uint m, lfloat3 pv, lmask needed) {
    __global const ShadowCacheGpu* c = &state->shadow_cache_table[i * state->scene.camera->light_count + m];
    LatticeCell cell = lattice_cell(c, pv);
    int x0[SOMBRA_LANES], row[SOMBRA_LANES], on[SOMBRA_LANES];
    LSTORE(cell.x0, x0);
    LSTORE(cell.z0 * c->dims.y + cell.y0, row);
    LSTORE(needed, on);
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
        if (!on[lane]) continue;
        uint word = c->mark_offset + (uint)row[lane] * c->mark_row_words + (uint)x0[lane] / 32u, bit = 1u << ((uint)x0[lane] % 32u);
        if (word == state->last_mark_word[m][lane] && bit == state->last_mark_bit[m][lane]) continue;
        state->last_mark_word[m][lane] = word, state->last_mark_bit[m][lane] = bit;
        atomic_or(&state->shadow_cache_marks[word], bit);
    }
}
#else
/* The shadow term of light m at voxel point pv of volume i, read trilinearly from the shadow
 * cache (Ament Alg. 1, second pass) instead of evaluating the technique per sample. */
static inline lfloat cached_shadow(const CameraState* state, uint i, uint m, lfloat3 pv) {
    __global const ShadowCacheGpu* c = &state->shadow_cache_table[i * state->scene.camera->light_count + m];
    LatticeCell cell = lattice_cell(c, pv);
    lint x0 = cell.x0, y0 = cell.y0, z0 = cell.z0;
    lfloat fx = cell.fx, fy = cell.fy, fz = cell.fz;
    lint x1 = lmin(x0 + 1, c->dims.x - 1), y1 = lmin(y0 + 1, c->dims.y - 1), z1 = lmin(z0 + 1, c->dims.z - 1);
    int sy = c->dims.x, sz = c->dims.x * c->dims.y, base = (int)c->offset;
#define CACHE_AT(x, y, z) gather(state->shadow_cache, base + (x) + (y) * sy + (z) * sz)
    lfloat c00 = mix(CACHE_AT(x0, y0, z0), CACHE_AT(x1, y0, z0), fx), c10 = mix(CACHE_AT(x0, y1, z0), CACHE_AT(x1, y1, z0), fx);
    lfloat c01 = mix(CACHE_AT(x0, y0, z1), CACHE_AT(x1, y0, z1), fx), c11 = mix(CACHE_AT(x0, y1, z1), CACHE_AT(x1, y1, z1), fx);
#undef CACHE_AT
    return mix(mix(c00, c10, fy), mix(c01, c11, fy), fz);
}
#endif
#endif

/* One point of all active volumes, closing the interval [t − delta, t] (traversal.h): the
 * interval's opacity α = 1 − exp(−Σ σ̄ᵢ·delta) from each volume's pre-integrated extinction σ̄ᵢ,
 * the colours shaded at t blended by σ̄ᵢ, then I_acc += I_p α t_acc; t_acc *= 1 − α (Knecht Eq.
 * 3.10–3.11). The light term of I_p (incidence, phase, shadow) is taken at the interval's
 * midpoint t − delta/2: the in-scattered light ∫ σ e^(−σ(s−t₀)) L(s) ds / α weights L about the
 * midpoint (its centroid is t₀ + delta/2 − σ·delta²/12 + …), so the quadrature's error is of
 * second order in the step; at t it was first order, every shadowed image ≈ 0.4 % too dark at
 * the default step (docs/shadows.md "In-scattering quadrature"). front[i]: volume i's density at
 * the previous point. Returns the lanes whose ray goes on (early ray termination). */
static inline lmask shade_sample(VOLUME_DATA_PARAM, CameraState* state, const VolumeRay* ray, const SegmentCursor* cursor,
                          lfloat* front, lmask sampling) {
    lfloat t = select((lfloat)(0.0f), cursor->t, sampling); /* finite positions in idle lanes */
    lfloat t_light = t - select((lfloat)(0.0f), 0.5f * cursor->delta, sampling); /* the interval's midpoint */
    lfloat3 p_light = l3_mad(ray->dir, t_light, ray->origin);
    lfloat sigma_sum = (lfloat)(0.0f);
    lfloat3 color_sum = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    uint light_count = state->scene.camera->light_count;
    lfloat shadow[SOMBRA_LIGHT_SLOTS]; /* transmittance to each light, found once per sample */
    lmask shadow_known[SOMBRA_LIGHT_SLOTS];
    for (uint m = 0; m < light_count; ++m) shadow[m] = (lfloat)(1.0f), shadow_known[m] = (lmask)(0);
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) {
        lmask here = sampling & ((cursor->active & (1u << i)) != 0u);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &state->scene.volumes[i];
        lfloat3 pv = ray_voxel_point(ray, i, t);
        lfloat density = sample_density(volume_data, v, pv);
        state->samples += select((luint)(0u), (luint)(1u), here);
        const lfloat front_density = front[i];
        lfloat sigma = interval_sigma(state->scene.tf_tables, v, density, &front[i], here);
        lmask interval = here & (cursor->delta > 0.0f) & !cursor->empty_interval;
        if (v->stiff && lany(interval)) {
            /* a stiff volume's interval in pieces split at the voxel-centre planes, as the light
             * passes integrate it (traversal.h): its opacity no longer depends on the step */
            lfloat depth = split_interval_depth(volume_data, v, state->scene.tf_tables, ray, i, t - cursor->delta, t, front_density,
                                                density, interval);
            sigma = select(sigma, depth / select((lfloat)(1.0f), cursor->delta, interval), interval);
        }
        lmask visible = (sigma > 0.0f) & interval;
        if (!lany(visible)) continue;
#ifndef SOMBRA_SHADOW_CACHE_MARK
        Classified c = classify(state->scene.tf_tables, v, density);
#endif
#ifndef SOMBRA_SCATTERING /* scattering shades without normals */
        lfloat3 normal = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
#ifdef SOMBRA_HAS_LIGHTS
        normal = normal_from_gradient(v, gradient_voxel(volume_data, v, pv));
#endif
#endif
#if SHADOW_TERM
#ifdef SOMBRA_SCATTERING
        lfloat3 facing = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
#else
        lfloat3 facing = normal_facing_viewer(normal, state->to_viewer);
#endif
        for (uint m = 0; m < light_count; ++m) {
            /* only where the light's term can be non-zero (shading.h): a light behind the
             * sample's lit side costs no shadow lookup */
            lmask needed = visible & !shadow_known[m];
            if (!lany(needed)) continue;
            needed &= light_term_possible(&state->scene.lights[m], p_light, facing);
            if (!lany(needed)) continue;
#ifdef SOMBRA_SHADOW_CACHE_MARK /* the lookups the cached pass makes, marked */
            mark_cached_cell(state, i, m, ray_voxel_point(ray, i, t_light), needed);
            lfloat transmittance_to_light = (lfloat)(1.0f);
#else
            lfloat transmittance_to_light;
            if (state->shadow_cache_reads)
                transmittance_to_light = cached_shadow(state, i, m, ray_voxel_point(ray, i, t_light));
            else
                transmittance_to_light = light_transmittance(volume_data, state, m, p_light, needed);
#endif
            shadow[m] = select(shadow[m], transmittance_to_light, needed);
            shadow_known[m] |= needed;
        }
#endif
#ifdef SOMBRA_SHADOW_CACHE_MARK /* no shading: the samples and their opacity only */
        sigma_sum += select((lfloat)(0.0f), sigma, visible);
#else
#ifdef SOMBRA_SCATTERING
        lfloat3 shaded = scatter_shade(state->scene.lights, light_count, state->scene.camera->ambient_intensity, state->scene.camera->phase_g, v,
                                       c.color, p_light, state->to_viewer, shadow);
#else
        lfloat3 shaded = phong_shade(state->scene.lights, light_count, state->scene.camera->ambient_intensity, v, c.color, p_light, normal,
                                     state->to_viewer, shadow);
#endif
        sigma = select((lfloat)(0.0f), sigma, visible);
        sigma_sum += sigma;
        color_sum = l3_mad(shaded, sigma, color_sum);
#endif
    }
    lmask lit = sigma_sum > 0.0f;
    lfloat alpha = 1.0f - exp(-sigma_sum * cursor->delta);
    lfloat weight = select((lfloat)(0.0f), alpha * state->transmittance / select((lfloat)(1.0f), sigma_sum, lit), lit);
    state->radiance = l3_mad(color_sum, weight, state->radiance);
    state->transmittance = select(state->transmittance, state->transmittance * (1.0f - alpha), lit);
    return state->transmittance > state->scene.camera->termination_transmittance;
}

#ifdef SOMBRA_HAS_MESHES
#include "surfaces.h"
#endif

/* The launch row a work-item renders, its launch's rows of work-groups interleaved `ways` ways: the
 * groups' p-th row renders launch group row (p − start(r)) · ways + r, residue r taking the
 * positions from start(r) on (residue 0 first, each in order). A CPU device (PoCL) hands each of
 * its threads a contiguous run of a launch's groups, often half of those left: in order, each
 * thread rendered one strip of a band of rows, and the one with the denser strip kept the other
 * waiting (the smoke's cone at 128²: 446–459 ms in bands, 341–350 in one launch); interleaved by
 * the threads, each run spans the band, its groups `ways` rows apart (bench/README.md
 * "sombra_bench_tiles"). ways = 1 (GPUs): the launch's order. */
#define kInterleavedGroups 64u /* PoCL's runs: up to 64 groups, or half of those left */
static inline uint interleaved_launch_row(uint ways) {
    /* the band's first row: the launch's global offset (get_global_offset is missing from libclc's
     * PTX, tests/portability) */
    const uint group_rows = (uint)get_local_size(1), groups = (uint)get_num_groups(1), position = (uint)get_group_id(1);
    const uint first = (uint)get_global_id(1) - position * group_rows - (uint)get_local_id(1);
    /* a launch of more groups is handed out in runs of 64 as threads come free, which balances it;
     * interleaved, its neighbouring groups' shared reads were lost (teapot_fog's AO at 256²: +15 %) */
    if (groups * (uint)get_num_groups(0) > kInterleavedGroups * ways) ways = 1;
    uint residue = 0, start = 0;
    for (; residue + 1 < ways; ++residue) {
        const uint count = (groups - min(residue, groups) + ways - 1) / ways;  /* group rows ≡ residue (mod ways) */
        if (position < start + count) break;
        start += count;
    }
    return first + ((position - start) * ways + residue) * group_rows + (uint)get_local_id(1);
}

__kernel void render_camera(SCENE_PARAMS, __global float4* image, __global uint* sample_counts, uint row_interleave,
                            uint write_image_rows, __global const uint* rendered_packets, uint skip_rendered SHADOW_PARAMS
                            SHADOW_CACHE_PARAMS SURFACE_SHADOW_CACHE_PARAMS
#ifdef SOMBRA_HAS_MESHES
                            , SURFACE_PARAMS
#endif
) {
    /* the launch's row; y: the image's (CameraGpu first_row, row_stride) */
    uint row = interleaved_launch_row(max(row_interleave, 1u));
    uint y = camera->first_row + row * camera->row_stride;
    if (y >= camera->height) return;
    uint packet_stride = max(camera->packet_stride, 1u); /* the image's packet (CameraGpu packet_stride) */
    uint x0 = (uint)(get_global_id(0) * packet_stride + (camera->first_packet + row) % packet_stride) * SOMBRA_LANES;
    /* a packet auto's probe already rendered into the frame's image (CameraPassReads.rendered_packets:
     * a bit per packet, image row · packets per row + packet) keeps its pixels */
    uint packet = y * ((camera->width + SOMBRA_LANES - 1) / SOMBRA_LANES) + x0 / SOMBRA_LANES;
    if (skip_rendered && x0 < camera->width && (rendered_packets[packet / 32u] >> (packet % 32u)) & 1u) return;
    lint xs = (int)x0 + LANE_INDEX;
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
#define SOMBRA_JITTER_LANE(c) sombra_pixel_jitter((uint)LC(xs, c), y, camera->jitter_seed)
    state.scene = scene_refs(camera, lights, volumes, tf_tables, occupancy, LFROM_LANES(SOMBRA_JITTER_LANE));
#undef SOMBRA_JITTER_LANE
    SHADOW_STATE_INIT(state.shadow)
#ifdef SOMBRA_SHADOW_CACHE
    state.shadow_cache_table = shadow_cache_table;
#ifdef SOMBRA_SHADOW_CACHE_MARK
    state.shadow_cache_marks = shadow_cache_marks;
    for (uint m = 0; m < SOMBRA_LIGHT_SLOTS; ++m)
        for (uint lane = 0; lane < SOMBRA_LANES; ++lane) state.last_mark_word[m][lane] = state.last_mark_bit[m][lane] = 0u; /* no bit */
#else
    state.shadow_cache = shadow_cache;
    state.shadow_cache_reads = shadow_cache_reads;
#endif
#endif
#ifdef SOMBRA_SURFACE_SHADOW_CACHE
    state.surface_shadow_cache = surface_shadow_cache;
    state.surface_cache_triangles = surface_cache_triangles;
#endif

    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, camera->volume_count, state.scene.jitter, lanes);
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
            composite_surface(volume_data, &state, &cursor, &ray, surface_triangles, surface_materials, surface_bias, cursor.surface);
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
    for (uint lane = 0; lane < SOMBRA_LANES && x0 + lane < camera->width; ++lane) {
        size_t pixel = (size_t)(write_image_rows ? y : row) * camera->width + x0 + lane; /* CameraPassReads.image_rows */
        image[pixel] = (float4)(red[lane], green[lane], blue[lane], 1.0f - transmittance[lane]);
        sample_counts[pixel] = samples[lane];
    }
}

#if SHADOW_TERM
/* Whether a shaded camera sample can read lattice point v (voxel units) of volume `volume`:
 * samples are shaded only where σ > 0, i.e. in or next to a possibly visible brick (occupancy),
 * and read the lattice points of their cell. */
static inline bool cache_point_read(__global const uchar* occupancy, __global const VolumeGpu* volume, float3 v, float reach) {
    int3 lo = clamp(convert_int3(floor((v - reach) / SOMBRA_BRICK_SIZE)), (int3)(0), volume->brick_dims.xyz - 1);
    int3 hi = clamp(convert_int3(floor((v + reach) / SOMBRA_BRICK_SIZE)), (int3)(0), volume->brick_dims.xyz - 1);
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x)
                if (occupancy[volume->brick_offset + x + volume->brick_dims.x * (y + volume->brick_dims.y * z)]) return true;
    return false;
}

/* Whether lattice point (x, y, z) is one that fill_mode asks for (shadow_cache_fill), at voxel v. */
static inline bool cache_point_wanted(__global const uchar* occupancy, __global const VolumeGpu* volume, __global const ShadowCacheGpu* c,
                                      uint fill_mode, __global const uint* fill_mask, uint x, uint row, float3 v) {
    if (x >= (uint)c->dims.x) return false;
    const bool in_mask = fill_mode != 0 && (fill_mask[c->mark_offset + row * c->mark_row_words + x / 32u] >> (x % 32u)) & 1u;
    if (fill_mode == 1) return in_mask;
    /* a light's lattice reaches past the volume's box (render.cl cache_point_read clamps to it) */
    const float3 hi = convert_float3(volume->dims.xyz - 1) + c->reach;
    if (any(v < -c->reach) || any(v > hi)) return false;
    return !in_mask && cache_point_read(occupancy, volume, v, c->reach);
}

/* What a cache fill (shadow_cache_fill, surface_shadow_cache_fill) writes for SOMBRA_LANES
 * neighbouring points: the shadow term of light `light_index` at world points p by the program's
 * technique in the lanes where read[lane], 1 in the others unless keep_unread (they keep their
 * value); out[lane · stride] for lanes < count. Shadow rays start jittered as the camera pass's
 * pixels (xs, row) would. */
static inline void cache_fill_lanes(VOLUME_DATA_PARAM, SceneRefs scene, ShadowState* shadow, uint light_index, lfloat3 p, lint xs,
                             uint row, const int* read, bool keep_unread, uint count, __global float* out, uint stride) {
#define SOMBRA_JITTER_LANE(k) sombra_pixel_jitter((uint)LC(xs, k), row, scene.camera->jitter_seed)
    scene.jitter = LFROM_LANES(SOMBRA_JITTER_LANE);
#undef SOMBRA_JITTER_LANE
    float values[SOMBRA_LANES];
    LSTORE(shadow_transmittance(volume_data, &scene, shadow, light_index, p, LLOAD(read) != 0), values);
    for (uint lane = 0; lane < SOMBRA_LANES && lane < count; ++lane)
        if (read[lane] || !keep_unread) out[lane * stride] = read[lane] ? values[lane] : 1.0f;
}

/* Voxel coordinate of a lattice's index k along y or z (ShadowCacheGpu.row_block). */
static inline float lattice_voxel(__global const ShadowCacheGpu* c, uint k, float spacing, float origin) {
    return (k / c->row_block) * spacing + (k % c->row_block) * (spacing / c->row_block_stride) + origin;
}

/* The visible fill's second step, for cache entry `cache_entry`: a point is needed when a cell
 * the marking pass marked (SOMBRA_SHADOW_CACHE_MARK) has it as a corner — cells x − 1..x,
 * y − 1..y, z − 1..z — and it is not filled yet. Writes those bits to shadow_cache_need, adds them
 * to shadow_cache_filled and their count to need_count[0]. A work-item: one mask word, 32 points
 * along x (ShadowCacheGpu.mark_offset). */
__kernel void shadow_cache_need(__global const ShadowCacheGpu* shadow_cache_table, uint cache_entry,
                                __global const uint* shadow_cache_marks, __global uint* shadow_cache_filled,
                                __global uint* shadow_cache_need, __global uint* need_count) {
    __global const ShadowCacheGpu* c = &shadow_cache_table[cache_entry];
    uint w = get_global_id(0), row = get_global_id(1), dims_y = (uint)c->dims.y;
    if (w >= c->mark_row_words || row >= dims_y * (uint)c->dims.z) return;
    const bool y_above = row % dims_y > 0, z_above = row >= dims_y;
    const uint rows[4] = {row, y_above ? row - 1 : row, z_above ? row - dims_y : row, y_above && z_above ? row - 1 - dims_y : row};
    uint here = 0, before = 0;
    for (uint k = 0; k < 4; ++k) {
        __global const uint* marks = &shadow_cache_marks[c->mark_offset + rows[k] * c->mark_row_words];
        here |= marks[w];
        if (w > 0) before |= marks[w - 1];
    }
    const uint points = min(32u, (uint)c->dims.x - 32u * w);
    uint cover = (here | (here << 1) | (before >> 31)) & (points == 32u ? 0xffffffffu : (1u << points) - 1u);
    const uint word = c->mark_offset + row * c->mark_row_words + w;
    const uint need = cover & ~shadow_cache_filled[word];
    shadow_cache_filled[word] |= need;
    shadow_cache_need[word] = need;
    if (need) atomic_add(need_count, popcount(need));
}

/* The entry a cache fill's work-item fills: cache_entry + its third index (a launch may fill
 * several: auto's probe fills every entry's small lattice in one launch, as waiting for one launch
 * per entry kept the second core idle), if that entry's lattice is of the kind the kernel fills
 * (ShadowCacheGpu.column_axes.w: 1 for a light lattice); its light: entry mod light count. */
static inline bool fill_entry(uint cache_entry, __global const ShadowCacheGpu* shadow_cache_table, uint columns, uint* entry) {
    *entry = cache_entry + (uint)get_global_id(2);
    return (shadow_cache_table[*entry].column_axes.w != 0) == (columns != 0);
}

/* The shadow cache's first pass (Ament Alg. 1, updateShadowCache): the shadow term of the entry's
 * light (fill_entry) at the lattice points of its entry, by the program's technique; a
 * work-item evaluates SOMBRA_LANES neighbouring points of a lattice row (rows: y + dims.y · z).
 * fill_mask (ShadowCacheGpu.mark_offset) and fill_mode: 0 (all) — points no shaded sample can
 * read (cache_point_read) are not evaluated and hold 1, the mask is not read; 1 (visible) — the
 * points whose mask bit is set; 2 (the rest) — the points a sample can read whose bit is not set.
 * With 1 and 2 the others keep their values. */
__kernel void shadow_cache_fill(SCENE_PARAMS, uint cache_entry, __global const ShadowCacheGpu* shadow_cache_table,
                                __global float* shadow_cache, uint fill_mode, __global const uint* fill_mask SHADOW_PARAMS) {
    uint entry;
    if (!fill_entry(cache_entry, shadow_cache_table, 0u, &entry)) return;
    __global const ShadowCacheGpu* c = &shadow_cache_table[entry];
    uint row = get_global_id(1);
    if (row >= (uint)(c->dims.y * c->dims.z)) return;
    uint x0 = get_global_id(0) * SOMBRA_LANES;
    const uint light_index = entry % camera->light_count;
    __global const VolumeGpu* volume = &volumes[entry / camera->light_count];
    const float voxel_y = lattice_voxel(c, row % c->dims.y, c->spacing.y, c->block_origin.y);
    const float voxel_z = lattice_voxel(c, row / c->dims.y, c->spacing.z, c->block_origin.z);
    int read[SOMBRA_LANES];
    bool any_read = false;
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
        const uint x = x0 + lane;
        read[lane] = cache_point_wanted(occupancy, volume, c, fill_mode, fill_mask, x, row, (float3)(x * c->spacing.x, voxel_y, voxel_z)) ? -1 : 0;
        any_read = any_read || read[lane];
    }
    if (!any_read) {
        if (fill_mode != 0) return;
        for (uint lane = 0; lane < SOMBRA_LANES && x0 + lane < (uint)c->dims.x; ++lane)
            shadow_cache[c->offset + (size_t)row * c->dims.x + x0 + lane] = 1.0f;
        return;
    }
    lint xs = (int)x0 + LANE_INDEX;
    lfloat3 voxel = l3(LCONVERT_FLOAT(xs) * c->spacing.x, (lfloat)(voxel_y), (lfloat)(voxel_z));
    lfloat3 p;
    p.x = mad(voxel.x, c->voxel_to_world[0].x, mad(voxel.y, c->voxel_to_world[0].y, mad(voxel.z, c->voxel_to_world[0].z, c->voxel_to_world[0].w)));
    p.y = mad(voxel.x, c->voxel_to_world[1].x, mad(voxel.y, c->voxel_to_world[1].y, mad(voxel.z, c->voxel_to_world[1].z, c->voxel_to_world[1].w)));
    p.z = mad(voxel.x, c->voxel_to_world[2].x, mad(voxel.y, c->voxel_to_world[2].y, mad(voxel.z, c->voxel_to_world[2].z, c->voxel_to_world[2].w)));
    SceneRefs scene = scene_refs(camera, lights, volumes, tf_tables, occupancy, (lfloat)(0.0f));
    ShadowState shadow;
    SHADOW_STATE_INIT(shadow)
    cache_fill_lanes(volume_data, scene, &shadow, light_index, p, xs, row, read, fill_mode != 0, (uint)c->dims.x - x0,
                     &shadow_cache[c->offset + (size_t)row * c->dims.x + x0], 1u);
}

#ifdef SOMBRA_SHADOW_COLUMNS
/* Voxel coordinates of point (x, y, z) of a light's lattice (ShadowCacheGpu.column_axes). */
static inline lfloat3 column_point_voxel(__global const ShadowCacheGpu* c, lfloat x, float y, float z) {
    const float v_c = mad(z, c->column_along.y, c->column_along.x), w = mad(c->column_along.z, v_c, c->column_along.w);
    lfloat axis[3];
    axis[c->column_axes.x] = mad(mad(x, c->column_across[0].w, c->column_across[0].z), w, mad(c->column_across[0].y, v_c, c->column_across[0].x));
    axis[c->column_axes.y] = (lfloat)(mad(mad(y, c->column_across[1].w, c->column_across[1].z), w, mad(c->column_across[1].y, v_c, c->column_across[1].x)));
    axis[c->column_axes.z] = (lfloat)(v_c);
    return l3(axis[0], axis[1], axis[2]);
}

/* The light lattices' fill (ShadowCacheGpu.column_axes.w = 1), for the points fill_mode asks for
 * as shadow_cache_fill: a work-item marches SOMBRA_LANES neighbouring columns (x, y) from the
 * light. At a column's first point a sample can read (whatever the mode: a point's value does not
 * depend on which points a fill asks for), the shadow ray to the light; then point by point the
 * piece back to the previous point, T(p_z) = T(p_z → p_z−1) · T(p_z−1), up to the last point asked
 * for: each column costs one ray's length, not one per point. A column stops once T < 10⁻⁶ (the
 * shadow ray's own cut-off). */
__kernel void shadow_cache_fill_columns(SCENE_PARAMS, uint cache_entry, __global const ShadowCacheGpu* shadow_cache_table,
                                        __global float* shadow_cache, uint fill_mode, __global const uint* fill_mask SHADOW_PARAMS) {
    uint entry;
    if (!fill_entry(cache_entry, shadow_cache_table, 1u, &entry)) return;
    __global const ShadowCacheGpu* c = &shadow_cache_table[entry];
    const uint column_row = get_global_id(1), x0 = get_global_id(0) * SOMBRA_LANES;
    const uint dims_y = (uint)c->dims.y, dims_z = (uint)c->dims.z;
    if (column_row >= dims_y) return;
    const uint light_index = entry % camera->light_count;
    __global const VolumeGpu* volume = &volumes[entry / camera->light_count];
    /* the lattice's y index (auto's probe fills blocks of rows: lattice_voxel in index units) */
    const float y = lattice_voxel(c, column_row, c->spacing.y, c->block_origin.y);
    const lint xs = (int)x0 + LANE_INDEX;
    /* the column's x index (auto's probe fills every k-th packet: ShadowCacheGpu.block_origin) */
    const float packet_columns = c->block_origin.w > 0.0f ? c->block_origin.w : (float)SOMBRA_LANES;
    const lfloat x = (lfloat)(mad((float)get_global_id(0), packet_columns, c->block_origin.x)) + LCONVERT_FLOAT(LANE_INDEX);
    int first[SOMBRA_LANES], last[SOMBRA_LANES];
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) first[lane] = (int)dims_z, last[lane] = -1;
    for (uint z = 0; z < dims_z; ++z) {
        float vx[SOMBRA_LANES], vy[SOMBRA_LANES], vz[SOMBRA_LANES];
        const lfloat3 v = column_point_voxel(c, x, y, (float)z);
        LSTORE(v.x, vx), LSTORE(v.y, vy), LSTORE(v.z, vz);
        const uint row = column_row + dims_y * z;
        for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
            const float3 v_lane = (float3)(vx[lane], vy[lane], vz[lane]);
            const bool wanted = cache_point_wanted(occupancy, volume, c, fill_mode, fill_mask, x0 + lane, row, v_lane);
            /* the chain's start: the first point a sample can read (fill_mode 0 asks for exactly those) */
            if (first[lane] == (int)dims_z && (fill_mode == 0 ? wanted : cache_point_wanted(occupancy, volume, c, 0, fill_mask, x0 + lane, row, v_lane)))
                first[lane] = (int)z;
            if (wanted) {
                first[lane] = min(first[lane], (int)z), last[lane] = (int)z;  /* (a marked point is one a sample reads) */
            } else if (fill_mode == 0 && x0 + lane < (uint)c->dims.x) {
                shadow_cache[c->offset + (size_t)row * c->dims.x + x0 + lane] = 1.0f;
            }
        }
    }
    int z_first = (int)dims_z, z_last = -1;
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) z_first = min(z_first, first[lane]), z_last = max(z_last, last[lane]);
    if (z_last < 0) return;
    SceneRefs scene = scene_refs(camera, lights, volumes, tf_tables, occupancy, (lfloat)(0.0f));
#define SOMBRA_JITTER_LANE(k) sombra_pixel_jitter((uint)LC(xs, k), column_row, camera->jitter_seed)
    scene.jitter = LFROM_LANES(SOMBRA_JITTER_LANE);
#undef SOMBRA_JITTER_LANE
    ShadowState shadow;
    SHADOW_STATE_INIT(shadow)
    const lint first_z = LLOAD(first), last_z = LLOAD(last);
    lfloat transmittance = (lfloat)(1.0f);
    lfloat3 previous = l3_splat((float3)(0.0f));
    for (int z = z_first; z <= z_last; ++z) {
        const lfloat3 v = column_point_voxel(c, x, y, (float)z);
        lfloat3 p;
        p.x = lattice_row(c->voxel_to_world[0], v), p.y = lattice_row(c->voxel_to_world[1], v), p.z = lattice_row(c->voxel_to_world[2], v);
        const lint zs = (lint)(z);
        const lmask start = first_z == zs, go_on = (first_z < zs) & (zs <= last_z) & (transmittance >= 1e-6f);
        if (lany(start | go_on)) {
            lfloat3 dir, to_previous = l3_sub(previous, p);
            lfloat t_max, piece = sqrt(l3_dot(to_previous, to_previous));
            ray_to_light(&lights[light_index], p, &dir, &t_max);
            to_previous = l3_scale(to_previous, 1.0f / fmax(piece, 1e-30f));
            dir = l3(select(dir.x, to_previous.x, go_on), select(dir.y, to_previous.y, go_on), select(dir.z, to_previous.z, go_on));
            t_max = select(t_max, piece, go_on);
            const lfloat t = piece_transmittance(volume_data, &scene, &shadow, p, dir, t_max, start | go_on);
            transmittance = select(transmittance, select(transmittance * t, t, start), start | go_on);
        }
        previous = p;
        float values[SOMBRA_LANES], vx[SOMBRA_LANES], vy[SOMBRA_LANES], vz[SOMBRA_LANES];
        LSTORE(transmittance, values), LSTORE(v.x, vx), LSTORE(v.y, vy), LSTORE(v.z, vz);
        const uint row = column_row + dims_y * (uint)z;
        for (uint lane = 0; lane < SOMBRA_LANES; ++lane)
            if (first[lane] <= z && z <= last[lane] &&
                cache_point_wanted(occupancy, volume, c, fill_mode, fill_mask, x0 + lane, row, (float3)(vx[lane], vy[lane], vz[lane])))
                shadow_cache[c->offset + (size_t)row * c->dims.x + x0 + lane] = values[lane];
    }
}
#endif

#ifdef SOMBRA_HAS_MESHES
/* The surface shadow cache's fill: the shadow term of light `light_index` at surface points
 * (surface_points: position, unit normal; rows of row_points points) by the program's technique,
 * looked up where a fragment at the point looks it up (surface_shadow_lookup, surface_bias);
 * point k's value at surface_shadow_cache[k · light_count + light_index]. */
__kernel void surface_shadow_cache_fill(SCENE_PARAMS, uint light_index, __global const float4* surface_points, uint point_count,
                                        uint row_points, __global const float* surface_bias,
                                        __global float* surface_shadow_cache SHADOW_PARAMS) {
    uint first = get_global_id(1) * row_points + get_global_id(0) * SOMBRA_LANES;
    if (get_global_id(0) * SOMBRA_LANES >= row_points || first >= point_count) return;
    float px[SOMBRA_LANES], py[SOMBRA_LANES], pz[SOMBRA_LANES], nx[SOMBRA_LANES], ny[SOMBRA_LANES], nz[SOMBRA_LANES];
    int read[SOMBRA_LANES];
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
        uint k = min(first + lane, point_count - 1);
        float4 q = surface_points[2 * k], n = surface_points[2 * k + 1];
        px[lane] = q.x, py[lane] = q.y, pz[lane] = q.z, nx[lane] = n.x, ny[lane] = n.y, nz[lane] = n.z;
        read[lane] = first + lane < point_count ? -1 : 0;
    }
    lfloat3 p = surface_shadow_lookup(&lights[light_index], l3(LLOAD(px), LLOAD(py), LLOAD(pz)),
                                      l3(LLOAD(nx), LLOAD(ny), LLOAD(nz)), (lfloat)(surface_bias[light_index]));
    lint xs = (int)(first % row_points) + LANE_INDEX;
    uint row = get_global_id(1);
    SceneRefs scene = scene_refs(camera, lights, volumes, tf_tables, occupancy, (lfloat)(0.0f));
    ShadowState shadow;
    SHADOW_STATE_INIT(shadow)
    cache_fill_lanes(volume_data, scene, &shadow, light_index, p, xs, row, read, false, point_count - first,
                     &surface_shadow_cache[(size_t)first * camera->light_count + light_index], camera->light_count);
}
#endif
#endif

#if SHADOW_TERM && SOMBRA_LANES == 1
/* Transmittance to light `light_index` at arbitrary world points, by the program's technique
 * (sombra visibility, the API's shadow queries, tests). Built with SOMBRA_LANES=1. */
__kernel void shadow_probe(SCENE_PARAMS, uint light_index, __global const float4* points, __global float* transmittance
                           SHADOW_PARAMS) {
    size_t i = get_global_id(0);
    SceneRefs scene = scene_refs(camera, lights, volumes, tf_tables, occupancy, sombra_pixel_jitter((uint)i, 0u, camera->jitter_seed));
    ShadowState shadow;
    SHADOW_STATE_INIT(shadow)
    transmittance[i] = shadow_transmittance(volume_data, &scene, &shadow, light_index, l3(points[i].x, points[i].y, points[i].z), 1);
}
#endif
