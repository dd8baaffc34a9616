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
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "cli/clusters_command.h"
#include "render/staged_outputs.h"
#include "scene/input_file.h"
#include "scene/suggest.h"
#include "sombra/sombra.h"

namespace {

// The enumerated options' names: the library's list (render.h render_option_values).
// A near miss gets a suggestion ("dms is not one of … (did you mean dsm?)").
CLI::Validator member_of(const char* option) {
    std::vector<std::string> names = sombra::render_option_values(option);
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ",") + n;
    return CLI::Validator(
        [names, list](std::string& value) -> std::string {
            if (std::find(names.begin(), names.end(), value) != names.end()) return "";
            std::string close = sombra::detail::closest_name(value, names);
            return value + " is not one of {" + list + "}" + (close.empty() ? "" : " (did you mean " + close + "?)");
        },
        "{" + list + "}");
}

const auto kStart = std::chrono::steady_clock::now();  // the whole command's wall clock starts here

void write_text_file(const std::string& path, const std::string& text) {
    std::ofstream out(path);
    if (!(out << text << '\n') || !(out.flush())) throw sombra::Error(path + ": cannot write file");
}

// A float as the JSON number of its shortest decimal form (0.02f → 0.02, not 0.0199999996).
double decimal(float value) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, value).ptr;
    return std::strtod(std::string(text, end).c_str(), nullptr);
}

// "shadow cache on (auto: 1.2 M points to fill, ≈ 15.7 M samples; surfaces on: 0.3 M points to
// fill, ≤ 0.5 M fragments); " — what the frame did with
// the shadow cache and, for auto, why; nothing when the frame has no shadow term to cache.
std::string shadow_cache_note(const sombra::RenderStats& s, const sombra::RenderOptions& o) {
    if (!s.shadow_cache_used && s.shadow_cache_points_to_fill == 0) return "";
    std::string note = std::string("shadow cache ") + (s.shadow_cache_used ? "on" : "off");
    if (o.shadow_cache == sombra::ShadowCacheMode::Auto) {
        auto millions = [](unsigned long long n) {
            char text[32];
            std::snprintf(text, sizeof text, "%.1f", double(n) / 1e6);
            return std::string(text);
        };
        note += " (auto: " + millions(s.shadow_cache_points_to_fill) + " M points to fill, ≈ " +
                millions(s.shadow_cache_estimated_samples) + " M samples";
        if (s.shadow_cache_surface_points > 0)
            note += std::string("; surfaces ") + (s.shadow_cache_surfaces_used ? "on: " : "off: ") +
                    millions(s.shadow_cache_surface_points_to_fill) + " M points to fill, ≤ " +
                    millions(s.shadow_cache_estimated_fragments) + " M fragments";
        note += ")";
    }
    return note + "; ";
}

// The effective options of the command, as --stats writes them.
nlohmann::json options_json(const sombra::RenderOptions& o) {
    return {{"width", o.width},
            {"height", o.height},
            {"shadows", sombra::render_option_value(o, "shadows")},
            {"shading", sombra::render_option_value(o, "shading")},
            {"gradient", sombra::render_option_value(o, "gradient")},
            {"phase_g", decimal(o.phase_g)},
            {"dsm_resolution", o.dsm_resolution},
            {"dsm_epsilon", decimal(o.dsm_epsilon)},
            {"dsm_step", decimal(o.dsm_step)},
            {"dsm_storage", o.dsm_storage},
            {"dsm_lookup", o.dsm_lookup},
            {"dsm_precompression", o.dsm_precompression},
            {"dsm_prefilter", o.dsm_prefilter},
            {"dsm_prefilter_jitter", o.dsm_prefilter_jitter},
            {"dsm_prefilter_seed", o.dsm_prefilter_seed},
            {"dsm_clusters", o.dsm_clusters},
            {"dsm_cluster_distance", decimal(o.dsm_cluster_distance)},
            {"dsm_cluster_hysteresis", decimal(o.dsm_cluster_hysteresis)},
            {"lowpass_filter_width", decimal(o.lowpass_filter_width)},
            {"lowpass_filter_kernel", o.lowpass_filter_kernel},
            {"shadow_cache", sombra::render_option_value(o, "shadow_cache")},
            {"cone_angle_deg", decimal(o.cone_angle_deg)},
            {"shadow_ray_step", decimal(o.shadow_ray_step)},
            {"storage", sombra::render_option_value(o, "storage")},
            {"empty_space_skipping", o.empty_space_skipping},
            {"termination_transmittance", decimal(o.termination_transmittance)},
            {"jitter_seed", o.jitter_seed},
            {"lanes", o.lanes}};
}

