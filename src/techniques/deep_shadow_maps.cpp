// sombra — the deep-shadow-map module (deep_shadow_maps.h).
#include "techniques/deep_shadow_maps.h"

#include <chrono>
#include <cstring>
#include <ostream>

#include "distributed/map_exchange.h"
#include "shadows/dsm_views.h"
#include "sombra/distributed.h"
#include "techniques/option_declarations.h"

namespace sombra::techniques {

namespace {
const std::vector<ShadowTechnique>& dsm_techniques() {  // the techniques that read the maps
    static const std::vector<ShadowTechnique> techniques{ShadowTechnique::Dsm, ShadowTechnique::ShadowMap};
    return techniques;
}
}  // namespace

// The options of DsmOptions (render.h): every one keys the maps (dsm and shadowmap read the same
// maps: the technique does not), except the hysteresis, which only decides which clusters stay.
const std::vector<OptionSpec>& dsm_option_specs() {
    constexpr unsigned every_command = kRenderCommand | kDsmCommand | kVisibilityCommand;
    static const std::vector<OptionSpec> specs = [] {
        std::vector<Declaration> d = {
            declare("dsm_resolution", "--dsm-res", [](auto& o) -> auto& { return o.dsm.resolution; },
                    "deep shadow map texels per side")
                .range(1, 8192).unit("texels"),
            declare("dsm_epsilon", "--eps", [](auto& o) -> auto& { return o.dsm.epsilon; },
                    "deep shadow map compression error bound ε (Knecht Eq. 3.1)")
                .range(0, 1),
            declare("dsm_error", "--dsm-error", [](auto& o) -> auto& { return o.dsm.error; },
                    "what ε bounds: absolute (opacity, |α' − α| ≤ ε) or relative (optical depth, |τ' − τ| ≤ ε: "
                    "the light that is left within a factor e^±ε, dim regions kept)")
                .choices({"absolute", "relative"}),
            declare("dsm_step", "--dsm-step", [](auto& o) -> auto& { return o.dsm.step; },
                    "DSM generation: factor on each volume's step for the rays from the light (> 1: faster, coarser)")
                .range(0.01, 16),  // 100× finer at most: a ray of the finest volume then takes ≤ 100× its voxels
            declare("dsm_storage", "--dsm-storage", [](auto& o) -> auto& { return o.dsm.storage; },
                    "deep shadow map storage: atlas, chunked, chunked-ondemand (Knecht) or compact")
                .choices(dsm_storage_names()),
            declare("dsm_lookup", "--dsm-lookup", [](auto& o) -> auto& { return o.dsm.lookup; },
                    "DSM lookups: packed (each texel's nodes copied into one run after generation) or native "
                    "(in the storage's own layout)")
                .choices({"packed", "native"}),
            declare("dsm_precompression", "--precompression", [](auto& o) -> auto& { return o.dsm.precompression; },
                    "pre-compressed visibility tables for DSM generation (Hadwiger §3.2)"),
            declare("dsm_prefilter", "--prefilter", [](auto& o) -> auto& { return o.dsm.prefilter; },
                    "DSM pre-filtering: none, box (2×2 sub-pixel rays), tent (4×4) or 5tap (centre + 4 corners)")
                .choices({"none", "box", "tent", "5tap"}),
            declare("dsm_prefilter_jitter", "--no-prefilter-jitter", [](auto& o) -> auto& { return o.dsm.prefilter_jitter; },
                    "pre-filtering: sub-pixel rays at the centres of their cells, not jittered"),
            declare("dsm_prefilter_seed", "--prefilter-seed", [](auto& o) -> auto& { return o.dsm.prefilter_seed; },
                    "pre-filtering: seed of the sub-pixel rays' jitter")
                .range(0, 999999999),
            declare("dsm_clusters", "--clusters", [](auto& o) -> auto& { return o.dsm.clusters; },
                    "clustered deep shadow maps (Knecht §3.4): at most M object clusters per light, each with its own "
                    "--dsm-res map focused on it")
                .range(0, 64).special("0: off"),
            declare("dsm_cluster_distance", "--cluster-distance", [](auto& o) -> auto& { return o.dsm.cluster_distance; },
                    "clustering threshold d0 in light space")
                .range(0, 10).special("0: automatic, from the projected object sizes"),
        };
        for (Declaration& option : d) option.only(dsm_techniques()).keys().commands(every_command);
        d.push_back(declare("dsm_cluster_hysteresis", "--cluster-hysteresis", [](auto& o) -> auto& { return o.dsm.cluster_hysteresis; },
                            "keep the previous frame's clusters while their spread is within 1 + H of new ones (API re-renders)")
                        .range(0, 10).special("0: off").only(dsm_techniques()));
        return std::vector<OptionSpec>(d.begin(), d.end());
    }();
    return specs;
}

void DeepShadowMaps::add_defines(const Scene&, const RenderOptions& options, std::vector<std::string>& defines) const {
    defines.push_back(options.shadows == ShadowTechnique::ShadowMap ? "SOMBRA_TECHNIQUE_SHADOWMAP" : "SOMBRA_TECHNIQUE_DSM");
    for (auto& d : memory::make_dsm_storage(options.dsm.storage, options.dsm.lookup)->lookup_defines()) defines.push_back(d);
    shadows::add_dsm_value_define(options.dsm, defines);
}

void DeepShadowMaps::add_key(const RenderOptions& o, int lanes, std::ostream& key) const {
    add_option_keys(dsm_option_specs(), o, key);
    key << " lanes " << lanes;  // other packets build other maps
}

void DeepShadowMaps::plan_lights(const Scene& scene, const packing::PackedScene& packed, const RenderOptions& options) {
    if (options.dsm.clusters > 0) {
        auto start = std::chrono::steady_clock::now();
        clustering::ClusterOptions cluster_options{options.dsm.clusters, options.dsm.cluster_distance, nullptr,
                                                   options.dsm.cluster_hysteresis};
        std::vector<std::vector<std::vector<std::size_t>>> previous;  // last frame's members, same m and d0
        if (clusters_ && clusters_->options.max_clusters == cluster_options.max_clusters &&
            clusters_->options.distance == cluster_options.distance) {
            for (const clustering::LightClusters& light : clusters_->lights) {
                previous.emplace_back();
                for (const clustering::Cluster& c : light.clusters) previous.back().push_back(c.members);
            }
            cluster_options.previous = &previous;
        }
        clusters_ = make_clustered_views(scene, options.dsm.resolution, cluster_options);
        clustering_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        views_ = clusters_->views;
        meshes_ = clusters_->meshes;
        light_views_ = clusters_->light_views;
    } else {
        clusters_.reset();
        light_views_.clear();
        views_ = shadows::make_dsm_views(scene, packed, options.dsm.resolution, &light_views_);
        meshes_.clear();
    }
    light_views_buffer_ = cl::Buffer();  // uploaded anew at the next bind
}

std::vector<bool> DeepShadowMaps::needed_views(const SceneOnDevice& s) const {
    std::vector<bool> needed(views_.size(), false);
    for (std::size_t light = 0; light < light_views_.size(); ++light)
        for (cl_uint v = light_views_[light].first; v < light_views_[light].first + light_views_[light].count; ++v)
            needed[v] = s.needs_light(light);
    return needed;
}

void DeepShadowMaps::note_built(const std::vector<bool>& generate, RenderStats& stats) {
    built_views_ = views_, built_meshes_ = meshes_;
    generated_.resize(views_.size(), false);
    for (std::size_t v = 0; v < views_.size(); ++v) generated_[v] = generated_[v] || generate[v];
    for (auto& [stage, ms] : dsm_.stats.stage_ms) stats.stage_ms[stage] = ms;
    views_generated_ = dsm_.stats.views_generated;
}

// Only the views of the lights the call needs are generated (`sombra dsm --light k`, a query of
// one light): each view keeps its index, so its map — and the jitter of its rays, seeded by the
// index — is the one a build of every light makes.
void DeepShadowMaps::prepare(const SceneOnDevice& s, RenderStats& stats) {
    dsm_ = shadows::DeviceDsm();  // the previous scene's maps go before the new ones are allocated
    const std::vector<bool> generate = needed_views(s);
    generated_.assign(views_.size(), false);
    dsm_ = shadows::build_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, s.options.dsm, s.options.lanes, meshes_,
                                           generate);
    note_built(generate, stats);
    if (s.exchange) exchange_maps(s, stats);
}

