/* sombra — deep shadow map views: the ray of a texel (generation) and the texel position and depth
 * of a world point (lookup), with one depth convention for both (see DsmViewGpu). */
#ifndef SOMBRA_DSM_VIEW_H
#define SOMBRA_DSM_VIEW_H
#include "shared/types.h"
#include "shared/hash.h"
#include "lanes.h"

/* Ray through the point (ndc_x, ndc_y) ∈ [−1, 1]² of the view's image plane; t along it is the
 * view's depth (unit direction from the light, or from the near plane). */
static inline void dsm_view_ray(__global const DsmViewGpu* v, float ndc_x, float ndc_y, float3* origin, float3* dir) {
    float3 across = ndc_x * v->extent_x * v->axis_x.xyz + ndc_y * v->extent_y * v->axis_y.xyz;
    if (v->perspective) {
        *origin = v->origin.xyz;
        *dir = normalize(v->axis_z.xyz + across);
    } else {
        *origin = v->origin.xyz + across;
        *dir = v->axis_z.xyz;
    }
}

/* The ray of texel (x, y) of a generated map: the one place a texel's ray position is chosen (the
 * texel centre; shifted and jittered in pre-filtering's sub-pixel maps, see DsmViewGpu). */
static inline void dsm_texel_ray(__global const DsmViewGpu* v, uint x, uint y, float3* origin, float3* dir) {
    float res = (float)v->resolution;
    float px = sombra_texel_ray_coord(x, y, 0, v->ray_shift, v->jitter, v->jitter_seed);
    float py = sombra_texel_ray_coord(x, y, 1, v->ray_shift, v->jitter, v->jitter_seed);
    dsm_view_ray(v, (px / res) * 2.0f - 1.0f, (py / res) * 2.0f - 1.0f, origin, dir);
}

/* Continuous texel coordinates (texel centres at integers) and depth of points p; `covered` marks
 * the lanes whose point projects into the view (in front of a perspective view, inside the map). */
static inline lmask dsm_view_project(__global const DsmViewGpu* v, lfloat3 p, lfloat* u, lfloat* w, lfloat* depth) {
    lfloat3 d = l3_sub(p, l3_splat(v->origin.xyz));
    lfloat qx = l3_dot_uniform(d, v->axis_x.xyz), qy = l3_dot_uniform(d, v->axis_y.xyz);
    lfloat qz = l3_dot_uniform(d, v->axis_z.xyz);
    lfloat nx, ny;
    lmask covered;
    if (v->perspective) {
        lmask in_front = qz > 0.0f;
        lfloat inv = 1.0f / select((lfloat)(1.0f), qz, in_front);
        nx = qx * inv / v->extent_x;
        ny = qy * inv / v->extent_y;
        *depth = sqrt(l3_dot(d, d));
        covered = in_front;
    } else {
        nx = qx / v->extent_x;
        ny = qy / v->extent_y;
        *depth = qz;
        covered = (lmask)(-1) & (qz == qz); /* all lanes (true in every width) */
    }
    covered &= (fabs(nx) <= 1.0f) & (fabs(ny) <= 1.0f);
    float res = (float)v->resolution;
    *u = (nx * 0.5f + 0.5f) * res - 0.5f;
    *w = (ny * 0.5f + 0.5f) * res - 0.5f;
    return covered;
}

#endif
