#include "sombra/scene.h"

#include <cmath>
#include <filesystem>

#include "math_constants.h"
#include "scene/json_fields.h"
#include "sombra/limits.h"
#include "shared/types.h"

namespace sombra {
namespace {

using detail::JsonFields;
using nlohmann::json;

std::array<float, 16> multiply(const std::array<float, 16>& a, const std::array<float, 16>& b) {
    std::array<float, 16> r{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k) r[i * 4 + j] += a[i * 4 + k] * b[k * 4 + j];
    return r;
}

// ParaView layout: rgb_points = [x, r, g, b, x, r, g, b, …], opacity_points = [x, a, x, a, …].
std::vector<float> flat_numbers(JsonFields& f, const std::string& key, std::size_t group) {
    const json& v = f.at(key);
    if (!v.is_array() || v.empty() || v.size() % group != 0)
        f.fail(key, "must be a flat array of " + std::to_string(group) + "-tuples");
    if (v.size() / group > limits::kMaxTransferPoints)
        f.fail(key, "at most " + std::to_string(limits::kMaxTransferPoints) + " points");
    std::vector<float> out;
    for (const auto& e : v) out.push_back(f.number_of(e, key));
    return out;
}

TransferFunction read_transfer_function(const json& j, const std::string& file, const std::string& path) {
    JsonFields f(j, file, path);
    TransferFunction tf;
    auto rgb = flat_numbers(f, "rgb_points", 4);
    for (std::size_t i = 0; i < rgb.size(); i += 4) tf.color_points.push_back({rgb[i], rgb[i + 1], rgb[i + 2], rgb[i + 3]});
    auto op = flat_numbers(f, "opacity_points", 2);
    for (std::size_t i = 0; i < op.size(); i += 2) tf.opacity_points.push_back({op[i], op[i + 1]});
    f.finish();
    try {
        tf.validate(path);
    } catch (const Error& e) {
        throw Error(file + ": " + e.what());
    }
    return tf;
}

std::array<float, 16> read_transform(const json& j, const std::string& file, const std::string& path) {
    JsonFields f(j, file, path);
    if (f.has("matrix")) {
        const json& m = f.at("matrix");
        if (!m.is_array() || m.size() != 16) f.fail("matrix", "must be 16 numbers (row-major 4×4)");
        std::array<float, 16> out{};
        for (int i = 0; i < 16; ++i) out[i] = f.number_of(m[i], "matrix");
        f.finish();
        return out;
    }
    Vec3 translate = f.vec3("translate", {0, 0, 0});
    Vec3 rotate = f.vec3("rotate_deg", {0, 0, 0});
    Vec3 scale{1, 1, 1};
    if (f.has("scale")) {
        const json& s = f.at("scale");
        if (s.is_number()) scale.fill(f.number_of(s, "scale"));
        else scale = f.vec3("scale", scale);
    }
    for (float s : scale)
        if (!(std::fabs(s) > 0.f)) f.fail("scale", "must be non-zero");
    f.finish();
    return make_transform(translate, rotate, scale);
}

std::shared_ptr<const Volume> read_generator(const json& j, const std::string& file, const std::string& path,
                                             const VolumeLoadOptions& options) {
    JsonFields f(j, file, path);
    std::string type = f.string("type");
    const int size = int(f.integer("size", 64, 1, limits::kMaxGeneratorSize));
    if (std::uint64_t(size) * size * size > options.max_voxels)
        f.fail("size", std::to_string(size) + "³ voxels exceed the limit of " + std::to_string(options.max_voxels));
    const auto seed = [&] { return std::uint32_t(f.integer("seed", 1, 0, UINT32_MAX)); };
    float density = f.number("density", 1.f);
    Volume v;
    if (type == "sphere") v = make_sphere(size, f.number("radius_fraction", 0.4f), density);
    else if (type == "slab") {
        const int axis = int(f.integer("axis", 2, 0, 2));
        v = make_slab(size, axis, f.number("lo", 0.25f), f.number("hi", 0.75f), density);
    } else if (type == "blobs") v = make_gaussian_blobs(size, int(f.integer("count", 8, 1, limits::kMaxGeneratorBlobs)), seed());
    else if (type == "cloud") v = make_cloud_noise(size, seed());
    else if (type == "steam") v = make_steam_plume(size, seed());
    else f.fail("type", "unknown generator '" + type + "' (sphere, slab, blobs, cloud, steam)");
    f.finish();
    return std::make_shared<const Volume>(std::move(v));
}

std::filesystem::path relative_to(const std::string& file, const std::string& name) {
    std::filesystem::path p = name;
    if (p.is_relative()) p = std::filesystem::path(file).parent_path() / p;
    return p.lexically_normal();
}

// Phong coefficients of a "material" object (Knecht Eq. 3.8), each ≥ 0.
Material read_phong(JsonFields& m, Material fallback) {
    Material out;
    out.ambient = m.number("ambient", fallback.ambient);
    out.diffuse = m.number("diffuse", fallback.diffuse);
    out.specular = m.number("specular", fallback.specular);
    out.shininess = m.number("shininess", fallback.shininess);
    for (auto key : {"ambient", "diffuse", "specular", "shininess"})
        if (m.number(key, 0.f) < 0.f) m.fail(key, "must be ≥ 0");
    return out;
}

// "bounds": {"mesh": FILE, "transform": …}: a closed mesh in the volume's object frame. A missing,
// malformed or open mesh fails naming the scene, the field and the mesh file.
VolumeBound read_bound(const json& j, const std::string& file, const std::string& path) {
    JsonFields f(j, file, path);
    VolumeBound b;
    std::string mesh_path = relative_to(file, f.string("mesh")).string();
    try {
        Mesh mesh = load_mesh(mesh_path);
        check_closed(mesh, mesh_path);
        b.mesh = std::make_shared<const Mesh>(std::move(mesh));
    } catch (const Error& e) {
        f.fail("mesh", e.what());
    }
    if (f.has("transform")) b.transform = read_transform(f.at("transform"), file, f.field("transform"));
    f.finish();
    return b;
}

VolumeInstance read_volume(const json& j, const std::string& file, const std::string& path,
                           const VolumeLoadOptions& options) {
    JsonFields f(j, file, path);
    VolumeInstance vi;
    vi.name = f.string("name", path);
    bool has_file = f.has("file"), has_generator = f.has("generator");
    if (has_file == has_generator) f.fail("", "needs exactly one of 'file' and 'generator'");
    if (has_file) {
        VolumeLoadOptions with_grid = options;
        if (f.has("grid")) {
            with_grid.grid = f.string("grid");
            if (with_grid.grid.empty()) f.fail("grid", "must be a grid name (leave it out for the first float grid)");
        }
        vi.volume = std::make_shared<const Volume>(load_volume(relative_to(file, f.string("file")).string(), with_grid));
    } else {
        vi.volume = read_generator(f.at("generator"), file, f.field("generator"), options);
    }
    vi.spacing = f.vec3("spacing", vi.volume->spacing);
    // The file's placement (orientation and position), then the scene's transform: one matrix.
    std::array<float, 16> placement = vi.volume->placement;
    const std::string where = f.string("placement", "file");
    if (where == "centered") placement[3] = placement[7] = placement[11] = 0.f;
    else if (where != "file") f.fail("placement", "must be \"file\" (where the file puts the volume) or \"centered\" "
                                                  "(its orientation kept, its centre at the origin)");
    vi.transform = placement;
    if (f.has("transform")) vi.transform = multiply(read_transform(f.at("transform"), file, f.field("transform")), placement);
    vi.transfer_function = read_transfer_function(f.at("transfer_function"), file, f.field("transfer_function"));
    vi.step_voxels = f.number("step_voxels", vi.step_voxels);
    vi.opacity_unit = f.number("opacity_unit", 0.f);
    if (auto problem = volume_problem(vi)) f.fail(problem->field, problem->what);
    if (f.has("material")) {
        JsonFields m(f.at("material"), file, f.field("material"));
        vi.material = read_phong(m, vi.material);
        m.finish();
    }
    if (f.has("bounds")) vi.bound = read_bound(f.at("bounds"), file, f.field("bounds"));
    f.finish();
    return vi;
}

MeshInstance read_mesh(const json& j, const std::string& file, const std::string& path) {
    JsonFields f(j, file, path);
    MeshInstance mi;
    mi.name = f.string("name", path);
    mi.mesh = std::make_shared<const Mesh>(load_mesh(relative_to(file, f.string("file")).string()));
    if (f.has("transform")) mi.transform = read_transform(f.at("transform"), file, f.field("transform"));
    if (f.has("material")) {
        JsonFields m(f.at("material"), file, f.field("material"));
        mi.material.color = m.vec3("color", mi.material.color);
        for (float c : mi.material.color)
            if (!(c >= 0.f && c <= 1.f)) m.fail("color", "must lie in [0, 1]");
        mi.material.opacity = m.number("opacity", mi.material.opacity);
        if (!(mi.material.opacity >= 0.f && mi.material.opacity <= 1.f)) m.fail("opacity", "must lie in [0, 1]");
        mi.material.phong = read_phong(m, mi.material.phong);
        m.finish();
    }
    f.finish();
    return mi;
}

}  // namespace

LightType parse_light_type(const std::string& name) {
    if (name == "directional") return LightType::Directional;
    if (name == "spot") return LightType::Spot;
    if (name == "point" || name == "omni") return LightType::Point;
    throw Error("unknown light type '" + name + "' (directional, spot, point)");
}

const char* light_type_name(LightType type) {
    switch (type) {
        case LightType::Directional: return "directional";
        case LightType::Spot: return "spot";
        default: return "point";
    }
}

namespace {

Light read_light(const json& j, const std::string& file, const std::string& path) {
    JsonFields f(j, file, path);
    Light l;
    const std::string type = f.string("type");
    try {
        l.type = parse_light_type(type);
    } catch (const Error& e) {
        f.fail("type", e.what());
    }
    if (l.type != LightType::Directional) l.position = f.vec3("position", l.position);
    if (l.type != LightType::Point) l.direction = f.vec3("direction", l.direction);
    l.color = f.vec3("color", l.color);
    l.intensity = f.number("intensity", l.intensity);
    if (l.type == LightType::Spot) {
        l.cone_angle_deg = f.number("cone_angle_deg", l.cone_angle_deg);
        l.cone_softness = f.number("cone_softness", l.cone_softness);
    }
    if (l.type != LightType::Directional && f.has("attenuation")) {
        Vec3 a = f.vec3("attenuation", {1, 0, 0});
        l.att_constant = a[0], l.att_linear = a[1], l.att_quadratic = a[2];
    }
    if (auto problem = light_problem(l)) f.fail(problem->field, problem->what);
    normalize_light_direction(l);
    f.finish();
    return l;
}

// Every corner of the box [lo, hi] mapped by `transform` must lie within ±kMaxCoordinate, so that
// distances, their squares and the kernels' products stay finite as floats.
void check_world_extent(const std::string& where, const std::string& field, const std::array<float, 16>& transform,
                        const Vec3& lo, const Vec3& hi) {
    for (int corner = 0; corner < 8; ++corner)
        for (int row = 0; row < 3; ++row) {
            double w = transform[std::size_t(row * 4 + 3)];
            for (int a = 0; a < 3; ++a) w += double(transform[std::size_t(row * 4 + a)]) * ((corner >> a) & 1 ? hi[a] : lo[a]);
            if (!(std::fabs(w) <= limits::kMaxCoordinate))
                throw file_error(where, field, "places the object beyond ±1e18 (world coordinates must stay finite)");
        }
}

void check_point(const std::string& where, const std::string& field, const Vec3& p) {
    for (float c : p)
        if (!(std::fabs(c) <= limits::kMaxCoordinate)) throw file_error(where, field, "must lie within ±1e18");
}

}  // namespace

std::array<float, 16> make_transform(const Vec3& t, const Vec3& r, const Vec3& s) {
    auto rot = [](int axis, float deg) {
        float c = std::cos(deg * float(kPi) / 180.f), sn = std::sin(deg * float(kPi) / 180.f);
        std::array<float, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        int a = (axis + 1) % 3, b = (axis + 2) % 3;
        m[a * 4 + a] = c, m[a * 4 + b] = -sn, m[b * 4 + a] = sn, m[b * 4 + b] = c;
        return m;
    };
    std::array<float, 16> scale{s[0], 0, 0, 0, 0, s[1], 0, 0, 0, 0, s[2], 0, 0, 0, 0, 1};
    std::array<float, 16> translate{1, 0, 0, t[0], 0, 1, 0, t[1], 0, 0, 1, t[2], 0, 0, 0, 1};
    // world = T · Rz · Ry · Rx · S · object
    return multiply(translate, multiply(rot(2, r[2]), multiply(rot(1, r[1]), multiply(rot(0, r[0]), scale))));
}

std::array<float, 16> bound_to_world(const VolumeInstance& volume) { return multiply(volume.transform, volume.bound.transform); }

std::optional<FieldProblem> volume_problem(const VolumeInstance& vi) {
    for (float s : vi.spacing)
        if (!(s >= limits::kMinLength && s <= limits::kMaxCoordinate)) return FieldProblem{"spacing", "must be ≥ 1e-12 (positive)"};
    if (!(vi.step_voxels >= 0.01f && vi.step_voxels <= 16.f)) return FieldProblem{"step_voxels", "must lie in [0.01, 16]"};
    if (!(vi.opacity_unit == 0.f || (vi.opacity_unit >= limits::kMinLength && vi.opacity_unit <= limits::kMaxCoordinate)))
        return FieldProblem{"opacity_unit", "must be 0 (one voxel) or ≥ 1e-12"};  // σ = −ln(1 − α)/unit stays finite
    for (float m : vi.transform)
        if (!std::isfinite(m)) return FieldProblem{"transform", "must be finite"};
    return std::nullopt;
}

std::optional<FieldProblem> light_problem(const Light& l) {
    if (l.type != LightType::Point) {
        const double len = std::hypot(double(l.direction[0]), double(l.direction[1]), double(l.direction[2]));
        if (!(len > 1e-6 && std::isfinite(len))) return FieldProblem{"direction", "must be a non-zero vector"};
    }
    for (float c : l.color)
        if (!(c >= 0.f && std::isfinite(c))) return FieldProblem{"color", "must be ≥ 0"};
    if (!(l.intensity >= 0.f && std::isfinite(l.intensity))) return FieldProblem{"intensity", "must be ≥ 0"};
    if (l.type == LightType::Spot) {
        if (!(l.cone_angle_deg > 0.f && l.cone_angle_deg < 90.f)) return FieldProblem{"cone_angle_deg", "must lie in (0, 90)"};
        if (!(l.cone_softness >= 0.f && l.cone_softness <= 1.f)) return FieldProblem{"cone_softness", "must lie in [0, 1]"};
    }
    if (l.type != LightType::Directional) {
        const float a[3] = {l.att_constant, l.att_linear, l.att_quadratic};
        if (!(a[0] >= 0.f && a[1] >= 0.f && a[2] >= 0.f && a[0] + a[1] + a[2] > 0.f && std::isfinite(a[0] + a[1] + a[2])))
            return FieldProblem{"attenuation", "constant, linear, quadratic must be ≥ 0 and not all 0"};
    }
    return std::nullopt;
}

std::optional<FieldProblem> camera_problem(const Camera& c) {
    auto within = [](const Vec3& p) {
        for (float v : p)
            if (!(std::fabs(v) <= limits::kMaxCoordinate)) return false;
        return true;
    };
    if (!within(c.position)) return FieldProblem{"position", "must lie within ±1e18"};
    if (!within(c.look_at)) return FieldProblem{"look_at", "must lie within ±1e18"};
    const Vec3 d{c.look_at[0] - c.position[0], c.look_at[1] - c.position[1], c.look_at[2] - c.position[2]};
    const float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 1e-6f)) return FieldProblem{"look_at", "must differ from camera.position"};
    const Vec3& u = c.up;
    const Vec3 cross{d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
    const float ulen = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]) > 1e-6f * len * ulen) || !std::isfinite(ulen))
        return FieldProblem{"up", "must be a non-zero vector not parallel to the view direction"};
    if (!(c.fov_y_deg > 0.f && c.fov_y_deg < 180.f)) return FieldProblem{"fov_y_deg", "must lie in (0, 180)"};
    return std::nullopt;
}

