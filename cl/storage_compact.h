/* sombra — "compact" deep shadow map storage: per texel a run of nodes (depth, opacity) in one
 * array, located by a per-texel offset table (the lookup texture of Knecht Eq. 4.13–4.17, built
 * by counting first and allocating with a prefix sum, so nothing is wasted). Functions:
 *   dsm_texel_opacity(...)  the texel's V'(z) at depth z (Knecht Eq. 3.7), binary search. */
#ifndef SOMBRA_STORAGE_COMPACT_H
#define SOMBRA_STORAGE_COMPACT_H
#include "lanes.h"

#define DSM_STORAGE_PARAMS __global const uint* restrict texel_first, __global const float* restrict nodes
#define DSM_STORAGE_ARGS texel_first, nodes

#if SOMBRA_LANES == 1
inline lint gather_uint_as_int(__global const uint* ptr, lint idx) { return (int)ptr[idx]; }
#else
inline lint gather_uint_as_int(__global const uint* ptr, lint idx) {
#define SOMBRA_GATHER_UINT_LANE(c) (int)ptr[LC(idx, c)]
    return LFROM_LANES_AS(lint, SOMBRA_GATHER_UINT_LANE);
#undef SOMBRA_GATHER_UINT_LANE
}
#endif

/* V'(z) of texels `texel` (one per lane): 0 before the first node, the last node's opacity
 * after the last, linear in between (Knecht Eq. 3.7); clamped to [0, 1]. */
inline lfloat dsm_texel_opacity(DSM_STORAGE_PARAMS, lint texel, lfloat z, uint max_nodes) {
    lint lo = gather_uint_as_int(texel_first, texel), hi = gather_uint_as_int(texel_first, texel + 1);
    lint begin = lo, end = hi;
    /* first node deeper than z, by bisection over at most max_nodes nodes */
    for (uint span = max_nodes; span > 0; span >>= 1) {
        lmask open = lo < hi;
        lint mid = (lo + hi) >> 1;
        lfloat mid_z = gather(nodes, 2 * select(begin, mid, open));
        lmask deeper = mid_z > z;
        hi = select(hi, mid, open & deeper);
        lo = select(lo, mid + 1, open & !deeper);
    }
    lint upper = lo; /* in [begin, end] */
    lmask before = upper == begin, after = upper == end;
    lint i1 = clamp(upper, begin, end - 1), i0 = max(i1 - 1, begin);
    lmask any_node = end > begin;
    i1 = select(begin, i1, any_node);
    i0 = select(begin, i0, any_node);
    lfloat z0 = gather(nodes, 2 * i0), a0 = gather(nodes, 2 * i0 + 1);
    lfloat z1 = gather(nodes, 2 * i1), a1 = gather(nodes, 2 * i1 + 1);
    lfloat f = clamp((z - z0) / fmax(z1 - z0, 1e-30f), 0.0f, 1.0f);
    lfloat alpha = mix(a0, a1, f);
    alpha = select(alpha, a1, after);
    alpha = select(alpha, (lfloat)(0.0f), before | !any_node);
    return clamp(alpha, 0.0f, 1.0f);
}

#endif
