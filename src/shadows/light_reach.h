// sombra — which volumes can shadow which: the volumes' world bounding boxes, and whether a box
// lies between another box and a light. The shadow cache's entries (src/render/shadow_cache.cpp)
// and the low-pass tables' (sat_update.cpp) are keyed by the volumes that can reach them.
#pragma once
#include <cmath>
#include <vector>

#include "geometry/scene_upload.h"
#include "shadows/sat_grid.h"  // D3, scene_corners

namespace sombra::shadows {

struct WorldBox {
    D3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    void add(const D3& p);
    WorldBox grown(double r) const;
    bool overlaps(const WorldBox& o) const;
    double diagonal() const;
};

// Per volume, the world box of its voxel cells (corners ± half a voxel).
std::vector<WorldBox> volume_boxes(const packing::PackedScene& packed);

// Whether `caster` meets the region between `receiver` and `light` (conservative): the box of
// `receiver` and a point or spot light's position, or `receiver` swept to infinity towards a
// directional light.
bool between_light_and(const WorldBox& receiver, const WorldBox& caster, const LightGpu& light);

}  // namespace sombra::shadows
