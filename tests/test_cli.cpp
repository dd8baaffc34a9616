// The `sombra` executable: bad input gets one clear line naming file and field, a non-zero exit
// and no output file; good input writes the image and the stats.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <sys/stat.h>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include "test_support.h"

namespace {

using sombra::test::CliOutput;
using sombra::test::run_cli_output;

struct CliRun {
    int exit_code;
    std::string stderr_text;
};

CliRun run_cli(const std::string& args) {
    std::string err = sombra::test::temp_dir() + "/stderr.txt";
    std::string command = std::string(SOMBRA_CLI) + " " + args + " 2>" + err + " >/dev/null";
    int status = std::system(command.c_str());
    std::ifstream in(err);
    std::stringstream text;
    text << in.rdbuf();
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text.str()};
}

// stdout and stderr of one run
std::string write_file(const std::string& name, const std::string& content) {
    std::string path = sombra::test::temp_dir() + "/" + name;
    std::ofstream(path) << content;
    return path;
}

// A minimal valid scene with one generated volume; `patch` is merged into it.
std::string scene_file(const std::string& name, const nlohmann::json& patch) {
    nlohmann::json scene = {
        {"camera", {{"position", {0, 0, 3}}, {"look_at", {0, 0, 0}}}},
        {"image", {{"width", 32}, {"height", 24}}},
        {"volumes", {{{"generator", {{"type", "sphere"}, {"size", 16}}},
                      {"transform", {{"scale", 0.06}}},
                      {"transfer_function", {{"rgb_points", {0, 1, 1, 1, 1, 1, 0.5, 0.2}},
                                             {"opacity_points", {0, 0, 1, 0.5}}}}}}},
        {"lights", {{{"type", "directional"}, {"direction", {0, -1, -1}}}}}};
    scene.merge_patch(patch);
    return write_file(name, scene.dump(2));
}

void require_clean_failure(const CliRun& run, const std::string& file, const std::string& field, const std::string& output) {
    INFO("stderr: " << run.stderr_text);
    CHECK(run.exit_code != 0);
    CHECK(std::count(run.stderr_text.begin(), run.stderr_text.end(), '\n') == 1);
    CHECK(run.stderr_text.find(file) != std::string::npos);
    CHECK(run.stderr_text.find(field) != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(output));
}

// Two small spheres, "left" and "right", 4 apart across a directional light: two clusters.
std::string two_spheres_file(const std::string& name) {
    const nlohmann::json sphere = {{"type", "sphere"}, {"size", 16}};
    const nlohmann::json tf = {{"rgb_points", {0, 1, 1, 1, 1, 1, 1, 1}}, {"opacity_points", {0, 0, 1, 0.5}}};
    auto volume = [&](const char* volume_name, float x) {
        return nlohmann::json{{"name", volume_name}, {"generator", sphere}, {"transfer_function", tf},
                              {"transform", {{"translate", {x, 0, 0}}, {"scale", 0.06}}}};
    };
    return scene_file(name, {{"camera", {{"position", {0, 0, 8}}}}, {"volumes", {volume("left", -2), volume("right", 2)}}});
}

}  // namespace

TEST_CASE("sombra render writes the image and the stats", "[cli]") {
    std::string scene = scene_file("good.json", nlohmann::json::object());
    std::string out = sombra::test::temp_dir() + "/good.png", stats = sombra::test::temp_dir() + "/good-stats.json";
    CliRun run = run_cli("render " + scene + " -o " + out + " --stats " + stats + " --device " + sombra::test::device_selector());
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    REQUIRE(std::filesystem::exists(out));
    auto image = sombra::read_image(out);
    CHECK(image.width == 32);
    CHECK(image.height == 24);
    std::ifstream in(stats);
    auto j = nlohmann::json::parse(in);
    CHECK(j.at("samples").get<double>() > 0);
    CHECK(j.at("stage_ms").contains("camera_pass"));
    CHECK(!j.at("device").get<std::string>().empty());
}

TEST_CASE("sombra render --shadows lowpass writes soft shadows", "[cli]") {
    std::string scene = scene_file("lowpass.json", nlohmann::json::object());
    std::string out = sombra::test::temp_dir() + "/lowpass.png", stats = sombra::test::temp_dir() + "/lowpass-stats.json";
    CliRun run = run_cli("render " + scene + " -o " + out + " --stats " + stats + " --shadows lowpass --filter 5 --filter-kernel gauss");
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    CHECK(std::filesystem::exists(out));
    std::ifstream in(stats);
    CHECK(nlohmann::json::parse(in).at("sat").at("tables").get<int>() == 1);

    // --sat-cells-across: a filter of 16 voxels gets cells of 2 across the light (8 per patch), or
    // voxel cells with 0; the cells along the light stay
    std::vector<double> cell_voxels;  // the last run's, in finest voxels
    auto cells = [&](const std::string& across) {
        CliRun wide = run_cli("render " + scene + " -o " + out + " --stats " + stats + " --shadows lowpass --filter 16" + across);
        INFO(wide.stderr_text);
        REQUIRE(wide.exit_code == 0);
        std::ifstream stats_in(stats);
        const nlohmann::json table = nlohmann::json::parse(stats_in).at("sat").at("per_table").at(0);
        cell_voxels = table.at("cell_voxels").get<std::vector<double>>();
        std::sort(cell_voxels.begin(), cell_voxels.end());
        return table.at("cells").get<std::vector<int>>();
    };
    const std::vector<int> fine = cells(" --sat-cells-across 0");
    REQUIRE(cell_voxels.size() == 3);
    CHECK(cell_voxels[0] == Approx(1.0));
    CHECK(cell_voxels[2] == Approx(1.0));
    const std::vector<int> coarse = cells("");
    CHECK(cell_voxels[0] == Approx(1.0));  // along the light
    CHECK(cell_voxels[1] == Approx(2.0));  // across it: 16 / 8
    CHECK(cell_voxels[2] == Approx(2.0));
    REQUIRE(coarse.size() == 3);
    int halved = 0, kept = 0;
    for (std::size_t a = 0; a < 3; ++a) halved += 2 * coarse[a] <= fine[a] + 2, kept += coarse[a] == fine[a];
    CHECK(halved == 2);
    CHECK(kept == 1);
    CliRun dsm = run_cli("render " + scene + " -o " + out + " --shadows dsm --sat-cells-across 4");
    CHECK(dsm.exit_code != 0);
    CHECK(dsm.stderr_text == "sombra: error: --sat-cells-across: applies to --shadows lowpass, ao, not dsm\n");
}

