// sombra_bench_objects — deep shadow maps against scene size, in one run (Knecht 2011 §5.3–5.4):
//  1. Fig. 5.13 analogue: N steaming cups (the cup and steam plume of data/scenes/cup_array.json,
//     Fig. 5.12, copied onto a grid), one spot + one point light: DSM generation time, raster
//     time, camera-pass time, nodes per texel and memory against N, per storage backend (and, with
//     --clusters, per number of clustered deep shadow maps per light, Knecht §3.4).
//  2. Tables 5.5–5.7 analogue: data-set resolution classes, the cup under one procedural cloud
//     of 64³, 128³ or 256³ voxels (same world size): the same columns per class and backend.
// Times are medians of OpenCL profiling events (RenderStats::stage_ms) after one warm-up; the
// prepared scene is dropped before every render so that each one builds its maps. See bench/README.md.
#include <CLI/CLI.hpp>
#include "host/guarded_main.h"
#include "bench_util.h"
#include "shared/types.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <thread>

#include "sombra/sombra.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::forget_preparation;
using sombra::bench::median;
using sombra::bench::write_file;

// validate_scene (src/scene/scene.cpp) allows at most SOMBRA_MAX_VOLUMES (32) volumes per scene.
constexpr int kMaxVolumes = SOMBRA_MAX_VOLUMES;

struct BenchOptions {
    std::vector<int> counts{1, 2, 4, 8, 16, 24};
    std::vector<int> cloud_sizes{64, 128, 256};
    std::vector<std::string> storages{"atlas", "chunked"};
    std::vector<int> clusters{0};  // clustered deep shadow maps (Knecht §3.4): 0 off, else M per light
    int dsm_resolution = 256;
    float epsilon = 0.02f;
    int width = 160, height = 160;
    int runs = 2;
    std::string device = "auto";
    std::string out_dir;
    std::string data_dir = SOMBRA_DATA_DIR;
};

struct Row {
    std::string label;  // N, or the cloud's voxels per side
    std::string storage;  // the backend, and ", M clusters" when clustered
    std::size_t triangles = 0;
    int volumes = 0;
    unsigned long long voxels = 0;
    double clustering_ms = 0, generation_ms = 0, raster_ms = 0, render_ms = 0, wall_ms = 0;
    double mean_nodes = 0;
    unsigned max_nodes = 0;
    int views = 0;
    unsigned long long bytes_used = 0, capped = 0;
};

bool is_raster_stage(const std::string& stage) {
    return stage.find("raster") != std::string::npos || stage.find("fragments") != std::string::npos;
}

// The cup and its steam: the first cup and the first steam of data/scenes/cup_array.json (mesh,
// material, transfer function, step, plume size), copied to other places.
struct CupTemplate {
    sombra::MeshInstance cup;
    sombra::VolumeInstance steam;
};

CupTemplate cup_template(const std::string& data_dir) {
    sombra::Scene s = sombra::load_scene(data_dir + "/scenes/cup_array.json");
    if (s.meshes.empty() || s.volumes.empty()) throw sombra::Error(data_dir + "/scenes/cup_array.json: needs a cup and a steam");
    return {s.meshes[0], s.volumes[0]};
}

// A transform moved to (x, y) in the ground plane (row-major: the translation is column 3).
std::array<float, 16> placed(std::array<float, 16> m, float x, float y) {
    m[3] = x, m[7] = y;
    return m;
}

sombra::VolumeInstance steam(const CupTemplate& t, std::shared_ptr<const sombra::Volume> volume, float x, float y,
                             const std::string& name) {
    sombra::VolumeInstance vi = t.steam;
    // the template's world box, whatever the voxel count
    float s = t.steam.spacing[0] * float(t.steam.volume->dims[0]) / float(volume->dims[0]);
    vi.volume = std::move(volume);
    vi.spacing = {s, s, s};
    vi.transform = placed(t.steam.transform, x, y);
    vi.name = name;
    return vi;
}

sombra::MeshInstance cup(const CupTemplate& t, float x, float y, int i) {
    sombra::MeshInstance mi = t.cup;
    mi.transform = placed(t.cup.transform, x, y);
    mi.name = "cup_" + std::to_string(i);
    return mi;
}

