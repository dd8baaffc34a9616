// sombra — a scene packed for the kernels: volume voxels (buffer or 3D image atlas), per-volume
// brick occupancy for empty-space skipping, transfer-function tables, lights. Shared by every pass.
#pragma once
#include <CL/opencl.hpp>

#include <array>
#include <vector>

#include "host/runtime.h"
#include "shared/types.h"
#include "sombra/scene.h"

namespace sombra::packing {

constexpr int kTransferTableSize = 1024;

// Brick value ranges of a volume (Hadwiger §3): brick b covers voxels [4b, 4b + 4] per axis (4 =
// SOMBRA_BRICK_SIZE), one voxel of overlap so that every trilinear sample inside the brick reads
// only its voxels.
struct BrickRanges {
    std::array<int, 3> brick_dims{0, 0, 0};
    std::vector<float> min, max;
};
BrickRanges compute_brick_ranges(const Volume& volume);

// Every brick's distance byte from its occupancy flags (1: may be visible; x fastest), for the
// marches' brick test (cl/traversal.h in_empty_bricks): an empty brick holds r, an occupied one
// 128 + r, where r ≥ 1 is its Chebyshev distance (in bricks) to the nearest brick of the other
// kind, at most 127 — every brick within r − 1 of it, inside the grid, is of its own kind.
std::vector<cl_uchar> brick_distances(const std::vector<cl_uchar>& occupied, const std::array<int, 3>& brick_dims);

// A volume's voxel (continuous index, voxel centres at integers) → world map, row-major, and its inverse.
std::array<float, 16> voxel_to_world_matrix(const VolumeInstance& vi);
std::array<float, 16> world_to_voxel_matrix(const VolumeInstance& vi);

// Host-side packing, independent of OpenCL devices (the CPU references read it too).
struct PackedScene {
    std::vector<VolumeGpu> volumes;
    std::vector<LightGpu> lights;
    std::vector<cl_float4> tf_tables;
    // Per volume from VolumeGpu::brick_offset: each brick's flag (1: it may be visible under the
    // transfer function), then each brick's distance byte (brick_distances).
    std::vector<cl_uchar> occupancy;
    std::vector<std::array<float, 16>> voxel_to_world;  // row-major, per volume
    std::vector<SurfaceTriangleGpu> bound_triangles;    // polyhedral bounds in the world (VolumeGpu.bound_first)
};
PackedScene pack_scene(const Scene& scene);
std::vector<LightGpu> pack_lights(const Scene& scene);  // the lights part of pack_scene

CameraGpu pack_camera(const Scene& scene, int width, int height);

// The packed scene on a device. Voxels live in one float buffer, or in one 3D image whose z
// slices stack the volumes (padded to the largest x/y), as the kernels' SOMBRA_USE_IMAGES says.
struct DeviceScene {
    bool uses_images = false;
    cl::Buffer voxel_buffer;
    cl::Image3D voxel_image;
    cl::Buffer occupancy, tf_tables, volumes, lights;
    double upload_ms = 0;  // sum of the upload commands' profiling times
};
DeviceScene upload_scene(host::Runtime& runtime, const Scene& scene, const PackedScene& packed, bool use_images);

}  // namespace sombra::packing
