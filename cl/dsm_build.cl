/* sombra — deep shadow map generation (Knecht Alg. 3.1; Hadwiger §3.1, §3.3): a work-item casts
 * the rays of SOMBRA_LANES neighbouring texels of one row from the light as a packet (lanes.h:
 * 8 on CPUs, 1 on GPUs) over the same segment traversal as the camera pass, accumulates each
 * lane's opacity (Knecht Eq. 3.2), compresses each lane's visibility function on the fly with its
 * own compressor (shared/compress.h) and hands the nodes to the lane's storage writer
 * (dsm_storage.h). Every lane computes what the 1-lane kernel computes for its texel. Kernels:
 *   dsm_build  generation into the backend's storage
 *   dsm_count  nodes per texel only (SOMBRA_DSM_COUNT_ONLY; the compact backend's first pass)
 * Defines as render.cl: SOMBRA_LANES, SOMBRA_VOLUME_SLOTS, SOMBRA_USE_IMAGES, SOMBRA_SKIP_EMPTY;
 * the backend's (SOMBRA_DSM_ATLAS, SOMBRA_DSM_CHUNKED); SOMBRA_DSM_PRECOMPRESSED (pre-compressed
 * visibility tables, Hadwiger §3.2); SOMBRA_HAS_MESHES (the texel's fragment list merged into the
 * segment boundaries: surfaces as vertical steps, Knecht §3.2; polyhedral volume bounds). */
#include "shared/types.h"
#include "shared/hash.h"
#include "shared/compress.h"
#include "shared/dsm_value.h"
#include "lanes.h"
#include "volume_sample.h"
#include "traversal.h"
#include "dsm_view.h"
#include "dsm_generation.h"

/* A ray stops once its transmittance falls below this: V(z) is then within 10⁻⁴ of 1. */
#define DSM_TERMINATION_TRANSMITTANCE 1e-4f

/* What a lane's compressor is fed (shared/dsm_value.h): its accumulated opacity, or its optical depth. */
#ifdef SOMBRA_DSM_OPTICAL_DEPTH
#define DSM_LANE_VALUE(lane) optical_depth[lane]
#else
#define DSM_LANE_VALUE(lane) (1.0f - transmittance[lane])
#endif

#ifdef SOMBRA_HAS_MESHES
/* A surface fragment the cursor handed over at its depth (traversal.h), in depth order with the
 * volume samples: a vertical step of its opacity a, α_acc += a (1 − α_acc), two nodes at its depth
 * that the compressor never smooths away (Knecht §3.2). */
#define DSM_SURFACE_STEP(lane, f)                                                                          \
    do {                                                                                                   \
        float a = surface_materials[screen_triangles[(f).triangle].mesh].color.w;                          \
        if (!(a > 0.0f)) break;                                                                            \
        float before = DSM_LANE_VALUE(lane);                                                               \
        transmittance[lane] *= 1.0f - a;                                                                   \
        optical_depth[lane] = fmin(optical_depth[lane] + dsm_optical_depth_of(a), SOMBRA_DSM_MAX_OPTICAL_DEPTH); \
        STORE_NODES(lane, compressor_flush(&compressor[lane]));                                            \
        STORE_NODES(lane, compressor_step(&compressor[lane], (f).depth, before, DSM_LANE_VALUE(lane)));    \
        previous_t[lane] = (f).depth;                                                                      \
    } while (0)
#endif

