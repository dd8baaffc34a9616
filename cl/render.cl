/* sombra — camera pass: ray casting through homogeneous segments, classification, gradient,
 * Phong, front-to-back compositing (Knecht Eq. 3.10–3.11), early ray termination.
 * Defines: SOMBRA_USE_IMAGES (3D image atlas instead of a buffer), SOMBRA_SOBEL (Sobel
 * gradients), SOMBRA_SKIP_EMPTY (brick skipping), SOMBRA_HAS_LIGHTS (any light in the scene). */
#include "shared/types.h"
#include "shared/hash.h"
#include "volume_sample.h"
#include "shading.h"

typedef struct {
    float3 radiance;      /* I_acc */
    float transmittance;  /* t_acc */
    uint samples;
    float termination;
    float3 to_viewer;
    float ambient_intensity;
    uint light_count;
    __global const LightGpu* lights;
    __global const VolumeGpu* volumes;
    __global const float4* tf_tables;
} VisitState;

#include "traversal.h"

/* One sample of all active volumes: extinction-weighted blend of their shaded colours,
 * α = 1 − exp(−Σσ·Δ), then I_acc += I_p α t_acc; t_acc *= 1 − α (Knecht Eq. 3.10–3.11). */
bool visit_sample(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray, float t, float step, uint active) {
    float3 p = ray->origin + t * ray->dir;
    float sigma_sum = 0.0f;
    float3 color_sum = (float3)(0.0f);
    for (uint i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        if (!(active & (1u << i))) continue;
        __global const VolumeGpu* v = &state->volumes[i];
        float3 pv = ray->vox_origin[i] + t * ray->vox_dir[i];
        float4 rgb_sigma = classify(state->tf_tables, v, sample_density(volume_data, v, pv));
        state->samples += 1;
        if (rgb_sigma.w <= 0.0f) continue;
        float3 normal = (float3)(0.0f);
#ifdef SOMBRA_HAS_LIGHTS
        normal = normal_from_gradient(v, gradient_voxel(volume_data, v, pv));
#endif
        float3 shaded = phong_shade(state->lights, state->light_count, state->ambient_intensity, v->ambient,
                                    v->diffuse, v->specular, v->shininess, rgb_sigma.xyz, p, normal,
                                    state->to_viewer);
        sigma_sum += rgb_sigma.w;
        color_sum += rgb_sigma.w * shaded;
    }
    if (sigma_sum > 0.0f) {
        float alpha = 1.0f - exp(-sigma_sum * step);
        state->radiance += (color_sum / sigma_sum) * alpha * state->transmittance;
        state->transmittance *= 1.0f - alpha;
    }
    return state->transmittance > state->termination;
}

__kernel void render_camera(
    VOLUME_DATA_PARAM,
    __global const uchar* occupancy, __global const float4* tf_tables, __global const VolumeGpu* volumes,
    __global const LightGpu* lights, __global const CameraGpu* camera, __global float4* image,
    __global uint* sample_counts) {
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= camera->width || y >= camera->height) return;

    /* pinhole camera through the pixel centre */
    float sx = ((x + 0.5f) / camera->width) * 2.0f - 1.0f;
    float sy = 1.0f - ((y + 0.5f) / camera->height) * 2.0f;
    float3 dir = normalize(camera->forward.xyz + sx * camera->right.xyz + sy * camera->up.xyz);

    VolumeRay ray;
    make_volume_ray(&ray, volumes, camera->volume_count, camera->position.xyz, dir, 0.0f, INFINITY);

    VisitState state;
    state.radiance = (float3)(0.0f);
    state.transmittance = 1.0f;
    state.samples = 0;
    state.termination = camera->termination_transmittance;
    state.to_viewer = -dir;
    state.ambient_intensity = camera->ambient_intensity;
    state.light_count = camera->light_count;
    state.lights = lights;
    state.volumes = volumes;
    state.tf_tables = tf_tables;
    traverse_segments(volume_data, &state, &ray, volumes, camera->volume_count, occupancy,
                      sombra_pixel_jitter(x, y, camera->jitter_seed));

    float3 color = state.radiance + state.transmittance * camera->background.xyz;
    image[y * camera->width + x] = (float4)(color, 1.0f - state.transmittance);
    sample_counts[y * camera->width + x] = state.samples;
}
