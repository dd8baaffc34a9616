// sombra — shadow techniques "dsm" and "shadowmap" (cl/techniques/dsm.h, shadowmap.h): the deep
// shadow maps of every light, built from the light (src/shadows/dsm_builder.h) into the chosen
// storage backend (src/memory/), regenerated per light when it moves (Knecht §3.2). With
// DsmOptions::clusters, one map per object cluster (clustered_views.h, Knecht §3.4),
// planned anew each frame and regenerated only where a cluster's members or focus changed.
#pragma once
#include <optional>

#include "shadows/dsm_builder.h"
#include "techniques/clustered_views.h"
#include "techniques/technique.h"

namespace sombra::techniques {

class DeepShadowMaps final : public ShadowModule {
public:
    void add_defines(const Scene& scene, const RenderOptions& options, std::vector<std::string>& defines) const override;
    void add_key(const RenderOptions& options, int lanes, std::ostream& key) const override;
    void plan_lights(const Scene& scene, const packing::PackedScene& packed, const RenderOptions& options) override;
    void prepare(const SceneOnDevice& on_device, RenderStats& stats) override;
    void update_lights(const SceneOnDevice& on_device, const std::vector<bool>& moved, RenderStats& stats) override;
    void bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions& options) const override;
    void add_stats(RenderStats& stats) const override;
    std::string light_data_key(std::size_t light) const override;
    std::vector<DeepShadowMap> read_back_maps(host::Runtime& runtime, std::size_t light) const override;
    bool crosses_ranks() const override { return true; }

private:
    // planned for the lights (and, clustered, the camera) as they are now
    std::vector<DsmViewGpu> views_;
    shadows::ViewMeshes meshes_;                    // clustered: the meshes of each view's map
    std::vector<DsmLightViews> light_views_;  // per light: its views
    mutable cl::Buffer light_views_buffer_;   // light_views_ on the device, uploaded at the first bind
    std::optional<ClusteredViews> clusters_;
    double clustering_ms_ = 0;
    // what the maps in dsm_ were generated from
    std::vector<DsmViewGpu> built_views_;
    shadows::ViewMeshes built_meshes_;
    std::vector<bool> generated_;  // per view: its map holds nodes (false: left empty for a light no call needed yet)
    shadows::DeviceDsm dsm_;
    int views_generated_ = 0;  // by the last prepare or update

    // Per view, whether its light's maps are needed by the call (SceneOnDevice::lights_needed).
    std::vector<bool> needed_views(const SceneOnDevice& s) const;
    // After a build or regeneration of the views marked in `generate`.
    void note_built(const std::vector<bool>& generate, RenderStats& stats);
    // A distributed render: this rank's maps sent to every rank, and every rank's merged into the
    // maps the lookups read (src/distributed/map_exchange.h); the views of each rank become
    // clusters of their light.
    void exchange_maps(const SceneOnDevice& s, RenderStats& stats);
    unsigned long long map_bytes_sent_ = 0, map_bytes_received_ = 0;
};

}  // namespace sombra::techniques
