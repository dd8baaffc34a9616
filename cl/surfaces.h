/* sombra — translucent surfaces in the camera pass (issue 4; Knecht §3.1, docs/architecture.md "Data flow"):
 * each pixel's surface fragments (geometry/fragments.h: depth along the camera ray, sorted near to
 * far) bound its segments; the segment cursor (traversal.h) hands each one over at its depth, in
 * order with the volume samples, and it is composited front to back. Colour: Phong with the
 * normal interpolated over the triangle (turned to the viewer) and the mesh's material, times each
 * light's shadow term at the surface point (the same function volume samples use); α: the
 * material's opacity. Bound fragments (SOMBRA_TRI_BOUND) never reach it: the cursor keeps them.
 * With SOMBRA_SURFACE_SHADOW_CACHE the shadow term is interpolated from the surface shadow cache
 * (per light at a barycentric lattice on each triangle, filled by render.cl
 * surface_shadow_cache_fill at surface_shadow_lookup's point) instead of evaluated per fragment.
 * Included by render.cl after CameraState and light_transmittance() with SOMBRA_HAS_MESHES. */
#ifndef SOMBRA_SURFACES_H
#define SOMBRA_SURFACES_H

#define SURFACE_PARAMS                                                                                   \
    __global const uint *fragment_first, __global const FragmentGpu *fragments,                         \
        __global const ScreenTriangleGpu *screen_triangles, __global const SurfaceTriangleGpu *surface_triangles, \
        __global const SurfaceMaterialGpu *surface_materials, __global const float *surface_bias
#define SURFACE_ARGS fragment_first, fragments, screen_triangles, surface_triangles, surface_materials, surface_bias

/* Where the shadow term of light `light` is looked up for surface point p with unit normal n: a
 * little off the surface on the light's side, so that the surface's own step in the deep shadow
 * map does not shadow it: bias ∝ `distance`, the light's reach over the scene (surface_bias: the
 * scene box's diagonal, or a positional light's distance to its farthest corner, to which its map's
 * texels are proportional; not the camera distance, which a camera move would change), scaled by
 * 1/|cos θ| (θ: incidence; capped at 5×), since at grazing light the neighbouring texels that the
 * bilinear lookup reads hold the surface's step at depths further apart. The per-fragment
 * evaluation and the surface cache's fill both look up here, so the cache holds at its points
 * what a fragment there evaluates. */
static inline lfloat3 surface_shadow_lookup(__global const LightGpu* light, lfloat3 p, lfloat3 normal, lfloat distance) {
    lfloat3 to_light;
    light_incidence(light, p, &to_light);
    lfloat cos_incidence = l3_dot(normal, to_light);
    lfloat bias = 2e-3f * distance / fmax(fabs(cos_incidence), 0.2f) * select((lfloat)(1.0f), (lfloat)(-1.0f), cos_incidence < 0.0f);
    return l3_mad(normal, bias, p);
}

#ifdef SOMBRA_SURFACE_SHADOW_CACHE
/* Lane c's cached shadow term of every light at barycentric point (v, w) of source triangle
 * `source`: linear over the cell of the triangle's lattice (SurfaceShadowCache: k intervals per
 * edge, point (i, j) at weights (1 − (i + j)/k, i/k, j/k)) that holds it; k = 1 reads the corners
 * with the normal's weights. */
static inline void surface_cache_read(const CameraState* state, uint source, float v, float w, float cached[][SOMBRA_LANES], int c) {
    uint first = state->surface_cache_triangles[2 * source], k = state->surface_cache_triangles[2 * source + 1];
    float a = v * (float)k, b = w * (float)k;
    int j0 = min((int)floor(b), (int)k - 1);
    int i0 = clamp((int)floor(a), 0, (int)k - 1 - j0);
    float fa = a - (float)i0, fb = b - (float)j0;
#define LATTICE_POINT(i, j) (first + (uint)(j) * (k + 1u) - (uint)(j) * (uint)((j) - 1) / 2u + (uint)(i))
    uint p0, p1, p2;
    float w0, w1, w2;
    if (fa + fb > 1.0f && i0 + j0 + 2 <= (int)k) { /* the cell's upper triangle */
        p0 = LATTICE_POINT(i0 + 1, j0 + 1), p1 = LATTICE_POINT(i0, j0 + 1), p2 = LATTICE_POINT(i0 + 1, j0);
        w0 = fa + fb - 1.0f, w1 = 1.0f - fa, w2 = 1.0f - fb;
    } else {
        p0 = LATTICE_POINT(i0, j0), p1 = LATTICE_POINT(i0 + 1, j0), p2 = LATTICE_POINT(i0, j0 + 1);
        w0 = 1.0f - fa - fb, w1 = fa, w2 = fb;
    }
#undef LATTICE_POINT
    uint lights = state->scene.camera->light_count;
    __global const float* values = state->surface_shadow_cache;
    for (uint m = 0; m < lights; ++m)
        cached[m][c] = w0 * values[p0 * lights + m] + w1 * values[p1 * lights + m] + w2 * values[p2 * lights + m];
}
#endif

/* Composites, in lanes `lanes`, the surface fragment the segment cursor handed over
 * (cursor->surface_fragment: Knecht §3.1.2, a surface lies on a segment boundary). */
