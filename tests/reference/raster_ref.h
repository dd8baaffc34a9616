// sombra tests — CPU reference of cl/raster.cl: coverage evaluated per pixel centre, directly.
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "shared/types.h"

namespace sombra::reference {

// Whether the triangle covers the centre of pixel (px, py) under the top-left rule, written as a
// symbolic perturbation: P counts as inside iff P + (−ε, −ε²) lies strictly inside (ε → 0).
bool covers(const ScreenTriangleGpu& t, int px, int py);

// Per tile (ty·tiles_x + tx): the (triangle index, 64-bit mask) pairs with a non-empty mask, sorted.
using TileList = std::vector<std::pair<std::uint32_t, std::uint64_t>>;
std::vector<TileList> tile_lists(const std::vector<ScreenTriangleGpu>& triangles, int width, int height);

// How many triangles cover each pixel (row-major).
std::vector<int> coverage_counts(const std::vector<ScreenTriangleGpu>& triangles, int width, int height);

}  // namespace sombra::reference