void DeepShadowMaps::exchange_maps(const SceneOnDevice& s, RenderStats& stats) {
    if (clusters_) throw Error("--clusters: a distributed render's ranks build one map per light of their own region; use --clusters 0");
    using clock = std::chrono::steady_clock;
    auto lap = clock::now();
    auto stage = [&](const char* name) {  // the time since the last stage, as `name`
        const auto now = clock::now();
        stats.stage_ms[name] = std::chrono::duration<double, std::milli>(now - lap).count();
        lap = now;
    };
    const distributed::MapSet own{dsm_.views, light_views_, dsm_.storage->read_packed(s.runtime), dsm_.optical_depth};
    const distributed::ReceivedMaps received = distributed::exchange_maps(*s.exchange, own, stage);
    map_bytes_sent_ = received.bytes_sent, map_bytes_received_ = received.bytes_received;
    std::vector<distributed::MapSet> sets;
    for (std::size_t r = 0; r < received.ranks.size(); ++r)
        sets.push_back(distributed::deserialize(received.ranks[r], "rank " + std::to_string(r)));
    distributed::MapSet merged = distributed::merge_map_sets(sets);
    dsm_.views = merged.views;
    dsm_.views_buffer = host::make_buffer(s.runtime, CL_MEM_READ_ONLY, merged.views.size() * sizeof(DsmViewGpu), merged.views.data(),
                                          "received deep shadow map views");
    dsm_.storage = memory::make_received_storage(s.runtime, merged.nodes);
    views_ = built_views_ = merged.views;
    meshes_.clear(), built_meshes_.clear();
    generated_.assign(views_.size(), true);
    light_views_ = merged.light_views;
    light_views_buffer_ = cl::Buffer();
    stage("dsm_exchange_merge");  // checked, merged and uploaded
}

