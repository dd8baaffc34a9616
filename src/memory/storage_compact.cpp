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
        std::vector<cl_uint> texel_first(texels + 1, 0);
        for (std::size_t i = 0; i < texels; ++i) {
            unsigned long long next = (unsigned long long)texel_first[i] + host_counts[i];
            if (next > 0x7fffffffull) throw Error("--dsm-res/--eps: more than 2^31 deep shadow map nodes");
            texel_first[i + 1] = cl_uint(next);
        }
        stats.stage_ms["dsm_prefix_sum"] =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        summarize_counts(host_counts, context.views, context.texels_per_view, stats);

        // one spare node: lookups of empty texels at the end read in bounds
        std::size_t node_count = std::size_t(texel_first.back()) + 1;
        cl::Buffer nodes = host::make_buffer(rt, CL_MEM_READ_WRITE, node_count * 2 * sizeof(float), nullptr, "deep shadow map nodes");
        for (std::size_t v = 0; update && v < context.views.size(); ++v) {
            // a kept view's nodes are one run: move it to its new place
            std::size_t first = v * context.texels_per_view, last = first + context.texels_per_view;
            std::size_t run = std::size_t(texel_first_[last] - texel_first_[first]) * 2 * sizeof(float);
            if (context.generates(v) || run == 0) continue;
            rt.queue().enqueueCopyBuffer(nodes_, nodes, std::size_t(texel_first_[first]) * 2 * sizeof(float),
                                         std::size_t(texel_first[first]) * 2 * sizeof(float), run);
        }
        texel_first_ = std::move(texel_first);
        counts_ = std::move(host_counts);
        nodes_ = nodes;
        texel_first_buffer_ = host::make_buffer(rt, CL_MEM_READ_ONLY, texel_first_.size() * sizeof(cl_uint), texel_first_.data(),
                                                "deep shadow map offsets");
        for (cl_uint v = 0; v < context.views.size(); ++v) {
            if (!context.generates(v)) continue;
            stats.stage_ms["dsm_build"] += context.run_view(context.defines, "dsm_build", v, [&](host::KernelArgs& args) { args("texel_first", texel_first_buffer_)("nodes", nodes_); });
        }
        stats.bytes_used = stats.nodes * 2 * sizeof(float) + texel_first_.size() * sizeof(cl_uint);
        stats.bytes_wasted = 2 * sizeof(float);  // the spare node
    }

    void bind_for_reading(host::KernelArgs& args) const override { args("texel_first", texel_first_buffer_)("nodes", nodes_); }

    DeepShadowMap read_back(host::Runtime& rt, const DsmViewGpu& view, cl_uint) const override {
        std::size_t texels = std::size_t(view.resolution) * view.resolution, first = view.first_texel;
        DeepShadowMap map;
        map.width = map.height = int(view.resolution);
        cl_uint base = texel_first_[first], end = texel_first_[first + texels];
        map.first.resize(texels + 1);
        for (std::size_t i = 0; i <= texels; ++i) map.first[i] = texel_first_[first + i] - base;
        std::vector<float> raw(std::size_t(end - base) * 2);
        if (!raw.empty())
            rt.queue().enqueueReadBuffer(nodes_, CL_TRUE, std::size_t(base) * 2 * sizeof(float), raw.size() * sizeof(float), raw.data());
        for (std::size_t i = 0; i < raw.size(); i += 2) map.nodes.push_back({raw[i], raw[i + 1]});
        return map;
    }

private:
    std::vector<cl_uint> texel_first_, counts_;
    cl::Buffer texel_first_buffer_, nodes_;
};

}  // namespace

std::unique_ptr<DsmStorage> make_compact_storage() { return std::make_unique<CompactStorage>(); }

}  // namespace sombra::memory
