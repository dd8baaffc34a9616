// sombra — the render options as data (sombra/options.h): the generic options' declarations, every
// module's gathered into one list, and the one place values are checked, parsed and shown.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <nlohmann/json.hpp>

#include "scene/suggest.h"
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/render.h"
#include "techniques/option_declarations.h"
#include "techniques/technique.h"

namespace sombra {
namespace {

using techniques::declare;
using techniques::declare_enum;

std::vector<std::pair<std::string, ShadowTechnique>> technique_values() {
    std::vector<std::pair<std::string, ShadowTechnique>> values;
    for (const std::string& name : shadow_technique_names()) values.emplace_back(name, parse_shadow_technique(name));
    return values;
}

std::string shadows_help() {
    std::string help = "the shadow technique:";
    for (const auto& [name, technique] : technique_values()) help += "\n  " + name + ": " + shadow_technique_summary(technique);
    return help;
}

// The options of the image and the camera pass (RenderOptions' own fields).
std::vector<OptionSpec> generic_option_specs() {
    static const std::string shadows = shadows_help();
    const std::vector<techniques::Declaration> d = {
        declare("width", "--width", [](auto& o) -> auto& { return o.width; }, "image width")
            .range(0, limits::kMaxImageSide).unit("pixels").special("0: the scene's"),
        declare("height", "--height", [](auto& o) -> auto& { return o.height; }, "image height")
            .range(0, limits::kMaxImageSide).unit("pixels").special("0: the scene's"),
        declare_enum<ShadowTechnique>("shadows", "--shadows", [](auto& o) -> auto& { return o.shadows; }, shadows.c_str(),
                                      technique_values()),
        declare_enum<ShadingModel>("shading", "--shading", [](auto& o) -> auto& { return o.shading; },
                                   "phong (gradient normals) or scattering (single scattering with shadows, Ament 2014 Eq. 1-3)",
                                   {{"phong", ShadingModel::Phong}, {"scattering", ShadingModel::Scattering}}),
        declare("phase_g", "--phase-g", [](auto& o) -> auto& { return o.phase_g; },
                "Henyey-Greenstein asymmetry g for --shading scattering")
            .range(-1, 1).open_min().open_max().special("0: isotropic"),
        declare_enum<GradientMethod>("gradient", "--gradient", [](auto& o) -> auto& { return o.gradient; }, "central or sobel",
                                     {{"central", GradientMethod::CentralDifferences}, {"sobel", GradientMethod::Sobel}}),
        declare_enum<ShadowCacheMode>("shadow_cache", "--shadow-cache", [](auto& o) -> auto& { return o.shadow_cache; },
                                      "the shadow term per volume and light on a lattice, filled by the technique, read "
                                      "trilinearly: on, off, or auto (on when a short probe of both finds the fill and the cached camera pass "
                                      "cheaper than evaluating the technique per sample; later runs of a frame choose by the times earlier runs recorded)",
                                      {{"auto", ShadowCacheMode::Auto}, {"on", ShadowCacheMode::On}, {"off", ShadowCacheMode::Off}}),
        declare_enum<ShadowCacheFill>("shadow_cache_fill", "--shadow-cache-fill", [](auto& o) -> auto& { return o.shadow_cache_fill; },
                                      "which lattice points a shadow cache fill evaluates: visible (those this frame's samples "
                                      "read, found by a marking camera pass; a frame from another view completes the lattice) or all "
                                      "(every point near a visible brick at once, no marking pass); the image is the same",
                                      {{"visible", ShadowCacheFill::Visible}, {"all", ShadowCacheFill::All}}),
        declare_enum<VolumeStorage>("volume_storage", "--volume-storage", [](auto& o) -> auto& { return o.volume_storage; },
                                    "auto (buffer on CPUs, image on GPUs), buffer or image",
                                    {{"auto", VolumeStorage::Auto}, {"buffer", VolumeStorage::Buffer}, {"image", VolumeStorage::Image}})
            .keys(),
        declare("empty_space_skipping", "--no-empty-space-skipping", [](auto& o) -> auto& { return o.empty_space_skipping; },
                "march empty bricks too (for comparisons)"),
        declare("termination_transmittance", "--termination", [](auto& o) -> auto& { return o.termination_transmittance; },
                "early ray termination: a camera ray stops when its transmittance falls below this")
            .range(0, 1).special("0: never"),
        declare("jitter_seed", "--seed", [](auto& o) -> auto& { return o.jitter_seed; }, "seed of the per-pixel ray jitter")
            .range(0, 4294967295.0),
        declare("lanes", "--lanes", [](auto& o) -> auto& { return o.lanes; },
                "rays per work-item in vector types (camera pass, DSM generation, low-pass table resampling): 1, 4, 8, 16, "
                "or 0: on CPUs 8 in the camera pass and the native float vector width in the light passes, 1 on GPUs")
            .choices({"0", "1", "4", "8", "16"}).keys(),
    };
    return std::vector<OptionSpec>(d.begin(), d.end());
}

// "1", "0.02", "1e+06": the shortest text that reads back as the value.
std::string number_text(double value) {
    if (value == std::floor(value) && std::fabs(value) < 1e15) return std::to_string((long long)value);
    std::ostringstream text;
    text.precision(9);
    text << value;
    return text.str();
}

std::string list_text(const std::vector<std::string>& names) {
    std::string text;
    for (const std::string& n : names) text += (text.empty() ? "" : ", ") + n;
    return text;
}

bool in_range(const OptionSpec& spec, double v) {
    const bool above = spec.min_open ? v > spec.min : v >= spec.min;
    const bool below = spec.max_open ? v < spec.max : v <= spec.max;
    return above && below;
}

std::string interval_text(const OptionSpec& spec) {
    return (spec.min_open ? "(" : "[") + number_text(spec.min) + ", " + number_text(spec.max) + (spec.max_open ? ")" : "]");
}

const char* kind_name(OptionKind kind) {
    switch (kind) {
        case OptionKind::Integer: return "an integer";
        case OptionKind::Real: return "a number";
        case OptionKind::Flag: return "true or false";
        case OptionKind::Choice: return "a name";
    }
    return "";
}

[[noreturn]] void refuse_kind(const OptionSpec& spec, const OptionValue& value, const std::string& label) {
    const std::string shown = std::holds_alternative<std::string>(value) ? "'" + std::get<std::string>(value) + "'" : option_value_text(value);
    throw Error(label + ": expected " + (spec.choices.empty() ? kind_name(spec.kind) : "one of " + list_text(spec.choices)) +
                ", got " + shown);
}

void check_choice(const OptionSpec& spec, const std::string& name, const std::string& label) {
    if (std::find(spec.choices.begin(), spec.choices.end(), name) != spec.choices.end()) return;
    const bool word = std::any_of(name.begin(), name.end(), [](unsigned char c) { return std::isalpha(c); });
    throw Error(label + ": unknown value '" + name + "' (" + list_text(spec.choices) + ")" +
                (word ? detail::did_you_mean(name, spec.choices) : ""));
}

}  // namespace

OptionValue OptionSpec::default_value() const { return get(RenderOptions{}); }

bool OptionSpec::applies_to(ShadowTechnique technique) const {
    return techniques.empty() || std::find(techniques.begin(), techniques.end(), technique) != techniques.end();
}

const std::vector<OptionSpec>& render_option_specs() {
    static const std::vector<OptionSpec> specs = [] {
        std::vector<OptionSpec> all = generic_option_specs();
        for (const auto* module : {&techniques::dsm_option_specs(), &techniques::sat_option_specs(), &techniques::ray_option_specs()})
            all.insert(all.end(), module->begin(), module->end());
        return all;
    }();
    return specs;
}

const OptionSpec* find_render_option(const std::string& name) {
    for (const OptionSpec& spec : render_option_specs())
        if (spec.key == name || spec.flag == name) return &spec;
    return nullptr;
}

OptionValue check_option_value(const OptionSpec& spec, const OptionValue& value, const std::string& label) {
    switch (spec.kind) {
        case OptionKind::Flag:
            if (!std::holds_alternative<bool>(value)) refuse_kind(spec, value, label);
            return value;
        case OptionKind::Choice:
            if (!std::holds_alternative<std::string>(value)) refuse_kind(spec, value, label);
            check_choice(spec, std::get<std::string>(value), label);
            return value;
        case OptionKind::Integer: {
            if (!std::holds_alternative<long long>(value)) refuse_kind(spec, value, label);
            const long long v = std::get<long long>(value);
            if (!spec.choices.empty()) check_choice(spec, std::to_string(v), label);
            else if (!in_range(spec, double(v)))
                throw Error(label + ": must lie in " + interval_text(spec) + ", got " + std::to_string(v));
            return value;
        }
        case OptionKind::Real: {
            double v = 0;
            if (std::holds_alternative<long long>(value)) v = double(std::get<long long>(value));
            else if (std::holds_alternative<double>(value)) v = std::get<double>(value);
            else refuse_kind(spec, value, label);
            if (!std::isfinite(v) || !in_range(spec, v) || std::fabs(v) > 3.4e38)
                throw Error(label + ": must lie in " + interval_text(spec) + ", got " + number_text(v));
            return OptionValue(v);
        }
    }
    return value;
}

OptionValue parse_option_text(const OptionSpec& spec, const std::string& text, const std::string& label) {
    switch (spec.kind) {
        case OptionKind::Flag:
            if (text == "true" || text == "on" || text == "1") return OptionValue(true);
            if (text == "false" || text == "off" || text == "0") return OptionValue(false);
            break;
        case OptionKind::Choice: return check_option_value(spec, OptionValue(text), label);
        case OptionKind::Integer: {
            errno = 0;
            char* end = nullptr;
            const long long v = std::strtoll(text.c_str(), &end, 10);
            if (!text.empty() && *end == '\0' && errno == 0) return check_option_value(spec, OptionValue(v), label);
            break;
        }
        case OptionKind::Real: {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (!text.empty() && *end == '\0') return check_option_value(spec, OptionValue(v), label);
            break;
        }
    }
    refuse_kind(spec, OptionValue(text), label);
}

void set_option(RenderOptions& options, const OptionSpec& spec, const OptionValue& value, const std::string& label) {
    spec.set(options, check_option_value(spec, value, label));
}

std::string option_value_text(const OptionValue& value) {
    if (const bool* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
    if (const long long* i = std::get_if<long long>(&value)) return std::to_string(*i);
    if (const double* d = std::get_if<double>(&value)) return number_text(*d);
    return std::get<std::string>(value);
}

std::string option_range_text(const OptionSpec& spec) {
    std::string text;
    if (spec.kind == OptionKind::Choice || (spec.kind == OptionKind::Integer && !spec.choices.empty()))
        text = "{" + list_text(spec.choices) + "}";
    else if (spec.kind != OptionKind::Flag)
        text = interval_text(spec);
    if (!spec.unit.empty()) text += " " + spec.unit;
    if (!spec.special.empty()) text += "; " + spec.special;
    return text;
}

void check_option_applies(const OptionSpec& spec, ShadowTechnique technique, const std::string& label,
                          const std::string& technique_label) {
    if (spec.applies_to(technique)) return;
    std::string names;
    for (ShadowTechnique t : spec.techniques) names += std::string(names.empty() ? "" : ", ") + shadow_technique_name(t);
    throw Error(label + ": applies to " + technique_label + names + ", not " + shadow_technique_name(technique));
}

std::vector<std::string> render_option_values(const std::string& key) {
    const OptionSpec* spec = find_render_option(key);
    if (spec && spec->kind == OptionKind::Choice) return spec->choices;
    std::vector<std::string> named;
    for (const OptionSpec& s : render_option_specs())
        if (s.kind == OptionKind::Choice) named.push_back(s.key);
    throw Error("unknown enumerated render option '" + key + "' (" + list_text(named) + ")" + detail::did_you_mean(key, named));
}

namespace {
// " (did you mean 'dsm_resolution'?)" for a misspelt key, "" when no key is close.
std::string closest_key(const std::string& key) {
    std::vector<std::string> keys;
    for (const OptionSpec& s : render_option_specs()) keys.push_back(s.key);
    return detail::did_you_mean(key, keys);
}

const OptionSpec& spec_of(const std::string& key) {
    if (const OptionSpec* spec = find_render_option(key)) return *spec;
    throw Error("unknown render option '" + key + "'" + closest_key(key));
}
}  // namespace

void set_render_option(RenderOptions& options, const std::string& key, const std::string& value) {
    const OptionSpec& spec = spec_of(key);
    spec.set(options, parse_option_text(spec, value, key));
}

std::string render_option_value(const RenderOptions& options, const std::string& key) {
    return option_value_text(spec_of(key).get(options));
}

void check_render_options(const RenderOptions& options) {
    for (const OptionSpec& spec : render_option_specs()) check_option_value(spec, spec.get(options), spec.key);
}

void set_render_option_json(RenderOptions& options, const std::string& key, const std::string& json_value, const std::string& where) {
    const std::string label = where + "." + key;
    const OptionSpec* spec = find_render_option(key);
    if (!spec || spec->key != key) throw Error(where + ": unknown key '" + key + "'" + closest_key(key));
    const nlohmann::json v = nlohmann::json::parse(json_value, nullptr, false);
    OptionValue value;
    if (v.is_boolean()) value = v.get<bool>();
    else if (v.is_number_integer() && (v.is_number_unsigned() ? v.get<unsigned long long>() <= 1ull << 62 : true))
        value = v.get<long long>();
    else if (v.is_number()) value = v.get<double>();
    else if (v.is_string()) value = v.get<std::string>();
    else throw Error(label + ": expected " + std::string(kind_name(spec->kind)) + ", got " + std::string(v.type_name()));
    set_option(options, *spec, value, label);
}

RenderOptions scene_render_options(const Scene& scene) {
    RenderOptions options;
    for (const auto& [key, text] : scene.render_settings) set_render_option_json(options, key, text, scene.source + ": render");
    return options;
}

}  // namespace sombra
