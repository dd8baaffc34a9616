// sombra — command-line renderer. Thin: parses arguments and calls the public library API.
#include <CLI/CLI.hpp>
#include "host/guarded_main.h"
#include <CL/opencl.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <cmath>
#include <iostream>
#include <sstream>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <tuple>
#include <unistd.h>
#include <variant>

#include <nlohmann/json.hpp>

#include "cli/clusters_command.h"
#include "cli/distributed_mpi.h"
#include "cli/info_command.h"
#include "cli/view_command.h"
#include "render/staged_outputs.h"
#include "scene/input_file.h"
#include "scene/suggest.h"
#include "sombra/sombra.h"

namespace {

const auto kStart = std::chrono::steady_clock::now();  // the whole command's wall clock starts here

void write_text_file(const std::string& path, const std::string& text) {
    std::ofstream out(path);
    if (!(out << text << '\n') || !(out.flush())) throw sombra::Error(path + ": cannot write file");
}

// "shadow cache off (auto: 1.1 × (fill ≈ 35.1 s + cached pass ≈ 0.6 s) ≥ per sample ≈ 12.8 s, measured
// in 0.42 s; surfaces on: 0.3 M points to fill, ≤ 0.5 M fragments); ", "shadow cache on, 0.94 M
// points this view reads filled, 2 lattices along the lights' rays (auto: …); " — what the frame did with
// the shadow cache and, for auto, why; nothing when the frame has no shadow term to cache.
std::string shadow_cache_note(const sombra::RenderStats& s, const sombra::RenderOptions& o) {
    if (!s.shadow_cache_used && s.shadow_cache_points_to_fill == 0 && s.shadow_cache_probe_ms == 0) return "";
    auto text = [](const char* format, double value) {
        char buffer[48];
        std::snprintf(buffer, sizeof buffer, format, value);
        return std::string(buffer);
    };
    std::string note = std::string("shadow cache ") + (s.shadow_cache_used ? "on" : "off");
    if (s.shadow_cache_used && s.shadow_cache_visible_fill)  // the visible fill (docs/shadows.md)
        note += text(", %.2f M points this view reads filled", double(s.shadow_cache_points_marked) / 1e6);
    if (s.shadow_cache_used && s.shadow_cache_light_lattices > 0)  // shadow rays' columns (docs/shadows.md)
        note += text(", %.0f lattices along the lights' rays", double(s.shadow_cache_light_lattices));
    if (o.shadow_cache == sombra::ShadowCacheMode::Auto) {
        std::vector<std::string> parts;
        if (s.shadow_cache_probe_ms > 0)
            parts.push_back(text("%.1f × ", sombra::kShadowCacheAutoMargin) + text("(fill ≈ %.2f s", s.shadow_cache_estimated_fill_ms / 1e3) +
                            text(" + cached pass ≈ %.2f s)", s.shadow_cache_estimated_cached_ms / 1e3) +
                            (s.shadow_cache_used ? " < " : " ≥ ") + text("per sample ≈ %.2f s", s.shadow_cache_estimated_per_sample_ms / 1e3) +
                            text(", measured in %.2f s", s.shadow_cache_probe_ms / 1e3));
        else if (s.shadow_cache_auto_remembered)
            parts.push_back("as this frame chose before");
        else if (s.shadow_cache_auto_history) {  // times of earlier runs (docs/shadows.md "Auto across processes")
            auto measured = [&](double ms) { return ms < 0 ? std::string("not run") : text("≈ %.2f s", ms / 1e3); };
            parts.push_back("earlier runs of this frame: on " + measured(s.shadow_cache_history_on_ms) + ", off " +
                            measured(s.shadow_cache_history_off_ms));
        }
        else if (s.shadow_cache_used && s.shadow_cache_points_to_fill == 0 && s.shadow_cache_entries_reused > 0)
            parts.push_back("filled before");
        if (s.shadow_cache_surface_points > 0)
            parts.push_back(std::string("surfaces ") + (s.shadow_cache_surfaces_used ? "on: " : "off: ") +
                            text("%.1f M points to fill, ≤ ", double(s.shadow_cache_surface_points_to_fill) / 1e6) +
                            text("%.1f M fragments", double(s.shadow_cache_estimated_fragments) / 1e6));
        std::string why;
        for (const std::string& part : parts) why += (why.empty() ? "" : "; ") + part;
        if (!why.empty()) note += " (auto: " + why + ")";
    }
    return note + "; ";
}

// The effective options of the command, as --stats writes them: every option the command has.
nlohmann::json options_json(const sombra::RenderOptions& o, unsigned command) {
    nlohmann::json j = nlohmann::json::object();
    for (const sombra::OptionSpec& spec : sombra::render_option_specs())
        if (spec.commands & command) std::visit([&](const auto& value) { j[spec.key] = value; }, spec.get(o));
    return j;
}

// What every --stats file holds besides the library's stats: the version, the scene as given, the
// effective options and the wall clock of the whole command (up to writing the stats).
struct StatsContext {
    std::string scene_path;
    sombra::RenderOptions options;
    unsigned command = sombra::kRenderCommand;
};

nlohmann::json command_stats(const sombra::RenderStats& stats, const StatsContext& context) {
    nlohmann::json j = nlohmann::json::parse(stats.to_json());
    j["version"] = SOMBRA_VERSION;
    j["scene"] = context.scene_path;
    j["options"] = options_json(context.options, context.command);
    j["total_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - kStart).count();
    return j;
}

// The wall clock of every progress stage the command went through, in order (a stage met again
// adds to its time), passed on to the stderr reporter unless --quiet.
struct StageTimes {
    std::vector<std::pair<std::string, double>> ms;
    sombra::ProgressCallback callback(bool quiet) {
        sombra::ProgressCallback print = quiet ? nullptr : sombra::text_progress(std::cerr, isatty(STDERR_FILENO) == 1);
        return [this, print](const sombra::ProgressReport& r) {
            if (r.done && !r.failed) {
                auto it = std::find_if(ms.begin(), ms.end(), [&](const auto& s) { return s.first == r.stage; });
                if (it == ms.end()) ms.emplace_back(r.stage, r.elapsed_ms);
                else it->second += r.elapsed_ms;
            }
            if (print) print(r);
        };
    }
    // "summed-area tables 9,657 ms, shadow cache 16,967 ms, camera pass 373 ms; longest: shadow cache 16,967 ms"
    std::string summary() const {
        std::string text;
        for (const auto& [stage, t] : ms) text += (text.empty() ? "" : ", ") + stage + " " + sombra::format_ms(t) + " ms";
        auto longest = std::max_element(ms.begin(), ms.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
        if (longest != ms.end()) text += "; longest: " + longest->first + " " + sombra::format_ms(longest->second) + " ms";
        return text;
    }
};

// --stats next to the other outputs: staged with them.
void stage_stats(sombra::detail::StagedOutputs& outputs, const std::string& stats_path, const nlohmann::json& stats) {
    if (!stats_path.empty())
        outputs.write(stats_path, [&](const std::string& path) { write_text_file(path, stats.dump(2)); });
}

// sombra dsm: one deep EXR per view of the light (a point light has six cube faces), all written
// (with the stats) before any takes its name.
int write_dsm(sombra::Context& context, const sombra::Scene& scene, int light, const StatsContext& stats_context,
              const std::string& output, const std::string& stats_path, bool quiet) {
    const sombra::RenderOptions& options = stats_context.options;
    sombra::RenderStats stats;
    auto maps = sombra::build_deep_shadow_maps(context, scene, light, options, &stats);
    if (maps.empty())  // clustered: every object misses B, so the light shadows nothing the camera sees
        throw sombra::Error("--light: light " + std::to_string(light) +
                            " has no deep shadow map (--clusters: no object can shadow what the camera sees)");
    std::filesystem::path out(output);
    sombra::detail::StagedOutputs outputs;
    std::vector<std::string> written;
    for (const sombra::DeepShadowMap& map : maps) {
        std::string path = output;
        if (maps.size() > 1)  // NAME.exr → NAME.+x.exr …, or NAME.cluster0.0.exr …
            path = (out.parent_path() / (out.stem().string() + "." + map.view_name + out.extension().string())).string();
        outputs.write(path, [&](const std::string& staged) { sombra::write_deep_exr(map, staged); });
        written.push_back(path + " (" + std::to_string(map.width) + "×" + std::to_string(map.height) + ", " +
                          std::to_string(map.nodes.size()) + " nodes)");
    }
    // no camera here: the stats describe this light's maps, not an image
    nlohmann::json j = command_stats(stats, stats_context);
    for (const char* camera_only : {"width", "height", "samples", "msamples_per_s"}) j.erase(camera_only);
    unsigned long long nodes = 0;
    for (const sombra::DeepShadowMap& map : maps) nodes += map.nodes.size();
    nlohmann::json& dsm_stats = j["dsm"];
    dsm_stats["light"] = light;
    dsm_stats["views"] = maps.size();
    dsm_stats["nodes"] = nodes;
    dsm_stats["resolution"] = maps.empty() ? 0 : maps.front().width;
    dsm_stats["mean_nodes_per_texel"] =
        maps.empty() ? 0.0 : double(nodes) / (double(maps.size()) * maps.front().width * maps.front().height);
    stage_stats(outputs, stats_path, j);
    outputs.commit();
    if (!quiet)
        for (const std::string& line : written) std::cerr << "sombra: wrote " << line << "\n";
    return 0;
}

// sombra visibility: per point, each technique's transmittance (deep shadow map, shadow ray,
// binary shadow map, low-pass filtered with --filter W), the brute-force reference, and their
// differences; then the mean and max error of each.
// The techniques `sombra visibility` compares, by their --shadows names, with their CSV columns.
const std::vector<std::tuple<std::string, const char*, sombra::ShadowTechnique>>& visibility_techniques() {
    static const std::vector<std::tuple<std::string, const char*, sombra::ShadowTechnique>> all = {
        {"dsm", "dsm", sombra::ShadowTechnique::Dsm},
        {"rays", "shadow_ray", sombra::ShadowTechnique::Rays},
        {"shadowmap", "shadow_map", sombra::ShadowTechnique::ShadowMap},
        {"lowpass", "lowpass", sombra::ShadowTechnique::Lowpass}};
    return all;
}

int print_visibility(sombra::Context& context, const sombra::Scene& scene, int light, const StatsContext& stats_context,
                     const std::vector<std::string>& asked, const std::string& points_path, const std::string& stats_path,
                     bool quiet) {
    const sombra::RenderOptions& options = stats_context.options;
    auto points = sombra::load_points_csv(points_path);
    std::vector<std::pair<const char*, sombra::ShadowTechnique>> techniques;  // those asked (all by default), in order
    for (const auto& [name, column, technique] : visibility_techniques())
        if (asked.empty() || std::find(asked.begin(), asked.end(), name) != asked.end()) techniques.emplace_back(column, technique);
    const int count = int(techniques.size());
    std::vector<sombra::ShadowQuery> queries;
    for (const auto& [name, technique] : techniques) {
        sombra::RenderOptions technique_options = options;
        technique_options.shadows = technique;
        queries.push_back(sombra::shadow_transmittance(context, scene, light, points, technique_options));
    }
    std::cout << "x,y,z,reference";
    for (const auto& t : techniques) std::cout << "," << t.first;
    for (const auto& t : techniques) std::cout << "," << t.first << "_error";
    std::cout << "\n";
    std::vector<double> sum(std::size_t(count), 0.0), worst(std::size_t(count), 0.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
        double reference = sombra::reference_transmittance(scene, light, points[i]);
        std::cout << points[i][0] << "," << points[i][1] << "," << points[i][2] << "," << reference;
        for (const auto& q : queries) std::cout << "," << q.transmittance[i];
        for (int k = 0; k < count; ++k) {
            double e = std::fabs(queries[std::size_t(k)].transmittance[i] - reference);
            sum[std::size_t(k)] += e, worst[std::size_t(k)] = std::max(worst[std::size_t(k)], e);
            std::cout << "," << e;
        }
        std::cout << "\n";
    }
    double n = double(std::max<std::size_t>(points.size(), 1));
    std::ostringstream summary;
    summary << "sombra: " << points.size() << " points; |T − reference| mean/max:";
    for (std::size_t k = 0; k < techniques.size(); ++k)
        summary << (k ? "," : "") << " " << techniques[k].first << " " << sum[k] / n << "/" << worst[k];
    summary << " (lowpass W " << options.sat.filter_width << ")\n";
    if (!quiet) std::cerr << summary.str();
    sombra::detail::StagedOutputs outputs;
    nlohmann::json j = command_stats(queries.front().stats, stats_context);  // the first technique's build
    stage_stats(outputs, stats_path, j);
    outputs.commit();
    return 0;
}

// A number of type T in [lo, hi], checked after conversion to T (CLI::Range lets NaN through, and
// an int option would wrap 4294967304 before a range check on the narrowed value).
template <typename T>
CLI::Validator in_range(T lo, T hi) {
    std::ostringstream range;
    range << "[" << lo << ", " << hi << "]";
    return CLI::Validator(
        [lo, hi, range = range.str()](std::string& text) {
            T value{};
            const bool ok = CLI::detail::lexical_cast(text, value) && value >= lo && value <= hi;
            return ok ? std::string() : "must lie in " + range + ", got " + text;
        },
        std::string(std::is_integral_v<T> ? "INT" : "NUMBER") + " in " + range.str());
}

// The command word: the first argument that is not an option (sombra itself has only --help and
// --version), "" when there is none.
std::string command_word(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return "";
}

// The first argument after the command word that looks like an option `command` does not have
// ("--shadow", "--shadow=dsm", "-x"; not "-7", not after "--"), "" when there is none. For sombra
// itself (no command word), every argument is looked at.
std::string unknown_option(const CLI::App& command, int argc, char** argv, std::vector<std::string>& known) {
    for (const CLI::Option* option : command.get_options()) {
        for (const std::string& name : option->get_lnames()) known.push_back("--" + name);
        for (const std::string& name : option->get_snames()) known.push_back("-" + name);
    }
    bool after_command = command.get_parent() == nullptr;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (!after_command) {
            after_command = arg == command.get_name();
            continue;
        }
        if (arg == "--") break;
        if (arg.size() < 2 || arg[0] != '-' || std::isdigit((unsigned char)arg[1]) || arg[1] == '.') continue;
        const std::string name = arg[1] == '-' ? arg.substr(0, arg.find('=')) : arg.substr(0, 2);
        if (std::find(known.begin(), known.end(), name) == known.end()) return name;
    }
    return "";
}

// One subcommand's render options, generated from their declarations (sombra/options.h): a flag
// per option, checked as it is parsed; the values the user gave, applied over the scene's
// "render" block once the scene is loaded.
struct RenderOptionFlags {
    unsigned command = 0;
    struct Given {
        const sombra::OptionSpec* spec;
        CLI::Option* option;
        std::string text;  // for options that take a value
    };
    std::vector<std::unique_ptr<Given>> options;
};

// A validator that runs the declaration's own check (CLI11 puts the flag in front of the message).
CLI::Validator declared_check(const sombra::OptionSpec& spec) {
    return CLI::Validator(
        [&spec](std::string& text) {
            try {
                sombra::parse_option_text(spec, text, spec.flag);
                return std::string();
            } catch (const sombra::Error& e) {
                return std::string(e.what()).substr(spec.flag.size() + 2);
            }
        },
        sombra::option_range_text(spec));
}

void add_render_options(CLI::App& app, unsigned command, RenderOptionFlags& flags) {
    flags.command = command;
    for (const sombra::OptionSpec& spec : sombra::render_option_specs()) {
        if (!(spec.commands & command)) continue;
        auto given = std::make_unique<RenderOptionFlags::Given>(RenderOptionFlags::Given{&spec, nullptr, {}});
        if (spec.kind == sombra::OptionKind::Flag) {  // a switch that sets the other value than the default
            given->option = app.add_flag(spec.flag, spec.help);
        } else {
            const char* type = spec.kind == sombra::OptionKind::Integer ? "INT" : spec.kind == sombra::OptionKind::Real ? "NUMBER" : "NAME";
            given->option = app.add_option(spec.flag, given->text, spec.help)
                                ->type_name(type)
                                ->default_str(sombra::option_value_text(spec.default_value()))
                                ->check(declared_check(spec));
        }
        flags.options.push_back(std::move(given));
    }
}

// The scene's "render" block, then the flags given. A flag that does not apply to the render's
// technique is refused (the scene file's block may hold options for other techniques).
sombra::RenderOptions effective_options(const RenderOptionFlags& flags, const sombra::Scene& scene) {
    sombra::RenderOptions options = sombra::scene_render_options(scene);
    for (const auto& given : flags.options) {
        if (given->option->count() == 0) continue;
        const sombra::OptionSpec& spec = *given->spec;
        if (spec.kind == sombra::OptionKind::Flag)
            sombra::set_option(options, spec, !std::get<bool>(spec.default_value()), spec.flag);
        else
            sombra::set_option(options, spec, sombra::parse_option_text(spec, given->text, spec.flag), spec.flag);
    }
    if (flags.command == sombra::kRenderCommand)
        for (const auto& given : flags.options)
            if (given->option->count() > 0) sombra::check_option_applies(*given->spec, options.shadows, given->spec->flag);
    return options;
}

// The options given as flags, by key, as a scene file's "render" block holds them; the image size
// is left out (a written scene holds it in "image").
nlohmann::json given_options_json(const RenderOptionFlags& flags) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& given : flags.options) {
        const sombra::OptionSpec& spec = *given->spec;
        if (given->option->count() == 0 || spec.key == "width" || spec.key == "height") continue;
        const sombra::OptionValue value = spec.kind == sombra::OptionKind::Flag ? sombra::OptionValue(!std::get<bool>(spec.default_value()))
                                                                                : sombra::parse_option_text(spec, given->text, spec.flag);
        std::visit([&](const auto& v) { j[spec.key] = v; }, value);
    }
    return j;
}

