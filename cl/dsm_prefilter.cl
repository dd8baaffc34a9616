/* sombra — deep shadow map pre-filtering (Lokovic & Veach 2000; Hadwiger §3.1: "combining the
 * samples of multiple subpixel rays"): each texel's visibility is the weighted sum of the
 * visibility functions of the sub-pixel rays of a map generated at twice the resolution (2×2 rays
 * per texel; a box or tent kernel over them), merged exactly at the union of their nodes — a sum
 * of piecewise-linear functions is piecewise linear between those depths — and compressed again
 * with the same on-the-fly compressor into the chosen storage backend. The fine map is in compact
 * storage (read here directly: texel_first offsets + (depth, opacity) nodes). Same kernel names
 * as dsm_build.cl, so the storage backends run it unchanged:
 *   dsm_build  filtered texels into the backend's storage
 *   dsm_count  nodes per filtered texel only (SOMBRA_DSM_COUNT_ONLY)
 * Defines: SOMBRA_PREFILTER_TENT (4×4 tent kernel, weights 1 3 3 1 per axis; else the 2×2 box). */
#include "shared/types.h"
#include "lanes.h"
#include "dsm_generation.h"

#ifdef SOMBRA_PREFILTER_TENT
#define PREFILTER_SPAN 4 /* fine texels per axis: 2x − 1 … 2x + 2 */
#define PREFILTER_FIRST (-1)
__constant float prefilter_weight[4] = {1.0f, 3.0f, 3.0f, 1.0f};
#else
#define PREFILTER_SPAN 2 /* fine texels per axis: 2x, 2x + 1 */
#define PREFILTER_FIRST 0
__constant float prefilter_weight[2] = {1.0f, 1.0f};
#endif
#define PREFILTER_TAPS (PREFILTER_SPAN * PREFILTER_SPAN)


DSM_GENERATION_KERNEL(__global const DsmViewGpu* views, uint view_index, float epsilon, __global const DsmViewGpu* fine_views,
     __global const uint* fine_first, __global const float* fine_nodes, DSM_BUILD_STORAGE_PARAMS) {
    __global const DsmViewGpu* v = &views[view_index];
    __global const DsmViewGpu* fine = &fine_views[view_index];
    uint x = get_global_id(0), y = get_global_id(1);
    if (x >= v->resolution || y >= v->resolution) return;
    DSM_TEXELS_BEGIN(v, x, y, 1);
    /* the taps: fine texels under the kernel (clamped at the map's border), their node runs */
    uint next[PREFILTER_TAPS], end[PREFILTER_TAPS];
    float weight[PREFILTER_TAPS], z0[PREFILTER_TAPS], a0[PREFILTER_TAPS];
    float total = 0.0f;
    int last = (int)fine->resolution - 1;
    for (int j = 0; j < PREFILTER_SPAN; ++j)
        for (int i = 0; i < PREFILTER_SPAN; ++i) {
            int fx = clamp(2 * (int)x + PREFILTER_FIRST + i, 0, last), fy = clamp(2 * (int)y + PREFILTER_FIRST + j, 0, last);
            uint texel = fine->first_texel + (uint)fy * fine->resolution + (uint)fx, tap = j * PREFILTER_SPAN + i;
            next[tap] = fine_first[texel];
            end[tap] = fine_first[texel + 1];
            weight[tap] = prefilter_weight[i] * prefilter_weight[j];
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
        /* V(z) = Σ w V_t(z) / Σ w, each V_t by Knecht Eq. 3.7 */
        float v_sum = 0.0f;
        for (int t = 0; t < PREFILTER_TAPS; ++t) {
            if (next[t] < end[t] && fine_nodes[2 * next[t]] == z) { /* pass the node at z */
                z0[t] = z;
                a0[t] = fine_nodes[2 * next[t] + 1];
                next[t] += 1;
            }
            float value = a0[t];
            if (z0[t] == -INFINITY) value = 0.0f;
            else if (next[t] < end[t]) {
                float z1 = fine_nodes[2 * next[t]], a1 = fine_nodes[2 * next[t] + 1];
                value = mix(a0[t], a1, clamp((z - z0[t]) / fmax(z1 - z0[t], 1e-30f), 0.0f, 1.0f));
            }
            v_sum += weight[t] * clamp(value, 0.0f, 1.0f);
        }
        STORE_NODES(0, compressor_add(&compressor, z, v_sum / total, previous_z == -INFINITY ? z - fmax(fabs(z) * 1e-6f, 1e-6f) : previous_z));
        previous_z = z;
    }
    STORE_NODES(0, compressor_finish(&compressor));
    DSM_TEXELS_END(v, x, y, 1);
}