TEST_CASE("sombra --version prints the project's version", "[cli]") {
    CliOutput run = run_cli_output("--version");
    INFO(run.err);
    CHECK(run.exit_code == 0);
    CHECK(run.out == std::string("sombra ") + SOMBRA_VERSION + "\n");
    CHECK(std::string(SOMBRA_VERSION).find('.') != std::string::npos);
}

TEST_CASE("misspelt commands, options and scene keys name the closest real one", "[cli]") {
    std::string f = scene_file("suggest.json", nlohmann::json::object());
    std::string out = sombra::test::temp_dir() + "/suggest.png";
    std::remove(out.c_str());
    const auto check_line = [&](const std::string& args, const std::string& line) {
        CliRun run = run_cli(args);
        INFO(args);
        CHECK(run.stderr_text == line + "\n");
        CHECK(run.exit_code == 2);
        CHECK_FALSE(std::filesystem::exists(out));
    };
    check_line("rendr " + f + " -o " + out, "sombra: error: unknown command 'rendr' (did you mean 'render'?)");
    check_line("visiblity " + f, "sombra: error: unknown command 'visiblity' (did you mean 'visibility'?)");
    check_line("frobnicate", "sombra: error: unknown command 'frobnicate'");
    check_line("--verison", "sombra: error: unknown option '--verison' (did you mean '--version'?)");
    check_line("render " + f + " -o " + out + " --shadow dsm",
               "sombra: error: unknown option '--shadow' (did you mean '--shadows'?)");
    // named before the missing -o, also in the --name=value form
    check_line("render " + f + " --dsm-rse=64", "sombra: error: unknown option '--dsm-rse' (did you mean '--dsm-res'?)");
    check_line("dsm " + f + " --light 0 -o d.exr --filter 2", "sombra: error: unknown option '--filter'");
    // scene keys: a misspelt required key is unknown, not missing; an optional one gets the closest key too
    nlohmann::json volume = {{"generator", {{"type", "sphere"}, {"size", 16}}},
                             {"transfer_fuction", {{"rgb_points", {0, 1, 1, 1}}, {"opacity_points", {0, 0, 1, 1}}}}};
    std::string typo = scene_file("suggest_tf.json", {{"volumes", {volume}}});
    CliRun run = run_cli("render " + typo + " -o " + out);
    require_clean_failure(run, typo + ": volumes[0]: unknown key 'transfer_fuction' (did you mean 'transfer_function'?)", "", out);
    CHECK(run.exit_code == 1);
    typo = scene_file("suggest_fov.json", {{"camera", {{"fov_y_dg", 30}}}});
    require_clean_failure(run_cli("render " + typo + " -o " + out),
                          typo + ": camera: unknown key 'fov_y_dg' (did you mean 'fov_y_deg'?)", "", out);
}

TEST_CASE("sombra render --help shows every option's default, from RenderOptions{}", "[cli]") {
    CliOutput run = run_cli_output("render --help");
    REQUIRE(run.exit_code == 0);
    const auto line_of = [&](const std::string& option) {
        std::size_t at = run.out.find("  " + option + " ");
        REQUIRE(at != std::string::npos);
        return run.out.substr(at, run.out.find('\n', at) - at);
    };
    const sombra::RenderOptions defaults;
    CHECK_THAT(line_of("--dsm-res"), Catch::Contains("=" + std::to_string(defaults.dsm.resolution)));
    CHECK_THAT(line_of("--eps"), Catch::Contains("=0.02"));
    CHECK_THAT(line_of("--filter"), Catch::Contains("=3"));
    CHECK_THAT(line_of("--cone-angle"), Catch::Contains("=10"));
    CHECK_THAT(line_of("--shadows"), Catch::Contains("=dsm"));  // shadows by default (issue 29)
    CHECK_THAT(line_of("--dsm-storage"), Catch::Contains("=" + defaults.dsm.storage));
    CHECK_THAT(line_of("--dsm-lookup"), Catch::Contains("=" + defaults.dsm.lookup));
    CHECK_THAT(line_of("--device"), Catch::Contains("=auto"));
    // generated: every declared option of the command has its flag, its default inside its own range
    for (const sombra::OptionSpec& spec : sombra::render_option_specs()) {
        if (!(spec.commands & sombra::kRenderCommand)) continue;
        INFO(spec.key);
        CHECK_NOTHROW(sombra::check_option_value(spec, spec.default_value(), spec.key));
        if (spec.kind != sombra::OptionKind::Flag)
            CHECK_THAT(line_of(spec.flag), Catch::Contains("=" + sombra::option_value_text(spec.default_value())));
        else
            CHECK_THAT(line_of(spec.flag), Catch::Contains(spec.help));
    }
}

