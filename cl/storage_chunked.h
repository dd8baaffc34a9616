/* sombra — "chunked" deep shadow map storage (Knecht §4.2.2, Alg. 4.1, Eq. 4.11–4.17): the nodes
 * of an 8×8 tile go into chunks of SOMBRA_CHUNK_LENGTH nodes, taken in order by the tile's
 * work-items through an atomic counter (Eq. 4.11–4.12) and allocated on demand from a global
 * pool (Alg. 4.1, claim_block in dsm_storage_common.h). Each texel's nodes form a
 * linked list whose head sits in a per-texel lookup table (Eq. 4.13–4.17). After generation the
 * nodes are rearranged for reading (dsm_rearrange: depth, opacity and link in one float4, as
 * Knecht's chunk texture) and lookups walk the list linearly, or (packed lookups, the default) each
 * texel's list is copied into one run (dsm_pack). With SOMBRA_CHUNKS_COUNTED the
 * host counts the nodes of every tile first (dsm_count) and gives each tile an exact run
 * instead of whole chunks: Knecht wasted 7.8 chunks per chunk used (Table 5.11); this wastes none,
 * at the price of a second march. */
#ifndef SOMBRA_STORAGE_CHUNKED_H
#define SOMBRA_STORAGE_CHUNKED_H
#include "dsm_storage_common.h"

#ifndef SOMBRA_CHUNK_LENGTH
#define SOMBRA_CHUNK_LENGTH 64
#endif
#ifndef SOMBRA_CHUNKS_PER_TILE
#define SOMBRA_CHUNKS_PER_TILE 64
#endif
#define CHUNK_END 0xffffffffu

/* allocator[0]: chunks handed out (may exceed the pool: the host grows it and rebuilds),
 * [1]: requests the pool or a tile's chunk table could not serve. */
#define DSM_WRITE_PARAMS                                                                                   \
    __global uint* restrict tile_fill, __global uint* restrict tile_chunks, __global float* restrict chunk_nodes, \
        __global uint* restrict chunk_next, __global uint* restrict texel_head, __global uint* restrict texel_count, \
        __global uint* restrict chunk_allocator, uint chunk_pool
#define DSM_WRITE_ARGS tile_fill, tile_chunks, chunk_nodes, chunk_next, texel_head, texel_count, chunk_allocator, chunk_pool

typedef struct {
    uint tile, texel, count, previous_slot;
} DsmWriter;

static inline void dsm_writer_begin(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    uint per_row = dsm_tiles_per_row(v);
    w->tile = dsm_view_number(v) * per_row * per_row + (y / DSM_TILE_SIZE) * per_row + x / DSM_TILE_SIZE;
    w->texel = dsm_texel_index(v, x, y);
    w->count = 0;
    w->previous_slot = CHUNK_END;
    texel_head[w->texel] = CHUNK_END;
}

/* Global index of chunk `c` of `tile`, allocated if needed (Knecht Alg. 4.1). */
static inline uint chunk_of_tile(DSM_WRITE_PARAMS, uint tile, uint c) {
    if (c >= SOMBRA_CHUNKS_PER_TILE) {
        atomic_inc(&chunk_allocator[1]);
        return CHUNK_END;
    }
    return claim_block(&tile_chunks[tile * SOMBRA_CHUNKS_PER_TILE + c], chunk_allocator, chunk_pool);
}

static inline void dsm_writer_put(DsmWriter* w, DSM_WRITE_PARAMS, float z, float alpha) {
    uint n = atomic_inc(&tile_fill[w->tile]); /* the tile's n-th node */
#ifdef SOMBRA_CHUNKS_COUNTED
    /* counted allocation: the host counted every tile's nodes first and gave each tile one
     * exact run (tile_chunks holds its first slot): nothing is wasted */
    uint slot = tile_chunks[w->tile] + n;
#else
    /* on demand (Knecht Alg. 4.1): chunk n / L, layer n mod L (Eq. 4.11–4.12) */
    uint chunk = chunk_of_tile(DSM_WRITE_ARGS, w->tile, n / SOMBRA_CHUNK_LENGTH);
    if (chunk == CHUNK_END) return;
    uint slot = chunk * SOMBRA_CHUNK_LENGTH + n % SOMBRA_CHUNK_LENGTH;
#endif
    vstore2((float2)(z, alpha), slot, chunk_nodes);
    chunk_next[slot] = CHUNK_END;
    if (w->previous_slot == CHUNK_END) texel_head[w->texel] = slot;
    else chunk_next[w->previous_slot] = slot;
    w->previous_slot = slot;
    w->count += 1;
}