// Camera, spot light and point light framing a grid of half extent `half` (world units) around the
// origin, as in steaming_cups.json scaled with the grid.
void frame(sombra::Scene& scene, float half) {
    float k = std::max(1.f, half / 80.f);
    scene.camera.position = {40.f * k, -300.f * k, 140.f * k};
    scene.camera.look_at = {0, 0, 35};
    scene.camera.up = {0, 0, 1};
    scene.camera.fov_y_deg = 45;
    scene.background = {0.55f, 0.6f, 0.7f};
    scene.ambient_intensity = 0.25f;
    sombra::Light spot;
    spot.type = sombra::LightType::Spot;
    spot.position = {-200.f * k, -150.f * k, 260.f * k};
    spot.direction = {200.f * k, 150.f * k, -260.f * k + 35.f};
    float distance = std::sqrt(spot.direction[0] * spot.direction[0] + spot.direction[1] * spot.direction[1] +
                               spot.direction[2] * spot.direction[2]);
    spot.cone_angle_deg = std::min(80.f, float(std::atan2(1.5f * half + 60.f, distance) * 180.0 / M_PI) + 5.f);
    spot.cone_softness = 0.2f;
    spot.color = {1.f, 0.9f, 0.75f};
    spot.intensity = 1.3f;
    sombra::Light point;
    point.type = sombra::LightType::Point;
    point.position = {160.f * k, -60.f * k, 140.f * k};
    point.color = {0.6f, 0.7f, 1.f};
    point.intensity = 0.8f;
    scene.lights = {spot, point};
}

// N cups with steam on a ⌈√N⌉-wide grid, 62 units apart (cup_array.json); steam above the
// first min(N, SOMBRA_MAX_VOLUMES) cups, seeded as in cup_array.json.
sombra::Scene cups_scene(int n, const CupTemplate& t) {
    sombra::Scene scene;
    scene.source = "objects_bench: " + std::to_string(n) + " cups";
    int columns = int(std::ceil(std::sqrt(double(n))));
    int rows = (n + columns - 1) / columns;
    const float pitch = 62.f;
    for (int i = 0; i < n; ++i) {
        float x = (float(i % columns) - 0.5f * float(columns - 1)) * pitch;
        float y = (float(i / columns) - 0.5f * float(rows - 1)) * pitch;
        scene.meshes.push_back(cup(t, x, y, i));
        if (i < kMaxVolumes) {
            auto plume = std::make_shared<const sombra::Volume>(
                sombra::make_steam_plume(t.steam.volume->dims[0], 3u + 4u * unsigned(i)));
            scene.volumes.push_back(steam(t, plume, x, y, "steam_" + std::to_string(i)));
        }
    }
    frame(scene, 0.5f * pitch * float(std::max(columns, rows) - 1));
    return scene;
}

// One cup under one cloud of n³ voxels; the cloud covers the same world box at every n.
sombra::Scene cloud_scene(int n, const CupTemplate& t) {
    sombra::Scene scene;
    scene.source = "objects_bench: cloud " + std::to_string(n);
    scene.meshes.push_back(cup(t, 0, 0, 0));
    auto cloud = std::make_shared<const sombra::Volume>(sombra::make_cloud_noise(n, 5u));
    scene.volumes.push_back(steam(t, cloud, 0, 0, "cloud"));
    frame(scene, 0.f);
    return scene;
}

