/* sombra — building a light-aligned summed-area table (Ament §4.2.1, §5). sat_resample integrates
 * the extinction σ of every volume (through its transfer function, as the camera pass classifies
 * it) over each cell of a grid aligned with the light and stores the cell's optical depth as a
 * 64-bit fixed-point integer (shared/types.h), already summed along grid axis 2; sat_scan sums
 * along axis 0 or 1. One work-item per line: the prefix sums run in parallel over lines. Integer
 * sums are exact and independent of the order, so the table cannot cancel the way float32 SATs
 * do (docs/architecture.md "Numerics"). Built with SOMBRA_LANES=1; defines as dsm_build.cl. */
#include "shared/types.h"
#include "lanes.h"
#include "volume_sample.h"
#include "traversal.h"
#include "lowpass.h"

/* Whether the part [t0, t1] of the ray lies in bricks of volume i whose σ is 0 everywhere (the
 * camera pass's occupancy flags, traversal.h): the bricks under the part's voxel-space bounding
 * box, when it spans at most three per axis (a table cell spans one or two), all empty. Such a
 * part adds exactly 0, so skipping it changes no bit of the table. */
static inline int segment_in_empty_bricks(__global const uchar* occupancy, __global const VolumeGpu* v, const VolumeRay* ray,
                                          uint i, float t0, float t1) {
    lfloat3 q0 = ray_voxel_point(ray, i, t0), q1 = ray_voxel_point(ray, i, t1); /* SOMBRA_LANES=1: lfloat is float */
    float3 p0 = (float3)(q0.x, q0.y, q0.z), p1 = (float3)(q1.x, q1.y, q1.z);
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

/* Optical depth of the segment from a.xyz to b.xyz under the renderer's model: each volume's part
 * inside its box [−0.5, dims − 0.5] in steps of at most its ray step, each split at the
 * voxel-centre planes it crosses and pre-integrated (traversal.h split_interval_depth, whatever the
 * volume's stiffness: a table is built once per light); parts in empty bricks are skipped.
 * The points are float4, not float3: both kernels call this function, so a compiler may keep it
 * out of line, and Intel's CPU runtime (oneAPI 2026.2) passes float3 arguments to the vectorised
 * copy of an out-of-line function wrongly — garbage in most of the 16 lanes, different from run
 * to run (docs/tests.md "Intel's OpenCL CPU runtime", tests/portability/intel_float3_call.c). */
static inline float segment_optical_depth(VOLUME_DATA_PARAM, __global const uchar* occupancy, __global const VolumeGpu* volumes,
                                          uint volume_count, __global const float* tf_tables, float4 a4, float4 b4) {
    float3 a = a4.xyz, b = b4.xyz;
    float length = distance(a, b);
    if (!(length > 0.0f)) return 0.0f;
    VolumeRay ray;
    make_volume_ray(&ray, volumes, volume_count, l3_splat(a), l3_splat((b - a) / length), 0.0f, length);
    float depth = 0.0f;
    for (uint i = 0; i < volume_count; ++i) {
        __global const VolumeGpu* v = &volumes[i];
        float t0 = ray.t_enter[i], t1 = ray.t_exit[i];
        if (!(t0 < t1) || segment_in_empty_bricks(occupancy, v, &ray, i, t0, t1)) continue;
        int steps = clamp((int)ceil((t1 - t0) / v->step - 1e-3f), 1, 4096); /* 1e-3: the same count in double */
        float h = (t1 - t0) / (float)steps, ta = t0, da = density_at_point(volume_data, v, &ray, i, t0);
        for (int s = 1; s <= steps; ++s) {
            float tb = s == steps ? t1 : t0 + (float)s * h;
            float db = density_at_point(volume_data, v, &ray, i, tb);
            depth += split_interval_depth(volume_data, v, tf_tables, &ray, i, ta, tb, da, db, 1);
            ta = tb, da = db;
        }
    }
    return depth;
}

/* Work-item (i, j): the column of cells (i, j, 0 … n.z − 1) of the grid origin + i·cell_u + j·cell_v
 * + k·cell_w. A cell holds the optical depth along the lights' axes through its centre, face to
 * face (the mean over the axes in light_axes: bit a = a light shines along grid axis a; a table
 * no light is aligned with uses all three) — ∫σ over the cell under the renderer's model, not σ at
 * its centre times the cell, so a thin near-opaque feature inside a cell counts in full. Clamped
 * to SOMBRA_SAT_MAX_CELL_TAU and rounded to fixed point; the column's running sums go to
 * S(i + 1, j + 1, k + 1); the zero border S(0, ·, ·) … is cleared by the host. */
__kernel void sat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                           uint volume_count, __global const uchar* occupancy, __global ulong* sat, uint data_offset, int4 n, float4 origin,
                           float4 cell_u, float4 cell_v, float4 cell_w, float cell_length, uint light_axes) {
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= n.x || j >= n.y) return;
    float3 base = origin.xyz + (i + 0.5f) * cell_u.xyz + (j + 0.5f) * cell_v.xyz;
    float3 axis[3] = {cell_u.xyz, cell_v.xyz, cell_w.xyz};
    uint axes = light_axes & 7u ? light_axes & 7u : 7u;
    float count = (float)popcount(axes);
    __global ulong* s = sat + data_offset;
    ulong running = 0;
    for (int k = 0; k < n.z; ++k) {
        float3 centre = base + (k + 0.5f) * cell_w.xyz;
        float tau = 0.0f;
        for (int a = 0; a < 3; ++a)
            if (axes & (1u << a))
                tau += segment_optical_depth(volume_data, occupancy, volumes, volume_count, tf_tables,
                                             (float4)(centre - 0.5f * axis[a], 1.0f), (float4)(centre + 0.5f * axis[a], 1.0f));
        running += sat_fixed_point(tau / count);
        s[sat_entry(n, i + 1, j + 1, k + 1)] = running;
    }
}

