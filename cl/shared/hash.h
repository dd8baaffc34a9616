/* sombra — deterministic per-pixel jitter, shared by the kernels and the CPU references so both
 * offset each ray's first sample identically (docs/architecture.md "Banding"). Compiles as OpenCL C and C++. */
#ifndef SOMBRA_SHARED_HASH_H
#define SOMBRA_SHARED_HASH_H

#ifdef __OPENCL_C_VERSION__
#define SB_INLINE static inline
typedef uint sb_hash_uint;
#else
#include <cstdint>
#define SB_INLINE static inline
typedef std::uint32_t sb_hash_uint;
#endif

/* PCG-style integer hash (Jarzynski & Olano 2020, "pcg" variant). */
SB_INLINE sb_hash_uint sombra_hash(sb_hash_uint v) {
    sb_hash_uint state = v * 747796405u + 2891336453u;
    sb_hash_uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

/* Jitter in [0, 1) for pixel (x, y) of a frame seeded by seed; 24 bits of the hash. */
SB_INLINE float sombra_pixel_jitter(sb_hash_uint x, sb_hash_uint y, sb_hash_uint seed) {
    sb_hash_uint h = sombra_hash(x + sombra_hash(y + sombra_hash(seed)));
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

/* Coordinate along `axis` (0: x, 1: y) of texel (x, y)'s ray in a DSM view's image plane, in
 * texels from the map's corner (DsmViewGpu): the texel centre, shifted by `shift`, plus stratified
 * jitter (Lokovic & Veach 2000 §5.1) uniform in [−jitter/2, jitter/2) when jitter > 0. */
SB_INLINE float sombra_texel_ray_coord(sb_hash_uint x, sb_hash_uint y, sb_hash_uint axis, float shift, float jitter,
                                       sb_hash_uint seed) {
    float p = (float)(axis ? y : x) + 0.5f + shift;
    if (jitter > 0.0f) p += jitter * (sombra_pixel_jitter(x, y, seed ^ (axis * 0x9e3779b9u)) - 0.5f);
    return p;
}

#endif /* SOMBRA_SHARED_HASH_H */
