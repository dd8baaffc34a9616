// sombra — deep shadow map storage backends behind one interface (docs/architecture.md "Host/kernel contract
// are swappable on both sides"). Each backend has a kernel header of the same function names
// (cl/storage_<name>.h) and this C++ side: it allocates for a set of DSM views, runs generation
// into its layout, binds its buffers to lookup kernels, reports bytes used and wasted, and reads a
// view back for export. A storage that was built once can regenerate some views and keep the
// others (a moved light rebuilds its own views only: Knecht §3.2 "Deep Shadow Map Re-Generation").
#pragma once
#include <CL/opencl.hpp>

#include <algorithm>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/kernel_args.h"
#include "host/runtime.h"
#include "shared/types.h"
#include "sombra/shadows.h"

namespace sombra::memory {

struct DsmStats {
    int views = 0, resolution = 0;
    std::map<std::string, double> stage_ms;  // kernels from profiling events, host steps by clock
    unsigned long long nodes = 0;
    double mean_nodes_per_texel = 0;         // over all texels of all views
    unsigned max_nodes_per_texel = 0;
    unsigned long long bytes_used = 0, bytes_wasted = 0;
    unsigned long long capped_texels = 0;    // texels that hit a layer cap (atlas)
    int views_generated = 0;                 // by the last build (all views, or the changed lights')
    double precompression_max_error = 0;     // of the pre-compressed visibility tables, if used
};

// What generation needs from the caller: the device, the views, and a way to enqueue dsm_build.cl
// for one view with the backend's buffers appended to the common arguments.
struct BuildContext {
    host::Runtime& runtime;
    std::vector<DsmViewGpu>& views;          // the backend sets max_nodes
    std::vector<std::string> defines;        // the volume pass defines (+ the backend's own)
    std::size_t texels_per_view = 0;
    std::string program = "dsm_build.cl";    // the generation program (dsm_prefilter.cl when filtering)
    // Views to generate. Empty: all. Views left out keep the nodes of the storage's previous
    // build, or stay empty (no nodes: fully lit) in a storage never built.
    std::vector<bool> regenerate;
    bool generates(std::size_t view) const { return regenerate.empty() || regenerate[view]; }
    std::size_t generated_views() const {
        return regenerate.empty() ? views.size() : std::size_t(std::count(regenerate.begin(), regenerate.end(), true));
    }
    // Builds `kernel` of `program_defines`, binds the common arguments for `view`, lets `bind` add
    // the backend's (DSM_BUILD_STORAGE_PARAMS), runs it over the view's texels and returns the
    // kernel time in ms.
    std::function<double(const std::vector<std::string>& program_defines, const char* kernel, cl_uint view,
                         const std::function<void(host::KernelArgs&)>& bind)>
        run_view;
};

// Every texel's nodes as one run, in the compact layout (cl/storage_compact.h): the compact
// storage itself, and the copy that packed lookups read (RenderOptions::dsm_lookup).
struct PackedNodes {
    std::vector<cl_uint> texel_first;  // per texel its first node; texels + 1 entries
    cl::Buffer texel_first_buffer, nodes;  // nodes: (depth, opacity) pairs, + 1 spare (lookups of empty texels read in bounds)
    std::size_t bytes() const { return texel_first.size() * sizeof(cl_uint) + (node_count() + 1) * 2 * sizeof(float); }
    std::size_t node_count() const { return texel_first.empty() ? 0 : std::size_t(texel_first.back()); }
    void bind(host::KernelArgs& args) const { args("texel_first", texel_first_buffer)("nodes", nodes); }
    DeepShadowMap read_back(host::Runtime& runtime, const DsmViewGpu& view) const;
};
// PackedNodes on the host: what a rank of a distributed render sends (src/distributed/map_exchange.h).
struct HostPackedNodes {
    std::vector<cl_uint> texel_first;  // texels + 1 entries
    std::vector<float> nodes;          // (depth, opacity) pairs, texel_first.back() of them
};
// Offsets of consecutive runs of counts[i] nodes (a prefix sum, counts.size() + 1 entries);
// throws sombra::Error past 2^31 nodes.
std::vector<cl_uint> run_offsets(const std::vector<cl_uint>& counts);

class DsmStorage {
public:
    virtual ~DsmStorage() = default;
    virtual std::string name() const = 0;
    virtual std::vector<std::string> defines() const = 0;  // selects cl/storage_<name>.h for generation
    // The defines of the lookup programs: none (the compact reader) when lookups read the packed
    // copy, else the backend's own.
    std::vector<std::string> lookup_defines() const { return packed_lookups_ ? std::vector<std::string>{} : defines(); }
    // Generates context.generates() views; stats cover every view (nodes, bytes) and the work
    // done by this call (stage times).
    virtual void build(BuildContext& context, DsmStats& stats) = 0;
    // Launches of run_view per generated view when the pools need not grow (a count and a build,
    // or a build alone): the progress stage's work. A rerun extends the stage.
    virtual int generation_passes() const { return 1; }
    // Share of the allocated node memory held by superseded nodes of regenerated views; the
    // caller rebuilds everything anew when it grows too large.
    virtual double garbage_fraction() const { return 0.0; }
    // DSM_READ_PARAMS of the lookup programs, in order: the packed copy's or the backend's own.
    void bind_for_reading(host::KernelArgs& args) const {
        if (packed_lookups_) packed_.bind(args);
        else bind_native(args);
    }
    // One view's nodes on the host (deep EXR export, tests).
    DeepShadowMap read_back(host::Runtime& runtime, const DsmViewGpu& view, cl_uint view_number) const {
        return packed_lookups_ ? packed_.read_back(runtime, view) : read_back_native(runtime, view, view_number);
    }
    // Every view's nodes on the host in the compact layout: the packed copy, or the compact storage
    // itself. Throws sombra::Error for another backend read natively (--dsm-lookup native).
    HostPackedNodes read_packed(host::Runtime& runtime) const;

protected:
    virtual void bind_native(host::KernelArgs& args) const = 0;
    virtual DeepShadowMap read_back_native(host::Runtime& runtime, const DsmViewGpu& view, cl_uint view_number) const = 0;
    // After a build with packed lookups: every texel's nodes (`counts` per texel) copied into
    // packed_ by the backend's dsm_pack kernel (cl/dsm_storage_common.h), whose own buffers
    // `bind_source` binds; stage "dsm_pack", bytes_used grows by the copy.
    void pack(BuildContext& context, const std::vector<cl_uint>& counts,
              const std::function<void(host::KernelArgs&)>& bind_source, DsmStats& stats);

