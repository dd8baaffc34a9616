/* sombra — reading a volume for a packet of rays (lanes.h): density at continuous voxel positions,
 * transfer function, gradient. One function, sample_density(), hides where voxels live: a float
 * buffer (fast on PoCL: 80 vs 35 Msamples/s, docs/architecture.md) or a 3D image atlas read through
 * the texture cache (GPUs), chosen by SOMBRA_USE_IMAGES. Both interpolate the 8 voxels in float
 * with the same formula: a GPU's linear filter weighs them in 8-bit fixed point (density errors of
 * 1.6e-3 measured on an H200, docs/gpu-check.md), too coarse for the closed forms. */
#ifndef SOMBRA_VOLUME_SAMPLE_H
#define SOMBRA_VOLUME_SAMPLE_H
#include "shared/types.h"
#include "lanes.h"

#ifdef SOMBRA_USE_IMAGES
#define VOLUME_DATA_PARAM __read_only image3d_t volume_data
__constant sampler_t volume_sampler = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP_TO_EDGE | CLK_FILTER_NEAREST;

/* Trilinear density of one lane from the image atlas: the 8 voxels around (px, py, pz) (already
 * clamped to the volume), the +1 neighbours clamped to its last voxel, z shifted to its slices. */
static inline float image_trilinear(__read_only image3d_t volume_data, int4 last, int z_offset, float px, float py, float pz) {
    float bx = floor(px), by = floor(py), bz = floor(pz);
    float fx = px - bx, fy = py - by, fz = pz - bz;
    int x0 = (int)bx, y0 = (int)by, z0 = (int)bz + z_offset;
    int x1 = min(x0 + 1, last.x), y1 = min(y0 + 1, last.y), z1 = min((int)bz + 1, last.z) + z_offset;
#define SOMBRA_VOXEL(i, j, k) read_imagef(volume_data, volume_sampler, (int4)(i, j, k, 0)).x
    float c00 = mix(SOMBRA_VOXEL(x0, y0, z0), SOMBRA_VOXEL(x1, y0, z0), fx);
    float c10 = mix(SOMBRA_VOXEL(x0, y1, z0), SOMBRA_VOXEL(x1, y1, z0), fx);
    float c01 = mix(SOMBRA_VOXEL(x0, y0, z1), SOMBRA_VOXEL(x1, y0, z1), fx);
    float c11 = mix(SOMBRA_VOXEL(x0, y1, z1), SOMBRA_VOXEL(x1, y1, z1), fx);
#undef SOMBRA_VOXEL
    return mix(mix(c00, c10, fy), mix(c01, c11, fy), fz);
}
#else
#define VOLUME_DATA_PARAM __global const float* restrict volume_data
#endif

static inline lfloat3 to_voxel_point(__global const VolumeGpu* v, lfloat3 p) {
    return l3(l3_dot_uniform(p, v->world_to_voxel[0].xyz) + v->world_to_voxel[0].w,
              l3_dot_uniform(p, v->world_to_voxel[1].xyz) + v->world_to_voxel[1].w,
              l3_dot_uniform(p, v->world_to_voxel[2].xyz) + v->world_to_voxel[2].w);
}

static inline lfloat3 to_voxel_direction(__global const VolumeGpu* v, lfloat3 d) {
    return l3(l3_dot_uniform(d, v->world_to_voxel[0].xyz), l3_dot_uniform(d, v->world_to_voxel[1].xyz),
              l3_dot_uniform(d, v->world_to_voxel[2].xyz));
}

/* Trilinear density at voxel positions p (voxel centres at integers), clamped to the edge.
 * Callers keep p finite in every lane (masked lanes included). */