void normalize_light_direction(Light& l) {
    if (l.type == LightType::Point) return;
    const double len = std::hypot(double(l.direction[0]), double(l.direction[1]), double(l.direction[2]));
    for (float& c : l.direction) c = float(c / len);
}

void validate_scene(const Scene& scene, const std::string& where) {
    if (auto problem = camera_problem(scene.camera)) throw file_error(where, "camera." + problem->field, problem->what);
    if (scene.width < 1 || scene.height < 1 || scene.width > limits::kMaxImageSide || scene.height > limits::kMaxImageSide)
        throw file_error(where, "image", "width and height must lie in [1, " + std::to_string(limits::kMaxImageSide) + "]");
    if (scene.volumes.size() > SOMBRA_MAX_VOLUMES)
        throw file_error(where, "volumes", "at most " + std::to_string(SOMBRA_MAX_VOLUMES) + " volumes per scene");
    if (scene.lights.size() > std::size_t(limits::kMaxLights))
        throw file_error(where, "lights", "at most " + std::to_string(limits::kMaxLights) + " lights per scene");
    if (!(scene.ambient_intensity >= 0.f && std::isfinite(scene.ambient_intensity)))
        throw file_error(where, "ambient_intensity", "must be ≥ 0");
    for (std::size_t i = 0; i < scene.lights.size(); ++i) {
        check_point(where, "lights[" + std::to_string(i) + "].position", scene.lights[i].position);
        if (auto problem = light_problem(scene.lights[i]))
            throw file_error(where, "lights[" + std::to_string(i) + "]." + problem->field, problem->what);
    }
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        const MeshInstance& mi = scene.meshes[i];
        if (!mi.mesh || mi.mesh->positions.empty()) continue;
        Vec3 lo = mi.mesh->positions.front(), hi = lo;
        for (const Vec3& p : mi.mesh->positions)
            for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
        check_world_extent(where, "meshes[" + std::to_string(i) + "]", mi.transform, lo, hi);
    }
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        if (!scene.volumes[i].volume || scene.volumes[i].volume->voxel_count() == 0)
            throw file_error(where, "volumes[" + std::to_string(i) + "]", "volume is empty");
        const VolumeInstance& vi = scene.volumes[i];
        if (auto problem = volume_problem(vi)) throw file_error(where, "volumes[" + std::to_string(i) + "]." + problem->field, problem->what);
        Vec3 half;
        for (int a = 0; a < 3; ++a) half[a] = 0.5f * float(vi.volume->dims[a]) * vi.spacing[a];
        check_world_extent(where, "volumes[" + std::to_string(i) + "]", vi.transform, {-half[0], -half[1], -half[2]}, half);
        if (const auto& bound = scene.volumes[i].bound.mesh) {  // API users build bounds in memory
            std::string field = "volumes[" + std::to_string(i) + "].bounds.mesh";
            try {
                validate_mesh(*bound, bound->source);
                check_closed(*bound, bound->source);
            } catch (const Error& e) {
                throw file_error(where, field, e.what());
            }
        }
    }
}

