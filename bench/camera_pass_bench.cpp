// sombra_bench_camera — the camera pass (cl/render.cl) through OpenCL vs the same algorithm as
// native C++ (threads, with and without SIMD), on the same packed scene. Prints median times,
// Msamples/s, their ratio, and how far the native images are from the OpenCL one (a benchmark
// that measures different work is worthless). See bench/README.md.
#include <CLI/CLI.hpp>
#include "host/guarded_main.h"
#include "bench_util.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include "native_camera_pass.h"
#include "sombra/sombra.h"

namespace {

using sombra::bench::fixed;
using sombra::bench::median;
using sombra::bench::sci;
using sombra::bench::write_file;

using sombra::bench::NativeVariant;

struct BenchOptions {
    std::string scene = SOMBRA_DEFAULT_SCENE;
    int width = 0, height = 0;  // 0: the scene's size
    int runs = 5;
    std::string device = "auto";
    std::string out_dir;
    unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    bool scalar = true;
};

struct Row {
    std::string path;
    double median_ms = 0;
    unsigned long long samples = 0;
    double max_abs_diff = 0, mean_abs_diff = 0;  // RGB vs the OpenCL image (0 for the OpenCL row)
    double msamples_per_s() const { return median_ms > 0 ? double(samples) / (median_ms * 1e3) : 0; }
};

// Max and mean absolute difference over the RGB channels of two RGBA images.
void compare_rgb(const std::vector<float>& a, const std::vector<float>& b, Row& row) {
    double max_diff = 0, sum = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (i % 4 == 3) continue;
        double d = std::fabs(double(a[i]) - double(b[i]));
        if (!(d <= max_diff)) max_diff = d;  // a NaN makes the maximum NaN
        sum += d, ++count;
    }
    row.max_abs_diff = max_diff, row.mean_abs_diff = count ? sum / double(count) : 0;
}

// One warm-up render, then `runs` timed ones; the OpenCL time is the kernel's profiling event.
Row bench_opencl(sombra::Context& context, const sombra::Scene& scene, const sombra::RenderOptions& options, int runs,
                 sombra::Image& image) {
    sombra::render(context, scene, options);  // program build, PoCL kernel cache, first enqueue
    std::vector<double> ms;
    Row row;
    for (int i = 0; i < runs; ++i) {
        sombra::RenderResult r = sombra::render(context, scene, options);
        ms.push_back(r.stats.stage_ms.at("camera_pass"));
        row.samples = r.stats.samples;
        image = std::move(r.image);
    }
    int lanes = options.lanes > 0 ? options.lanes : (context.device().is_gpu ? 1 : 8);
    row.path = "OpenCL " + context.device().name + " (buffer, " + std::to_string(lanes) + (lanes == 1 ? " lane)" : " lanes)");
    row.median_ms = median(ms);
    return row;
}

// Same protocol; wall-clock time of render_native() (threads started and joined inside).
Row bench_native(const sombra::bench::NativeScene& scene, NativeVariant variant, unsigned threads, int runs,
                 const sombra::Image& reference) {
    using clock = std::chrono::steady_clock;
    sombra::bench::render_native(scene, variant, threads);
    std::vector<double> ms;
    sombra::bench::NativeImage image;
    for (int i = 0; i < runs; ++i) {
        auto t0 = clock::now();
        image = sombra::bench::render_native(scene, variant, threads);
        ms.push_back(std::chrono::duration<double, std::milli>(clock::now() - t0).count());
    }
    Row row;
    row.path = std::string("native C++ ") + (variant == NativeVariant::Simd ? "SIMD (omp simd, AVX2)" : "scalar") +
               ", " + std::to_string(threads) + " threads";
    row.median_ms = median(ms);
    row.samples = image.samples;
    compare_rgb(reference.rgba, image.rgba, row);
    return row;
}

std::string markdown_table(const std::vector<Row>& rows, double native_simd_rate) {
    std::ostringstream s;
    s << "| path | median ms | Msamples/s | ratio to native SIMD |\n|---|---:|---:|---:|\n";
    for (const Row& r : rows)
        s << "| " << r.path << " | " << fixed(r.median_ms, 1) << " | " << fixed(r.msamples_per_s(), 1) << " | "
          << fixed(r.msamples_per_s() / native_simd_rate, 3) << " |\n";
    return s.str();
}

std::string csv_table(const std::vector<Row>& rows, double native_simd_rate) {
    std::ostringstream s;
    s << "path,median_ms,msamples_per_s,ratio_to_native_simd,samples,max_abs_rgb_diff,mean_abs_rgb_diff\n";
    for (const Row& r : rows)
        s << '"' << r.path << "\"," << fixed(r.median_ms, 3) << ',' << fixed(r.msamples_per_s(), 3) << ','
          << fixed(r.msamples_per_s() / native_simd_rate, 4) << ',' << r.samples << ',' << sci(r.max_abs_diff) << ','
          << sci(r.mean_abs_diff) << '\n';
    return s.str();
}

