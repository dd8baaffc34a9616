/* sombra — evaluates the sampling functions of volume_sample.h at given voxel positions, for the
 * tests that compare them with plain C++: density, classification, voxel gradient, normal. */
#include "volume_sample.h"

__kernel void sample_probe(VOLUME_DATA_PARAM, __global const float4* tf_tables, __global const VolumeGpu* volume,
                           __global const float4* points, __global float4* density_rgba_sigma,
                           __global float4* gradients, __global float4* normals) {
    size_t i = get_global_id(0);
    float3 p = points[i].xyz;
    float density = sample_density(volume_data, volume, p);
    float4 c = classify(tf_tables, volume, density);
    density_rgba_sigma[i] = (float4)(density, c.x, c.w, 0.0f);
    float3 g = gradient_voxel(volume_data, volume, p);
    gradients[i] = (float4)(g, 0.0f);
    normals[i] = (float4)(normal_from_gradient(volume, g), 0.0f);
}
