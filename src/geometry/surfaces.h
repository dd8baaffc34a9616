// sombra — translucent meshes in the passes (issue 4): the per-triangle shading data and per-mesh
// materials the kernels read (cl/surfaces.h), and a view's per-pixel fragment lists (raster stage +
// fragment stage, geometry/rasterizer.h and geometry/fragments.h).
#pragma once
#include <vector>

#include "geometry/fragments.h"

namespace sombra::surfaces {

// Triangles in the order of ScreenTriangleGpu::source (mesh after mesh), one material per instance;
// each triangle's corner.w is its mesh's opacity (shadow rays read it without the materials).
struct PackedSurfaces {
    std::vector<SurfaceTriangleGpu> triangles;
    std::vector<SurfaceMaterialGpu> materials;
};
PackedSurfaces pack_surfaces(const Scene& scene);

// Polyhedral volume bounds (issue 4): whether any volume has one; whether a view needs fragment
// lists (surfaces or bounds). pack_bounds sets every volume's bound_first/bound_count and returns
// the bound triangles in the world, corner.w = the volume's index (shadow rays cross them).
bool has_bounds(const Scene& scene);
bool has_fragments(const Scene& scene);
std::vector<SurfaceTriangleGpu> pack_bounds(const Scene& scene, std::vector<VolumeGpu>& volumes);

struct DeviceSurfaces {
    cl::Buffer triangles, materials;
    cl_uint triangle_count = 0;
};
DeviceSurfaces upload_surfaces(host::Runtime& runtime, const PackedSurfaces& packed);

// What shadow rays cross (render.cl: surfaces_transmittance, or the polyhedral bounds' crossings):
// the triangles in the order of a bounding-volume hierarchy over them (geometry/bvh.h) and its
// nodes. `what` names them in allocation errors.
struct ShadowBvh {
    cl::Buffer triangles, nodes;
    cl_uint node_count = 0;
};
ShadowBvh upload_shadow_bvh(host::Runtime& runtime, const std::vector<SurfaceTriangleGpu>& triangles,
                           const std::string& what);

// A view's fragments: each pixel's covering triangles — the meshes' surfaces and the volumes'
// bound meshes (flagged SOMBRA_TRI_BOUND, mesh = the volume's index) — sorted near to far, with
// the screen triangles their ids index.
struct ViewFragments {
    raster::DeviceTiles tiles;
    raster::DeviceFragments fragments;
};
// `meshes` (empty: all) and `volume_mask` (bit i: volume i's bound mesh) choose what the view
// holds: a cluster's deep shadow map holds its members only (Knecht §3.4.3). Triangles keep their
// ids (ScreenTriangleGpu.source) either way.
ViewFragments view_fragments(host::Runtime& runtime, const Scene& scene, const raster::View& view,
                             const std::vector<bool>& meshes = {}, cl_uint volume_mask = ~0u);

}  // namespace sombra::surfaces
