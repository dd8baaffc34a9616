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
/* Precision of the lookups' geometry and weights: double where the device has it (the host
 * defines SOMBRA_SAT_FP64), else float. The sums themselves are exact either way: every box is an
 * integer inclusion–exclusion over 64-bit entries (which reach 2^50 and more), and only the
 * weighted blend of the small box sums is in sat_real. */
#ifdef SOMBRA_SAT_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double sat_real;
typedef double2 sat_real2;
typedef double3 sat_real3;
#define convert_sat_real3 convert_double3
#define SAT_PI M_PI
#else
typedef float sat_real;
typedef float2 sat_real2;
typedef float3 sat_real3;
#define convert_sat_real3 convert_float3
#define SAT_PI M_PI_F
#endif
#define SR(x) ((sat_real)(x)) /* a constant in sat_real (an unsuffixed literal would be double) */

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

/* The cells of a real interval [lo, hi) along one grid axis as consecutive weighted integer
 * ranges [bound[r], bound[r + 1]): the integral of a cell-wise constant σ over [lo, hi) is
 * Σ weight[r] · Σ σ(cells of range r) (a partial first cell, the whole cells between, a partial
 * last cell). The interval is clamped to the axis's n cells (σ is 0 outside them). */
typedef struct {
    int bound[4];
    sat_real weight[3];
    int ranges;
} SatAxis;

static inline SatAxis sat_axis(sat_real lo, sat_real hi, int n) {
    lo = clamp(lo, SR(0), (sat_real)n);
    hi = clamp(hi, lo, (sat_real)n);
    int first = min((int)floor(lo), n - 1), last = min((int)floor(hi), n - 1);
    sat_real f_lo = lo - (sat_real)first, f_hi = hi - (sat_real)last;
    /* every field is written at a fixed place: NVIDIA's optimiser miscompiled stores at a computed
     * index here in float builds (launch failure −9999; docs/gpu-check.md, the third lease) */
    bool one_cell = first == last, middle = last > first + 1, tail = !one_cell && f_hi != SR(0);
    SatAxis axis;
    axis.bound[0] = first, axis.bound[1] = first + 1;
    axis.bound[2] = middle ? last : last + 1, axis.bound[3] = last + 1;
    axis.weight[0] = one_cell ? f_hi - f_lo : SR(1) - f_lo;
    axis.weight[1] = middle ? SR(1) : f_hi; /* [first + 1, last) whole, else the last cell's part */
    axis.weight[2] = f_hi;
    axis.ranges = one_cell ? (axis.weight[0] != SR(0)) : 1 + (int)middle + (int)tail;
    return axis;
}

/* acc + Σ cells over the box of three axes' ranges: each of the ≤ 4 × 4 × 4 corner entries is
 * read once; the ≤ 27 range boxes are exact integer differences of them, taken one axis after
 * the other (S wraps modulo 2^64 in between, exact in the end); only their blend is sat_real. */
static inline sat_real sat_box_axes(sat_real acc, __global const ulong* s, int4 n, const SatAxis* x, const SatAxis* y, const SatAxis* z) {
    if (!x->ranges || !y->ranges || !z->ranges) return acc;
    ulong dx[3][4][4]; /* [x range][y bound][z bound]: Σ over the x range at one (y, z) corner */
    for (int q = 0; q <= y->ranges; ++q)
        for (int r = 0; r <= z->ranges; ++r) {
            ulong previous = s[sat_entry(n, x->bound[0], y->bound[q], z->bound[r])];
            for (int i = 0; i < x->ranges; ++i) {
                ulong next = s[sat_entry(n, x->bound[i + 1], y->bound[q], z->bound[r])];
                dx[i][q][r] = next - previous, previous = next;
            }
        }
    for (int i = 0; i < x->ranges; ++i)
        for (int j = 0; j < y->ranges; ++j)
            for (int k = 0; k < z->ranges; ++k) {
                ulong box = (dx[i][j + 1][k + 1] - dx[i][j][k + 1]) - (dx[i][j + 1][k] - dx[i][j][k]);
                acc += x->weight[i] * y->weight[j] * z->weight[k] * (sat_real)(long)box;
            }
    return acc;
}

/* Σ cells over the real box [lo, hi) (grid units; with wrap, axis 0 is periodic: [lo, hi), shorter
 * than the period, is moved into the first period and split where it crosses the end). S is
 * multilinear inside a cell, so this is the trilinear blend of S at the box's corners (Ament
 * Eq. 13 at real positions) without its cancellation. */
