/* sombra — building a light-aligned summed-area table (Ament §4.2.1, §5). sat_resample integrates
 * the extinction σ of every volume (through its transfer function, as the camera pass classifies
 * it) over each cell of a grid aligned with the light and stores the cell's optical depth as a
 * 64-bit fixed-point integer (shared/types.h), already summed along grid axis 2; sat_scan sums
 * along axis 0 or 1. One work-item per line: the prefix sums run in parallel over lines. Integer
 * sums are exact and independent of the order, so the table cannot cancel the way float32 SATs
 * do (docs/architecture.md "Numerics"). The resamples march SOMBRA_LANES neighbouring columns
 * together (lanes.h; the scans are scalar); defines as dsm_build.cl. */
#include "shared/types.h"
#include "lanes.h"
#include "volume_sample.h"
#include "traversal.h"
#include "lowpass.h"

/* Whether the voxel-space part from p0 to p1 lies in bricks of volume v whose σ is 0 everywhere
 * (the camera pass's occupancy flags, traversal.h): the bricks under its bounding box, when it
 * spans at most three per axis (a table cell spans one or two), all empty. Such a part adds
 * exactly 0, so skipping it changes no bit of the table. */
static inline int part_in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* v, float3 p0, float3 p1) {
    float3 last = (float3)((float)(v->dims.x - 1), (float)(v->dims.y - 1), (float)(v->dims.z - 1));
    int3 lo = convert_int3(clamp(fmin(p0, p1), 0.0f, last)) / SOMBRA_BRICK_SIZE;
    int3 hi = min(convert_int3(clamp(fmax(p0, p1), 0.0f, last)) / SOMBRA_BRICK_SIZE, v->brick_dims.xyz - 1);
    /* trilinear samples in the last voxel of a brick read the next brick's first: its flags cover
     * them (scene_upload.cpp), and a sample at a brick's upper face is the next brick's */
    if (any(hi - lo > 2)) return 0;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x)
                if (occupancy[v->brick_offset + x + v->brick_dims.x * (y + v->brick_dims.y * z)]) return 0;
    return 1;
}

/* part_in_empty_bricks for the part [t0, t1] of each lane's ray in volume i. */
static inline lmask segment_in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* v, const VolumeRay* ray,
                                            uint i, lfloat t0, lfloat t1) {
    lfloat3 q0 = ray_voxel_point(ray, i, t0), q1 = ray_voxel_point(ray, i, t1);
    float x0[SOMBRA_LANES], y0[SOMBRA_LANES], z0[SOMBRA_LANES], x1[SOMBRA_LANES], y1[SOMBRA_LANES], z1[SOMBRA_LANES];
    LSTORE(q0.x, x0), LSTORE(q0.y, y0), LSTORE(q0.z, z0), LSTORE(q1.x, x1), LSTORE(q1.y, y1), LSTORE(q1.z, z1);
    int empty[SOMBRA_LANES];
    for (int lane = 0; lane < SOMBRA_LANES; ++lane)
        empty[lane] = part_in_empty_bricks(occupancy, v, (float3)(x0[lane], y0[lane], z0[lane]), (float3)(x1[lane], y1[lane], z1[lane]))
                          ? (SOMBRA_LANES == 1 ? 1 : -1)
                          : 0;
    return LLOAD(empty);
}

/* ∫σ of volume i over each lane's part [t0, t1] of the ray (lanes `inside`; t0, t1 finite in every
 * lane), *density the density at t0: in steps of at most the volume's ray step, each integrated
 * as the other light passes integrate it (traversal.h interval_volume_depth: split at the
 * voxel-centre planes it crosses when the volume is stiff, else one pre-integrated interval).
 * *density becomes the density at t1. */
