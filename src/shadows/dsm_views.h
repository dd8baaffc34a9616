// sombra — the deep shadow map views of a scene's lights (Knecht §3.2): one perspective view for a
// spot light (its cone), six 90° cube faces for a point light, one orthographic view fitted to
// the scene for a directional light; depth ranges fitted to the objects.
#pragma once
#include <vector>

#include "render/scene_upload.h"

namespace sombra::shadows {

// World-space corners of every volume's box (8 per volume).
std::vector<std::array<float, 3>> scene_box_corners(const packing::PackedScene& packed, const Scene& scene);

// Views for every light, in light order; sets packed.lights[i].view_first / view_count.
// first_texel of each view is laid out consecutively (resolution² texels per view).
std::vector<DsmViewGpu> make_dsm_views(const Scene& scene, packing::PackedScene& packed, int resolution);

}  // namespace sombra::shadows
