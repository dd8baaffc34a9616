/* sombra — reading a volume: density at a continuous voxel position, transfer function, gradient.
 * One function, sample_density(), hides where voxels live: a float buffer with manual trilinear
 * interpolation (fast on PoCL: 80 vs 35 Msamples/s, OPENCL-NOTES.md) or a 3D image atlas with the
 * hardware's linear filter (GPUs), chosen by the SOMBRA_USE_IMAGES define. */
#ifndef SOMBRA_VOLUME_SAMPLE_H
#define SOMBRA_VOLUME_SAMPLE_H
#include "shared/types.h"

#ifdef SOMBRA_USE_IMAGES
#define VOLUME_DATA_PARAM __read_only image3d_t volume_data
__constant sampler_t volume_sampler = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP_TO_EDGE | CLK_FILTER_LINEAR;
#else
#define VOLUME_DATA_PARAM __global const float* restrict volume_data
#endif

inline float3 to_voxel_point(__global const VolumeGpu* v, float3 p) {
    return (float3)(dot(v->world_to_voxel[0].xyz, p) + v->world_to_voxel[0].w,
                    dot(v->world_to_voxel[1].xyz, p) + v->world_to_voxel[1].w,
                    dot(v->world_to_voxel[2].xyz, p) + v->world_to_voxel[2].w);
}

inline float3 to_voxel_direction(__global const VolumeGpu* v, float3 d) {
    return (float3)(dot(v->world_to_voxel[0].xyz, d), dot(v->world_to_voxel[1].xyz, d),
                    dot(v->world_to_voxel[2].xyz, d));
}

/* Trilinear density at voxel position p (voxel centres at integers), clamped to the edge. */
inline float sample_density(VOLUME_DATA_PARAM, __global const VolumeGpu* v, float3 p) {
    float3 hi = convert_float3(v->dims.xyz) - 1.0f;
    p = clamp(p, (float3)(0.0f), hi);
#ifdef SOMBRA_USE_IMAGES
    float4 coord = (float4)(p.x + 0.5f, p.y + 0.5f, p.z + 0.5f + v->image_z_offset, 0.0f);
    return read_imagef(volume_data, volume_sampler, coord).x;
#else
    float3 base = floor(p);
    float3 f = p - base;
    int3 i0 = convert_int3(base);
    int3 i1 = min(i0 + 1, v->dims.xyz - 1);
    size_t sx = 1, sy = (size_t)v->dims.x, sz = (size_t)v->dims.x * (size_t)v->dims.y;
    __global const float* d = volume_data + v->data_offset;
    size_t y0 = i0.y * sy, y1 = i1.y * sy, z0 = i0.z * sz, z1 = i1.z * sz;
    float c00 = mix(d[i0.x * sx + y0 + z0], d[i1.x * sx + y0 + z0], f.x);
    float c10 = mix(d[i0.x * sx + y1 + z0], d[i1.x * sx + y1 + z0], f.x);
    float c01 = mix(d[i0.x * sx + y0 + z1], d[i1.x * sx + y0 + z1], f.x);
    float c11 = mix(d[i0.x * sx + y1 + z1], d[i1.x * sx + y1 + z1], f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
#endif
}

/* Transfer function: linear interpolation in the volume's table of (r, g, b, σ), σ being the
 * extinction per world unit (opacity already converted, see README "opacity convention"). */
inline float4 classify(__global const float4* tf_tables, __global const VolumeGpu* v, float density) {
    float u = clamp((density - v->tf_domain_min) * v->tf_domain_scale, 0.0f, (float)(v->tf_size - 1));
    uint i0 = min((uint)u, v->tf_size - 2);
    float f = u - (float)i0;
    __global const float4* table = tf_tables + v->tf_offset;
    return mix(table[i0], table[i0 + 1], f);
}

/* Voxel-space gradient of the density: central differences, or the 3×3×3 Sobel operator when
 * SOMBRA_SOBEL is defined (course slides, "Gradient Calculation"). Units: density per voxel. */
inline float3 gradient_voxel(VOLUME_DATA_PARAM, __global const VolumeGpu* v, float3 p) {
#ifdef SOMBRA_SOBEL
    float3 g = (float3)(0.0f);
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                /* weight of the smoothing taps: 1 at the corners of each face row, 2 at the centre */
                float wx = 2.0f - (float)abs(dx), wy = 2.0f - (float)abs(dy), wz = 2.0f - (float)abs(dz);
                float s = sample_density(volume_data, v, p + (float3)(dx, dy, dz));
                g += s * (float3)(dx * wy * wz, dy * wx * wz, dz * wx * wy);
            }
    return g * (1.0f / 32.0f);
#else
    float gx = sample_density(volume_data, v, p + (float3)(1, 0, 0)) - sample_density(volume_data, v, p - (float3)(1, 0, 0));
    float gy = sample_density(volume_data, v, p + (float3)(0, 1, 0)) - sample_density(volume_data, v, p - (float3)(0, 1, 0));
    float gz = sample_density(volume_data, v, p + (float3)(0, 0, 1)) - sample_density(volume_data, v, p - (float3)(0, 0, 1));
    return 0.5f * (float3)(gx, gy, gz);
#endif
}

/* World-space surface normal from the voxel-space gradient (g_world = Jᵀ g_voxel, J = the
 * world→voxel Jacobian), pointing towards lower density. Returns 0 where the gradient vanishes,
 * measured in transfer-function entries per voxel so that the threshold is unit-free. */
inline float3 normal_from_gradient(__global const VolumeGpu* v, float3 g_voxel) {
    if (length(g_voxel) * v->tf_domain_scale < 1e-3f) return (float3)(0.0f);
    float3 g = g_voxel.x * v->world_to_voxel[0].xyz + g_voxel.y * v->world_to_voxel[1].xyz +
               g_voxel.z * v->world_to_voxel[2].xyz;
    return -normalize(g);
}

#endif