static inline lfloat part_optical_depth(VOLUME_DATA_PARAM, __global const VolumeGpu* v, __global const float* tf_tables,
                                        const VolumeRay* ray, uint i, lfloat t0, lfloat t1, lfloat* density, lmask inside) {
    lint steps = lclamp(LCONVERT_INT(ceil((t1 - t0) / v->step - 1e-3f)), 1, 4096); /* 1e-3: the same count in double */
    lfloat h = (t1 - t0) / LCONVERT_FLOAT(steps), ta = t0, da = *density, depth = (lfloat)(0.0f);
    for (int s = 1; s <= 4096; ++s) {
        lmask more = inside & (steps >= s);
        if (!lany(more)) break;
        lfloat tb = select(ta, select(t0 + (float)s * h, t1, steps == s), more);
        lfloat db = density_at_point(volume_data, v, ray, i, tb);
        depth += select((lfloat)(0.0f), interval_volume_depth(volume_data, v, tf_tables, ray, i, ta, tb, da, db, more), more);
        ta = tb, da = select(da, db, more);
    }
    *density = da;
    return depth;
}

/* The density each lane's ray ended its last part with, and where (a column's cells share their
 * faces: a part that starts where the previous one ended reuses the sample). */
typedef struct {
    lfloat t[SOMBRA_VOLUME_SLOTS], density[SOMBRA_VOLUME_SLOTS];
} PartEnds;

static inline void no_part_ends(PartEnds* ends) {
    for (uint i = 0; i < SOMBRA_VOLUME_SLOTS; ++i) ends->t[i] = (lfloat)(-INFINITY), ends->density[i] = (lfloat)(0.0f);
}

/* Optical depth of each lane's stretch [ta, tb] of `ray` (lanes `live`) under the renderer's model:
 * each volume's part inside its box [−0.5, dims − 0.5] (part_optical_depth); parts in empty bricks
 * are skipped. The lanes march together, each its own number of steps (on CPU devices the packet
 * is how the kernel reaches the SIMD units, lanes.h); every lane computes what one lane would.
 * `ends`: the previous stretch's part ends on the same ray, updated. */
static inline lfloat stretch_optical_depth(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const VolumeGpu* volumes,
                                           uint volume_count, __global const float* tf_tables, const VolumeRay* ray, lfloat ta,
                                           lfloat tb, lmask live, PartEnds* ends) {
    lfloat depth = (lfloat)(0.0f);
    for (uint i = 0; i < volume_count; ++i) {
        __global const VolumeGpu* v = &volumes[i];
        lfloat t0 = fmax(ta, ray->t_enter[i]), t1 = fmin(tb, ray->t_exit[i]); /* missed: both +∞ */
        lmask inside = live & (t0 < t1);
        if (!lany(inside)) continue;
        t0 = select((lfloat)(0.0f), t0, inside), t1 = select((lfloat)(0.0f), t1, inside);
        inside &= !segment_in_empty_bricks(occupancy, v, ray, i, t0, t1);
        if (!lany(inside)) continue;
        lmask fresh = inside & (t0 != ends->t[i]);
        lfloat density = ends->density[i];
        if (lany(fresh)) density = select(density, density_at_point(volume_data, v, ray, i, t0), fresh);
        depth += select((lfloat)(0.0f), part_optical_depth(volume_data, v, tf_tables, ray, i, t0, t1, &density, inside), inside);
        ends->t[i] = select(ends->t[i], t1, inside);
        ends->density[i] = select(ends->density[i], density, inside);
    }
    return depth;
}

/* Optical depth of each lane's segment from a to b (lanes `active`) through the volumes of
 * `volume_mask`: stretch_optical_depth of a ray of its own. */
static inline lfloat segment_optical_depth(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const VolumeGpu* volumes,
                                           uint volume_count, uint volume_mask, __global const float* tf_tables, lfloat3 a, lfloat3 b,
                                           lmask active) {
    lfloat3 ab = l3_sub(b, a);
    lfloat length = sqrt(l3_dot(ab, ab));
    lmask live = active & (length > 0.0f);
    if (!lany(live)) return (lfloat)(0.0f);
    VolumeRay ray;
    length = select((lfloat)(0.0f), length, live);
    make_volume_ray(&ray, volumes, volume_count, a, l3_scale(ab, 1.0f / select((lfloat)(1.0f), length, live)), (lfloat)(0.0f), length);
    volume_ray_only(&ray, volume_count, volume_mask);
    PartEnds ends;
    no_part_ends(&ends);
    return stretch_optical_depth(volume_data, occupancy, volumes, volume_count, tf_tables, &ray, (lfloat)(0.0f), length, live, &ends);
}

