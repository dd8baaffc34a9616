/* sombra — walking the bounding-volume hierarchy over the world-space mesh triangles
 * (src/geometry/bvh.h) for a packet of rays o + t·d, t_min ≤ t ≤ t_max: the leaves whose box the ray of
 * any lane crosses, one after the other, near child first. Callers test the leaf's triangles
 * themselves (shadow rays through surfaces, crossings of polyhedral bounds; t_min and t_max may
 * change between calls, e.g. shrink to the nearest crossing found so far):
 *     BvhWalk walk;
 *     bvh_walk_init(&walk, node_count);
 *     uint first, count;
 *     while (bvh_walk_next(&walk, nodes, o, d, t_min, t_max, lanes, &first, &count))
 *         for (uint k = first; k < first + count; ++k) … triangle k (BVH order) …
 * Needs traversal.h (intersect_box). */
#ifndef SOMBRA_BVH_H
#define SOMBRA_BVH_H

typedef struct {
    uint stack[SOMBRA_BVH_MAX_DEPTH]; /* nodes still to visit (the host bounds the tree's depth) */
    int top;
} BvhWalk;

static inline void bvh_walk_init(BvhWalk* w, uint node_count) {
    w->top = 0;
    if (node_count > 0) w->stack[w->top++] = 0u;
}

/* The next leaf whose box some lane in `lanes` crosses within [t_min, t_max]: its triangle range
 * in *first, *count. Returns false once the hierarchy is exhausted. */
static inline bool bvh_walk_next(BvhWalk* w, __global const BvhNodeGpu* nodes, lfloat3 o, lfloat3 d, lfloat t_min, lfloat t_max,
                          lmask lanes, uint* first, uint* count) {
    while (w->top > 0) {
        uint i = w->stack[--w->top];
        __global const BvhNodeGpu* n = &nodes[i];
        lfloat t0, t1;
        intersect_box(o, d, l3_splat(n->box_min.xyz), l3_splat(n->box_max.xyz), &t0, &t1);
        if (!lany(lanes & (fmax(t0, t_min) <= fmin(t1, t_max)))) continue;
        if (n->count == 0u) { /* inner node: its first child follows it, `first` is the second */
            w->stack[w->top++] = n->first;
            w->stack[w->top++] = i + 1u;
            continue;
        }
        *first = n->first;
        *count = n->count;
        return true;
    }
    return false;
}

#endif
