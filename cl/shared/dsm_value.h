/* sombra — what a deep shadow map node's value holds (issue 27 item 1), shared by the DSM build,
 * pre-filter and lookup kernels and the host's read-back.
 *
 * Absolute bound (default): the accumulated opacity α = 1 − T; the compressor keeps |α' − α| ≤ ε
 * (Knecht Eq. 3.1), so where little light is left (T ≲ ε) the map may be black.
 * Relative bound (SOMBRA_DSM_OPTICAL_DEPTH): the optical depth τ = −ln T, compressed by the same
 * compressor with |τ' − τ| ≤ ε, so T' = exp(−τ') lies within a factor e^±ε of T wherever light
 * is left (and within e^ε − 1 ≈ ε absolutely); τ is linear through a homogeneous medium, so
 * such a segment costs one node and exp(−τ) between nodes is exact there. Lookups interpolate τ
 * linearly between nodes and return 1 − exp(−τ'). */
#ifndef SOMBRA_SHARED_DSM_VALUE_H
#define SOMBRA_SHARED_DSM_VALUE_H

#ifndef __OPENCL_C_VERSION__
#include <algorithm>
#include <cmath>
#define SB_DSM_VALUE_INLINE static inline
#define SB_DSM_CLAMP(x, lo, hi) std::clamp(x, lo, hi)
#define SB_DSM_EXP(x) std::exp(x)
#define SB_DSM_LOG(x) std::log(x)
#else
#define SB_DSM_VALUE_INLINE static inline
#define SB_DSM_CLAMP(x, lo, hi) clamp(x, lo, hi)
#define SB_DSM_EXP(x) exp(x)
#define SB_DSM_LOG(x) log(x)
#endif

/* The deepest optical depth a node holds: T = e^−27.6 ≈ 10⁻¹², what an opaque surface's step
 * (T = 0) becomes. */
#define SOMBRA_DSM_MAX_OPTICAL_DEPTH 27.6f

/* The optical depth of an opacity a ∈ [0, 1] (an opaque a = 1: the deepest). */
SB_DSM_VALUE_INLINE float dsm_optical_depth_of(float opacity) {
    return SB_DSM_CLAMP(-SB_DSM_LOG(1.0f - SB_DSM_CLAMP(opacity, 0.0f, 1.0f)), 0.0f, SOMBRA_DSM_MAX_OPTICAL_DEPTH);
}

/* The opacity α ∈ [0, 1] of an (interpolated) optical depth τ. */
SB_DSM_VALUE_INLINE float dsm_opacity_of_optical_depth(float optical_depth) {
    return 1.0f - SB_DSM_EXP(-SB_DSM_CLAMP(optical_depth, 0.0f, SOMBRA_DSM_MAX_OPTICAL_DEPTH));
}

#ifdef __OPENCL_C_VERSION__
/* A stored (or interpolated) node value as the opacity lookups return. */
#ifdef SOMBRA_DSM_OPTICAL_DEPTH
#define DSM_NODE_OPACITY(value) dsm_opacity_of_optical_depth(value)
#define DSM_NODE_VALUE(opacity) dsm_optical_depth_of(opacity)
#else
#define DSM_NODE_OPACITY(value) clamp((value), 0.0f, 1.0f)
#define DSM_NODE_VALUE(opacity) (opacity)
#endif
#endif

#endif /* SOMBRA_SHARED_DSM_VALUE_H */
