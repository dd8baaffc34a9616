#include "memory/dsm_storage.h"

#include <algorithm>
#include <chrono>

#include "sombra/error.h"

namespace sombra::memory {

std::unique_ptr<DsmStorage> make_compact_storage();
std::unique_ptr<DsmStorage> make_atlas_storage();
std::unique_ptr<DsmStorage> make_chunked_storage(bool counted);

namespace {

// The backend registry: a name (RenderOptions::dsm_storage, --storage) and its maker.
struct StorageEntry {
    const char* name;
    std::unique_ptr<DsmStorage> (*make)();
};
const StorageEntry kStorages[] = {
    {"atlas", make_atlas_storage},
    {"chunked", [] { return make_chunked_storage(true); }},
    {"chunked-ondemand", [] { return make_chunked_storage(false); }},
    {"compact", make_compact_storage},
};

}  // namespace

std::unique_ptr<DsmStorage> make_dsm_storage(const std::string& name, const std::string& lookup) {
    if (lookup != "packed" && lookup != "native")
        throw Error("--dsm-lookup: unknown deep shadow map lookup '" + lookup + "' (packed, native)");
    for (const StorageEntry& e : kStorages)
        if (name == e.name) {
            std::unique_ptr<DsmStorage> storage = e.make();
            storage->packed_lookups_ = lookup == "packed" && name != "compact";  // compact is packed already
            return storage;
        }
    std::string names;
    for (const StorageEntry& e : kStorages) names += std::string(names.empty() ? "" : ", ") + e.name;
    throw Error("--storage: unknown deep shadow map storage '" + name + "' (" + names + ")");
}

}  // namespace sombra::memory

namespace sombra {

std::vector<std::string> dsm_storage_names() {
    std::vector<std::string> names;
    for (const memory::StorageEntry& e : memory::kStorages) names.push_back(e.name);
    return names;
}

}  // namespace sombra

namespace sombra::memory {

std::vector<cl_uint> count_nodes(BuildContext& context, DsmStats& stats, const std::vector<cl_uint>& kept) {
    host::Runtime& rt = context.runtime;
    std::size_t texels = context.views.size() * context.texels_per_view;
    std::vector<cl_uint> host_counts(texels, 0);
    if (kept.size() == texels) host_counts = kept;
    cl::Buffer counts = host::make_buffer(rt, CL_MEM_READ_WRITE, texels * sizeof(cl_uint), nullptr, "deep shadow map node counts");
    auto count_defines = context.defines;
    count_defines.push_back("SOMBRA_DSM_COUNT_ONLY");
    for (cl_uint v = 0; v < context.views.size(); ++v) {
        if (!context.generates(v)) continue;
        stats.stage_ms["dsm_count"] +=
            context.run_view(count_defines, "dsm_count", v, [&](host::KernelArgs& args) { args("counts", counts); });
        std::size_t first = v * context.texels_per_view;
        rt.queue().enqueueReadBuffer(counts, CL_TRUE, first * sizeof(cl_uint), context.texels_per_view * sizeof(cl_uint),
                                     host_counts.data() + first);
    }
    return host_counts;
}

cl::Buffer grow_buffer(host::Runtime& runtime, const cl::Buffer& old, std::size_t kept_bytes, std::size_t new_bytes,
                       const char* what) {
    cl::Buffer grown = host::make_buffer(runtime, CL_MEM_READ_WRITE, std::max<std::size_t>(new_bytes, 4), nullptr, what);
    kept_bytes = std::min(kept_bytes, new_bytes);
    if (kept_bytes > 0) runtime.queue().enqueueCopyBuffer(old, grown, 0, 0, kept_bytes);
    return grown;
}

void summarize_counts(const std::vector<cl_uint>& counts, std::vector<DsmViewGpu>& views, std::size_t texels_per_view,
                      DsmStats& stats) {
    stats.nodes = 0;
    stats.max_nodes_per_texel = 0;
    for (std::size_t v = 0; v < views.size(); ++v) {
        auto begin = counts.begin() + std::ptrdiff_t(v * texels_per_view);
        views[v].max_nodes = *std::max_element(begin, begin + std::ptrdiff_t(texels_per_view));
        stats.max_nodes_per_texel = std::max(stats.max_nodes_per_texel, unsigned(views[v].max_nodes));
        for (auto it = begin; it != begin + std::ptrdiff_t(texels_per_view); ++it) stats.nodes += *it;
    }
    stats.mean_nodes_per_texel = counts.empty() ? 0.0 : double(stats.nodes) / double(counts.size());
}

std::vector<cl_uint> run_offsets(const std::vector<cl_uint>& counts) {
    std::vector<cl_uint> first(counts.size() + 1, 0);
    for (std::size_t i = 0; i < counts.size(); ++i) {
        unsigned long long next = (unsigned long long)first[i] + counts[i];
        if (next > 0x7fffffffull) throw Error("--dsm-res/--eps: more than 2^31 deep shadow map nodes");
        first[i + 1] = cl_uint(next);
    }
    return first;
}

DeepShadowMap PackedNodes::read_back(host::Runtime& rt, const DsmViewGpu& view) const {
    std::size_t texels = std::size_t(view.resolution) * view.resolution, first = view.first_texel;
    DeepShadowMap map;
    map.width = map.height = int(view.resolution);
    cl_uint base = texel_first[first], end = texel_first[first + texels];
    map.first.resize(texels + 1);
    for (std::size_t i = 0; i <= texels; ++i) map.first[i] = texel_first[first + i] - base;
    std::vector<float> raw(std::size_t(end - base) * 2);
    if (!raw.empty())
        rt.queue().enqueueReadBuffer(nodes, CL_TRUE, std::size_t(base) * 2 * sizeof(float), raw.size() * sizeof(float), raw.data());
    for (std::size_t i = 0; i < raw.size(); i += 2) map.nodes.push_back({raw[i], raw[i + 1]});
    return map;
}

void DsmStorage::pack(BuildContext& context, const std::vector<cl_uint>& counts,
                      const std::function<void(host::KernelArgs&)>& bind_source, DsmStats& stats) {
    host::Runtime& rt = context.runtime;
    auto start = std::chrono::steady_clock::now();
    packed_.texel_first = run_offsets(counts);
    stats.stage_ms["dsm_prefix_sum"] += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    packed_.texel_first_buffer = host::make_buffer(rt, CL_MEM_READ_ONLY, packed_.texel_first.size() * sizeof(cl_uint),
                                                   packed_.texel_first.data(), "deep shadow map offsets");
    packed_.nodes = host::make_buffer(rt, CL_MEM_READ_WRITE, (packed_.node_count() + 1) * 2 * sizeof(float), nullptr,
                                      "packed deep shadow map nodes");
    cl::Kernel kernel(rt.program(context.program, context.defines), "dsm_pack");
    const cl_uint resolution = context.views.front().resolution;
    for (const DsmViewGpu& view : context.views) {
        host::KernelArgs args(kernel);
        bind_source(args);
        args("first_texel", view.first_texel)("resolution", resolution)("texel_first", packed_.texel_first_buffer)("packed", packed_.nodes);
        args.done();
        cl::Event event;
        rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(context.texels_per_view), cl::NullRange, nullptr, &event);
        event.wait();
        stats.stage_ms["dsm_pack"] += host::Runtime::event_ms(event);
    }
    stats.bytes_used += packed_.bytes();
}

}  // namespace sombra::memory
