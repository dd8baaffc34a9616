/* sombra — local illumination: Phong with several lights and distance attenuation
 * (course slides "phongShading", "getAttenuation"; Knecht Eq. 3.8–3.9). */
#ifndef SOMBRA_SHADING_H
#define SOMBRA_SHADING_H
#include "shared/types.h"

/* Unit vector from p towards the light, and the light's intensity factor at p: distance
 * attenuation 1/(c + l·d + q·d²) for point and spot lights, times the spot cone's smooth edge. */
inline float light_incidence(__global const LightGpu* light, float3 p, float3* to_light) {
    if (light->type == SOMBRA_LIGHT_DIRECTIONAL) {
        *to_light = -light->direction.xyz;
        return 1.0f;
    }
    float3 d = light->position.xyz - p;
    float dist = length(d);
    *to_light = dist > 0.0f ? d / dist : (float3)(0.0f, 0.0f, 1.0f);
    float attenuation = 1.0f / (light->att_constant + dist * (light->att_linear + dist * light->att_quadratic));
    if (light->type == SOMBRA_LIGHT_SPOT) {
        float cos_angle = dot(-*to_light, light->direction.xyz);
        attenuation *= smoothstep(light->cos_outer, light->cos_inner, cos_angle);
    }
    return attenuation;
}

/* I_p = k_a i_a c + Σ_m f_m [k_d (L_m·N) c + k_s (R_m·V)^n] i_m · shadow_m  (Knecht Eq. 3.9).
 * N is made to face the viewer (gradients have no preferred side); N = 0 marks a vanishing
 * gradient, shaded as if lit head-on without a highlight (homogeneous media such as fog). The
 * shadow term is 1 until a shadow technique provides it. */
inline float3 phong_shade(__global const LightGpu* lights, uint light_count, float ambient_intensity,
                          float ka, float kd, float ks, float shininess, float3 color, float3 p,
                          float3 normal, float3 to_viewer) {
    float3 result = ka * ambient_intensity * color;
    bool has_normal = dot(normal, normal) > 0.0f;
    if (has_normal && dot(normal, to_viewer) < 0.0f) normal = -normal;
    for (uint m = 0; m < light_count; ++m) {
        float3 to_light;
        float incidence = light_incidence(&lights[m], p, &to_light);
        if (incidence <= 0.0f) continue;
        float3 lit;
        if (has_normal) {
            float n_dot_l = fmax(dot(normal, to_light), 0.0f);
            float3 reflected = 2.0f * dot(normal, to_light) * normal - to_light;
            float r_dot_v = fmax(dot(reflected, to_viewer), 0.0f);
            float highlight = n_dot_l > 0.0f && ks > 0.0f ? pow(r_dot_v, shininess) : 0.0f;
            lit = kd * n_dot_l * color + ks * highlight;
        } else {
            lit = kd * color;
        }
        float shadow = 1.0f;
        result += incidence * shadow * lit * lights[m].color.xyz;
    }
    return result;
}

#endif
