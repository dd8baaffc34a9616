#include "shadows/dsm_builder.h"

#include <cmath>

#include "sombra/error.h"

namespace sombra::shadows {

std::vector<std::string> volume_pass_defines(const Scene& scene, bool use_images, bool skip_empty) {
    std::vector<std::string> defines{"SOMBRA_VOLUME_SLOTS=" + std::to_string(scene.volumes.size())};
    if (use_images) defines.push_back("SOMBRA_USE_IMAGES");
    if (skip_empty) defines.push_back("SOMBRA_SKIP_EMPTY");
    return defines;
}

DeviceDsm build_deep_shadow_maps(host::Runtime& runtime, const Scene& scene, const packing::DeviceScene& device_scene,
                                 std::vector<DsmViewGpu> views, const DsmBuildOptions& options) {
    if (!(options.epsilon >= 0.f) || !std::isfinite(options.epsilon)) throw Error("--eps: must be ≥ 0");
    DeviceDsm dsm;
    dsm.storage = memory::make_dsm_storage(options.storage);
    dsm.stats.views = int(views.size());
    dsm.stats.resolution = options.resolution;
    dsm.views_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, views.size() * sizeof(DsmViewGpu), views.data(),
                                         "deep shadow map views");

    auto defines = volume_pass_defines(scene, device_scene.uses_images, true);
    defines.push_back("SOMBRA_LANES=1");
    for (auto& d : dsm.storage->defines()) defines.push_back(d);
    memory::BuildContext context{runtime, views, defines, std::size_t(options.resolution) * std::size_t(options.resolution), {}};
    context.run_view = [&](const std::vector<std::string>& program_defines, const char* kernel_name, cl_uint view,
                           const std::function<void(cl::Kernel&, int)>& bind) {
        cl::Kernel kernel(runtime.program("dsm_build.cl", program_defines), kernel_name);
        int a = 0;
        if (device_scene.uses_images) kernel.setArg(a++, device_scene.voxel_image);
        else kernel.setArg(a++, device_scene.voxel_buffer);
        kernel.setArg(a++, device_scene.occupancy);
        kernel.setArg(a++, device_scene.tf_tables);
        kernel.setArg(a++, device_scene.volumes);
        kernel.setArg(a++, cl_uint(scene.volumes.size()));
        kernel.setArg(a++, dsm.views_buffer);
        kernel.setArg(a++, view);
        kernel.setArg(a++, options.epsilon);
        bind(kernel, a);
        cl::Event event;
        runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                             cl::NDRange(std::size_t(options.resolution), std::size_t(options.resolution)),
                                             cl::NullRange, nullptr, &event);
        event.wait();
        return host::Runtime::event_ms(event);
    };
    dsm.storage->build(context, dsm.stats);
    // the backend set max_nodes per view (bounds the lookups' bisection)
    runtime.queue().enqueueWriteBuffer(dsm.views_buffer, CL_TRUE, 0, views.size() * sizeof(DsmViewGpu), views.data());
    dsm.views = views;
    return dsm;
}

}  // namespace sombra::shadows
