// sombra — the deep-shadow-map module (deep_shadow_maps.h).
#include "techniques/deep_shadow_maps.h"

#include <ostream>

#include "shadows/dsm_views.h"

namespace sombra::techniques {

shadows::DsmBuildOptions dsm_build_options(const RenderOptions& o) {
    return {o.dsm_resolution, o.dsm_epsilon, o.dsm_storage, o.dsm_precompression, o.dsm_prefilter, o.dsm_prefilter_jitter,
            o.dsm_prefilter_seed, o.lanes};
}

void DeepShadowMaps::add_defines(const Scene&, const RenderOptions& options, std::vector<std::string>& defines) const {
    defines.push_back(options.shadows == ShadowTechnique::ShadowMap ? "SOMBRA_TECHNIQUE_SHADOWMAP" : "SOMBRA_TECHNIQUE_DSM");
    for (auto& d : memory::make_dsm_storage(options.dsm_storage)->defines()) defines.push_back(d);
}

// dsm and shadowmap read the same maps: the technique is not part of the key
void DeepShadowMaps::add_key(const RenderOptions& o, int lanes, std::ostream& key) const {
    key << o.dsm_resolution << ' ' << o.dsm_epsilon << ' ' << o.dsm_storage << ' ' << o.dsm_precompression << ' ' << o.dsm_prefilter
        << ' ' << o.dsm_prefilter_jitter << ' ' << o.dsm_prefilter_seed << ' ' << lanes;  // other packets build other maps
}

void DeepShadowMaps::plan_lights(const Scene& scene, packing::PackedScene& packed, const RenderOptions& options) {
    views_ = shadows::make_dsm_views(scene, packed, options.dsm_resolution);
}

void DeepShadowMaps::prepare(const SceneOnDevice& s, RenderStats& stats) {
    dsm_ = shadows::DeviceDsm();  // the previous scene's maps go before the new ones are allocated
    dsm_ = shadows::build_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, dsm_build_options(s.options));
    for (auto& [stage, ms] : dsm_.stats.stage_ms) stats.stage_ms[stage] = ms;
    views_generated_ = dsm_.stats.views_generated;
}

// Knecht §3.2 "Deep Shadow Map Re-Generation": only the views of lights that moved.
void DeepShadowMaps::update_lights(const SceneOnDevice& s, const std::vector<bool>& moved, RenderStats& stats) {
    views_generated_ = 0;
    std::vector<bool> regenerate(views_.size(), false);
    bool any = false;
    for (std::size_t i = 0; i < moved.size(); ++i) {
        const LightGpu& l = s.packed.lights[i];
        for (cl_uint v = l.view_first; v < l.view_first + l.view_count; ++v) regenerate[v] = moved[i];
        any = any || moved[i];
    }
    if (!any) return;
    // superseded nodes stay in the pools of the on-demand backends until the set is built anew
    if (dsm_.storage->garbage_fraction() > 0.5)
        dsm_ = shadows::build_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, dsm_build_options(s.options));
    else
        shadows::regenerate_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, dsm_build_options(s.options), dsm_,
                                             regenerate);
    for (auto& [stage, ms] : dsm_.stats.stage_ms) stats.stage_ms[stage] = ms;
    views_generated_ = dsm_.stats.views_generated;
}

// SHADOW_PARAMS of cl/techniques/dsm.h: the views, then the backend's DSM_READ_PARAMS
void DeepShadowMaps::bind(host::KernelArgs& args, host::Runtime&, const RenderOptions&) const {
    args("views", dsm_.views_buffer);
    dsm_.storage->bind_for_reading(args);
}

void DeepShadowMaps::add_stats(RenderStats& stats) const {
    const memory::DsmStats& d = dsm_.stats;
    stats.dsm_views = d.views;
    stats.dsm_views_generated = views_generated_;
    stats.dsm_storage = dsm_.storage->name();
    stats.dsm_nodes = d.nodes;
    stats.dsm_mean_nodes_per_texel = d.mean_nodes_per_texel;
    stats.dsm_max_nodes_per_texel = d.max_nodes_per_texel;
    stats.dsm_bytes_used = d.bytes_used;
    stats.dsm_bytes_wasted = d.bytes_wasted;
    stats.dsm_capped_texels = d.capped_texels;
}

std::unique_ptr<ShadowModule> make_deep_shadow_maps(ShadowTechnique) { return std::make_unique<DeepShadowMaps>(); }

}  // namespace sombra::techniques
