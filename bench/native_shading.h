// sombra bench — one point of the camera pass in C++: trilinear density, transfer function,
// pre-integrated extinction, central-difference gradient, normal, Phong (cl/volume_sample.h,
// cl/shading.h). Every function is
// inline and branch-light so that the SIMD path can call it inside `#pragma omp simd` loops; the
// scalar path calls the very same functions, so both compute the same thing per point.
#pragma once
#include <algorithm>
#include <cmath>

#include "native_traversal.h"

namespace sombra::bench {

// Inlined everywhere: a call left in an `omp simd` loop body keeps its V3 arguments in memory.
#define SOMBRA_BENCH_INLINE inline __attribute__((always_inline))

// One volume as the sample math reads it (fields of VolumeGpu, pointers into host copies).
struct VolumeView {
    const float* voxels;       // this volume's voxels, x fastest
    int nx, ny, nz;            // dims
    const float* tf;           // r, g, b, σ per table entry
    const float* sigma_prefix; // ∫σ du up to each entry as (hi, lo) float pairs (VolumeGpu::tf_integral_offset)
    int tf_size;
    float tf_min, tf_scale;
    V3 j0, j1, j2;             // rows of the world → voxel Jacobian J
    float ka, kd, ks, shininess;  // Phong material (Knecht Eq. 3.8)
};

struct LightView {
    int type;  // SOMBRA_LIGHT_*
    V3 position, direction, color;
    float cos_outer, cos_inner, att_constant, att_linear, att_quadratic;
};

SOMBRA_BENCH_INLINE float mix(float a, float b, float t) { return a + (b - a) * t; }  // OpenCL mix()
SOMBRA_BENCH_INLINE float clampf(float x, float lo, float hi) { return std::fmin(std::fmax(x, lo), hi); }
SOMBRA_BENCH_INLINE float length(V3 v) { return std::sqrt(dot(v, v)); }
// c ? a : b per component (a struct-valued ?: would put the V3 in memory and stop the vectoriser).
SOMBRA_BENCH_INLINE V3 select(bool c, V3 a, V3 b) { return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z}; }

// Trilinear density at voxel position p (voxel centres at integers), clamped to the edge.
SOMBRA_BENCH_INLINE float sample_density(const VolumeView& v, V3 p) {
    float px = clampf(p.x, 0.0f, float(v.nx - 1)), py = clampf(p.y, 0.0f, float(v.ny - 1)),
          pz = clampf(p.z, 0.0f, float(v.nz - 1));
    float bx = std::floor(px), by = std::floor(py), bz = std::floor(pz);
    float fx = px - bx, fy = py - by, fz = pz - bz;
    int x0 = int(bx), y0 = int(by), z0 = int(bz);  // 32-bit indices: 8-wide gathers on AVX2
    int x1 = std::min(x0 + 1, v.nx - 1), y1 = std::min(y0 + 1, v.ny - 1), z1 = std::min(z0 + 1, v.nz - 1);
    int sy = v.nx, sz = v.nx * v.ny;
    const float* d = v.voxels;
    float c00 = mix(d[x0 + y0 * sy + z0 * sz], d[x1 + y0 * sy + z0 * sz], fx);
    float c10 = mix(d[x0 + y1 * sy + z0 * sz], d[x1 + y1 * sy + z0 * sz], fx);
    float c01 = mix(d[x0 + y0 * sy + z1 * sz], d[x1 + y0 * sy + z1 * sz], fx);
    float c11 = mix(d[x0 + y1 * sy + z1 * sz], d[x1 + y1 * sy + z1 * sz], fx);
    return mix(mix(c00, c10, fy), mix(c01, c11, fy), fz);
}

