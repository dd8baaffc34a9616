/* sombra — "compact" deep shadow map storage: per texel a run of nodes (depth, opacity) in one
 * array, located by a per-texel offset table (the role of Knecht's lookup texture, Eq. 4.13–4.17).
 * The host counts the nodes first (dsm_count) and allocates with a prefix sum, so nothing is
 * wasted; generation therefore marches twice. */
#ifndef SOMBRA_STORAGE_COMPACT_H
#define SOMBRA_STORAGE_COMPACT_H
#include "dsm_storage_common.h"

/* ---- writing (dsm_build.cl) ---- */
#define DSM_WRITE_PARAMS __global const uint* restrict texel_first, __global float* restrict nodes
#define DSM_WRITE_ARGS texel_first, nodes

typedef struct {
    uint next; /* index of the texel's next node */
} DsmWriter;

inline void dsm_writer_begin(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    w->next = texel_first[dsm_texel_index(v, x, y)];
}

inline void dsm_writer_put(DsmWriter* w, DSM_WRITE_PARAMS, float z, float alpha) {
    vstore2((float2)(z, alpha), w->next, nodes);
    w->next += 1;
}

inline void dsm_writer_end(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {}

/* ---- reading (render.cl) ---- */
#define DSM_READ_PARAMS __global const uint* restrict texel_first, __global const float* restrict nodes
#define DSM_READ_ARGS texel_first, nodes
/* the same buffers kept in a pass's state struct */
#define DSM_READ_STATE_FIELDS __global const uint* texel_first; __global const float* nodes;
#define DSM_READ_STATE_INIT(s) ((s).texel_first = texel_first, (s).nodes = nodes)
#define DSM_READ_ARGS_OF(s) (s)->texel_first, (s)->nodes


/* V'(z) of texels (x, y) of view v, one per lane (Knecht Eq. 3.7): bisection for the first node
 * deeper than z over the texel's run, clamped to [0, 1]. */
inline lfloat dsm_texel_opacity(DSM_READ_PARAMS, __global const DsmViewGpu* v, lint x, lint y, lfloat z) {
    lint texel = (int)v->first_texel + y * (int)v->resolution + x;
    lint begin = gather_uint_as_int(texel_first, texel);
    lint count = gather_uint_as_int(texel_first, texel + 1) - begin;
#define DSM_NODE_DEPTH(k) gather(nodes, 2 * (begin + (k)))
#define DSM_NODE_OPACITY(k) gather(nodes, 2 * (begin + (k)) + 1)
    lint lo;
    DSM_BISECT(lo, count, z, v->max_nodes);
    DSM_INTERPOLATE(lo, count, z);
#undef DSM_NODE_DEPTH
#undef DSM_NODE_OPACITY
}

#endif
