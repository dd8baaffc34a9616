// Volume sampling, transfer functions and gradients: kernels against plain C++.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <random>

#include "host/runtime.h"
#include "reference/raycaster_ref.h"
#include "geometry/scene_upload.h"
#include "test_support.h"

using namespace sombra;

namespace {

struct ProbeResult {
    std::vector<cl_float4> density, gradient, normal;
};

// Runs sample_probe.cl on volume 0 of `scene` at voxel positions `points`.
ProbeResult probe(const Scene& scene, const std::vector<cl_float4>& points, bool sobel, bool images) {
    auto& rt = test::context().runtime();
    packing::PackedScene packed = packing::pack_scene(scene);
    packing::DeviceScene dev = packing::upload_scene(rt, scene, packed, images);
    std::vector<std::string> defines;
    if (sobel) defines.push_back("SOMBRA_SOBEL");
    if (images) defines.push_back("SOMBRA_USE_IMAGES");
    cl::Kernel kernel(rt.program("tests/sample_probe.cl", defines), "sample_probe");
    std::size_t n = points.size(), bytes = n * sizeof(cl_float4);
    cl::Buffer in = host::make_buffer(rt, CL_MEM_READ_ONLY, bytes, points.data(), "points");
    cl::Buffer d(rt.context(), CL_MEM_WRITE_ONLY, bytes), g(rt.context(), CL_MEM_WRITE_ONLY, bytes),
        nrm(rt.context(), CL_MEM_WRITE_ONLY, bytes);
    if (images) kernel.setArg(0, dev.voxel_image);
    else kernel.setArg(0, dev.voxel_buffer);
    kernel.setArg(1, dev.tf_tables);
    kernel.setArg(2, dev.volumes);
    kernel.setArg(3, in);
    kernel.setArg(4, d);
    kernel.setArg(5, g);
    kernel.setArg(6, nrm);
    rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(n));
    ProbeResult r{std::vector<cl_float4>(n), std::vector<cl_float4>(n), std::vector<cl_float4>(n)};
    rt.queue().enqueueReadBuffer(d, CL_TRUE, 0, bytes, r.density.data());
    rt.queue().enqueueReadBuffer(g, CL_TRUE, 0, bytes, r.gradient.data());
    rt.queue().enqueueReadBuffer(nrm, CL_TRUE, 0, bytes, r.normal.data());
    return r;
}

// f(x, y, z) = a·x + b·y + c·z in voxel units: every gradient estimator is exact on it inside.
Volume linear_ramp(int n, double a, double b, double c) {
    Volume v;
    v.dims = {n, n, n};
    v.voxels.resize(std::size_t(n) * n * n);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                v.voxels[std::size_t(x) + n * (std::size_t(y) + n * z)] = float(0.5 + a * x + b * y + c * z);
    v.update_range();
    return v;
}

Scene single_volume_scene(Volume v, const std::array<float, 16>& transform) {
    Scene s = test::sphere_scene();
    s.volumes[0].volume = std::make_shared<const Volume>(std::move(v));
    s.volumes[0].transform = transform;
    s.volumes[0].transfer_function.color_points = {{0.f, 0.f, 0.f, 0.f}, {2.f, 1.f, 1.f, 1.f}};
    s.volumes[0].transfer_function.opacity_points = {{0.f, 0.f}, {2.f, 0.8f}};
    return s;
}

std::vector<cl_float4> random_points(int count, float lo, float hi, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(lo, hi);
    std::vector<cl_float4> p(static_cast<std::size_t>(count));
    for (auto& q : p) q = {{u(rng), u(rng), u(rng), 0.f}};
    return p;
}

}  // namespace

