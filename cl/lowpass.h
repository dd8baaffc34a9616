/* sombra — low-pass filtered optical depth from a light-aligned summed-area table (Ament §4.2.1–
 * 4.2.2, Eq. 7–15). The box of a sample is W × W cells across the light (centred on the sample,
 * Eq. 7, U = V = W/2) and runs from the sample to the grid's face towards the light (Eq. 8, 10);
 * its sum (Eq. 12) is one inclusion–exclusion over 8 SAT corners (Eq. 13), so the cost does not
 * depend on W. The sample lies between cell boundaries: the box is the blend of the 2×2×2 boxes
 * at the neighbouring integer positions, which is the exact integral of the cell-wise constant σ
 * over the box at the sample's real position (S is multilinear inside a cell). Each box is an
 * exact 64-bit integer; only their blend is float. See shared/types.h for the table layout. */
#ifndef SOMBRA_LOWPASS_H
#define SOMBRA_LOWPASS_H
#include "shared/types.h"

inline size_t sat_entry(int4 n, int i, int j, int k) {
    return (size_t)i + (size_t)(n.x + 1) * ((size_t)j + (size_t)(n.y + 1) * (size_t)k);
}

inline ulong sat_fixed_point(float tau) {
    return convert_ulong_sat_rte(fmin(fmax(tau, 0.0f), SOMBRA_SAT_MAX_CELL_TAU) * SOMBRA_SAT_UNITS_PER_TAU);
}

/* Σ cells in [lo, hi) (integer bounds, clamped to the grid: σ is 0 outside it). */
inline long sat_box(__global const ulong* s, int4 n, int3 lo, int3 hi) {
    lo = clamp(lo, (int3)(0), n.xyz);
    hi = clamp(hi, (int3)(0), n.xyz);
    ulong sum = s[sat_entry(n, hi.x, hi.y, hi.z)] - s[sat_entry(n, lo.x, hi.y, hi.z)] - s[sat_entry(n, hi.x, lo.y, hi.z)] -
                s[sat_entry(n, hi.x, hi.y, lo.z)] + s[sat_entry(n, lo.x, lo.y, hi.z)] + s[sat_entry(n, lo.x, hi.y, lo.z)] +
                s[sat_entry(n, hi.x, lo.y, lo.z)] - s[sat_entry(n, lo.x, lo.y, lo.z)];
    return (long)sum; /* wraps modulo 2^64 in between, exact in the end */
}

/* Box-filtered optical depth τ̄ from world point p towards the light of grid g (Ament Eq. 13, 15):
 * CSAT(C) / A with A = W² cells. */
inline float csat_filtered_depth(__global const ulong* sat, __global const SatGridGpu* g, float3 p) {
    __global const ulong* s = sat + g->data_offset;
    int4 n = g->dims;
    int width = (int)g->filter_cells;
    float c[3];
    for (int a = 0; a < 3; ++a) c[a] = dot(g->to_grid[a].xyz, p) + g->to_grid[a].w;
    int axis = (int)g->light_axis;
    int lo0[3], hi0[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
        int extent = a == 0 ? n.x : a == 1 ? n.y : n.z;
        /* lateral: [c − W/2, c + W/2]; along the light: from c to the face towards the light */
        float start = a == axis ? c[a] : c[a] - 0.5f * width;
        start = clamp(start, -2.0f - width, extent + 2.0f); /* finite ints outside the grid */
        float base = floor(start);
        f[a] = start - base;
        int b = (int)base;
        if (a != axis) lo0[a] = b, hi0[a] = b + width;
        else if (g->light_positive) lo0[a] = b, hi0[a] = extent;
        else lo0[a] = 0, hi0[a] = b; /* [0, c]: the upper bound moves */
    }
    float sum = 0.0f;
    for (int corner = 0; corner < 8; ++corner) {
        int lo[3], hi[3];
        float weight = 1.0f;
        for (int a = 0; a < 3; ++a) {
            int shift = (corner >> a) & 1;
            weight *= shift ? f[a] : 1.0f - f[a];
            bool fixed_hi = a == axis && g->light_positive, fixed_lo = a == axis && !g->light_positive;
            lo[a] = lo0[a] + (fixed_lo ? 0 : shift);
            hi[a] = hi0[a] + (fixed_hi ? 0 : shift);
        }
        if (weight == 0.0f) continue;
        sum += weight * (float)sat_box(s, n, (int3)(lo[0], lo[1], lo[2]), (int3)(hi[0], hi[1], hi[2]));
    }
    return sum * g->tau_per_unit / (float)(width * width);
}

#endif