// Transfer function colour: linear interpolation in the table of (r, g, b, σ) (classify(); the
// camera pass takes σ pre-integrated over the interval instead, preintegrated_sigma()).
SOMBRA_BENCH_INLINE V3 classify_color(const VolumeView& v, float density) {
    float u = clampf((density - v.tf_min) * v.tf_scale, 0.0f, float(v.tf_size - 1));
    int i0 = std::min(int(u), v.tf_size - 2);
    float f = u - float(i0);
    int e = 4 * i0;  // entry i0, then i0 + 1; plain indices so that the loads become gathers
    return {mix(v.tf[e], v.tf[e + 4], f), mix(v.tf[e + 1], v.tf[e + 5], f), mix(v.tf[e + 2], v.tf[e + 6], f)};
}

// σ of the table at entry coordinate u in [0, size − 1] (linear between entries).
SOMBRA_BENCH_INLINE float table_sigma(const VolumeView& v, float u) {
    int i0 = std::min(int(u), v.tf_size - 2);
    int e = 4 * i0;
    return mix(v.tf[e + 3], v.tf[e + 7], u - float(i0));
}

// preintegrated_sigma() of cl/volume_sample.h: the mean σ over an interval along which the density
// runs linearly from d_front to d_back (σ linear between entries, constant beyond both ends): σ at
// the middle within one entry cell; across cells the partial cells at both ends plus the whole
// cells between them from the prefix sums, plus the clamped parts. Branch-free (selects) for
// `omp simd`; equal densities give classify()'s σ.
SOMBRA_BENCH_INLINE float preintegrated_sigma(const VolumeView& v, float d_front, float d_back) {
    float last = float(v.tf_size - 1);
    float ua = (std::fmin(d_front, d_back) - v.tf_min) * v.tf_scale;
    float ub = (std::fmax(d_front, d_back) - v.tf_min) * v.tf_scale;
    float a = clampf(ua, 0.0f, last), b = clampf(ub, 0.0f, last);
    int ia = std::min(int(a), v.tf_size - 2), ib = std::min(int(b), v.tf_size - 2);
    float mid_sigma = table_sigma(v, 0.5f * (a + b));
    bool one_cell = ia == ib;
    bool simple = one_cell && ua == a && ub == b;  // no clamped part either: the mean is mid_sigma
    float a_end = float(ia + 1), b_start = float(ib);
    const float* prefix = v.sigma_prefix;
    float whole = (prefix[2 * ib] - prefix[2 * (ia + 1)]) + (prefix[2 * ib + 1] - prefix[2 * (ia + 1) + 1]);
    float across = (a_end - a) * table_sigma(v, 0.5f * (a + a_end)) + (b - b_start) * table_sigma(v, 0.5f * (b_start + b)) +
                   whole;
    float inside = one_cell ? (b - a) * mid_sigma : across;
    float below = std::fmax(std::fmin(ub, 0.0f) - ua, 0.0f), above = std::fmax(ub - std::fmax(ua, last), 0.0f);
    float integral = below * v.tf[3] + above * v.tf[4 * (v.tf_size - 1) + 3] + inside;
    float width = ub - ua;
    bool interval = width > 0.0f;
    return interval && !simple ? integral / (interval ? width : 1.0f) : mid_sigma;
}

// Central differences in voxel space (the renderer's default GradientMethod).
SOMBRA_BENCH_INLINE V3 gradient_voxel(const VolumeView& v, V3 p) {
    float gx = sample_density(v, {p.x + 1.0f, p.y, p.z}) - sample_density(v, {p.x - 1.0f, p.y, p.z});
    float gy = sample_density(v, {p.x, p.y + 1.0f, p.z}) - sample_density(v, {p.x, p.y - 1.0f, p.z});
    float gz = sample_density(v, {p.x, p.y, p.z + 1.0f}) - sample_density(v, {p.x, p.y, p.z - 1.0f});
    return 0.5f * V3{gx, gy, gz};
}

// World normal: g_world = Jᵀ g_voxel, pointing to lower density; 0 where the gradient vanishes
// (below 1e-3 transfer-function entries per voxel).
SOMBRA_BENCH_INLINE V3 normal_from_gradient(const VolumeView& v, V3 g_voxel) {
    V3 g = g_voxel.x * v.j0 + g_voxel.y * v.j1 + g_voxel.z * v.j2;
    V3 n = (-1.0f / length(g)) * g;
    bool vanishes = length(g_voxel) * v.tf_scale < 1e-3f;
    return select(vanishes, V3{0, 0, 0}, n);
}

