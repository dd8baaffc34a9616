/* sombra — building a light-aligned summed-area table (Ament §4.2.1, §5). sat_resample samples the
 * extinction σ of every volume (through its transfer function, as the camera pass classifies it)
 * in each cell of a grid aligned with the light and stores the cell's optical depth σ·h as a
 * 64-bit fixed-point integer (shared/types.h), already summed along grid axis 2; sat_scan sums
 * along axis 0 or 1. One work-item per line: the prefix sums run in parallel over lines. Integer
 * sums are exact and independent of the order, so the table cannot cancel the way float32 SATs
 * do (DESIGN.md "SAT precision"). Built with SOMBRA_LANES=1; defines as dsm_build.cl. */
#include "shared/types.h"
#include "lanes.h"
#include "volume_sample.h"
#include "lowpass.h"

/* Sum of σ over the volumes whose box [−0.5, dims − 0.5] (voxel space) holds world point p. */
inline float extinction_at_point(VOLUME_DATA_PARAM, __global const VolumeGpu* volumes, uint volume_count,
                                 __global const float* tf_tables, float3 p) {
    float sigma = 0.0f;
    for (uint i = 0; i < volume_count; ++i) {
        __global const VolumeGpu* v = &volumes[i];
        float3 q = (float3)(dot(v->world_to_voxel[0].xyz, p) + v->world_to_voxel[0].w,
                            dot(v->world_to_voxel[1].xyz, p) + v->world_to_voxel[1].w,
                            dot(v->world_to_voxel[2].xyz, p) + v->world_to_voxel[2].w);
        float3 hi = convert_float3(v->dims.xyz) - 0.5f;
        if (any(q < -0.5f) || any(q > hi)) continue;
        sigma += classify(tf_tables, v, sample_density(volume_data, v, l3(q.x, q.y, q.z))).sigma;
    }
    return sigma;
}

/* Work-item (i, j): the column of cells (i, j, 0 … n.z − 1), sampled at their centres origin +
 * (i + ½)·cell_u + (j + ½)·cell_v + (k + ½)·cell_w; σ·h is clamped to SOMBRA_SAT_MAX_CELL_TAU and
 * rounded to fixed point. Writes the column's running sums into S(i + 1, j + 1, k + 1); the zero
 * border S(0, ·, ·) … is cleared by the host. */
__kernel void sat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                           uint volume_count, __global ulong* sat, uint data_offset, int4 n, float4 origin,
                           float4 cell_u, float4 cell_v, float4 cell_w, float cell_length) {
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= n.x || j >= n.y) return;
    float3 base = origin.xyz + (i + 0.5f) * cell_u.xyz + (j + 0.5f) * cell_v.xyz;
    __global ulong* s = sat + data_offset;
    ulong running = 0;
    for (int k = 0; k < n.z; ++k) {
        float sigma = extinction_at_point(volume_data, volumes, volume_count, tf_tables, base + (k + 0.5f) * cell_w.xyz);
        running += sat_fixed_point(sigma * cell_length);
        s[sat_entry(n, i + 1, j + 1, k + 1)] = running;
    }
}

/* SSAT (Ament §4.2.3): work-item (i, j) is the ray of cells (φ_i, θ_j, r_0 … r_n.z−1) from the
 * light, sampled at their centres; a cell holds σ·Δr·w_θ (shared/types.h, SsatGridGpu). */
__kernel void ssat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                            uint volume_count, __global ulong* sat, __global const SsatGridGpu* grid) {
    int4 n = grid->dims;
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= n.x || j >= n.y) return;
    float phi = grid->start.x + (i + 0.5f) * grid->cell.x;
    float theta0 = grid->start.y + j * grid->cell.y, theta1 = theta0 + grid->cell.y;
    float theta = theta0 + 0.5f * grid->cell.y;
    float w_theta = (cos(theta0) - cos(theta1)) / grid->cell.y;
    float3 dir = sin(theta) * cos(phi) * grid->axes[0].xyz + sin(theta) * sin(phi) * grid->axes[1].xyz +
                 cos(theta) * grid->axes[2].xyz;
    __global ulong* s = sat + grid->data_offset;
    ulong running = 0;
    for (int k = 0; k < n.z; ++k) {
        float r = grid->start.z + (k + 0.5f) * grid->cell.z;
        float sigma = extinction_at_point(volume_data, volumes, volume_count, tf_tables, grid->light.xyz + r * dir);
        running += sat_fixed_point(sigma * grid->cell.z * w_theta);
        s[sat_entry(n, i + 1, j + 1, k + 1)] = running;
    }
}

/* Work-item (a, b): the line along `axis` (0 or 1) through entries a + 1, b + 1 of the other two
 * axes (in increasing axis order), turned into its inclusive prefix sums. */
__kernel void sat_scan(__global ulong* sat, uint data_offset, int4 n, uint axis) {
    int a = get_global_id(0) + 1, b = get_global_id(1) + 1;
    int length = axis == 0 ? n.x : n.y;
    if (a > (axis == 0 ? n.y : n.x) || b > n.z) return;
    __global ulong* s = sat + data_offset;
    size_t first = axis == 0 ? sat_entry(n, 0, a, b) : sat_entry(n, a, 0, b);
    size_t stride = axis == 0 ? 1 : (size_t)(n.x + 1);
    ulong running = 0;
    for (int t = 1; t <= length; ++t) {
        running += s[first + t * stride];
        s[first + t * stride] = running;
    }
}
