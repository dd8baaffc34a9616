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

// DSM cases state Knecht's absolute bound |ΔT| ≤ ε unless they set o.dsm.error = "relative".
RenderOptions technique(ShadowTechnique t, const std::string& storage = "atlas", float eps = 0.001f, int res = 256) {
    RenderOptions o;
    o.shadows = t;
    o.dsm.error = "absolute";
    o.dsm.storage = storage;
    o.dsm.epsilon = eps;
    o.dsm.resolution = res;
    return o;
}

std::vector<double> query(const Scene& scene, const std::vector<Vec3>& points, const RenderOptions& o) {
    return shadow_transmittance(test::context(), scene, 0, points, o).transmittance;
}

// One volume of voxel size h centred at the origin.
Scene one_volume(std::shared_ptr<const Volume> volume, const TransferFunction& tf, float h) {
    Scene scene;
    VolumeInstance vi;
    vi.volume = std::move(volume);
    vi.transfer_function = tf;
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {h, h, h});
    scene.volumes.push_back(vi);
    return scene;
}

// A homogeneous cube of n³ voxels of size h centred at the origin, opacity alpha per voxel.
Scene homogeneous_cube(int n, float h, float alpha) { return one_volume(constant_volume({n, n, n}, 1.f), constant_tf(alpha), h); }

// A point light inside a homogeneous cube (voxel size h, opacity alpha per voxel) and `count`
// random points in [−half, half]³ whose exact transmittance exp(−σ r) lies in [t_min, t_max].
struct LitCube {
    Scene scene;
    std::vector<Vec3> points;
    std::vector<double> exact;
};
LitCube point_light_in_cube(int n, float alpha, int count, float half, unsigned seed, double t_min = 0, double t_max = 1) {
    const float h = 1.f / float(n);
    LitCube c{homogeneous_cube(n, h, alpha), {}, {}};
    c.scene.lights = {point_light({0.05f, -0.03f, 0.02f})};
    const double sigma = sigma_of(alpha, h);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uni(-half, half);
    for (int i = 0; i < count; ++i) {
        Vec3 p{uni(rng), uni(rng), uni(rng)};
        double r2 = 0;
        for (int k = 0; k < 3; ++k) r2 += (double(p[k]) - c.scene.lights[0].position[k]) * (double(p[k]) - c.scene.lights[0].position[k]);
        const double t = std::exp(-sigma * std::sqrt(r2));
        if (t < t_min || t > t_max) continue;
        c.points.push_back(p);
        c.exact.push_back(t);
    }
    return c;
}

}  // namespace

