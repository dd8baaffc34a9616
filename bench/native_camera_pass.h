// sombra bench — the camera pass of cl/render.cl as native C++ (threads, optionally SIMD), reading
// exactly the data the kernel reads: pack_scene() and pack_camera() from src/geometry/scene_upload.h.
// The kernel's algorithm for scenes without shadows, meshes or polyhedral bounds (Phong, central
// differences): exact intervals, brick skipping, pre-integrated extinction, early termination.
#pragma once
#include <vector>

#include "geometry/scene_upload.h"
#include "sombra/render.h"
#include "sombra/scene.h"

namespace sombra::bench {

// Everything the kernel's arguments hold, in host memory.
struct NativeScene {
    packing::PackedScene packed;
    CameraGpu camera{};
    std::vector<float> voxels;  // all volumes concatenated (VolumeGpu::data_offset), the buffer path
    std::vector<float> tf;      // packed.tf_tables flattened: r, g, b, σ per entry
    bool skip_empty = true;     // SOMBRA_SKIP_EMPTY
};

// Packs the scene as sombra::render() does for these options (size, termination, jitter seed,
// empty-space skipping). Central-difference gradients only (the renderer's default).
NativeScene make_native_scene(const Scene& scene, const RenderOptions& options);

enum class NativeVariant {
    Scalar,  // one ray at a time per thread, as a work-item runs it
    Simd     // per thread a wavefront of rays in flight; their points shaded in `omp simd` batches
};

struct NativeImage {
    std::vector<float> rgba;  // like sombra::Image::rgba
    unsigned long long samples = 0;  // one per active volume per point, as the kernel counts
};

NativeImage render_native(const NativeScene& scene, NativeVariant variant, unsigned threads);

}  // namespace sombra::bench