static inline sat_real sat_box_real(__global const ulong* s, int4 n, sat_real3 lo, sat_real3 hi, bool wrap) {
    SatAxis y = sat_axis(lo.y, hi.y, n.y), z = sat_axis(lo.z, hi.z, n.z);
    if (!wrap) {
        SatAxis x = sat_axis(lo.x, hi.x, n.x);
        return sat_box_axes(SR(0), s, n, &x, &y, &z);
    }
    sat_real shift = floor(lo.x / (sat_real)n.x) * (sat_real)n.x;
    SatAxis x = sat_axis(lo.x - shift, hi.x - shift, n.x);
    sat_real sum = sat_box_axes(SR(0), s, n, &x, &y, &z);
    if (hi.x - shift <= (sat_real)n.x) return sum;
    x = sat_axis(SR(0), hi.x - shift - (sat_real)n.x, n.x);
    return sat_box_axes(sum, s, n, &x, &y, &z);
}

#ifdef SOMBRA_LOWPASS_GAUSS
/* Gaussian filtering (Ament §4.3, Eq. 25): the patch is cut into K × K sub-boxes; each sub-box's
 * mean optical depth (its SAT box / its area) is weighted by the mass of a Gaussian with σ = a
 * quarter of the patch width (truncated at ±2σ) over it. */
#define SOMBRA_GAUSS_SUBBOXES 5
static inline sat_real normal_mass(sat_real a, sat_real b) {
    const sat_real inv_sqrt2 = SR(0.70710678118654752440);
    return SR(0.5) * (erf(b * inv_sqrt2) - erf(a * inv_sqrt2));
}

/* Grid point from the two lateral coordinates (the axes other than `axis`, in order) and depth. */
static inline sat_real3 sat_point(int axis, sat_real a, sat_real b, sat_real depth) {
    return axis == 0 ? (sat_real3)(depth, a, b) : axis == 1 ? (sat_real3)(a, depth, b) : (sat_real3)(a, b, depth);
}

/* Σ w·τ_sub / Σ w over the patch [lo, hi] across `axis`, [depth.x, depth.y] along it, in units of
 * S. `sphere` (SSAT) turns sub-box areas into solid angles over Δφ·Δθ; NULL: Cartesian cells. */
static inline sat_real gauss_patch(__global const ulong* s, int4 n, int axis, sat_real2 lo, sat_real2 hi, sat_real2 depth,
                                   bool wrap, __global const SsatGridGpu* sphere) {
    const int k = SOMBRA_GAUSS_SUBBOXES;
    sat_real2 step = (hi - lo) / (sat_real)k;
    sat_real sum = SR(0), weights = SR(0);
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            sat_real2 a = lo + (sat_real2)((sat_real)i * step.x, (sat_real)j * step.y);
            sat_real2 b = lo + (sat_real2)((sat_real)(i + 1) * step.x, (sat_real)(j + 1) * step.y);
            sat_real box = sat_box_real(s, n, sat_point(axis, a.x, a.y, depth.x), sat_point(axis, b.x, b.y, depth.y), wrap);
            sat_real area = step.x * step.y;
            if (sphere) { /* (cos θ_a − cos θ_b)/Δθ instead of the θ extent */
                sat_real ta = clamp((sat_real)sphere->start.y + a.y * (sat_real)sphere->cell.y, SR(0), SAT_PI);
                sat_real tb = clamp((sat_real)sphere->start.y + b.y * (sat_real)sphere->cell.y, SR(0), SAT_PI);
                area = step.x * (cos(ta) - cos(tb)) / (sat_real)sphere->cell.y;
            }
            sat_real w = normal_mass(SR(-2) + SR(4) * (sat_real)i / (sat_real)k, SR(-2) + SR(4) * (sat_real)(i + 1) / (sat_real)k) *
                         normal_mass(SR(-2) + SR(4) * (sat_real)j / (sat_real)k, SR(-2) + SR(4) * (sat_real)(j + 1) / (sat_real)k);
            if (area > SR(0)) sum += w * box / area, weights += w;
        }
    return weights > SR(0) ? sum / weights : SR(0);
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
    /* a table the box cannot reach adds 0 (a light may have one table per group of volumes): the
     * box (lateral W/2 and the blend's next cell around c) misses the grid across the light, or
     * the table lies behind the sample, away from the light */
    for (int a = 0; a < 3; ++a) {
        float extent = a == 0 ? n.x : a == 1 ? n.y : n.z;
        if (a != axis && (c[a] + 0.5f * width + 1.0f < 0.0f || c[a] - 0.5f * width - 1.0f > extent)) return 0.0f;
        if (a == axis && (g->light_positive ? c[a] - 1.0f > extent : c[a] + 1.0f < 0.0f)) return 0.0f;
    }
