#include "memory/dsm_storage.h"

#include <algorithm>

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

std::unique_ptr<DsmStorage> make_dsm_storage(const std::string& name) {
    for (const StorageEntry& e : kStorages)
        if (name == e.name) return e.make();
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

}  // namespace sombra::memory