DSM_GENERATION_KERNEL(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
     __global const VolumeGpu* volumes, uint volume_count, __global const DsmViewGpu* views, uint view_index,
     float epsilon, float step_scale,
#ifdef SOMBRA_DSM_PRECOMPRESSED
     __global const PrecompressionGpu* precompression, __global const float* precompressed_fraction,
     __global const float* precompressed_opacity, __global const uchar* precompressed_count,
#endif
#ifdef SOMBRA_HAS_MESHES
     __global const uint* fragment_first, __global const FragmentGpu* fragments,
     __global const ScreenTriangleGpu* screen_triangles, __global const SurfaceMaterialGpu* surface_materials,
#endif
     DSM_BUILD_STORAGE_PARAMS) {
    __global const DsmViewGpu* v = &views[view_index];
    uint x0 = get_global_id(0) * SOMBRA_LANES, y = get_global_id(1);
    if (x0 >= v->resolution || y >= v->resolution) return; /* padding of the grid */
    uint n = min((uint)SOMBRA_LANES, v->resolution - x0);  /* texels of this packet; lanes ≥ n are padding */
    DSM_TEXELS_BEGIN(v, x0, y, n);

    /* every lane's ray and jitter as the 1-lane kernel computes them (padding lanes: a copy of
     * the row's last texel, finite and never sampled) */
    float ox[SOMBRA_LANES], oy[SOMBRA_LANES], oz[SOMBRA_LANES], dx[SOMBRA_LANES], dy[SOMBRA_LANES], dz[SOMBRA_LANES];
    float jitter[SOMBRA_LANES];
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
        uint x = min(x0 + lane, v->resolution - 1);
        float3 origin, dir;
        dsm_texel_ray(v, x, y, &origin, &dir);
        ox[lane] = origin.x, oy[lane] = origin.y, oz[lane] = origin.z;
        dx[lane] = dir.x, dy[lane] = dir.y, dz[lane] = dir.z;
        jitter[lane] = sombra_pixel_jitter(x, y, view_index);
    }
    lmask texels = (int)x0 + LANE_INDEX < (int)v->resolution;
    VolumeRay ray;
    make_volume_ray(&ray, volumes, volume_count, l3(LLOAD(ox), LLOAD(oy), LLOAD(oz)), l3(LLOAD(dx), LLOAD(dy), LLOAD(dz)),
                    (lfloat)(0.0f), (lfloat)(INFINITY));
    volume_ray_only(&ray, volume_count, v->volume_mask);
    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, volume_count, LLOAD(jitter), texels);
    cursor.step_scale = step_scale; /* RenderOptions::dsm_step */
#ifdef SOMBRA_HAS_MESHES /* the texel's fragments: surfaces and volume bounds are segment boundaries */
    uint texel[SOMBRA_LANES];
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) texel[lane] = y * v->resolution + min(x0 + lane, v->resolution - 1);
    segment_cursor_use_fragments(&cursor, volumes, volume_count, fragment_first, fragments, screen_triangles, texel, texels);
#endif

    /* per lane: the compressor, the transmittance and the previous sample's depth */
    VisibilityCompressor compressor[SOMBRA_LANES];
    float transmittance[SOMBRA_LANES], optical_depth[SOMBRA_LANES], previous_t[SOMBRA_LANES];
    for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
        compressor_init(&compressor[lane], epsilon);
        transmittance[lane] = 1.0f;
        optical_depth[lane] = 0.0f;
        previous_t[lane] = -INFINITY;
    }
    lfloat front[SOMBRA_VOLUME_SLOTS]; /* each volume's density at the previous point */
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) front[i] = (lfloat)(0.0f);
    lmask sampling;
    while (lany(sampling = segment_cursor_next(&cursor, &ray, volumes, volume_count, occupancy))) {
#ifdef SOMBRA_HAS_MESHES
        if (lany(cursor.surface)) {
            int surface_lane[SOMBRA_LANES];
            LSTORE(cursor.surface, surface_lane);
            for (uint lane = 0; lane < SOMBRA_LANES; ++lane)
                if (surface_lane[lane]) DSM_SURFACE_STEP(lane, fragments[cursor.surface_fragment[lane]]);
            sampling &= !cursor.surface;
        }
#endif
        lfloat t = select((lfloat)(0.0f), cursor.t, sampling); /* finite positions in idle lanes */
        lmask stepwise = sampling; /* lanes whose interval is one exact value, not a table's nodes */
#ifdef SOMBRA_DSM_PRECOMPRESSED
        /* Hadwiger §3.2: a whole step between two samples of a one-volume segment is replaced by
         * its pre-compressed visibility function, so an isosurface between two samples rises where
         * it lies, not at the next sample (partial intervals at segment ends are integrated) */
        lmask single = cursor.full_step & sampling & (cursor.active != 0u) & ((cursor.active & (cursor.active - 1u)) == 0u);
        lfloat front_density = (lfloat)(0.0f), density = (lfloat)(0.0f);
        lmask tabled = (lmask)(0);
        for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) {
            lmask here = single & (cursor.active == (1u << i));
            if (!lany(here) || precompression[i].size == 0) continue;
            front_density = select(front_density, front[i], here);
            density = select(density, density_at_point(volume_data, &volumes[i], &ray, i, t), here);
            front[i] = select(front[i], density, here);
            tabled |= here;
        }
        stepwise &= !tabled;
        int tabled_lane[SOMBRA_LANES];
        uint active_lane[SOMBRA_LANES];
        float front_lane[SOMBRA_LANES], back_lane[SOMBRA_LANES];
        LSTORE(tabled, tabled_lane);
        LSTORE(cursor.active, active_lane);
        LSTORE(front_density, front_lane);
        LSTORE(density, back_lane);