namespace {

// Whether a map generated for view `a` holding `a_meshes` serves view `b` holding `b_meshes`
// (the backend's statistics in max_nodes aside).
bool same_map(DsmViewGpu a, DsmViewGpu b, const std::vector<bool>& a_meshes, const std::vector<bool>& b_meshes) {
    a.max_nodes = b.max_nodes = 0;
    return std::memcmp(&a, &b, sizeof a) == 0 && a_meshes == b_meshes;
}

const std::vector<bool>& meshes_of(const shadows::ViewMeshes& meshes, std::size_t view) {
    static const std::vector<bool> all;
    return view < meshes.size() ? meshes[view] : all;
}

}  // namespace

// Knecht §3.2 "Deep Shadow Map Re-Generation": only the views of lights that moved; clustered
// (§3.4.3), also the views whose cluster's members or focus changed — a camera move that keeps
// the clusters regenerates nothing. A different number of views builds the set anew.
void DeepShadowMaps::update_lights(const SceneOnDevice& s, const std::vector<bool>& moved, RenderStats& stats) {
    views_generated_ = 0;
    const bool anew = views_.size() != built_views_.size();
    if (anew) generated_.assign(views_.size(), false);
    const std::vector<bool> needed = needed_views(s);
    std::vector<bool> regenerate(views_.size(), false);
    bool any = false;
    for (std::size_t i = 0; i < moved.size(); ++i) {
        const DsmLightViews& l = light_views_[i];
        for (cl_uint v = l.first; v < l.first + l.count; ++v) {
            const bool stale = moved[i] || anew || !same_map(views_[v], built_views_[v], meshes_of(meshes_, v), meshes_of(built_meshes_, v));
            if (stale) generated_[v] = false;  // a light no call needs now is left stale, and built when one does
            regenerate[v] = needed[v] && !generated_[v];
            any = any || regenerate[v];
        }
    }
    if (!any && !anew) return;
    if (s.exchange) throw Error("internal: the maps of a distributed render are built once per render (render_distributed)");
    // superseded nodes stay in the pools of the on-demand backends until the set is built anew
    if (anew || dsm_.storage->garbage_fraction() > 0.5) {
        for (std::size_t v = 0; v < views_.size(); ++v) regenerate[v] = needed[v];  // what was kept goes too
        generated_.assign(views_.size(), false);
        dsm_ = shadows::DeviceDsm();
        dsm_ = shadows::build_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, s.options.dsm, s.options.lanes, meshes_,
                                               regenerate);
    } else {
        shadows::regenerate_deep_shadow_maps(s.runtime, s.scene, s.packed, s.device, views_, s.options.dsm, s.options.lanes, dsm_,
                                             regenerate, meshes_);
    }
    note_built(regenerate, stats);
}