TEST_CASE("accuracy: point light inside a homogeneous cube, T = exp(-sigma r)", "[accuracy]") {
    const auto [scene, points, exact] = point_light_in_cube(32, 0.03f, 300, 0.4f, 11);
    Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
    INFO("rays " << rays.describe());
    CHECK(rays.valid);
    CHECK(rays.max <= 1e-4);
    for (const char* storage : {"atlas", "chunked", "compact"})
        for (const char* bound : {"absolute", "relative"}) {
            const float eps = 0.001f;
            RenderOptions o = technique(ShadowTechnique::Dsm, storage, eps, 256);
            o.dsm.error = bound;
            Errors dsm = errors_of(query(scene, points, o), exact);
            INFO("dsm " << storage << " " << bound << " " << dsm.describe());
            CHECK(dsm.valid);
            CHECK(dsm.max <= std::expm1(double(eps)) + 1e-4);  // relative: |ΔT| ≤ T (e^ε − 1)
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
    TransferFunction tf;
    tf.color_points = {{0.f, 1.f, 1.f, 1.f}};
    tf.opacity_points = {{0.f, 0.f}, {1.f, peak}};
    Scene scene = one_volume(std::make_shared<const Volume>(std::move(v)), tf, h);
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
    // the judge first (issue 27 item 3): the brute-force reference pre-integrates σ over the value
    // range in closed form, so the stiff wall is exact up to rounding (the midpoint rule was off
    // by up to 0.029); measured max error 2e-14
    std::vector<double> reference;
    for (const Vec3& p : points) reference.push_back(reference_transmittance(scene, 0, p));
    Errors judge = errors_of(reference, exact);
    INFO("reference " << judge.describe());
    CHECK(judge.valid);
    CHECK(judge.max <= 1e-4);
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
    RenderOptions lowpass = technique(ShadowTechnique::Lowpass);
    lowpass.sat.filter_width = 1.f;
    Errors low = errors_of(query(scene, points, lowpass), exact);
    INFO("low-pass W 1 " << low.describe());
    CHECK(low.valid);
    CHECK(low.max <= 0.02);
}

TEST_CASE("atlas memory follows the nodes: a many-node map within 2x of compact's bytes", "[accuracy][dsm]") {
    // point light inside a homogeneous cube, ε 0.001: ~8 nodes in every texel of six faces
    const int n = 32;
    Scene scene = homogeneous_cube(n, 1.f / n, 0.03f);
    scene.lights = {point_light({0.05f, -0.03f, 0.02f})};
    std::vector<Vec3> points = {{0.1f, 0.1f, 0.1f}};
    auto stats_of = [&](const char* storage, const char* lookup) {
        RenderOptions o = technique(ShadowTechnique::Dsm, storage, 0.001f, 256);
        o.dsm.lookup = lookup;
        return shadow_transmittance(test::context(), scene, 0, points, o).stats;
    };
    // the atlas's own layout (native lookups); packed lookups add a compact copy
    RenderStats compact = stats_of("compact", "native"), atlas = stats_of("atlas", "native");
    CHECK(stats_of("atlas", "packed").dsm_bytes_used == atlas.dsm_bytes_used + compact.dsm_bytes_used);
    INFO("nodes " << compact.dsm_nodes << " (mean " << compact.dsm_mean_nodes_per_texel << ", max "
                  << compact.dsm_max_nodes_per_texel << " per texel); bytes: compact " << compact.dsm_bytes_used
                  << ", atlas " << atlas.dsm_bytes_used);
    CHECK(atlas.dsm_nodes == compact.dsm_nodes);
    CHECK(compact.dsm_mean_nodes_per_texel > 5);  // the case is not trivial
    CHECK(atlas.dsm_bytes_used <= 2 * compact.dsm_bytes_used);
}

TEST_CASE("accuracy: homogeneous slab in a rotated anisotropic volume, directional and far spot light", "[accuracy]") {
    // voxels (1.5, 1, 0.75) mm, a slab of 16 voxels along the volume's x (24 mm) of value 1 in a
    // 24×20×32 grid of value 1 inside the slab only; rotated; opacity unit 1 mm
    const int nx = 16, ny = 20, nz = 32;
    Scene scene;
    VolumeInstance vi;
    vi.volume = constant_volume({nx, ny, nz}, 1.f);
    vi.spacing = {1.5f, 1.f, 0.75f};
    vi.transform = make_transform({3.f, -2.f, 1.f}, {25.f, -40.f, 70.f}, {1.f, 1.f, 1.f});
    const float alpha = 0.05f;  // per mm
    vi.transfer_function = constant_tf(alpha);
    vi.opacity_unit = 1.f;
    scene.volumes.push_back(vi);
    const double sigma = sigma_of(alpha, 1.0);
    // box frame: rotation R of the transform (columns), half extents n·spacing/2
    const std::array<double, 3> half{0.5 * nx * 1.5, 0.5 * ny * 1.0, 0.5 * nz * 0.75};
    auto chord = [&](const Vec3& p, const Vec3& toward) {  // length inside the box along p + t·toward
        std::array<double, 3> pb{}, ub{};
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                double r = vi.transform[std::size_t(j * 4 + i)];  // Rᵀ
                pb[i] += r * (double(p[j]) - vi.transform[std::size_t(j * 4 + 3)]);
                ub[i] += r * double(toward[j]);
            }
        double t0 = 0, t1 = INFINITY;
        for (int a = 0; a < 3; ++a) {
            if (ub[a] == 0) continue;
            double ta = (-half[a] - pb[a]) / ub[a], tb = (half[a] - pb[a]) / ub[a];
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
        }
        return std::max(0.0, t1 - t0);
    };
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> uni(-0.8f, 0.8f);
    std::vector<Vec3> points;
    for (int i = 0; i < 200; ++i) {  // inside the box
        Vec3 b{float(uni(rng) * half[0]), float(uni(rng) * half[1]), float(uni(rng) * half[2])}, p{};
        for (int j = 0; j < 3; ++j)
            p[std::size_t(j)] = vi.transform[std::size_t(j * 4 + 3)] + vi.transform[std::size_t(j * 4)] * b[0] +
                                vi.transform[std::size_t(j * 4 + 1)] * b[1] + vi.transform[std::size_t(j * 4 + 2)] * b[2];
        points.push_back(p);
    }
    const Vec3 d{0.3f, -0.5f, -0.81f};
    const double len = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
    const Vec3 toward{float(-d[0] / len), float(-d[1] / len), float(-d[2] / len)};

    SECTION("directional light") {
        scene.lights = {directional(d)};
        std::vector<double> exact;
        for (const Vec3& p : points) exact.push_back(std::exp(-sigma * chord(p, toward)));
        Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
        Errors dsm = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, "atlas", 0.001f, 512)), exact);
        INFO("slab, directional: rays " << rays.describe() << "; dsm 512² eps 0.001 " << dsm.describe());
        CHECK(rays.valid);
        CHECK(dsm.valid);
        CHECK(rays.max <= 1e-4);
        // the bilinear term: near the box's silhouette the four texels see different chords
        CHECK(dsm.mean <= 0.001 + 1e-4);
    }
    SECTION("spot light from far away") {
        const float far = 2000.f;
        scene.lights = {spot({float(3.f - far * toward[0]), float(-2.f - far * toward[1]), float(1.f - far * toward[2])}, d, 2.f)};
        std::vector<double> exact;
        for (const Vec3& p : points) {
            Vec3 to_light{scene.lights[0].position[0] - p[0], scene.lights[0].position[1] - p[1], scene.lights[0].position[2] - p[2]};
            double l = std::sqrt(double(to_light[0]) * to_light[0] + double(to_light[1]) * to_light[1] + double(to_light[2]) * to_light[2]);
            exact.push_back(std::exp(-sigma * chord(p, {float(to_light[0] / l), float(to_light[1] / l), float(to_light[2] / l)})));
        }
        Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
        INFO("slab, far spot: rays " << rays.describe());
        CHECK(rays.valid);
        CHECK(rays.max <= 1e-4);
    }
}

