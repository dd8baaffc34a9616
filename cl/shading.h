/* sombra — local illumination for a packet of samples: Phong with several lights and distance
 * attenuation (course slides "phongShading", "getAttenuation"; Knecht Eq. 3.8–3.9). */
#ifndef SOMBRA_SHADING_H
#define SOMBRA_SHADING_H
#include "shared/types.h"
#include "lanes.h"
#include "shared/phase.h"

/* Unit vectors from p towards the light, and the light's intensity factor at p: distance
 * attenuation 1/(c + l·d + q·d²) for point and spot lights, times the spot cone's smooth edge. */
static inline lfloat light_incidence(__global const LightGpu* light, lfloat3 p, lfloat3* to_light) {
    if (light->type == SOMBRA_LIGHT_DIRECTIONAL) {
        *to_light = l3_splat(-light->direction.xyz);
        return (lfloat)(1.0f);
    }
    lfloat3 d = l3_sub(l3_splat(light->position.xyz), p);
    lfloat dist = sqrt(l3_dot(d, d));
    lmask at_light = dist <= 0.0f;
    lfloat inv = 1.0f / select(dist, (lfloat)(1.0f), at_light);
    *to_light = l3_select(l3_scale(d, inv), l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(1.0f)), at_light);
    lfloat attenuation = 1.0f / (light->att_constant + dist * (light->att_linear + dist * light->att_quadratic));
    if (light->type == SOMBRA_LIGHT_SPOT) {
        lfloat cos_angle = -l3_dot_uniform(*to_light, light->direction.xyz);
        attenuation *= smoothstep(light->cos_outer, light->cos_inner, cos_angle);
    }
    return attenuation;
}

/* N turned to face the viewer (gradients have no preferred side): the side Eq. 3.9 lights. */
static inline lfloat3 normal_facing_viewer(lfloat3 normal, lfloat3 to_viewer) {
    return l3_select(normal, l3_scale(normal, (lfloat)(-1.0f)), l3_dot(normal, to_viewer) < 0.0f);
}

/* The lanes where a light's term can be non-zero, whatever its shadow: the light reaches p
 * (f_m > 0: inside a spot's cone) and, for Phong with a normal (`facing`, from
 * normal_facing_viewer; 0 = none), lies on the lit side (L·N > 0: else both k_d (L·N) and the
 * highlight are 0). Elsewhere the shading multiplies shadow_m by 0, so the pass need not find it
 * (Henyey–Greenstein's phase is positive in every direction: single scattering passes no normal). */
static inline lmask light_term_possible(__global const LightGpu* light, lfloat3 p, lfloat3 facing) {
    lfloat3 to_light;
    lfloat incidence = light_incidence(light, p, &to_light);
    lmask has_normal = l3_dot(facing, facing) > 0.0f;
    return (incidence > 0.0f) & (!has_normal | (l3_dot(facing, to_light) > 0.0f));
}

/* I_p = k_a i_a c + Σ_m f_m [k_d (L_m·N) c + k_s (R_m·V)^n] i_m · shadow_m  (Knecht Eq. 3.9).
 * N is made to face the viewer (gradients have no preferred side); N = 0 marks a vanishing
 * gradient, shaded as if lit head-on without a highlight (homogeneous media such as fog).
 * shadow[m] is the transmittance 1 − α_m from the sample to light m (Knecht Eq. 3.8). */
/* The coefficients per lane (surface fragments of several meshes share a packet). */
static inline lfloat3 phong_shade_lanes(__global const LightGpu* lights, uint light_count, float ambient_intensity, lfloat ka,
                                 lfloat kd, lfloat ks, lfloat shininess, lfloat3 color, lfloat3 p, lfloat3 normal,
                                 lfloat3 to_viewer, const lfloat* shadow) {
    lfloat3 result = l3_scale(color, ka * ambient_intensity);
    lmask has_normal = l3_dot(normal, normal) > 0.0f;
    normal = normal_facing_viewer(normal, to_viewer);
    for (uint m = 0; m < light_count; ++m) {
        lfloat3 to_light;
        lfloat incidence = light_incidence(&lights[m], p, &to_light);
        lfloat n_dot_l_signed = l3_dot(normal, to_light);
        lfloat n_dot_l = fmax(n_dot_l_signed, 0.0f);
        lfloat3 reflected = l3_sub(l3_scale(normal, 2.0f * n_dot_l_signed), to_light);
        lfloat r_dot_v = fmax(l3_dot(reflected, to_viewer), 0.0f);
        lfloat highlight = lany(ks > 0.0f) ? select((lfloat)(0.0f), pow(r_dot_v, shininess), n_dot_l > 0.0f)
                                           : (lfloat)(0.0f);
        lfloat diffuse = select(kd, kd * n_dot_l, has_normal); /* no normal: lit head-on */
        lfloat specular = select((lfloat)(0.0f), ks * highlight, has_normal);
        lfloat weight = incidence * shadow[m];
        result = l3_add(result, l3(weight * (diffuse * color.x + specular) * lights[m].color.x,
                                   weight * (diffuse * color.y + specular) * lights[m].color.y,
                                   weight * (diffuse * color.z + specular) * lights[m].color.z));
    }
    return result;
}

/* Single scattering with shadows (Ament et al. 2014 Eq. 1–3): the radiance a sample scatters
 * towards the viewer, per unit extinction, with albedo c (the transfer function's colour):
 * c [k_a i_a + Σ_m 4π p(θ_m) f_m i_m · shadow_m], p Henyey–Greenstein with asymmetry g. The phase
 * is scaled by 4π so that isotropic scattering has unit gain (as a head-on diffuse k_d = 1). */
static inline lfloat3 scatter_shade(__global const LightGpu* lights, uint light_count, float ambient_intensity, float g,
                             __global const VolumeGpu* material, lfloat3 color, lfloat3 p, lfloat3 to_viewer,
                             const lfloat* shadow) {
    lfloat gain = (lfloat)(material->ambient * ambient_intensity);
    lfloat3 light_sum = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    for (uint m = 0; m < light_count; ++m) {
        lfloat3 to_light;
        lfloat incidence = light_incidence(&lights[m], p, &to_light);
        lfloat cos_theta = -l3_dot(to_light, to_viewer); /* light travels along −to_light */
        lfloat weight = incidence * shadow[m] * (4.0f * M_PI_F) * SOMBRA_HG_PHASE(g, cos_theta);
        light_sum = l3_add(light_sum, l3(weight * lights[m].color.x, weight * lights[m].color.y, weight * lights[m].color.z));
    }
    return l3(color.x * (gain + light_sum.x), color.y * (gain + light_sum.y), color.z * (gain + light_sum.z));
}

static inline lfloat3 phong_shade(__global const LightGpu* lights, uint light_count, float ambient_intensity,
                           __global const VolumeGpu* material, lfloat3 color, lfloat3 p, lfloat3 normal,
                           lfloat3 to_viewer, const lfloat* shadow) {
    return phong_shade_lanes(lights, light_count, ambient_intensity, (lfloat)(material->ambient), (lfloat)(material->diffuse),
                             (lfloat)(material->specular), (lfloat)(material->shininess), color, p, normal, to_viewer,
                             shadow);
}

#endif
