// sombra — a bounding-volume hierarchy over the world-space mesh triangles, so that a shadow ray
// tests the triangles near it instead of every triangle (cl/bvh.h walks it in the kernels).
// Built on the host with the surface area heuristic over 12 bins per axis (Wald 2007, "On fast
// construction of SAH-based bounding volume hierarchies"); leaves of at most `leaf_size` triangles.
#pragma once
#include <cstdint>
#include <vector>

#include "shared/types.h"

namespace sombra::bvh {

struct Hierarchy {
    std::vector<BvhNodeGpu> nodes;  // depth first; nodes[0] is the root (empty when there are no triangles)
    std::vector<std::uint32_t> order;  // triangle k of the BVH order is input triangle order[k]
};

// Builds the hierarchy over `triangles` (corner, corner1, corner2 in world space). Degenerate
// triangles (zero area, repeated corners) are kept: their boxes are points or lines.
Hierarchy build(const std::vector<SurfaceTriangleGpu>& triangles, unsigned leaf_size = 4);

// `triangles` permuted into BVH order (what the kernels index with a leaf's [first, first + count)).
std::vector<SurfaceTriangleGpu> reorder(const std::vector<SurfaceTriangleGpu>& triangles, const Hierarchy& h);

}  // namespace sombra::bvh