TEST_CASE("accuracy: nearly transparent medium, light along a face, light on the boundary, eps 0 and eps >= 1", "[accuracy]") {
    const int n = 16;
    const float h = 1.f / n;
    SECTION("opacity 1e-6 per voxel: T = exp(-sigma r) to 1e-7") {
        Scene scene = homogeneous_cube(n, h, 1e-6f);
        scene.lights = {point_light({-0.2f, 0.1f, 0.f})};
        const double sigma = sigma_of(1e-6, h);
        std::vector<Vec3> points = {{0.3f, 0.2f, 0.1f}, {-0.45f, -0.4f, 0.3f}, {0.f, 0.f, 0.f}};
        std::vector<double> exact;
        for (const Vec3& p : points) {
            double dx = p[0] + 0.2, dy = p[1] - 0.1, dz = p[2];
            exact.push_back(std::exp(-sigma * std::sqrt(dx * dx + dy * dy + dz * dz)));
        }
        Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
        Errors dsm = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, "compact", 0.f, 64)), exact);
        INFO("transparent: rays " << rays.describe() << "; dsm eps 0 " << dsm.describe());
        CHECK(rays.max <= 1e-6);
        CHECK(dsm.max <= 1e-6);
    }
    SECTION("directional light exactly along a face, points on the face and inside") {
        Scene scene = homogeneous_cube(n, h, 0.1f);
        scene.lights = {directional({0, 0, -1})};  // travels along −z; the face x = +0.5 contains the rays
        const double sigma = sigma_of(0.1, h);
        std::vector<Vec3> points = {{0.5f, 0.1f, 0.2f}, {0.5f, -0.3f, -0.4f}, {0.2f, 0.1f, -0.1f}, {0.5f, 0.5f, 0.f}};
        std::vector<double> chords = {0.3, 0.9, 0.6, 0.5};
        std::vector<double> exact;
        for (double c : chords) exact.push_back(std::exp(-sigma * c));
        for (auto t : {ShadowTechnique::Rays, ShadowTechnique::Dsm}) {
            auto got = query(scene, points, technique(t, "atlas", 0.001f, 128));
            for (std::size_t i = 0; i < got.size(); ++i) {
                INFO("technique " << int(t) << " point " << i << " got " << got[i] << " exact " << exact[i]);
                CHECK(std::isfinite(got[i]));
                CHECK(got[i] >= 0.0);
                CHECK(got[i] <= 1.0);
                // on the face itself the ray is inside the closed box: both sides are right within the model
                if (i == 2) CHECK(std::fabs(got[i] - exact[i]) <= (t == ShadowTechnique::Rays ? 1e-4 : 0.001 + 1e-4));
            }
        }
    }
    SECTION("point light on the boundary, eps 0 and eps 1") {
        Scene scene = homogeneous_cube(n, h, 0.05f);
        scene.lights = {point_light({0.5f, 0.f, 0.f})};
        const double sigma = sigma_of(0.05, h);
        std::vector<Vec3> points = {{0.f, 0.f, 0.f}, {-0.3f, 0.2f, 0.1f}, {0.4f, -0.1f, 0.2f}};
        std::vector<double> exact;
        for (const Vec3& p : points) {
            double dx = p[0] - 0.5, dy = p[1], dz = p[2];
            exact.push_back(std::exp(-sigma * std::sqrt(dx * dx + dy * dy + dz * dz)));
        }
        Errors rays = errors_of(query(scene, points, technique(ShadowTechnique::Rays)), exact);
        Errors dsm0 = errors_of(query(scene, points, technique(ShadowTechnique::Dsm, "atlas", 0.f, 128)), exact);
        auto coarse = query(scene, points, technique(ShadowTechnique::Dsm, "atlas", 1.f, 128));
        INFO("light on boundary: rays " << rays.describe() << "; dsm eps 0 " << dsm0.describe());
        CHECK(rays.max <= 1e-4);
        CHECK(dsm0.max <= 2e-4);  // ε = 0: only float rounding and the bilinear term
        for (double t : coarse) CHECK((std::isfinite(t) && t >= 0 && t <= 1));  // ε ≥ 1: one line, still in [0, 1]
    }
}

