// sombra — shadow techniques "dsm" and "shadowmap" (cl/techniques/dsm.h, shadowmap.h): the deep
// shadow maps of every light, built from the light (src/shadows/dsm_builder.h) into the chosen
// storage backend (src/memory/), regenerated per light when it moves (Knecht §3.2).
#pragma once
#include "shadows/dsm_builder.h"
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

    const shadows::DeviceDsm& maps() const { return dsm_; }  // for build_deep_shadow_maps (API)

private:
    std::vector<DsmViewGpu> views_;  // planned for the lights as they are now
    shadows::DeviceDsm dsm_;
    int views_generated_ = 0;  // by the last prepare or update
};

shadows::DsmBuildOptions dsm_build_options(const RenderOptions& options);

}  // namespace sombra::techniques