#ifdef SOMBRA_LOWPASS_GAUSS
    {
        int a0 = axis == 0 ? 1 : 0, a1 = axis == 2 ? 1 : 2; /* the lateral axes, in order */
        sat_real2 centre = (sat_real2)(c[a0], c[a1]);
        sat_real extent = axis == 0 ? n.x : axis == 1 ? n.y : n.z;
        sat_real along = clamp((sat_real)c[axis], SR(0), extent);
        sat_real2 depth = g->light_positive ? (sat_real2)(along, extent) : (sat_real2)(SR(0), along);
        sat_real half_patch = SR(0.5) * (sat_real)width;
        return (float)(gauss_patch(s, n, axis, centre - half_patch, centre + half_patch, depth, false, 0) * (sat_real)g->tau_per_unit);
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
    sat_real3 c = (sat_real3)(dot(g->to_grid[0].xyz, p) + g->to_grid[0].w, dot(g->to_grid[1].xyz, p) + g->to_grid[1].w,
                              dot(g->to_grid[2].xyz, p) + g->to_grid[2].w);
    sat_real radius = SR(0.5) * (sat_real)g->filter_cells;
    sat_real box = sat_box_real(sat + g->data_offset, g->dims, c - radius, c + radius, false);
    return (float)(box * (sat_real)g->tau_per_unit / (SR(8) * radius * radius));
}

/* Cone shadows: the cone of half angle atan(cone_tan) from p towards the light (unit vector
 * `towards`, up to world distance `reach`) as a series of cubes of growing size along its axis,
 * each read from the SAT in constant time: τ = Σ mean σ(cube) · its length. A cube of radius
 * ≥ SOMBRA_CONE_SNAP_RADIUS cells has its faces moved to the nearest cell faces (by ≤ ½ cell, ≤ 1/8
 * of its side): one integer box of 8 entries instead of the exact real box's up to 64. That moved
 * the shipped scenes' images by 1e-4 RMS, against the technique's own 2e-3–2e-2 RMS error, and T
 * by up to 0.06 at a point of a 20³ noise cloud (docs/lowpass.md). The march stops once the light
 * is gone (SOMBRA_OPAQUE_DEPTH). */
static inline float sat_cone_depth(__global const ulong* sat, __global const SatGridGpu* g, float3 p, float3 towards, float reach) {
    __global const ulong* s = sat + g->data_offset;
    /* whole vectors: written one lane at a time through a pointer (until 2026-12-07), their fourth
     * (padding) lane kept the stack's garbage, which the vector arithmetic below carries along, and
     * a subnormal left there by an earlier kernel made PoCL's cone pass 1.4× slower for the rest of
     * the process (teapot_fog at 128²: 72 → 103 ms after one deep-shadow-map build; bench/README.md
     * "sombra_bench_frame_sequence"; tests/portability/kernel_rules.sh) */
    const sat_real3 c = (sat_real3)((sat_real)(dot(g->to_grid[0].xyz, p) + g->to_grid[0].w), (sat_real)(dot(g->to_grid[1].xyz, p) + g->to_grid[1].w),
                                    (sat_real)(dot(g->to_grid[2].xyz, p) + g->to_grid[2].w));
    const sat_real3 d = (sat_real3)((sat_real)(dot(g->to_grid[0].xyz, towards) * g->cell_size), /* unit vector in grid axes */
                                    (sat_real)(dot(g->to_grid[1].xyz, towards) * g->cell_size),
                                    (sat_real)(dot(g->to_grid[2].xyz, towards) * g->cell_size));
    sat_real3 n = convert_sat_real3(g->dims.xyz);
    /* the grid covers the occupied bricks only: from a point outside it (at distance `outside`), the
     * march first skips the cubes that miss the grid */
    sat_real outside = length(fmax(fmax(-c, c - n), SR(0)));
    sat_real t_max = fmin((sat_real)reach / (sat_real)g->cell_size, SR(4) * (n.x + n.y + n.z) + outside);
    sat_real tau = SR(0), t = SR(0.5), opaque = (sat_real)SOMBRA_OPAQUE_DEPTH / (sat_real)g->tau_per_unit;
    if (outside > SR(0))
        for (int i = 0; i < 256 && t < t_max; ++i) { /* the cubes before the grid */
            sat_real radius = fmax(SR(0.5), t * (sat_real)g->cone_tan), span = fmin(SR(2) * radius, t_max - t);
            sat_real3 centre = c + (t + SR(0.5) * span) * d;
            if (!any(centre + radius < SR(0)) && !any(centre - radius > n)) break;
            t += span;
        }
    for (int i = 0; i < 256 && t < t_max && tau <= opaque; ++i) {
        sat_real radius = fmax(SR(0.5), t * (sat_real)g->cone_tan), span = fmin(SR(2) * radius, t_max - t);
        sat_real3 centre = c + (t + SR(0.5) * span) * d;
        if (any(centre + radius < SR(0)) || any(centre - radius > n)) break; /* left the grid */
        sat_real mean;
        if (radius >= SR(SOMBRA_CONE_SNAP_RADIUS)) { /* faces on the nearest cell faces: one integer box */
            int3 lo = convert_int3(round(centre - radius)), hi = convert_int3(round(centre + radius));
            int3 side = hi - lo;
            mean = (sat_real)sat_box(s, g->dims, lo, hi) / ((sat_real)side.x * (sat_real)side.y * (sat_real)side.z);
        } else
            mean = sat_box_real(s, g->dims, centre - radius, centre + radius, false) / (SR(8) * radius * radius * radius);
        tau += mean * span;
        t += span;
    }
    return (float)(tau * (sat_real)g->tau_per_unit);
}