TEST_CASE("transfer function: interpolation, clamping, opacity → extinction", "[tf]") {
    TransferFunction tf;
    tf.color_points = {{0.f, 0.f, 0.f, 0.f}, {10.f, 1.f, 0.5f, 0.f}};
    tf.opacity_points = {{2.f, 0.f}, {4.f, 0.5f}, {8.f, 1.f}};
    CHECK(tf.color(5.f)[0] == Approx(0.5f));
    CHECK(tf.color(-3.f)[0] == Approx(0.f));
    CHECK(tf.color(30.f)[1] == Approx(0.5f));
    CHECK(tf.opacity(3.f) == Approx(0.25f));
    CHECK(tf.opacity(100.f) == Approx(1.f));
    CHECK(tf.domain_min() == 0.f);
    CHECK(tf.domain_max() == 10.f);
    const float unit = 0.25f;
    auto table = tf.table(11, unit);  // entries at x = 0, 1, …, 10
    CHECK(table[4][3] == Approx(-std::log(0.5) / unit));  // σ = −ln(1 − α) / unit
    CHECK(table[0][3] == 0.f);
    CHECK(table[10][3] == Approx(-std::log(1e-6) / unit));  // α = 1 is capped, finite
    // opacity correction: α at step Δ equals 1 − (1 − α₀)^(Δ/unit)
    for (float step : {0.05f, 0.25f, 1.f}) CHECK(1 - std::exp(-table[4][3] * step) == Approx(1 - std::pow(0.5, step / unit)));
}

TEST_CASE("transfer function validation names the field", "[tf]") {
    TransferFunction tf;
    tf.color_points = {{0.f, 0.f, 0.f, 0.f}};
    tf.opacity_points = {{0.f, 1.5f}};
    CHECK_THROWS_WITH(tf.validate("tf"), Catch::Contains("tf.opacity_points[0]"));
    tf.opacity_points = {{1.f, 0.f}, {0.f, 0.f}};
    CHECK_THROWS_WITH(tf.validate("tf"), Catch::Contains("sorted"));
    tf.opacity_points.clear();
    CHECK_THROWS_WITH(tf.validate("tf"), Catch::Contains("at least one"));
}

TEST_CASE("trilinear sampling and classification: kernel vs C++ over random points", "[sampling]") {
    Scene s = single_volume_scene(make_gaussian_blobs(12, 4, 11), make_transform({0, 0, 0}, {0, 0, 0}, {1, 1, 1}));
    s.volumes[0].transfer_function = test::ramp_tf(0.1f, 0.8f, 0.7f);
    auto points = random_points(2000, -1.f, 12.f, 5);  // includes clamped positions outside
    for (bool images : {false, true}) {
        ProbeResult r = probe(s, points, false, images);
        const Volume& v = *s.volumes[0].volume;
        const TransferFunction& tf = s.volumes[0].transfer_function;
        double worst_density = 0, worst_sigma = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            double ref = reference::sample_trilinear(v, points[i].s[0], points[i].s[1], points[i].s[2]);
            worst_density = std::max(worst_density, std::fabs(r.density[i].s[0] - ref));
            double sigma = -std::log1p(-std::min(0.999999, double(tf.opacity(float(ref)))));  // unit = 1 voxel
            worst_sigma = std::max(worst_sigma, std::fabs(r.density[i].s[2] - sigma) / (1 + sigma));
        }
        INFO((images ? "image" : "buffer") << ": density error " << worst_density << ", σ rel. error " << worst_sigma);
        CHECK(worst_density < 1e-5);
        CHECK(worst_sigma < 5e-3);  // 1024-entry table vs exact evaluation
    }
}

TEST_CASE("gradients are exact on a linear ramp and follow the volume's transform", "[sampling][gradient]") {
    const double a = 0.01, b = -0.02, c = 0.015;
    // rotated, anisotropically scaled volume: the world normal is −Jᵀ∇f normalised
    auto transform = make_transform({0.3f, -0.2f, 0.1f}, {30.f, -40.f, 15.f}, {0.5f, 2.f, 1.f});
    Scene s = single_volume_scene(linear_ramp(16, a, b, c), transform);
    auto points = random_points(500, 1.5f, 13.5f, 9);  // inside, away from the clamped border
    packing::PackedScene packed = packing::pack_scene(s);
    const VolumeGpu& g = packed.volumes[0];
    for (bool sobel : {false, true}) {
        ProbeResult r = probe(s, points, sobel, false);
        double worst_gradient = 0, worst_normal = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            worst_gradient = std::max({worst_gradient, std::fabs(r.gradient[i].s[0] - a), std::fabs(r.gradient[i].s[1] - b),
                                       std::fabs(r.gradient[i].s[2] - c)});
            double w[3];
            for (int k = 0; k < 3; ++k)
                w[k] = a * g.world_to_voxel[0].s[k] + b * g.world_to_voxel[1].s[k] + c * g.world_to_voxel[2].s[k];
            double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            for (int k = 0; k < 3; ++k) worst_normal = std::max(worst_normal, std::fabs(r.normal[i].s[k] + w[k] / len));
        }
        INFO((sobel ? "Sobel" : "central") << ": gradient error " << worst_gradient << ", normal error " << worst_normal);
        CHECK(worst_gradient < 1e-5);
        CHECK(worst_normal < 1e-4);
    }
}

