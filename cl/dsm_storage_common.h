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
#include "shared/dsm_value.h"
#include "lanes.h"

#define DSM_TILE_SIZE 8 /* texels per side of a tile (Knecht §4.1.1, Hadwiger Fig. 1) */

static inline uint dsm_texel_index(__global const DsmViewGpu* v, uint x, uint y) { return v->first_texel + y * v->resolution + x; }

/* Tiles of a view: ⌈resolution / 8⌉² of them, numbered row by row; views follow each other. */
static inline uint dsm_tiles_per_row(__global const DsmViewGpu* v) { return (v->resolution + DSM_TILE_SIZE - 1) / DSM_TILE_SIZE; }
static inline uint dsm_view_number(__global const DsmViewGpu* v) { return v->first_texel / (v->resolution * v->resolution); }

#define DSM_NO_BLOCK 0xffffffffu

/* An entry whose claim found the pool empty: later claims of it give up at once. */
#define DSM_BLOCK_WANTED 0xffffffffu
/* An entry a work-item has claimed and not yet given its block. */
#define DSM_BLOCK_CLAIMING 0xfffffffeu

/* Knecht Alg. 4.1: the block recorded in *entry (stored + 1; 0 = none), else a fresh one from
 * counters[0]. The first work-item to swap the entry from 0 to CLAIMING draws the block and
 * publishes it; a work-item that finds CLAIMING waits for that publication, which is a few
 * straight-line instructions away and earlier in program order (a GPU warp and PoCL's vectorised
 * work-item loop run the claim before the wait, PoCL's scalar loop runs one work-item to its end),
 * so the wait cannot deadlock. No block is ever drawn and lost: drawing first and swapping after
 * lost up to 31 blocks per entry in a warp's lockstep on a GPU, and the atlas ran out of its pool
 * (docs/gpu-check.md). A claim that finds the pool empty gives the number back (counters[0]
 * counts handed-out blocks only and never exceeds the pool) and marks the entry wanted;
 * counters[1] counts the wanted entries, each once, so the host grows the pool by exactly what is
 * missing. Every access to *entry is atomic: the reads are atomic_or with 0, OpenCL 1.2's atomic load. */
static inline uint claim_block(__global uint* entry, __global uint* counters, uint pool) {
    uint held = atomic_or(entry, 0u);
    if (held == 0u) {
        held = atomic_cmpxchg(entry, 0u, DSM_BLOCK_CLAIMING);
        if (held == 0u) {
            uint fresh = atomic_inc(&counters[0]);
            if (fresh < pool) {
                held = fresh + 1;
            } else {
                atomic_dec(&counters[0]);
                atomic_inc(&counters[1]);
                held = DSM_BLOCK_WANTED;
            }
            atomic_xchg(entry, held);
        }
    }
    while (held == DSM_BLOCK_CLAIMING) held = atomic_or(entry, 0u);
    return held == DSM_BLOCK_WANTED ? DSM_NO_BLOCK : held - 1;
}

#ifdef SOMBRA_DSM_BUILD_PROGRAM
/* Packed lookups (RenderOptions::dsm_lookup "packed", src/memory/dsm_storage.h): after generation a
 * backend's dsm_pack kernel copies every texel's nodes, in depth order, into one run of
 * packed[texel_first[t] …] (the compact layout, storage_compact.h), which every lookup then reads.
 * A launch covers texels [first_texel, first_texel + resolution²) of one view: the texel of
 * work-item i, its view number and its (x, y). */
static inline void dsm_pack_texel(uint first_texel, uint resolution, uint* texel, uint* view, uint* x, uint* y) {
    uint i = (uint)get_global_id(0);
    *texel = first_texel + i;
    *view = first_texel / (resolution * resolution);
    *x = i % resolution;
    *y = i / resolution;
}
#endif

/* Lookups are scalar, one lane at a time (techniques/dsm.h): a lane's search stops as soon as its
 * own texel is answered, instead of every lane of a packet running the longest search in lockstep
 * through per-lane gathers. Each bilinear corner keeps a hint per lane (Hadwiger §3.5: the search
 * starts at the previous sample's node): the node index, or for linked lists the slot, found by
 * the previous lookup, and the texel it was found in. */
typedef struct {
    int texel; /* −1: none yet */
    int node;
} DsmSearchHint;

/* For backends with random access to node k of a texel, given as DSM_NODE(k) (a float2: depth,
 * opacity; k in [0, count)): V'(z) of a texel of `count` nodes (Knecht Eq. 3.7), 0 before the
 * first node, the last node's opacity from the last on, linear in between, clamped to [0, 1].
 * lo, the number of nodes at or before z, is found by walking from the hint's lo (of the previous
 * lookup of the same corner, in whatever texel: neighbouring texels and successive samples hold
 * similar functions); the walk ends at the same lo from every start, so hints change the cost,
 * never the result. The two nodes it tests last, lo − 1 and lo, are the pair interpolated: a good
 * hint costs two node reads. */
#define DSM_SCALAR_LOOKUP(result, count, z, hint)                                                     \
    do {                                                                                               \
        int lo_ = clamp((hint)->node, 0, (count));                                                    \
        float2 n0_ = (float2)(0.0f), n1_ = (float2)(0.0f);                                            \
        if (lo_ < (count)) n1_ = DSM_NODE(lo_);                                                       \
        if (lo_ < (count) && n1_.x <= (z)) {                                                          \
            do { /* forward past the nodes at or before z */                                          \
                n0_ = n1_;                                                                             \
                ++lo_;                                                                                 \
                if (lo_ < (count)) n1_ = DSM_NODE(lo_);                                               \
            } while (lo_ < (count) && n1_.x <= (z));                                                  \
        } else {                                                                                       \
            if (lo_ > 0) n0_ = DSM_NODE(lo_ - 1);                                                     \
            while (lo_ > 0 && n0_.x > (z)) { /* back over the nodes deeper than z */                 \
                n1_ = n0_;                                                                             \
                --lo_;                                                                                 \
                if (lo_ > 0) n0_ = DSM_NODE(lo_ - 1);                                                 \
            }                                                                                          \
        }                                                                                              \
        (hint)->node = lo_;                                                                            \
        float r_ = mix(n0_.y, n1_.y, clamp(((z) - n0_.x) / fmax(n1_.x - n0_.x, 1e-30f), 0.0f, 1.0f)); \
        r_ = lo_ == (count) ? n0_.y : r_; /* after the last node (none: 0) */                        \
        r_ = lo_ == 0 ? 0.0f : r_;        /* before the first */                                      \
        (result) = DSM_NODE_OPACITY(r_); /* shared/dsm_value.h: α, or 1 − exp(−τ) */                   \
    } while (0)

#endif
