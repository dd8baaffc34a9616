/* sombra — evaluates the sampling functions of volume_sample.h at given voxel positions, for the
 * tests that compare them with plain C++: density, classification, voxel gradient, normal. */
#include "volume_sample.h"

__kernel void sample_probe(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volume,
                           __global const float4* points, __global float4* density_rgba_sigma,
                           __global float4* gradients, __global float4* normals) {
    size_t i = get_global_id(0);
    float4 q = points[i];
    lfloat3 p = l3(q.x, q.y, q.z); /* built with SOMBRA_LANES = 1 */
    float density = sample_density(volume_data, volume, p);
    Classified c = classify(tf_tables, volume, density);
    density_rgba_sigma[i] = (float4)(density, c.color.x, c.sigma, 0.0f);
    lfloat3 g = gradient_voxel(volume_data, volume, p);
    gradients[i] = (float4)(g.x, g.y, g.z, 0.0f);
    lfloat3 n = normal_from_gradient(volume, g);
    normals[i] = (float4)(n.x, n.y, n.z, 0.0f);
}