TEST_CASE("a vanishing gradient gives a zero normal, never NaN", "[sampling][gradient][numerics]") {
    Volume flat = linear_ramp(8, 0, 0, 0);
    Scene s = single_volume_scene(flat, make_transform({0, 0, 0}, {0, 0, 0}, {1e-3f, 1e-3f, 1e-3f}));
    ProbeResult r = probe(s, random_points(100, 0.f, 7.f, 3), true, false);
    for (auto& n : r.normal) {
        REQUIRE(std::isfinite(n.s[0]));
        CHECK(n.s[0] == 0.f);
        CHECK(n.s[1] == 0.f);
        CHECK(n.s[2] == 0.f);
    }
}

TEST_CASE("brick distances: the cube of (2r - 1)^3 bricks around a brick is of its kind, and the next one is not", "[sampling]") {
    // random occupancy at several densities and shapes (thin grids, all empty, all occupied), against brute force
    std::mt19937 rng(7);
    const std::array<int, 3> shapes[] = {{9, 7, 5}, {1, 12, 3}, {16, 16, 16}, {4, 1, 1}};
    for (const auto& dims : shapes)
        for (double density : {0.0, 0.02, 0.3, 0.9, 1.0}) {
            INFO(dims[0] << "x" << dims[1] << "x" << dims[2] << " occupied " << density);
            const std::size_t count = std::size_t(dims[0]) * dims[1] * dims[2];
            std::bernoulli_distribution occupied_draw(density);
            std::vector<cl_uchar> occupied(count);
            for (auto& o : occupied) o = occupied_draw(rng) ? 1 : 0;
            const std::vector<cl_uchar> bytes = packing::brick_distances(occupied, dims);
            REQUIRE(bytes.size() == count);
            auto index = [&](int x, int y, int z) { return std::size_t(x) + std::size_t(dims[0]) * (std::size_t(y) + std::size_t(dims[1]) * std::size_t(z)); };
            for (int z = 0; z < dims[2]; ++z)
                for (int y = 0; y < dims[1]; ++y)
                    for (int x = 0; x < dims[0]; ++x) {
                        const bool full = occupied[index(x, y, z)] != 0;
                        const int byte = bytes[index(x, y, z)];
                        CHECK((byte >= 128) == full);
                        const int r = full ? byte - 128 : byte;
                        REQUIRE(r >= 1);
                        REQUIRE(r <= 127);
                        // the nearest brick of the other kind, by brute force (127: none)
                        int nearest = 127;
                        for (int qz = 0; qz < dims[2]; ++qz)
                            for (int qy = 0; qy < dims[1]; ++qy)
                                for (int qx = 0; qx < dims[0]; ++qx)
                                    if ((occupied[index(qx, qy, qz)] != 0) != full)
                                        nearest = std::min(nearest, std::max({std::abs(qx - x), std::abs(qy - y), std::abs(qz - z)}));
                        CHECK(r == nearest);
                    }
        }
}

TEST_CASE("brick ranges cover every voxel a trilinear sample in the brick reads", "[sampling]") {
    Volume v = make_cloud_noise(19, 4);  // not a multiple of the brick size
    packing::BrickRanges r = packing::compute_brick_ranges(v);
    const int n = (19 + SOMBRA_BRICK_SIZE - 1) / SOMBRA_BRICK_SIZE;
    REQUIRE(r.brick_dims == std::array<int, 3>{n, n, n});
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.f, 18.f);
    for (int i = 0; i < 5000; ++i) {
        float p[3] = {u(rng), u(rng), u(rng)};
        int b[3];
        for (int k = 0; k < 3; ++k) b[k] = std::min(int(p[k]) / SOMBRA_BRICK_SIZE, r.brick_dims[k] - 1);
        std::size_t brick = std::size_t(b[0]) + std::size_t(n) * (std::size_t(b[1]) + std::size_t(n) * std::size_t(b[2]));
        double value = reference::sample_trilinear(v, p[0], p[1], p[2]);
        REQUIRE(value >= r.min[brick] - 1e-6);
        REQUIRE(value <= r.max[brick] + 1e-6);
    }
}
