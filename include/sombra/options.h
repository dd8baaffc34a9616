// sombra — the render options as data: each option is declared once (OptionSpec) by the module that
// uses it (src/render/render_options.cpp for the image and camera pass; each shadow technique's
// module for its own), and everything else is generated from those declarations: the command
// line's flags and --help, the scene file's "render" block, the Python keyword arguments and
// RenderOptions properties, the one validation (and its message), the `options` of --stats, the
// modules' cache keys, and the "does not apply to this technique" check.
#pragma once
#include <functional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace sombra {

struct RenderOptions;
enum class ShadowTechnique;

enum class OptionKind { Integer, Real, Flag, Choice };

// A value as the user wrote it: a flag, an integer, a real number or a name.
using OptionValue = std::variant<bool, long long, double, std::string>;

// The subcommands an option belongs to (bits of OptionSpec::commands).
enum OptionCommand : unsigned { kRenderCommand = 1, kDsmCommand = 2, kVisibilityCommand = 4 };

struct OptionSpec {
    std::string key;    // "dsm_resolution": the scene file's "render" block, Python, the `options` of --stats
    std::string flag;   // "--dsm-res"; a flag defaulting to true is written --no-NAME and sets it false
    OptionKind kind = OptionKind::Real;
    std::string help;   // one line
    std::string unit;   // "texels", "voxels", "degrees", or ""
    // Integer and Real: the closed or open interval the value must lie in; special: what a value
    // with a meaning of its own means ("0: off").
    double min = 0, max = 0;
    bool min_open = false, max_open = false;
    std::string special;
    std::vector<std::string> choices;         // Choice: the names, in order
    std::vector<ShadowTechnique> techniques;  // those it applies to; empty: every technique
    bool keys_data = false;  // changing it rebuilds the scene's prepared data (the module's maps or tables)
    unsigned commands = kRenderCommand;
    std::function<OptionValue(const RenderOptions&)> get;
    std::function<void(RenderOptions&, const OptionValue&)> set;  // of a value check_option_value accepted

    OptionValue default_value() const;
    bool applies_to(ShadowTechnique technique) const;
};

// Every render option, the generic ones first, then each technique module's.
const std::vector<OptionSpec>& render_option_specs();
// By key ("dsm_resolution") or flag ("--dsm-res"); nullptr for neither.
const OptionSpec* find_render_option(const std::string& name);

// The checks, in one place and one message format: "LABEL: must lie in [1, 8192], got 0",
// "LABEL: unknown value 'dms' (atlas, chunked, …) (did you mean …?)", "LABEL: expected an
// integer, got 'x'". LABEL is how the user named the option: the flag, "FILE: render.KEY", or the
// Python argument. Returns the value as the option's kind holds it (an integer for a Real is a real).
OptionValue check_option_value(const OptionSpec& spec, const OptionValue& value, const std::string& label);
// The same from text ("512", "0.02", "on", "dsm").
OptionValue parse_option_text(const OptionSpec& spec, const std::string& text, const std::string& label);
void set_option(RenderOptions& options, const OptionSpec& spec, const OptionValue& value, const std::string& label);
// The value as text ("512", "0.02", "true", "dsm"), floats in their shortest form.
std::string option_value_text(const OptionValue& value);
// "[1, 8192] texels, 0: off" — the range, unit and special values, for help texts; "" for flags.
std::string option_range_text(const OptionSpec& spec);

// An option the user set that does not apply to the technique: "LABEL: applies to --shadows
// dsm, shadowmap, not rays" (the CLI and Python call it on the options they were given; Python
// names its keyword, `shadows=`, as `technique_label`).
void check_option_applies(const OptionSpec& spec, ShadowTechnique technique, const std::string& label,
                          const std::string& technique_label = "--shadows ");

}  // namespace sombra
