// sombra tests — plain C++ reference of the light-aligned summed-area tables (cl/sat_build.cl)
// and of the box-filtered optical depth (cl/lowpass.h, Ament Eq. 12–13), in double precision.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "shadows/sat_grid.h"
#include "sombra/scene.h"

namespace sombra::reference {

// Cells of a grid with their values, index i + n0·(j + n1·k).
struct CellGrid {
    std::array<int, 3> dims{0, 0, 0};
    std::vector<double> cells;
    double at(int i, int j, int k) const { return cells[std::size_t(i) + std::size_t(dims[0]) * (std::size_t(j) + std::size_t(dims[1]) * std::size_t(k))]; }
};

// Optical depth of every cell of `frame`: the mean over the grid axes in light_axes (bit a: axis a;
// 0: all three) of ∫σ along that axis through the cell's centre, face to face
// (segment_optical_depth, the transfer function evaluated directly), as cl/sat_build.cl, over the
// volumes of frame.volume_mask.
CellGrid sat_cells(const Scene& scene, const shadows::SatFrame& frame, unsigned light_axes);

// Cells of a point light's spherical grid (SSAT, Ament §4.2.3): ∫σ over the cell's radial segment
// through its centre angles times w_θ = (cos θ_j − cos θ_j+1)/Δθ, over the volumes of the grid's
// volume_mask.
CellGrid ssat_cells(const Scene& scene, const SsatGridGpu& grid);

// The cells of a device table (exclusive SAT, fixed point), recovered by differencing, as τ.
CellGrid cells_of_table(const std::vector<std::uint64_t>& table, const std::array<int, 3>& dims);

// Brute force: Σ cells over the real box [lo, hi) in cell units, a cell weighted by the fraction
// of it inside the box (σ is constant in a cell); outside the grid σ = 0.
double box_sum(const CellGrid& grid, const std::array<double, 3>& lo, const std::array<double, 3>& hi);

// Exclusive SAT of a grid in type T (double, float, or fixed-point uint64) and a box sum of it.
template <typename T>
std::vector<T> build_sat(const CellGrid& grid, T (*convert)(double));
template <typename T>
T sat_box(const std::vector<T>& sat, const std::array<int, 3>& dims, const std::array<int, 3>& lo, const std::array<int, 3>& hi);

// Box-filtered optical depth τ̄ at world point p (Ament Eq. 12–13): the W × W box across grid
// axis `axis` centred on p, from p to the grid face towards the light (+axis if positive), / W².
double filtered_depth(const CellGrid& grid, const shadows::SatFrame& frame, int axis, bool positive, int width,
                      const std::array<double, 3>& p);

// Gaussian-filtered optical depth (Ament §4.3, Eq. 25): the same patch cut into k × k sub-boxes,
// their mean optical depths weighted by the mass of a Gaussian (σ = W/4, truncated at ±2σ).
double gauss_filtered_depth(const CellGrid& grid, const shadows::SatFrame& frame, int axis, bool positive, int width,
                            const std::array<double, 3>& p, int k = 5);

// The baselines on a volume-aligned grid (Schlegel et al. 2011), brute force over the cells:
// ambient optical depth (mean σ·h in the cube of side `width` cells around p, × width/2) and cone
// optical depth (cubes of half size max(½, t·tan) along `towards` from t = ½ cell, up to `reach`
// world units or where the cubes leave the grid (from a point outside the grid, the cubes before
// it are skipped); cubes of half size ≥ snap_radius cells have their faces on the
// nearest cell faces, as the kernel's from SOMBRA_CONE_SNAP_RADIUS; +∞: every cube exact), stopping
// at the opaque depth (SOMBRA_OPAQUE_DEPTH), as the kernel does; both in cl/shared/types.h.
double ambient_depth(const CellGrid& grid, const shadows::SatFrame& frame, int width, const std::array<double, 3>& p);
double cone_depth(const CellGrid& grid, const shadows::SatFrame& frame, double cone_tan, const std::array<double, 3>& p,
                  const std::array<double, 3>& towards, double reach, double snap_radius = SOMBRA_CONE_SNAP_RADIUS);

}  // namespace sombra::reference
