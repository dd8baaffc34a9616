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
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

static inline size_t sat_entry(int4 n, int i, int j, int k) {
    return (size_t)i + (size_t)(n.x + 1) * ((size_t)j + (size_t)(n.y + 1) * (size_t)k);
}

static inline ulong sat_fixed_point(float tau) {
    return convert_ulong_sat_rte(fmin(fmax(tau, 0.0f), SOMBRA_SAT_MAX_CELL_TAU) * SOMBRA_SAT_UNITS_PER_TAU);
}

/* Σ cells in [lo, hi) (integer bounds, clamped to the grid: σ is 0 outside it). */
static inline long sat_box(__global const ulong* s, int4 n, int3 lo, int3 hi) {
    lo = clamp(lo, (int3)(0), n.xyz);
    hi = clamp(hi, (int3)(0), n.xyz);
    ulong sum = s[sat_entry(n, hi.x, hi.y, hi.z)] - s[sat_entry(n, lo.x, hi.y, hi.z)] - s[sat_entry(n, hi.x, lo.y, hi.z)] -
                s[sat_entry(n, hi.x, hi.y, lo.z)] + s[sat_entry(n, lo.x, lo.y, hi.z)] + s[sat_entry(n, lo.x, hi.y, lo.z)] +
                s[sat_entry(n, hi.x, lo.y, lo.z)] - s[sat_entry(n, lo.x, lo.y, lo.z)];
    return (long)sum; /* wraps modulo 2^64 in between, exact in the end */
}

/* S at a real grid position: trilinear in the integer entries (exact for cell-wise constant
 * cells), in double: the entries reach 2^50 and more, the boxes built from them are small. */
static inline double sat_at(__global const ulong* s, int4 n, double3 g) {
    g = clamp(g, (double3)(0.0), convert_double3(n.xyz));
    int3 i = min(convert_int3(floor(g)), n.xyz - 1);
    i = max(i, (int3)(0));
    double3 f = g - convert_double3(i);
    double sum = 0.0;
    for (int c = 0; c < 8; ++c) {
        int3 o = (int3)(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        int3 e = min(i + o, n.xyz);
        double w = (o.x ? f.x : 1.0 - f.x) * (o.y ? f.y : 1.0 - f.y) * (o.z ? f.z : 1.0 - f.z);
        if (w != 0.0) sum += w * (double)s[sat_entry(n, e.x, e.y, e.z)];
    }
    return sum;
}

/* S at real grid position g; with wrap, grid axis 0 is periodic: S(x + k·n.x) = S(x) + k·S(n.x). */
static inline double sat_at_wrapped(__global const ulong* s, int4 n, double3 g, bool wrap) {
    if (!wrap) return sat_at(s, n, g);
    double turns = floor(g.x / n.x);
    return sat_at(s, n, (double3)(g.x - turns * n.x, g.y, g.z)) + turns * sat_at(s, n, (double3)(n.x, g.y, g.z));
}

/* Σ cells over the real box [lo, hi) (grid units): 8 corners of S. */
static inline double sat_box_real(__global const ulong* s, int4 n, double3 lo, double3 hi, bool wrap) {
    double sum = 0.0;
    for (int c = 0; c < 8; ++c) {
        double3 corner = (double3)(c & 1 ? lo.x : hi.x, c & 2 ? lo.y : hi.y, c & 4 ? lo.z : hi.z);
        sum += (popcount(c) & 1 ? -1.0 : 1.0) * sat_at_wrapped(s, n, corner, wrap);
    }
    return sum;
}

#ifdef SOMBRA_LOWPASS_GAUSS
/* Gaussian filtering (Ament §4.3, Eq. 25): the patch is cut into K × K sub-boxes; each sub-box's
 * mean optical depth (its SAT box / its area) is weighted by the mass of a Gaussian with σ = a
 * quarter of the patch width (truncated at ±2σ) over it. The (K+1)² × 2 corners of S are read once. */
#define SOMBRA_GAUSS_SUBBOXES 5
static inline double normal_mass(double a, double b) { return 0.5 * (erf(b * M_SQRT1_2) - erf(a * M_SQRT1_2)); }

/* Grid point from the two lateral coordinates (the axes other than `axis`, in order) and depth. */
static inline double3 sat_point(int axis, double a, double b, double depth) {
    return axis == 0 ? (double3)(depth, a, b) : axis == 1 ? (double3)(a, depth, b) : (double3)(a, b, depth);
}

/* Σ w·τ_sub / Σ w over the patch [lo, hi] across `axis`, [depth.x, depth.y] along it, in units of
 * S. `sphere` (SSAT) turns sub-box areas into solid angles over Δφ·Δθ; NULL: Cartesian cells. */
static inline double gauss_patch(__global const ulong* s, int4 n, int axis, double2 lo, double2 hi, double2 depth, bool wrap,
                          __global const SsatGridGpu* sphere) {
    const int k = SOMBRA_GAUSS_SUBBOXES;
    double corner[SOMBRA_GAUSS_SUBBOXES + 1][SOMBRA_GAUSS_SUBBOXES + 1][2];
    double2 step = (hi - lo) / k;
    for (int i = 0; i <= k; ++i)
        for (int j = 0; j <= k; ++j)
            for (int d = 0; d < 2; ++d)
                corner[i][j][d] = sat_at_wrapped(s, n, sat_point(axis, lo.x + i * step.x, lo.y + j * step.y, d ? depth.y : depth.x), wrap);
    double sum = 0.0, weights = 0.0;
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            double box = 0.0;
            for (int d = 0; d < 2; ++d)
                box += (d ? 1.0 : -1.0) * (corner[i + 1][j + 1][d] - corner[i][j + 1][d] - corner[i + 1][j][d] + corner[i][j][d]);
            double area = step.x * step.y;
            if (sphere) { /* (cos θ_a − cos θ_b)/Δθ instead of the θ extent */
                double ta = clamp(sphere->start.y + (lo.y + j * step.y) * sphere->cell.y, 0.0, M_PI);
                double tb = clamp(sphere->start.y + (lo.y + (j + 1) * step.y) * sphere->cell.y, 0.0, M_PI);
                area = step.x * (cos(ta) - cos(tb)) / sphere->cell.y;
            }
            double w = normal_mass(-2.0 + 4.0 * i / k, -2.0 + 4.0 * (i + 1) / k) * normal_mass(-2.0 + 4.0 * j / k, -2.0 + 4.0 * (j + 1) / k);
            if (area > 0.0) sum += w * box / area, weights += w;
        }
    return weights > 0.0 ? sum / weights : 0.0;
}
#endif

