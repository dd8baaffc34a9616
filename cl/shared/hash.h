/* sombra — deterministic per-pixel jitter, shared by the kernels and the CPU references so both
 * offset each ray's first sample identically (DESIGN.md: banding). Compiles as OpenCL C and C++. */
#ifndef SOMBRA_SHARED_HASH_H
#define SOMBRA_SHARED_HASH_H

#ifdef __OPENCL_C_VERSION__
#define SB_INLINE inline
typedef uint sb_hash_uint;
#else
#include <cstdint>
#define SB_INLINE inline
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

#endif /* SOMBRA_SHARED_HASH_H */
