// sombra — compact storage: count, prefix sum, write (cl/storage_compact.h).
#include <chrono>

#include "memory/dsm_storage.h"
#include "sombra/error.h"

namespace sombra::memory {
namespace {

class CompactStorage : public DsmStorage {
public:
    std::string name() const override { return "compact"; }
    std::vector<std::string> defines() const override { return {}; }
    int generation_passes() const override { return 2; }

    void build(BuildContext& context, DsmStats& stats) override {
        host::Runtime& rt = context.runtime;
        std::size_t texels = context.views.size() * context.texels_per_view;
        bool update = counts_.size() == texels && !context.regenerate.empty();
        std::vector<cl_uint> host_counts = count_nodes(context, stats, update ? counts_ : std::vector<cl_uint>{});

        auto start = std::chrono::steady_clock::now();
        std::vector<cl_uint> texel_first = run_offsets(host_counts);
        stats.stage_ms["dsm_prefix_sum"] =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        summarize_counts(host_counts, context.views, context.texels_per_view, stats);

        // one spare node: lookups of empty texels at the end read in bounds
        std::size_t node_count = std::size_t(texel_first.back()) + 1;
        cl::Buffer nodes = host::make_buffer(rt, CL_MEM_READ_WRITE, node_count * 2 * sizeof(float), nullptr, "deep shadow map nodes");
        const std::vector<cl_uint>& before = packed_.texel_first;
        for (std::size_t v = 0; update && v < context.views.size(); ++v) {
            // a kept view's nodes are one run: move it to its new place
            std::size_t first = v * context.texels_per_view, last = first + context.texels_per_view;
            std::size_t run = std::size_t(before[last] - before[first]) * 2 * sizeof(float);
            if (context.generates(v) || run == 0) continue;
            rt.queue().enqueueCopyBuffer(packed_.nodes, nodes, std::size_t(before[first]) * 2 * sizeof(float),
                                         std::size_t(texel_first[first]) * 2 * sizeof(float), run);
        }
        packed_.texel_first = std::move(texel_first);
        counts_ = std::move(host_counts);
        packed_.nodes = nodes;
        packed_.texel_first_buffer = host::make_buffer(rt, CL_MEM_READ_ONLY, packed_.texel_first.size() * sizeof(cl_uint),
                                                       packed_.texel_first.data(), "deep shadow map offsets");
        for (cl_uint v = 0; v < context.views.size(); ++v) {
            if (!context.generates(v)) continue;
            stats.stage_ms["dsm_build"] += context.run_view(context.defines, "dsm_build", v, [&](host::KernelArgs& args) { packed_.bind(args); });
        }
        stats.bytes_used = packed_.bytes();
        stats.bytes_wasted = 2 * sizeof(float);  // the spare node
    }

protected:
    // the storage is packed: both lookups read its runs
    void bind_native(host::KernelArgs& args) const override { packed_.bind(args); }
    DeepShadowMap read_back_native(host::Runtime& rt, const DsmViewGpu& view, cl_uint) const override {
        return packed_.read_back(rt, view);
    }

private:
    std::vector<cl_uint> counts_;
};

// Nodes uploaded from the host (make_received_storage): lookups only.
class ReceivedStorage : public DsmStorage {
public:
    ReceivedStorage(host::Runtime& rt, const HostPackedNodes& host) {
        packed_.texel_first = host.texel_first;
        packed_.texel_first_buffer = host::make_buffer(rt, CL_MEM_READ_ONLY, host.texel_first.size() * sizeof(cl_uint),
                                                       host.texel_first.data(), "received deep shadow map offsets");
        std::vector<float> nodes = host.nodes;
        nodes.resize(nodes.size() + 2, 0.f);  // the spare node (PackedNodes)
        packed_.nodes = host::make_buffer(rt, CL_MEM_READ_ONLY, nodes.size() * sizeof(float), nodes.data(), "received deep shadow map nodes");
    }
    std::string name() const override { return "received"; }
    std::vector<std::string> defines() const override { return {}; }
    void build(BuildContext&, DsmStats&) override { throw Error("internal: received deep shadow maps cannot be generated"); }

protected:
    void bind_native(host::KernelArgs& args) const override { packed_.bind(args); }
    DeepShadowMap read_back_native(host::Runtime& rt, const DsmViewGpu& view, cl_uint) const override {
        return packed_.read_back(rt, view);
    }
};

}  // namespace

std::unique_ptr<DsmStorage> make_compact_storage() { return std::make_unique<CompactStorage>(); }

std::unique_ptr<DsmStorage> make_received_storage(host::Runtime& runtime, const HostPackedNodes& nodes) {
    return std::make_unique<ReceivedStorage>(runtime, nodes);
}

HostPackedNodes DsmStorage::read_packed(host::Runtime& rt) const {
    if (packed_.texel_first.empty())
        throw Error("--dsm-lookup native: a distributed render sends the packed maps; use --dsm-lookup packed");
    HostPackedNodes host{packed_.texel_first, std::vector<float>(packed_.node_count() * 2)};
    if (!host.nodes.empty())
        rt.queue().enqueueReadBuffer(packed_.nodes, CL_TRUE, 0, host.nodes.size() * sizeof(float), host.nodes.data());
    return host;
}

}  // namespace sombra::memory
