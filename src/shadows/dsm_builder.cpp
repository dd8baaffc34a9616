#include "shadows/dsm_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "geometry/surfaces.h"
#include "shadows/precompression.h"
#include "shared/dsm_value.h"

#include "sombra/error.h"

namespace sombra::shadows {

std::vector<std::string> volume_pass_defines(const Scene& scene, bool use_images, bool skip_empty) {
    // at least one slot: a scene of meshes alone has no volume, and OpenCL C has no empty arrays
    std::vector<std::string> defines{"SOMBRA_VOLUME_SLOTS=" + std::to_string(std::max<std::size_t>(scene.volumes.size(), 1))};
    if (use_images) defines.push_back("SOMBRA_USE_IMAGES");
    if (skip_empty) defines.push_back("SOMBRA_SKIP_EMPTY");
    for (const VolumeInstance& vi : scene.volumes)
        if (vi.clipped()) {  // traversal.h make_volume_ray: the world box as well
            defines.push_back("SOMBRA_VOLUME_CLIP");
            break;
        }
    return defines;
}

DeepShadowMap read_back_map(host::Runtime& runtime, const DeviceDsm& dsm, cl_uint view) {
    DeepShadowMap map = dsm.storage->read_back(runtime, dsm.views[view], view);
    if (dsm.optical_depth) {  // cl/shared/dsm_value.h
        for (DsmNode& node : map.nodes) node.opacity = dsm_opacity_of_optical_depth(node.opacity);
        map.interpolation = DeepShadowMap::Interpolation::OpticalDepth;
    }
    return map;
}

void add_dsm_value_define(const DsmOptions& options, std::vector<std::string>& defines) {
    if (options.error == "relative") defines.push_back("SOMBRA_DSM_OPTICAL_DEPTH");
}

namespace {

// A DSM set about to be generated: its backend and its views on the device.
DeviceDsm start_dsm(host::Runtime& runtime, const std::vector<DsmViewGpu>& views, const DsmOptions& options) {
    DeviceDsm dsm;
    dsm.storage = memory::make_dsm_storage(options.storage, options.lookup);
    dsm.optical_depth = options.error == "relative";
    dsm.stats.views = int(views.size());
    dsm.stats.resolution = options.resolution;
    dsm.views_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, views.size() * sizeof(DsmViewGpu), views.data(),
                                         "deep shadow map views");
    return dsm;
}

// The work of generating the `regenerate` views (empty: all) of `dsm`, for its progress stage:
// a launch per generation pass of each.
double generation_launches(const DeviceDsm& dsm, const std::vector<bool>& regenerate) {
    std::size_t views = regenerate.empty() ? std::size_t(dsm.stats.views) : std::size_t(std::count(regenerate.begin(), regenerate.end(), true));
    return double(views) * dsm.storage->generation_passes();
}

// Generates into the backend; the backend sets max_nodes per view (statistics), so the views go to
// the device again.
void finish_dsm(host::Runtime& runtime, DeviceDsm& dsm, memory::BuildContext& context) {
    dsm.stats.stage_ms.clear();
    dsm.stats.views_generated = 0;
    for (std::size_t v = 0; v < context.views.size(); ++v) dsm.stats.views_generated += context.generates(v) ? 1 : 0;
    dsm.storage->build(context, dsm.stats);
    runtime.queue().enqueueWriteBuffer(dsm.views_buffer, CL_TRUE, 0, context.views.size() * sizeof(DsmViewGpu),
                                       context.views.data());
    dsm.views = context.views;
}

// The pre-compressed visibility tables of every volume, on the device (one table per transfer
// function and step; 256 densities per axis).
struct DevicePrecompression {
    cl::Buffer params, fraction, opacity, count;
};

DevicePrecompression upload_precompression(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                           float epsilon, float step_scale, memory::DsmStats& stats) {
    auto start = std::chrono::steady_clock::now();
    std::vector<PrecompressionGpu> params;
    std::vector<float> fraction, opacity;
    std::vector<cl_uchar> count;
    double max_error = 0;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeInstance& vi = scene.volumes[i];
        float voxel_size = packed.volumes[i].step / vi.step_voxels;
        float step = packed.volumes[i].step * step_scale;  // the generation rays' step (dsm_build.cl)
        float unit = vi.opacity_unit > 0.f ? vi.opacity_unit : voxel_size;
        // the table's own error adds to the DSM's: give it half of ε (at least 10⁻³)
        PrecompressionTable table = build_precompression_table(vi.transfer_function, unit, step, 256,
                                                               std::max(0.5f * epsilon, 1e-3f));
        max_error = std::max(max_error, table.max_error);
        params.push_back({cl_uint(count.size()), cl_uint(table.size), table.domain_min, table.domain_scale});
        fraction.insert(fraction.end(), table.fraction.begin(), table.fraction.end());
        opacity.insert(opacity.end(), table.opacity.begin(), table.opacity.end());
        count.insert(count.end(), table.counts.begin(), table.counts.end());
    }
    stats.stage_ms["dsm_precompression_table"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    stats.precompression_max_error = max_error;
    auto ro = CL_MEM_READ_ONLY;
    return {host::make_buffer(runtime, ro, params.size() * sizeof(PrecompressionGpu), params.data(), "pre-compression tables"),
            host::make_buffer(runtime, ro, fraction.size() * sizeof(float), fraction.data(), "pre-compression tables"),
            host::make_buffer(runtime, ro, opacity.size() * sizeof(float), opacity.data(), "pre-compression tables"),
            host::make_buffer(runtime, ro, count.size(), count.data(), "pre-compression tables")};
}

void generate(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
              const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views, const DsmOptions& options, int lanes,
              DeviceDsm& dsm, const std::vector<bool>& regenerate, const ViewMeshes& meshes);

// The sub-pixel maps of the `regenerate` views (empty: all); the others' stay empty.
SubPixelDsm generate_sub_pixel_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                    const packing::DeviceScene& device_scene, const std::vector<DsmViewGpu>& views,
                                    const DsmOptions& options, int lanes, const std::vector<bool>& regenerate, const ViewMeshes& meshes) {
    SubPixelDsm sub{sub_pixel_views(views, options.prefilter, options.prefilter_jitter, options.prefilter_seed), {}};
    DsmOptions sub_options = options;
    sub_options.resolution = sub.layout.resolution;
    sub_options.epsilon = 0.5f * options.epsilon;
    sub_options.storage = "compact";
    sub_options.prefilter = "none";
    std::vector<bool> sub_regenerate;
    for (bool r : regenerate) sub_regenerate.insert(sub_regenerate.end(), std::size_t(sub.layout.maps), r);
    ViewMeshes sub_meshes;  // each sub-pixel map holds what its view holds
    for (const auto& m : meshes) sub_meshes.insert(sub_meshes.end(), std::size_t(sub.layout.maps), m);
    sub.dsm = start_dsm(runtime, sub.layout.views, sub_options);
    runtime.progress().extend(generation_launches(sub.dsm, sub_regenerate));
    generate(runtime, scene, packed, device_scene, sub.layout.views, sub_options, lanes, sub.dsm, sub_regenerate, sub_meshes);
    return sub;
}

