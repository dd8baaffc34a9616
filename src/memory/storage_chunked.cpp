// sombra — chunked storage: Knecht Alg. 4.1 chunks per tile, linked lists (cl/storage_chunked.h).
#include <algorithm>
#include <chrono>
#include <array>
#include <cstring>

#include "memory/dsm_storage.h"
#include "sombra/error.h"

namespace sombra::memory {
namespace {
// the kernel's allocator (cl/storage_chunked.h): chunks handed out, requests not served
using ChunkAllocatorCounters = std::array<cl_uint, 2>;

constexpr unsigned kChunkLength = 64;    // Knecht's L_C
constexpr unsigned kChunksPerTile = 64;  // Knecht's C_B: up to 4096 nodes per tile

class ChunkedStorage : public DsmStorage {
public:
    explicit ChunkedStorage(bool counted) : counted_(counted) {}
    std::string name() const override { return counted_ ? "chunked" : "chunked-ondemand"; }
    int generation_passes() const override { return counted_ ? 2 : 1; }
    std::vector<std::string> defines() const override {
        std::vector<std::string> d{"SOMBRA_DSM_CHUNKED", "SOMBRA_CHUNK_LENGTH=" + std::to_string(kChunkLength),
                                   "SOMBRA_CHUNKS_PER_TILE=" + std::to_string(kChunksPerTile)};
        if (counted_) d.push_back("SOMBRA_CHUNKS_COUNTED");
        return d;
    }