// Old spellings still accepted, each with a note: --storage (the DSM storage, now --dsm-storage)
// and --prefilter-jitter on|off|SEED (now --no-prefilter-jitter and --prefilter-seed).
std::vector<std::string> current_spellings(int argc, char** argv) {
    std::vector<std::string> args(argv, argv + argc);
    std::vector<std::string> out;
    for (std::size_t i = 0; i < args.size(); ++i) {
        std::string arg = args[i], value;
        const std::size_t equals = arg.find('=');
        const std::string name = arg.substr(0, equals);
        if (name != "--storage" && name != "--prefilter-jitter") {
            out.push_back(arg);
            continue;
        }
        if (equals != std::string::npos) value = arg.substr(equals + 1);
        else if (i + 1 < args.size()) value = args[++i];
        if (name == "--storage") {
            std::cerr << "sombra: note: --storage is now --dsm-storage (the deep shadow maps' storage)\n";
            out.insert(out.end(), {"--dsm-storage", value});
        } else {
            std::cerr << "sombra: note: --prefilter-jitter is now --no-prefilter-jitter / --prefilter-seed SEED\n";
            if (value == "off") out.push_back("--no-prefilter-jitter");
            else if (value != "on") out.insert(out.end(), {"--prefilter-seed", value});
        }
    }
    return out;
}