static inline lfloat sample_density(VOLUME_DATA_PARAM, __global const VolumeGpu* v, lfloat3 p) {
    lfloat px = clamp_index(p.x, (float)(v->dims.x - 1));
    lfloat py = clamp_index(p.y, (float)(v->dims.y - 1));
    lfloat pz = clamp_index(p.z, (float)(v->dims.z - 1));
#ifdef SOMBRA_USE_IMAGES
    int4 last = (int4)(v->dims.x - 1, v->dims.y - 1, v->dims.z - 1, 0);
    int z_offset = (int)v->image_z_offset;
#define SOMBRA_READ_LANE(c) image_trilinear(volume_data, last, z_offset, LC(px, c), LC(py, c), LC(pz, c))
    return LFROM_LANES(SOMBRA_READ_LANE);
#undef SOMBRA_READ_LANE
#else
    lfloat bx = floor(px), by = floor(py), bz = floor(pz);
    lfloat fx = px - bx, fy = py - by, fz = pz - bz;
    int sy = v->dims.x, sz = v->dims.x * v->dims.y;
    lint x0 = LCONVERT_INT(bx), y0 = LCONVERT_INT(by) * sy, z0 = LCONVERT_INT(bz) * sz;
    /* the +1 neighbour, clamped: stays on the same voxel at the upper edge */
    lint x1 = lmin(x0 + 1, v->dims.x - 1), y1 = lmin(y0 + sy, (v->dims.y - 1) * sy), z1 = lmin(z0 + sz, (v->dims.z - 1) * sz);
    __global const float* d = volume_data + v->data_offset;
    lfloat c00 = mix(gather(d, x0 + y0 + z0), gather(d, x1 + y0 + z0), fx);
    lfloat c10 = mix(gather(d, x0 + y1 + z0), gather(d, x1 + y1 + z0), fx);
    lfloat c01 = mix(gather(d, x0 + y0 + z1), gather(d, x1 + y0 + z1), fx);
    lfloat c11 = mix(gather(d, x0 + y1 + z1), gather(d, x1 + y1 + z1), fx);
    return mix(mix(c00, c10, fy), mix(c01, c11, fy), fz);
#endif
}

/* Transfer function: linear interpolation in the volume's table of (r, g, b, σ), σ being the
 * extinction per world unit (opacity already converted, see docs/scenes.md "opacity convention"). */
typedef struct {
    lfloat3 color;
    lfloat sigma;
} Classified;

static inline Classified classify(__global const float* tf_tables, __global const VolumeGpu* v, lfloat density) {
    lfloat u = clamp_index((density - v->tf_domain_min) * v->tf_domain_scale, (float)(v->tf_size - 1));
    lint i0 = lmin(LCONVERT_INT(u), (int)v->tf_size - 2);
    lfloat f = u - LCONVERT_FLOAT(i0);
    __global const float* table = tf_tables + 4 * v->tf_offset;
    lint e0 = 4 * i0, e1 = e0 + 4;
    Classified c;
    c.color = l3(mix(gather(table, e0), gather(table, e1), f), mix(gather(table, e0 + 1), gather(table, e1 + 1), f),
                 mix(gather(table, e0 + 2), gather(table, e1 + 2), f));
    c.sigma = mix(gather(table, e0 + 3), gather(table, e1 + 3), f);
    return c;
}

/* σ of the volume's table at entry coordinates u in [0, size − 1] (linear between entries). */
static inline lfloat table_sigma(__global const float* table, uint size, lfloat u) {
    lint i0 = lmin(LCONVERT_INT(u), (int)size - 2);
    lfloat f = u - LCONVERT_FLOAT(i0);
    return mix(gather(table, 4 * i0 + 3), gather(table, 4 * i0 + 7), f);
}

/* Pre-integrated extinction (Engel et al. 2001, in the form of an integral function): the mean σ
 * over an interval along which the density runs linearly from d_front to d_back, under the
 * table's model (σ linear between entries, constant beyond both ends). Times the interval's
 * length it is the interval's optical depth, exact for homogeneous media and for density linear
 * along the ray, whatever the step — so a thin, stiff feature between two samples adds what the
 * model says, not what one sample of it says. Equal densities give classify()'s σ.
 * Within one entry cell the mean of the linear σ is σ at the middle (exact, no cancellation);
 * across cells, ∫σ du is the partial cells at both ends plus the whole cells between them from
 * the prefix sums F (hi + lo pairs), plus the clamped parts beyond the table: every term ≥ 0. */
