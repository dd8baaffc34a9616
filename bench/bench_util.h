// sombra benchmarks — small helpers both benches use: medians and number formatting for the
// tables, and writing a result file.
#pragma once
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sombra/sombra.h"

namespace sombra::bench {

inline double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

inline std::string fixed(double v, int digits) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(digits) << v;
    return s.str();
}

inline std::string shortest(float v) {  // 0.02f → "0.02", 0.5f → "0.5", 2.f → "2"
    std::ostringstream s;
    s << v;
    return s.str();
}

inline std::string sci(double v) {
    std::ostringstream s;
    s << std::scientific << std::setprecision(2) << v;
    return s.str();
}

inline void write_file(const std::filesystem::path& path, const std::string& text) {
    std::ofstream out(path);
    out << text;
    if (!out) throw sombra::Error(path.string() + ": cannot write");
}

// Uniform random points in the world boxes of the scene's volumes (a volume drawn uniformly, then
// a point in its voxel-centre box mapped by its transform); deterministic for a seed.
inline std::vector<sombra::Vec3> random_points(const sombra::Scene& scene, int count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, scene.volumes.size() - 1);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    std::vector<sombra::Vec3> points;
    for (int i = 0; i < count; ++i) {
        const sombra::VolumeInstance& vi = scene.volumes[pick(rng)];
        float o[3];
        for (int a = 0; a < 3; ++a) o[a] = u(rng) * float(vi.volume->dims[a] - 1) * vi.spacing[a];
        const auto& m = vi.transform;
        sombra::Vec3 p;
        for (int r = 0; r < 3; ++r) p[r] = m[4 * r] * o[0] + m[4 * r + 1] * o[1] + m[4 * r + 2] * o[2] + m[4 * r + 3];
        points.push_back(p);
    }
    return points;
}

// The brute-force reference at every point, on all cores (the function is pure).
inline std::vector<double> reference_values(const sombra::Scene& scene, int light, const std::vector<sombra::Vec3>& points) {
    std::vector<double> values(points.size());
    unsigned workers = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> threads;
    for (unsigned w = 0; w < workers; ++w)
        threads.emplace_back([&, w] {
            for (std::size_t i = w; i < points.size(); i += workers)
                values[i] = sombra::reference_transmittance(scene, light, points[i]);
        });
    for (auto& t : threads) t.join();
    return values;
}

// render() keeps the last prepared scene (device data and shadow tables) in the Context and
// reuses it when only the camera or image changed; a 1×1 render without shadows replaces it, so
// that the next render builds its shadow data again.
inline void forget_preparation(sombra::Context& context, const sombra::Scene&) { context.release_prepared_scenes(); }

// One warm-up render (program builds, PoCL kernel cache, first enqueue; unless warm_up is false),
// then `runs` timed ones, each after forget_preparation so that it builds its shadow data anew:
// their stats and wall times.
struct TimedRender {
    sombra::RenderStats stats;
    double wall_ms = 0;
};
inline std::vector<TimedRender> fresh_renders(sombra::Context& context, const sombra::Scene& scene,
                                              const sombra::RenderOptions& options, int runs, bool warm_up = true) {
    if (warm_up) {
        forget_preparation(context, scene);
        sombra::render(context, scene, options);
    }
    std::vector<TimedRender> out;
    for (int i = 0; i < runs; ++i) {
        forget_preparation(context, scene);
        auto start = std::chrono::steady_clock::now();
        sombra::RenderStats stats = sombra::render(context, scene, options).stats;
        out.push_back({std::move(stats), std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count()});
    }
    return out;
}

}  // namespace sombra::bench