/* SSAT (Ament §4.2.3): work-item (i, j) is the ray of cells (φ_i, θ_j, r_0 … r_n.z−1) from the
 * light; a cell holds the optical depth of its radial segment through the cell's centre angles
 * (segment_optical_depth) times w_θ (shared/types.h, SsatGridGpu). */
__kernel void ssat_resample(VOLUME_DATA_PARAM, __global const float* tf_tables, __global const VolumeGpu* volumes,
                            uint volume_count, __global const uchar* occupancy, __global ulong* sat, __global const SsatGridGpu* grid) {
    int4 n = grid->dims;
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= n.x || j >= n.y) return;
    float phi = grid->start.x + (i + 0.5f) * grid->cell.x;
    float theta0 = grid->start.y + j * grid->cell.y, theta1 = theta0 + grid->cell.y;
    float theta = theta0 + 0.5f * grid->cell.y;
    float w_theta = (cos(theta0) - cos(theta1)) / grid->cell.y;
    float3 dir = sin(theta) * cos(phi) * grid->axes[0].xyz + sin(theta) * sin(phi) * grid->axes[1].xyz +
                 cos(theta) * grid->axes[2].xyz;
    __global ulong* s = sat + grid->data_offset;
    ulong running = 0;
    for (int k = 0; k < n.z; ++k) {
        float r0 = grid->start.z + k * grid->cell.z;
        float3 a = grid->light.xyz + r0 * dir, b = grid->light.xyz + (r0 + grid->cell.z) * dir;
        running += sat_fixed_point(segment_optical_depth(volume_data, occupancy, volumes, volume_count, tf_tables, (float4)(a, 1.0f),
                                                         (float4)(b, 1.0f)) * w_theta);
        s[sat_entry(n, i + 1, j + 1, k + 1)] = running;
    }
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