namespace {

// The exact single-scattering radiance of one camera ray through the homogeneous cube [−½, ½]³ of
// extinction σ and albedo 1, lit by a directional light travelling along −x (so the light's path
// inside the cube to a point at x is ½ − x), isotropic phase (unit gain), no ambient, black
// background: R = ∫ σ e^(−σ(s − t₀)) e^(−σ(½ − x(s))) ds over the ray's chord [t₀, t₁], in closed
// form because the exponent is linear in s. 0 where the ray misses the cube.
double exact_in_scattering(Vec3 eye, const std::array<double, 3>& dir, double sigma) {
    double t0 = 0, t1 = INFINITY;
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(dir[a]) < 1e-12) {
            if (std::fabs(eye[a]) > 0.5) return 0;
            continue;
        }
        double ta = (-0.5 - eye[a]) / dir[a], tb = (0.5 - eye[a]) / dir[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
    }
    if (!(t1 > t0)) return 0;
    double k = sigma * (1 - dir[0]);  // exponent −σ(½ − eye_x) + σ t₀ − k s
    return sigma * std::exp(sigma * t0 - sigma * (0.5 - eye[0])) * (std::exp(-k * t0) - std::exp(-k * t1)) / k;
}

}  // namespace

// Issue 27 item 0: the light term of each camera interval at its midpoint integrates in-scattering
// to second order. A lit, self-shadowed homogeneous cube (single scattering, shadow rays, which are
// exact here) against the closed form at three steps: the error must fall with the square of the
// step (ratio ≈ 4 per halving; the far end's first-order term gave ≈ 2), and stay small at the
// default step. Tolerances from the measurement (docs/shadows.md "In-scattering quadrature").
TEST_CASE("accuracy: in-scattering of a lit homogeneous cube converges with the square of the step", "[accuracy]") {
    const int n = 32, size = 40;
    const float h = 1.f / n, alpha = 0.1f;
    const double sigma = sigma_of(alpha, h);
    Scene scene = homogeneous_cube(n, h, alpha);
    scene.lights = {directional({-1, 0, 0})};
    scene.ambient_intensity = 0.f;
    scene.camera.position = {0.3f, 0.2f, 3.f};
    scene.camera.look_at = {0, 0, 0};
    scene.camera.up = {0, 1, 0};
    scene.camera.fov_y_deg = 30.f;
    RenderOptions o;
    o.width = o.height = size;
    o.shading = ShadingModel::Scattering;
    o.shadows = ShadowTechnique::Rays;
    o.rays.step = 0.25f;
    o.shadow_cache = ShadowCacheMode::Off;
    o.termination_transmittance = 1e-6f;
    // the camera's rays through the pixel centres (cl/render.cl render_camera)
    Vec3 eye = scene.camera.position;
    std::array<double, 3> forward{-eye[0], -eye[1], -eye[2]};
    auto unit = [](std::array<double, 3> v) {
        double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        return std::array<double, 3>{v[0] / l, v[1] / l, v[2] / l};
    };
    auto cross = [](std::array<double, 3> a, std::array<double, 3> b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    forward = unit(forward);
    std::array<double, 3> right = unit(cross(forward, {0, 1, 0})), up = cross(right, forward);
    double tan_half = std::tan(15.0 * M_PI / 180.0);
    std::vector<double> exact(std::size_t(size) * size);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            double sx = ((x + 0.5) / size) * 2 - 1, sy = 1 - ((y + 0.5) / size) * 2;
            std::array<double, 3> d;
            for (int a = 0; a < 3; ++a) d[a] = forward[a] + sx * tan_half * right[a] + sy * tan_half * up[a];
            exact[std::size_t(y) * size + x] = exact_in_scattering(eye, unit(d), sigma);
        }
    auto relative_rmse = [&](float step_voxels) {
        Scene s = scene;
        s.volumes[0].step_voxels = step_voxels;
        Image image = render(test::context(), s, o).image;
        double squared = 0, mean = 0;
        int hits = 0;
        for (std::size_t i = 0; i < exact.size(); ++i) {
            if (exact[i] <= 0) continue;
            double d = image.rgba[i * 4] - exact[i];
            squared += d * d, mean += exact[i], ++hits;
        }
        REQUIRE(hits > size * size / 4);
        return std::sqrt(squared / hits) / (mean / hits);
    };
    double coarse = relative_rmse(2.f), middle = relative_rmse(1.f), fine = relative_rmse(0.5f);
    INFO("relative RMSE at steps 2, 1, 0.5 voxels: " << coarse << " " << middle << " " << fine);
    CHECK(coarse / middle >= 3.0);
    CHECK(middle / fine >= 3.0);
    CHECK(fine <= 5e-5);  // measured 1.8e-5 (2: 2.7e-4, 1: 6.9e-5)
}