// One warm-up render, then `runs` timed ones, each building its maps anew.
void measure(sombra::Context& context, const sombra::Scene& scene, const sombra::RenderOptions& options, int runs, Row& row) {
    std::vector<double> clustering, generation, raster, render, wall;
    sombra::RenderStats last;
    for (const sombra::bench::TimedRender& timed : sombra::bench::fresh_renders(context, scene, options, runs)) {
        last = timed.stats;
        wall.push_back(timed.wall_ms);
        double gen = 0, ras = 0;
        bool built = false;
        for (const auto& [stage, ms] : last.stage_ms) {
            bool dsm = stage.rfind("dsm_", 0) == 0;
            built = built || dsm;
            if (is_raster_stage(stage) && (dsm || stage.rfind("camera_", 0) == 0)) ras += ms;
            else if (dsm && stage != "dsm_clustering") gen += ms;
        }
        if (!built) throw sombra::Error("a DSM render reported no dsm_* stage: the maps were reused, not generated");
        generation.push_back(gen), raster.push_back(ras), render.push_back(last.stage_ms.at("camera_pass"));
        clustering.push_back(last.stage_ms.count("dsm_clustering") ? last.stage_ms.at("dsm_clustering") : 0.0);
    }
    row.clustering_ms = median(clustering), row.generation_ms = median(generation), row.raster_ms = median(raster), row.render_ms = median(render);
    row.wall_ms = median(wall);
    row.views = last.dsm_views, row.mean_nodes = last.dsm_mean_nodes_per_texel, row.max_nodes = last.dsm_max_nodes_per_texel;
    row.bytes_used = last.dsm_bytes_used, row.capped = last.dsm_capped_texels;
}

void describe(Row& row, const sombra::Scene& scene) {
    row.volumes = int(scene.volumes.size());
    for (const auto& m : scene.meshes) row.triangles += m.mesh->triangles.size();
    for (const auto& v : scene.volumes) row.voxels += v.volume->voxel_count();
}

std::string markdown(const std::vector<Row>& rows, const std::string& first) {
    std::ostringstream s;
    s << "| " << first << " | storage | triangles | volumes | voxels | views | clustering ms | DSM gen ms | raster ms | render ms | "
      << "wall ms | nodes/texel mean | max | bytes used | capped texels |\n"
      << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows)
        s << "| " << r.label << " | " << r.storage << " | " << r.triangles << " | " << r.volumes << " | " << r.voxels << " | "
          << r.views << " | " << fixed(r.clustering_ms, 2) << " | " << fixed(r.generation_ms, 1) << " | " << fixed(r.raster_ms, 1) << " | " << fixed(r.render_ms, 1)
          << " | " << fixed(r.wall_ms, 0) << " | " << fixed(r.mean_nodes, 3) << " | " << r.max_nodes << " | " << r.bytes_used
          << " | " << r.capped << " |\n";
    return s.str();
}

std::string csv(const std::vector<Row>& rows, const std::string& part) {
    std::ostringstream s;
    for (const Row& r : rows)
        s << part << ',' << r.label << ',' << r.storage << ',' << r.triangles << ',' << r.volumes << ',' << r.voxels << ','
          << r.views << ',' << fixed(r.generation_ms, 3) << ',' << fixed(r.raster_ms, 3) << ',' << fixed(r.render_ms, 3) << ','
          << fixed(r.wall_ms, 1) << ',' << fixed(r.mean_nodes, 5) << ',' << r.max_nodes << ',' << r.bytes_used << ','
          << r.capped << ',' << fixed(r.clustering_ms, 3) << '\n';
    return s.str();
}

