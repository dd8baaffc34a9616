/* sombra — deep shadow map pre-filtering (Lokovic & Veach 2000 §5.1; Hadwiger §3.1: "combining the
 * samples of multiple subpixel rays"): each texel's visibility is the weighted sum of the
 * visibility functions of its taps in the sub-pixel maps (shared/prefilter.h: positions and
 * weights), merged exactly at the union of their nodes — a sum of piecewise-linear functions is
 * piecewise linear between those depths — and compressed again with the same on-the-fly
 * compressor into the chosen storage backend. The sub-pixel maps are in compact storage (read here
 * directly: texel_first offsets + (depth, opacity) nodes), `sub_maps` of them per view, in order.
 * Same kernel names as dsm_build.cl, so the storage backends run it unchanged:
 *   dsm_build  filtered texels into the backend's storage
 *   dsm_count  nodes per filtered texel only (SOMBRA_DSM_COUNT_ONLY)
 * Defines: SOMBRA_PREFILTER_TENT or SOMBRA_PREFILTER_5TAP select the taps (else the 2×2 box). */
#include "shared/types.h"
#include "shared/prefilter.h"
#include "shared/dsm_value.h"
#include "lanes.h"
#include "dsm_generation.h"

#if defined(SOMBRA_PREFILTER_TENT)
__constant int prefilter_taps[][4] = SOMBRA_PREFILTER_TENT_TAPS;
#elif defined(SOMBRA_PREFILTER_5TAP)
__constant int prefilter_taps[][4] = SOMBRA_PREFILTER_5TAP_TAPS;
#else
__constant int prefilter_taps[][4] = SOMBRA_PREFILTER_BOX_TAPS;
#endif
#define PREFILTER_TAPS ((int)(sizeof(prefilter_taps) / sizeof(prefilter_taps[0])))

/* A tap's V at depth z ≥ its last passed node (z0, a0) (z0 = −∞: none passed, V = 0), linear
 * towards its next node (fine_nodes[next], if next < end), as an opacity in [0, 1] (the nodes'
 * values are opacities or optical depths: shared/dsm_value.h). */
static inline float prefilter_tap_value(__global const float* fine_nodes, uint next, uint end, float z0, float a0, float z) {
    float value = a0;
    if (z0 == -INFINITY) value = 0.0f;
    else if (next < end) {
        float z1 = fine_nodes[2 * next], a1 = fine_nodes[2 * next + 1];
        value = mix(a0, a1, clamp((z - z0) / fmax(z1 - z0, 1e-30f), 0.0f, 1.0f));
    }
    return DSM_NODE_OPACITY(value);
}


DSM_GENERATION_KERNEL(__global const DsmViewGpu* views, uint view_index, float epsilon, __global const DsmViewGpu* sub_views,
     uint sub_maps, uint sub_scale, __global const uint* fine_texel_first, __global const float* fine_nodes, DSM_BUILD_STORAGE_PARAMS) {
    __global const DsmViewGpu* v = &views[view_index];
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= v->resolution || y >= v->resolution) return;
    DSM_TEXELS_BEGIN(v, x, y, 1);
    /* the taps: sub-map texels under the kernel (clamped at the map's border), their node runs */
    uint next[PREFILTER_TAPS], end[PREFILTER_TAPS];
    float weight[PREFILTER_TAPS], z0[PREFILTER_TAPS], a0[PREFILTER_TAPS];
    float total = 0.0f;
    for (int tap = 0; tap < PREFILTER_TAPS; ++tap) {
        __global const DsmViewGpu* sub = &sub_views[view_index * sub_maps + prefilter_taps[tap][0]];
        int last = (int)sub->resolution - 1;
        int fx = clamp((int)(sub_scale * x) + prefilter_taps[tap][1], 0, last);
        int fy = clamp((int)(sub_scale * y) + prefilter_taps[tap][2], 0, last);
        uint texel = sub->first_texel + (uint)fy * sub->resolution + (uint)fx;
        next[tap] = fine_texel_first[texel];
        end[tap] = fine_texel_first[texel + 1];
        weight[tap] = (float)prefilter_taps[tap][3];
        z0[tap] = -INFINITY; /* no node passed yet: V = 0 */
        a0[tap] = 0.0f;
        total += weight[tap];
    }

    VisibilityCompressor compressor;
    compressor_init(&compressor, epsilon);
    float previous_z = -INFINITY;
    for (;;) {
        /* next depth of the union of the taps' nodes */
        float z = INFINITY;
        for (int t = 0; t < PREFILTER_TAPS; ++t)
            if (next[t] < end[t]) z = fmin(z, fine_nodes[2 * next[t]]);
        if (!(z < INFINITY)) break;
        /* V just before z and at z, Σ w V_t / Σ w, each V_t by Knecht Eq. 3.7. A tap with two nodes
         * at z (a surface's vertical step, dsm_build.cl) jumps there: so does the sum. */
        float before_sum = 0.0f, after_sum = 0.0f;
        int jump = 0;
        for (int t = 0; t < PREFILTER_TAPS; ++t) {
            before_sum += weight[t] * prefilter_tap_value(fine_nodes, next[t], end[t], z0[t], a0[t], z);
            for (int passed = 0; next[t] < end[t] && fine_nodes[2 * next[t]] == z; ++passed) { /* pass the nodes at z */
                float a = fine_nodes[2 * next[t] + 1];
                jump |= passed > 0 && a != a0[t];
                z0[t] = z;
                a0[t] = a;
                next[t] += 1;
            }
            after_sum += weight[t] * prefilter_tap_value(fine_nodes, next[t], end[t], z0[t], a0[t], z);
        }
        if (jump) { /* a vertical step, never smoothed away (as in generation) */
            STORE_NODES(0, compressor_flush(&compressor));
            STORE_NODES(0, compressor_step(&compressor, z, DSM_NODE_VALUE(before_sum / total), DSM_NODE_VALUE(after_sum / total)));
        } else {
            STORE_NODES(0, compressor_add(&compressor, z, DSM_NODE_VALUE(after_sum / total),
                                          previous_z == -INFINITY ? z - fmax(fabs(z) * 1e-6f, 1e-6f) : previous_z));
        }
        previous_z = z;
    }
    STORE_NODES(0, compressor_finish(&compressor));
    DSM_TEXELS_END(v, x, y, 1);
}
