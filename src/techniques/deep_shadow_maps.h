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
    void plan_lights(const Scene& scene, packing::PackedScene& packed, const RenderOptions& options) override;
    void prepare(const SceneOnDevice& on_device, RenderStats& stats) override;
    void update_lights(const SceneOnDevice& on_device, const std::vector<bool>& moved, RenderStats& stats) override;
    void bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions& options) const override;
    void add_stats(RenderStats& stats) const override;
    std::string light_data_key(std::size_t light) const override;

    const shadows::DeviceDsm& maps() const { return dsm_; }  // for build_deep_shadow_maps (API)

private:
    // planned for the lights (and, clustered, the camera) as they are now
    std::vector<DsmViewGpu> views_;
    shadows::ViewMeshes meshes_;                    // clustered: the meshes of each view's map
    std::vector<std::pair<cl_uint, cl_uint>> light_views_;  // per light: view_first, view_count
    std::optional<ClusteredViews> clusters_;
    double clustering_ms_ = 0;
    // what the maps in dsm_ were generated from
    std::vector<DsmViewGpu> built_views_;
    shadows::ViewMeshes built_meshes_;
    shadows::DeviceDsm dsm_;
    int views_generated_ = 0;  // by the last prepare or update
};

}  // namespace sombra::techniques
