// sombra tests — closed-form accuracy (issue "exact where the answer is known"): every shadow
// technique against transmittances known exactly, not against the reference. Tolerances: shadow
// rays 1e-4 on homogeneous media; deep shadow maps ε + 1e-4 (+ the lookup's bilinear term, zero
// where the neighbouring texels see the same function); the one-voxel wall 0.01 (rays, DSM) and
// 0.02 (low-pass, W = 1). Every value finite and in [0, 1].
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <sstream>

#include "test_support.h"

using namespace sombra;

namespace {

using test::constant_tf;
using test::constant_volume;

double sigma_of(double alpha, double unit) { return -std::log(1.0 - alpha) / unit; }

Light point_light(Vec3 p) {
    Light l;
    l.type = LightType::Point;
    l.position = p;
    return l;
}
Light directional(Vec3 d) {
    Light l;
    l.type = LightType::Directional;
    l.direction = d;
    return l;
}
Light spot(Vec3 p, Vec3 d, float cone_deg) {
    Light l;
    l.type = LightType::Spot;
    l.position = p;
    l.direction = d;
    l.cone_angle_deg = cone_deg;
    return l;
}

struct Errors {
    double mean = 0, max = 0;
    bool valid = true;  // every value finite and in [0, 1]
    std::string describe() const {
        std::ostringstream s;
        s << "mean " << mean << " max " << max << (valid ? "" : " (INVALID VALUES)");
        return s.str();
    }
};

Errors errors_of(const std::vector<double>& got, const std::vector<double>& exact) {
    Errors e;
    for (std::size_t i = 0; i < got.size(); ++i) {
        double d = std::fabs(got[i] - exact[i]);
        if (!(std::isfinite(got[i]) && got[i] >= 0 && got[i] <= 1)) e.valid = false, d = INFINITY;
        e.mean += d / double(got.size());
        e.max = std::max(e.max, d);
    }
    return e;
}

RenderOptions technique(ShadowTechnique t, const std::string& storage = "atlas", float eps = 0.001f, int res = 256) {
    RenderOptions o;
    o.shadows = t;
    o.dsm_storage = storage;
    o.dsm_epsilon = eps;
    o.dsm_resolution = res;
    return o;
}

std::vector<double> query(const Scene& scene, const std::vector<Vec3>& points, const RenderOptions& o) {
    return shadow_transmittance(test::context(), scene, 0, points, o).transmittance;
}

// A homogeneous cube of n³ voxels of size h centred at the origin, opacity alpha per voxel.
Scene homogeneous_cube(int n, float h, float alpha) {
    Scene scene;
    VolumeInstance vi;
    vi.volume = constant_volume({n, n, n}, 1.f);
    vi.transfer_function = constant_tf(alpha);
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {h, h, h});
    scene.volumes.push_back(vi);
    return scene;
}

}  // namespace

TEST_CASE("accuracy: point light inside a homogeneous cube, T = exp(-sigma r)", "[accuracy]") {
    const int n = 32;
    const float h = 1.f / n, alpha = 0.03f;
    Scene scene = homogeneous_cube(n, h, alpha);
    scene.lights = {point_light({0.05f, -0.03f, 0.02f})};
    const double sigma = sigma_of(alpha, h);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> uni(-0.4f, 0.4f);
    std::vector<Vec3> points;
    std::vector<double> exact;
    for (int i = 0; i < 300; ++i) {
        Vec3 p{uni(rng), uni(rng), uni(rng)};
        points.push_back(p);
        double dx = double(p[0]) - scene.lights[0].position[0], dy = double(p[1]) - scene.lights[0].position[1],
               dz = double(p[2]) - scene.lights[0].position[2];
        exact.push_back(std::exp(-sigma * std::sqrt(dx * dx + dy * dy + dz * dz)));
    }
    Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
    INFO("rays " << rays.describe());
    CHECK(rays.valid);
    CHECK(rays.max <= 1e-4);
    for (const char* storage : {"atlas", "chunked", "compact"}) {
        const float eps = 0.001f;
        Errors dsm = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, storage, eps, 256)), exact);
        INFO("dsm " << storage << " " << dsm.describe());
        CHECK(dsm.valid);
        CHECK(dsm.max <= eps + 1e-4);
    }
}

namespace {

// ∫₀¹ −ln(1 − a·d) dd: the optical depth (in opacity units) of one flank of a trilinear tent
// whose peak value 1 maps to opacity a, the transfer function's opacity linear from 0 to a.
double tent_flank_depth(double a) { return ((1 - a) * std::log1p(-a) - (1 - a) + 1) / a; }

// A one-voxel wall: voxels of value 1 in the slice x = n/2, 0 elsewhere; opacity linear in the
// value from 0 to `peak` per voxel; light along the wall's normal (+x).
Scene one_voxel_wall(int n, float h, float peak) {
    Volume v;
    v.dims = {n, n, n};
    v.voxels.assign(v.voxel_count(), 0.f);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y) v.voxels[std::size_t((z * n + y) * n + n / 2)] = 1.f;
    v.source = "wall";
    v.update_range();
    Scene scene;
    VolumeInstance vi;
    vi.volume = std::make_shared<const Volume>(std::move(v));
    vi.transfer_function.color_points = {{0.f, 1.f, 1.f, 1.f}};
    vi.transfer_function.opacity_points = {{0.f, 0.f}, {1.f, peak}};
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {h, h, h});
    scene.volumes.push_back(vi);
    scene.lights = {directional({1, 0, 0})};
    return scene;
}

}  // namespace

TEST_CASE("accuracy: one-voxel near-opaque wall, light along its normal", "[accuracy]") {
    const int n = 16;
    const float h = 1.f / n, peak = 0.999999f;
    Scene scene = one_voxel_wall(n, h, peak);
    const double behind = std::exp(-2 * tent_flank_depth(peak));  // ≈ e⁻² = 0.135
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> across(-0.4f, 0.4f), depth(0.2f, 0.45f);
    std::vector<Vec3> points;
    std::vector<double> exact;
    for (int i = 0; i < 200; ++i) {
        points.push_back({depth(rng), across(rng), across(rng)});  // behind the wall (x > 1.5 voxels)
        exact.push_back(behind);
    }
    Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
    // DSM: the model's error plus the compression's ε (the default ε 0.02 alone allows 0.02)
    Errors dsm_fine = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, "atlas", 0.005f, 64)), exact);
    Errors dsm_default = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, "atlas", 0.02f, 64)), exact);
    INFO("wall: model T " << behind << "; rays " << rays.describe() << "; dsm eps 0.005 " << dsm_fine.describe()
                          << "; dsm eps 0.02 " << dsm_default.describe());
    CHECK(rays.valid);
    CHECK(dsm_fine.valid);
    CHECK(dsm_default.valid);
    CHECK(rays.max <= 0.01);
    CHECK(dsm_fine.max <= 0.01);
    CHECK(dsm_default.max <= 0.02 + 0.005);
}
