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

/* Knecht Alg. 4.1 with CAS only (spin-waits deadlock on PoCL): the block recorded in *entry
 * (stored + 1; 0 = none), else a fresh one from counters[0] claimed by compare-and-swap. A claim
 * that finds the pool empty gives its number back (counters[0] counts handed-out blocks only and
 * never exceeds the pool) and marks the entry wanted; counters[1] counts the wanted entries, each
 * once, so the host grows the pool by what is missing, not by how often it was asked. A block
 * lost to another work-item that claimed the entry first is counted in counters[lost] (waste).
 * Every access to *entry is atomic (other work-items cmpxchg it concurrently): the first read is
 * an atomic_or with 0, OpenCL 1.2's atomic load. */
static inline uint claim_block(__global uint* entry, __global uint* counters, uint pool, uint lost) {
    uint held = atomic_or(entry, 0u);
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