// A parse error: a misspelt command or option is named with the closest real one; else CLI11's line.
int parse_error(CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
    if (e.get_exit_code() == 0) return app.exit(e);
    const std::string command = command_word(argc, argv);
    std::vector<std::string> known;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) known.push_back(sub->get_name());
    if (!command.empty() && std::find(known.begin(), known.end(), command) == known.end()) {
        std::cerr << "sombra: error: unknown command '" << command << "'" << sombra::detail::did_you_mean(command, known) << "\n";
        return 2;
    }
    known.clear();
    const std::string option = unknown_option(command.empty() ? app : *app.get_subcommand(command), argc, argv, known);
    if (!option.empty()) {
        std::cerr << "sombra: error: unknown option '" << option << "'" << sombra::detail::did_you_mean(option, known) << "\n";
        return 2;
    }
    std::cerr << "sombra: error: " << e.what() << "\n";
    return 2;
}

// What the render, dsm and visibility commands share.
struct SceneCommandArgs {
    std::string scene_path, output, device = "auto", stats_path, non_finite = "reject", points_path;
    std::string preset = "auto", write_scene;  // render: a volume file's scene
    int light_index = 0;
    bool quiet = false;
    bool distributed = false;  // render: one region per rank of mpirun (docs/distributed.md)
};

