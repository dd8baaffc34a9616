/* sombra — shadow technique "dsm": deep shadow maps (Knecht Eq. 3.7, 4.18–4.19). The transmittance
 * to a light is 1 − V'(depth) of the view that covers the point (a point light's cube face, found
 * by projection), filtered bilinearly over the four nearest texels; points no view covers are
 * lit. Clustered maps (Knecht §3.4.4): a light's views come in clusters, each cluster's map holds
 * only its objects, and the transmittance is the product over the clusters (Eq. 3.12). The storage backend (dsm_storage.h) provides DSM_READ_PARAMS and the texel lookup; with
 * DSM_BINARY_LOOKUP (techniques/shadowmap.h) each texel is the binary shadow-map baseline.
 * Interface: techniques/technique.h. */
#ifndef SOMBRA_TECHNIQUE_DSM_H
#define SOMBRA_TECHNIQUE_DSM_H
#define SHADOW_TERM 1
#include "dsm_view.h"
#include "dsm_storage.h"

#define SHADOW_PARAMS , __global const DsmViewGpu *views, __global const DsmLightViews *light_views, DSM_READ_PARAMS
typedef struct {
    __global const DsmViewGpu* views;
    __global const DsmLightViews* light_views; /* per light: its views */
    DSM_READ_STATE_FIELDS
    /* per light, bilinear corner and lane: where the previous lookup found its node */
    DsmSearchHint hints[SOMBRA_LIGHT_SLOTS * 4][SOMBRA_LANES];
} ShadowState;

static inline void dsm_state_init(ShadowState* s) {
    for (int i = 0; i < SOMBRA_LIGHT_SLOTS * 4; ++i)
        for (int lane = 0; lane < SOMBRA_LANES; ++lane) s->hints[i][lane].texel = -1, s->hints[i][lane].node = 0;
}
#define SHADOW_STATE_INIT(s) (s).views = views; (s).light_views = light_views; DSM_READ_STATE_INIT(s); dsm_state_init(&(s));

/* α of one texel at depth z: V'(z) (Knecht Eq. 3.7), or with DSM_BINARY_LOOKUP the binary
 * shadow-map baseline: fully shadowed behind the depth where the texel's opacity reaches 1/2
 * (the depth a classic shadow map stores), lit before it. */
static inline float texel_attenuation(DSM_READ_PARAMS, __global const DsmViewGpu* v, int x, int y, float z, DsmSearchHint* hint) {
    float alpha = dsm_texel_opacity(DSM_READ_ARGS, v, x, y, z, hint);
#ifdef DSM_BINARY_LOOKUP
    alpha = alpha >= 0.5f ? 1.0f : 0.0f;
#endif
    return alpha;
}

static inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint light_index, lfloat3 p,
                                   lmask lanes) {
    const DsmLightViews light = s->light_views[light_index];
    DsmSearchHint (*hints)[SOMBRA_LANES] = &s->hints[4 * light_index];
    lfloat transmittance = (lfloat)(1.0f), alpha = (lfloat)(0.0f); /* alpha: of the current cluster */
    lmask done = !lanes;                                                 /* lanes the cluster's views covered */
    uint cluster = light.count > 0 ? s->views[light.first].cluster : 0u;
    for (uint i = 0; i < light.count; ++i) {
        __global const DsmViewGpu* v = &s->views[light.first + i];
        if (v->cluster != cluster) { /* the next cluster: Eq. 3.12, T = Π (1 − α_cluster) */
            transmittance *= 1.0f - alpha;
            alpha = (lfloat)(0.0f);
            done = !lanes;
            cluster = v->cluster;
        }
        if (!lany(!done)) continue;
        lfloat u, w, depth;
        lmask covered = dsm_view_project(v, p, &u, &w, &depth) & !done;
        if (!lany(covered)) continue;
        u = select((lfloat)(0.0f), u, covered); /* finite texel indices in every lane */
        w = select((lfloat)(0.0f), w, covered);
        lfloat u0 = floor(u), w0 = floor(w), fu = u - u0, fw = w - w0;
        int last = (int)v->resolution - 1;
        lint x0 = lclamp(LCONVERT_INT(u0), 0, last), x1 = lclamp(LCONVERT_INT(u0) + 1, 0, last);
        lint y0 = lclamp(LCONVERT_INT(w0), 0, last), y1 = lclamp(LCONVERT_INT(w0) + 1, 0, last);
        /* the four texels of each covered lane, one lane at a time (dsm_storage_common.h) */
        int cover_lane[SOMBRA_LANES], x0_lane[SOMBRA_LANES], x1_lane[SOMBRA_LANES], y0_lane[SOMBRA_LANES], y1_lane[SOMBRA_LANES];
        float z_lane[SOMBRA_LANES], a00[SOMBRA_LANES], a10[SOMBRA_LANES], a01[SOMBRA_LANES], a11[SOMBRA_LANES];
        LSTORE(covered, cover_lane);
        LSTORE(x0, x0_lane);
        LSTORE(x1, x1_lane);
        LSTORE(y0, y0_lane);
        LSTORE(y1, y1_lane);
        LSTORE(depth, z_lane);
        for (int lane = 0; lane < SOMBRA_LANES; ++lane) {
            a00[lane] = a10[lane] = a01[lane] = a11[lane] = 0.0f;
            if (!cover_lane[lane]) continue;
            float z = z_lane[lane];
            a00[lane] = texel_attenuation(DSM_READ_ARGS_OF(s), v, x0_lane[lane], y0_lane[lane], z, &hints[0][lane]);
            a10[lane] = texel_attenuation(DSM_READ_ARGS_OF(s), v, x1_lane[lane], y0_lane[lane], z, &hints[1][lane]);
            a01[lane] = texel_attenuation(DSM_READ_ARGS_OF(s), v, x0_lane[lane], y1_lane[lane], z, &hints[2][lane]);
            a11[lane] = texel_attenuation(DSM_READ_ARGS_OF(s), v, x1_lane[lane], y1_lane[lane], z, &hints[3][lane]);
        }
        alpha = select(alpha, mix(mix(LLOAD(a00), LLOAD(a10), fu), mix(LLOAD(a01), LLOAD(a11), fu), fw), covered);
        done |= covered;
    }
    return transmittance * (1.0f - alpha);
}
#endif
