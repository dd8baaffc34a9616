/* sombra — camera pass: ray casting through homogeneous segments, classification, gradient,
 * Phong, front-to-back compositing (Knecht Eq. 3.10–3.11), early ray termination. A work-item
 * renders SOMBRA_LANES neighbouring pixels of one row as a packet (lanes.h).
 * Defines: SOMBRA_LANES (1 on GPUs, 8 or 16 on CPUs), SOMBRA_USE_IMAGES (3D image atlas instead of
 * a buffer), SOMBRA_SOBEL (Sobel gradients), SOMBRA_SKIP_EMPTY (brick skipping),
 * SOMBRA_HAS_LIGHTS (any light in the scene). */
#include "shared/types.h"
#include "shared/hash.h"
#include "lanes.h"
#include "volume_sample.h"
#include "shading.h"

typedef struct {
    lfloat3 radiance;      /* I_acc */
    lfloat transmittance;  /* t_acc */
    luint samples;
    float termination;
    lfloat3 to_viewer;
    float ambient_intensity;
    uint light_count;
    __global const LightGpu* lights;
    __global const VolumeGpu* volumes;
    __global const float* tf_tables;
} VisitState;

#include "traversal.h"

/* One sample of all active volumes: extinction-weighted blend of their shaded colours,
 * α = 1 − exp(−Σσ·Δ), then I_acc += I_p α t_acc; t_acc *= 1 − α (Knecht Eq. 3.10–3.11). */
lmask visit_sample(VOLUME_DATA_PARAM, VisitState* state, const VolumeRay* ray, lfloat t, lfloat step, luint active,
                   lmask sampling) {
    t = select((lfloat)(0.0f), t, sampling); /* finite positions in idle lanes */
    lfloat3 p = l3_mad(ray->dir, t, ray->origin);
    lfloat sigma_sum = (lfloat)(0.0f);
    lfloat3 color_sum = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    for (uint i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        lmask here = sampling & ((active & (1u << i)) != 0u);
        if (!lany(here)) continue;
        __global const VolumeGpu* v = &state->volumes[i];
        lfloat3 pv = ray_voxel_point(ray, i, t);
        Classified c = classify(state->tf_tables, v, sample_density(volume_data, v, pv));
        state->samples += select((luint)(0u), (luint)(1u), here);
        lfloat sigma = select((lfloat)(0.0f), c.sigma, here);
        lmask visible = sigma > 0.0f;
        if (!lany(visible)) continue;
        lfloat3 normal = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
#ifdef SOMBRA_HAS_LIGHTS
        normal = normal_from_gradient(v, gradient_voxel(volume_data, v, pv));
#endif
        lfloat3 shaded = phong_shade(state->lights, state->light_count, state->ambient_intensity, v, c.color, p, normal,
                                     state->to_viewer);
        sigma_sum += sigma;
        color_sum = l3_mad(shaded, sigma, color_sum);
    }
    lmask lit = sigma_sum > 0.0f;
    lfloat alpha = 1.0f - exp(-sigma_sum * step);
    lfloat weight = select((lfloat)(0.0f), alpha * state->transmittance / select((lfloat)(1.0f), sigma_sum, lit), lit);
    state->radiance = l3_mad(color_sum, weight, state->radiance);
    state->transmittance = select(state->transmittance, state->transmittance * (1.0f - alpha), lit);
    return state->transmittance > state->termination;
}

__kernel void render_camera(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const float* tf_tables,
                            __global const VolumeGpu* volumes, __global const LightGpu* lights,
                            __global const CameraGpu* camera, __global float4* image, __global uint* sample_counts) {
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

    VisitState state;
    state.radiance = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    state.transmittance = (lfloat)(1.0f);
    state.samples = (luint)(0u);
    state.termination = camera->termination_transmittance;
    state.to_viewer = l3_scale(dir, (lfloat)(-1.0f));
    state.ambient_intensity = camera->ambient_intensity;
    state.light_count = camera->light_count;
    state.lights = lights;
    state.volumes = volumes;
    state.tf_tables = tf_tables;
#define SOMBRA_JITTER_LANE(c) sombra_pixel_jitter((uint)LC(xs, c), y, camera->jitter_seed)
    lfloat jitter = LFROM_LANES(SOMBRA_JITTER_LANE);
#undef SOMBRA_JITTER_LANE
    traverse_segments(volume_data, &state, &ray, volumes, camera->volume_count, occupancy, jitter, lanes);

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
