/* sombra — the taps of the DSM pre-filters (Lokovic & Veach 2000 §5.1: sub-pixel rays combined
 * under a filter kernel; Hadwiger §3.1, "a 5-tap pre-filter kernel", Figs. 4, 6). Shared by
 * dsm_prefilter.cl (the merge) and the host (tests). Compiles as OpenCL C and C++.
 * A pre-filtered view of N² texels merges the sub-pixel maps src/shadows/dsm_views.cpp
 * (sub_pixel_views) generates; tap {map, dx, dy, w}: texel (x, y) takes texel (s·x + dx, s·y + dy)
 * of sub-map `map` (clamped to it) with weight w / Σw. Sampling positions, in texels from the
 * texel centre (before jitter):
 *   box   s = 2, one map of 2N²:  (±¼, ±¼), equal weights (the 2×2 sub-pixel rays)
 *   tent  s = 2, one map of 2N²:  {−¾, −¼, ¼, ¾}², weights (1 3 3 1)⊗(1 3 3 1) — the separable
 *         tent of radius 1 texel at those points; rays shared with the neighbours
 *   5tap  s = 1, two maps of (N+1)²: the centre (weight ½) and the 4 corners (±½, ±½) (⅛ each),
 *         the quincunx pattern; the same radius-1 tent at those points gives 4 : 1. Corner rays
 *         are shared by 4 texels, so 5 taps cost 2 rays per texel (map 0: centres, map 1: corners). */
#ifndef SOMBRA_SHARED_PREFILTER_H
#define SOMBRA_SHARED_PREFILTER_H

#define SOMBRA_PREFILTER_BOX_TAPS {{0, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {0, 1, 1, 1}}
#define SOMBRA_PREFILTER_TENT_TAPS                                                                      \
    {{0, -1, -1, 1}, {0, 0, -1, 3}, {0, 1, -1, 3}, {0, 2, -1, 1}, {0, -1, 0, 3}, {0, 0, 0, 9}, {0, 1, 0, 9}, \
     {0, 2, 0, 3},   {0, -1, 1, 3}, {0, 0, 1, 9},  {0, 1, 1, 9},  {0, 2, 1, 3}, {0, -1, 2, 1}, {0, 0, 2, 3}, \
     {0, 1, 2, 3},   {0, 2, 2, 1}}
#define SOMBRA_PREFILTER_5TAP_TAPS {{0, 0, 0, 4}, {1, 0, 0, 1}, {1, 1, 0, 1}, {1, 0, 1, 1}, {1, 1, 1, 1}}

#endif /* SOMBRA_SHARED_PREFILTER_H */
