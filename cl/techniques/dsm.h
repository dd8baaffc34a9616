/* sombra — shadow technique "dsm": deep shadow maps (Knecht Eq. 3.7, 4.18–4.19). The transmittance
 * to a light is 1 − V'(depth) of the view that covers the point (a point light's cube face, found
 * by projection), filtered bilinearly over the four nearest texels; points no view covers are
 * lit. The storage backend (dsm_storage.h) provides DSM_READ_PARAMS and the texel lookup; with
 * DSM_BINARY_LOOKUP (techniques/shadowmap.h) each texel is the binary shadow-map baseline.
 * Interface: techniques/technique.h. */
#ifndef SOMBRA_TECHNIQUE_DSM_H
#define SOMBRA_TECHNIQUE_DSM_H
#define SHADOW_TERM 1
#include "dsm_view.h"
#include "dsm_storage.h"

#define SHADOW_PARAMS , __global const DsmViewGpu *views, DSM_READ_PARAMS
typedef struct {
    __global const DsmViewGpu* views;
    DSM_READ_STATE_FIELDS
#ifdef DSM_HAS_SEARCH_HINTS
    DsmSearchHint hints[SOMBRA_LIGHT_SLOTS * 4]; /* per light and bilinear corner: the last node found */
#endif
} ShadowState;

inline void dsm_state_init(ShadowState* s) {
#ifdef DSM_HAS_SEARCH_HINTS
    for (int i = 0; i < SOMBRA_LIGHT_SLOTS * 4; ++i) s->hints[i].texel = (lint)(-1);
#endif
}
#define SHADOW_STATE_INIT(s) (s).views = views; DSM_READ_STATE_INIT(s); dsm_state_init(&(s));

/* α of one texel at depth z: V'(z) (Knecht Eq. 3.7), or with DSM_BINARY_LOOKUP the binary
 * shadow-map baseline: fully shadowed behind the depth where the texel's opacity reaches 1/2
 * (the depth a classic shadow map stores), lit before it. */
#ifdef DSM_HAS_SEARCH_HINTS
#define DSM_HINT_PARAM , DsmSearchHint* hint
#define DSM_HINT_ARG(h) , (h)
#define DSM_TEXEL_OPACITY(v, x, y, z) dsm_texel_opacity_hinted(DSM_READ_ARGS, v, x, y, z, hint)
#else
#define DSM_HINT_PARAM
#define DSM_HINT_ARG(h)
#define DSM_TEXEL_OPACITY(v, x, y, z) dsm_texel_opacity(DSM_READ_ARGS, v, x, y, z)
#endif
inline lfloat texel_attenuation(DSM_READ_PARAMS, __global const DsmViewGpu* v, lint x, lint y, lfloat z DSM_HINT_PARAM) {
    lfloat alpha = DSM_TEXEL_OPACITY(v, x, y, z);
#ifdef DSM_BINARY_LOOKUP
    alpha = select((lfloat)(0.0f), (lfloat)(1.0f), alpha >= 0.5f);
#endif
    return alpha;
}

inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint light_index, lfloat3 p,
                                   lmask lanes) {
    __global const LightGpu* light = &scene->lights[light_index];
#ifdef DSM_HAS_SEARCH_HINTS
    DsmSearchHint* hints = &s->hints[4 * light_index];
#endif
    lfloat alpha = (lfloat)(0.0f);
    lmask done = !lanes;
    for (uint i = 0; i < light->view_count; ++i) {
        __global const DsmViewGpu* v = &s->views[light->view_first + i];
        lfloat u, w, depth;
        lmask covered = dsm_view_project(v, p, &u, &w, &depth) & !done;
        if (!lany(covered)) continue;
        u = select((lfloat)(0.0f), u, covered); /* finite texel indices in every lane */
        w = select((lfloat)(0.0f), w, covered);
        lfloat u0 = floor(u), w0 = floor(w), fu = u - u0, fw = w - w0;
        int last = (int)v->resolution - 1;
        lint x0 = clamp(LCONVERT_INT(u0), 0, last), x1 = clamp(LCONVERT_INT(u0) + 1, 0, last);
        lint y0 = clamp(LCONVERT_INT(w0), 0, last), y1 = clamp(LCONVERT_INT(w0) + 1, 0, last);
        lfloat a00 = texel_attenuation(DSM_READ_ARGS_OF(s), v, x0, y0, depth DSM_HINT_ARG(&hints[0]));
        lfloat a10 = texel_attenuation(DSM_READ_ARGS_OF(s), v, x1, y0, depth DSM_HINT_ARG(&hints[1]));
        lfloat a01 = texel_attenuation(DSM_READ_ARGS_OF(s), v, x0, y1, depth DSM_HINT_ARG(&hints[2]));
        lfloat a11 = texel_attenuation(DSM_READ_ARGS_OF(s), v, x1, y1, depth DSM_HINT_ARG(&hints[3]));
        alpha = select(alpha, mix(mix(a00, a10, fu), mix(a01, a11, fu), fw), covered);
        done |= covered;
    }
    return 1.0f - alpha;
}
#endif
