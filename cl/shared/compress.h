/* sombra — on-the-fly compression of a visibility function (Lokovic & Veach 2000; Knecht
 * Alg. 3.2, Eq. 3.1–3.6), shared verbatim by the DSM build kernel and the C++ tests.
 *
 * The function is fed as samples (z, α_acc) with z strictly increasing and α_acc non-decreasing.
 * It emits nodes (z, α) of a piecewise-linear V' with |V'(z_k) − α_acc(z_k)| ≤ ε at every sample
 * (Eq. 3.1). A "slope wedge" [m_lo, m_hi] holds the slopes from the current origin node that stay
 * within ±ε of every sample seen since (Eq. 3.3–3.4); when a sample closes the wedge, a node is
 * placed at the previous sample on the wedge's middle line and becomes the new origin (Eq.
 * 3.5–3.6). Slopes are per unit depth, not per sample, so skipped empty space and segments of
 * different steps are handled alike. m_lo starts at 0: V is non-decreasing, so a non-negative
 * slope always fits (m_hi ≥ 0 because α_origin ≤ α_acc + ε), and V' stays monotone. Node
 * opacities may exceed 1 by up to ε; lookups clamp V' to [0, 1], which only reduces the error.
 * Nothing is emitted until opacity first rises above 0: empty space produces no nodes. */
#ifndef SOMBRA_SHARED_COMPRESS_H
#define SOMBRA_SHARED_COMPRESS_H

#ifndef __OPENCL_C_VERSION__
#include <cmath>
#define SB_COMPRESS_INLINE static inline
#define SB_FMAX(a, b) std::fmax(a, b)
#define SB_FMIN(a, b) std::fmin(a, b)
#else
#define SB_COMPRESS_INLINE static inline
#define SB_FMAX(a, b) fmax(a, b)
#define SB_FMIN(a, b) fmin(a, b)
#endif

typedef struct {
    float epsilon;
    float origin_z, origin_alpha; /* last emitted node */
    float m_lo, m_hi;             /* slope wedge from the origin */
    float prev_z, prev_alpha;     /* last sample seen */
    int started;                  /* an origin node exists */
} VisibilityCompressor;

/* Emitted nodes, at most two per call: a caller writes out[0..count). */
typedef struct {
    float z[2], alpha[2];
    int count;
} CompressorOutput;

SB_COMPRESS_INLINE void compressor_init(VisibilityCompressor* c, float epsilon) {
    c->epsilon = epsilon;
    c->origin_z = c->origin_alpha = 0.0f;
    c->m_lo = 0.0f;
    c->m_hi = 0.0f;
    c->prev_z = c->prev_alpha = 0.0f;
    c->started = 0;
}

SB_COMPRESS_INLINE void compressor_emit(CompressorOutput* out, float z, float alpha) {
    out->z[out->count] = z;
    out->alpha[out->count] = alpha;
    out->count += 1;
}

/* Restarts the wedge at node (z, alpha) and narrows it to the sample (sample_z, sample_alpha). */
SB_COMPRESS_INLINE void compressor_restart(VisibilityCompressor* c, float z, float alpha, float sample_z,
                                           float sample_alpha) {
    float dz = sample_z - z;
    c->origin_z = z;
    c->origin_alpha = alpha;
    c->m_lo = SB_FMAX(0.0f, (sample_alpha - c->epsilon - alpha) / dz); /* Eq. 3.5 */
    c->m_hi = (sample_alpha + c->epsilon - alpha) / dz;                 /* Eq. 3.6 */
}

/* Feeds one sample. first_z is where the opacity was last known to be 0 (the previous sample's
 * depth, or the sample's own interval start), used for the first node. */
SB_COMPRESS_INLINE CompressorOutput compressor_add(VisibilityCompressor* c, float z, float alpha, float first_z) {
    CompressorOutput out;
    out.count = 0;
    if (!c->started) {
        if (alpha > 0.0f) {
            compressor_emit(&out, first_z, 0.0f); /* the function leaves 0 here */
            c->started = 1;
            compressor_restart(c, first_z, 0.0f, z, alpha);
        }
    } else {
        float dz = z - c->origin_z;
        float lo = SB_FMAX(c->m_lo, (alpha - c->epsilon - c->origin_alpha) / dz); /* Eq. 3.3 */
        float hi = SB_FMIN(c->m_hi, (alpha + c->epsilon - c->origin_alpha) / dz); /* Eq. 3.4 */
        if (lo > hi) {
            /* the sample left the wedge: a node at the previous sample on the wedge's middle line */
            float node_alpha = c->origin_alpha + 0.5f * (c->m_lo + c->m_hi) * (c->prev_z - c->origin_z);
            compressor_emit(&out, c->prev_z, node_alpha);
            compressor_restart(c, c->prev_z, node_alpha, z, alpha);
        } else {
            c->m_lo = lo;
            c->m_hi = hi;
        }
    }
    c->prev_z = z;
    c->prev_alpha = alpha;
    return out;
}

/* Ends the function: the last node closes the open line segment at the last sample. */
SB_COMPRESS_INLINE CompressorOutput compressor_finish(VisibilityCompressor* c) {
    CompressorOutput out;
    out.count = 0;
    if (c->started && c->prev_z > c->origin_z)
        compressor_emit(&out, c->prev_z, c->origin_alpha + 0.5f * (c->m_lo + c->m_hi) * (c->prev_z - c->origin_z));
    return out;
}

/* Before a vertical step (a surface, Knecht §3.2): ends the open line at the last sample as
 * compressor_finish does; the step then starts from there. */
SB_COMPRESS_INLINE CompressorOutput compressor_flush(VisibilityCompressor* c) {
    CompressorOutput out = compressor_finish(c);
    if (out.count > 0) c->origin_z = out.z[0], c->origin_alpha = out.alpha[0];
    return out;
}

/* A vertical step at z from alpha_before to alpha_after (a surface crossing, after
 * compressor_flush): two nodes at the same depth, never smoothed away; the next line starts at
 * (z, alpha_after) with an open wedge. A step at the origin's depth (coincident surfaces) only
 * moves the origin up. */
SB_COMPRESS_INLINE CompressorOutput compressor_step(VisibilityCompressor* c, float z, float alpha_before, float alpha_after) {
    CompressorOutput out;
    out.count = 0;
    if (!(c->started && c->origin_z == z)) compressor_emit(&out, z, alpha_before);
    compressor_emit(&out, z, alpha_after);
    c->started = 1;
    c->origin_z = c->prev_z = z;
    c->origin_alpha = c->prev_alpha = alpha_after;
    c->m_lo = 0.0f;
    c->m_hi = INFINITY;
    return out;
}

#endif /* SOMBRA_SHARED_COMPRESS_H */
