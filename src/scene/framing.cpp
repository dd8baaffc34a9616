// sombra — framing a scene: world bounds, the fitted camera and key light, volume scenes made
// from one volume file, and writing a scene back as a file.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "math_constants.h"
#include "scene/json_fields.h"
#include "scene/scene_json.h"
#include "sombra/error.h"
#include "sombra/scene.h"

namespace sombra {
namespace {

using D3 = std::array<double, 3>;
D3 d3(const Vec3& v) { return {v[0], v[1], v[2]}; }
Vec3 f3(const D3& v) { return {float(v[0]), float(v[1]), float(v[2])}; }
D3 add(const D3& a, const D3& b, double s = 1) { return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]}; }
double dot(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
D3 cross(const D3& a, const D3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
D3 normalized(const D3& a) {
    const double n = std::sqrt(dot(a, a));
    return {a[0] / n, a[1] / n, a[2] / n};
}

Vec3 transformed(const std::array<float, 16>& m, const Vec3& p) {
    Vec3 out;
    for (int r = 0; r < 3; ++r)
        out[std::size_t(r)] = m[std::size_t(r * 4)] * p[0] + m[std::size_t(r * 4 + 1)] * p[1] + m[std::size_t(r * 4 + 2)] * p[2] +
                              m[std::size_t(r * 4 + 3)];
    return out;
}

// The camera's frame: forward, right, up.
struct Frame {
    D3 forward, right, up;
};
Frame frame_of(const Camera& c) {
    Frame f;
    f.forward = normalized(add(d3(c.look_at), d3(c.position), -1));
    f.right = normalized(cross(f.forward, d3(c.up)));
    f.up = cross(f.right, f.forward);
    return f;
}

bool ends_with_json(std::string path) {
    std::transform(path.begin(), path.end(), path.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
}

}  // namespace

void Box3::add(const Vec3& p) {
    for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
}

void Box3::add(const Box3& b) {
    if (!b.empty()) add(b.lo), add(b.hi);
}

Box3 world_bounds(const VolumeInstance& vi) {
    Box3 box;
    if (!vi.volume) return box;
    Vec3 half;
    for (std::size_t a = 0; a < 3; ++a) half[a] = 0.5f * float(vi.volume->dims[a]) * vi.spacing[a];
    for (int corner = 0; corner < 8; ++corner)
        box.add(transformed(vi.transform, {corner & 1 ? half[0] : -half[0], corner & 2 ? half[1] : -half[1],
                                           corner & 4 ? half[2] : -half[2]}));
    return box;
}

Box3 world_bounds(const MeshInstance& mi) {
    Box3 box;
    if (mi.mesh)
        for (const Vec3& p : mi.mesh->positions) box.add(transformed(mi.transform, p));
    return box;
}

Box3 world_bounds(const Scene& scene) {
    Box3 box;
    for (const VolumeInstance& vi : scene.volumes) box.add(world_bounds(vi));
    for (const MeshInstance& mi : scene.meshes) box.add(world_bounds(mi));
    return box;
}

Vec3 natural_up(const Scene& scene) {
    bool all_vdb = true;
    for (const VolumeInstance& vi : scene.volumes) {
        std::string source = vi.volume ? vi.volume->source : "";
        std::transform(source.begin(), source.end(), source.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        all_vdb = all_vdb && source.size() > 4 && source.compare(source.size() - 4, 4, ".vdb") == 0;
    }
    return all_vdb ? Vec3{0, 1, 0} : Vec3{0, 0, 1};
}

Camera fit_camera(const Box3& box, const Vec3& up_given, int width, int height, float fov_y_deg) {
    Camera camera;
    camera.fov_y_deg = fov_y_deg;
    if (box.empty() || width < 1 || height < 1) return camera;
    const D3 up = normalized(d3(up_given));
    const D3 front = std::fabs(up[2]) > 0.5 ? D3{0, 1, 0} : D3{0, 0, 1};
    const D3 side = normalized(cross(front, up));  // +x for both
    const double azimuth = 35 * kPi / 180, elevation = 20 * kPi / 180;
    const D3 towards_camera = normalized(add(add(D3{}, front, std::cos(elevation) * std::cos(azimuth)),
                                             add(add(D3{}, side, std::cos(elevation) * std::sin(azimuth)), up, std::sin(elevation))));
    const D3 center = d3(box.center());
    camera.look_at = f3(center);
    camera.up = f3(up);
    camera.position = f3(add(center, towards_camera, 1));
    const Frame f = frame_of(camera);
    const double tan_y = std::tan(fov_y_deg * kPi / 360) * 0.92, tan_x = tan_y * double(width) / double(height);
    double size = 0, distance = 0;
    for (int a = 0; a < 3; ++a) size = std::max(size, double(box.hi[std::size_t(a)] - box.lo[std::size_t(a)]));
    for (int corner = 0; corner < 8; ++corner) {
        const D3 p{corner & 1 ? box.hi[0] : box.lo[0], corner & 2 ? box.hi[1] : box.lo[1], corner & 4 ? box.hi[2] : box.lo[2]};
        const D3 r = add(p, center, -1);
        const double depth = dot(r, f.forward);  // the camera at centre − distance · forward sees it at distance + depth
        distance = std::max({distance, std::fabs(dot(r, f.right)) / tan_x - depth, std::fabs(dot(r, f.up)) / tan_y - depth,
                             depth + 0.05 * size});
    }
    if (!(distance > 0)) distance = 1;
    camera.position = f3(add(center, towards_camera, distance));
    return camera;
}

void fit_scene_camera(Scene& scene, int width, int height) {
    scene.camera = fit_camera(world_bounds(scene), natural_up(scene), width, height);
    scene.camera_fitted = true;
}

Light key_light(const Camera& camera) {
    const Frame f = frame_of(camera);
    const double up = std::tan(40 * kPi / 180), left = std::tan(40 * kPi / 180);
    const D3 from = normalized(add(add(add(D3{}, f.forward, -1), f.up, up), f.right, -left));  // towards the light
    Light light;
    light.type = LightType::Directional;
    light.direction = f3(add(D3{}, from, -1));
    light.color = {1.f, 0.97f, 0.92f};
    return light;
}

VolumeScene volume_scene(const std::string& path, TransferPreset preset, int width, int height, const VolumeLoadOptions& options) {
    VolumeScene out;
    auto volume = std::make_shared<Volume>(load_volume(path, options, &out.report));
    out.statistics = volume_statistics(*volume);
    out.preset = preset == TransferPreset::Auto ? choose_transfer_preset(out.statistics, out.report.format) : preset;
    VolumeInstance vi;
    vi.spacing = volume->spacing;
    vi.transform = volume->placement;
    vi.transfer_function = preset_transfer_function(out.statistics, out.preset);
    vi.name = std::filesystem::path(path).filename().string();
    if (out.preset == TransferPreset::Fog) vi.material = {0.4f, 1.f, 0.f, 1.f};  // a medium: no highlights
    else vi.material = {0.3f, 0.7f, 0.3f, 20.f};
    vi.volume = std::move(volume);
    Scene& scene = out.scene;
    scene.source = path;
    scene.volumes.push_back(std::move(vi));
    scene.width = width, scene.height = height;
    scene.background = out.preset == TransferPreset::Fog ? Vec3{0.22f, 0.25f, 0.3f} : Vec3{0.03f, 0.03f, 0.04f};
    scene.ambient_intensity = 0.5f;
    fit_scene_camera(scene, width, height);
    scene.lights.push_back(key_light(scene.camera));
    normalize_light_direction(scene.lights.back());  // as a scene file's light is read
    validate_scene(scene, path);
    return out;
}

namespace {

// A file path of a scene file, made absolute against the file's folder (`holder[key]`, when there).
void make_path_absolute(nlohmann::json& holder, const char* key, const std::filesystem::path& folder) {
    if (!holder.is_object() || !holder.contains(key) || !holder[key].is_string()) return;
    const std::filesystem::path path = holder[key].get<std::string>();
    if (path.is_relative()) holder[key] = (folder / path).lexically_normal().generic_string();
}

}  // namespace

std::string scene_file_text(const Scene& scene, const std::string& scene_path, const std::string& render_block_json) {
    using nlohmann::json;
    json j;
    j["camera"] = camera_json(scene.camera);
    j["image"] = {{"width", scene.width}, {"height", scene.height}};
    j["background"] = vec_json(scene.background);
    j["ambient_intensity"] = scene.ambient_intensity;
    if (!scene.meshes.empty()) throw file_error(scene_path, "meshes", "only scenes of volume files can be written");
    const std::filesystem::path folder =
        scene_path.empty() ? std::filesystem::path() : std::filesystem::absolute(scene_path).parent_path();
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeInstance& vi = scene.volumes[i];
        const std::string field = "volumes[" + std::to_string(i) + "]";
        if (!vi.volume || vi.transform != vi.volume->placement || vi.spacing != vi.volume->spacing || vi.bound.mesh ||
            !std::filesystem::exists(vi.volume->source))
            throw file_error(scene_path, field, "only volumes read from a file, where the file places them, can be written");
        std::filesystem::path file = std::filesystem::absolute(vi.volume->source).lexically_normal();
        std::filesystem::path relative = folder.empty() ? std::filesystem::path() : file.lexically_relative(folder);
        const Material& m = vi.material;
        j["volumes"].push_back({{"name", vi.name},
                                {"file", (relative.empty() ? file : relative).generic_string()},
                                {"step_voxels", vi.step_voxels},
                                {"opacity_unit", vi.opacity_unit},
                                {"transfer_function", transfer_function_json(vi.transfer_function)},
                                {"material", {{"ambient", m.ambient}, {"diffuse", m.diffuse}, {"specular", m.specular}, {"shininess", m.shininess}}}});
    }
    j["lights"] = lights_json(scene.lights);
    j["render"] = json::parse(render_block_json);
    return j.dump(2);
}

std::string edited_scene_file_text(const Scene& scene, const std::string& render_block_json) {
    using nlohmann::json;
    if (!is_scene_file(scene.source)) return scene_file_text(scene, "", render_block_json);
    json j = detail::parse_json_file(scene.source);
    const std::filesystem::path folder = std::filesystem::absolute(scene.source).parent_path();
    json none = json::array();
    const auto objects = [&](const char* key, std::size_t count) -> json& {
        json& list = j.contains(key) ? j[key] : none;
        if (!list.is_array() || list.size() != count)
            throw file_error(scene.source, key, "does not hold the scene's " + std::to_string(count) + " objects any more");
        return list;
    };
    json& volumes = objects("volumes", scene.volumes.size());
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        make_path_absolute(volumes[i], "file", folder);
        if (volumes[i].contains("bounds")) make_path_absolute(volumes[i]["bounds"], "mesh", folder);
        volumes[i]["transfer_function"] = transfer_function_json(scene.volumes[i].transfer_function);
    }
    for (json& mesh : objects("meshes", scene.meshes.size())) make_path_absolute(mesh, "file", folder);
    j["camera"] = camera_json(scene.camera);
    j["image"] = {{"width", scene.width}, {"height", scene.height}};
    j["lights"] = lights_json(scene.lights);
    j["render"] = json::parse(render_block_json);
    return j.dump(2);
}

bool is_scene_file(const std::string& path) {
    if (!ends_with_json(path)) return false;
    try {
        const nlohmann::json j = detail::parse_json_file(path);
        return !(j.is_object() && j.contains("raw"));
    } catch (const Error&) {
        return true;  // load_scene says what is wrong with it
    }
}

}  // namespace sombra
