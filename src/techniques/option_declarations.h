// sombra — declaring a render option (sombra/options.h) in one statement: the field it sets, found
// by an accessor, gives its kind, default, getter and setter; the chained calls add the rest.
//   declare("dsm_resolution", "--dsm-res", [](auto& o) -> auto& { return o.dsm.resolution; },
//           "deep shadow map texels per side").range(1, 8192).unit("texels").only(kDsmTechniques).keys()
#pragma once
#include <charconv>
#include <cstdlib>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "sombra/options.h"
#include "sombra/render.h"

namespace sombra::techniques {

// A float as the double of its shortest decimal form (0.02f → 0.02, not 0.0199999996).
inline double shortest_decimal(float value) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, value).ptr;
    return std::strtod(std::string(text, end).c_str(), nullptr);
}

struct Declaration {
    OptionSpec spec;
    Declaration& range(double min, double max) { return spec.min = min, spec.max = max, *this; }
    Declaration& open_min() { return spec.min_open = true, *this; }
    Declaration& open_max() { return spec.max_open = true, *this; }
    Declaration& special(const char* meaning) { return spec.special = meaning, *this; }
    Declaration& unit(const char* unit) { return spec.unit = unit, *this; }
    Declaration& choices(std::vector<std::string> names) { return spec.choices = std::move(names), *this; }
    Declaration& only(std::vector<ShadowTechnique> techniques) { return spec.techniques = std::move(techniques), *this; }
    Declaration& keys() { return spec.keys_data = true, *this; }
    Declaration& commands(unsigned mask) { return spec.commands = mask, *this; }
    operator OptionSpec() const { return spec; }
};

// An option of a bool, integer, float or std::string (a Choice: add .choices) field.
template <typename Access>
Declaration declare(const char* key, const char* flag, Access access, const char* help) {
    using T = std::decay_t<decltype(access(std::declval<RenderOptions&>()))>;
    Declaration d;
    d.spec.key = key, d.spec.flag = flag, d.spec.help = help;
    if constexpr (std::is_same_v<T, bool>) {
        d.spec.kind = OptionKind::Flag;
        d.spec.get = [access](const RenderOptions& o) { return OptionValue(bool(access(o))); };
        d.spec.set = [access](RenderOptions& o, const OptionValue& v) { access(o) = std::get<bool>(v); };
    } else if constexpr (std::is_integral_v<T>) {
        d.spec.kind = OptionKind::Integer;
        d.spec.get = [access](const RenderOptions& o) { return OptionValue((long long)access(o)); };
        d.spec.set = [access](RenderOptions& o, const OptionValue& v) { access(o) = T(std::get<long long>(v)); };
    } else if constexpr (std::is_floating_point_v<T>) {
        d.spec.kind = OptionKind::Real;
        d.spec.get = [access](const RenderOptions& o) { return OptionValue(shortest_decimal(access(o))); };
        d.spec.set = [access](RenderOptions& o, const OptionValue& v) { access(o) = T(std::get<double>(v)); };
    } else {
        static_assert(std::is_same_v<T, std::string>, "an option is a bool, an integer, a float or a name");
        d.spec.kind = OptionKind::Choice;
        d.spec.get = [access](const RenderOptions& o) { return OptionValue(access(o)); };
        d.spec.set = [access](RenderOptions& o, const OptionValue& v) { access(o) = std::get<std::string>(v); };
    }
    return d;
}

// An option of an enum field, its values by name.
template <typename E, typename Access>
Declaration declare_enum(const char* key, const char* flag, Access access, const char* help,
                         std::vector<std::pair<std::string, E>> values) {
    Declaration d;
    d.spec.key = key, d.spec.flag = flag, d.spec.help = help, d.spec.kind = OptionKind::Choice;
    for (const auto& value : values) d.spec.choices.push_back(value.first);
    d.spec.get = [access, values](const RenderOptions& o) {
        for (const auto& [name, value] : values)
            if (value == access(o)) return OptionValue(name);
        return OptionValue(std::to_string(int(access(o))));  // not a declared value: check_render_options names it
    };
    d.spec.set = [access, values](RenderOptions& o, const OptionValue& v) {
        for (const auto& [name, value] : values)
            if (name == std::get<std::string>(v)) access(o) = value;
    };
    return d;
}

// The module's part of the preparation key: every option it declares that keys its data.
void add_option_keys(const std::vector<OptionSpec>& specs, const RenderOptions& options, std::ostream& key);

// The modules' declarations (each in its module's .cpp), and all of them in order.
const std::vector<OptionSpec>& dsm_option_specs();
const std::vector<OptionSpec>& sat_option_specs();
const std::vector<OptionSpec>& ray_option_specs();

}  // namespace sombra::techniques
