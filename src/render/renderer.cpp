#include <chrono>
#include <sstream>

#include <nlohmann/json.hpp>

#include "render/scene_upload.h"
#include "shadows/dsm_builder.h"
#include "shadows/dsm_views.h"
#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra {
namespace {

// -D defines for the camera pass: what this scene and these options need, nothing more.
std::vector<std::string> camera_pass_defines(const Scene& scene, const RenderOptions& options, bool use_images,
                                             int lanes) {
    std::vector<std::string> defines = shadows::volume_pass_defines(scene, use_images, options.empty_space_skipping);
    defines.push_back("SOMBRA_LANES=" + std::to_string(lanes));
    if (options.gradient == GradientMethod::Sobel) defines.push_back("SOMBRA_SOBEL");
    if (!scene.lights.empty()) defines.push_back("SOMBRA_HAS_LIGHTS");
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Rays) defines.push_back("SOMBRA_SHADOW_RAYS");
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Dsm) defines.push_back("SOMBRA_SHADOW_DSM");
    return defines;
}

}  // namespace

std::string RenderStats::to_json() const {
    nlohmann::json j;
    j["device"] = device;
    j["width"] = width;
    j["height"] = height;
    j["samples"] = samples;
    j["msamples_per_s"] = msamples_per_s;
    j["stage_ms"] = stage_ms;
    if (dsm_views > 0) {
        j["dsm"] = {{"views", dsm_views},
                    {"nodes", dsm_nodes},
                    {"mean_nodes_per_texel", dsm_mean_nodes_per_texel},
                    {"max_nodes_per_texel", dsm_max_nodes_per_texel},
                    {"bytes_used", dsm_bytes_used},
                    {"bytes_wasted", dsm_bytes_wasted}};
    }
    return j.dump(2);
}

RenderResult render(Context& context, const Scene& scene, const RenderOptions& options) {
    using clock = std::chrono::steady_clock;
    host::Runtime& runtime = context.runtime();
    int width = options.width > 0 ? options.width : scene.width;
    int height = options.height > 0 ? options.height : scene.height;
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        throw Error("--width/--height: must lie in [1, 16384]");
    validate_scene(scene, scene.source);

    RenderResult result;
    RenderStats& stats = result.stats;
    stats.device = runtime.info().name;
    stats.width = width, stats.height = height;

    auto t0 = clock::now();
    packing::PackedScene packed = packing::pack_scene(scene);
    bool use_dsm = options.shadows == ShadowTechnique::Dsm && !scene.lights.empty();
    std::vector<DsmViewGpu> views;
    if (use_dsm) views = shadows::make_dsm_views(scene, packed, options.dsm_resolution);
    CameraGpu camera = packing::pack_camera(scene, width, height);
    camera.termination_transmittance = options.termination_transmittance;
    camera.jitter_seed = options.jitter_seed;
    stats.stage_ms["host_prepare"] = std::chrono::duration<double, std::milli>(clock::now() - t0).count();

    int lanes = options.lanes > 0 ? options.lanes : (runtime.info().is_gpu ? 1 : 8);
    if (lanes != 1 && lanes != 4 && lanes != 8 && lanes != 16) throw Error("--lanes: must be 1, 4, 8 or 16");
    bool use_images = options.storage == VolumeStorage::Image ||
                      (options.storage == VolumeStorage::Auto && runtime.info().is_gpu);
    packing::DeviceScene device_scene = packing::upload_scene(runtime, scene, packed, use_images);
    stats.stage_ms["upload"] = device_scene.upload_ms;

    shadows::DeviceDsm dsm;
    if (use_dsm) {
        dsm = shadows::build_deep_shadow_maps(runtime, scene, packed, device_scene, views,
                                              {options.dsm_resolution, options.dsm_epsilon});
        stats.stage_ms["dsm_count"] = dsm.stats.count_ms;
        stats.stage_ms["dsm_prefix_sum"] = dsm.stats.prefix_sum_ms;
        stats.stage_ms["dsm_write"] = dsm.stats.write_ms;
        stats.dsm_views = dsm.stats.views;
        stats.dsm_nodes = dsm.stats.nodes;
        stats.dsm_mean_nodes_per_texel = dsm.stats.mean_nodes_per_texel;
        stats.dsm_max_nodes_per_texel = dsm.stats.max_nodes_per_texel;
        stats.dsm_bytes_used = dsm.stats.bytes_used;
        stats.dsm_bytes_wasted = dsm.stats.bytes_wasted;
    }

    std::size_t pixels = std::size_t(width) * std::size_t(height);
    cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
    cl::Buffer image_buffer = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_float4), nullptr, "image");
    cl::Buffer count_buffer = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_uint), nullptr, "sample counts");

    auto build_start = clock::now();
    cl::Program& program = runtime.program("render.cl", camera_pass_defines(scene, options, use_images, lanes));
    stats.stage_ms["program_build"] = std::chrono::duration<double, std::milli>(clock::now() - build_start).count();
    cl::Kernel kernel(program, "render_camera");
    int arg = 0;
    if (use_images) kernel.setArg(arg++, device_scene.voxel_image);
    else kernel.setArg(arg++, device_scene.voxel_buffer);
    kernel.setArg(arg++, device_scene.occupancy);
    kernel.setArg(arg++, device_scene.tf_tables);
    kernel.setArg(arg++, device_scene.volumes);
    kernel.setArg(arg++, device_scene.lights);
    kernel.setArg(arg++, camera_buffer);
    kernel.setArg(arg++, image_buffer);
    kernel.setArg(arg++, count_buffer);
    if (use_dsm) {
        kernel.setArg(arg++, dsm.views_buffer);
        kernel.setArg(arg++, dsm.texel_first_buffer);
        kernel.setArg(arg++, dsm.nodes_buffer);
    }

    cl::Event event;
    // Packets run on CPUs: PoCL keeps every work-item's private state of a work-group on one
    // stack, and its default group size overflows it for 8- and 16-lane packets; 4×4 groups
    // measured fastest here (the kernel ignores the padding of the grid).
    std::size_t columns = std::size_t((width + lanes - 1) / lanes), rows = std::size_t(height);
    cl::NDRange local = cl::NullRange;
    if (lanes > 1) {
        const std::size_t group = 4;
        columns = (columns + group - 1) / group * group;
        rows = (rows + group - 1) / group * group;
        local = cl::NDRange(group, group);
    }
    runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(columns, rows), local, nullptr, &event);
    event.wait();
    double kernel_ms = host::Runtime::event_ms(event);
    stats.stage_ms["camera_pass"] = kernel_ms;

    result.image.width = width, result.image.height = height;
    result.image.rgba.resize(pixels * 4);
    std::vector<cl_uint> counts(pixels);
    runtime.queue().enqueueReadBuffer(image_buffer, CL_TRUE, 0, pixels * sizeof(cl_float4), result.image.rgba.data(), nullptr, &event);
    double readback_ms = host::Runtime::event_ms(event);
    runtime.queue().enqueueReadBuffer(count_buffer, CL_TRUE, 0, pixels * sizeof(cl_uint), counts.data(), nullptr, &event);
    stats.stage_ms["readback"] = readback_ms + host::Runtime::event_ms(event);
    for (cl_uint c : counts) stats.samples += c;
    stats.msamples_per_s = kernel_ms > 0 ? double(stats.samples) / (kernel_ms * 1e3) : 0.0;
    return result;
}

}  // namespace sombra