// What every --stats file holds besides the library's stats: the version, the scene as given, the
// effective options and the wall clock of the whole command (up to writing the stats).
struct StatsContext {
    std::string scene_path;
    sombra::RenderOptions options;
};

nlohmann::json command_stats(const sombra::RenderStats& stats, const StatsContext& context) {
    nlohmann::json j = nlohmann::json::parse(stats.to_json());
    j["version"] = SOMBRA_VERSION;
    j["scene"] = context.scene_path;
    j["options"] = options_json(context.options);
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
        if (maps.size() > 1) {  // NAME.exr → NAME.+x.exr …, or NAME.cluster0.0.exr … (lights[i].<view>)
            std::string face = map.light_name.substr(map.light_name.find("].") + 2);
            path = (out.parent_path() / (out.stem().string() + "." + face + out.extension().string())).string();
        }
        outputs.write(path, [&](const std::string& staged) { sombra::write_deep_exr(map, staged); });
        written.push_back(path + " (" + std::to_string(map.width) + "×" + std::to_string(map.height) + ", " +
                          std::to_string(map.nodes.size()) + " nodes)");
    }
    // no camera here: the stats describe this light's maps, not an image
    nlohmann::json j = command_stats(stats, stats_context);
    for (const char* camera_only : {"width", "height", "samples", "msamples_per_s"}) j.erase(camera_only);
    for (const char* camera_only : {"width", "height", "shadows", "shading", "gradient", "phase_g", "jitter_seed",
                                    "termination_transmittance", "lowpass_filter_width", "lowpass_filter_kernel",
                                    "shadow_cache", "cone_angle_deg", "shadow_ray_step"})
        j["options"].erase(camera_only);
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
int print_visibility(sombra::Context& context, const sombra::Scene& scene, int light, const StatsContext& stats_context,
                     const std::string& points_path, const std::string& stats_path, bool quiet) {
    const sombra::RenderOptions& options = stats_context.options;
    auto points = sombra::load_points_csv(points_path);
    const std::pair<const char*, sombra::ShadowTechnique> techniques[] = {{"dsm", sombra::ShadowTechnique::Dsm},
                                                                          {"shadow_ray", sombra::ShadowTechnique::Rays},
                                                                          {"shadow_map", sombra::ShadowTechnique::ShadowMap},
                                                                          {"lowpass", sombra::ShadowTechnique::Lowpass}};
    constexpr int count = 4;
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
    double sum[count] = {}, worst[count] = {};
    for (std::size_t i = 0; i < points.size(); ++i) {
        double reference = sombra::reference_transmittance(scene, light, points[i]);
        std::cout << points[i][0] << "," << points[i][1] << "," << points[i][2] << "," << reference;
        for (const auto& q : queries) std::cout << "," << q.transmittance[i];
        for (int k = 0; k < count; ++k) {
            double e = std::fabs(queries[std::size_t(k)].transmittance[i] - reference);
            sum[k] += e, worst[k] = std::max(worst[k], e);
            std::cout << "," << e;
        }
        std::cout << "\n";
    }
    double n = double(std::max<std::size_t>(points.size(), 1));
    std::ostringstream summary;
    summary << "sombra: " << points.size() << " points; |T − reference| mean/max:";
    for (int k = 0; k < count; ++k) summary << (k ? "," : "") << " " << techniques[k].first << " " << sum[k] / n << "/" << worst[k];
    summary << " (lowpass W " << options.lowpass_filter_width << ")\n";
    if (!quiet) std::cerr << summary.str();
    sombra::ShadowQuery& dsm = queries.front();
    sombra::detail::StagedOutputs outputs;
    nlohmann::json j = command_stats(dsm.stats, stats_context);
    // every technique was asked, at points rather than pixels: no camera options
    for (const char* camera_only : {"width", "height", "shadows", "shading", "gradient", "phase_g", "jitter_seed"})
        j["options"].erase(camera_only);
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

int run(int argc, char** argv) {
    CLI::App app{"sombra — volumetric shadows for scenes of volumes and translucent geometry"};
    app.require_subcommand(1);
    app.option_defaults()->always_capture_default();  // --help shows every default (before the subcommands copy it)
    const sombra::RenderOptions defaults;               // the one source of the defaults
    app.set_version_flag("--version", std::string("sombra ") + SOMBRA_VERSION, "print the version and exit");

    std::string scene_path, output, device = "auto", stats_path, non_finite = "reject";
    std::string gradient = sombra::render_option_value(defaults, "gradient"), storage = sombra::render_option_value(defaults, "storage");
    int width = defaults.width, height = defaults.height;
    unsigned seed = defaults.jitter_seed;
    bool no_skip = !defaults.empty_space_skipping;
    CLI::App* render = app.add_subcommand("render", "render a scene to an image (PNG or EXR)");
    render->add_option("scene", scene_path, "scene file (JSON)")->required();
    render->add_option("-o,--output", output, "output image, .png (sRGB) or .exr (linear float)")->required();
    const CLI::Validator image_side = in_range<int>(1, sombra::limits::kMaxImageSide);
    render->add_option("--width", width, "image width (default: the scene's)")->check(image_side);
    render->add_option("--height", height, "image height (default: the scene's)")->check(image_side);
    render->add_option("--device", device, "auto, cpu, gpu, or an index from `sombra devices`");
    render->add_option("--stats", stats_path, "write per-stage times and sample counts as JSON");
    render->add_option("--gradient", gradient, "central or sobel")->check(member_of("gradient"));
    std::string shading = sombra::render_option_value(defaults, "shading");
    float phase_g = defaults.phase_g;
    render->add_option("--shading", shading,
                       "phong (gradient normals) or scattering (single scattering with shadows, Ament 2014 Eq. 1-3)")
        ->check(member_of("shading"));
    render->add_option("--phase-g", phase_g, "Henyey-Greenstein asymmetry g in (-1, 1) for --shading scattering (0: isotropic)");
    std::string shadows = sombra::render_option_value(defaults, "shadows");
    std::string shadows_help = "the shadow technique:";
    for (const std::string& name : sombra::render_option_values("shadows"))
        shadows_help += "\n  " + name + ": " + sombra::shadow_technique_summary(sombra::parse_shadow_technique(name));
    render->add_option("--shadows", shadows, shadows_help)->check(member_of("shadows"));
    float filter_width = defaults.lowpass_filter_width;
    render->add_option("--filter", filter_width, "lowpass: filter width in voxels (softness of the shadows); ao: cube side")
        ->check(in_range<float>(0, 4096));
    float cone_angle = defaults.cone_angle_deg;
    std::string shadow_cache = sombra::render_option_value(defaults, "shadow_cache");
    render->add_option("--shadow-cache", shadow_cache,
                       "the shadow term per volume and light on a lattice, filled by the technique, read trilinearly: on, off, "
                       "or auto (on when filling it costs fewer points than the frame's samples)")
        ->check(member_of("shadow_cache"));
    render->add_option("--cone-angle", cone_angle, "cone: half angle of the shadow cones in degrees")->check(in_range<float>(0.01f, 60));
    float ray_step = defaults.shadow_ray_step;
    render->add_option("--ray-step", ray_step, "rays: factor on each volume's step for the shadow rays, in (0, 16] (< 1: finer)")
        ->check(in_range<float>(1e-6f, 16));
    std::string filter_kernel = defaults.lowpass_filter_kernel;
    render->add_option("--filter-kernel", filter_kernel, "lowpass: box (one SAT box) or gauss (5×5 sub-boxes, Ament Eq. 25)")
        ->check(member_of("lowpass_filter_kernel"));
    int dsm_resolution = defaults.dsm_resolution;
    float dsm_epsilon = defaults.dsm_epsilon;
    std::string dsm_storage = defaults.dsm_storage;
    std::string dsm_lookup = defaults.dsm_lookup;
    const char* dsm_lookup_help = "DSM lookups: packed (each texel's nodes copied into one run after generation) or native "
                                  "(in the storage's own layout)";
    bool precompression = defaults.dsm_precompression;
    std::string prefilter = defaults.dsm_prefilter;
    render->add_option("--dsm-res", dsm_resolution, "deep shadow map texels per side")->check(in_range<int>(1, 8192));
    render->add_option("--storage", dsm_storage, "deep shadow map storage: atlas, chunked, chunked-ondemand (Knecht) or compact")
        ->check(member_of("dsm_storage"));
    render->add_option("--dsm-lookup", dsm_lookup, dsm_lookup_help)->check(member_of("dsm_lookup"));
    render->add_flag("--precompression", precompression, "pre-compressed visibility tables for DSM generation (Hadwiger §3.2)");
    std::string prefilter_jitter = !defaults.dsm_prefilter_jitter ? "off"
                                   : defaults.dsm_prefilter_seed == 1 ? "on"
                                                                      : std::to_string(defaults.dsm_prefilter_seed);
    render->add_option("--prefilter", prefilter,
                       "DSM pre-filtering: none, box (2×2 sub-pixel rays), tent (4×4) or 5tap (centre + 4 corners)")
        ->check(member_of("dsm_prefilter"));
    render->add_option("--prefilter-jitter", prefilter_jitter, "jittered sub-pixel rays: on (seed 1), off, or a seed");
    render->add_option("--eps", dsm_epsilon, "deep shadow map compression error bound ε (Knecht Eq. 3.1)")
        ->check(in_range<float>(0, 1e6f));
    float dsm_step = defaults.dsm_step;
    const char* dsm_step_help = "DSM generation: factor on each volume's step for the rays from the light, in (0, 16] (> 1: faster, coarser)";
    render->add_option("--dsm-step", dsm_step, dsm_step_help)->check(in_range<float>(1e-6f, 16));
    int dsm_clusters = defaults.dsm_clusters;
    float cluster_distance = defaults.dsm_cluster_distance;
    const char* clusters_help = "clustered deep shadow maps (Knecht §3.4): at most M object clusters per light, each with its "
                                "own --dsm-res map focused on it (0: off)";
    const char* distance_help = "clustering threshold d0 in light space, [0, 10] (0: automatic, from the projected object sizes)";
    render->add_option("--clusters", dsm_clusters, clusters_help)->check(in_range<int>(0, 64));
    render->add_option("--cluster-distance", cluster_distance, distance_help)->check(in_range<float>(0, 10));
    float cluster_hysteresis = defaults.dsm_cluster_hysteresis;
    render->add_option("--cluster-hysteresis", cluster_hysteresis,
                       "keep the previous frame's clusters while their spread is within 1 + H of new ones (API re-renders; 0: off)")
        ->check(in_range<float>(0, 10));
    render->add_option("--volume-storage", storage, "auto (buffer on CPUs, image on GPUs), buffer or image")
        ->check(member_of("storage"));
    render->add_option("--non-finite", non_finite, "NaN/Inf voxels: reject (error) or sanitize (set to 0, warn)")
        ->check(CLI::IsMember({"reject", "sanitize"}));
    render->add_flag("--no-empty-space-skipping", no_skip, "march empty bricks too (for comparisons)");
    render->add_option("--seed", seed, "seed of the per-pixel ray jitter");
    int lanes = defaults.lanes;
    render->add_option("--lanes", lanes, "rays per work-item in vector types (camera pass and DSM generation): 1, 4, 8, 16 (default: on CPUs 8 in the camera pass, the native float vector width in DSM generation; 1 on GPUs)")
        ->check(CLI::IsMember({0, 1, 4, 8, 16}));

    CLI::App* devices = app.add_subcommand("devices", "list OpenCL platforms and devices");

    int light_index = 0;
    std::string points_path;
    CLI::App* dsm = app.add_subcommand("dsm", "write one light's deep shadow map as a scanline deep OpenEXR");
    dsm->add_option("scene", scene_path, "scene file (JSON)")->required();
    dsm->add_option("--light", light_index, "light index in the scene")->required();
    dsm->add_option("-o,--output", output, "output .exr (a point light writes NAME.+x.exr … NAME.-z.exr; clustered maps NAME.cluster<k>.<j>.exr)")->required();
    CLI::App* visibility = app.add_subcommand("visibility", "transmittance to a light at points: technique vs reference");
    visibility->add_option("scene", scene_path, "scene file (JSON)")->required();
    visibility->add_option("--light", light_index, "light index in the scene")->required();
    visibility->add_option("--points", points_path, "CSV file of x,y,z world points (one per line)")->required();
    bool quiet = false;
    for (CLI::App* sub : {render, dsm, visibility})
        sub->add_flag("-q,--quiet", quiet, "print nothing on stderr but errors (no progress, no summary)");
    for (CLI::App* sub : {dsm, visibility}) {
        sub->add_option("--device", device, "auto, cpu, gpu, or an index from `sombra devices`");
        sub->add_option("--dsm-res", dsm_resolution, "deep shadow map texels per side")->check(in_range<int>(1, 8192));
        sub->add_option("--storage", dsm_storage, "deep shadow map storage: atlas, chunked, chunked-ondemand (Knecht) or compact")
            ->check(member_of("dsm_storage"));
        sub->add_option("--dsm-lookup", dsm_lookup, dsm_lookup_help)->check(member_of("dsm_lookup"));
        sub->add_flag("--precompression", precompression, "pre-compressed visibility tables (Hadwiger §3.2)");
        sub->add_option("--prefilter", prefilter, "DSM pre-filtering: none, box, tent or 5tap")
            ->check(member_of("dsm_prefilter"));
        sub->add_option("--prefilter-jitter", prefilter_jitter, "jittered sub-pixel rays: on (seed 1), off, or a seed");
        sub->add_option("--eps", dsm_epsilon, "compression error bound ε")->check(in_range<float>(0, 1e6f));
        sub->add_option("--dsm-step", dsm_step, dsm_step_help)->check(in_range<float>(1e-6f, 16));
        sub->add_option("--clusters", dsm_clusters, clusters_help)->check(in_range<int>(0, 64));
        sub->add_option("--cluster-distance", cluster_distance, distance_help)->check(in_range<float>(0, 10));
        sub->add_option("--stats", stats_path, "write build times and DSM sizes as JSON");
    }
    sombra::cli::ClustersCommand clusters;
    sombra::cli::add_clusters_command(app, clusters);
    clusters.app->get_option("--clusters")->check(in_range<int>(1, 64));
    clusters.app->get_option("--cluster-distance")->check(in_range<double>(0, 10));
    for (const char* size : {"--width", "--height"}) clusters.app->get_option(size)->check(in_range<int>(1, 16384));
    clusters.app->get_option("--light")->check(in_range<int>(0, 1 << 20));
    visibility->add_option("--filter", filter_width, "low-pass filter width W in voxels (Ament §4.2.1)")
        ->check(in_range<float>(0, 4096));
    visibility->add_option("--filter-kernel", filter_kernel, "low-pass filter kernel: box or gauss")
        ->check(member_of("lowpass_filter_kernel"));

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        // a misspelt command or option is named, with the closest real one, before anything else
        const std::string command = command_word(argc, argv);
        std::vector<std::string> known;
        for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) known.push_back(sub->get_name());
        if (!command.empty() && std::find(known.begin(), known.end(), command) == known.end()) {
            std::cerr << "sombra: error: unknown command '" << command << "'" << sombra::detail::did_you_mean(command, known) << "\n";
            return 2;
        }
        known.clear();
        {
            const std::string option = unknown_option(command.empty() ? app : *app.get_subcommand(command), argc, argv, known);
            if (!option.empty()) {
                std::cerr << "sombra: error: unknown option '" << option << "'" << sombra::detail::did_you_mean(option, known) << "\n";
                return 2;
            }
        }
        std::cerr << "sombra: error: " << e.what() << "\n";
        return 2;
    }

    if (devices->parsed()) {
        auto list = sombra::list_devices();
        if (list.empty()) throw sombra::Error("no OpenCL device found (install pocl-opencl-icd: scripts/install-deps.sh)");
        for (auto& d : list)
            std::cout << d.index << ": " << d.name << " [" << d.platform << "] " << (d.is_gpu ? "GPU" : "CPU") << ", "
                      << d.opencl_c_version << ", " << (d.global_memory_bytes >> 20) << " MiB\n";
        return 0;
    }

    if (clusters.app->parsed()) return sombra::cli::run_clusters_command(clusters, sombra::load_scene(clusters.scene_path));

    // a wrong output name fails before the work, not after it
    const std::string output_extension = [&] {
        std::string e = std::filesystem::path(output).extension().string();
        std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        return e;
    }();
    if (render->parsed() && output_extension != ".png" && output_extension != ".exr")
        throw sombra::Error(output + ": output must end in .png or .exr");
    if (dsm->parsed() && output_extension != ".exr")
        throw sombra::Error(output + ": a deep shadow map is written as OpenEXR: the name must end in .exr");
    auto check_outputs = [&] { sombra::detail::StagedOutputs::check_targets({output, stats_path}); };
    check_outputs();

    sombra::VolumeLoadOptions load;
    load.non_finite = non_finite == "sanitize" ? sombra::NonFinitePolicy::Sanitize : sombra::NonFinitePolicy::Reject;
    sombra::Scene scene = sombra::load_scene(scene_path, load);
    if (visibility->parsed()) sombra::detail::regular_file_size(points_path);  // an input, read below
    check_outputs();  // again, now that the inputs are known: no output may name one (before any work)
    sombra::Context context(device);
    sombra::RenderOptions options;
    options.width = width, options.height = height;
    sombra::set_render_option(options, "gradient", gradient);
    sombra::set_render_option(options, "shading", shading);
    options.phase_g = phase_g;
    sombra::set_render_option(options, "storage", storage);
    options.empty_space_skipping = !no_skip;
    options.jitter_seed = seed;
    options.lanes = lanes;
    sombra::set_render_option(options, "shadows", shadows);
    options.lowpass_filter_width = filter_width;
    options.lowpass_filter_kernel = filter_kernel;
    options.cone_angle_deg = cone_angle;
    options.shadow_ray_step = ray_step;
    sombra::set_render_option(options, "shadow_cache", shadow_cache);
    options.dsm_resolution = dsm_resolution;
    options.dsm_epsilon = dsm_epsilon;
    options.dsm_storage = dsm_storage;
    options.dsm_lookup = dsm_lookup;
    options.dsm_precompression = precompression;
    options.dsm_prefilter = prefilter;
    options.dsm_step = dsm_step;
    options.dsm_clusters = dsm_clusters;
    options.dsm_cluster_distance = cluster_distance;
    options.dsm_cluster_hysteresis = cluster_hysteresis;
    options.dsm_prefilter_jitter = prefilter_jitter != "off";
    if (prefilter_jitter != "on" && prefilter_jitter != "off") {
        bool digits = !prefilter_jitter.empty() && prefilter_jitter.size() <= 9 &&
                      std::all_of(prefilter_jitter.begin(), prefilter_jitter.end(), [](char c) { return c >= '0' && c <= '9'; });
        if (!digits) throw sombra::Error("--prefilter-jitter: expected on, off or a seed (0 … 999999999), got '" + prefilter_jitter + "'");
        options.dsm_prefilter_seed = unsigned(std::stoul(prefilter_jitter));
    }
    StageTimes stages;
    options.progress = stages.callback(quiet);
    const StatsContext stats_context{scene_path, options};
    if (dsm->parsed()) return write_dsm(context, scene, light_index, stats_context, output, stats_path, quiet);
    if (visibility->parsed()) return print_visibility(context, scene, light_index, stats_context, points_path, stats_path, quiet);
    sombra::RenderResult result = sombra::render(context, scene, options);
    sombra::detail::StagedOutputs outputs;
    outputs.write(output, [&](const std::string& staged) { sombra::write_image(result.image, staged); });
    stage_stats(outputs, stats_path, command_stats(result.stats, stats_context));
    outputs.commit();
    if (!quiet)
        std::cerr << "sombra: wrote " << output << " (" << result.image.width << "×" << result.image.height << ", "
                  << result.stats.device << ", " << result.stats.msamples_per_s << " Msamples/s; " << shadow_cache_note(result.stats, options)
                  << stages.summary() << ")\n";
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra", run, argc, argv); }