/* Box-filtered optical depth from world point p towards point light g (Ament Eq. 16–24): the
 * tangential W × W patch at p (Eq. 16) seen from the light spans φ ± U/(R sin θ), θ ± U/R; the
 * spherical pyramid runs from the light to p (Eq. 21–22). τ̄ = Σ(σ·Δr·w_θ)·Δφ·Δθ / Ω_box (the
 * solid-angle average over the pyramid's rays, Eq. 24). Boxes across φ = ±π wrap; near the
 * poles the box takes every φ. With SOMBRA_LOWPASS_GAUSS, Gaussian weights over sub-boxes. */
static inline float ssat_filtered_depth(__global const ulong* sat, __global const SsatGridGpu* g, float3 p) {
    __global const ulong* s = sat + g->data_offset;
    int4 n = g->dims;
    sat_real3 d = convert_sat_real3(p - g->light.xyz);
    sat_real x = dot(d, convert_sat_real3(g->axes[0].xyz)), y = dot(d, convert_sat_real3(g->axes[1].xyz));
    sat_real z = dot(d, convert_sat_real3(g->axes[2].xyz));
    sat_real r = sqrt(x * x + y * y + z * z);
    if (!(r > SR(1e-9))) return 0.0f; /* at the light */
    /* a table the pyramid cannot reach adds 0, before any trigonometry (a light may have one table
     * per group of volumes): p no farther than the table's first radius, or the pyramid (half
     * angle β, tan β = √2·U/r, the patch's corners) outside the table's cone (α: cos_reach) */
    if (r <= (sat_real)g->start.z) return 0.0f;
    sat_real u = g->half_width, slant = sqrt(r * r + SR(2) * u * u);
    sat_real cos_beta = r / slant, sin_beta = sqrt(SR(2)) * u / slant;
    sat_real cos_a = g->cos_reach, sin_a = g->sin_reach;
    if (sin_a * cos_beta + cos_a * sin_beta > SR(0) && x < r * (cos_a * cos_beta - sin_a * sin_beta)) return 0.0f; /* α + β < π */
    sat_real theta = acos(clamp(z / r, SR(-1), SR(1))), phi = atan2(y, x);
    sat_real h_theta = fmin(u / r, SAT_PI), h_phi = u / (r * fmax(sin(theta), SR(1e-9)));
    bool all_phi = h_phi >= SAT_PI;
    sat_real3 start = convert_sat_real3(g->start.xyz), cell = convert_sat_real3(g->cell.xyz);
    sat_real3 lo = ((sat_real3)(phi - h_phi, theta - h_theta, start.z) - start) / cell;
    sat_real3 hi = ((sat_real3)(phi + h_phi, theta + h_theta, r) - start) / cell;
    if (all_phi) lo.x = SR(0), hi.x = (sat_real)n.x;
    bool wrap = g->wrap_phi && !all_phi;
#ifdef SOMBRA_LOWPASS_GAUSS
    return (float)(gauss_patch(s, n, 2, lo.xy, hi.xy, (sat_real2)(lo.z, hi.z), wrap, g) * (sat_real)g->tau_per_unit);
#else
    sat_real theta_lo = fmax(theta - h_theta, SR(0)), theta_hi = fmin(theta + h_theta, SAT_PI);
    sat_real solid_angle = (all_phi ? SR(2) * SAT_PI : SR(2) * h_phi) * (cos(theta_lo) - cos(theta_hi));
    sat_real sum = sat_box_real(s, n, lo, hi, wrap);
    return solid_angle > SR(0) ? (float)(sum * cell.x * cell.y * (sat_real)g->tau_per_unit / solid_angle) : 0.0f;
#endif
}

#endif
