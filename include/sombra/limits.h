// sombra — upper bounds on every count and size an input may ask for (docs/hostile-input.md, the table of limits).
// Files are checked against them (and against their real size) before anything is allocated.
#pragma once
#include <cstdint>

namespace sombra::limits {

constexpr std::uint64_t kMaxVolumeVoxels = std::uint64_t(1) << 30;   // per volume (1024³; 4 GiB as floats)
// per volume file read in parts (VolumeLoadOptions::header_only: the ranks of a distributed render
// each read a box of at most kMaxVolumeVoxels; 2^40 = 10240³)
constexpr std::uint64_t kMaxPartedVolumeVoxels = std::uint64_t(1) << 40;
constexpr int kMaxGeneratorSize = 1024;                              // generator "size" (voxels per side)
constexpr int kMaxGeneratorBlobs = 256;                              // blobs generator "count"
constexpr int kMaxImageSide = 16384;                                 // image width and height
constexpr int kMaxLights = 8;                                        // lights per scene
constexpr int kMaxMeshes = 256;                                      // mesh instances per scene
constexpr std::uint64_t kMaxTransferPoints = 65536;                  // rgb and opacity points per function
constexpr std::uint64_t kMaxMeshVertices = std::uint64_t(1) << 26;   // per mesh file
constexpr std::uint64_t kMaxMeshTriangles = std::uint64_t(1) << 26;  // per mesh file (after triangulation)
constexpr std::uint64_t kMaxPoints = std::uint64_t(1) << 24;         // rows of a --points file
constexpr std::uint64_t kMaxInputFileBytes = std::uint64_t(1) << 30; // scene JSON, raw headers, meshes, points CSV
constexpr double kMaxCoordinate = 1e18;                              // |world coordinate| of boxes, camera, lights
constexpr float kMinLength = 1e-12f;                                 // voxel spacing, opacity_unit (so σ stays finite)

}  // namespace sombra::limits