// Pre-filtering (Lokovic–Veach; Hadwiger §3.1): the sub-pixel maps (ε/2), then dsm_prefilter.cl
// merges each texel's taps under the filter kernel and compresses the sum (ε/2) into the chosen
// backend.
void generate_prefiltered(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                          const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views, const DsmOptions& options, int lanes,
                          DeviceDsm& dsm, const std::vector<bool>& regenerate, const ViewMeshes& meshes) {
    SubPixelDsm sub = generate_sub_pixel_maps(runtime, scene, packed, device_scene, views, options, lanes, regenerate, meshes);
    std::vector<std::string> defines{"SOMBRA_LANES=1"};
    if (options.prefilter == "tent") defines.push_back("SOMBRA_PREFILTER_TENT");
    if (options.prefilter == "5tap") defines.push_back("SOMBRA_PREFILTER_5TAP");
    for (auto& d : dsm.storage->defines()) defines.push_back(d);
    add_dsm_value_define(options, defines);
    memory::BuildContext context{runtime, views, defines, std::size_t(options.resolution) * std::size_t(options.resolution),
                                 "dsm_prefilter.cl", regenerate, {}};
    float merge_epsilon = 0.5f * options.epsilon;
    context.run_view = [&](const std::vector<std::string>& program_defines, const char* kernel_name, cl_uint view,
                           const std::function<void(host::KernelArgs&)>& bind) {
        cl::Kernel kernel(runtime.program("dsm_prefilter.cl", program_defines), kernel_name);
        host::KernelArgs args(kernel);
        args("views", dsm.views_buffer)("view_index", view)("epsilon", merge_epsilon)("sub_views", sub.dsm.views_buffer);
        args("sub_maps", cl_uint(sub.layout.maps))("sub_scale", cl_uint(sub.layout.scale));
        sub.dsm.storage->bind_for_reading(args.prefix("fine_"));  // compact: offsets, nodes
        bind(args.prefix(""));
        args.done();
        return host::run_packets(runtime, kernel, options.resolution, options.resolution, 1);
    };
    finish_dsm(runtime, dsm, context);
    for (auto& [stage, ms] : sub.dsm.stats.stage_ms) dsm.stats.stage_ms["dsm_fine_" + stage.substr(4)] = ms;
}

