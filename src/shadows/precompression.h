// sombra — pre-compression of transfer-function frequencies (Hadwiger et al. 2006, §3.2): for every
// pair of successive density samples (front, back) one step Δ apart, the visibility function of
// the segment between them — density varying linearly from front to back (pre-integration, Engel
// et al. 2001) — is precomputed and compressed with the DSM compressor (cl/shared/compress.h), so
// a step function in the opacity TF (an isosurface) is placed where it lies inside the step rather
// than at the next sample. Rebuild the table whenever the transfer function, opacity unit or step
// change (the inputs are recorded in the table so callers can check).
#pragma once
#include <cstddef>
#include <vector>

#include "sombra/transfer_function.h"

namespace sombra::shadows {

struct PrecompressionTable {
    int size = 0;  // entries per axis: densities at the TF table's sample points (domain_min … domain_max)
    float domain_min = 0, domain_scale = 0;  // same mapping as the kernel's TF table: u = (d − min)·scale
    static constexpr int kMaxNodes = 4;
    // Entry (front, back) = front * size + back. Per entry up to 4 nodes (fraction f ∈ (0, 1] of the
    // step, opacity α of the step up to f), sorted by f, the last one at f = 1 carrying the whole
    // step's opacity V(1). The origin (0, 0) is implicit and never stored; a node (f > 0, α = 0)
    // marks where opacity leaves 0 inside the step (an isosurface). Unused nodes have f = α = 0.
    // Entries whose segment has zero opacity everywhere (empty space) have no nodes (count 0).
    // V'(f) is the polyline through (0, 0) and the nodes, clamped to [0, 1] (see evaluate()).
    std::vector<float> fraction, opacity;  // size*size*kMaxNodes each
    std::vector<unsigned char> counts;     // size*size
    double max_error = 0;  // largest |V'(f) − V(f)| over the fine samples of all entries (≤ epsilon
                           // unless 4 nodes did not suffice; then reported here)
    std::size_t entries_over_budget = 0;  // entries whose compressed function needed more than 4 nodes
                                          // (kept: recompressed with a doubled ε until ≤ 4 nodes fit)

    // The inputs the table was built for (rebuild when any of them, or the TF, changes).
    float opacity_unit = 0, step = 0, epsilon = 0;
    int fine_samples = 0;

    // Density of table index i (i ∈ [0, size)).
    float density(int i) const { return domain_scale > 0.f ? domain_min + float(i) / domain_scale : domain_min; }
    // Nearest table index of a density (clamped), as the kernel rounds u.
    int index(float density) const;
    std::size_t entry(int front, int back) const { return std::size_t(front) * std::size_t(size) + std::size_t(back); }
    // V'(f) of entry (front, back): opacity of the step's first fraction f ∈ [0, 1], clamped to [0, 1].
    float evaluate(int front, int back, float f) const;
};

// Builds the table: size ≥ 2 entries per axis over [tf.domain_min(), tf.domain_max()]; opacity_unit,
// step (world units) and epsilon > 0; fine_samples ≥ 2 samples of V per entry (at f = k/fine_samples,
// k = 1 … fine_samples). σ(d) = −ln(1 − α(d))/opacity_unit with α(d) the TF's piecewise-linear
// opacity, capped at σ = −ln(1e-6)/opacity_unit; the integral over the linear density ramp is
// evaluated exactly (closed-form antiderivative of σ over density, in double). Throws sombra::Error
// on invalid arguments. Multithreaded (std::thread).
PrecompressionTable build_precompression_table(const TransferFunction& tf, float opacity_unit, float step, int size,
                                               float epsilon, int fine_samples = 256);

}  // namespace sombra::shadows
