/* sombra — "atlas" deep shadow map storage (Hadwiger §3.4, Fig. 1; Knecht §4.2.1): nodes live in
 * blocks of SOMBRA_ATLAS_LAYERS consecutive layers of one 8×8 tile, allocated on demand from one
 * pool (the 3D texture atlas, flattened to a buffer: block b, layer l, texel t of the tile at
 * ((b · LAYERS + l) · 64 + t)). A low-resolution layout table holds, per tile, the block of each
 * layer range (0 = not allocated), so memory follows the node count instead of the longest
 * function. A texel may hold at most SOMBRA_ATLAS_MAX_BLOCKS · LAYERS nodes (the layer cap);
 * when it is hit, the deepest node overwrites the last layer, the texel is counted, and nothing
 * is ever written out of bounds. Blocks are allocated on demand by claim_block
 * (dsm_storage_common.h), which never draws a block it does not keep. Lookups read
 * the layers in place (native) or a packed copy that dsm_pack makes after generation. */
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
 * [1]: requests the pool could not serve, [2]: texels that hit the layer cap. */
#define DSM_WRITE_PARAMS                                                                                 \
    __global uint* restrict atlas_layout, __global uint* restrict texel_count, __global float* restrict atlas_blocks, \
        __global uint* restrict atlas_allocator, uint atlas_pool_blocks
#define DSM_WRITE_ARGS atlas_layout, texel_count, atlas_blocks, atlas_allocator, atlas_pool_blocks

/* The tile of texel (x, y) of view number `view`, views of `per_row`² tiles. */
static inline uint atlas_tile_of(uint view, uint per_row, uint x, uint y) {
    return view * per_row * per_row + (y / DSM_TILE_SIZE) * per_row + x / DSM_TILE_SIZE;
}
static inline uint atlas_tile(__global const DsmViewGpu* v, uint x, uint y) { return atlas_tile_of(dsm_view_number(v), dsm_tiles_per_row(v), x, y); }
static inline uint atlas_texel_in_tile(uint x, uint y) { return (y % DSM_TILE_SIZE) * DSM_TILE_SIZE + x % DSM_TILE_SIZE; }
/* Where node k of a texel lies in the pool: in block `block`, layer k mod LAYERS, the texel's column of the tile. */
static inline uint atlas_node_index(uint block, uint k, uint texel_in_tile) {
    return (block * SOMBRA_ATLAS_LAYERS + k % SOMBRA_ATLAS_LAYERS) * ATLAS_TILE_TEXELS + texel_in_tile;
}
/* Node k of a texel through its tile's layout entries (an unallocated entry, which a finished
 * build never leaves below the texel's count, reads block 0). */
static inline float2 atlas_node(__global const uint* layout, __global const float* atlas_blocks, uint k, uint texel_in_tile) {
    return vload2(atlas_node_index(max(layout[k / SOMBRA_ATLAS_LAYERS], 1u) - 1, k, texel_in_tile), atlas_blocks);
}

typedef struct {
    uint tile, texel_in_tile, texel, count;
    int capped;
    uint held_slot, held_block; /* the layer range last claimed and its block: one claim per range */
} DsmWriter;

static inline void dsm_writer_begin(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    w->tile = atlas_tile(v, x, y);
    w->texel_in_tile = atlas_texel_in_tile(x, y);
    w->texel = dsm_texel_index(v, x, y);
    w->count = 0;
    w->capped = 0;
    w->held_slot = SOMBRA_ATLAS_MAX_BLOCKS; /* none */
}

/* The block of layer range `slot` of `tile`, allocated if needed. */
static inline uint atlas_block(DSM_WRITE_PARAMS, uint tile, uint slot) {
    return claim_block(&atlas_layout[tile * SOMBRA_ATLAS_MAX_BLOCKS + slot], atlas_allocator, atlas_pool_blocks);
}