static inline void composite_surface(VOLUME_DATA_PARAM, CameraState* state, const SegmentCursor* cursor, const VolumeRay* ray,
                              __global const SurfaceTriangleGpu* surface_triangles,
                              __global const SurfaceMaterialGpu* surface_materials, __global const float* surface_bias,
                              lmask lanes) {
    float ox[SOMBRA_LANES], oy[SOMBRA_LANES], oz[SOMBRA_LANES];
    float dx[SOMBRA_LANES], dy[SOMBRA_LANES], dz[SOMBRA_LANES];
    LSTORE(ray->origin.x, ox), LSTORE(ray->origin.y, oy), LSTORE(ray->origin.z, oz);
    LSTORE(ray->dir.x, dx), LSTORE(ray->dir.y, dy), LSTORE(ray->dir.z, dz);
    int take[SOMBRA_LANES];
    LSTORE(lanes, take);
    {
        /* per lane: its fragment's material and normal, gathered into lane vectors */
        float depth[SOMBRA_LANES], opacity[SOMBRA_LANES], ka[SOMBRA_LANES], kd[SOMBRA_LANES], ks[SOMBRA_LANES];
        float shininess[SOMBRA_LANES], cr[SOMBRA_LANES], cg[SOMBRA_LANES], cb[SOMBRA_LANES];
        float nx[SOMBRA_LANES], ny[SOMBRA_LANES], nz[SOMBRA_LANES];
#ifdef SOMBRA_SURFACE_SHADOW_CACHE
        float cached[SOMBRA_LIGHT_SLOTS][SOMBRA_LANES];
        for (uint m = 0; m < SOMBRA_LIGHT_SLOTS; ++m)
            for (int c = 0; c < SOMBRA_LANES; ++c) cached[m][c] = 1.0f;
#endif
        for (int c = 0; c < SOMBRA_LANES; ++c) {
            depth[c] = 0.0f, opacity[c] = 0.0f, ka[c] = kd[c] = ks[c] = 0.0f, shininess[c] = 1.0f;
            cr[c] = cg[c] = cb[c] = 0.0f, nx[c] = ny[c] = nz[c] = 0.0f;
            if (!take[c]) continue;
            FragmentGpu f = cursor->fragments[cursor->surface_fragment[c]];
            __global const ScreenTriangleGpu* st = &cursor->screen[f.triangle];
            __global const SurfaceTriangleGpu* tri = &surface_triangles[st->source];
            __global const SurfaceMaterialGpu* m = &surface_materials[st->mesh];
            depth[c] = f.depth;
            opacity[c] = m->color.w;
            cr[c] = m->color.x, cg[c] = m->color.y, cb[c] = m->color.z;
            ka[c] = m->ambient, kd[c] = m->diffuse, ks[c] = m->specular, shininess[c] = m->shininess;
            /* barycentric coordinates of the fragment's point in the triangle's plane */
            float3 q = (float3)(ox[c], oy[c], oz[c]) + f.depth * (float3)(dx[c], dy[c], dz[c]) - tri->corner.xyz;
            float3 e1 = tri->corner1.xyz - tri->corner.xyz, e2 = tri->corner2.xyz - tri->corner.xyz;
            float d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2), d20 = dot(q, e1), d21 = dot(q, e2);
            float denom = d00 * d11 - d01 * d01;
            float v = denom != 0.0f ? clamp((d11 * d20 - d01 * d21) / denom, 0.0f, 1.0f) : 0.0f;
            float w = denom != 0.0f ? clamp((d00 * d21 - d01 * d20) / denom, 0.0f, 1.0f - v) : 0.0f;
            float3 n = (1.0f - v - w) * tri->normal[0].xyz + v * tri->normal[1].xyz + w * tri->normal[2].xyz;
            float len = length(n);
            n = len > 1e-12f ? n / len : normalize(cross(e1, e2));
            nx[c] = n.x, ny[c] = n.y, nz[c] = n.z;
#ifdef SOMBRA_SURFACE_SHADOW_CACHE
            surface_cache_read(state, st->source, v, w, cached, c);
#endif
        }
        lmask here = LLOAD(take);
        lfloat t = LLOAD(depth);
        lfloat3 p = l3_mad(ray->dir, t, ray->origin);
        uint light_count = state->scene.camera->light_count;
        lfloat shadow[SOMBRA_LIGHT_SLOTS];
        lfloat3 normal = l3(LLOAD(nx), LLOAD(ny), LLOAD(nz));
#if SHADOW_TERM && !defined(SOMBRA_SURFACE_SHADOW_CACHE)
        lfloat3 facing = normal_facing_viewer(normal, state->to_viewer);
#endif
        for (uint m = 0; m < light_count; ++m) {
#if SHADOW_TERM && defined(SOMBRA_SURFACE_SHADOW_CACHE)
            shadow[m] = select((lfloat)(1.0f), LLOAD(cached[m]), here);
#elif SHADOW_TERM
            /* only where the light's term can be non-zero (shading.h) */
            lmask lit = here & light_term_possible(&state->scene.lights[m], p, facing);
            shadow[m] = (lfloat)(1.0f);
            if (lany(lit)) {
                lfloat3 lookup = surface_shadow_lookup(&state->scene.lights[m], p, normal, (lfloat)(surface_bias[m]));
                shadow[m] = select((lfloat)(1.0f), light_transmittance(volume_data, state, m, lookup, lit), lit);
            }
#else
            shadow[m] = (lfloat)(1.0f);
#endif
        }
        lfloat3 shaded = phong_shade_lanes(state->scene.lights, light_count, state->scene.camera->ambient_intensity, LLOAD(ka),
                                           LLOAD(kd), LLOAD(ks), LLOAD(shininess), l3(LLOAD(cr), LLOAD(cg), LLOAD(cb)), p,
                                           normal, state->to_viewer, shadow);
        lfloat alpha = select((lfloat)(0.0f), LLOAD(opacity), here);
        state->radiance = l3_mad(shaded, alpha * state->transmittance, state->radiance);
        state->transmittance *= 1.0f - alpha;
    }
}

#endif
