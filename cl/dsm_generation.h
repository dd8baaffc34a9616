/* sombra — what the two DSM generation programs (dsm_build.cl: ray casting from the light;
 * dsm_prefilter.cl: merging sub-pixel maps) share: the kernel names, the storage parameters and
 * the hand-over of compressed nodes to the storage backend, in its counting and writing forms.
 *   SOMBRA_DSM_COUNT_ONLY  the kernel is dsm_count and only counts nodes per texel (the first pass
 *                          of the counted backends); else it is dsm_build and writes them
 * A generation kernel handles texels x0 … x0 + n − 1 of row y (n ≤ SOMBRA_LANES, one per lane of
 * a packet, lanes.h), each with its own writer or counter. It is declared
 * DSM_GENERATION_KERNEL(…, DSM_BUILD_STORAGE_PARAMS), calls DSM_TEXELS_BEGIN(v, x0, y, n) first,
 * STORE_NODES(lane, compressor output) for every batch of nodes of a lane, and
 * DSM_TEXELS_END(v, x0, y, n) last. Lanes ≥ n (padding beyond the map) write nothing. */
#ifndef SOMBRA_DSM_GENERATION_H
#define SOMBRA_DSM_GENERATION_H
#include "shared/compress.h"

#define SOMBRA_DSM_BUILD_PROGRAM /* backends may add kernels of their own (dsm_rearrange) */
#ifndef SOMBRA_DSM_COUNT_ONLY
#include "dsm_storage.h"
#endif

#ifdef SOMBRA_DSM_COUNT_ONLY
#define DSM_GENERATION_KERNEL __kernel void dsm_count
#define DSM_BUILD_STORAGE_PARAMS __global uint* counts
#define DSM_TEXELS_BEGIN(v, x0, y, n) \
    uint count[SOMBRA_LANES];         \
    for (uint lane_ = 0; lane_ < SOMBRA_LANES; ++lane_) count[lane_] = 0
#define STORE_NODES(lane, out) (count[lane] += (out).count)
#define DSM_TEXELS_END(v, x0, y, n)                  \
    for (uint lane_ = 0; lane_ < (n); ++lane_) \
    counts[(v)->first_texel + (y) * (v)->resolution + (x0) + lane_] = count[lane_]
#else
#define DSM_GENERATION_KERNEL __kernel void dsm_build
#define DSM_BUILD_STORAGE_PARAMS DSM_WRITE_PARAMS
#define DSM_TEXELS_BEGIN(v, x0, y, n)          \
    DsmWriter writer[SOMBRA_LANES];            \
    for (uint lane_ = 0; lane_ < (n); ++lane_) \
    dsm_writer_begin(&writer[lane_], DSM_WRITE_ARGS, (v), (x0) + lane_, (y))
#define STORE_NODES(lane, out)                                                                \
    do {                                                                                      \
        CompressorOutput emitted = (out);                                                     \
        for (int i = 0; i < emitted.count; ++i)                                               \
            dsm_writer_put(&writer[lane], DSM_WRITE_ARGS, emitted.z[i], emitted.alpha[i]);    \
    } while (0)
#define DSM_TEXELS_END(v, x0, y, n)            \
    for (uint lane_ = 0; lane_ < (n); ++lane_) \
    dsm_writer_end(&writer[lane_], DSM_WRITE_ARGS, (v), (x0) + lane_, (y))
#endif

#endif
