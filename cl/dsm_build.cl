/* sombra — deep shadow map generation (Knecht Alg. 3.1; Hadwiger §3.1, §3.3): one work-item per
 * texel casts a ray from the light over the same segment traversal as the camera pass,
 * accumulates opacity (Knecht Eq. 3.2), compresses the visibility function on the fly
 * (shared/compress.h) and hands the nodes to the storage backend (dsm_storage.h). Built with
 * SOMBRA_LANES=1. Kernels:
 *   dsm_build  generation into the backend's storage
 *   dsm_count  nodes per texel only (SOMBRA_DSM_COUNT_ONLY; the compact backend's first pass)
 * Defines as render.cl: SOMBRA_VOLUME_SLOTS, SOMBRA_USE_IMAGES, SOMBRA_SKIP_EMPTY; the
 * backend's (SOMBRA_DSM_ATLAS, SOMBRA_DSM_CHUNKED); SOMBRA_DSM_PRECOMPRESSED (pre-compressed
 * visibility tables, Hadwiger §3.2). */
#include "shared/types.h"
#include "shared/hash.h"
#include "shared/compress.h"
#include "lanes.h"
#include "volume_sample.h"
#include "traversal.h"
#include "dsm_view.h"
#include "dsm_generation.h"

/* A ray stops once its transmittance falls below this: V(z) is then within 10⁻⁴ of 1. */
#define DSM_TERMINATION_TRANSMITTANCE 1e-4f


DSM_GENERATION_KERNEL(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
     __global const VolumeGpu* volumes, uint volume_count, __global const DsmViewGpu* views, uint view_index,
     float epsilon,
#ifdef SOMBRA_DSM_PRECOMPRESSED
     __global const PrecompressionGpu* precompression, __global const float* precompressed_fraction,
     __global const float* precompressed_opacity, __global const uchar* precompressed_count,
#endif
     DSM_BUILD_STORAGE_PARAMS) {
    __global const DsmViewGpu* v = &views[view_index];
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= v->resolution || y >= v->resolution) return;
    DSM_TEXEL_BEGIN(v, x, y);

    float3 origin, dir;
    dsm_texel_ray(v, x, y, &origin, &dir);
    VolumeRay ray;
    make_volume_ray(&ray, volumes, volume_count, l3_splat(origin), l3_splat(dir), (lfloat)(0.0f), (lfloat)(INFINITY));
    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, volume_count, sombra_pixel_jitter(x, y, view_index), (lmask)(1));

    VisibilityCompressor compressor;
    compressor_init(&compressor, epsilon);
    float transmittance = 1.0f, previous_t = -INFINITY;
    uint count = 0;
#ifdef SOMBRA_DSM_PRECOMPRESSED
    float previous_density = 0.0f;
    int previous_segment = -1, previous_k = -1;
#endif
    while (segment_cursor_next(&cursor, &ray, volumes, volume_count, occupancy)) {
        float t = cursor.t, step = cursor.step;
        /* opacity starts to rise within this sample's step, not before the previous sample */
        float first_z = fmax(previous_t, t - step);
#ifdef SOMBRA_DSM_PRECOMPRESSED
        /* Hadwiger §3.2: in a segment of one volume, the step from the previous sample to this one
         * is replaced by its pre-compressed visibility function, so an isosurface between two
         * samples rises where it lies, not at the next sample */
        uint active = cursor.active;
        if (active != 0 && (active & (active - 1)) == 0) {
            uint i = 31 - clz(active);
            __global const VolumeGpu* v = &volumes[i];
            float density = sample_density(volume_data, v, ray_voxel_point(&ray, i, t));
            __global const PrecompressionGpu* table = &precompression[i];
            bool consecutive = cursor.segment == previous_segment && cursor.k == previous_k + 1;
            previous_segment = cursor.segment, previous_k = cursor.k;
            float front_density = previous_density;
            previous_density = density;
            if (consecutive && table->size > 0) {
                float last = (float)(table->size - 1);
                uint front = (uint)rint(clamp((front_density - table->domain_min) * table->domain_scale, 0.0f, last));
                uint back = (uint)rint(clamp((density - table->domain_min) * table->domain_scale, 0.0f, last));
                uint entry = table->entry_offset + front * table->size + back;
                uint node_count = precompressed_count[entry];
                float start_transmittance = transmittance, start_t = t - step, fed_z = previous_t;
                for (uint j = 0; j < node_count; ++j) {
                    float z = start_t + precompressed_fraction[4 * entry + j] * step;
                    float step_alpha = precompressed_opacity[4 * entry + j];
                    transmittance = start_transmittance * (1.0f - step_alpha);
                    STORE_NODES(compressor_add(&compressor, z, 1.0f - transmittance, fed_z));
                    fed_z = z;
                }
                previous_t = t;
                if (transmittance < DSM_TERMINATION_TRANSMITTANCE) cursor.alive = 0;
                continue;
            }
        }
#endif
        float sigma = extinction_at(volume_data, volumes, tf_tables, &ray, t, cursor.active, 1);
        transmittance *= exp(-sigma * step); /* α_acc += α_sample (1 − α_acc), Knecht Eq. 3.2 */
        STORE_NODES(compressor_add(&compressor, t, 1.0f - transmittance, first_z));
        previous_t = t;
        if (transmittance < DSM_TERMINATION_TRANSMITTANCE) cursor.alive = 0;
    }
    STORE_NODES(compressor_finish(&compressor));
    DSM_TEXEL_END(v, x, y);
}
