/* sombra — what the two DSM generation programs (dsm_build.cl: ray casting from the light;
 * dsm_prefilter.cl: merging sub-pixel maps) share: the kernel names, the storage parameters and
 * the hand-over of compressed nodes to the storage backend, in its counting and writing forms.
 *   SOMBRA_DSM_COUNT_ONLY  the kernel is dsm_count and only counts nodes per texel (the first pass
 *                          of the counted backends); else it is dsm_build and writes them
 * A generation kernel is declared DSM_GENERATION_KERNEL(…, DSM_BUILD_STORAGE_PARAMS), calls
 * DSM_TEXEL_BEGIN(v, x, y) first, STORE_NODES(compressor output) for every batch of nodes, and
 * DSM_TEXEL_END(v, x, y) last; `count` must be a uint in scope. */
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
#define DSM_TEXEL_BEGIN(v, x, y)
#define STORE_NODES(out) (count += (out).count)
#define DSM_TEXEL_END(v, x, y) (counts[(v)->first_texel + (y) * (v)->resolution + (x)] = count)
#else
#define DSM_GENERATION_KERNEL __kernel void dsm_build
#define DSM_BUILD_STORAGE_PARAMS DSM_WRITE_PARAMS
#define DSM_TEXEL_BEGIN(v, x, y) \
    DsmWriter writer;            \
    dsm_writer_begin(&writer, DSM_WRITE_ARGS, (v), (x), (y))
#define STORE_NODES(out)                                                                   \
    do {                                                                                   \
        CompressorOutput emitted = (out);                                                  \
        for (int i = 0; i < emitted.count; ++i)                                            \
            dsm_writer_put(&writer, DSM_WRITE_ARGS, emitted.z[i], emitted.alpha[i]);       \
        count += emitted.count;                                                            \
    } while (0)
#define DSM_TEXEL_END(v, x, y) dsm_writer_end(&writer, DSM_WRITE_ARGS, (v), (x), (y))
#endif

#endif
