/* sombra — ray/triangle crossing, the one test every pass uses: shadow rays through surfaces
 * (render.cl surfaces_transmittance) and through polyhedral volume bounds (the segment cursor's
 * triangle source, traversal.h). Watertight, like the C++ reference (reference_transmittance.cpp
 * crossing_t): a ray through an edge two triangles share crosses exactly one of them, so a bound's
 * parity flips once there and a surface attenuates once. */
#ifndef SOMBRA_RAY_TRIANGLE_H
#define SOMBRA_RAY_TRIANGLE_H
#include "lanes.h"

static inline int lexicographically_before(float3 p, float3 q) {
    return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z)));
}

/* Which side of the edge p → q each lane's line origin + t·dir passes: the sign of the triple
 * product [dir, p − o, q − o], true for +. It is computed with the edge's endpoints in
 * lexicographic order and negated for the other direction, so the two triangles that share the
 * edge (and run it oppositely) get exactly opposite signs whatever the rounding; a line through
 * the edge (0) takes the side of the lexicographic direction. */
static inline lmask edge_side(lfloat3 origin, lfloat3 dir, float3 p, float3 q) {
    int forward = lexicographically_before(p, q);
    float3 lo = forward ? p : q, hi = forward ? q : p;
    lfloat3 a = l3_sub(l3_splat(lo), origin), b = l3_sub(l3_splat(hi), origin);
    lfloat w = dir.x * (a.y * b.z - a.z * b.y) + dir.y * (a.z * b.x - a.x * b.z) + dir.z * (a.x * b.y - a.y * b.x);
    lmask positive = w >= 0.0f;
    return forward ? positive : !positive;
}

/* Parameter t of the crossing of each lane's ray origin + t·dir with the triangle (c0, c1, c2):
 * the line passes all three edges on the same side and meets the plane there. +∞ in lanes
 * outside `lanes`, that miss it, that run in its plane (|dir · n| ≤ 10⁻⁷ |n|) or when the
 * triangle is degenerate (n = 0): no division by zero, no NaN. t may be ≤ 0: callers bound it. */
static inline lfloat ray_triangle_t(lfloat3 origin, lfloat3 dir, float3 c0, float3 c1, float3 c2, lmask lanes) {
    float3 n = cross(c1 - c0, c2 - c0);
    float area2 = dot(n, n); /* |n|² */
    if (!(area2 > 0.0f)) return (lfloat)(INFINITY); /* (a scalar test: & with a lane mask would truncate it) */
    lfloat facing = l3_dot_uniform(dir, n);
    lmask crossing = lanes & (facing * facing > 1e-14f * area2);
    if (!lany(crossing)) return (lfloat)(INFINITY);
    lmask side = edge_side(origin, dir, c0, c1);
    crossing &= (edge_side(origin, dir, c1, c2) == side) & (edge_side(origin, dir, c2, c0) == side);
    if (!lany(crossing)) return (lfloat)(INFINITY);
    lfloat t = l3_dot_uniform(l3_sub(l3_splat(c0), origin), n) / select((lfloat)(1.0f), facing, crossing);
    return select((lfloat)(INFINITY), t, crossing);
}

#endif
