/* sombra — ray packets. A work-item marches SOMBRA_LANES rays at once in OpenCL vector types:
 * PoCL does not vectorize kernels with inner loops across work-items (docs/architecture.md "Facts about PoCL"), so on CPU
 * devices the packet is how the kernel reaches the SIMD units; GPUs build with SOMBRA_LANES=1 and
 * the same code is plain scalar code. Everything is written with masks:
 *   lfloat / lint / luint   one value per lane
 *   lmask                   result of a comparison: scalar 0/1, vector 0/−1; combine with & | !
 *   select(a, b, m)         per lane m ? b : a (OpenCL built-in, works for both)
 *   gather(ptr, idx)        per-lane loads ptr[idx]
 *   LSTORE(v, array)        lanes to a private array (vstoreN), for per-lane writes at the end
 *   LLOAD(array)            a private array back to lanes (vloadN), after per-lane scalar work
 *   LFROM_LANES(f), LC(v,c) build a lane vector from f(c) for every component c of the width
 *   LFROM_LANES_AS(type, f) the same for another lane type (lint, luint) */
#ifndef SOMBRA_LANES_H
#define SOMBRA_LANES_H

#ifndef SOMBRA_LANES
#define SOMBRA_LANES 1
#endif

#if SOMBRA_LANES == 1
typedef float lfloat;
typedef int lint;
typedef uint luint;
typedef int lmask;
#define lany(m) ((m) != 0)
#define LCONVERT_INT(x) convert_int(x)
#define LAS_INT(x) as_int(x)
#define LCONVERT_FLOAT(x) convert_float(x)
#define LFROM_LANES_AS(type, f) ((type)(f(_)))
#define LC(v, c) (v)
#define LANE_INDEX ((lint)(0))
#define LSTORE(v, array) ((array)[0] = (v))
#define LLOAD(array) ((array)[0])
#elif SOMBRA_LANES == 4
typedef float4 lfloat;
typedef int4 lint;
typedef uint4 luint;
typedef int4 lmask;
#define lany(m) any(m)
#define LCONVERT_INT(x) convert_int4(x)
#define LAS_INT(x) as_int4(x)
#define LCONVERT_FLOAT(x) convert_float4(x)
#define LFROM_LANES_AS(type, f) ((type)(f(s0), f(s1), f(s2), f(s3)))
#define LSTORE(v, array) vstore4((v), 0, (array))
#define LLOAD(array) vload4(0, (array))
#define LC(v, c) ((v).c)
#define LANE_INDEX ((lint)(0, 1, 2, 3))
#elif SOMBRA_LANES == 8
typedef float8 lfloat;
typedef int8 lint;
typedef uint8 luint;
typedef int8 lmask;
#define lany(m) any(m)
#define LCONVERT_INT(x) convert_int8(x)
#define LAS_INT(x) as_int8(x)
#define LCONVERT_FLOAT(x) convert_float8(x)
#define LFROM_LANES_AS(type, f) ((type)(f(s0), f(s1), f(s2), f(s3), f(s4), f(s5), f(s6), f(s7)))
#define LSTORE(v, array) vstore8((v), 0, (array))
#define LLOAD(array) vload8(0, (array))
#define LC(v, c) ((v).c)
#define LANE_INDEX ((lint)(0, 1, 2, 3, 4, 5, 6, 7))
#elif SOMBRA_LANES == 16
typedef float16 lfloat;
typedef int16 lint;
typedef uint16 luint;
typedef int16 lmask;
#define lany(m) any(m)
#define LCONVERT_INT(x) convert_int16(x)
#define LAS_INT(x) as_int16(x)
#define LCONVERT_FLOAT(x) convert_float16(x)
#define LFROM_LANES_AS(type, f) ((type)(f(s0), f(s1), f(s2), f(s3), f(s4), f(s5), f(s6), f(s7), f(s8), f(s9), f(sA), f(sB), f(sC), f(sD), f(sE), f(sF)))
#define LSTORE(v, array) vstore16((v), 0, (array))
#define LLOAD(array) vload16(0, (array))
#define LC(v, c) ((v).c)
#define LANE_INDEX ((lint)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#else
#error "SOMBRA_LANES must be 1, 4, 8 or 16"
#endif

#define LFROM_LANES(f) LFROM_LANES_AS(lfloat, f)

/* x clamped to [0, hi] for a load index, also where x is NaN or ±∞ (then 0 or hi): clamp() and
 * min/max are undefined for NaN (OpenCL 1.2 §6.12.2, §6.12.4), fmax/fmin return the other operand.
 * Every lane of a packet loads, and lanes masked off carry whatever position their ray gave. */
static inline lfloat clamp_index(lfloat x, float hi) { return fmin(fmax(x, 0.0f), hi); }

/* min and clamp of lane integers against scalar bounds, the bounds splat first. OpenCL C allows
 * min(int4, int) (§6.12.3), but Oclgrind 21.10 reads the scalar as if it were a vector: lanes 1 to
 * N-1 compare with garbage and index memory out of bounds (tests/portability/oclgrind_min_scalar.sim). */
static inline lint lmin(lint x, int hi) { return min(x, (lint)(hi)); }
static inline lint lclamp(lint x, int lo, int hi) { return clamp(x, (lint)(lo), (lint)(hi)); }

/* Per-lane loads ptr[idx[lane]] (the CPU has no cheaper gather for OpenCL C to use). */
#if SOMBRA_LANES == 1
static inline lfloat gather(__global const float* ptr, lint idx) { return ptr[idx]; }
#else
static inline lfloat gather(__global const float* ptr, lint idx) {
#define SOMBRA_GATHER_LANE(c) ptr[LC(idx, c)]
    return LFROM_LANES(SOMBRA_GATHER_LANE);
#undef SOMBRA_GATHER_LANE
}
#endif

/* Three lane vectors: a point or a direction per lane (structure of arrays). */
typedef struct {
    lfloat x, y, z;
} lfloat3;

static inline lfloat3 l3(lfloat x, lfloat y, lfloat z) {
    lfloat3 r = {x, y, z};
    return r;
}
static inline lfloat3 l3_splat(float3 v) { return l3((lfloat)(v.x), (lfloat)(v.y), (lfloat)(v.z)); }
static inline lfloat3 l3_add(lfloat3 a, lfloat3 b) { return l3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline lfloat3 l3_sub(lfloat3 a, lfloat3 b) { return l3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline lfloat3 l3_scale(lfloat3 a, lfloat s) { return l3(a.x * s, a.y * s, a.z * s); }
static inline lfloat3 l3_mad(lfloat3 a, lfloat s, lfloat3 b) { return l3(mad(a.x, s, b.x), mad(a.y, s, b.y), mad(a.z, s, b.z)); }
static inline lfloat l3_dot(lfloat3 a, lfloat3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline lfloat l3_dot_uniform(lfloat3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline lfloat3 l3_select(lfloat3 a, lfloat3 b, lmask m) { return l3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m)); }
static inline lfloat3 l3_normalize(lfloat3 a) {
    lfloat inv = rsqrt(l3_dot(a, a));
    return l3_scale(a, inv);
}

#endif
