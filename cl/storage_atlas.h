/* sombra — "atlas" deep shadow map storage (Hadwiger §3.4, Fig. 1; Knecht §4.2.1): nodes live in
 * blocks of SOMBRA_ATLAS_LAYERS consecutive layers of one 8×8 tile, allocated on demand from one
 * pool (the 3D texture atlas, flattened to a buffer: block b, layer l, texel t of the tile at
 * ((b · LAYERS + l) · 64 + t)). A low-resolution layout table holds, per tile, the block of each
 * layer range (0 = not allocated), so memory follows the node count instead of the longest
 * function. A texel may hold at most SOMBRA_ATLAS_MAX_BLOCKS · LAYERS nodes (the layer cap);
 * when it is hit, the deepest node overwrites the last layer, the texel is counted, and nothing
 * is ever written out of bounds. Blocks are allocated with atomic_inc + atomic_cmpxchg only (no
 * spin-waits, which deadlock on PoCL); a block lost in a race is counted as waste. */
#ifndef SOMBRA_STORAGE_ATLAS_H
#define SOMBRA_STORAGE_ATLAS_H
#include "dsm_storage_common.h"

#ifndef SOMBRA_ATLAS_LAYERS
#define SOMBRA_ATLAS_LAYERS 8
#endif
#ifndef SOMBRA_ATLAS_MAX_BLOCKS
#define SOMBRA_ATLAS_MAX_BLOCKS 32
#endif
#define ATLAS_TILE_TEXELS (DSM_TILE_SIZE * DSM_TILE_SIZE)

/* allocator[0]: blocks handed out (may exceed the pool: then the host grows it and rebuilds),
 * [1]: requests the pool could not serve, [2]: texels that hit the layer cap, [3]: blocks lost
 * in allocation races. */
#define DSM_WRITE_PARAMS                                                                                 \
    __global uint* restrict atlas_layout, __global uint* restrict texel_count, __global float* restrict atlas_blocks, \
        __global uint* restrict atlas_allocator, uint atlas_pool_blocks
#define DSM_WRITE_ARGS atlas_layout, texel_count, atlas_blocks, atlas_allocator, atlas_pool_blocks

inline uint atlas_tile(__global const DsmViewGpu* v, uint x, uint y) {
    uint per_row = dsm_tiles_per_row(v);
    return dsm_view_number(v) * per_row * per_row + (y / DSM_TILE_SIZE) * per_row + x / DSM_TILE_SIZE;
}
inline uint atlas_texel_in_tile(uint x, uint y) { return (y % DSM_TILE_SIZE) * DSM_TILE_SIZE + x % DSM_TILE_SIZE; }

typedef struct {
    uint tile, texel_in_tile, texel, count;
    int capped;
} DsmWriter;

inline void dsm_writer_begin(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    w->tile = atlas_tile(v, x, y);
    w->texel_in_tile = atlas_texel_in_tile(x, y);
    w->texel = dsm_texel_index(v, x, y);
    w->count = 0;
    w->capped = 0;
}

/* The block of layer range `slot` of `tile`, allocated if needed. */
inline uint atlas_block(DSM_WRITE_PARAMS, uint tile, uint slot) {
    return claim_block(&atlas_layout[tile * SOMBRA_ATLAS_MAX_BLOCKS + slot], atlas_allocator, atlas_pool_blocks, 3);
}

inline void dsm_writer_put(DsmWriter* w, DSM_WRITE_PARAMS, float z, float alpha) {
    const uint cap = SOMBRA_ATLAS_MAX_BLOCKS * SOMBRA_ATLAS_LAYERS;
    uint k = w->count;
    if (k >= cap) { /* keep the function's end: the deepest node replaces the last layer */
        if (!w->capped) atomic_inc(&atlas_allocator[2]);
        w->capped = 1;
        k = cap - 1;
    } else {
        w->count += 1;
    }
    uint block = atlas_block(DSM_WRITE_ARGS, w->tile, k / SOMBRA_ATLAS_LAYERS);
    if (block == DSM_NO_BLOCK) return;
    uint at = (block * SOMBRA_ATLAS_LAYERS + k % SOMBRA_ATLAS_LAYERS) * ATLAS_TILE_TEXELS + w->texel_in_tile;
    vstore2((float2)(z, alpha), at, atlas_blocks);
}

