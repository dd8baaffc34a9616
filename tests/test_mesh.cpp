// Meshes: the real OBJ files (counts from data/README.md), PLY, malformed files, scene JSON fields.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "sombra/sombra.h"
#include "test_support.h"

using namespace sombra;

namespace {

std::string write_text(const std::string& name, const std::string& text, std::ios::openmode mode = {}) {
    std::string path = test::temp_dir() + "/" + name;
    std::ofstream(path, std::ios::out | mode) << text;
    return path;
}

using test::error_of;

void require_one_line_naming(const std::string& message, const std::string& file, const std::string& what = "") {
    INFO(message);
    CHECK(message.rfind(file, 0) == 0);
    CHECK(message.find('\n') == std::string::npos);
    if (!what.empty()) CHECK(message.find(what) != std::string::npos);
}

std::array<float, 3> box_min(const Mesh& m) {
    std::array<float, 3> lo{1e30f, 1e30f, 1e30f};
    for (auto& p : m.positions)
        for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], p[i]);
    return lo;
}

const std::string kCubePlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 6\nproperty list uchar int vertex_indices\nend_header\n";
const std::string kCubePlyBody =
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";

// A minimal valid scene with one generated volume and `meshes`.
std::string scene_with_meshes(const std::string& name, const nlohmann::json& meshes) {
    nlohmann::json scene = {
        {"volumes", {{{"generator", {{"type", "sphere"}, {"size", 8}}},
                      {"transfer_function", {{"rgb_points", {0, 1, 1, 1}}, {"opacity_points", {0, 0, 1, 1}}}}}}},
        {"meshes", meshes}};
    return write_text(name, scene.dump(2));
}

}  // namespace

TEST_CASE("the real meshes load with the counts of data/README.md", "[mesh]") {
    Mesh teapot = load_mesh(test::data_path("meshes/teapot.obj"));
    CHECK(teapot.triangles.size() == 992);
    CHECK(teapot.positions.size() == 529);  // 792 `v` lines; Assimp welds the 263 repeated positions
    CHECK(teapot.normals.empty());
    CHECK(box_min(teapot)[0] == Approx(-16.070313f));
    CHECK(box_min(teapot)[2] == Approx(-10.f));

    Mesh bunny = load_mesh(test::data_path("meshes/bunny.obj"));
    CHECK(bunny.positions.size() == 1839);
    CHECK(bunny.triangles.size() == 3674);
    CHECK(box_min(bunny)[1] == Approx(-0.003149f));
    // The file's first triangle after the welding keeps its corners.
    for (auto& t : bunny.triangles)
        for (auto k : t) REQUIRE(k < bunny.positions.size());
}

TEST_CASE("PLY meshes load, ASCII and binary — quads are triangulated", "[mesh]") {
    Mesh cube = load_mesh(write_text("cube.ply", kCubePlyHeader + kCubePlyBody));
    CHECK(cube.positions.size() == 8);
    CHECK(cube.triangles.size() == 12);

    std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    binary.append(reinterpret_cast<const char*>(v), sizeof v);
    const unsigned char n = 3;
    const int idx[3] = {0, 1, 2};
    binary.push_back(char(n));
    binary.append(reinterpret_cast<const char*>(idx), sizeof idx);
    Mesh tri = load_mesh(write_text("tri.ply", binary, std::ios::binary));
    CHECK(tri.positions.size() == 3);
    REQUIRE(tri.triangles.size() == 1);
    CHECK(tri.positions[tri.triangles[0][1]][0] == 1.f);
}

TEST_CASE("normals are read when the file has them", "[mesh]") {
    std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nf 1//1 2//1 3//1\n";
    Mesh m = load_mesh(write_text("normals.obj", obj));
    REQUIRE(m.normals.size() == m.positions.size());
    for (auto& n : m.normals) CHECK(n[2] == Approx(1.f));  // unit length
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "property float nx\nproperty float ny\nproperty float nz\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n0 0 0 1 0 0\n1 0 0 1 0 0\n0 1 0 1 0 0\n3 0 1 2\n";
    m = load_mesh(write_text("normals.ply", ply));
    REQUIRE(m.normals.size() == 3);
    CHECK(m.normals[0][0] == Approx(1.f));
}

