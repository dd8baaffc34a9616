// sombra — piecewise-linear transfer functions (ParaView-style RGBPoints + opacity points).
#pragma once
#include <array>
#include <string>
#include <vector>

namespace sombra {

// Colour and opacity as functions of the data value. Opacity convention: an opacity point's
// value α is the opacity of a slab of thickness `opacity_unit` (world units) of that material;
// the renderer converts it to extinction σ = −ln(1 − α) / opacity_unit and uses
// α' = 1 − exp(−σ Δ) at step Δ (the same as α' = 1 − (1 − α)^(Δ/opacity_unit)).
struct TransferFunction {
    struct ColorPoint { float x, r, g, b; };
    struct OpacityPoint { float x, alpha; };
    std::vector<ColorPoint> color_points;      // sorted by x; at least one
    std::vector<OpacityPoint> opacity_points;  // sorted by x; at least one

    std::array<float, 3> color(float x) const;  // clamped at the ends
    float opacity(float x) const;
    // Domain covered by the points (union of both lists).
    float domain_min() const;
    float domain_max() const;
    // Table of (r, g, b, σ) at `size` equally spaced values over [domain_min, domain_max].
    // σ is capped at −ln(1e-6)/opacity_unit for α = 1.
    std::vector<std::array<float, 4>> table(int size, float opacity_unit) const;
    // Throws sombra::Error naming `where` if the points are empty, unsorted, non-finite, or out of
    // range (colours and opacities must lie in [0, 1]).
    void validate(const std::string& where) const;
};

}  // namespace sombra