void add_scene_command_args(CLI::App& sub, SceneCommandArgs& a) {
    sub.add_option("scene", a.scene_path,
                   "scene file (JSON), or a volume file (any format `sombra info` reads: rendered with a fitted camera, "
                   "a key light and a transfer function of --preset)")
        ->required();
    sub.add_option("--device", a.device, "auto, cpu, gpu, or an index from `sombra devices`");
    sub.add_option("--non-finite", a.non_finite, "NaN/Inf voxels: reject (error) or sanitize (set to 0, warn)")
        ->check(CLI::IsMember({"reject", "sanitize"}));
    sub.add_flag("-q,--quiet", a.quiet, "print nothing on stderr but errors (no progress, no summary)");
}

int list_devices() {
    auto list = sombra::list_devices();
    if (list.empty()) throw sombra::Error("no OpenCL device found (install pocl-opencl-icd: scripts/install-deps.sh)");
    for (auto& d : list)
        std::cout << d.index << ": " << d.name << " [" << d.platform << "] " << (d.is_gpu ? "GPU" : "CPU") << ", "
                  << d.opencl_c_version << ", " << (d.global_memory_bytes >> 20) << " MiB\n";
    return 0;
}

std::string lower_extension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return e;
}

// A wrong output name fails before the work, not after it.
void check_output_name(const std::string& output, bool image) {
    const std::string e = lower_extension(output);
    if (image && e != ".png" && e != ".exr") throw sombra::Error(output + ": output must end in .png or .exr");
    if (!image && e != ".exr")
        throw sombra::Error(output + ": a deep shadow map is written as OpenEXR: the name must end in .exr");
}