TEST_CASE("sombra render and dsm --stats hold the version, the scene, the options and the whole command time", "[cli]") {
    const std::string dir = sombra::test::temp_dir();
    std::string scene = scene_file("stats_fields.json", {{"image", {{"width", 8}, {"height", 8}}}});
    std::string stats = dir + "/stats_fields.stats.json";
    CliRun run = run_cli("render " + scene + " -o " + dir + "/stats_fields.exr --stats " + stats +
                         " --shadows dsm --dsm-res 16 --eps 0.05 --lanes 4");
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
    CHECK(j.at("version") == SOMBRA_VERSION);
    CHECK(j.at("scene") == scene);
    CHECK(j.at("total_ms").get<double>() > 0);
    CHECK(j.at("total_ms").get<double>() >= j.at("stage_ms").at("camera_pass").get<double>());
    const nlohmann::json& o = j.at("options");
    CHECK(o.at("shadows") == "dsm");
    CHECK(o.at("dsm_resolution") == 16);
    CHECK(o.at("dsm_epsilon").get<double>() == 0.05);  // the float's shortest decimal form
    CHECK(o.at("lanes") == 4);
    CHECK(o.at("lowpass_filter_width").get<double>() == Approx(sombra::RenderOptions{}.sat.filter_width));
    CHECK(o.at("volume_storage") == "auto");
    for (const sombra::OptionSpec& spec : sombra::render_option_specs())  // every option of the command, none other
        CHECK(o.contains(spec.key) == bool(spec.commands & sombra::kRenderCommand));
    CHECK(j.at("width") == 8);

    // sombra dsm: the maps' sizes, no camera fields
    std::string point = scene_file("stats_point.json", {{"lights", {{{"type", "point"}, {"position", {0, 0.5, 0.5}}}}}});
    run = run_cli("dsm " + point + " --light 0 --dsm-res 8 -o " + dir + "/stats_faces.exr --stats " + stats);
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    j = nlohmann::json::parse(std::ifstream(stats));
    for (const char* camera_only : {"width", "height", "samples", "msamples_per_s"}) CHECK_FALSE(j.contains(camera_only));
    CHECK(j.at("dsm").at("views") == 6);
    CHECK(j.at("dsm").at("resolution") == 8);
    CHECK(j.at("dsm").at("nodes").get<double>() > 0);
    CHECK(j.at("dsm").at("bytes_used").get<double>() > 0);
    CHECK(j.at("options").at("dsm_resolution") == 8);
    CHECK_FALSE(j.at("options").contains("shadows"));  // camera options do not apply
    CHECK(j.at("scene") == point);
}

TEST_CASE("EXR is premultiplied (no background where nothing is), PNG has the background composited", "[cli]") {
    const std::string dir = sombra::test::temp_dir();
    std::string scene = scene_file("premultiplied.json", {{"background", {0.55, 0.6, 0.7}}});
    const std::string png = dir + "/premultiplied.png", exr = dir + "/premultiplied.exr";
    for (const std::string& out : {png, exr}) {
        // off: two processes must not choose differently near auto's break-even (README, the shadow cache)
        CliRun run = run_cli("render " + scene + " -o " + out + " --shadows rays --shadow-cache off");
        INFO(run.stderr_text);
        REQUIRE(run.exit_code == 0);
    }
    sombra::Image e = sombra::read_image(exr), p = sombra::read_image(png);
    REQUIRE(e.width == p.width);
    REQUIRE(e.height == p.height);
    for (int c = 0; c < 4; ++c) CHECK(e.rgba[std::size_t(c)] == 0.f);  // the corner: empty, transparent black
    const float background[3] = {0.55f, 0.6f, 0.7f};
    const auto to_srgb = [](float v) {
        v = std::min(std::max(v, 0.f), 1.f);
        return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
    };
    double covered = 0, worst = 0;
    for (std::size_t i = 0; i < e.rgba.size(); i += 4) {
        covered += e.rgba[i + 3];
        for (std::size_t c = 0; c < 3; ++c) {  // EXR over the background = the PNG (8-bit sRGB of the same linear value)
            const float composite = e.rgba[i + c] + (1.f - e.rgba[i + 3]) * background[c];
            worst = std::max(worst, double(std::fabs(to_srgb(composite) - p.rgba[i + c])));
        }
    }
    CHECK(covered > 1);  // the sphere is in the picture
    CHECK(worst <= 0.51 / 255);
}

TEST_CASE("sombra devices lists the PoCL device", "[cli]") {
    CHECK(run_cli("devices").exit_code == 0);
}

