// sombra — building the deep shadow maps of a scene on the device (Knecht Alg. 3.1): views per
// light, then per view two passes of dsm_build.cl — count the nodes of every texel, turn the
// counts into offsets by a prefix sum, write the nodes — into "compact" storage.
#pragma once
#include <CL/opencl.hpp>

#include <vector>

#include "render/scene_upload.h"
#include "sombra/shadows.h"

namespace sombra::shadows {

struct DsmBuildOptions {
    int resolution = 512;
    float epsilon = 0.02f;  // Knecht Eq. 3.1
};

struct DsmStats {
    int views = 0, resolution = 0;
    double count_ms = 0, prefix_sum_ms = 0, write_ms = 0;  // kernels from profiling events, prefix sum on the host
    unsigned long long nodes = 0;
    double mean_nodes_per_texel = 0;  // over all texels of all views
    unsigned max_nodes_per_texel = 0;
    unsigned long long bytes_used = 0, bytes_wasted = 0;
};

struct DeviceDsm {
    std::vector<DsmViewGpu> views;
    std::vector<cl_uint> texel_first;  // host copy of the offsets (views·res² + 1)
    cl::Buffer views_buffer, texel_first_buffer, nodes_buffer;
    DsmStats stats;
};

// packed.lights must already carry view_first / view_count from make_dsm_views (the same views).
DeviceDsm build_deep_shadow_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                 const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views,
                                 const DsmBuildOptions& options);

// One view's map read back from the device, for export (sombra dsm) and tests.
DeepShadowMap read_back(host::Runtime& runtime, const DeviceDsm& dsm, int view, const std::string& name);

std::vector<std::string> volume_pass_defines(const Scene& scene, bool use_images, bool skip_empty);

}  // namespace sombra::shadows
