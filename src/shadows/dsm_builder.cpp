#include "shadows/dsm_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "sombra/error.h"

namespace sombra::shadows {

std::vector<std::string> volume_pass_defines(const Scene& scene, bool use_images, bool skip_empty) {
    std::vector<std::string> defines{"SOMBRA_VOLUME_SLOTS=" + std::to_string(scene.volumes.size())};
    if (use_images) defines.push_back("SOMBRA_USE_IMAGES");
    if (skip_empty) defines.push_back("SOMBRA_SKIP_EMPTY");
    return defines;
}

DeviceDsm build_deep_shadow_maps(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                                 const packing::DeviceScene& device_scene, std::vector<DsmViewGpu> views,
                                 const DsmBuildOptions& options) {
    if (!(options.epsilon >= 0.f) || !std::isfinite(options.epsilon)) throw Error("--eps: must be ≥ 0");
    DeviceDsm dsm;
    DsmStats& stats = dsm.stats;
    stats.views = int(views.size());
    stats.resolution = options.resolution;
    std::size_t texels_per_view = std::size_t(options.resolution) * std::size_t(options.resolution);
    std::size_t texels = views.size() * texels_per_view;
    auto defines = volume_pass_defines(scene, device_scene.uses_images, true);
    defines.push_back("SOMBRA_LANES=1");
    cl::Program& program = runtime.program("dsm_build.cl", defines);
    cl::Kernel count(program, "dsm_count"), write(program, "dsm_write");

    auto ro = CL_MEM_READ_ONLY;
    dsm.views_buffer = host::make_buffer(runtime, ro, views.size() * sizeof(DsmViewGpu), views.data(), "deep shadow map views");
    cl::Buffer counts = host::make_buffer(runtime, CL_MEM_READ_WRITE, texels * sizeof(cl_uint), nullptr, "deep shadow map node counts");
    auto set_common = [&](cl::Kernel& k, cl_uint view) {
        int a = 0;
        if (device_scene.uses_images) k.setArg(a++, device_scene.voxel_image);
        else k.setArg(a++, device_scene.voxel_buffer);
        k.setArg(a++, device_scene.occupancy);
        k.setArg(a++, device_scene.tf_tables);
        k.setArg(a++, device_scene.volumes);
        k.setArg(a++, cl_uint(scene.volumes.size()));
        k.setArg(a++, dsm.views_buffer);
        k.setArg(a++, view);
        k.setArg(a++, options.epsilon);
        return a;
    };
    cl::NDRange grid(std::size_t(options.resolution), std::size_t(options.resolution));
    cl::Event event;

    // pass 1: count
    for (std::size_t v = 0; v < views.size(); ++v) {
        int a = set_common(count, cl_uint(v));
        count.setArg(a, counts);
        runtime.queue().enqueueNDRangeKernel(count, cl::NullRange, grid, cl::NullRange, nullptr, &event);
        event.wait();
        stats.count_ms += host::Runtime::event_ms(event);
    }
    std::vector<cl_uint> host_counts(texels);
    runtime.queue().enqueueReadBuffer(counts, CL_TRUE, 0, texels * sizeof(cl_uint), host_counts.data());

    // prefix sum → offsets; each view's largest texel bounds its lookups' bisection
    auto scan_start = std::chrono::steady_clock::now();
    dsm.texel_first.assign(texels + 1, 0);
    for (std::size_t i = 0; i < texels; ++i) {
        unsigned long long next = (unsigned long long)dsm.texel_first[i] + host_counts[i];
        if (next > 0xffffffffull) throw Error("--dsm-res/--eps: more than 2^32 deep shadow map nodes");
        dsm.texel_first[i + 1] = cl_uint(next);
    }
    for (std::size_t v = 0; v < views.size(); ++v) {
        auto begin = host_counts.begin() + std::ptrdiff_t(v * texels_per_view);
        views[v].max_nodes = *std::max_element(begin, begin + std::ptrdiff_t(texels_per_view));
        stats.max_nodes_per_texel = std::max(stats.max_nodes_per_texel, unsigned(views[v].max_nodes));
    }
    stats.prefix_sum_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - scan_start).count();
    stats.nodes = dsm.texel_first.back();
    stats.mean_nodes_per_texel = texels ? double(stats.nodes) / double(texels) : 0.0;
    runtime.queue().enqueueWriteBuffer(dsm.views_buffer, CL_TRUE, 0, views.size() * sizeof(DsmViewGpu), views.data());
    dsm.views = views;

    // pass 2: write; one spare node so that lookups of empty trailing texels read in bounds
    std::size_t node_bytes = (stats.nodes + 1) * 2 * sizeof(float);
    dsm.texel_first_buffer = host::make_buffer(runtime, ro, dsm.texel_first.size() * sizeof(cl_uint), dsm.texel_first.data(),
                                               "deep shadow map offsets");
    dsm.nodes_buffer = host::make_buffer(runtime, CL_MEM_READ_WRITE, node_bytes, nullptr, "deep shadow map nodes");
    for (std::size_t v = 0; v < views.size(); ++v) {
        int a = set_common(write, cl_uint(v));
        write.setArg(a++, dsm.texel_first_buffer);
        write.setArg(a, dsm.nodes_buffer);
        runtime.queue().enqueueNDRangeKernel(write, cl::NullRange, grid, cl::NullRange, nullptr, &event);
        event.wait();
        stats.write_ms += host::Runtime::event_ms(event);
    }
    stats.bytes_used = stats.nodes * 2 * sizeof(float) + dsm.texel_first.size() * sizeof(cl_uint);
    stats.bytes_wasted = 2 * sizeof(float);  // the spare node
    return dsm;
}

DeepShadowMap read_back(host::Runtime& runtime, const DeviceDsm& dsm, int view, const std::string& name) {
    if (view < 0 || view >= int(dsm.views.size())) throw Error("--light: no such deep shadow map view");
    const DsmViewGpu& v = dsm.views[std::size_t(view)];
    std::size_t texels = std::size_t(v.resolution) * v.resolution, first = v.first_texel;
    DeepShadowMap map;
    map.width = map.height = int(v.resolution);
    map.light_name = name;
    cl_uint base = dsm.texel_first[first], end = dsm.texel_first[first + texels];
    map.first.resize(texels + 1);
    for (std::size_t i = 0; i <= texels; ++i) map.first[i] = dsm.texel_first[first + i] - base;
    std::vector<float> raw(std::size_t(end - base) * 2);
    if (!raw.empty())
        runtime.queue().enqueueReadBuffer(dsm.nodes_buffer, CL_TRUE, std::size_t(base) * 2 * sizeof(float),
                                          raw.size() * sizeof(float), raw.data());
    map.nodes.resize(raw.size() / 2);
    for (std::size_t i = 0; i < map.nodes.size(); ++i) map.nodes[i] = {raw[2 * i], raw[2 * i + 1]};
    return map;
}

}  // namespace sombra::shadows