TEST_CASE("accuracy: dim light — a point light inside a thick homogeneous cube, absolute vs relative DSM bound", "[accuracy][dsm]") {
    // σ·r reaches ≈ 6.5 at the far corners: T from 1 down to ≈ 1.5e-3; the points of the dim region
    const auto [scene, points, exact] = point_light_in_cube(32, 0.15f, 2000, 0.45f, 5, 1e-3, 0.05);
    REQUIRE(points.size() >= 100);
    auto worst_relative = [&](const std::vector<double>& got) {
        double worst = 0;
        for (std::size_t i = 0; i < got.size(); ++i) worst = std::max(worst, std::fabs(got[i] - exact[i]) / exact[i]);
        return worst;
    };
    const float eps = 0.02f;
    for (const char* storage : {"atlas", "chunked", "compact"}) {
        RenderOptions absolute = technique(ShadowTechnique::Dsm, storage, eps, 128), relative = absolute;
        relative.dsm.error = "relative";
        const double absolute_error = worst_relative(query(scene, points, absolute));
        const double relative_error = worst_relative(query(scene, points, relative));
        INFO(storage << ": " << points.size() << " points with T in [1e-3, 0.05]: max |T' − T| / T absolute bound "
                     << absolute_error << ", relative bound " << relative_error);
        // τ is linear along each ray of a homogeneous medium, so one segment holds it exactly
        // (measured 1.8e-6 on every storage; the bound e^ε − 1 ≈ 0.02 allows far more)
        CHECK(relative_error <= 1e-3);
        // the absolute bound lets the dim region be off by up to ε, which is up to 20× T here
        // (measured 0.30 on every storage)
        CHECK(absolute_error > 0.1);
    }
}