/* The lanes' cells' optical depths `depth` (fixed point, sat_fixed_point) added to their columns'
 * running sums, written to S(i + 1, j + 1, k + 1) for the lanes' i = i0 + lane < n.x. */
static inline void write_running_sums(__global ulong* s, int4 n, int i0, int j, int k, lfloat depth, ulong* running) {
    float cell[SOMBRA_LANES];
    LSTORE(depth, cell);
    for (int lane = 0; lane < SOMBRA_LANES && i0 + lane < n.x; ++lane) {
        running[lane] += sat_fixed_point(cell[lane]);
        s[sat_entry(n, i0 + lane + 1, j + 1, k + 1)] = running[lane];
    }
}

/* Work-item (p, j): the columns of cells (i, j, 0 … n.z − 1), i = p·SOMBRA_LANES + lane, of the
 * grid origin + i·cell_u + j·cell_v + k·cell_w. A cell holds the optical depth along the lights'
 * axes through its centre, face to face (the mean over the axes in light_axes: bit a = a light
 * shines along grid axis a; a table no light is aligned with uses all three) — ∫σ over the cell
 * under the renderer's model, not σ at its centre times the cell, so a thin near-opaque feature
 * inside a cell counts in full; the volumes of volume_mask only (a table per group of volumes,
 * src/shadows/sat_grid.h). Clamped to SOMBRA_SAT_MAX_CELL_TAU and rounded to fixed point; the
 * column's running sums go to S(i + 1, j + 1, k + 1); the zero border S(0, ·, ·) … is cleared by
 * the host. */
__kernel void sat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                           uint volume_count, __global const uchar* occupancy, __global ulong* sat, uint data_offset, int4 n, float4 origin,
                           float4 cell_u, float4 cell_v, float4 cell_w, float cell_length, uint light_axes, uint volume_mask) {
    int i0 = get_global_id(0) * SOMBRA_LANES, j = get_global_id(1);
    if (i0 >= n.x || j >= n.y) return;
    lint i = i0 + LANE_INDEX;
    lmask active = i < n.x;
    lfloat u = LCONVERT_FLOAT(i) + 0.5f;
    float3 row = origin.xyz + (j + 0.5f) * cell_v.xyz;
    lfloat3 base = l3_mad(l3_splat(cell_u.xyz), u, l3_splat(row)); /* the column's start: the face of cell k = 0 */
    float3 axis[3] = {cell_u.xyz, cell_v.xyz, cell_w.xyz};
    uint axes = light_axes & 7u ? light_axes & 7u : 7u;
    float count = (float)popcount(axes);
    /* along axis w the column's cells lie on one line: one ray, cell k its stretch [k, k + 1]·|w| */
    float w_length = length(cell_w.xyz);
    VolumeRay column;
    make_volume_ray(&column, volumes, volume_count, base, l3_splat(cell_w.xyz / w_length), (lfloat)(0.0f), (lfloat)(n.z * w_length));
    volume_ray_only(&column, volume_count, volume_mask); /* the table's group of volumes */
    PartEnds ends;
    no_part_ends(&ends);
    ulong running[SOMBRA_LANES];
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) running[lane] = 0;
    for (int k = 0; k < n.z; ++k) {
        lfloat3 centre = l3_add(base, l3_splat((k + 0.5f) * cell_w.xyz));
        lfloat tau = (lfloat)(0.0f);
        for (int a = 0; a < 2; ++a)
            if (axes & (1u << a))
                tau += segment_optical_depth(volume_data, occupancy, volumes, volume_count, volume_mask, tf_tables,
                                             l3_sub(centre, l3_splat(0.5f * axis[a])),
                                             l3_add(centre, l3_splat(0.5f * axis[a])), active);
        if (axes & 4u)
            tau += stretch_optical_depth(volume_data, occupancy, volumes, volume_count, tf_tables, &column, (lfloat)(k * w_length),
                                         (lfloat)((k + 1) * w_length), active, &ends);
        write_running_sums(sat + data_offset, n, i0, j, k, tau / count, running);
    }
}

