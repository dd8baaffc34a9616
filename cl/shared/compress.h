/* sombra — on-the-fly compression of a visibility function (Lokovic & Veach 2000; Knecht
 * Alg. 3.2, Eq. 3.1–3.6), shared verbatim by the DSM build kernel and the C++ tests.
 *
 * The function is fed as samples (z, α_acc) with z strictly increasing and α_acc non-decreasing.
 * It emits nodes (z, α) of a piecewise-linear V' with |V'(z_k) − α_acc(z_k)| ≤ ε at every sample
 * (Eq. 3.1). A "slope wedge" [m_lo, m_hi] holds the slopes from the current origin node that stay
 * within ±ε of every sample seen since (Eq. 3.3–3.4); when a sample closes the wedge, a node is
 * placed and becomes the new origin (Eq. 3.5–3.6). Unbiased placement (issue 27 item 2): the node
 * goes where α last rose (the "change point"), on the function itself when the wedge there allows
 * (else at the nearest edge of what it allows), not at the previous sample on the wedge's middle
 * line. A line that runs on past a kink into a flat stretch (the far side of a medium, the gap
 * between two volumes) is pushed by the flat samples to the edge of the ±ε band: the middle-line
 * rule left every such stretch up to ε too dark (a slab of opacity 0.730 flattened to 0.750 at ε
 * 0.02). Ending the line at the kink keeps the bound — every sample up to the change point is
 * within ε of any line in the wedge saved there, and the flat samples after it, equal to α there,
 * are within ε of the node and of the next line, which starts through the last of them — and
 * makes the mean signed error ≈ 0 (docs/deep-shadow-maps.md "Unbiased compression"). Slopes are per unit depth, not per sample, so skipped empty space and segments of
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
    float change_z, change_alpha; /* the last sample where α rose since the origin (or the origin) */
    float change_lo, change_hi;   /* the wedge just after that sample */
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
    c->change_z = c->change_alpha = 0.0f;
    c->change_lo = c->change_hi = 0.0f;
    c->started = 0;
}

SB_COMPRESS_INLINE void compressor_emit(CompressorOutput* out, float z, float alpha) {
    out->z[out->count] = z;
    out->alpha[out->count] = alpha;
    out->count += 1;
}

/* Saves (z, alpha) and the current wedge as the change point. */
SB_COMPRESS_INLINE void compressor_mark_change(VisibilityCompressor* c, float z, float alpha) {
    c->change_z = z;
    c->change_alpha = alpha;
    c->change_lo = c->m_lo;
    c->change_hi = c->m_hi;
}

/* Restarts the wedge at node (z, alpha) and narrows it to the sample (sample_z, sample_alpha),
 * which becomes the change point. */
SB_COMPRESS_INLINE void compressor_restart(VisibilityCompressor* c, float z, float alpha, float sample_z,
                                           float sample_alpha) {
    float dz = sample_z - z;
    c->origin_z = z;
    c->origin_alpha = alpha;
    c->m_lo = SB_FMAX(0.0f, (sample_alpha - c->epsilon - alpha) / dz); /* Eq. 3.5 */
    c->m_hi = (sample_alpha + c->epsilon - alpha) / dz;                 /* Eq. 3.6 */
    compressor_mark_change(c, sample_z, sample_alpha);
}

/* The value of a node at depth z, where the function is `alpha`, for slopes in [lo, hi] from the
 * origin: alpha itself when a slope of the wedge reaches it, else the nearest line's value. */
SB_COMPRESS_INLINE float compressor_node_alpha(const VisibilityCompressor* c, float z, float alpha, float lo, float hi) {
    float dz = z - c->origin_z;
    return SB_FMIN(SB_FMAX(alpha, c->origin_alpha + lo * dz), c->origin_alpha + hi * dz);
}

/* Narrows the wedge to the sample (z, alpha); returns 0 (and leaves the wedge) if it closes. */
SB_COMPRESS_INLINE int compressor_narrow(VisibilityCompressor* c, float z, float alpha) {
    float dz = z - c->origin_z;
    float lo = SB_FMAX(c->m_lo, (alpha - c->epsilon - c->origin_alpha) / dz); /* Eq. 3.3 */
    float hi = SB_FMIN(c->m_hi, (alpha + c->epsilon - c->origin_alpha) / dz); /* Eq. 3.4 */
    if (lo > hi) return 0;
    c->m_lo = lo;
    c->m_hi = hi;
    if (alpha != c->prev_alpha) compressor_mark_change(c, z, alpha);
    return 1;
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
    } else if (!compressor_narrow(c, z, alpha)) {
        /* the sample left the wedge: a node at the change point (none when α has not risen since
         * the origin, a surface step: the line restarts from the origin itself) */
        float node_z = c->origin_z, node_alpha = c->origin_alpha;
        if (c->change_z > c->origin_z) {
            node_z = c->change_z;
            node_alpha = compressor_node_alpha(c, node_z, c->change_alpha, c->change_lo, c->change_hi);
            compressor_emit(&out, node_z, node_alpha);
        }
        if (c->prev_z > node_z) {
            /* α stayed flat from node_z to prev_z: the next line starts through those samples */
            compressor_restart(c, node_z, node_alpha, c->prev_z, c->prev_alpha);
            if (!compressor_narrow(c, z, alpha)) { /* and the sample leaves it at once: a node at prev_z */
                node_alpha = compressor_node_alpha(c, c->prev_z, c->prev_alpha, c->m_lo, c->m_hi);
                compressor_emit(&out, c->prev_z, node_alpha);
                compressor_restart(c, c->prev_z, node_alpha, z, alpha);
            }
        } else {
            compressor_restart(c, node_z, node_alpha, z, alpha);
        }
    }
    c->prev_z = z;
    c->prev_alpha = alpha;
    return out;
}

/* Ends the function: the last node closes the open line at the change point; lookups past the
 * last node read its value, so a flat tail needs none. */
SB_COMPRESS_INLINE CompressorOutput compressor_finish(VisibilityCompressor* c) {
    CompressorOutput out;
    out.count = 0;
    if (c->started && c->change_z > c->origin_z)
        compressor_emit(&out, c->change_z, compressor_node_alpha(c, c->change_z, c->change_alpha, c->change_lo, c->change_hi));
    return out;
}

/* Before a vertical step (a surface, Knecht §3.2): ends the open line as compressor_finish does;
 * the step then starts from there. */
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
    compressor_mark_change(c, z, alpha_after); /* no rise since the step yet */
    return out;
}

#endif /* SOMBRA_SHARED_COMPRESS_H */