TEST_CASE("accuracy: the camera pass sees a one-voxel near-opaque wall with the same opacity at every step", "[accuracy][render]") {
    // seen along its normal, the wall's coverage is 1 − exp(−∫σ), the same closed form as the
    // light passes' (issue 27 item 3): stiff intervals are split at the voxel-centre planes in the
    // camera pass too, so the step no longer changes it
    const int n = 16;
    const float peak = 0.999999f;
    Scene scene = one_voxel_wall(n, 1.f / n, peak);
    scene.lights.clear();  // the coverage only
    scene.camera.position = {-2.f, 0.f, 0.f};
    scene.camera.look_at = {0.f, 0.f, 0.f};
    scene.camera.up = {0.f, 0.f, 1.f};
    scene.camera.fov_y_deg = 4.f;  // rays within 2° of the normal: a path 1.0006× the wall's at most
    scene.width = scene.height = 8;
    const double coverage = 1 - std::exp(-2 * tent_flank_depth(peak));  // ≈ 0.865
    for (float step : {0.25f, 0.5f, 1.f, 2.f}) {
        scene.volumes[0].step_voxels = step;
        const Image image = render(test::context(), scene, RenderOptions{}).image;
        double worst = 0;
        for (int i = 0; i < image.width * image.height; ++i) worst = std::max(worst, std::fabs(image.rgba[4 * std::size_t(i) + 3] - coverage));
        INFO("step " << step << " voxels: max |coverage − closed form| " << worst);
        CHECK(worst <= 2e-3);  // measured 9.2e-4 at every step (before the split: 0.036, 0.073, 0.135, 0.78)
    }
}

TEST_CASE("accuracy: the DSM's signed error at the default ε, both bounds", "[accuracy][dsm]") {
    // a point light inside a homogeneous cube (T from 1 to ≈ 0.1): the compressor's nodes sit on
    // the function where they can (compress.h), so no error is the nodes' (it was ≈ 0.6 ε darker
    // behind media: issue 27 item 2; docs/deep-shadow-maps.md "Unbiased compression")
    const auto [scene, points, exact] = point_light_in_cube(32, 0.05f, 600, 0.45f, 9);
    for (const char* bound : {"absolute", "relative"}) {
        RenderOptions o = technique(ShadowTechnique::Dsm, "atlas", 0.02f, 128);
        o.dsm.error = bound;
        const std::vector<double> got = query(scene, points, o);
        double signed_mean = 0, abs_mean = 0;
        for (std::size_t i = 0; i < got.size(); ++i) {
            signed_mean += (got[i] - exact[i]) / double(got.size());
            abs_mean += std::fabs(got[i] - exact[i]) / double(got.size());
        }
        INFO(bound << ": mean signed " << signed_mean << ", mean |ΔT| " << abs_mean << " over " << got.size() << " points");
        if (std::string(bound) == "relative") {
            CHECK(std::fabs(signed_mean) <= 1e-5);  // measured 5.5e-8: τ is linear, one segment holds it
        } else {
            // measured +4.4e-3 = 0.22 ε (mean |ΔT| 9.0e-3): what remains is the chord's, not the
            // nodes' — between nodes the opacity is linear while 1 − e^−σr is concave, so T' ≥ T
            CHECK(signed_mean > 0);
            CHECK(signed_mean <= 0.3 * 0.02);
        }
    }
}