/* SSAT (Ament §4.2.3): work-item (p, j) holds the rays of cells (φ_i, θ_j, r_0 … r_n.z−1) from the
 * light, i = p·SOMBRA_LANES + lane; a cell holds the optical depth of its radial segment through
 * the cell's centre angles (segment_optical_depth) times w_θ (shared/types.h, SsatGridGpu). */
__kernel void ssat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                            uint volume_count, __global const uchar* occupancy, __global ulong* sat, __global const SsatGridGpu* grid) {
    int4 n = grid->dims;
    int i0 = get_global_id(0) * SOMBRA_LANES, j = get_global_id(1);
    if (i0 >= n.x || j >= n.y) return;
    lint i = i0 + LANE_INDEX;
    lmask active = i < n.x;
    lfloat phi = grid->start.x + (LCONVERT_FLOAT(i) + 0.5f) * grid->cell.x;
    float theta0 = grid->start.y + j * grid->cell.y, theta1 = theta0 + grid->cell.y;
    float theta = theta0 + 0.5f * grid->cell.y;
    float w_theta = (cos(theta0) - cos(theta1)) / grid->cell.y;
    lfloat3 dir = l3_add(l3_add(l3_scale(l3_splat(grid->axes[0].xyz), sin(theta) * cos(phi)), l3_scale(l3_splat(grid->axes[1].xyz), sin(theta) * sin(phi))),
                         l3_splat(cos(theta) * grid->axes[2].xyz));
    /* the cells of a ray lie on it: one ray from the light, cell k its stretch [r_k, r_k+1] */
    VolumeRay ray;
    make_volume_ray(&ray, volumes, volume_count, l3_splat(grid->light.xyz), dir, (lfloat)(grid->start.z),
                    (lfloat)(grid->start.z + n.z * grid->cell.z));
    volume_ray_only(&ray, volume_count, grid->volume_mask); /* the table's group of volumes */
    PartEnds ends;
    no_part_ends(&ends);
    ulong running[SOMBRA_LANES];
    for (int lane = 0; lane < SOMBRA_LANES; ++lane) running[lane] = 0;
    for (int k = 0; k < n.z; ++k) {
        float r0 = grid->start.z + k * grid->cell.z, r1 = grid->start.z + (k + 1) * grid->cell.z;
        write_running_sums(sat + grid->data_offset, n, i0, j, k,
                           stretch_optical_depth(volume_data, occupancy, volumes, volume_count, tf_tables, &ray, (lfloat)(r0), (lfloat)(r1),
                                                 active, &ends) * w_theta, running);
    }
}

/* Work-item (a, b, axis): entry (a, b) of the table's face where index `axis` is 0 (the other two
 * axes in increasing order, each 0 … n), set to 0 — the zero borders S(0, ·, ·), S(·, 0, ·),
 * S(·, ·, 0), the only entries the resamples do not write. One launch for the three faces. */
__kernel void sat_clear_borders(__global ulong* sat, uint data_offset, int4 n) {
    int a = get_global_id(0), b = get_global_id(1), axis = get_global_id(2);
    int3 e = axis == 0 ? (int3)(0, a, b) : axis == 1 ? (int3)(a, 0, b) : (int3)(a, b, 0);
    if (e.x > n.x || e.y > n.y || e.z > n.z) return;
    sat[data_offset + sat_entry(n, e.x, e.y, e.z)] = 0;
}

/* Work-item (a, b): the line along `axis` (0 or 1) through entries a + 1, b + 1 of the other two
 * axes (in increasing axis order), turned into its inclusive prefix sums. */
__kernel void sat_scan(__global ulong* sat, uint data_offset, int4 n, uint axis) {
    int a = get_global_id(0) + 1, b = get_global_id(1) + 1;
    int length = axis == 0 ? n.x : n.y;
    if (a > (axis == 0 ? n.y : n.x) || b > n.z) return;
    __global ulong* s = sat + data_offset;
    size_t first = axis == 0 ? sat_entry(n, 0, a, b) : sat_entry(n, a, 0, b);
    size_t stride = axis == 0 ? 1 : (size_t)(n.x + 1);
    ulong running = 0;
    for (int t = 1; t <= length; ++t) {
        running += s[first + t * stride];
        s[first + t * stride] = running;
    }
}
