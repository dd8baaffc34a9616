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

static inline void dsm_writer_begin(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {
    w->next = texel_first[dsm_texel_index(v, x, y)];
}

static inline void dsm_writer_put(DsmWriter* w, DSM_WRITE_PARAMS, float z, float alpha) {
    vstore2((float2)(z, alpha), w->next, nodes);
    w->next += 1;
}

static inline void dsm_writer_end(DsmWriter* w, DSM_WRITE_PARAMS, __global const DsmViewGpu* v, uint x, uint y) {}

/* ---- reading (render.cl) ---- */
#define DSM_READ_PARAMS __global const uint* restrict texel_first, __global const float* restrict nodes
#define DSM_READ_ARGS texel_first, nodes
/* the same buffers kept in a pass's state struct */
#define DSM_READ_STATE_FIELDS __global const uint* texel_first; __global const float* nodes;
#define DSM_READ_STATE_INIT(s) ((s).texel_first = texel_first, (s).nodes = nodes)
#define DSM_READ_ARGS_OF(s) (s)->texel_first, (s)->nodes


/* V'(z) of texel (x, y) of view v (Knecht Eq. 3.7): the walk of DSM_SCALAR_LOOKUP over the texel's
 * run of nodes. */
static inline float dsm_texel_opacity(DSM_READ_PARAMS, __global const DsmViewGpu* v, int x, int y, float z, DsmSearchHint* hint) {
    uint texel = v->first_texel + (uint)y * v->resolution + (uint)x;
    uint begin = texel_first[texel];
    int count = (int)(texel_first[texel + 1] - begin);
#define DSM_NODE(k) vload2(begin + (uint)(k), nodes)
    float alpha;
    DSM_SCALAR_LOOKUP(alpha, count, z, hint);
#undef DSM_NODE
    return alpha;
}

#endif
