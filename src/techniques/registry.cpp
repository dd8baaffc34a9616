// sombra — the shadow-technique registry (technique.h) and the modules' defaults.
#include <ostream>

#include "scene/suggest.h"
#include "sombra/error.h"
#include "techniques/option_declarations.h"
#include "techniques/technique.h"

namespace sombra {
namespace techniques {

void ShadowModule::add_key(const RenderOptions&, int, std::ostream&) const {}

void add_option_keys(const std::vector<OptionSpec>& specs, const RenderOptions& options, std::ostream& key) {
    for (const OptionSpec& spec : specs)
        if (spec.keys_data) key << ' ' << spec.key << '=' << option_value_text(spec.get(options));
}
void ShadowModule::plan_lights(const Scene&, const packing::PackedScene&, const RenderOptions&) {}
void ShadowModule::prepare(const SceneOnDevice&, RenderStats&) {}
void ShadowModule::update_lights(const SceneOnDevice&, const std::vector<bool>&, RenderStats&) {}
void ShadowModule::refresh(const SceneOnDevice&, RenderStats&) {}
void ShadowModule::bind(host::KernelArgs&, host::Runtime&, const RenderOptions&) const {}
void ShadowModule::add_stats(RenderStats&) const {}
std::vector<std::string> ShadowModule::shadow_cache_keys(const SceneOnDevice&) const { return {}; }
std::string ShadowModule::light_data_key(std::size_t) const { return {}; }
std::vector<DeepShadowMap> ShadowModule::read_back_maps(host::Runtime&, std::size_t) const {
    throw Error("--shadows: this technique has no deep shadow maps to read back (internal error)");
}

const std::vector<TechniqueEntry>& registry() {
    static const std::vector<TechniqueEntry> entries = {
        {ShadowTechnique::None, "none", "no shadows: every light reaches every point", make_no_shadows},
        {ShadowTechnique::Rays, "rays", "shadow rays marched from every sample to every light (the baseline)", make_shadow_rays},
        {ShadowTechnique::Dsm, "dsm", "deep shadow maps (Hadwiger 2006, Knecht 2011)", make_deep_shadow_maps},
        {ShadowTechnique::ShadowMap, "shadowmap", "binary shadow maps with 2x2 percentage-closer filtering (baseline)",
         make_deep_shadow_maps},
        {ShadowTechnique::Lowpass, "lowpass", "low-pass filtered soft shadows from light-aligned summed-area tables (Ament 2014)",
         make_sat_shadows},
        {ShadowTechnique::Ao, "ao", "SAT ambient occlusion (baseline of Ament 2014)", make_sat_shadows},
        {ShadowTechnique::Cone, "cone", "cone shadows from a volume-aligned SAT (baseline of Ament 2014)", make_sat_shadows},
    };
    return entries;
}

const TechniqueEntry& entry(ShadowTechnique technique) {
    for (const TechniqueEntry& e : registry())
        if (e.technique == technique) return e;
    throw Error("--shadows: technique " + std::to_string(int(technique)) + " is not registered");
}

std::unique_ptr<ShadowModule> make_module(const Scene& scene, ShadowTechnique technique) {
    if (scene.lights.empty()) return make_no_shadows(ShadowTechnique::None);
    return entry(technique).make(technique);
}

}  // namespace techniques

std::vector<std::string> shadow_technique_names() {
    std::vector<std::string> names;
    for (const techniques::TechniqueEntry& e : techniques::registry()) names.push_back(e.name);
    return names;
}

const char* shadow_technique_name(ShadowTechnique technique) { return techniques::entry(technique).name; }
const char* shadow_technique_summary(ShadowTechnique technique) { return techniques::entry(technique).summary; }

ShadowTechnique parse_shadow_technique(const std::string& name) {
    for (const techniques::TechniqueEntry& e : techniques::registry())
        if (name == e.name) return e.technique;
    std::string message = "--shadows: unknown technique '" + name + "'";
    std::string close = detail::closest_name(name, shadow_technique_names());
    if (!close.empty()) message += " (did you mean " + close + "?)";
    message += "; expected one of:";
    for (const std::string& n : shadow_technique_names()) message += " " + n;
    throw Error(message);
}

}  // namespace sombra
