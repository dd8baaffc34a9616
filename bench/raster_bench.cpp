// sombra bench — the raster and fragment stages (Knecht §3.1.1–3.1.2) on the real meshes: host
// projection, raster_count + raster_write, segments_count + segments_write; medians of the
// kernels' profiling times after a warm-up, with the tile and fragment totals.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>

#include "bench_util.h"
#include "geometry/fragments.h"
#include "sombra/sombra.h"

using namespace sombra;

int main(int argc, char** argv) {
    CLI::App app("sombra raster bench: tile rasterizer and fragment sorting on the teapot and bunny");
    std::string device = "auto", out_dir = "bench/results", data_dir = SOMBRA_DATA_DIR;
    int runs = 5;
    app.add_option("--device", device, "OpenCL device: auto, cpu, gpu or an index");
    app.add_option("--runs", runs, "timed runs per row (median)")->check(CLI::Range(1, 100));
    app.add_option("--out", out_dir, "folder for raster.md and raster.csv");
    CLI11_PARSE(app, argc, argv);
    try {
        Context ctx(device);
        auto& rt = ctx.runtime();
        std::string md = "| mesh | pixels | triangles | project ms | raster ms (count + write) | tile entries | chunks | "
                         "wasted slots | fragments | max/pixel | fragments ms (count + sort) |\n"
                         "|---|---|---|---|---|---|---|---|---|---|---|\n";
        std::string csv = "mesh,resolution,triangles,project_ms,raster_count_ms,raster_write_ms,entries,chunks,wasted_slots,"
                          "fragments,max_per_pixel,fragments_count_ms,fragments_sort_ms\n";
        for (std::string name : {"teapot", "bunny"})
            for (int res : {256, 512, 1024}) {
                Mesh mesh = load_mesh(data_dir + "/meshes/" + name + ".obj");
                std::array<float, 3> lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
                for (auto& p : mesh.positions)
                    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
                float size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
                MeshInstance mi;
                mi.mesh = std::make_shared<const Mesh>(mesh);
                mi.transform = make_transform({-(lo[0] + hi[0]) / 2 / size, -(lo[1] + hi[1]) / 2 / size, -(lo[2] + hi[2]) / 2 / size},
                                              {0, 0, 0}, {1 / size, 1 / size, 1 / size});
                Camera cam;
                cam.position = {0.3f, 0.4f, 1.8f};
                raster::View view = raster::camera_view(cam, res, res);
                std::vector<double> project, rc, rw, fc, fw;
                raster::Stats rs;
                raster::FragmentStats fs;
                for (int run = 0; run <= runs; ++run) {  // run 0: warm-up
                    auto t0 = std::chrono::steady_clock::now();
                    auto proj = raster::project_meshes({mi}, view);
                    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
                    auto tiles = raster::rasterize(rt, proj.triangles, raster::make_screen(view));
                    auto frags = raster::sort_fragments(rt, tiles);
                    rs = tiles.stats, fs = frags.stats;
                    if (run == 0) continue;
                    project.push_back(ms), rc.push_back(rs.count_ms), rw.push_back(rs.write_ms);
                    fc.push_back(fs.count_ms), fw.push_back(fs.write_ms);
                }
                using bench::fixed;
                using bench::median;
                md += "| " + name + " | " + std::to_string(res) + "² | " + std::to_string(rs.triangles) + " | " +
                      fixed(median(project), 2) + " | " + fixed(median(rc) + median(rw), 2) + " (" + fixed(median(rc), 2) +
                      " + " + fixed(median(rw), 2) + ") | " + std::to_string(rs.entries) + " | " + std::to_string(rs.chunks) +
                      " | " + std::to_string(rs.wasted_slots) + " | " + std::to_string(fs.fragments) + " | " +
                      std::to_string(fs.max_per_pixel) + " | " + fixed(median(fc) + median(fw), 2) + " (" +
                      fixed(median(fc), 2) + " + " + fixed(median(fw), 2) + ") |\n";
                csv += name + "," + std::to_string(res) + "," + std::to_string(rs.triangles) + "," + fixed(median(project), 3) +
                       "," + fixed(median(rc), 3) + "," + fixed(median(rw), 3) + "," + std::to_string(rs.entries) + "," +
                       std::to_string(rs.chunks) + "," + std::to_string(rs.wasted_slots) + "," + std::to_string(fs.fragments) +
                       "," + std::to_string(fs.max_per_pixel) + "," + fixed(median(fc), 3) + "," + fixed(median(fw), 3) + "\n";
            }
        md = "# Raster and fragment stages on " + ctx.device().name + " (medians of " + std::to_string(runs) +
             " runs, kernel times from profiling events)\n\n" + md;
        std::cout << md;
        std::filesystem::create_directories(out_dir);
        bench::write_file(std::filesystem::path(out_dir) / "raster.md", md);
        bench::write_file(std::filesystem::path(out_dir) / "raster.csv", csv);
    } catch (const Error& e) {
        std::cerr << e.what() << "\n";
        return 1;
    }
    return 0;
}