static inline lfloat preintegrated_sigma(__global const float* tf_tables, __global const VolumeGpu* v, lfloat d_front,
                                  lfloat d_back) {
    __global const float* table = tf_tables + 4 * v->tf_offset;
    __global const float* prefix = tf_tables + v->tf_integral_offset;
    uint size = v->tf_size;
    float last = (float)(size - 1);
    lfloat ua = (fmin(d_front, d_back) - v->tf_domain_min) * v->tf_domain_scale;
    lfloat ub = (fmax(d_front, d_back) - v->tf_domain_min) * v->tf_domain_scale;
    lfloat a = clamp_index(ua, last), b = clamp_index(ub, last);
    lint ia = lmin(LCONVERT_INT(a), (int)size - 2), ib = lmin(LCONVERT_INT(b), (int)size - 2);
    lfloat mid_sigma = table_sigma(table, size, 0.5f * (a + b));
    lmask one_cell = ia == ib;
    lmask simple = one_cell & (ua == a) & (ub == b); /* no clamped part either: the mean is mid_sigma */
    if (!lany(!simple)) return mid_sigma;
    lfloat width = ub - ua;
    lfloat a_end = LCONVERT_FLOAT(ia + 1), b_start = LCONVERT_FLOAT(ib);
    lfloat whole = (gather(prefix, 2 * ib) - gather(prefix, 2 * (ia + 1))) + (gather(prefix, 2 * ib + 1) - gather(prefix, 2 * (ia + 1) + 1));
    lfloat across = (a_end - a) * table_sigma(table, size, 0.5f * (a + a_end)) +
                    (b - b_start) * table_sigma(table, size, 0.5f * (b_start + b)) + whole;
    lfloat inside = select(across, (b - a) * mid_sigma, one_cell);
    lfloat below = fmax(fmin(ub, 0.0f) - ua, 0.0f), above = fmax(ub - fmax(ua, last), 0.0f);
    lfloat integral = below * table[3] + above * table[4 * (size - 1) + 3] + inside;
    lmask interval = width > 0.0f;
    return select(mid_sigma, integral / select((lfloat)(1.0f), width, interval), interval & !simple);
}

static inline lfloat3 offset_voxel(lfloat3 p, float dx, float dy, float dz) { return l3(p.x + dx, p.y + dy, p.z + dz); }

/* Voxel-space gradient of the density: central differences, or the 3×3×3 Sobel operator when
 * SOMBRA_SOBEL is defined (course slides, "Gradient Calculation"). Units: density per voxel. */
static inline lfloat3 gradient_voxel(VOLUME_DATA_PARAM, __global const VolumeGpu* v, lfloat3 p) {
#ifdef SOMBRA_SOBEL
    lfloat3 g = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                /* smoothing taps: 2 on the axis of the difference's neighbours, 1 off it */
                float wx = 2.0f - (float)abs(dx), wy = 2.0f - (float)abs(dy), wz = 2.0f - (float)abs(dz);
                lfloat s = sample_density(volume_data, v, offset_voxel(p, dx, dy, dz));
                g = l3_add(g, l3(s * (dx * wy * wz), s * (dy * wx * wz), s * (dz * wx * wy)));
            }
    return l3_scale(g, (lfloat)(1.0f / 32.0f));
#else
    lfloat gx = sample_density(volume_data, v, offset_voxel(p, 1, 0, 0)) - sample_density(volume_data, v, offset_voxel(p, -1, 0, 0));
    lfloat gy = sample_density(volume_data, v, offset_voxel(p, 0, 1, 0)) - sample_density(volume_data, v, offset_voxel(p, 0, -1, 0));
    lfloat gz = sample_density(volume_data, v, offset_voxel(p, 0, 0, 1)) - sample_density(volume_data, v, offset_voxel(p, 0, 0, -1));
    return l3(0.5f * gx, 0.5f * gy, 0.5f * gz);
#endif
}

/* World-space surface normal from the voxel-space gradient (g_world = Jᵀ g_voxel, J = the
 * world→voxel Jacobian), pointing towards lower density. Lanes where the gradient vanishes —
 * measured in transfer-function entries per voxel, so the threshold is unit-free — get 0. */
static inline lfloat3 normal_from_gradient(__global const VolumeGpu* v, lfloat3 g_voxel) {
    lmask vanishing = sqrt(l3_dot(g_voxel, g_voxel)) * v->tf_domain_scale < 1e-3f;
    float3 j0 = v->world_to_voxel[0].xyz, j1 = v->world_to_voxel[1].xyz, j2 = v->world_to_voxel[2].xyz;
    lfloat3 g = l3(g_voxel.x * j0.x + g_voxel.y * j1.x + g_voxel.z * j2.x,
                   g_voxel.x * j0.y + g_voxel.y * j1.y + g_voxel.z * j2.y,
                   g_voxel.x * j0.z + g_voxel.y * j1.z + g_voxel.z * j2.z);
    /* keep the normalisation finite in vanishing lanes, then zero them */
    g = l3_select(g, l3((lfloat)(1.0f), (lfloat)(0.0f), (lfloat)(0.0f)), vanishing);
    lfloat3 n = l3_scale(l3_normalize(g), (lfloat)(-1.0f));
    lfloat3 zero = l3((lfloat)(0.0f), (lfloat)(0.0f), (lfloat)(0.0f));
    return l3_select(n, zero, vanishing);
}

#endif