static inline void dsm_writer_end(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    texel_count[w->texel] = w->count;
}

#ifdef SOMBRA_DSM_BUILD_PROGRAM
/* Rearranges the chunk arrays into the chunk texture read by lookups: per slot one float4
 * (depth, opacity, link as bits, 0), Knecht's AoS form of §4.2.2. */
__kernel void dsm_rearrange(__global const float* chunk_nodes, __global const uint* chunk_next,
                            __global float4* chunk_texture) {
    size_t slot = get_global_id(0);
    float2 node = vload2(slot, chunk_nodes);
    chunk_texture[slot] = (float4)(node.x, node.y, as_float(chunk_next[slot]), 0.0f);
}

/* Packed lookups, instead of dsm_rearrange: the texel's list, walked from its head, into its run
 * (dsm_storage_common.h). */
__kernel void dsm_pack(__global const uint* restrict texel_head, __global const uint* restrict texel_count,
                       __global const float* restrict chunk_nodes, __global const uint* restrict chunk_next,
                       uint first_texel, uint resolution, __global const uint* restrict texel_first,
                       __global float* restrict packed) {
    uint texel, view, x, y;
    dsm_pack_texel(first_texel, resolution, &texel, &view, &x, &y);
    uint slot = texel_head[texel], at = texel_first[texel], end = at + texel_count[texel];
    for (; at < end && slot != CHUNK_END; ++at, slot = chunk_next[slot]) vstore2(vload2(slot, chunk_nodes), at, packed);
}
#endif

#define DSM_READ_PARAMS __global const uint* restrict texel_head, __global const float* restrict chunk_texture
#define DSM_READ_ARGS texel_head, chunk_texture
#define DSM_READ_STATE_FIELDS __global const uint* texel_head; __global const float* chunk_texture;
#define DSM_READ_STATE_INIT(s) ((s).texel_head = texel_head, (s).chunk_texture = chunk_texture)
#define DSM_READ_ARGS_OF(s) (s)->texel_head, (s)->chunk_texture

/* V'(z) of texel (x, y) of view v by walking its list (Knecht: linear search, no bisection), from
 * the head, or from the hint's slot when the previous lookup of this corner was in the same texel
 * and found a node at or before z there (Hadwiger §3.5); the hint keeps the last node at or
 * before z. 0 before the first node, the last node's opacity after the last, linear in between
 * (Eq. 3.7), clamped to [0, 1]. */
static inline float dsm_texel_opacity(DSM_READ_PARAMS, __global const DsmViewGpu* v, int x, int y, float z, DsmSearchHint* hint) {
    __global const float4* texture = (__global const float4*)chunk_texture;
    int texel = (int)dsm_texel_index(v, (uint)x, (uint)y);
    uint slot = CHUNK_END;
    float4 node;
    if (hint->texel == texel) {
        node = texture[hint->node];
        if (node.x <= z) slot = (uint)hint->node;
    }
    if (slot == CHUNK_END) {
        slot = texel_head[texel];
        if (slot == CHUNK_END) return 0.0f;
        node = texture[slot];
        if (!(node.x <= z)) return 0.0f; /* no node at or before z */
    }
    /* node (at slot) lies at or before z: walk on while the next one does too */
    float alpha = node.y;
    for (uint next = as_uint(node.z); next != CHUNK_END; next = as_uint(node.z)) {
        float4 after = texture[next];
        if (after.x > z) {
            alpha = mix(node.y, after.y, clamp((z - node.x) / fmax(after.x - node.x, 1e-30f), 0.0f, 1.0f));
            break;
        }
        slot = next;
        node = after;
        alpha = node.y;
    }
    hint->texel = texel;
    hint->node = (int)slot;
    return DSM_NODE_OPACITY(alpha);
}

#endif