int run(int argc, char** argv) {
    BenchOptions o;
    CLI::App app{"sombra deep shadow maps against the number of objects and the data-set resolution (Knecht §5.3–5.4)"};
    app.add_option("--counts", o.counts, "numbers of steaming cups N, comma-separated")->delimiter(',')->check(CLI::Range(1, 1024));
    app.add_option("--clouds", o.cloud_sizes, "cloud voxels per side of the resolution classes, comma-separated (0: none)")
        ->delimiter(',')
        ->check(CLI::Range(0, 1024));
    app.add_option("--storages", o.storages, "DSM storage backends, comma-separated")->delimiter(',');
    app.add_option("--clusters", o.clusters, "clustered deep shadow maps: clusters per light, comma-separated (0: off)")
        ->delimiter(',')
        ->check(CLI::Range(0, 64));
    app.add_option("--dsm-resolution", o.dsm_resolution, "DSM texels per side")->check(CLI::Range(1, 8192));
    app.add_option("--eps", o.epsilon, "DSM compression error bound ε")->check(CLI::Range(0.0f, 1e6f));
    app.add_option("--width", o.width, "image width")->check(CLI::Range(1, 16384));
    app.add_option("--height", o.height, "image height")->check(CLI::Range(1, 16384));
    app.add_option("--runs", o.runs, "timed renders per row, after one warm-up")->check(CLI::PositiveNumber);
    app.add_option("--device", o.device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--data", o.data_dir, "data folder (scenes/cup_array.json, meshes/cup.obj)");
    app.add_option("--out", o.out_dir, "write objects_table.md and objects_table.csv into this folder");
    CLI11_PARSE(app, argc, argv);
    o.cloud_sizes.erase(std::remove(o.cloud_sizes.begin(), o.cloud_sizes.end(), 0), o.cloud_sizes.end());

    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
    const CupTemplate cup_and_steam = cup_template(o.data_dir);
    sombra::Context context(o.device);
    sombra::RenderOptions base;
    base.width = o.width, base.height = o.height;
    base.shadows = sombra::ShadowTechnique::Dsm;
    base.dsm.resolution = o.dsm_resolution, base.dsm.epsilon = o.epsilon;

    std::cout << "command:  " << command << "\n"
              << "device:   " << context.device().name << " [" << context.device().platform << "]\n"
              << "cores:    " << std::thread::hardware_concurrency() << "\n"
              << "image:    " << o.width << "x" << o.height << ", DSM " << o.dsm_resolution << "², ε " << o.epsilon
              << ", spot + point light\n"
              << "runs:     " << o.runs << " timed after 1 warm-up, medians of OpenCL profiling events\n\n";
    for (int n : o.counts)
        if (n > kMaxVolumes)
            std::cout << "note: N = " << n << ": at most " << kMaxVolumes << " volumes per scene, the other "
                      << n - kMaxVolumes << " cups have no steam\n";

    std::vector<Row> count_rows, cloud_rows;
    auto measure_storages = [&](const sombra::Scene& scene, const std::string& label, std::vector<Row>& rows) {
        for (int m : o.clusters)
            for (const std::string& storage : o.storages) {
                Row r;
                r.label = label, r.storage = storage + (m ? ", " + std::to_string(m) + " clusters" : "");
                describe(r, scene);
                sombra::RenderOptions options = base;
                options.dsm.storage = storage;
                options.dsm.clusters = m;
                measure(context, scene, options, o.runs, r);
                rows.push_back(r);
                std::cout << label << " " << r.storage << ": gen " << fixed(r.generation_ms, 1) << " ms, raster "
                          << fixed(r.raster_ms, 1) << " ms, render " << fixed(r.render_ms, 1) << " ms, nodes/texel "
                          << fixed(r.mean_nodes, 3) << " (max " << r.max_nodes << ")" << std::endl;
            }
    };
    for (int n : o.counts) measure_storages(cups_scene(n, cup_and_steam), std::to_string(n), count_rows);
    for (int size : o.cloud_sizes) measure_storages(cloud_scene(size, cup_and_steam), std::to_string(size) + "³", cloud_rows);

    std::string table = "DSM generation and render time against the number of steaming cups N (Knecht Fig. 5.13):\n\n" +
                        markdown(count_rows, "N") +
                        "\nData-set resolution classes: the cup under one procedural cloud (Knecht Tables 5.5–5.7):\n\n" +
                        markdown(cloud_rows, "cloud");
    std::cout << "\n" << table;
    if (!o.out_dir.empty()) {
        std::filesystem::path dir(o.out_dir);
        std::filesystem::create_directories(dir);
        std::string header = "<!-- " + command + " | " + context.device().name + " | " +
                             std::to_string(std::thread::hardware_concurrency()) + " cores | " + std::to_string(o.width) + "x" +
                             std::to_string(o.height) + " | DSM " + std::to_string(o.dsm_resolution) + " | runs " +
                             std::to_string(o.runs) + " -->\n";
        write_file(dir / "objects_table.md", header + table);
        write_file(dir / "objects_table.csv",
                   "part,objects,storage,triangles,volumes,voxels,dsm_views,dsm_generation_ms,raster_ms,render_ms,wall_ms,"
                   "mean_nodes_per_texel,max_nodes_per_texel,bytes_used,capped_texels,clustering_ms\n" +
                       csv(count_rows, "cups") + csv(cloud_rows, "cloud"));
        std::cout << "wrote " << o.out_dir << "/objects_table.{md,csv}\n";
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_objects", run, argc, argv); }
