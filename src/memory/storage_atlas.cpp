// sombra — atlas storage: layer blocks per tile allocated on demand (cl/storage_atlas.h).
#include <algorithm>
#include <array>

#include "memory/dsm_storage.h"
#include "sombra/error.h"

namespace sombra::memory {
namespace {
// the kernel's allocator (cl/storage_atlas.h): blocks handed out, requests not served, capped texels
using AtlasAllocatorCounters = std::array<cl_uint, 3>;

constexpr unsigned kLayers = 8;      // layers per block (Hadwiger: "e.g. eight")
constexpr unsigned kMaxBlocks = 32;  // blocks per tile: a cap of 256 layers per texel
constexpr unsigned kTileTexels = 64;
constexpr std::size_t kBlockBytes = std::size_t(kLayers) * kTileTexels * 2 * sizeof(float);

class AtlasStorage : public DsmStorage {
public:
    std::string name() const override { return "atlas"; }
    std::vector<std::string> defines() const override {
        return {"SOMBRA_DSM_ATLAS", "SOMBRA_ATLAS_LAYERS=" + std::to_string(kLayers),
                "SOMBRA_ATLAS_MAX_BLOCKS=" + std::to_string(kMaxBlocks)};
    }

    void build(BuildContext& context, DsmStats& stats) override {
        host::Runtime& rt = context.runtime;
        const TileGrid grid(context);
        const std::size_t view_tiles = grid.view_tiles, tiles = grid.tiles, texels = grid.texels;
        bool update = tiles_ == tiles && !context.regenerate.empty();
        if (!update) {
            tiles_ = tiles;
            layout_ = host::make_buffer(rt, CL_MEM_READ_WRITE, tiles * kMaxBlocks * sizeof(cl_uint), nullptr, "atlas layout table");
            counts_ = host::make_buffer(rt, CL_MEM_READ_WRITE, texels * sizeof(cl_uint), nullptr, "atlas texel counts");
            allocator_ = host::make_buffer(rt, CL_MEM_READ_WRITE, sizeof(AtlasAllocatorCounters), nullptr, "atlas allocator");
            rt.queue().enqueueFillBuffer(layout_, cl_uint(0), 0, tiles * kMaxBlocks * sizeof(cl_uint));
            rt.queue().enqueueFillBuffer(counts_, cl_uint(0), 0, texels * sizeof(cl_uint));
            pool_blocks_ = 0;
            capped_per_view_.assign(context.views.size(), 0);
            layout_host_.assign(tiles * kMaxBlocks, 0);
        }
        // First guess: the kept blocks plus as many as the regenerated views held before (one per
        // tile when new). A pool that runs out is grown to what was asked for, and the generated
        // views run again (once more: the second pool fits every request).
        const cl_uint blocks_before = pool_blocks_;
        std::size_t guess = 0;
        for (std::size_t v = 0; v < context.views.size(); ++v) {
            if (!context.generates(v)) continue;
            auto begin = layout_host_.begin() + std::ptrdiff_t(v * view_tiles * kMaxBlocks);
            guess += std::max<std::size_t>(view_tiles, std::size_t(std::count_if(begin, begin + std::ptrdiff_t(view_tiles * kMaxBlocks),
                                                                                 [](cl_uint b) { return b != 0; })));
        }
        cl_uint pool = cl_uint(std::max<std::size_t>(blocks_before + guess, 1));
        AtlasAllocatorCounters counters{};
        for (int attempt = 0;; ++attempt) {
            if (std::size_t(pool) * kBlockBytes > rt.device().getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>())
                throw Error("--dsm-res/--eps: the atlas needs " + std::to_string((std::size_t(pool) * kBlockBytes) >> 20) +
                            " MiB, more than one allocation on " + rt.info().name + " may hold");
            blocks_ = grow_buffer(rt, blocks_, std::size_t(blocks_before) * kBlockBytes, std::size_t(pool) * kBlockBytes, "atlas blocks");
            for (std::size_t v = 0; v < context.views.size(); ++v)
                if (context.generates(v))
                    rt.queue().enqueueFillBuffer(layout_, cl_uint(0), v * view_tiles * kMaxBlocks * sizeof(cl_uint),
                                                 view_tiles * kMaxBlocks * sizeof(cl_uint));
            counters = {blocks_before, 0, 0};
            rt.queue().enqueueWriteBuffer(allocator_, CL_TRUE, 0, sizeof(counters), counters.data());
            for (cl_uint v = 0; v < context.views.size(); ++v) {
                if (!context.generates(v)) continue;
                cl_uint capped_before = counters[2];
                stats.stage_ms["dsm_build"] += context.run_view(context.defines, "dsm_build", v, [&](host::KernelArgs& args) {
                    args("atlas_layout", layout_)("texel_count", counts_)("atlas_blocks", blocks_)("atlas_allocator", allocator_);
                    args("atlas_pool_blocks", pool);
                });
                rt.queue().enqueueReadBuffer(allocator_, CL_TRUE, 0, sizeof(counters), counters.data());
                capped_per_view_[v] = counters[2] - capped_before;
            }
            if (counters[1] == 0) break;
            if (attempt > 2) throw Error("atlas storage: the pool ran out four times (internal error)");
            rt.progress().extend(double(context.generated_views()));  // the views run again
            // grow by the entries that found no block (each counted once, and no block is drawn
            // and lost: claim_block): the next run asks for the same blocks
            pool = cl_uint(std::size_t(counters[0]) + counters[1] + 1);
        }
        // Shrink the pool to the blocks handed out (they are numbered from 0): memory follows the
        // node count, not the first guess.
        std::size_t used_blocks = std::max<std::size_t>(std::min<std::size_t>(counters[0], pool), 1);
        if (used_blocks < pool) blocks_ = grow_buffer(rt, blocks_, used_blocks * kBlockBytes, used_blocks * kBlockBytes, "atlas blocks");
        pool_blocks_ = cl_uint(used_blocks);
        std::vector<cl_uint> host_counts(texels);
        rt.queue().enqueueReadBuffer(counts_, CL_TRUE, 0, texels * sizeof(cl_uint), host_counts.data());
        summarize_counts(host_counts, context.views, context.texels_per_view, stats);
        rt.queue().enqueueReadBuffer(layout_, CL_TRUE, 0, layout_host_.size() * sizeof(cl_uint), layout_host_.data());
        counts_host_ = host_counts;
        std::size_t live_blocks = std::size_t(std::count_if(layout_host_.begin(), layout_host_.end(), [](cl_uint b) { return b != 0; }));
        garbage_fraction_ = double(used_blocks - std::min(live_blocks, used_blocks)) / double(used_blocks);
        stats.capped_texels = 0;
        for (auto c : capped_per_view_) stats.capped_texels += c;
        stats.bytes_used = used_blocks * kBlockBytes + layout_host_.size() * sizeof(cl_uint) + texels * sizeof(cl_uint);
        // empty layers of allocated blocks (tiles whose texels differ in node count), blocks of the
        // superseded nodes of regenerated views
        stats.bytes_wasted = used_blocks * kBlockBytes - std::min<std::size_t>(stats.nodes * 2 * sizeof(float), used_blocks * kBlockBytes);
        if (packed_lookups_) pack(context, counts_host_, [&](host::KernelArgs& args) { bind_native(args); }, stats);
    }

