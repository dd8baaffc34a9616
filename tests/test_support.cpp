#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sys/wait.h>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <fstream>
#include <unistd.h>

namespace sombra::test {

// The device of the whole suite: SOMBRA_DEVICE (a --device value: "cpu", "gpu", "auto" or an index
// from `sombra devices`), PoCL's CPU device by default.
std::string device_selector() {
    const char* chosen = std::getenv("SOMBRA_DEVICE");
    return chosen && *chosen ? chosen : "cpu";
}

Context& context() {
    static Context ctx(device_selector());
    return ctx;
}

ImageDifference compare(const Image& a, const Image& b) {
    ImageDifference d;
    std::size_t n = std::min(a.rgba.size(), b.rgba.size()) / 4;
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            float x = a.rgba[i * 4 + c], y = b.rgba[i * 4 + c];
            if (!std::isfinite(x) || !std::isfinite(y)) { ++d.non_finite; continue; }
            double diff = std::fabs(double(x) - double(y));
            d.max_abs = std::max(d.max_abs, diff);
            d.mean_abs += diff;
        }
    d.mean_abs /= double(std::max<std::size_t>(1, n * 3));
    return d;
}

TransferFunction ramp_tf(float lo, float hi, float max_alpha) {
    TransferFunction tf;
    tf.color_points = {{0.f, 0.9f, 0.5f, 0.3f}, {1.f, 0.3f, 0.6f, 1.0f}};
    tf.opacity_points = {{lo, 0.f}, {hi, max_alpha}, {1.f, max_alpha}};
    if (lo <= 0.f) tf.opacity_points.erase(tf.opacity_points.begin());
    return tf;
}

MeshInstance centred_mesh(const std::string& data_file, const Vec3& rotate_deg) {
    Mesh mesh = load_mesh(data_path(data_file));
    std::array<float, 3> lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
    for (auto& p : mesh.positions)
        for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
    float size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    for (auto& p : mesh.positions)
        for (int i = 0; i < 3; ++i) p[i] = (p[i] - 0.5f * (lo[i] + hi[i])) / size;
    MeshInstance mi;
    mi.mesh = std::make_shared<const Mesh>(std::move(mesh));
    mi.transform = make_transform({0, 0, 0}, rotate_deg, {1, 1, 1});
    return mi;
}

MeshInstance quad(float half, float z0, float opacity, Vec3 color) {
    auto mesh = std::make_shared<Mesh>();
    mesh->positions = {{-half, -half, z0}, {half, -half, z0}, {half, half, z0}, {-half, half, z0}};
    mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
    mesh->source = "quad";
    MeshInstance mi;
    mi.mesh = mesh;
    mi.material.color = color;
    mi.material.opacity = opacity;
    mi.name = "quad";
    return mi;
}

Camera mesh_camera() {
    Camera cam;
    cam.position = {0.3f, 0.4f, 1.8f};
    cam.fov_y_deg = 40.f;
    return cam;
}

std::shared_ptr<const Volume> constant_volume(std::array<int, 3> dims, float value) {
    Volume v;
    v.dims = dims;
    v.voxels.assign(v.voxel_count(), value);
    v.source = "constant";
    v.update_range();
    return std::make_shared<const Volume>(std::move(v));
}

TransferFunction constant_tf(float alpha) {
    TransferFunction tf;
    tf.color_points = {{0.f, 1.f, 1.f, 1.f}};
    tf.opacity_points = {{0.f, alpha}};
    return tf;
}

RenderOptions unshadowed() {
    RenderOptions options;
    options.shadows = ShadowTechnique::None;
    return options;
}

Scene sphere_scene(int size) {
    Scene s;
    VolumeInstance vi;
    vi.volume = std::make_shared<const Volume>(make_sphere(size, 0.4f, 1.f));
    vi.transfer_function = ramp_tf(0.2f, 0.6f, 0.4f);
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {1.f / size, 1.f / size, 1.f / size});
    s.volumes.push_back(vi);
    Light l;
    l.direction = {-0.3f, -0.5f, -0.8f};
    s.lights.push_back(l);
    s.camera.position = {0.3f, 0.4f, 2.2f};
    s.background = {0.1f, 0.1f, 0.2f};
    s.width = s.height = 40;
    return s;
}

Scene overlapping_scene() {
    Scene s;
    VolumeInstance a, b;
    a.volume = std::make_shared<const Volume>(make_gaussian_blobs(20, 5, 7));
    a.transfer_function = ramp_tf(0.1f, 0.7f, 0.5f);
    a.transform = make_transform({-0.15f, 0.f, 0.f}, {20.f, 35.f, 0.f}, {0.05f, 0.05f, 0.05f});
    a.material.specular = 0.5f;
    b.volume = std::make_shared<const Volume>(make_cloud_noise(16, 3));
    b.spacing = {1.f, 1.5f, 1.f};
    b.transfer_function = ramp_tf(0.2f, 0.9f, 0.3f);
    b.transform = make_transform({0.2f, 0.1f, -0.1f}, {0.f, -25.f, 10.f}, {0.06f, 0.06f, 0.06f});
    b.step_voxels = 0.35f;
    s.volumes = {a, b};
    Light dir, spot, point;
    dir.direction = {0.f, -1.f, -0.2f};
    dir.intensity = 0.7f;
    spot.type = LightType::Spot;
    spot.position = {1.5f, 1.f, 1.5f};
    spot.direction = {-1.5f, -1.f, -1.5f};
    spot.cone_angle_deg = 12.f;
    spot.cone_softness = 0.3f;
    spot.color = {1.f, 0.6f, 0.3f};
    point.type = LightType::Point;
    point.position = {-1.f, 0.5f, 1.f};
    point.att_linear = 0.3f, point.att_quadratic = 0.2f;
    s.lights = {dir, spot, point};
    s.camera.position = {0.4f, 0.5f, 2.f};
    s.camera.fov_y_deg = 35.f;
    s.width = 48, s.height = 36;
    return s;
}

// A folder named by mkdtemp, not by the process id: a folder left behind by an earlier process
// with the same id (ids are reused, across CI's test runs too) once handed a program-cache test
// that earlier process's cache. Removed with its contents when the process exits.
std::string temp_dir() {
    struct OwnedFolder {
        std::string path;
        OwnedFolder() {
            std::string pattern = (std::filesystem::temp_directory_path() / "sombra-test-XXXXXX").string();
            if (!mkdtemp(pattern.data())) throw std::runtime_error("test: cannot create a folder from " + pattern);
            path = pattern;
        }
        ~OwnedFolder() {
            std::error_code ignored;
            std::filesystem::remove_all(path, ignored);
        }
    };
    static OwnedFolder folder;
    return folder.path;
}

std::string data_path(const std::string& relative) { return std::string(SOMBRA_DATA_DIR) + "/" + relative; }

CliOutput run_cli_output(const std::string& args) {
    const std::string dir = temp_dir();
    const std::string command = std::string(SOMBRA_CLI) + " " + args + " >" + dir + "/stdout.txt 2>" + dir + "/stderr.txt";
    const int status = std::system(command.c_str());
    const auto read = [](const std::string& path) {
        std::ifstream in(path);
        std::stringstream text;
        text << in.rdbuf();
        return text.str();
    };
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read(dir + "/stdout.txt"), read(dir + "/stderr.txt")};
}

}  // namespace sombra::test