// --write-scene: the scene made for a volume file, its "render" block the options given as flags
// (the image size is the scene's), written with the image.
// --distributed: every rank renders its region, rank 0 writes what the others sent.
int render_image(sombra::Context& context, const sombra::Scene& scene, const StatsContext& stats_context, const SceneCommandArgs& a,
                 const StageTimes& stages, const nlohmann::json& given_options, sombra::cli::MpiRanks* ranks,
                 const sombra::VolumeLoadOptions& load) {
    const sombra::RenderOptions& options = stats_context.options;
    const std::string scene_text =
        a.write_scene.empty() ? "" : sombra::scene_file_text(scene, a.write_scene, given_options.dump());  // fails before the work
    sombra::RenderResult result;
    if (ranks) {
        result = sombra::render_distributed(context, scene, options, *ranks, load);
        ranks->finish();
        if (ranks->rank() != 0) return 0;
    } else {
        result = sombra::render(context, scene, options);
    }
    sombra::detail::StagedOutputs outputs;
    outputs.write(a.output, [&](const std::string& staged) { sombra::write_image(result.image, staged); });
    if (!a.write_scene.empty()) outputs.write(a.write_scene, [&](const std::string& staged) { write_text_file(staged, scene_text); });
    stage_stats(outputs, a.stats_path, command_stats(result.stats, stats_context));
    outputs.commit();
    if (!a.quiet)
        std::cerr << "sombra: wrote " << a.output << " (" << result.image.width << "×" << result.image.height << ", "
                  << result.stats.device << ", " << result.stats.msamples_per_s << " Msamples/s; "
                  << shadow_cache_note(result.stats, options) << stages.summary() << ")\n";
    return 0;
}

