// sombra — the enumerated render options by name (render.h: render_option_values and friends): the
// one list the command line, --stats and the Python module share.
#include <algorithm>
#include <functional>
#include <sstream>
#include <utility>

#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra {
namespace {

// One enumerated option: its value names in order, and how to read and write it in RenderOptions.
struct EnumOption {
    const char* option;
    const char* flag;  // on the command line, for errors
    std::vector<std::pair<std::string, int>> values;
    std::function<int(const RenderOptions&)> get;
    std::function<void(RenderOptions&, int)> set;
    std::function<std::string(const RenderOptions&)> shown;  // the value as set, for errors
};

template <typename E, E RenderOptions::*field>
EnumOption enum_option(const char* option, const char* flag, std::vector<std::pair<std::string, E>> values) {
    EnumOption o{option, flag, {}, [](const RenderOptions& r) { return int(r.*field); },
                 [](RenderOptions& r, int v) { r.*field = E(v); }, [](const RenderOptions& r) { return std::to_string(int(r.*field)); }};
    for (const auto& [name, value] : values) o.values.emplace_back(name, int(value));
    return o;
}

// An option held as its name in RenderOptions (std::string): value i is names[i]; a name not in
// the list reads as −1.
template <std::string RenderOptions::*field>
EnumOption named_option(const char* option, const char* flag, const std::vector<std::string>& names) {
    EnumOption o{option, flag, {},
                 [names](const RenderOptions& r) {
                     auto it = std::find(names.begin(), names.end(), r.*field);
                     return it == names.end() ? -1 : int(it - names.begin());
                 },
                 [names](RenderOptions& r, int v) { r.*field = names[std::size_t(v)]; },
                 [](const RenderOptions& r) { return "'" + r.*field + "'"; }};
    for (std::size_t i = 0; i < names.size(); ++i) o.values.emplace_back(names[i], int(i));
    return o;
}

// the shadow techniques: the registry of technique modules (src/techniques/registry.cpp)
std::vector<std::pair<std::string, ShadowTechnique>> technique_values() {
    std::vector<std::pair<std::string, ShadowTechnique>> values;
    for (const std::string& name : shadow_technique_names()) values.emplace_back(name, parse_shadow_technique(name));
    return values;
}

const std::vector<EnumOption>& enum_options() {
    static const std::vector<EnumOption> options = {
        enum_option<ShadowTechnique, &RenderOptions::shadows>("shadows", "--shadows", technique_values()),
        enum_option<GradientMethod, &RenderOptions::gradient>(
            "gradient", "--gradient", {{"central", GradientMethod::CentralDifferences}, {"sobel", GradientMethod::Sobel}}),
        enum_option<ShadingModel, &RenderOptions::shading>(
            "shading", "--shading", {{"phong", ShadingModel::Phong}, {"scattering", ShadingModel::Scattering}}),
        enum_option<VolumeStorage, &RenderOptions::storage>(
            "storage", "--volume-storage", {{"auto", VolumeStorage::Auto}, {"buffer", VolumeStorage::Buffer}, {"image", VolumeStorage::Image}}),
        named_option<&RenderOptions::dsm_storage>("dsm_storage", "--storage", dsm_storage_names()),
        named_option<&RenderOptions::dsm_lookup>("dsm_lookup", "--dsm-lookup", {"packed", "native"}),
        named_option<&RenderOptions::dsm_prefilter>("dsm_prefilter", "--prefilter", {"none", "box", "tent", "5tap"}),
        named_option<&RenderOptions::lowpass_filter_kernel>("lowpass_filter_kernel", "--filter-kernel", {"box", "gauss"}),
        enum_option<ShadowCacheMode, &RenderOptions::shadow_cache>(
            "shadow_cache", "--shadow-cache", {{"auto", ShadowCacheMode::Auto}, {"on", ShadowCacheMode::On}, {"off", ShadowCacheMode::Off}}),
    };
    return options;
}

const EnumOption& find_option(const std::string& option) {
    std::string known;
    for (const EnumOption& o : enum_options()) {
        if (o.option == option) return o;
        known += std::string(known.empty() ? "" : ", ") + o.option;
    }
    throw Error("unknown enumerated render option '" + option + "' (" + known + ")");
}

}  // namespace

std::vector<std::string> render_option_values(const std::string& option) {
    std::vector<std::string> names;
    for (const auto& value : find_option(option).values) names.push_back(value.first);
    return names;
}

void set_render_option(RenderOptions& options, const std::string& option, const std::string& value) {
    const EnumOption& o = find_option(option);
    std::string known;
    for (const auto& [name, v] : o.values) {
        if (name == value) return o.set(options, v);
        known += (known.empty() ? "" : ", ") + name;
    }
    throw Error(option + ": unknown value '" + value + "' (" + known + ")");
}

std::string render_option_value(const RenderOptions& options, const std::string& option) {
    const EnumOption& o = find_option(option);
    for (const auto& [name, v] : o.values)
        if (v == o.get(options)) return name;
    return "?";
}

void check_render_options(const RenderOptions& options) {
    for (const EnumOption& o : enum_options()) {
        int value = o.get(options);
        if (std::any_of(o.values.begin(), o.values.end(), [&](const auto& v) { return v.second == value; })) continue;
        std::string known;
        for (const auto& v : o.values) known += (known.empty() ? "" : ", ") + v.first;
        throw Error(std::string(o.flag) + ": unknown value " + o.shown(options) + " (" + known + ")");
    }
    if (!(options.shadow_ray_step > 0.f && options.shadow_ray_step <= 16.f)) {
        std::ostringstream got;
        got << options.shadow_ray_step;
        throw Error("--ray-step: must lie in (0, 16], got " + got.str());
    }
    if (!(options.dsm_step > 0.f && options.dsm_step <= 16.f)) {
        std::ostringstream got;
        got << options.dsm_step;
        throw Error("--dsm-step: must lie in (0, 16], got " + got.str());
    }
    if (options.dsm_clusters < 0 || options.dsm_clusters > 64)
        throw Error("--clusters: must lie in [0, 64] (0: off), got " + std::to_string(options.dsm_clusters));
    if (!(options.dsm_cluster_distance >= 0.f && options.dsm_cluster_distance <= 10.f)) {
        std::ostringstream got;
        got << options.dsm_cluster_distance;
        throw Error("--cluster-distance: must lie in [0, 10] (0: automatic), got " + got.str());
    }
    if (!(options.dsm_cluster_hysteresis >= 0.f && options.dsm_cluster_hysteresis <= 10.f)) {
        std::ostringstream got;
        got << options.dsm_cluster_hysteresis;
        throw Error("--cluster-hysteresis: must lie in [0, 10], got " + got.str());
    }
}

}  // namespace sombra
