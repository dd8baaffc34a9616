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

#include <array>

#include "geometry/rasterizer.h"

namespace sombra::reference {

using WorldTriangle = std::array<std::array<double, 3>, 3>;

// The world corners of every source triangle of the instances, in project_meshes' order.
std::vector<WorldTriangle> world_triangles(const std::vector<MeshInstance>& meshes);

// Per pixel (y·width + x): the screen triangles that cover it (covers()), each with the depth at
// which the pixel's ray meets its source triangle's world plane (double; raster::View's depth
// convention), sorted near to far.
struct Fragment {
    double depth;
    std::uint32_t triangle;
};
std::vector<std::vector<Fragment>> fragments(const std::vector<ScreenTriangleGpu>& triangles,
                                             const std::vector<WorldTriangle>& world, const raster::View& view);

}  // namespace sombra::reference