int run(int argc, char** argv) {
    BenchOptions o;
    CLI::App app{"sombra camera pass: OpenCL vs native C++ (threads + SIMD), same algorithm and data"};
    app.add_option("--scene", o.scene, "scene file (JSON)");
    app.add_option("--width", o.width, "image width (default: the scene's)");
    app.add_option("--height", o.height, "image height (default: the scene's)");
    app.add_option("--runs", o.runs, "timed renders per path, after one warm-up")->check(CLI::PositiveNumber);
    app.add_option("--device", o.device, "OpenCL device: auto, cpu, gpu, or an index from `sombra devices`");
    app.add_option("--threads", o.threads, "native threads (default: hardware_concurrency)")->check(CLI::PositiveNumber);
    app.add_option("--out", o.out_dir, "also write camera_pass.csv and camera_pass.md into this folder");
    app.add_flag("!--no-scalar", o.scalar, "skip the scalar native variant");
    CLI11_PARSE(app, argc, argv);

    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);

    sombra::Scene scene = sombra::load_scene(o.scene);
    sombra::RenderOptions options;  // defaults: central differences, skipping on, t ≤ 1e-3 stops, seed 1
    options.shadows = sombra::ShadowTechnique::None;  // the camera pass alone, as the native C++ one
    options.width = o.width, options.height = o.height;
    sombra::Context context(o.device);
    int width = o.width > 0 ? o.width : scene.width, height = o.height > 0 ? o.height : scene.height;

    std::cout << "command:  " << command << "\n"
              << "scene:    " << o.scene << " (" << width << "x" << height << ")\n"
              << "device:   " << context.device().name << " [" << context.device().platform << "]\n"
              << "cores:    " << std::thread::hardware_concurrency() << " (std::thread::hardware_concurrency), native threads "
              << o.threads << "\n"
              << "volumes: ";
    for (const sombra::VolumeInstance& vi : scene.volumes)
        std::cout << " " << vi.name << " " << vi.volume->dims[0] << "x" << vi.volume->dims[1] << "x" << vi.volume->dims[2]
                  << " (" << (vi.volume->voxel_count() * sizeof(float) >> 20) << " MiB float)";
    std::cout << "\n"
              << "runs:     " << o.runs << " timed after 1 warm-up, medians\n\n";

    sombra::Image cl_image;
    std::vector<Row> rows{bench_opencl(context, scene, options, o.runs, cl_image)};
    sombra::bench::NativeScene native = sombra::bench::make_native_scene(scene, options);
    rows.push_back(bench_native(native, NativeVariant::Simd, o.threads, o.runs, cl_image));
    if (o.scalar) rows.push_back(bench_native(native, NativeVariant::Scalar, o.threads, o.runs, cl_image));
    if (!context.device().is_gpu) {  // the same kernel without packets: what the vector lanes buy on a CPU
        sombra::RenderOptions scalar_kernel = options;
        scalar_kernel.lanes = 1;
        sombra::Image scalar_image;
        rows.push_back(bench_opencl(context, scene, scalar_kernel, o.runs, scalar_image));
        compare_rgb(scalar_image.rgba, cl_image.rgba, rows.back());
    }
    double simd_rate = rows[1].msamples_per_s();

    std::cout << markdown_table(rows, simd_rate) << "\n";
    for (const Row& r : rows) {
        std::cout << r.path << ": " << r.samples << " samples";
        if (&r != &rows[0])
            std::cout << " (" << std::showpos << (long long)(r.samples - rows[0].samples) << std::noshowpos
                      << " vs OpenCL), RGB vs OpenCL: max |diff| " << sci(r.max_abs_diff) << ", mean |diff| "
                      << sci(r.mean_abs_diff);
        std::cout << "\n";
    }
    std::cout << "OpenCL / native SIMD Msamples/s: " << fixed(rows[0].msamples_per_s() / simd_rate, 3) << "\n";

    bool images_match = true;
    for (std::size_t i = 1; i < rows.size(); ++i) images_match &= rows[i].mean_abs_diff <= 1e-3;
    if (!images_match) std::cout << "WARNING: a native image differs from the OpenCL one (mean |diff| > 1e-3)\n";

    if (!o.out_dir.empty()) {
        std::filesystem::create_directories(o.out_dir);
        std::string header = "<!-- " + command + " | " + context.device().name + " | " +
                             std::to_string(std::thread::hardware_concurrency()) + " cores -->\n";
        write_file(std::filesystem::path(o.out_dir) / "camera_pass.md", header + markdown_table(rows, simd_rate));
        write_file(std::filesystem::path(o.out_dir) / "camera_pass.csv", csv_table(rows, simd_rate));
        std::cout << "wrote " << o.out_dir << "/camera_pass.{csv,md}\n";
    }
    return images_match ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) { return sombra::host::guarded_main("sombra_bench_camera", run, argc, argv); }
