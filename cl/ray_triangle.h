/* sombra — ray/triangle crossing (Möller–Trumbore), the one test every pass uses: shadow rays
 * through surfaces (render.cl surfaces_transmittance) and through polyhedral volume bounds (the
 * segment cursor's triangle source, traversal.h). */
#ifndef SOMBRA_RAY_TRIANGLE_H
#define SOMBRA_RAY_TRIANGLE_H
#include "lanes.h"

/* Parameter t of the crossing of each lane's ray origin + t·dir with the triangle (corner,
 * corner + e1, corner + e2); +∞ in lanes outside `lanes`, that miss it, that run in its plane
 * (|det| ≤ 10⁻⁷ |e1 × e2|) or when the triangle is degenerate (e1 × e2 = 0): no division by
 * zero, no NaN. t may be ≤ 0: callers bound it. */
inline lfloat ray_triangle_t(lfloat3 origin, lfloat3 dir, float3 corner, float3 e1, float3 e2, lmask lanes) {
    float area2 = dot(cross(e1, e2), cross(e1, e2)); /* |e1 × e2|² */
    if (!(area2 > 0.0f)) return (lfloat)(INFINITY); /* (a scalar test: & with a lane mask would truncate it) */
    lfloat3 pvec = l3(dir.y * e2.z - dir.z * e2.y, dir.z * e2.x - dir.x * e2.z, dir.x * e2.y - dir.y * e2.x);
    lfloat det = l3_dot_uniform(pvec, e1);
    lmask crossing = lanes & (det * det > 1e-14f * area2);
    if (!lany(crossing)) return (lfloat)(INFINITY);
    lfloat inv = 1.0f / select((lfloat)(1.0f), det, crossing);
    lfloat3 tvec = l3_sub(origin, l3_splat(corner));
    lfloat u = l3_dot(tvec, pvec) * inv;
    lfloat3 qvec = l3(tvec.y * e1.z - tvec.z * e1.y, tvec.z * e1.x - tvec.x * e1.z, tvec.x * e1.y - tvec.y * e1.x);
    lfloat v = l3_dot(dir, qvec) * inv;
    lfloat t = l3_dot_uniform(qvec, e2) * inv;
    crossing &= (u >= 0.0f) & (v >= 0.0f) & (u + v <= 1.0f);
    return select((lfloat)(INFINITY), t, crossing);
}

#endif
