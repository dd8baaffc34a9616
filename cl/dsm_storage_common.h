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

/* An entry whose claim found the pool empty: later claims of it give up at once. */
#define DSM_BLOCK_WANTED 0xffffffffu

/* Knecht Alg. 4.1 with CAS only (spin-waits deadlock on PoCL): the block recorded in *entry
 * (stored + 1; 0 = none), else a fresh one from counters[0] claimed by compare-and-swap. A claim
 * that finds the pool empty gives its number back (counters[0] counts handed-out blocks only and
 * never exceeds the pool) and marks the entry wanted; counters[1] counts the wanted entries, each
 * once, so the host grows the pool by what is missing, not by how often it was asked. A block
 * lost to another work-item that claimed the entry first is counted in counters[lost] (waste). */
inline uint claim_block(__global uint* entry, __global uint* counters, uint pool, uint lost) {
    uint held = *entry;
    if (held == DSM_BLOCK_WANTED) return DSM_NO_BLOCK;
    if (held) return held - 1;
    uint fresh = atomic_inc(&counters[0]);
    if (fresh >= pool) {
        atomic_dec(&counters[0]);
        uint previous = atomic_cmpxchg(entry, 0u, DSM_BLOCK_WANTED);
        if (previous == 0u) atomic_inc(&counters[1]);
        return previous == 0u || previous == DSM_BLOCK_WANTED ? DSM_NO_BLOCK : previous - 1;
    }
    uint previous = atomic_cmpxchg(entry, 0u, fresh + 1);
    if (previous == DSM_BLOCK_WANTED) return DSM_NO_BLOCK; /* the pool is short anyway: a rebuild follows */
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

/* For backends with random access to node k of a texel, given as the macros DSM_NODE_DEPTH(k)
 * and DSM_NODE_OPACITY(k) (k a lint, valid in [0, count)):
 *   DSM_BISECT(lo, count, z, max_nodes)   lo = first node deeper than z, by bisection in at most
 *                                         ⌈log2(max_nodes + 1)⌉ steps
 *   DSM_WALK(lo, count, z, max_nodes)     the same by walking from a start index lo (Hadwiger §3.5:
 *                                         the search starts at the previous sample's node)
 *   DSM_INTERPOLATE(lo, count, z)         V'(z) from lo: 0 before the first node, the last node's
 *                                         opacity after the last, linear in between (Knecht Eq. 3.7) */
#define DSM_BISECT(lo, count, z, max_nodes)                                                             \
    do {                                                                                                 \
        lint hi_ = (count);                                                                              \
        (lo) = (lint)(0);                                                                                \
        for (uint span_ = (max_nodes); span_ > 0; span_ >>= 1) {                                         \
            lmask open_ = (lo) < hi_;                                                                    \
            lint mid_ = ((lo) + hi_) >> 1;                                                               \
            lmask deeper_ = DSM_NODE_DEPTH(select((lint)(0), mid_, open_)) > (z);                        \
            hi_ = select(hi_, mid_, open_ & deeper_);                                                    \
            (lo) = select((lo), mid_ + 1, open_ & !deeper_);                                             \
        }                                                                                                \
    } while (0)

#define DSM_WALK(lo, count, z, max_nodes)                                                               \
    do {                                                                                                 \
        (lo) = clamp((lo), (lint)(0), (count));                                                          \
        for (uint step_ = 0; step_ < (max_nodes); ++step_) { /* forward past nodes at or before z */     \
            lmask pass_ = (lo) < (count);                                                                \
            pass_ &= DSM_NODE_DEPTH(select((lint)(0), (lo), pass_)) <= (z);                              \
            if (!lany(pass_)) break;                                                                     \
            (lo) += select((lint)(0), (lint)(1), pass_);                                                 \
        }                                                                                                \
        for (uint step_ = 0; step_ < (max_nodes); ++step_) { /* back over nodes deeper than z */         \
            lmask back_ = (lo) > 0;                                                                      \
            back_ &= DSM_NODE_DEPTH(select((lint)(0), (lo) - 1, back_)) > (z);                           \
            if (!lany(back_)) break;                                                                     \
            (lo) -= select((lint)(0), (lint)(1), back_);                                                 \
        }                                                                                                \
    } while (0)

#define DSM_INTERPOLATE(lo, count, z)                                                                   \
    lmask any_node = (count) > 0;                                                                        \
    lint i1 = select((lint)(0), clamp((lo), (lint)(0), (count) - 1), any_node);                         \
    lint i0 = max(i1 - 1, (lint)(0));                                                                    \
    lfloat z0 = DSM_NODE_DEPTH(i0), a0 = DSM_NODE_OPACITY(i0);                                           \
    lfloat z1 = DSM_NODE_DEPTH(i1), a1 = DSM_NODE_OPACITY(i1);                                           \
    lfloat alpha = mix(a0, a1, clamp(((z) - z0) / fmax(z1 - z0, 1e-30f), 0.0f, 1.0f));                   \
    alpha = select(alpha, a1, (lo) == (count));                                                          \
    alpha = select(alpha, (lfloat)(0.0f), ((lo) == 0) | !any_node);                                      \
    return clamp(alpha, 0.0f, 1.0f)

#endif
