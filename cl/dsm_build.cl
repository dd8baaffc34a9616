/* sombra — deep shadow map generation (Knecht Alg. 3.1; Hadwiger §3.1, §3.3): one work-item per
 * texel casts a ray from the light over the same segment traversal as the camera pass,
 * accumulates opacity (Knecht Eq. 3.2) and compresses the visibility function on the fly
 * (shared/compress.h). Built with SOMBRA_LANES=1. Two kernels share build_texel():
 *   dsm_count  nodes per texel (pass 1; the host turns counts into offsets by a prefix sum)
 *   dsm_write  the nodes, at the texel's offset (pass 2)
 * Defines as render.cl: SOMBRA_VOLUME_SLOTS, SOMBRA_USE_IMAGES, SOMBRA_SKIP_EMPTY. */
#include "shared/types.h"
#include "shared/hash.h"
#include "shared/compress.h"
#include "lanes.h"
#include "volume_sample.h"
#include "traversal.h"
#include "dsm_view.h"

/* A ray stops once its transmittance falls below this: V(z) is then within 10⁻⁴ of 1. */
#define DSM_TERMINATION_TRANSMITTANCE 1e-4f

inline void store_nodes(CompressorOutput out, __global float* nodes, uint base, uint* count) {
    for (int i = 0; i < out.count; ++i) {
        if (nodes) {
            nodes[2 * (base + *count)] = out.z[i];
            nodes[2 * (base + *count) + 1] = out.alpha[i];
        }
        *count += 1;
    }
}

/* Marches texel (x, y) of view v; writes its nodes from nodes[2·base] on when nodes is given;
 * returns the node count. */
inline uint build_texel(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                        __global const VolumeGpu* volumes, uint volume_count, __global const DsmViewGpu* v, uint x,
                        uint y, float epsilon, uint seed, __global float* nodes, uint base) {
    float res = (float)v->resolution;
    float3 origin, dir;
    dsm_view_ray(v, ((x + 0.5f) / res) * 2.0f - 1.0f, ((y + 0.5f) / res) * 2.0f - 1.0f, &origin, &dir);
    VolumeRay ray;
    make_volume_ray(&ray, volumes, volume_count, l3_splat(origin), l3_splat(dir), (lfloat)(0.0f), (lfloat)(INFINITY));
    SegmentCursor cursor;
    segment_cursor_init(&cursor, &ray, volume_count, sombra_pixel_jitter(x, y, seed), (lmask)(1));

    VisibilityCompressor compressor;
    compressor_init(&compressor, epsilon);
    float transmittance = 1.0f, previous_t = -INFINITY;
    uint count = 0;
    while (segment_cursor_next(&cursor, &ray, volumes, volume_count, occupancy)) {
        float t = cursor.t, step = cursor.step;
        float sigma = extinction_at(volume_data, volumes, tf_tables, &ray, t, cursor.active, 1);
        transmittance *= exp(-sigma * step); /* α_acc += α_sample (1 − α_acc), Knecht Eq. 3.2 */
        /* opacity starts to rise within this sample's step, not before the previous sample */
        float first_z = fmax(previous_t, t - step);
        store_nodes(compressor_add(&compressor, t, 1.0f - transmittance, first_z), nodes, base, &count);
        previous_t = t;
        if (transmittance < DSM_TERMINATION_TRANSMITTANCE) cursor.alive = 0;
    }
    store_nodes(compressor_finish(&compressor), nodes, base, &count);
    return count;
}

__kernel void dsm_count(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                        __global const VolumeGpu* volumes, uint volume_count, __global const DsmViewGpu* views,
                        uint view_index, float epsilon, __global uint* counts) {
    __global const DsmViewGpu* v = &views[view_index];
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= v->resolution || y >= v->resolution) return;
    counts[v->first_texel + y * v->resolution + x] = build_texel(
        volume_data, occupancy, tf_tables, volumes, volume_count, v, x, y, epsilon, view_index, 0, 0);
}

__kernel void dsm_write(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                        __global const VolumeGpu* volumes, uint volume_count, __global const DsmViewGpu* views,
                        uint view_index, float epsilon, __global const uint* texel_first, __global float* nodes) {
    __global const DsmViewGpu* v = &views[view_index];
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= v->resolution || y >= v->resolution) return;
    uint texel = v->first_texel + y * v->resolution + x;
    build_texel(volume_data, occupancy, tf_tables, volumes, volume_count, v, x, y, epsilon, view_index, nodes,
                texel_first[texel]);
}