    // Counted allocation: nodes per texel (dsm_count), summed per tile, prefix sum → each
    // generated tile's first slot, after the slots already taken (kept views stay where they
    // are); returns the slots in use.
    std::size_t count_tiles(BuildContext& context, DsmStats& stats, std::vector<cl_uint>& host_counts,
                            std::vector<cl_uint>& tile_first, bool update) {
        host_counts = count_nodes(context, stats, update ? counts_host_ : std::vector<cl_uint>{});
        auto start = std::chrono::steady_clock::now();
        cl_uint resolution = context.views.front().resolution, per_row = (resolution + 7) / 8;
        std::vector<unsigned long long> per_tile(tile_first.size(), 0);
        for (std::size_t v = 0; v < context.views.size(); ++v)
            for (cl_uint y = 0; context.generates(v) && y < resolution; ++y)
                for (cl_uint x = 0; x < resolution; ++x)
                    per_tile[v * per_row * per_row + (y / 8) * per_row + x / 8] +=
                        host_counts[v * context.texels_per_view + std::size_t(y) * resolution + x];
        unsigned long long total = update ? slots_ - 1 : 0;  // the spare slot moves to the end
        for (std::size_t t = 0; t < per_tile.size(); ++t) {
            if (!context.generates(t / (per_row * per_row))) continue;
            tile_first[t] = cl_uint(total);
            total += per_tile[t];
            if (total > 0x7fffffffull) throw Error("--dsm-res/--eps: more than 2^31 deep shadow map nodes");
        }
        stats.stage_ms["dsm_prefix_sum"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        return std::size_t(total);
    }

    void build(BuildContext& context, DsmStats& stats) override {
        host::Runtime& rt = context.runtime;
        const TileGrid grid(context);
        const std::size_t view_tiles = grid.view_tiles, tiles = grid.tiles, texels = grid.texels;
        std::size_t table_entries = tiles * (counted_ ? 1 : kChunksPerTile);
        bool update = tiles_ == tiles && !context.regenerate.empty();
        if (!update) {
            tiles_ = tiles;
            fill_ = host::make_buffer(rt, CL_MEM_READ_WRITE, tiles * sizeof(cl_uint), nullptr, "chunk fill counters");
            tile_chunks_ = host::make_buffer(rt, CL_MEM_READ_WRITE, table_entries * sizeof(cl_uint), nullptr, "tile chunk tables");
            head_ = host::make_buffer(rt, CL_MEM_READ_WRITE, texels * sizeof(cl_uint), nullptr, "texel list heads");
            counts_ = host::make_buffer(rt, CL_MEM_READ_WRITE, texels * sizeof(cl_uint), nullptr, "texel node counts");
            allocator_ = host::make_buffer(rt, CL_MEM_READ_WRITE, sizeof(ChunkAllocatorCounters), nullptr, "chunk allocator");
            rt.queue().enqueueFillBuffer(tile_chunks_, cl_uint(0), 0, table_entries * sizeof(cl_uint));
            rt.queue().enqueueFillBuffer(allocator_, cl_uint(0), 0, sizeof(ChunkAllocatorCounters));
            rt.queue().enqueueFillBuffer(counts_, cl_uint(0), 0, texels * sizeof(cl_uint));
            rt.queue().enqueueFillBuffer(head_, cl_uint(0xffffffffu), 0, texels * sizeof(cl_uint));
            slots_ = 1, pool_ = 0;
        }
        // the generated views' tiles start empty
        auto reset_generated_tiles = [&] {
            for (std::size_t v = 0; v < context.views.size(); ++v) {
                if (!context.generates(v)) continue;
                std::size_t entries = view_tiles * (counted_ ? 1 : kChunksPerTile);
                rt.queue().enqueueFillBuffer(fill_, cl_uint(0), v * view_tiles * sizeof(cl_uint), view_tiles * sizeof(cl_uint));
                if (!counted_)
                    rt.queue().enqueueFillBuffer(tile_chunks_, cl_uint(0), v * entries * sizeof(cl_uint), entries * sizeof(cl_uint));
            }
        };
        std::size_t kept_slots = update ? slots_ : 0;  // slots holding the kept views' nodes
        ChunkAllocatorCounters counters{};
        rt.queue().enqueueReadBuffer(allocator_, CL_TRUE, 0, sizeof(counters), counters.data());
        const cl_uint chunks_before = counters[0];
        cl_uint pool = cl_uint(std::max<std::size_t>({std::size_t(pool_), tiles, 1}));
        if (counted_) {  // one exact run per tile: pool = nodes (+1 so that no buffer is empty)
            std::vector<cl_uint> host_counts, tile_first(tiles, 0);
            slots_ = count_tiles(context, stats, host_counts, tile_first, update) + 1;
            for (std::size_t v = 0; v < context.views.size(); ++v)
                if (context.generates(v))
                    rt.queue().enqueueWriteBuffer(tile_chunks_, CL_TRUE, v * view_tiles * sizeof(cl_uint), view_tiles * sizeof(cl_uint),
                                                  tile_first.data() + v * view_tiles);
        }
        for (int attempt = 0;; ++attempt) {
            std::size_t slots = counted_ ? slots_ : std::size_t(pool) * kChunkLength;
            nodes_ = grow_buffer(rt, nodes_, kept_slots * 2 * sizeof(float), slots * 2 * sizeof(float), "chunk nodes");
            next_ = grow_buffer(rt, next_, kept_slots * sizeof(cl_uint), slots * sizeof(cl_uint), "chunk links");
            reset_generated_tiles();
            counters = {chunks_before, 0};
            rt.queue().enqueueWriteBuffer(allocator_, CL_TRUE, 0, sizeof(counters), counters.data());
            for (cl_uint v = 0; v < context.views.size(); ++v) {
                if (!context.generates(v)) continue;
                stats.stage_ms["dsm_build"] += context.run_view(context.defines, "dsm_build", v, [&](host::KernelArgs& args) {
                    args("tile_fill", fill_)("tile_chunks", tile_chunks_)("chunk_nodes", nodes_)("chunk_next", next_);
                    args("texel_head", head_)("texel_count", counts_)("chunk_allocator", allocator_)("chunk_pool", pool);
                });
            }
            rt.queue().enqueueReadBuffer(allocator_, CL_TRUE, 0, sizeof(counters), counters.data());
            if (counters[1] == 0) break;
            // requests with blocks to spare: a tile over its chunk limit, not a short pool
            if (counters[0] < pool || attempt > 2) throw Error("--dsm-res: a tile holds more than " +
                                                 std::to_string(kChunkLength * kChunksPerTile) +
                                                 " nodes, the chunked storage's limit; raise --eps or use --storage atlas");
            // grow by the entries that found no chunk (each counted once, and no chunk is drawn
            // and lost: claim_block): the next run asks for the same chunks
            pool = cl_uint(std::size_t(counters[0]) + counters[1] + 1);
            rt.progress().extend(double(context.generated_views()));  // the views run again
        }
        if (!counted_) {
            pool_ = pool;
            slots_ = std::size_t(pool) * kChunkLength;
        }
        if (!packed_lookups_) {  // rearranged for reading in place: one float4 per slot
            texture_ = host::make_buffer(rt, CL_MEM_READ_WRITE, slots_ * 4 * sizeof(float), nullptr, "chunk texture");
            cl::Kernel rearrange(rt.program(context.program, context.defines), "dsm_rearrange");
            host::KernelArgs{rearrange}("chunk_nodes", nodes_)("chunk_next", next_)("chunk_texture", texture_).done();
            cl::Event event;
            rt.queue().enqueueNDRangeKernel(rearrange, cl::NullRange, cl::NDRange(slots_), cl::NullRange, nullptr, &event);
            event.wait();
            stats.stage_ms["dsm_rearrange"] = host::Runtime::event_ms(event);
        }

        counts_host_.resize(texels);
        rt.queue().enqueueReadBuffer(counts_, CL_TRUE, 0, texels * sizeof(cl_uint), counts_host_.data());
        summarize_counts(counts_host_, context.views, context.texels_per_view, stats);
        heads_host_.resize(texels);
        rt.queue().enqueueReadBuffer(head_, CL_TRUE, 0, texels * sizeof(cl_uint), heads_host_.data());
        // garbage: slots taken but no longer reachable (superseded nodes of regenerated views)
        // against the slots taken — the counted runs of every tile, or the
        // chunks handed out and those the tile tables point to
        std::size_t taken = slots_, live = stats.nodes + 1;
        if (!counted_) {
            std::vector<cl_uint> table(table_entries);
            rt.queue().enqueueReadBuffer(tile_chunks_, CL_TRUE, 0, table_entries * sizeof(cl_uint), table.data());
            taken = std::size_t(std::min(counters[0], pool)) * kChunkLength;
            live = std::size_t(std::count_if(table.begin(), table.end(), [](cl_uint c) { return c != 0; })) * kChunkLength;
        }
        garbage_fraction_ = taken > 0 ? double(taken - std::min(live, taken)) / double(taken) : 0.0;
        // per slot: the chunk texture's float4 (native lookups) or the node and its link (packed)
        std::size_t node_bytes = packed_lookups_ ? 2 * sizeof(float) + sizeof(cl_uint) : 4 * sizeof(float);
        std::size_t tables = texels * 2 * sizeof(cl_uint) + tiles * ((counted_ ? 1 : kChunksPerTile) + 1) * sizeof(cl_uint);
        // wasted: unfilled slots of allocated chunks (Knecht Table 5.11), the pool's unused tail, superseded nodes of regenerated views; counted allocation of a
        // fresh build wastes only the one spare slot
        stats.bytes_used = slots_ * node_bytes + tables;
        stats.bytes_wasted = (slots_ - stats.nodes) * node_bytes;
        if (packed_lookups_)
            pack(context, counts_host_, [&](host::KernelArgs& args) {
                args("texel_head", head_)("texel_count", counts_)("chunk_nodes", nodes_)("chunk_next", next_);
            }, stats);
    }

    double garbage_fraction() const override { return garbage_fraction_; }

protected:
    void bind_native(host::KernelArgs& args) const override { args("texel_head", head_)("chunk_texture", texture_); }

    DeepShadowMap read_back_native(host::Runtime& rt, const DsmViewGpu& view, cl_uint) const override {
        std::vector<float> texture(slots_ * 4);
        rt.queue().enqueueReadBuffer(texture_, CL_TRUE, 0, texture.size() * sizeof(float), texture.data());
        DeepShadowMap map;
        map.width = map.height = int(view.resolution);
        map.first.push_back(0);
        std::size_t texels = std::size_t(view.resolution) * view.resolution;
        for (std::size_t t = 0; t < texels; ++t) {
            cl_uint slot = heads_host_[view.first_texel + t];
            for (cl_uint k = 0; k < counts_host_[view.first_texel + t] && slot != 0xffffffffu; ++k) {
                const float* n = &texture[std::size_t(slot) * 4];
                map.nodes.push_back({n[0], n[1]});
                std::memcpy(&slot, &n[2], sizeof(slot));
            }
            map.first.push_back(cl_uint(map.nodes.size()));
        }
        return map;
    }

private:
    bool counted_;
    std::size_t tiles_ = 0, slots_ = 0;  // slots: of the node arrays (counted: + 1 spare)
    cl_uint pool_ = 0;                   // chunks of the pool (on demand)
    double garbage_fraction_ = 0;
    cl::Buffer fill_, tile_chunks_, nodes_, next_, head_, counts_, allocator_, texture_;
    std::vector<cl_uint> heads_host_, counts_host_;
};

}  // namespace

std::unique_ptr<DsmStorage> make_chunked_storage(bool counted) { return std::make_unique<ChunkedStorage>(counted); }

}  // namespace sombra::memory