TEST_CASE("missing and malformed mesh files fail with one line naming the file", "[mesh]") {
    require_one_line_naming(error_of([] { load_mesh("/nonexistent/m.obj"); }), "/nonexistent/m.obj", "cannot open");
    const std::vector<std::pair<std::string, std::string>> bad = {
        {"empty.obj", ""},
        {"points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},  // no faces
        {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"},
        {"garbage.obj", "v 0 0 zero\nv 1 0\nf a b c\n"},
        {"truncated.ply", kCubePlyHeader + kCubePlyBody.substr(0, 40)},
        {"header.ply", "ply\nformat ascii 1.0\nelement vertex two\nend_header\n0 0 0\n"},
        {"range.ply", kCubePlyHeader + kCubePlyBody.substr(0, kCubePlyBody.size() - 10) + "4 3 0 9 7\n"},
    };
    for (auto& [name, text] : bad) {
        std::string f = write_text(name, text);
        require_one_line_naming(error_of([&] { load_mesh(f); }), f);
    }
}

TEST_CASE("scene meshes: file, transform, material — bad fields are named", "[mesh][scene]") {
    std::string teapot = test::data_path("meshes/teapot.obj");
    nlohmann::json good = {{{"file", teapot},
                            {"name", "pot"},
                            {"transform", {{"translate", {1, 2, 3}}, {"scale", 0.1}}},
                            {"material", {{"color", {1, 0.5, 0}}, {"opacity", 0.4}, {"specular", 0.6}, {"shininess", 8}}}}};
    Scene s = load_scene(scene_with_meshes("good.json", good));
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].mesh->triangles.size() == 992);
    CHECK(s.meshes[0].name == "pot");
    CHECK(s.meshes[0].transform[3] == 1.f);
    CHECK(s.meshes[0].transform[0] == Approx(0.1f));
    CHECK(s.meshes[0].material.opacity == 0.4f);
    CHECK(s.meshes[0].material.color[1] == 0.5f);
    CHECK(s.meshes[0].material.phong.specular == 0.6f);
    CHECK(s.meshes[0].material.phong.diffuse == Material{}.diffuse);

    struct Bad {
        nlohmann::json mesh;
        std::string field;
    };
    std::vector<Bad> bad = {
        {{{"file", teapot}, {"colour", 1}}, "meshes[0]: unknown key 'colour'"},
        {{{"name", "no file"}}, "meshes[0].file"},
        {{{"file", 3}}, "meshes[0].file"},
        {{{"file", teapot}, {"material", {{"opacity", 1.5}}}}, "meshes[0].material.opacity"},
        {{{"file", teapot}, {"material", {{"color", {1, 1}}}}}, "meshes[0].material.color"},
        {{{"file", teapot}, {"material", {{"color", {1, 2, 0}}}}}, "meshes[0].material.color"},
        {{{"file", teapot}, {"material", {{"diffuse", -1}}}}, "meshes[0].material.diffuse"},
        {{{"file", teapot}, {"material", {{"glossy", 1}}}}, "meshes[0].material: unknown key 'glossy'"},
        {{{"file", teapot}, {"transform", {{"scale", 0}}}}, "meshes[0].transform.scale"},
        {{{"file", teapot}, {"transform", {{"rotate", {0, 0, 90}}}}}, "meshes[0].transform: unknown key 'rotate'"},
    };
    for (std::size_t i = 0; i < bad.size(); ++i) {
        std::string f = scene_with_meshes("bad" + std::to_string(i) + ".json", nlohmann::json::array({bad[i].mesh}));
        require_one_line_naming(error_of([&] { load_scene(f); }), f, bad[i].field);
    }
    std::string f = scene_with_meshes("notarray.json", {{"file", teapot}});
    require_one_line_naming(error_of([&] { load_scene(f); }), f, "meshes");
    f = scene_with_meshes("missing.json", nlohmann::json::array({{{"file", "nowhere.obj"}}}));
    require_one_line_naming(error_of([&] { load_scene(f); }), (std::filesystem::path(f).parent_path() / "nowhere.obj").string(),
                            "cannot open");
}

namespace {

// Every directed edge once and its reverse once (closed, consistently wound); returns the signed
// volume (> 0: wound outwards).
double check_closed(const Mesh& m) {
    std::map<std::pair<unsigned, unsigned>, int> directed;
    double volume = 0;
    for (auto& t : m.triangles) {
        for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
        auto &a = m.positions[t[0]], &b = m.positions[t[1]], &c = m.positions[t[2]];
        volume += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    }
    std::size_t open = 0;
    for (auto& [edge, count] : directed) open += count != 1 || directed.count({edge.second, edge.first}) != 1;
    CHECK(open == 0);
    return volume;
}

}  // namespace

TEST_CASE("the UV sphere is closed and wound outwards", "[mesh]") {
    Mesh m = make_uv_sphere(6, 9, 2.f);
    validate_mesh(m, "sphere");
    CHECK(check_closed(m) > 0.);
}

TEST_CASE("the generated cup (scripts/make_cup_mesh.py) is closed and wound outwards, a few thousand triangles",
          "[mesh]") {
    Mesh cup = load_mesh(test::data_path("meshes/cup.obj"));
    CHECK(cup.triangles.size() == 2520);
    CHECK(cup.positions.size() == 1264);
    // stands on z = 0, 9 tall (rim 9.175), handle towards +x
    CHECK(box_min(cup)[2] == Approx(0.f).margin(1e-5));
    CHECK(box_min(cup)[0] == Approx(-4.f).margin(1e-3));
    // the volume of the material: wall and bottom (the handle a little more), far below the cup's
    double volume = check_closed(cup), full = 3.14159265 * 9.0 * (3.1 * 3.1 + 3.1 * 4.0 + 4.0 * 4.0) / 3.0;
    CHECK(volume > 0.1 * full);
    CHECK(volume < 0.35 * full);
}