std::string DeepShadowMaps::light_data_key(std::size_t light) const {
    if (!clusters_ || light >= light_views_.size()) return {};
    std::string key = "views";
    const auto [first, count] = light_views_[light];
    for (cl_uint v = first; v < first + count; ++v) {
        DsmViewGpu view = views_[v];
        view.max_nodes = 0, view.first_texel = 0;
        key.append(reinterpret_cast<const char*>(&view), sizeof view);
        for (bool held : meshes_of(meshes_, v)) key += held ? '1' : '0';
    }
    return key;
}

// SHADOW_PARAMS of cl/techniques/dsm.h: the views, each light's range of them (uploaded once per
// plan), then the backend's DSM_READ_PARAMS
void DeepShadowMaps::bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions&) const {
    if (light_views_buffer_() == nullptr)
        light_views_buffer_ = host::make_buffer(runtime, CL_MEM_READ_ONLY, light_views_.size() * sizeof(DsmLightViews),
                                                light_views_.data(), "DSM light views");
    args("views", dsm_.views_buffer)("light_views", light_views_buffer_);
    dsm_.storage->bind_for_reading(args);
}

std::vector<DeepShadowMap> DeepShadowMaps::read_back_maps(host::Runtime& runtime, std::size_t light) const {
    static const char* faces[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
    const DsmLightViews range = light_views_.at(light);
    std::vector<DeepShadowMap> maps;
    cl_uint in_cluster = 0;  // clustered maps: the view's index within its cluster
    for (cl_uint v = 0; v < range.count; ++v) {
        const DsmViewGpu& view = dsm_.views[range.first + v];
        DeepShadowMap map = shadows::read_back_map(runtime, dsm_, range.first + v);
        map.light = int(light);
        if (clusters_) {
            in_cluster = v > 0 && dsm_.views[range.first + v - 1].cluster == view.cluster ? in_cluster + 1 : 0;
            map.view_name = "cluster" + std::to_string(view.cluster) + "." + std::to_string(in_cluster);
        } else if (range.count == 6) {
            map.view_name = faces[v];
        }
        map.light_name = "lights[" + std::to_string(light) + "]" + (map.view_name.empty() ? "" : "." + map.view_name);
        shadows::place_map(view, map);
        maps.push_back(std::move(map));
    }
    return maps;
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
    stats.map_bytes_sent = map_bytes_sent_, stats.map_bytes_received = map_bytes_received_;
    if (clusters_) {
        add_cluster_stats(*clusters_, stats);
        stats.stage_ms["dsm_clustering"] = clustering_ms_;
    }
}

std::unique_ptr<ShadowModule> make_deep_shadow_maps(ShadowTechnique) { return std::make_unique<DeepShadowMaps>(); }

}  // namespace sombra::techniques