// Generates the `regenerate` views (empty: all) of `dsm` into its storage.
void generate(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
              const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views, const DsmOptions& options, int lanes,
              DeviceDsm& dsm, const std::vector<bool>& regenerate, const ViewMeshes& meshes) {
    if (options.prefilter != "none")
        return generate_prefiltered(runtime, scene, packed, device_scene, views, options, lanes, dsm, regenerate, meshes);

    auto defines = volume_pass_defines(scene, device_scene.uses_images, true);
    const int packet = host::generation_lanes(runtime, lanes);  // texels of a row per work-item
    defines.push_back("SOMBRA_LANES=" + std::to_string(packet));
    for (auto& d : dsm.storage->defines()) defines.push_back(d);
    add_dsm_value_define(options, defines);
    DevicePrecompression precompression;
    if (options.precompression) {
        precompression = upload_precompression(runtime, scene, packed, options.epsilon, options.step, dsm.stats);
        defines.push_back("SOMBRA_DSM_PRECOMPRESSED");
    }
    surfaces::DeviceSurfaces surface_data;  // meshes: their fragments in each view become steps (Knecht §3.2)
    const bool fragment_lists = surfaces::has_fragments(scene);  // surfaces and polyhedral volume bounds
    if (fragment_lists) {
        surface_data = surfaces::upload_surfaces(runtime, surfaces::pack_surfaces(scene));
        defines.push_back("SOMBRA_HAS_MESHES");
    }
    memory::BuildContext context{runtime, views, defines, std::size_t(options.resolution) * std::size_t(options.resolution),
                                 "dsm_build.cl", regenerate, {}};
    context.run_view = [&](const std::vector<std::string>& program_defines, const char* kernel_name, cl_uint view,
                           const std::function<void(host::KernelArgs&)>& bind) {
        cl::Kernel kernel(runtime.program("dsm_build.cl", program_defines), kernel_name);
        surfaces::ViewFragments fragments;
        host::KernelArgs args(kernel);
        if (device_scene.uses_images) args("volume_data", device_scene.voxel_image);
        else args("volume_data", device_scene.voxel_buffer);
        args("occupancy", device_scene.occupancy)("tf_tables", device_scene.tf_tables)("volumes", device_scene.volumes);
        args("volume_count", cl_uint(scene.volumes.size()))("views", dsm.views_buffer)("view_index", view)("epsilon", options.epsilon);
        args("step_scale", options.step);
        if (options.precompression) {
            args("precompression", precompression.params)("precompressed_fraction", precompression.fraction);
            args("precompressed_opacity", precompression.opacity)("precompressed_count", precompression.count);
        }
        if (fragment_lists) {
            raster::View raster_view = raster::dsm_view(views[view]);
            // the view's near_depth is a ray distance fitted to the nearest corner, but the raster
            // stage clips at view z (≤ ray distance): clip far closer, so that no fitted geometry is lost
            if (raster_view.perspective) raster_view.near_depth = std::max(1e-6, 1e-4 * double(views[view].far_depth));
            fragments = surfaces::view_fragments(runtime, scene, raster_view, view < meshes.size() ? meshes[view] : std::vector<bool>{},
                                                 views[view].volume_mask);
            args("fragment_first", fragments.fragments.first)("fragments", fragments.fragments.fragments);
            args("screen_triangles", fragments.tiles.triangles)("surface_materials", surface_data.materials);
        }
        bind(args);
        args.done();
        return host::run_packets(runtime, kernel, options.resolution, options.resolution, packet);
    };
    finish_dsm(runtime, dsm, context);
}

}  // namespace

SubPixelDsm build_sub_pixel_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                 const packing::DeviceScene& device_scene, const std::vector<DsmViewGpu>& views,
                                 const DsmOptions& options, int lanes, const ViewMeshes& meshes) {
    return generate_sub_pixel_maps(runtime, scene, packed, device_scene, views, options, lanes, {}, meshes);
}

DeviceDsm build_deep_shadow_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                 const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views,
                                 const DsmOptions& options, int lanes, const ViewMeshes& meshes, const std::vector<bool>& generate_views) {
    DeviceDsm dsm = start_dsm(runtime, views, options);
    host::ProgressStage stage(runtime.progress(), "deep shadow maps", generation_launches(dsm, generate_views));
    generate(runtime, scene, packed, device_scene, views, options, lanes, dsm, generate_views, meshes);
    return dsm;
}

void regenerate_deep_shadow_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                 const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views,
                                 const DsmOptions& options, int lanes, DeviceDsm& dsm, const std::vector<bool>& regenerate,
                                 const ViewMeshes& meshes) {
    if (views.size() != dsm.views.size() || regenerate.size() != views.size())
        throw Error("deep shadow maps: the views of a regeneration must match the maps built (internal error)");
    runtime.queue().enqueueWriteBuffer(dsm.views_buffer, CL_TRUE, 0, views.size() * sizeof(DsmViewGpu), views.data());
    host::ProgressStage stage(runtime.progress(), "deep shadow maps", generation_launches(dsm, regenerate));
    generate(runtime, scene, packed, device_scene, views, options, lanes, dsm, regenerate, meshes);
}

}  // namespace sombra::shadows