// Phong needs N facing the viewer (gradients have no preferred side).
SOMBRA_BENCH_INLINE V3 face_viewer(V3 normal, V3 to_viewer) { return select(dot(normal, to_viewer) < 0.0f, -normal, normal); }

SOMBRA_BENCH_INLINE float smoothstep(float e0, float e1, float x) {
    float t = clampf((x - e0) / (e1 - e0), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

// One term of the sum in Knecht Eq. 3.9 for light m of type Type:
// f_m [k_d (L_m·N) c + k_s (R_m·V)^n] i_m, shadow = 1. f_m = attenuation 1/(c + l·d + q·d²) for
// point and spot lights, times the spot cone's smooth edge (light_incidence()). N = 0: lit head-on
// without a highlight. Written with selects instead of branches so that it vectorises.
template <int Type>
SOMBRA_BENCH_INLINE V3 light_term(const LightView& light, const VolumeView& v, V3 color, V3 p, V3 normal, V3 to_viewer) {
    V3 to_light;
    float incidence = 1.0f;
    if constexpr (Type == SOMBRA_LIGHT_DIRECTIONAL) {
        to_light = -light.direction;
    } else {
        V3 d = light.position - p;
        float dist = length(d);
        to_light = select(dist > 0.0f, (1.0f / dist) * d, V3{0, 0, 1});
        incidence = 1.0f / (light.att_constant + dist * (light.att_linear + dist * light.att_quadratic));
        if constexpr (Type == SOMBRA_LIGHT_SPOT)
            incidence *= smoothstep(light.cos_outer, light.cos_inner, dot(-to_light, light.direction));
    }
    bool has_normal = dot(normal, normal) > 0.0f;
    float n_dot_l_raw = dot(normal, to_light);
    float n_dot_l = std::fmax(n_dot_l_raw, 0.0f);
    V3 reflected = (2.0f * n_dot_l_raw) * normal - to_light;
    float r_dot_v = std::fmax(dot(reflected, to_viewer), 0.0f);
    float power = std::pow(r_dot_v, v.shininess);
    float highlight = n_dot_l > 0.0f && v.ks > 0.0f ? power : 0.0f;
    float diffuse = has_normal ? v.kd * n_dot_l : v.kd;
    float specular = has_normal ? v.ks * highlight : 0.0f;
    V3 lit = diffuse * color + V3{specular, specular, specular};
    float f = incidence > 0.0f ? incidence : 0.0f;
    return f * (lit * light.color);
}

// Ambient term of Knecht Eq. 3.9: k_a i_a c.
SOMBRA_BENCH_INLINE V3 ambient_term(const VolumeView& v, float ambient_intensity, V3 color) {
    return (v.ka * ambient_intensity) * color;
}

// I_p of Knecht Eq. 3.9 for one sample, all lights (scalar path; the SIMD path loops over
// lights outside its lane loop and calls light_term directly).
SOMBRA_BENCH_INLINE V3 phong_shade(const LightView* lights, unsigned light_count, float ambient_intensity, const VolumeView& v,
                      V3 color, V3 p, V3 normal, V3 to_viewer) {
    V3 result = ambient_term(v, ambient_intensity, color);
    normal = face_viewer(normal, to_viewer);
    for (unsigned m = 0; m < light_count; ++m) {
        const LightView& l = lights[m];
        if (l.type == SOMBRA_LIGHT_DIRECTIONAL) result = result + light_term<SOMBRA_LIGHT_DIRECTIONAL>(l, v, color, p, normal, to_viewer);
        else if (l.type == SOMBRA_LIGHT_SPOT) result = result + light_term<SOMBRA_LIGHT_SPOT>(l, v, color, p, normal, to_viewer);
        else result = result + light_term<SOMBRA_LIGHT_POINT>(l, v, color, p, normal, to_viewer);
    }
    return result;
}

}  // namespace sombra::bench