TEST_CASE("bad scenes fail with one line naming the file and the field", "[cli]") {
    std::string out = sombra::test::temp_dir() + "/never.png";
    std::remove(out.c_str());
    SECTION("missing scene file") {
        require_clean_failure(run_cli("render /nonexistent/scene.json -o " + out), "/nonexistent/scene.json", "cannot open", out);
    }
    SECTION("JSON syntax error names the line") {
        std::string f = write_file("syntax.json", "{\n  \"volumes\": [\n  }\n");
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "line 3", out);
    }
    SECTION("unknown key") {
        std::string f = scene_file("unknown.json", {{"camera", {{"fov", 30}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "camera: unknown key 'fov'", out);
    }
    SECTION("wrong type") {
        std::string f = scene_file("type.json", {{"camera", {{"fov_y_deg", "wide"}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "camera.fov_y_deg", out);
    }
    SECTION("camera at its look-at point") {
        std::string f = scene_file("camera.json", {{"camera", {{"position", {0, 0, 0}}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "camera.look_at", out);
    }
    SECTION("impossible spot cone") {
        std::string f = scene_file("spot.json", {{"lights", {{{"type", "spot"}, {"cone_angle_deg", 120}}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "lights[0].cone_angle_deg", out);
    }
    SECTION("zero light direction") {
        std::string f = scene_file("dir.json", {{"lights", {{{"type", "directional"}, {"direction", {0, 0, 0}}}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "lights[0].direction", out);
    }
    SECTION("unsorted transfer function") {
        std::string f = scene_file("tf.json", {{"volumes", {{{"generator", {{"type", "sphere"}}},
                                                             {"transfer_function", {{"rgb_points", {1, 1, 1, 1, 0, 0, 0, 0}},
                                                                                    {"opacity_points", {0, 0, 1, 1}}}}}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), f, "volumes[0].transfer_function.rgb_points[1]", out);
    }
    SECTION("missing volume file") {
        std::string f = scene_file("novol.json", {{"volumes", {{{"file", "missing.nii.gz"},
                                                               {"transfer_function", {{"rgb_points", {0, 1, 1, 1}},
                                                                                      {"opacity_points", {0, 0, 1, 1}}}}}}}});
        require_clean_failure(run_cli("render " + f + " -o " + out), "missing.nii.gz", "missing.nii.gz", out);
    }
    SECTION("missing or malformed mesh file") {
        std::string f = scene_file("nomesh.json", {{"meshes", nlohmann::json::array({{{"file", "missing.obj"}}})}});
        require_clean_failure(run_cli("render " + f + " -o " + out), "missing.obj", "cannot open", out);
        std::string bad = write_file("bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n");
        f = scene_file("badmesh.json", {{"meshes", nlohmann::json::array({{{"file", bad}}})}});
        require_clean_failure(run_cli("render " + f + " -o " + out), bad, "bad.ply", out);
    }
    SECTION("no such device") {
        std::string f = scene_file("device.json", nlohmann::json::object());
        require_clean_failure(run_cli("render " + f + " -o " + out + " --device 42"), "--device", "42", out);
    }
    SECTION("unsupported output format") {
        std::string f = scene_file("fmt.json", nlohmann::json::object());
        std::string jpg = sombra::test::temp_dir() + "/out.jpg";
        require_clean_failure(run_cli("render " + f + " -o " + jpg), jpg, ".png or .exr", jpg);
    }
    SECTION("bad low-pass filter width and kernel") {
        std::string f = scene_file("filter.json", nlohmann::json::object());
        require_clean_failure(run_cli("render " + f + " -o " + out + " --shadows lowpass --filter -2"), "--filter", "-2", out);
        require_clean_failure(run_cli("render " + f + " -o " + out + " --shadows lowpass --filter-kernel tent"), "--filter-kernel",
                              "tent", out);
    }
    SECTION("impossible image size") {
        std::string f = scene_file("size.json", nlohmann::json::object());
        require_clean_failure(run_cli("render " + f + " -o " + out + " --width 20000"), "--width", "[0, 16384]", out);
    }
    SECTION("unknown pre-filter options") {
        std::string f = scene_file("prefilter.json", nlohmann::json::object());
        std::string dsm = " --shadows dsm --dsm-res 16";
        require_clean_failure(run_cli("render " + f + " -o " + out + dsm + " --prefilter gauss"), "--prefilter", "gauss", out);
        require_clean_failure(run_cli("render " + f + " -o " + out + dsm + " --prefilter 5tap --prefilter-seed maybe"),
                              "--prefilter-seed", "maybe", out);
        CliRun ok = run_cli("render " + f + " -o " + out + dsm + " --prefilter 5tap --prefilter-jitter 3");  // the old spelling
        INFO(ok.stderr_text);
        CHECK(ok.exit_code == 0);
        CHECK_THAT(ok.stderr_text, Catch::Contains("note: --prefilter-jitter is now"));
        std::filesystem::remove(out);
        ok = run_cli("render " + f + " -o " + out + dsm + " --storage chunked");  // the old spelling of --dsm-storage
        CHECK(ok.exit_code == 0);
        CHECK_THAT(ok.stderr_text, Catch::Contains("note: --storage is now --dsm-storage"));
        CHECK(std::filesystem::exists(out));
        std::filesystem::remove(out);
    }
}

TEST_CASE("NaN voxels are rejected, or sanitized on request", "[cli]") {
    // a 2×2×2 float32 raw volume with one NaN, described by a JSON header
    std::string dir = sombra::test::temp_dir();
    float voxels[8] = {0, 1, 0.5f, 0.2f, NAN, 1, 0, 0};
    std::ofstream(dir + "/nan.raw", std::ios::binary).write(reinterpret_cast<const char*>(voxels), sizeof voxels);
    write_file("nan_volume.json", R"({"raw": "nan.raw", "dims": [2, 2, 2], "type": "float32"})");
    std::string f = scene_file("nan_scene.json", {{"volumes", {{{"file", "nan_volume.json"},
                                                               {"transfer_function", {{"rgb_points", {0, 1, 1, 1}},
                                                                                      {"opacity_points", {0, 0, 1, 1}}}}}}}});
    std::string out = dir + "/nan.png";
    std::remove(out.c_str());
    require_clean_failure(run_cli("render " + f + " -o " + out), "nan_volume.json", "voxels: 1 non-finite", out);
    CliRun ok = run_cli("render " + f + " -o " + out + " --non-finite sanitize");
    INFO(ok.stderr_text);
    CHECK(ok.exit_code == 0);
    CHECK(std::filesystem::exists(out));
}

TEST_CASE("sombra visibility prints every technique against the reference, and rejects bad points files", "[cli]") {
    std::string scene = scene_file("visibility.json", nlohmann::json::object());
    std::string points = write_file("points.csv", "0,0,0\n0.1,0.05,0\n0,0.1,0.02\n");
    std::string out = sombra::test::temp_dir() + "/visibility.csv";
    std::string command = std::string(SOMBRA_CLI) + " visibility " + scene + " --light 0 --points " + points +
                          " --dsm-res 32 --filter 1 >" + out + " 2>/dev/null";
    REQUIRE(std::system(command.c_str()) == 0);
    std::ifstream in(out);
    std::string header, line;
    std::getline(in, header);
    CHECK(header == "x,y,z,reference,dsm,shadow_ray,shadow_map,lowpass,dsm_error,shadow_ray_error,shadow_map_error,lowpass_error");
    int rows = 0;
    while (std::getline(in, line)) {
        std::stringstream fields(line);
        std::string field;
        int columns = 0;
        while (std::getline(fields, field, ',')) {
            double value = std::stod(field);
            CHECK(std::isfinite(value));
            ++columns;
        }
        CHECK(columns == 12);
        ++rows;
    }
    CHECK(rows == 3);
    // --shadows: only the techniques named, in the usual order
    CliOutput some = run_cli_output("visibility " + scene + " --light 0 --points " + points + " --shadows rays,dsm -q");
    REQUIRE(some.exit_code == 0);
    CHECK(some.out.substr(0, some.out.find('\n')) == "x,y,z,reference,dsm,shadow_ray,dsm_error,shadow_ray_error");
    CHECK(run_cli("visibility " + scene + " --light 0 --points " + points + " --shadows ao").exit_code == 2);
    std::string bad = write_file("bad_points.csv", "0,0,0\n0.1,zero,0\n");
    CliRun run = run_cli("visibility " + scene + " --light 0 --points " + bad);
    INFO("stderr: " << run.stderr_text);
    CHECK(run.exit_code != 0);
    CHECK(run.stderr_text.find("bad_points.csv") != std::string::npos);
    CHECK(run.stderr_text.find("line 2") != std::string::npos);
}

TEST_CASE("hostile arguments and outputs: exit 2 for bad sizes, nothing left after a failed output", "[cli][hostile]") {
    const std::string dir = sombra::test::temp_dir();
    std::string f = scene_file("outputs.json", {{"image", {{"width", 8}, {"height", 8}}}});
    std::string out = dir + "/kept.png";
    std::remove(out.c_str());
    for (const char* option : {"--width -7", "--width 4294967304", "--filter nan", "--cone-angle nan",
                               "--eps nan", "--dsm-res 8193"}) {  // NaN passes CLI::Range; ints would wrap
        CliRun run = run_cli("render " + f + " -o " + out + " " + option);
        require_clean_failure(run, std::string(option).substr(0, std::string(option).find(' ')), "must lie in", out);
        CHECK(run.exit_code == 2);
    }
    // an impossible --stats fails before the render, leaving neither the image nor a part file
    require_clean_failure(run_cli("render " + f + " -o " + out + " --stats " + dir), dir, "is a directory", out);
    require_clean_failure(run_cli("render " + f + " -o " + out + " --stats " + dir + "/no/such/stats.json"),
                          "stats.json", "cannot write", out);
    // sombra dsm: a point light's six faces are committed together; a .png name is refused
    std::string point = scene_file("point.json", {{"lights", {{{"type", "point"}, {"position", {0, 0.5, 0.5}}}}}});
    require_clean_failure(run_cli("dsm " + point + " --light 0 -o " + dir + "/d.png"), "d.png", ".exr", dir + "/d.png");
    CliRun ok = run_cli("dsm " + point + " --light 0 --dsm-res 8 -o " + dir + "/faces.exr");
    INFO(ok.stderr_text);
    CHECK(ok.exit_code == 0);
    for (const char* face : {"+x", "-x", "+y", "-y", "+z", "-z"})
        CHECK(std::filesystem::exists(dir + "/faces." + face + ".exr"));
    for (const auto& entry : std::filesystem::directory_iterator(dir))  // no staged file left behind
        CHECK(entry.path().filename().string().find(".sombra-") == std::string::npos);
}

TEST_CASE("hostile volume, scene and points files through the CLI: one line, exit 1", "[cli][hostile]") {
    const std::string dir = sombra::test::temp_dir(), out = dir + "/hostile.png";
    std::remove(out.c_str());
    // an unknown NIfTI datatype: our line only, not niftiio's "** ERROR"
    std::string header(352, '\0');
    const auto put16 = [&](std::size_t at, int v) { header[at] = char(v & 0xff), header[at + 1] = char((v >> 8) & 0xff); };
    put16(0, 348);
    for (int i = 0; i < 4; ++i) put16(40 + 2 * std::size_t(i), i == 0 ? 3 : 2);
    put16(70, 1234), put16(72, 32);
    header.replace(344, 4, std::string("n+1\0", 4));
    write_file("datatype.nii", header);
    std::string f = scene_file("datatype_scene.json", {{"volumes", {{{"file", "datatype.nii"},
                                                                     {"transfer_function", {{"rgb_points", {0, 1, 1, 1}},
                                                                                            {"opacity_points", {0, 0, 1, 1}}}}}}}});
    CliRun run = run_cli("render " + f + " -o " + out);
    require_clean_failure(run, "datatype.nii", "datatype", out);
    CHECK(run.exit_code == 1);
    CHECK(run.stderr_text.find("** ERROR") == std::string::npos);

    const std::string fifo = dir + "/points.fifo";
    std::remove(fifo.c_str());
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    std::string scene = scene_file("fifo_scene.json", nlohmann::json::object());
    for (const std::string& points : {fifo, std::string("/dev/zero"), dir}) {
        run = run_cli("visibility " + scene + " --light 0 --points " + points);
        require_clean_failure(run, points, "not a regular file", out);
        CHECK(run.exit_code == 1);
    }
    require_clean_failure(run_cli("render " + fifo + " -o " + out), fifo, "a FIFO", out);
}

TEST_CASE("enumerated render options by name: every name round-trips, unknown ones name the accepted", "[cli]") {
    using namespace sombra;
    for (const char* option : {"shadows", "gradient", "shading", "volume_storage", "shadow_cache", "dsm_storage"}) {
        const std::vector<std::string> names = render_option_values(option);
        REQUIRE(names.size() >= 2);
        for (const std::string& name : names) {
            RenderOptions o;
            set_render_option(o, option, name);
            CHECK(render_option_value(o, option) == name);
        }
    }
    RenderOptions o;
    set_render_option(o, "shadows", "dsm");
    CHECK(o.shadows == ShadowTechnique::Dsm);
    CHECK(render_option_value(RenderOptions{}, "shadows") == "dsm");  // the defaults have names too
    CHECK(test::error_of([&] { set_render_option(o, "shadows", "dsmm"); }) ==
          "shadows: unknown value 'dsmm' (none, rays, dsm, shadowmap, lowpass, ao, cone) (did you mean 'dsm'?)");
    CHECK(test::error_of([] { render_option_values("shadow"); }) ==
          "unknown enumerated render option 'shadow' (shadows, shading, gradient, shadow_cache, shadow_cache_fill, volume_storage, dsm_error, dsm_storage, "
          "dsm_lookup, dsm_prefilter, lowpass_filter_kernel, lowpass_precision, ray_cache_lattice) (did you mean 'shadows'?)");
    CHECK(parse_light_type("omni") == LightType::Point);
    CHECK(test::error_of([] { parse_light_type("sun"); }) == "unknown light type 'sun' (directional, spot, point)");
}

TEST_CASE("sombra render: one progress line per stage on a non-terminal stderr, the longest named, and --quiet prints nothing", "[cli]") {
    std::string scene = scene_file("progress.json", nlohmann::json::object());
    std::string out = sombra::test::temp_dir() + "/progress.png";
    CliRun run = run_cli("render " + scene + " -o " + out + " --shadows lowpass --filter 5 --shadow-cache on");
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    CHECK(run.stderr_text.find('\r') == std::string::npos);  // no bar when stderr is a file
    std::istringstream lines(run.stderr_text);
    std::map<std::string, int> stages;
    std::string line, summary;
    while (std::getline(lines, line)) {
        if (line.rfind("sombra: wrote ", 0) == 0) {
            summary = line;
            continue;
        }
        // "sombra: <stage> <ms> ms"
        REQUIRE(line.size() > 11);
        CHECK(line.rfind("sombra: ", 0) == 0);
        CHECK(line.substr(line.size() - 3) == " ms");
        std::string stage = line.substr(8, line.rfind(' ', line.size() - 4) - 8);
        ++stages[stage];
    }
    for (const char* stage : {"summed-area tables", "shadow cache", "camera pass"}) CHECK(stages[stage] == 1);
    for (const auto& [stage, count] : stages) CHECK(count == 1);
    CHECK_THAT(summary, Catch::Contains("shadow cache ") && Catch::Contains("summed-area tables ") && Catch::Contains("; longest: "));

    std::remove(out.c_str());
    for (const char* quiet : {"--quiet", "-q"}) {
        run = run_cli("render " + scene + " -o " + out + " --shadows lowpass " + quiet);
        CHECK(run.exit_code == 0);
        CHECK(run.stderr_text.empty());
        CHECK(std::filesystem::exists(out));
    }
    run = run_cli("dsm " + scene + " --light 0 --dsm-res 8 -o " + sombra::test::temp_dir() + "/progress_dsm.exr --quiet");
    CHECK(run.exit_code == 0);
    CHECK(run.stderr_text.empty());
}

TEST_CASE("sombra render --clusters renders clustered deep shadow maps and lists the clusters in --stats", "[cli][clustered_dsm]") {
    const std::string scene = two_spheres_file("render_clusters.json");
    const std::string dir = sombra::test::temp_dir(), out = dir + "/clusters.png", stats = dir + "/clusters_stats.json";
    CliRun run = run_cli("render " + scene + " -o " + out + " --stats " + stats + " --shadows dsm --dsm-res 32 --clusters 4");
    INFO(run.stderr_text);
    REQUIRE(run.exit_code == 0);
    CHECK(std::filesystem::exists(out));
    std::ifstream in(stats);
    const nlohmann::json j = nlohmann::json::parse(in);
    REQUIRE(j["dsm"]["lights"].size() == 1);
    const nlohmann::json& clusters = j["dsm"]["lights"][0]["clusters"];
    REQUIRE(clusters.size() == 2);
    CHECK(j["dsm"]["views"] == 2);
    CHECK(clusters[0]["views"][0]["projection"] == "orthographic");
    CHECK(j["stage_ms"].contains("dsm_clustering"));
    const std::string unwritten = dir + "/unwritten.png";
    require_clean_failure(run_cli("render " + scene + " -o " + unwritten + " --shadows dsm --clusters 65"), "--clusters", "[0, 64]", unwritten);
}

TEST_CASE("sombra clusters prints each light's clusters and writes them as JSON", "[cli][clustering]") {
    const std::string scene = two_spheres_file("clusters.json");
    const std::string json_path = sombra::test::temp_dir() + "/clusters.out.json";
    const CliOutput run = run_cli_output("clusters " + scene + " --json " + json_path);
    INFO("stderr: " << run.err);
    REQUIRE(run.exit_code == 0);
    CHECK(run.out.find("light 0 (directional): 2 clusters") != std::string::npos);
    CHECK(run.out.find("cluster 1:") != std::string::npos);
    std::ifstream in(json_path);
    const nlohmann::json j = nlohmann::json::parse(in);
    REQUIRE(j["lights"].size() == 1);
    const nlohmann::json& clusters = j["lights"][0]["clusters"];
    REQUIRE(clusters.size() == 2);
    std::set<std::string> members;
    for (const nlohmann::json& c : clusters) {
        CHECK(c["members"].size() == 1);
        members.insert(c["members"][0].get<std::string>());
        REQUIRE(c["views"].size() == 1);
        CHECK(c["views"][0]["projection"] == "orthographic");
        CHECK(c["views"][0]["far"].get<double>() > c["views"][0]["near"].get<double>());
    }
    CHECK(members == std::set<std::string>{"left", "right"});
    CHECK(run_cli_output("clusters " + scene + " --clusters 1").out.find("1 cluster,") != std::string::npos);

    const std::string unwritten = sombra::test::temp_dir() + "/unwritten.json";
    require_clean_failure(run_cli("clusters " + scene + " --clusters 0 --json " + unwritten), "--clusters", "[1, 64]", unwritten);
    require_clean_failure(run_cli("clusters " + scene + " --cluster-distance nan --json " + unwritten), "--cluster-distance", "[0, 10]", unwritten);
    require_clean_failure(run_cli("clusters " + scene + " --clusters many"), "--clusters", "many", unwritten);
    CHECK(run_cli("clusters " + scene + " --clusters 65").exit_code == 2);  // bad arguments: 2 (docs/command-line.md)
    require_clean_failure(run_cli("clusters " + scene + " --json /no/such/folder/c.json"), "/no/such/folder/c.json", "cannot write", unwritten);

    // --image: each object tinted by its cluster (two clusters: two different hues left and right)
    const std::string image_path = sombra::test::temp_dir() + "/clusters.png";
    REQUIRE(run_cli("clusters " + scene + " --image " + image_path + " --width 64 --height 32").exit_code == 0);
    const sombra::Image image = sombra::read_image(image_path);
    REQUIRE(image.width == 64);
    auto brightest = [&](int x0, int x1) {  // the most saturated pixel's RGB in columns [x0, x1)
        std::array<float, 3> best{0, 0, 0};
        for (int y = 0; y < image.height; ++y)
            for (int x = x0; x < x1; ++x) {
                const float* p = &image.rgba[std::size_t(4 * (y * image.width + x))];
                if (p[0] + p[1] + p[2] > best[0] + best[1] + best[2]) best = {p[0], p[1], p[2]};
            }
        return best;
    };
    std::array<float, 3> left = brightest(0, 32), right = brightest(32, 64);
    INFO("left " << left[0] << " " << left[1] << " " << left[2] << ", right " << right[0] << " " << right[1] << " " << right[2]);
    CHECK(std::abs(left[0] - right[0]) + std::abs(left[1] - right[1]) + std::abs(left[2] - right[2]) > 0.3f);
    const std::string unwritten_image = sombra::test::temp_dir() + "/unwritten.png";
    require_clean_failure(run_cli("clusters " + scene + " --image " + unwritten_image + " --light 3"), "--light", "1 lights", unwritten_image);
}

// Issue 25 item 1: an output never replaces an input of the command (compared by device and inode,
// links resolved) nor anything but a regular file, and the outputs of one command are committed
// together: each case is refused with one line before any work, and every input is left as it was.
TEST_CASE("outputs never touch inputs or non-regular files, and are committed together", "[cli][hostile]") {
    namespace fs = std::filesystem;
    const std::string dir = sombra::test::temp_dir() + "/outputs_inputs";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string scene = scene_file("outputs_inputs/s.json", {{"image", {{"width", 8}, {"height", 8}}}});
    const auto read_all = [](const std::string& path) {
        std::ifstream in(path);
        std::stringstream text;
        text << in.rdbuf();
        return text.str();
    };
    const std::string scene_text = read_all(scene);
    const std::string image = dir + "/o.png";
    fs::create_symlink(scene, dir + "/link.json");

    // --stats, -o or a link to it naming the scene: refused, the scene unchanged, no image
    for (const std::string& args : {"-o " + image + " --stats " + scene, "-o " + image + " --stats " + dir + "/link.json",
                                    "-o " + dir + "/./s.json.png --stats " + dir + "/../outputs_inputs/s.json"}) {
        const CliRun run = run_cli("render " + scene + " " + args);
        INFO(args << ": " << run.stderr_text);
        CHECK(run.exit_code != 0);
        CHECK(std::count(run.stderr_text.begin(), run.stderr_text.end(), '\n') == 1);
        CHECK(run.stderr_text.find("is an input of this command") != std::string::npos);
        CHECK(read_all(scene) == scene_text);
        CHECK_FALSE(fs::exists(image));
    }
    // the points file of `visibility` is an input too
    const std::string points = write_file("outputs_inputs/p.csv", "0,0,0\n0.1,0,0\n");
    const CliRun stats_on_points = run_cli("visibility " + scene + " --light 0 --points " + points + " --stats " + points);
    CHECK(stats_on_points.stderr_text.find("is an input of this command") != std::string::npos);
    CHECK(read_all(points) == "0,0,0\n0.1,0,0\n");
    // a device node (through a link: links are resolved) or a FIFO is never replaced
    fs::create_symlink("/dev/null", dir + "/null.png");
    REQUIRE(::mkfifo((dir + "/fifo.png").c_str(), 0600) == 0);
    for (const std::string& node : {dir + "/null.png", dir + "/fifo.png"}) {
        const CliRun run = run_cli("render " + scene + " -o " + node);
        INFO(node << ": " << run.stderr_text);
        CHECK(run.exit_code != 0);
        CHECK(run.stderr_text.find("not a regular file") != std::string::npos);
        CHECK_FALSE(fs::is_regular_file(node));
    }
    CHECK(fs::is_character_file("/dev/null"));
    // two outputs naming one file through different spellings
    const CliRun twice = run_cli("render " + scene + " -o " + image + " --stats " + dir + "/../outputs_inputs/o.png");
    CHECK(twice.stderr_text.find("named twice as an output") != std::string::npos);
    CHECK_FALSE(fs::exists(image));
    // clusters: a failed --image leaves no --json behind (both are committed together)
    const CliRun clusters = run_cli("clusters " + scene + " --json " + dir + "/c.json --image " + dir + "/c.bmp");
    CHECK(clusters.exit_code != 0);
    CHECK_FALSE(fs::exists(dir + "/c.json"));
}

// Issue 25: libraries print nothing of their own: a TIFF with a tag libtiff does not know (it
// warns "TIFFReadDirectory: Warning, Unknown field with tag 40000" on stderr) renders with only
// sombra's own lines (none with --quiet).
TEST_CASE("library chatter: libtiff's warnings do not reach stderr", "[cli][hostile]") {
    // a 4×4 8-bit one-page TIFF written by hand, with the private tag 40000 (sorted, as TIFF wants)
    const std::vector<std::array<std::uint32_t, 4>> entries = {
        {256, 3, 1, 4}, {257, 3, 1, 4}, {258, 3, 1, 8},  {259, 3, 1, 1},  {262, 3, 1, 1},
        {273, 4, 1, 0}, {277, 3, 1, 1}, {278, 3, 1, 4}, {279, 4, 1, 16}, {40000, 3, 1, 7}};
    std::string tiff = std::string("II*\0", 4);
    auto put = [&](std::uint32_t v, int bytes) {
        for (int i = 0; i < bytes; ++i) tiff.push_back(char((v >> (8 * i)) & 0xff));
    };
    put(8, 4);
    put(std::uint32_t(entries.size()), 2);
    const std::uint32_t data_at = 8 + 2 + 12 * std::uint32_t(entries.size()) + 4;
    for (const auto& e : entries) {
        put(e[0], 2), put(e[1], 2), put(e[2], 4);
        put(e[0] == 273 ? data_at : e[3], e[1] == 3 ? 2 : 4);
        if (e[1] == 3) put(0, 2);
    }
    put(0, 4);
    for (int i = 0; i < 16; ++i) tiff.push_back(char(i * 16));
    write_file("chatter.tif", tiff);
    const std::string scene = scene_file("chatter.json", {{"volumes", {{{"file", "chatter.tif"},
        {"transfer_function", {{"rgb_points", {0, 1, 1, 1, 255, 1, 1, 1}}, {"opacity_points", {0, 0, 255, 0.5}}}}}}}});
    const CliOutput run = run_cli_output("render " + scene + " -o " + sombra::test::temp_dir() + "/chatter.png -q");
    INFO(run.err);
    CHECK(run.exit_code == 0);
    CHECK(run.err.empty());
}