    double garbage_fraction() const override { return garbage_fraction_; }

protected:
    void bind_native(host::KernelArgs& args) const override {
        args("atlas_layout", layout_)("texel_count", counts_)("atlas_blocks", blocks_);
    }

    DeepShadowMap read_back_native(host::Runtime& rt, const DsmViewGpu& view, cl_uint view_number) const override {
        std::vector<float> blocks(std::size_t(pool_blocks_) * kBlockBytes / sizeof(float));
        rt.queue().enqueueReadBuffer(blocks_, CL_TRUE, 0, blocks.size() * sizeof(float), blocks.data());
        DeepShadowMap map;
        map.width = map.height = int(view.resolution);
        std::size_t per_row = (view.resolution + 7) / 8;
        map.first.push_back(0);
        for (cl_uint y = 0; y < view.resolution; ++y)
            for (cl_uint x = 0; x < view.resolution; ++x) {
                std::size_t tile = view_number * per_row * per_row + (y / 8) * per_row + x / 8;
                std::size_t in_tile = (y % 8) * 8 + x % 8;
                cl_uint count = counts_host_[view.first_texel + std::size_t(y) * view.resolution + x];
                for (cl_uint k = 0; k < count; ++k) {
                    std::size_t block = layout_host_[tile * kMaxBlocks + k / kLayers] - 1;
                    std::size_t at = ((block * kLayers + k % kLayers) * kTileTexels + in_tile) * 2;
                    map.nodes.push_back({blocks[at], blocks[at + 1]});
                }
                map.first.push_back(cl_uint(map.nodes.size()));
            }
        return map;
    }

private:
    std::size_t tiles_ = 0;
    cl_uint pool_blocks_ = 0;
    cl::Buffer layout_, counts_, blocks_, allocator_;
    std::vector<cl_uint> layout_host_, counts_host_;
    std::vector<unsigned long long> capped_per_view_;
    double garbage_fraction_ = 0;
};

}  // namespace

std::unique_ptr<DsmStorage> make_atlas_storage() { return std::make_unique<AtlasStorage>(); }

}  // namespace sombra::memory