inline void dsm_writer_end(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    texel_count[w->texel] = w->count;
}

#define DSM_READ_PARAMS \
    __global const uint* restrict atlas_layout, __global const uint* restrict texel_count, __global const float* restrict atlas_blocks
#define DSM_READ_ARGS atlas_layout, texel_count, atlas_blocks
#define DSM_READ_STATE_FIELDS __global const uint* atlas_layout; __global const uint* texel_count; __global const float* atlas_blocks;
#define DSM_READ_STATE_INIT(s) ((s).atlas_layout = atlas_layout, (s).texel_count = texel_count, (s).atlas_blocks = atlas_blocks)
#define DSM_READ_ARGS_OF(s) (s)->atlas_layout, (s)->texel_count, (s)->atlas_blocks
#define DSM_HAS_SEARCH_HINTS /* lookups can start from the previous sample's node */

/* Float index of node k of the lanes' texels (block looked up in the layout table). */
inline lint atlas_node_index(__global const uint* atlas_layout, lint tile, lint texel_in_tile, lint k) {
    lint entry = tile * SOMBRA_ATLAS_MAX_BLOCKS + k / SOMBRA_ATLAS_LAYERS;
    lint block = max(gather_uint_as_int(atlas_layout, entry) - 1, (lint)(0)); /* unallocated: read block 0, unused */
    return 2 * ((block * SOMBRA_ATLAS_LAYERS + k % SOMBRA_ATLAS_LAYERS) * ATLAS_TILE_TEXELS + texel_in_tile);
}

/* V'(z) of texels (x, y), one per lane. `hint` (may be 0) carries, per lane, the texel and node
 * index found by the previous lookup of the same caller: when the texel is the same, the search
 * walks from that node (Hadwiger §3.5: successive samples of a ray lie close in depth), else it
 * bisects; the found node is stored back. */
typedef struct {
    lint texel, node;
} DsmSearchHint;

inline lfloat dsm_texel_opacity_hinted(DSM_READ_PARAMS, __global const DsmViewGpu* v, lint x, lint y, lfloat z,
                                       DsmSearchHint* hint) {
    int per_row = (int)dsm_tiles_per_row(v);
    lint tile = (int)(dsm_view_number(v) * per_row * per_row) + (y / DSM_TILE_SIZE) * per_row + x / DSM_TILE_SIZE;
    lint texel_in_tile = (y % DSM_TILE_SIZE) * DSM_TILE_SIZE + x % DSM_TILE_SIZE;
    lint texel = (int)v->first_texel + y * (int)v->resolution + x;
    lint count = gather_uint_as_int(texel_count, texel);
#define DSM_NODE_DEPTH(k) gather(atlas_blocks, atlas_node_index(atlas_layout, tile, texel_in_tile, (k)))
#define DSM_NODE_OPACITY(k) gather(atlas_blocks, atlas_node_index(atlas_layout, tile, texel_in_tile, (k)) + 1)
    lint lo;
    lmask same = hint ? hint->texel == texel : (lmask)(0);
    if (hint && !lany(!same)) { /* every lane looks at the texel of its previous lookup */
        lo = hint->node;
        DSM_WALK(lo, count, z, v->max_nodes);
    } else {
        DSM_BISECT(lo, count, z, v->max_nodes);
    }
    if (hint) {
        hint->texel = texel;
        hint->node = lo;
    }
    DSM_INTERPOLATE(lo, count, z);
#undef DSM_NODE_DEPTH
#undef DSM_NODE_OPACITY
}

inline lfloat dsm_texel_opacity(DSM_READ_PARAMS, __global const DsmViewGpu* v, lint x, lint y, lfloat z) {
    return dsm_texel_opacity_hinted(DSM_READ_ARGS, v, x, y, z, 0);
}

#endif