int run_scene_command(SceneCommandArgs& a, const RenderOptionFlags& flags, CLI::App* render, CLI::App* dsm, CLI::App* visibility,
                      const std::vector<std::string>& visibility_shadows, sombra::cli::MpiRanks* ranks);

int run(int argc_given, char** argv_given) {
    const std::vector<std::string> args = current_spellings(argc_given, argv_given);
    std::vector<char*> argv_current;
    for (const std::string& arg : args) argv_current.push_back(const_cast<char*>(arg.c_str()));
    const int argc = int(argv_current.size());
    char** argv = argv_current.data();

    CLI::App app{"sombra — volumetric shadows for scenes of volumes and translucent geometry"};
    app.require_subcommand(1);
    app.option_defaults()->always_capture_default();  // --help shows every default
    app.set_version_flag("--version", std::string("sombra ") + SOMBRA_VERSION, "print the version and exit");
    SceneCommandArgs a;
    CLI::App* render = app.add_subcommand(
        "render", "render a scene or a volume file to an image (PNG or EXR), with deep shadow maps unless --shadows says otherwise");
    CLI::App* devices = app.add_subcommand("devices", "list OpenCL platforms and devices");
    CLI::App* dsm = app.add_subcommand("dsm", "write one light's deep shadow map as a scanline deep OpenEXR");
    CLI::App* visibility = app.add_subcommand("visibility", "transmittance to a light at points: technique vs reference");
    render->add_option("-o,--output", a.output, "output image, .png (sRGB) or .exr (linear float)")->required();
    render->add_option("--stats", a.stats_path, "write per-stage times and sample counts as JSON");
    render->add_option("--preset", a.preset,
                       "a volume file's transfer function: ct, mri, fog, or auto (by the value range; docs/volume-scenes.md)")
        ->check(CLI::IsMember({"auto", "ct", "mri", "fog"}));
    render->add_option("--write-scene", a.write_scene,
                       "also write the scene made for a volume file as a scene file (JSON) to edit and render again");
    render->add_flag("--distributed", a.distributed,
                     "under `mpirun -np N`: each rank renders one region of the world, the ranks exchange their deep shadow "
                     "maps, rank 0 composites and writes (docs/distributed.md)");
    dsm->add_option("-o,--output", a.output,
                    "output .exr (a point light writes NAME.+x.exr … NAME.-z.exr; clustered maps NAME.cluster<k>.<j>.exr)")
        ->required();
    visibility->add_option("--points", a.points_path, "CSV file of x,y,z world points (one per line)")->required();
    std::vector<std::string> visibility_shadows;
    std::vector<std::string> visibility_names;
    for (const auto& technique : visibility_techniques()) visibility_names.push_back(std::get<0>(technique));
    visibility->add_option("--shadows", visibility_shadows, "the techniques to compare, comma-separated (default: all)")
        ->delimiter(',')
        ->check(CLI::IsMember(visibility_names));
    for (CLI::App* sub : {dsm, visibility}) {
        sub->add_option("--light", a.light_index, "light index in the scene")->required()->default_str("");  // no default to show
        sub->add_option("--stats", a.stats_path, "write build times and DSM sizes as JSON");
    }
    RenderOptionFlags render_flags, dsm_flags, visibility_flags;
    for (auto [sub, command, flags] : {std::tuple{render, sombra::kRenderCommand, &render_flags},
                                       std::tuple{dsm, sombra::kDsmCommand, &dsm_flags},
                                       std::tuple{visibility, sombra::kVisibilityCommand, &visibility_flags}}) {
        add_scene_command_args(*sub, a);
        add_render_options(*sub, command, *flags);
    }
    sombra::cli::InfoCommand info;
    sombra::cli::add_info_command(app, info);
    sombra::cli::ViewCommand view;
    sombra::cli::add_view_command(app, view);
    sombra::cli::ClustersCommand clusters;
    sombra::cli::add_clusters_command(app, clusters);
    clusters.app->get_option("--clusters")->check(in_range<int>(1, 64));
    clusters.app->get_option("--cluster-distance")->check(in_range<double>(0, 10));
    for (const char* size : {"--width", "--height"}) clusters.app->get_option(size)->check(in_range<int>(0, 16384));  // 0: the scene's
    clusters.app->get_option("--light")->check(in_range<int>(0, 1 << 20));

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        return parse_error(app, e, argc, argv);
    }