static inline void dsm_writer_put(DsmWriter* w, DSM_WRITE_PARAMS, float z, float alpha) {
    const uint cap = SOMBRA_ATLAS_MAX_BLOCKS * SOMBRA_ATLAS_LAYERS;
    uint k = w->count;
    if (k >= cap) { /* keep the function's end: the deepest node replaces the last layer */
        if (!w->capped) atomic_inc(&atlas_allocator[2]);
        w->capped = 1;
        k = cap - 1;
    } else {
        w->count += 1;
    }
    uint slot = k / SOMBRA_ATLAS_LAYERS;
    if (slot != w->held_slot) {
        w->held_slot = slot;
        w->held_block = atlas_block(DSM_WRITE_ARGS, w->tile, slot);
    }
    uint block = w->held_block;
    if (block == DSM_NO_BLOCK) return;
    vstore2((float2)(z, alpha), atlas_node_index(block, k, w->texel_in_tile), atlas_blocks);
}

static inline void dsm_writer_end(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    texel_count[w->texel] = w->count;
}

#ifdef SOMBRA_DSM_BUILD_PROGRAM
/* Packed lookups: the texel's nodes, layer by layer, into its run (dsm_storage_common.h). */
__kernel void dsm_pack(__global const uint* restrict atlas_layout, __global const uint* restrict texel_count,
                       __global const float* restrict atlas_blocks, uint first_texel, uint resolution,
                       __global const uint* restrict texel_first, __global float* restrict packed) {
    uint texel, view, x, y;
    dsm_pack_texel(first_texel, resolution, &texel, &view, &x, &y);
    uint per_row = (resolution + DSM_TILE_SIZE - 1) / DSM_TILE_SIZE, texel_in_tile = atlas_texel_in_tile(x, y);
    __global const uint* layout = &atlas_layout[atlas_tile_of(view, per_row, x, y) * SOMBRA_ATLAS_MAX_BLOCKS];
    uint first = texel_first[texel], count = texel_count[texel];
    for (uint k = 0; k < count; ++k) vstore2(atlas_node(layout, atlas_blocks, k, texel_in_tile), first + k, packed);
}
#endif

#define DSM_READ_PARAMS \
    __global const uint* restrict atlas_layout, __global const uint* restrict texel_count, __global const float* restrict atlas_blocks
#define DSM_READ_ARGS atlas_layout, texel_count, atlas_blocks
#define DSM_READ_STATE_FIELDS __global const uint* atlas_layout; __global const uint* texel_count; __global const float* atlas_blocks;
#define DSM_READ_STATE_INIT(s) ((s).atlas_layout = atlas_layout, (s).texel_count = texel_count, (s).atlas_blocks = atlas_blocks)
#define DSM_READ_ARGS_OF(s) (s)->atlas_layout, (s)->texel_count, (s)->atlas_blocks

/* V'(z) of texel (x, y) of view v (Knecht Eq. 3.7) read in place (RenderOptions::dsm_lookup
 * "native"): the walk of DSM_SCALAR_LOOKUP, node k found through the tile's layout table (block
 * of layer range k / LAYERS, layer k mod LAYERS). */
static inline float dsm_texel_opacity(DSM_READ_PARAMS, __global const DsmViewGpu* v, int x, int y, float z, DsmSearchHint* hint) {
    uint texel_in_tile = atlas_texel_in_tile((uint)x, (uint)y);
    int count = (int)texel_count[dsm_texel_index(v, (uint)x, (uint)y)];
    __global const uint* layout = &atlas_layout[atlas_tile(v, (uint)x, (uint)y) * SOMBRA_ATLAS_MAX_BLOCKS];
#define DSM_NODE(k) atlas_node(layout, atlas_blocks, (uint)(k), texel_in_tile)
    float alpha;
    DSM_SCALAR_LOOKUP(alpha, count, z, hint);
#undef DSM_NODE
    return alpha;
}

#endif