#endif
        lfloat depth = lany(stepwise) ? interval_optical_depth(volume_data, volumes, tf_tables, &ray, &cursor, t, front, stepwise)
                                      : (lfloat)(0.0f);
        int sampling_lane[SOMBRA_LANES];
        float t_lane[SOMBRA_LANES], step_lane[SOMBRA_LANES], depth_lane[SOMBRA_LANES];
        LSTORE(sampling, sampling_lane);
        LSTORE(t, t_lane);
        LSTORE(cursor.step, step_lane);
        LSTORE(depth, depth_lane);
        /* each lane's point goes to its own compressor */
        for (uint lane = 0; lane < SOMBRA_LANES; ++lane) {
            if (!sampling_lane[lane]) continue;
            float t = t_lane[lane];
#ifdef SOMBRA_DSM_PRECOMPRESSED
            if (tabled_lane[lane]) {
                __global const PrecompressionGpu* table = &precompression[31 - clz(active_lane[lane])];
                float last = (float)(table->size - 1), step = step_lane[lane];
                uint front = (uint)rint(clamp((front_lane[lane] - table->domain_min) * table->domain_scale, 0.0f, last));
                uint back = (uint)rint(clamp((back_lane[lane] - table->domain_min) * table->domain_scale, 0.0f, last));
                uint entry = table->entry_offset + front * table->size + back;
                uint node_count = precompressed_count[entry];
                float start_transmittance = transmittance[lane], start_depth = optical_depth[lane];
                float start_t = t - step, fed_z = previous_t[lane];
                for (uint j = 0; j < node_count; ++j) {
                    float z = start_t + precompressed_fraction[4 * entry + j] * step;
                    float step_alpha = precompressed_opacity[4 * entry + j];
                    transmittance[lane] = start_transmittance * (1.0f - step_alpha);
                    optical_depth[lane] = fmin(start_depth + dsm_optical_depth_of(step_alpha), SOMBRA_DSM_MAX_OPTICAL_DEPTH);
                    STORE_NODES(lane, compressor_add(&compressor[lane], z, DSM_LANE_VALUE(lane), fed_z));
                    fed_z = z;
                }
                previous_t[lane] = t;
                continue;
            }
#endif
            /* α_acc += α_interval (1 − α_acc), Knecht Eq. 3.2, the interval's optical depth exact
             * (scalar exp: the same bits as 1 lane); the opacity starts to rise at the previous point */
            float first_z = previous_t[lane];
            previous_t[lane] = t;
            if (depth_lane[lane] != 0.0f) {
                transmittance[lane] *= exp(-depth_lane[lane]);
                optical_depth[lane] = fmin(optical_depth[lane] + depth_lane[lane], SOMBRA_DSM_MAX_OPTICAL_DEPTH);
            }
            float value = DSM_LANE_VALUE(lane);
            /* empty space before the first opacity changes nothing in a compressor (compress.h) */
            if (compressor[lane].started || value > 0.0f)
                STORE_NODES(lane, compressor_add(&compressor[lane], t, value, first_z));
        }
        cursor.alive &= !(LLOAD(transmittance) < DSM_TERMINATION_TRANSMITTANCE);
    }
    for (uint lane = 0; lane < n; ++lane) STORE_NODES(lane, compressor_finish(&compressor[lane]));
    DSM_TEXELS_END(v, x0, y, n);
}