TEST_CASE("accuracy: shadow rays on the cloud of bench/scenes/cloud_reference.json against the converged single-scattering integral",
          "[accuracy][render]") {
    // 16 of the 240 pixels of bench/converged_reference.py (issue 27): its numpy integral of the
    // scene, converged to < 1e-4 (steps halved from 1 voxel to 1/8; Richardson puts the last one's
    // error at 1.5e-5), independent of sombra's code. RGB with shadows, and without (`none`).
    struct Pixel {
        int x, y;
        std::array<double, 3> shadowed, unshadowed;
    };
    const std::array<Pixel, 16> pixels{{
        {28, 13, {0.144134, 0.151302, 0.168805}, {0.145117, 0.152261, 0.169752}},
        {23, 16, {0.251825, 0.256793, 0.273198}, {0.263660, 0.268030, 0.283752}},
        {16, 19, {0.101536, 0.110617, 0.130334}, {0.104294, 0.113133, 0.132514}},
        {16, 21, {0.171009, 0.178892, 0.198266}, {0.183518, 0.190332, 0.208226}},
        {45, 22, {0.467541, 0.447025, 0.424504}, {0.563506, 0.550235, 0.543009}},
        {27, 24, {0.433457, 0.434223, 0.446030}, {0.944577, 0.928614, 0.926502}},
        {44, 26, {0.548313, 0.515190, 0.472351}, {0.798530, 0.776743, 0.760761}},
        {31, 29, {0.364567, 0.356684, 0.351560}, {0.925233, 0.906501, 0.899042}},
        {11, 31, {0.087394, 0.098966, 0.122463}, {0.125023, 0.132838, 0.150955}},
        {11, 32, {0.087962, 0.099761, 0.123657}, {0.127349, 0.135222, 0.153500}},
        {44, 33, {0.234781, 0.224166, 0.212657}, {0.373159, 0.368200, 0.370487}},
        {34, 35, {0.361686, 0.347181, 0.330624}, {0.880791, 0.859726, 0.847018}},
        {14, 37, {0.204879, 0.220242, 0.252770}, {0.357930, 0.359685, 0.373218}},
        {42, 38, {0.403186, 0.378404, 0.346583}, {0.560315, 0.547191, 0.540059}},
        {17, 41, {0.151815, 0.164683, 0.191710}, {0.265675, 0.269071, 0.283091}},
        {21, 44, {0.118289, 0.129450, 0.152779}, {0.208017, 0.212559, 0.227096}},
    }};
    const Scene scene = load_scene(std::string(SOMBRA_DATA_DIR) + "/../bench/scenes/cloud_reference.json");
    RenderOptions o = scene_render_options(scene);  // single scattering, g = 0.3; default step 0.5 voxel
    REQUIRE(o.shading == ShadingModel::Scattering);
    // relative RMSE over the pixels' RGB, and the largest relative error of one channel
    auto compare = [&](bool shadowed) {
        const Image image = render(test::context(), scene, o).image;
        REQUIRE(image.width == 64);
        double squared = 0, reference = 0, worst = 0;
        for (const Pixel& p : pixels)
            for (int c = 0; c < 3; ++c) {
                const double ref = shadowed ? p.shadowed[std::size_t(c)] : p.unshadowed[std::size_t(c)];
                const double d = image.rgba[4 * (std::size_t(p.y) * std::size_t(image.width) + std::size_t(p.x)) + std::size_t(c)] - ref;
                squared += d * d, reference += ref * ref;
                worst = std::max(worst, std::fabs(d) / ref);
            }
        return std::array<double, 2>{std::sqrt(squared / reference), worst};
    };
    o.shadows = ShadowTechnique::None;  // the camera pass's conventions: rays, phase, falloff, cone, ambient, background
    auto none = compare(false);
    INFO("none against the unshadowed integral: relative RMSE " << none[0] << ", max " << none[1]);
    CHECK(none[0] <= 3e-4);  // measured 6.9e-5, max 4.6e-4
    CHECK(none[1] <= 2e-3);
    o.shadows = ShadowTechnique::Rays;
    o.shadow_cache = ShadowCacheMode::Off;  // the technique per sample: exact but for the camera step
    auto rays = compare(true);
    INFO("rays per sample: relative RMSE " << rays[0] << ", max " << rays[1]);
    CHECK(rays[0] <= 1.5e-3);  // measured 6.4e-4, max 1.6e-3 (second order: 1.5e-4 at step 0.25 over the 240 pixels)
    CHECK(rays[1] <= 4e-3);
    o.shadow_cache = ShadowCacheMode::Auto;  // the default: auto takes the cache here (trilinear over the voxel lattice)
    auto cached = compare(true);
    INFO("rays, shadow cache auto: relative RMSE " << cached[0] << ", max " << cached[1]);
    CHECK(cached[0] <= 5e-3);  // issue 27's bound; measured 3.2e-3, max 6.4e-3
}
