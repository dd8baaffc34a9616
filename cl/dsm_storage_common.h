/* sombra — what every deep shadow map storage backend shares: texel indices, per-lane loads of
 * integers, and the search of a texel's sorted nodes for depth z (Knecht Eq. 3.7). A backend
 * header (storage_compact.h, storage_atlas.h, storage_chunked.h) defines the same functions:
 *   DsmWriter, dsm_writer_begin / dsm_writer_put / dsm_writer_end   (generation)
 *   dsm_texel_opacity                                                (lookup)
 * with DSM_WRITE_PARAMS/ARGS and DSM_READ_PARAMS/ARGS naming its buffers; the build and lookup
 * kernels include one of them by define and never ask which. */
#ifndef SOMBRA_DSM_STORAGE_COMMON_H
#define SOMBRA_DSM_STORAGE_COMMON_H
#include "shared/types.h"
#include "lanes.h"

#define DSM_TILE_SIZE 8 /* texels per side of a tile (Knecht §4.1.1, Hadwiger Fig. 1) */

inline uint dsm_texel_index(__global const DsmViewGpu* v, uint x, uint y) { return v->first_texel + y * v->resolution + x; }

/* Tiles of a view: ⌈resolution / 8⌉² of them, numbered row by row; views follow each other. */
inline uint dsm_tiles_per_row(__global const DsmViewGpu* v) { return (v->resolution + DSM_TILE_SIZE - 1) / DSM_TILE_SIZE; }
inline uint dsm_view_number(__global const DsmViewGpu* v) { return v->first_texel / (v->resolution * v->resolution); }

#define DSM_NO_BLOCK 0xffffffffu

/* Knecht Alg. 4.1 with CAS only (spin-waits deadlock on PoCL): the block recorded in *entry
 * (stored + 1; 0 = none), else a fresh one from counters[0] claimed by compare-and-swap. A pool
 * that ran out counts the request in counters[1]; a block lost to another work-item that claimed
 * the entry first is counted in counters[lost] (waste). */
inline uint claim_block(__global uint* entry, __global uint* counters, uint pool, uint lost) {
    uint held = *entry;
    if (held) return held - 1;
    uint fresh = atomic_inc(&counters[0]);
    if (fresh >= pool) {
        atomic_inc(&counters[1]);
        return DSM_NO_BLOCK;
    }
    uint previous = atomic_cmpxchg(entry, 0u, fresh + 1);
    if (previous) {
        atomic_inc(&counters[lost]);
        return previous - 1;
    }
    return fresh;
}

#if SOMBRA_LANES == 1
inline lint gather_uint_as_int(__global const uint* ptr, lint idx) { return (int)ptr[idx]; }
#else
inline lint gather_uint_as_int(__global const uint* ptr, lint idx) {
#define SOMBRA_GATHER_UINT_LANE(c) (int)ptr[LC(idx, c)]
    return LFROM_LANES_AS(lint, SOMBRA_GATHER_UINT_LANE);
#undef SOMBRA_GATHER_UINT_LANE
}
#endif

/* Body of dsm_texel_opacity for backends with random access to node k of a texel, given as the
 * macros DSM_NODE_DEPTH(k) and DSM_NODE_OPACITY(k) (k a lint, valid in [0, count)): bisection
 * for the first node deeper than z in at most ⌈log2(max_nodes + 1)⌉ steps, then V'(z): 0 before
 * the first node, the last node's opacity after the last, linear in between; clamped to [0, 1]. */
#define DSM_BISECT_AND_INTERPOLATE(count, z, max_nodes)                                                 \
    lint lo = (lint)(0), hi = (count);                                                                   \
    for (uint span = (max_nodes); span > 0; span >>= 1) {                                                \
        lmask open = lo < hi;                                                                            \
        lint mid = (lo + hi) >> 1;                                                                       \
        lmask deeper = DSM_NODE_DEPTH(select((lint)(0), mid, open)) > (z);                               \
        hi = select(hi, mid, open & deeper);                                                             \
        lo = select(lo, mid + 1, open & !deeper);                                                        \
    }                                                                                                    \
    lmask any_node = (count) > 0;                                                                        \
    lint i1 = select((lint)(0), clamp(lo, (lint)(0), (count) - 1), any_node);                            \
    lint i0 = max(i1 - 1, (lint)(0));                                                                    \
    lfloat z0 = DSM_NODE_DEPTH(i0), a0 = DSM_NODE_OPACITY(i0);                                           \
    lfloat z1 = DSM_NODE_DEPTH(i1), a1 = DSM_NODE_OPACITY(i1);                                           \
    lfloat alpha = mix(a0, a1, clamp(((z) - z0) / fmax(z1 - z0, 1e-30f), 0.0f, 1.0f));                   \
    alpha = select(alpha, a1, lo == (count));                                                            \
    alpha = select(alpha, (lfloat)(0.0f), (lo == 0) | !any_node);                                        \
    return clamp(alpha, 0.0f, 1.0f)

#endif