    bool packed_lookups_ = false;
    PackedNodes packed_;
    friend std::unique_ptr<DsmStorage> make_dsm_storage(const std::string& name, const std::string& lookup);
};

// `name`: "atlas", "chunked", "chunked-ondemand" or "compact" (RenderOptions::dsm_storage);
// `lookup`: "packed" or "native" (RenderOptions::dsm_lookup). Throws sombra::Error naming
// --storage or --dsm-lookup otherwise.
std::unique_ptr<DsmStorage> make_dsm_storage(const std::string& name, const std::string& lookup = "packed");

// A storage of nodes made elsewhere (the maps of every rank of a distributed render, merged),
// read by the compact lookup; it cannot generate.
std::unique_ptr<DsmStorage> make_received_storage(host::Runtime& runtime, const HostPackedNodes& nodes);

// Shared helpers of the backends.
// Nodes per texel of every view, from a counting march (dsm_count, SOMBRA_DSM_COUNT_ONLY) over
// the views generated; the others' counts come from `kept` (their previous counts, or none).
std::vector<cl_uint> count_nodes(BuildContext& context, DsmStats& stats, const std::vector<cl_uint>& kept);
// A buffer of `new_bytes` whose first `kept_bytes` are copied from `old` (pools that grow while
// keeping the nodes of views not regenerated).
cl::Buffer grow_buffer(host::Runtime& runtime, const cl::Buffer& old, std::size_t kept_bytes, std::size_t new_bytes,
                       const char* what);
// The 8×8 tiles of a DSM set (every view has the same resolution), as the tiled backends lay them out.
struct TileGrid {
    std::size_t per_row, view_tiles, tiles, texels;
    explicit TileGrid(const BuildContext& context)
        : per_row((context.views.front().resolution + 7) / 8), view_tiles(per_row * per_row),
          tiles(context.views.size() * view_tiles), texels(context.views.size() * context.texels_per_view) {}
};

void summarize_counts(const std::vector<cl_uint>& counts, std::vector<DsmViewGpu>& views, std::size_t texels_per_view,
                      DsmStats& stats);

}  // namespace sombra::memory
