#include "view/view_session.h"

#include <chrono>
#include <cmath>
#include <variant>

#include "scene/scene_json.h"
#include "scene/suggest.h"
#include "sombra/error.h"
#include "sombra/options.h"

namespace sombra::view {
namespace {

using nlohmann::json;


// A request field that must be an object; its keys must be among `known`.
const json& object_field(const json& j, const std::string& field, const std::vector<std::string>& known) {
    if (!j.is_object()) throw Error(field + ": expected an object, got " + std::string(j.type_name()));
    for (const auto& [key, value] : j.items())
        if (std::find(known.begin(), known.end(), key) == known.end())
            throw Error(field + (field.empty() ? "" : ": ") + "unknown key '" + key + "'" + detail::did_you_mean(key, known));
    return j;
}

double number_field(const json& j, const std::string& field) {
    if (!j.is_number()) throw Error(field + ": expected a number, got " + std::string(j.type_name()));
    const double v = j.get<double>();
    if (!std::isfinite(v) || std::fabs(v) > 1e30) throw Error(field + ": must be a finite number of magnitude ≤ 1e30");
    return v;
}

Vec3 vec3_field(const json& j, const std::string& field) {
    if (!j.is_array() || j.size() != 3) throw Error(field + ": expected an array of 3 numbers");
    Vec3 v;
    for (std::size_t i = 0; i < 3; ++i) v[i] = float(number_field(j[i], field + "[" + std::to_string(i) + "]"));
    return v;
}

Camera read_camera(const json& j, Camera camera) {
    object_field(j, "camera", {"position", "look_at", "up", "fov_y_deg"});
    if (j.contains("position")) camera.position = vec3_field(j["position"], "camera.position");
    if (j.contains("look_at")) camera.look_at = vec3_field(j["look_at"], "camera.look_at");
    if (j.contains("up")) camera.up = vec3_field(j["up"], "camera.up");
    if (j.contains("fov_y_deg")) camera.fov_y_deg = float(number_field(j["fov_y_deg"], "camera.fov_y_deg"));
    if (auto problem = camera_problem(camera)) throw Error("camera." + problem->field + ": " + problem->what);
    return camera;
}

void read_lights(const json& j, std::vector<Light>& lights) {
    if (!j.is_array() || j.size() != lights.size())
        throw Error("lights: expected an array of " + std::to_string(lights.size()) + " lights (the scene's)");
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const std::string field = "lights[" + std::to_string(i) + "]";
        Light& light = lights[i];
        object_field(j[i], field, {"direction", "position"});
        if (j[i].contains("direction")) {
            if (light.type == LightType::Point) throw Error(field + ".direction: a point light has no direction");
            light.direction = vec3_field(j[i]["direction"], field + ".direction");
        }
        if (j[i].contains("position")) {
            if (light.type == LightType::Directional) throw Error(field + ".position: a directional light has no position");
            light.position = vec3_field(j[i]["position"], field + ".position");
        }
        if (auto problem = light_problem(light)) throw Error(field + "." + problem->field + ": " + problem->what);
        normalize_light_direction(light);
    }
}

// σ × s: α = 1 − e^(−σ u) becomes 1 − e^(−s σ u) = 1 − (1 − α)^s (an opaque point stays opaque).
void scale_opacity(Scene& scene, double s) {
    for (VolumeInstance& volume : scene.volumes)
        for (auto& point : volume.transfer_function.opacity_points)
            point.alpha = float(1.0 - std::pow(1.0 - double(point.alpha), s));
}

json option_json(const OptionValue& value) {
    return std::visit([](const auto& v) { return json(v); }, value);
}

}  // namespace

ViewSession::ViewSession(Scene scene, RenderOptions options, const std::string& device)
    : scene_(std::move(scene)), options_(std::move(options)), context_(device) {}

json ViewSession::state() {
    json j;
    j["source"] = scene_.source;
    j["device"] = context_.device().name;
    j["image"] = {{"width", scene_.width}, {"height", scene_.height}};
    j["camera"] = camera_json(scene_.camera);
    const Box3 box = world_bounds(scene_);
    j["bounds"] = {{"lo", vec_json(box.lo)}, {"hi", vec_json(box.hi)}};
    j["lights"] = lights_json(scene_.lights);
    j["techniques"] = json::array();
    for (const std::string& name : shadow_technique_names())
        j["techniques"].push_back({{"name", name}, {"summary", shadow_technique_summary(parse_shadow_technique(name))}});
    j["options"] = json::array();
    for (const OptionSpec& spec : render_option_specs()) {
        if (!(spec.commands & kRenderCommand)) continue;
        json techniques = json::array();
        for (ShadowTechnique t : spec.techniques) techniques.push_back(shadow_technique_name(t));
        const char* kinds[] = {"integer", "real", "flag", "choice"};
        j["options"].push_back({{"key", spec.key},
                                {"flag", spec.flag},
                                {"kind", kinds[int(spec.kind)]},
                                {"help", spec.help},
                                {"unit", spec.unit},
                                {"min", spec.min},
                                {"max", spec.max},
                                {"min_open", spec.min_open},
                                {"max_open", spec.max_open},
                                {"range", option_range_text(spec)},
                                {"choices", spec.choices},
                                {"techniques", techniques},
                                {"default", option_json(spec.default_value())},
                                {"value", option_json(spec.get(options_))}});
    }
    return j;
}

ViewFrame view_frame(const Scene& scene, const RenderOptions& options, const json& request) {
    object_field(request, "", {"options", "camera", "lights", "opacity_scale"});
    ViewFrame f{scene, options, json::object()};
    if (request.contains("options")) {
        if (!request["options"].is_object()) throw Error("options: expected an object");
        for (const auto& [key, value] : request["options"].items()) set_render_option_json(f.options, key, value.dump(), "options");
        for (const auto& [key, value] : request["options"].items())
            check_option_applies(*find_render_option(key), f.options.shadows, "options." + key, "shadows ");
    }
    if (request.contains("camera")) f.scene.camera = read_camera(request["camera"], f.scene.camera);
    if (request.contains("lights")) read_lights(request["lights"], f.scene.lights);
    if (request.contains("opacity_scale")) {
        const double s = number_field(request["opacity_scale"], "opacity_scale");
        if (!(s > 0 && s <= 100)) throw Error("opacity_scale: must lie in (0, 100], got " + request["opacity_scale"].dump());
        scale_opacity(f.scene, s);
    }
    if (f.options.width > 0) f.scene.width = f.options.width;
    if (f.options.height > 0) f.scene.height = f.options.height;
    f.scene.camera_fitted = false;  // the request's (or the loaded) camera, kept at every size
    for (const OptionSpec& spec : render_option_specs())
        if ((spec.commands & kRenderCommand) && spec.key != "width" && spec.key != "height" &&
            spec.get(f.options) != spec.default_value())
            f.render_block[spec.key] = option_json(spec.get(f.options));
    return f;
}

ViewSession::Rendered ViewSession::render(const ViewFrame& frame) {
    const auto start = std::chrono::steady_clock::now();
    RenderResult result = sombra::render(context_, frame.scene, frame.options);
    Rendered out;
    out.png = encode_png(result.image);
    out.stats = json::parse(result.stats.to_json());
    out.stats["frame_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return out;
}

std::string ViewSession::scene_text(const ViewFrame& frame) { return edited_scene_file_text(frame.scene, frame.render_block.dump()); }

}  // namespace sombra::view
