// sombra — the deep shadow map views of a scene's lights (Knecht §3.2): one perspective view for a
// spot light (its cone), six 90° cube faces for a point light, one orthographic view fitted to
// the scene for a directional light; depth ranges fitted to the objects.
#pragma once
#include <string>
#include <vector>

#include "geometry/scene_upload.h"
#include "sombra/shadows.h"

namespace sombra::shadows {

// World-space corners of every volume's box (8 per volume).
std::vector<std::array<float, 3>> scene_box_corners(const packing::PackedScene& packed, const Scene& scene);

// The meshes each view's map holds, per view (a cluster's map holds its members only, Knecht
// §3.4.3; its volumes are DsmViewGpu.volume_mask). No entry, or an empty one: every mesh.
using ViewMeshes = std::vector<std::vector<bool>>;

// Views for every light, in light order, and (when asked) each light's range of them. first_texel
// of each view is laid out consecutively (resolution² texels per view). Every view holds every
// object (one cluster per light).
std::vector<DsmViewGpu> make_dsm_views(const Scene& scene, const packing::PackedScene& packed, int resolution,
                                       std::vector<DsmLightViews>* light_views = nullptr);

// Sets map.world_to_camera and map.world_to_ndc from the view (DeepShadowMap's conventions:
// OpenEXR's camera and NDC spaces; texel rows go along axis_y, which is camera −y).
void place_map(const DsmViewGpu& view, DeepShadowMap& map);

// The sub-pixel maps a pre-filter merges (Lokovic & Veach 2000 §5.1; taps and sampling positions
// in cl/shared/prefilter.h): `maps` views of resolution² texels per DSM view, in view order;
// texel (x, y) of a DSM view reads sub-map texels (scale·x + dx, scale·y + dy).
struct SubPixelMaps {
    std::vector<DsmViewGpu> views;
    int maps = 1, scale = 2, resolution = 0;
};

// filter: box, tent or 5tap (else an Error naming --prefilter). With `jitter`, every sub-pixel
// ray is moved by a hash of (texel, seed, sub-map) within its cell: ±¼ texel of the DSM view.
SubPixelMaps sub_pixel_views(const std::vector<DsmViewGpu>& views, const std::string& filter, bool jitter, unsigned seed);

}  // namespace sombra::shadows
