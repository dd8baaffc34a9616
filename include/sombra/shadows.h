// sombra — shadow data on the host: deep shadow maps as node lists, their deep OpenEXR form, and
// the brute-force transmittance every shadow technique is measured against.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sombra/scene.h"

namespace sombra {

// One node of a compressed visibility function (Knecht §3.2): accumulated opacity α at a depth.
// Depth is the distance from the light along the texel's ray (spot and point lights) or from the
// DSM's near plane along the light direction (directional lights), in world units.
struct DsmNode {
    float depth;
    float opacity;
};

// The deep shadow map of one light view (one spot light, one cube face of a point light, or one
// directional light), read back from the device. Texel (x, y) owns the nodes
// nodes[first[y·width + x] … first[y·width + x + 1]), sorted by depth, opacity non-decreasing.
// A texel without nodes is fully lit.
struct DeepShadowMap {
    int width = 0, height = 0;
    std::vector<std::uint32_t> first;  // width·height + 1 offsets
    std::vector<DsmNode> nodes;
    // Between two nodes the opacity is linear (Knecht Eq. 3.7), or, for maps built with
    // DsmOptions::error "relative", 1 − exp(−τ) with the optical depth τ = −ln(1 − opacity) linear.
    enum class Interpolation { Opacity, OpticalDepth } interpolation = Interpolation::Opacity;
    std::string light_name;  // e.g. "lights[0]", "lights[1].+x", "lights[0].cluster1.0"
    // Which map it is: the light's index, and the view among the light's maps ("+x" … "-z" for a
    // point light's cube faces, "cluster<k>.<j>" for view j of cluster k, "" for a light's one
    // view). Unknown (−1, "") for a map read from a file.
    int light = -1;
    std::string view_name;
    // Where the map lies in the world, in OpenEXR's (and RenderMan's) conventions; row-major,
    // column vectors (p' = M·p, like VolumeInstance::transform). world_to_camera: to the light's
    // left-handed camera space (x right, y up in the map, z along the light; origin at the light,
    // or at the centre of a directional light's near plane). world_to_ndc: to (0, 0) at the map's
    // top-left corner … (1, 1) at its bottom-right, after division by w. Identity when unknown.
    std::array<float, 16> world_to_camera{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::array<float, 16> world_to_ndc{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
};

// A scanline deep OpenEXR that follows OpenEXR's deep convention, through OpenImageIO: one point
// sample per node (Z = ZBack = the node's depth) whose A is the node's own alpha
// 1 − V(z_i)/V(z_i−1), V = 1 − opacity clamped to [0, 1], so compositing a texel's samples front
// to back (e.g. `oiiotool --flatten`) gives the node's opacity; worldToCamera and worldToNDC in
// the header. Written under a temporary name renamed at the end (no partial file). Throws
// sombra::Error. docs/deep_exr.md describes the file.
void write_deep_exr(const DeepShadowMap& map, const std::string& path);
// Reads sombra's files, old ones too (before sombra:format 2, A was the accumulated opacity), and
// deep files of other tools (point samples, or volumetric samples that do not overlap).
DeepShadowMap read_deep_exr(const std::string& path);

// Ground truth: transmittance from world point p to light `light_index` of the scene, integrated
// in double precision: the ray cut at the planes of voxel centres and into pieces of at most
// `step_voxels` of each volume's smallest voxel, the value taken linear over each piece (trilinear
// interpolation at its ends) and σ integrated over the value range in closed form from the
// transfer function's opacity points (exact for stiff media; no table, no compression).
// Overlapping volumes add their optical depths; every mesh triangle crossed on the way multiplies
// the result by 1 − its mesh's opacity (brute force over all triangles). Lights at infinity
// (directional) integrate to the far side of every volume.
double reference_transmittance(const Scene& scene, int light_index, const Vec3& p, double step_voxels = 0.05);

}  // namespace sombra