#ifdef SOMBRA_FUZZ_CLI  // fuzz/fuzz_cli.cpp: no device, and nothing written
    if (devices->parsed() || clusters.app->parsed() || view.app->parsed()) return 0;
#endif
    if (devices->parsed()) return list_devices();
    if (info.app->parsed()) return sombra::cli::run_info_command(info);
    if (view.app->parsed()) return sombra::cli::run_view_command(view);
    if (clusters.app->parsed()) return sombra::cli::run_clusters_command(clusters, sombra::load_scene(clusters.scene_path));

    std::unique_ptr<sombra::cli::MpiRanks> ranks;
    if (render->parsed() && a.distributed) ranks = sombra::cli::MpiRanks::start();
    try {
        return run_scene_command(a, render->parsed() ? render_flags : dsm->parsed() ? dsm_flags : visibility_flags, render, dsm,
                                 visibility, visibility_shadows, ranks.get());
    } catch (const sombra::OtherRankFailed&) {
        return 1;  // the rank that failed said why
    } catch (...) {
        if (ranks && ranks->open()) ranks->all_ok(false);  // the collective the other ranks wait in
        if (ranks && ranks->first_failed() >= 0 && ranks->first_failed() != ranks->rank()) return 1;  // a lower rank says it
        throw;
    }
}