/* Box-filtered optical depth τ̄ from world point p towards the light of grid g (Ament Eq. 13, 15):
 * CSAT(C) / A with A = W² cells; with SOMBRA_LOWPASS_GAUSS, Gaussian weights over sub-boxes (Eq. 25). */
static inline float csat_filtered_depth(__global const ulong* sat, __global const SatGridGpu* g, float3 p) {
    __global const ulong* s = sat + g->data_offset;
    int4 n = g->dims;
    int width = (int)g->filter_cells;
    float c[3];
    for (int a = 0; a < 3; ++a) c[a] = dot(g->to_grid[a].xyz, p) + g->to_grid[a].w;
    int axis = (int)g->light_axis;
#ifdef SOMBRA_LOWPASS_GAUSS
    {
        int a0 = axis == 0 ? 1 : 0, a1 = axis == 2 ? 1 : 2; /* the lateral axes, in order */
        double2 centre = (double2)(c[a0], c[a1]);
        double extent = axis == 0 ? n.x : axis == 1 ? n.y : n.z;
        double along = clamp((double)c[axis], 0.0, extent);
        double2 depth = g->light_positive ? (double2)(along, extent) : (double2)(0.0, along);
        return (float)(gauss_patch(s, n, axis, centre - 0.5 * width, centre + 0.5 * width, depth, false, 0) * g->tau_per_unit);
    }
#endif
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

/* Baselines on one volume-aligned SAT (Schlegel et al. 2011). Ambient occlusion: the mean σ in the
 * cube of side W cells around p times W/2 cells, the optical depth of an average ray of that
 * radius (no direction). */
static inline float sat_ambient_depth(__global const ulong* sat, __global const SatGridGpu* g, float3 p) {
    double3 c;
    for (int a = 0; a < 3; ++a) ((double*)&c)[a] = dot(g->to_grid[a].xyz, p) + g->to_grid[a].w;
    double radius = 0.5 * g->filter_cells;
    double box = sat_box_real(sat + g->data_offset, g->dims, c - radius, c + radius, false);
    return (float)(box * g->tau_per_unit / (8.0 * radius * radius));
}

/* Cone shadows: the cone of half angle atan(cone_tan) from p towards the light (unit vector
 * `towards`, up to world distance `reach`) as a series of cubes of growing size along its axis,
 * each read from the SAT in constant time: τ = Σ mean σ(cube) · its length. */
static inline float sat_cone_depth(__global const ulong* sat, __global const SatGridGpu* g, float3 p, float3 towards, float reach) {
    __global const ulong* s = sat + g->data_offset;
    double3 c, d;
    for (int a = 0; a < 3; ++a) {
        ((double*)&c)[a] = dot(g->to_grid[a].xyz, p) + g->to_grid[a].w;
        ((double*)&d)[a] = dot(g->to_grid[a].xyz, towards) * g->cell_size; /* unit vector in grid axes */
    }
    double3 n = convert_double3(g->dims.xyz);
    double t_max = fmin((double)reach / g->cell_size, 4.0 * (n.x + n.y + n.z));
    double tau = 0.0, t = 0.5;
    for (int i = 0; i < 256 && t < t_max; ++i) {
        double radius = fmax(0.5, t * g->cone_tan), span = fmin(2.0 * radius, t_max - t);
        double3 centre = c + (t + 0.5 * span) * d;
        if (any(centre + radius < 0.0) || any(centre - radius > n)) break; /* left the grid */
        double box = sat_box_real(s, g->dims, centre - radius, centre + radius, false);
        tau += box / (8.0 * radius * radius * radius) * span;
        t += span;
    }
    return (float)(tau * g->tau_per_unit);
}

/* Box-filtered optical depth from world point p towards point light g (Ament Eq. 16–24): the
 * tangential W × W patch at p (Eq. 16) seen from the light spans φ ± U/(R sin θ), θ ± U/R; the
 * spherical pyramid runs from the light to p (Eq. 21–22). τ̄ = Σ(σ·Δr·w_θ)·Δφ·Δθ / Ω_box (the
 * solid-angle average over the pyramid's rays, Eq. 24). Boxes across φ = ±π wrap; near the
 * poles the box takes every φ. With SOMBRA_LOWPASS_GAUSS, Gaussian weights over sub-boxes. */
static inline float ssat_filtered_depth(__global const ulong* sat, __global const SsatGridGpu* g, float3 p) {
    __global const ulong* s = sat + g->data_offset;
    int4 n = g->dims;
    double3 d = convert_double3(p - g->light.xyz);
    double x = dot(d, convert_double3(g->axes[0].xyz)), y = dot(d, convert_double3(g->axes[1].xyz));
    double z = dot(d, convert_double3(g->axes[2].xyz));
    double r = sqrt(x * x + y * y + z * z);
    if (!(r > 1e-9)) return 0.0f; /* at the light */
    double theta = acos(clamp(z / r, -1.0, 1.0)), phi = atan2(y, x);
    double u = g->half_width, h_theta = fmin(u / r, M_PI), h_phi = u / (r * fmax(sin(theta), 1e-9));
    bool all_phi = h_phi >= M_PI;
    double3 start = convert_double3(g->start.xyz), cell = convert_double3(g->cell.xyz);
    double3 lo = ((double3)(phi - h_phi, theta - h_theta, start.z) - start) / cell;
    double3 hi = ((double3)(phi + h_phi, theta + h_theta, r) - start) / cell;
    if (all_phi) lo.x = 0.0, hi.x = n.x;
    bool wrap = g->wrap_phi && !all_phi;
#ifdef SOMBRA_LOWPASS_GAUSS
    return (float)(gauss_patch(s, n, 2, lo.xy, hi.xy, (double2)(lo.z, hi.z), wrap, g) * g->tau_per_unit);
#else
    double theta_lo = fmax(theta - h_theta, 0.0), theta_hi = fmin(theta + h_theta, M_PI);
    double solid_angle = (all_phi ? 2.0 * M_PI : 2.0 * h_phi) * (cos(theta_lo) - cos(theta_hi));
    double sum = sat_box_real(s, n, lo, hi, wrap);
    return solid_angle > 0.0 ? (float)(sum * cell.x * cell.y * g->tau_per_unit / solid_angle) : 0.0f;
#endif
}

#endif
