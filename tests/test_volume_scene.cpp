// From a volume file to a picture (issue 29): `sombra info`, `sombra render VOLUME_FILE` with its
// fitted camera, key light and preset, --write-scene, camera-less scenes fitted, shadows by default.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include "test_support.h"

namespace {

using sombra::test::CliOutput;
using sombra::test::run_cli_output;

// A float32 .npy of shape (z, y, x) = (4, 3, 2) holding 0, 1, …, 23 in file order (x fastest).
std::string tiny_npy() {
    std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (4, 3, 2), }";
    while ((10 + dict.size() + 1) % 64 != 0) dict += ' ';
    dict += '\n';
    std::string bytes = std::string("\x93NUMPY\x01\x00", 8) + char(dict.size() & 0xff) + char(dict.size() >> 8) + dict;
    for (int i = 0; i < 24; ++i) {
        const float v = float(i);
        bytes.append(reinterpret_cast<const char*>(&v), 4);
    }
    const std::string path = sombra::test::temp_dir() + "/tiny.npy";
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
}

// Where a world point lands in a width × height image seen by `camera`: pixel x, y (y down).
std::array<double, 2> project(const sombra::Camera& c, const sombra::Vec3& p, int width, int height) {
    auto sub = [](const sombra::Vec3& a, const sombra::Vec3& b) { return std::array<double, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
    auto dot = [](const std::array<double, 3>& a, const std::array<double, 3>& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    auto unit = [&](std::array<double, 3> a) {
        const double n = std::sqrt(dot(a, a));
        return std::array<double, 3>{a[0] / n, a[1] / n, a[2] / n};
    };
    const auto f = unit(sub(c.look_at, c.position));
    const std::array<double, 3> u0{c.up[0], c.up[1], c.up[2]};
    const auto r = unit({f[1] * u0[2] - f[2] * u0[1], f[2] * u0[0] - f[0] * u0[2], f[0] * u0[1] - f[1] * u0[0]});
    const std::array<double, 3> u{r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    const auto d = sub(p, c.position);
    const double t = std::tan(c.fov_y_deg * 3.14159265358979 / 360);
    const double x = dot(d, r) / dot(d, f) / (t * width / height), y = dot(d, u) / dot(d, f) / t;
    return {(x + 1) / 2 * width, (1 - y) / 2 * height};
}

// Every corner of `box` projects inside the image, in front of the camera.
void require_in_frame(const sombra::Camera& camera, const sombra::Box3& box, int width, int height) {
    for (int corner = 0; corner < 8; ++corner) {
        const sombra::Vec3 p{corner & 1 ? box.hi[0] : box.lo[0], corner & 2 ? box.hi[1] : box.lo[1], corner & 4 ? box.hi[2] : box.lo[2]};
        const auto xy = project(camera, p, width, height);
        INFO("corner " << corner << " at pixel " << xy[0] << ", " << xy[1]);
        CHECK(xy[0] >= 0);
        CHECK(xy[0] <= width);
        CHECK(xy[1] >= 0);
        CHECK(xy[1] <= height);
    }
}

std::size_t lines(const std::string& text) { return std::size_t(std::count(text.begin(), text.end(), '\n')); }

}  // namespace

TEST_CASE("sombra info: a tiny .npy's size, type, bounds, value range, percentiles and histogram", "[cli][info]") {
    const std::string npy = tiny_npy();
    CliOutput text = run_cli_output("info " + npy);
    INFO(text.err);
    REQUIRE(text.exit_code == 0);
    CHECK_THAT(text.out, Catch::Contains("2 × 3 × 4 (24 voxels)"));
    CHECK_THAT(text.out, Catch::Contains("float32"));
    CHECK_THAT(text.out, Catch::Contains("x [-1, 1]  y [-1.5, 1.5]  z [-2, 2]"));
    CHECK_THAT(text.out, Catch::Contains("min 0, max 23, mean 11.5"));
    CHECK_THAT(text.out, Catch::Contains("p1 0.23  p5 1.15  p25 5.75  p50 11.5  p75 17.25  p95 21.85  p99 22.77"));
    CHECK_THAT(text.out, Catch::Contains("non-finite    0"));

    CliOutput json = run_cli_output("info --json " + npy);
    REQUIRE(json.exit_code == 0);
    const nlohmann::json j = nlohmann::json::parse(json.out);  // one JSON object, nothing else
    CHECK(j.at("kind") == "volume");
    CHECK(j.at("format") == "npy");
    CHECK(j.at("voxel_type") == "float32");
    CHECK(j.at("dims") == nlohmann::json({2, 3, 4}));
    CHECK(j.at("voxels") == 24);
    CHECK(j.at("world_bounds").at("min") == nlohmann::json({-1.0, -1.5, -2.0}));
    CHECK(j.at("world_bounds").at("max") == nlohmann::json({1.0, 1.5, 2.0}));
    CHECK(j.at("min") == 0.0);
    CHECK(j.at("max") == 23.0);
    CHECK(j.at("percentiles").at("p50").get<double>() == Approx(11.5));
    CHECK(j.at("percentiles").at("p99").get<double>() == Approx(22.77));
    CHECK(j.at("background").at("voxels") == 1);  // 0 only: ≤ 0.23
    CHECK(j.at("foreground_percentiles").at("p1").get<double>() == Approx(1.22));  // of 1 … 23
    CHECK(j.at("non_finite") == 0);
    const auto counts = j.at("histogram").at("counts").get<std::vector<std::size_t>>();
    CHECK(counts.size() == 16);
    CHECK(std::accumulate(counts.begin(), counts.end(), std::size_t(0)) == 24);
    CHECK(j.at("placement").size() == 16);
    CHECK(j.at("preset") == "ct");  // 1 voxel of 24 is background: the data fill the box
}

TEST_CASE("sombra info: a real volume's placement in RAS millimetres and a scene's objects, lights and camera", "[cli][info]") {
    CliOutput head = run_cli_output("info --json " + sombra::test::data_path("volumes/ch2.nii.gz"));
    REQUIRE(head.exit_code == 0);
    const nlohmann::json h = nlohmann::json::parse(head.out);
    CHECK(h.at("voxel_type") == "uint8");
    CHECK(h.at("dims") == nlohmann::json({181, 217, 181}));
    CHECK(h.at("world_bounds").at("min") == nlohmann::json({-90.5, -125.5, -71.5}));
    CHECK(h.at("max") == 254.0);

    CliOutput scene = run_cli_output("info --json " + sombra::test::data_path("scenes/default.json"));
    REQUIRE(scene.exit_code == 0);
    const nlohmann::json s = nlohmann::json::parse(scene.out);
    CHECK(s.at("kind") == "scene");
    REQUIRE(s.at("objects").size() == 1);
    CHECK(s.at("objects")[0].at("world_bounds").at("min") == nlohmann::json({-64.0, -64.0, -128.0}));
    CHECK(s.at("lights").size() == 2);
    CHECK(s.at("lights")[1].at("type") == "point");
    CHECK(s.at("camera").at("fitted") == false);
    CHECK(s.at("camera").at("position") == nlohmann::json({0.0, -420.0, 60.0}));
}

TEST_CASE("sombra info and render: an unreadable file is one error line naming it, a non-zero exit and no output", "[cli][info]") {
    const std::string dir = sombra::test::temp_dir();
    const std::string missing = dir + "/no_such_volume.nii.gz";
    CliOutput info = run_cli_output("info " + missing);
    CHECK(info.exit_code != 0);
    CHECK(lines(info.err) == 1);
    CHECK_THAT(info.err, Catch::Contains(missing));
    CHECK(info.out.empty());

    const std::string bad = dir + "/bad.npy", out = dir + "/bad.png", written = dir + "/bad_scene.json";
    std::ofstream(bad) << "not a numpy file";
    CliOutput render = run_cli_output("render " + bad + " -o " + out + " --write-scene " + written);
    CHECK(render.exit_code != 0);
    CHECK(lines(render.err) == 1);
    CHECK_THAT(render.err, Catch::Contains(bad));
    CHECK_FALSE(std::filesystem::exists(out));
    CHECK_FALSE(std::filesystem::exists(written));

    // --preset and --write-scene belong to a volume file
    CliOutput scene = run_cli_output("render " + sombra::test::data_path("scenes/default.json") + " -o " + out + " --preset ct");
    CHECK(scene.exit_code != 0);
    CHECK(lines(scene.err) == 1);
    CHECK_THAT(scene.err, Catch::Contains("--preset: applies to a volume file"));
    CHECK_FALSE(std::filesystem::exists(out));
}

TEST_CASE("sombra render VOLUME_FILE: the volume in frame with deep shadow maps, and --write-scene renders the same image",
          "[cli][volume_scene]") {
    const std::string dir = sombra::test::temp_dir();
    const std::string volume = sombra::test::data_path("volumes/heart.vtk");
    const std::string out = dir + "/heart.png", stats = dir + "/heart-stats.json", scene_path = dir + "/heart_scene.json";
    CliOutput run = run_cli_output("render " + volume + " -o " + out + " --width 64 --height 48 --stats " + stats + " --write-scene " +
                         scene_path + " --device " + sombra::test::device_selector() + " --shadow-cache off");  // auto's measured choice may differ run to run
    INFO(run.err);
    REQUIRE(run.exit_code == 0);
    std::ifstream stats_in(stats);
    const nlohmann::json st = nlohmann::json::parse(stats_in);
    CHECK(st.at("options").at("shadows") == "dsm");  // shadows by default
    CHECK(st.at("dsm").is_object());

    // the written scene: a camera that frames the volume's world box at the image's aspect
    const sombra::Scene scene = sombra::load_scene(scene_path);
    CHECK(scene.width == 64);
    CHECK(scene.height == 48);
    REQUIRE(scene.volumes.size() == 1);
    REQUIRE(scene.lights.size() == 1);
    CHECK(scene.volumes[0].volume->source == std::filesystem::path(volume).lexically_normal().string());
    require_in_frame(scene.camera, sombra::world_bounds(scene.volumes[0]), 64, 48);

    // not all background: the heart (auto: ct, its densest quarter) covers a good part of the picture
    const sombra::Image image = sombra::read_image(out);
    REQUIRE(image.width == 64);
    std::size_t covered = 0;  // pixels unlike the corner's, which the 4 % margin leaves to the background
    for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
        float d = 0;
        for (std::size_t c = 0; c < 3; ++c) d = std::max(d, std::fabs(image.rgba[i + c] - image.rgba[c]));
        covered += d > 0.05f ? 1 : 0;
    }
    CHECK(covered > std::size_t(image.width * image.height / 16));  // measured: 322 of 3072

    // the written scene renders the same image
    const std::string again = dir + "/heart_again.png";
    CliOutput rerun = run_cli_output("render " + scene_path + " -o " + again + " --device " + sombra::test::device_selector() + " --shadow-cache off");
    INFO(rerun.err);
    REQUIRE(rerun.exit_code == 0);
    const auto difference = sombra::test::compare(image, sombra::read_image(again));
    CHECK(difference.max_abs == 0);
}

TEST_CASE("a scene without \"camera\" gets the fitted camera, and a given camera stays as written", "[scene][volume_scene]") {
    const std::string dir = sombra::test::temp_dir();
    nlohmann::json j = {{"image", {{"width", 80}, {"height", 40}}},
                        {"volumes", {{{"file", sombra::test::data_path("volumes/stent.npz")},
                                      {"transform", {{"translate", {500, -20, 30}}}},
                                      {"transfer_function", {{"rgb_points", {0, 1, 1, 1}}, {"opacity_points", {0, 0, 2000, 0.5}}}}}}},
                        {"lights", {{{"type", "directional"}, {"direction", {0, 0, -1}}}}}};
    const std::string path = dir + "/no_camera.json";
    std::ofstream(path) << j.dump();
    const sombra::Scene fitted = sombra::load_scene(path);
    CHECK(fitted.camera_fitted);
    const sombra::Box3 box = sombra::world_bounds(fitted);
    CHECK(box.lo[0] == 436.f);
    CHECK(box.hi[2] == 158.f);
    CHECK(fitted.camera.look_at == sombra::Vec3{500, -20, 30});
    CHECK(fitted.camera.up == sombra::Vec3{0, 0, 1});
    CHECK(fitted.camera.position[1] > 0.f);  // from the front (+y) and above
    CHECK(fitted.camera.position[2] > 30.f);
    require_in_frame(fitted.camera, box, 80, 40);

    j["camera"] = {{"position", {0, 0, 3}}, {"look_at", {0, 0, 0}}};
    std::ofstream(path) << j.dump();
    const sombra::Scene given = sombra::load_scene(path);
    CHECK_FALSE(given.camera_fitted);
    CHECK(given.camera.position == sombra::Vec3{0, 0, 3});
}

TEST_CASE("volume presets: auto picks ct, mri or fog by the values, and each ramp follows the percentiles", "[volume_scene]") {
    sombra::VolumeScene ct = sombra::volume_scene(sombra::test::data_path("volumes/stent.npz"), sombra::TransferPreset::Auto);
    CHECK(ct.preset == sombra::TransferPreset::Ct);  // 0–2000: a 12-bit range
    const auto& tf = ct.scene.volumes[0].transfer_function;
    CHECK(tf.opacity(float(ct.statistics.foreground_percentiles[4])) == 0.f);  // nothing below fg p75
    CHECK(tf.opacity(float(ct.statistics.foreground_percentiles[6])) == Approx(0.6f));
    sombra::VolumeScene fog = sombra::volume_scene(sombra::test::data_path("volumes/smoke_plume.vdb"), sombra::TransferPreset::Auto);
    CHECK(fog.preset == sombra::TransferPreset::Fog);
    CHECK(fog.scene.camera.up == sombra::Vec3{0, 1, 0});  // OpenVDB: Y up
    sombra::VolumeScene crop = sombra::volume_scene(sombra::test::data_path("volumes/heart.vtk"), sombra::TransferPreset::Auto);
    CHECK(crop.preset == sombra::TransferPreset::Ct);  // 0–255, 8 % background: the data fill the box
    sombra::VolumeScene mri = sombra::volume_scene(sombra::test::data_path("volumes/ch2.nii.gz"), sombra::TransferPreset::Auto);
    CHECK(mri.preset == sombra::TransferPreset::Mri);
    CHECK(mri.scene.volumes[0].transfer_function.opacity(float(mri.statistics.foreground_percentiles[2])) == 0.f);
    CHECK(sombra::choose_transfer_preset(mri.statistics, "nifti") == sombra::TransferPreset::Mri);
    CHECK_THROWS_WITH(sombra::parse_transfer_preset("bone"), Catch::Contains("unknown preset 'bone'"));
}