// render, dsm and visibility: load the scene (or a volume file's), then the command's work.
int run_scene_command(SceneCommandArgs& a, const RenderOptionFlags& flags, CLI::App* render, CLI::App* dsm, CLI::App* visibility,
                      const std::vector<std::string>& visibility_shadows, sombra::cli::MpiRanks* ranks) {
    if (!visibility->parsed()) check_output_name(a.output, render->parsed());
    if (!a.write_scene.empty() && lower_extension(a.write_scene) != ".json")
        throw sombra::Error(a.write_scene + ": --write-scene: a scene file's name must end in .json");
    auto check_outputs = [&] { sombra::detail::StagedOutputs::check_targets({a.output, a.stats_path, a.write_scene}); };
    check_outputs();
    sombra::VolumeLoadOptions load;
    load.non_finite = a.non_finite == "sanitize" ? sombra::NonFinitePolicy::Sanitize : sombra::NonFinitePolicy::Reject;
    const bool volume_file = !sombra::is_scene_file(a.scene_path);
    for (const char* flag : {"--preset", "--write-scene"})
        if (!volume_file && render->count(flag) > 0)
            throw sombra::Error(std::string(flag) + ": applies to a volume file, not a scene (" + a.scene_path + ")");
    sombra::VolumeLoadOptions headers = load;  // --distributed: each rank reads its region of .npy, raw and NRRD (raw or gzip) volumes
    headers.header_only = ranks != nullptr;
    sombra::Scene scene = volume_file ? sombra::volume_scene(a.scene_path, sombra::parse_transfer_preset(a.preset), 512, 512, load).scene
                                      : sombra::load_scene(a.scene_path, headers);
    if (visibility->parsed()) sombra::detail::regular_file_size(a.points_path);  // an input, read below
    check_outputs();  // again, now that the inputs are known: no output may name one (before any work)
    sombra::RenderOptions options = effective_options(flags, scene);
    const int width = options.width > 0 ? options.width : scene.width, height = options.height > 0 ? options.height : scene.height;
    if (scene.camera_fitted && (width != scene.width || height != scene.height)) {  // fitted to the image it renders
        scene.width = width, scene.height = height;
        sombra::fit_scene_camera(scene, width, height);
        if (volume_file) scene.lights.front() = sombra::key_light(scene.camera), sombra::normalize_light_direction(scene.lights.front());
    }
#ifdef SOMBRA_FUZZ_CLI  // parsed, checked and loaded: what the CLI harness exercises
    return 0;
#endif
    sombra::Context context(a.device);
    StageTimes stages;
    options.progress = stages.callback(a.quiet || (ranks && ranks->rank() != 0));  // one rank reports
    const StatsContext stats_context{a.scene_path, options, flags.command};
    if (dsm->parsed()) return write_dsm(context, scene, a.light_index, stats_context, a.output, a.stats_path, a.quiet);
    if (visibility->parsed())
        return print_visibility(context, scene, a.light_index, stats_context, visibility_shadows, a.points_path, a.stats_path, a.quiet);
    if (ranks && !ranks->all_ok(true)) throw sombra::OtherRankFailed();  // every rank loaded the scene
    return render_image(context, scene, stats_context, a, stages, given_options_json(flags), ranks, load);
}

}  // namespace

#ifdef SOMBRA_FUZZ_CLI
int sombra_cli_run(int argc, char** argv) { return run(argc, argv); }  // errors escape to the harness
#else
int main(int argc, char** argv) { return sombra::host::guarded_main("sombra", run, argc, argv); }
#endif