Scene load_scene(const std::string& path, const VolumeLoadOptions& options) {
    json root = detail::parse_json_file(path);
    JsonFields f(root, path, "");
    Scene scene;
    scene.source = path;
    if (f.has("camera")) {
        JsonFields c(f.at("camera"), path, "camera");
        scene.camera.position = c.vec3("position", scene.camera.position);
        scene.camera.look_at = c.vec3("look_at", scene.camera.look_at);
        scene.camera.up = c.vec3("up", scene.camera.up);
        scene.camera.fov_y_deg = c.number("fov_y_deg", scene.camera.fov_y_deg);
        c.finish();
    }
    if (f.has("image")) {
        JsonFields im(f.at("image"), path, "image");
        scene.width = int(im.integer("width", scene.width, 1, limits::kMaxImageSide));
        scene.height = int(im.integer("height", scene.height, 1, limits::kMaxImageSide));
        im.finish();
    }
    scene.background = f.vec3("background", scene.background);
    scene.ambient_intensity = f.number("ambient_intensity", scene.ambient_intensity);
    if (scene.ambient_intensity < 0.f) f.fail("ambient_intensity", "must be ≥ 0");
    if (f.has("meshes")) {
        const json& meshes = f.at("meshes");
        if (!meshes.is_array()) f.fail("meshes", "must be an array");
        if (meshes.size() > std::size_t(limits::kMaxMeshes))
            f.fail("meshes", "at most " + std::to_string(limits::kMaxMeshes) + " meshes per scene");
        for (std::size_t i = 0; i < meshes.size(); ++i)
            scene.meshes.push_back(read_mesh(meshes[i], path, "meshes[" + std::to_string(i) + "]"));
    }
    // a scene needs something to show: volumes, or meshes alone (then "volumes" may be left out)
    if (f.has("volumes") || scene.meshes.empty()) {
        const json& volumes = f.at("volumes");
        if (!volumes.is_array() || (volumes.empty() && scene.meshes.empty()))
            f.fail("volumes", scene.meshes.empty() ? "must be a non-empty array" : "must be an array");
        if (volumes.size() > SOMBRA_MAX_VOLUMES)  // before any is loaded
            f.fail("volumes", "at most " + std::to_string(SOMBRA_MAX_VOLUMES) + " volumes per scene");
        for (std::size_t i = 0; i < volumes.size(); ++i)
            scene.volumes.push_back(read_volume(volumes[i], path, "volumes[" + std::to_string(i) + "]", options));
    }
    if (f.has("lights")) {
        const json& lights = f.at("lights");
        if (!lights.is_array()) f.fail("lights", "must be an array");
        if (lights.size() > std::size_t(limits::kMaxLights))
            f.fail("lights", "at most " + std::to_string(limits::kMaxLights) + " lights per scene");
        for (std::size_t i = 0; i < lights.size(); ++i)
            scene.lights.push_back(read_light(lights[i], path, "lights[" + std::to_string(i) + "]"));
    }
    if (f.has("render")) {  // checked against the options' declarations by scene_render_options
        const json& block = f.at("render");
        if (!block.is_object()) f.fail("render", "must be an object of render options");
        for (auto it = block.begin(); it != block.end(); ++it) scene.render_settings.emplace_back(it.key(), it.value().dump());
    }
    f.finish();
    if (!f.has("camera")) {  // not (0, 0, 3): the objects in frame
        fit_scene_camera(scene, scene.width, scene.height);
        for (const Vec3& p : {scene.camera.position, scene.camera.look_at})
            for (float c : p)
                if (!(std::fabs(c) <= limits::kMaxCoordinate)) scene.camera = Camera{};  // objects out of range: validate_scene names them
    }
    validate_scene(scene, path);
    return scene;
}

}  // namespace sombra
