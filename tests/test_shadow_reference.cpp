// sombra tests — the ground-truth transmittance (reference_transmittance) against closed forms,
// and the deep OpenEXR form of deep shadow maps.
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include "test_support.h"

using namespace sombra;

namespace {

using D3 = std::array<double, 3>;

D3 d3(const Vec3& v) { return {v[0], v[1], v[2]}; }
Vec3 f3(const D3& v) { return {float(v[0]), float(v[1]), float(v[2])}; }
double dot3(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm3(const D3& a) { return std::sqrt(dot3(a, a)); }
D3 minus(const D3& a, const D3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

using test::constant_tf;
using test::constant_volume;

// σ = −ln(1 − α)/unit (docs/scenes.md, "Opacity convention").
double sigma_of(float alpha, double unit) { return -std::log(1.0 - double(alpha)) / unit; }

Light directional(const D3& direction) {
    Light l;
    l.type = LightType::Directional;
    l.direction = f3(direction);
    return l;
}
Light point_light(const D3& position) {
    Light l;
    l.type = LightType::Point;
    l.position = f3(position);
    return l;
}

// Length of the ray p + t·u (|u| = 1), t ∈ [0, t_end], inside the box {x : |x − c| ≤ half} (per
// axis), all in the box's own axis-aligned frame: the interval where every axis is inside.
double box_chord(const D3& half, const D3& p, const D3& u, double t_end) {
    double t0 = 0, t1 = t_end;
    for (int a = 0; a < 3; ++a) {
        if (u[a] == 0) {
            if (std::fabs(p[a]) > half[a]) return 0;
            continue;
        }
        double ta = (-half[a] - p[a]) / u[a], tb = (half[a] - p[a]) / u[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
    }
    return std::max(0.0, t1 - t0);
}

D3 random_unit(std::mt19937& rng) {
    std::normal_distribution<double> n(0, 1);
    for (;;) {
        D3 v{n(rng), n(rng), n(rng)};
        double len = norm3(v);
        if (len > 1e-3) return {v[0] / len, v[1] / len, v[2] / len};
    }
}

// Box frame of a volume whose transform is T·R·(uniform scale s): x_box = Rᵀ(x − t)/1, with the
// rotation read from the transform's columns (each of length s). All in double.
struct BoxFrame {
    D3 centre, half;
    double r[3][3];  // columns of R
    D3 to_box(const D3& x) const {
        D3 d = minus(x, centre);
        return {r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2], r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
                r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2]};
    }
    D3 dir_to_box(const D3& d) const { return to_box({d[0] + centre[0], d[1] + centre[1], d[2] + centre[2]}); }
    D3 from_box(const D3& b) const {
        D3 x = centre;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) x[i] += r[i][j] * b[j];
        return x;
    }
};

BoxFrame box_frame(const VolumeInstance& vi, double s) {
    BoxFrame f;
    for (int i = 0; i < 3; ++i) {
        f.centre[i] = vi.transform[i * 4 + 3];
        // box [−½, n − ½] in voxel space = [−n·sp/2, n·sp/2] in the object frame, times s
        f.half[i] = 0.5 * vi.volume->dims[i] * vi.spacing[i] * s;
        for (int j = 0; j < 3; ++j) f.r[i][j] = vi.transform[i * 4 + j] / s;
    }
    return f;
}

}  // namespace

TEST_CASE("reference transmittance: constant volume = exp(-sigma * chord)", "[shadow_reference]") {
    std::mt19937 rng(20240611);
    std::uniform_real_distribution<double> uni(-1, 1);

    struct Setup {
        const char* name;
        Vec3 rotate;
        float opacity_unit;
    };
    const Setup setups[] = {{"axis-aligned box, one-voxel unit", {0, 0, 0}, 0.f},
                            {"rotated box, explicit unit", {30, -20, 45}, 0.3f}};
    const double s = 0.25;
    double worst = 0;
    int rays = 0;
    for (const Setup& setup : setups) {
        SECTION(setup.name) {
            Scene scene;
            VolumeInstance vi;
            vi.volume = constant_volume({6, 4, 5}, 0.7f);
            vi.spacing = {1.f, 2.f, 0.5f};
            vi.transform = make_transform({0.3f, -0.2f, 0.1f}, setup.rotate, {float(s), float(s), float(s)});
            const float alpha = 0.1f;
            vi.transfer_function = constant_tf(alpha);
            vi.opacity_unit = setup.opacity_unit;
            scene.volumes.push_back(vi);
            const double unit = setup.opacity_unit > 0 ? setup.opacity_unit : 0.5 * s;  // smallest voxel: 0.5·s
            const double sigma = sigma_of(alpha, unit);
            const BoxFrame box = box_frame(vi, s);

            auto check = [&](const Light& light, const D3& p_box, double chord) {
                scene.lights = {light};
                const double expected = std::exp(-sigma * chord);
                const double got = reference_transmittance(scene, 0, f3(box.from_box(p_box)));
                const double rel = std::fabs(got - expected) / expected;
                worst = std::max(worst, rel);
                ++rays;
                INFO("chord " << chord << " expected " << expected << " got " << got);
                REQUIRE(rel < 1e-6);
            };
            auto random_in = [&](double factor) {  // uniform in the box scaled by `factor`, box frame
                return D3{factor * box.half[0] * uni(rng), factor * box.half[1] * uni(rng), factor * box.half[2] * uni(rng)};
            };
            // p is passed to the renderer as float: use the float-rounded point for the analytic chord.
            auto rounded = [&](const D3& p_box) { return box.to_box(d3(f3(box.from_box(p_box)))); };

            // Oblique directional lights, p inside: the chord is the distance to the exit face.
            for (int i = 0; i < 400; ++i) {
                D3 toward = random_unit(rng);  // from p towards the light
                Light l = directional({-toward[0], -toward[1], -toward[2]});
                D3 u = box.dir_to_box(d3(l.direction));
                u = {-u[0] / norm3(u), -u[1] / norm3(u), -u[2] / norm3(u)};
                D3 p = rounded(random_in(0.999));
                check(l, p, box_chord(box.half, p, u, INFINITY));
            }
            // Oblique directional lights, p anywhere around the box (the ray may miss it).
            for (int i = 0; i < 300; ++i) {
                D3 toward = random_unit(rng);
                Light l = directional({-toward[0], -toward[1], -toward[2]});
                D3 u = box.dir_to_box(d3(l.direction));
                u = {-u[0] / norm3(u), -u[1] / norm3(u), -u[2] / norm3(u)};
                D3 p = rounded(random_in(2.0));
                check(l, p, box_chord(box.half, p, u, INFINITY));
            }
            // Directional lights along the box axes (only for the axis-aligned box, where the
            // world axes are the box axes): the chord is the distance to one face, p[a] ∓ half[a].
            if (setup.rotate == Vec3{0, 0, 0})
                for (int i = 0; i < 150; ++i) {
                    int axis = i % 3;
                    double sign = (i / 3) % 2 ? 1 : -1;
                    D3 toward{0, 0, 0};
                    toward[axis] = sign;
                    D3 p = rounded(random_in(0.999));
                    double chord = sign > 0 ? box.half[axis] - p[axis] : p[axis] + box.half[axis];
                    check(directional({-toward[0], -toward[1], -toward[2]}), p, chord);
                }
            // Point light inside the box, p inside: the whole segment is inside, chord = |light − p|.
            for (int i = 0; i < 300; ++i) {
                D3 light_box = rounded(random_in(0.999)), p = rounded(random_in(0.999));
                Light l = point_light(box.from_box(light_box));
                D3 light_b = box.to_box(d3(l.position));
                check(l, p, norm3(minus(light_b, p)));
            }
            // Point light outside the box, p inside: distance to the exit face towards the light.
            for (int i = 0; i < 150; ++i) {
                D3 p = rounded(random_in(0.999));
                D3 light_box = random_unit(rng);
                for (int a = 0; a < 3; ++a) light_box[a] *= 3.0;
                Light l = point_light(box.from_box(light_box));
                D3 light_b = box.to_box(d3(l.position));
                D3 d = minus(light_b, p);
                double dist = norm3(d);
                check(l, p, box_chord(box.half, p, {d[0] / dist, d[1] / dist, d[2] / dist}, dist));
            }
            SUCCEED(setup.name << ": " << rays << " rays, max relative error of T " << worst);
            CHECK(rays >= 1000);
        }
    }
}

TEST_CASE("reference transmittance: homogeneous sphere, error bounded by the trilinear blur", "[shadow_reference]") {
    const int n = 96;
    const double h = 1.0 / n;   // world voxel size
    const double radius = 0.4;  // make_sphere: |centre − 0.5| ≤ 0.4 in [0, 1]³ → ball of radius 0.4 at the origin
    Scene scene;
    VolumeInstance vi;
    vi.volume = std::make_shared<const Volume>(make_sphere(n, float(radius), 1.f));
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {float(h), float(h), float(h)});
    const float alpha = 0.02f;  // per voxel (opacity_unit 0)
    vi.transfer_function.color_points = {{0.f, 1.f, 1.f, 1.f}};
    vi.transfer_function.opacity_points = {{0.49f, 0.f}, {0.51f, alpha}};  // σ: 0 outside, constant inside
    scene.volumes.push_back(vi);
    const double sigma = sigma_of(alpha, h);

    // Bound. The trilinear value at x mixes the 8 voxels of its cell, all within √3·h of x: so
    // σ_ref(x) = σ·[|x| < r] exactly outside the shell r − √3h ≤ |x| ≤ r + √3h, and differs by at most
    // σ inside it. With |p| ≤ r/2 the ray leaves the ball once; along it dt/d|x| = |x|/√(|x|² − b²)
    // (b = distance of the ray's line from the centre ≤ r/2) ≤ r₁/√(r₁² − (r/2)²), r₁ = r − √3h.
    // So |τ_ref − σ·chord| ≤ σ·2√3h·r₁/√(r₁² − r²/4) (+ midpoint-rule error ≤ 2 steps of σ at the
    // discontinuities, step 0.05h).
    const double r1 = radius - std::sqrt(3.0) * h;
    const double shell_path = 2 * std::sqrt(3.0) * h * r1 / std::sqrt(r1 * r1 - radius * radius / 4);
    const double bound = sigma * (shell_path + 2 * 0.05 * h);

    std::mt19937 rng(77);
    std::uniform_real_distribution<double> uni(-1, 1);
    double worst = 0, sum = 0;
    const int count = 200;
    for (int i = 0; i < count; ++i) {
        D3 p;
        do p = {uni(rng) * radius / 2, uni(rng) * radius / 2, uni(rng) * radius / 2};
        while (norm3(p) > radius / 2);
        p = d3(f3(p));
        D3 u = random_unit(rng);
        Light l = point_light({1.5 * u[0], 1.5 * u[1], 1.5 * u[2]});  // outside the box (half-diagonal 0.87)
        scene.lights = {l};
        D3 d = minus(d3(l.position), p);
        double dist = norm3(d);
        D3 dir{d[0] / dist, d[1] / dist, d[2] / dist};
        double pu = dot3(p, dir);
        double chord = -pu + std::sqrt(pu * pu - dot3(p, p) + radius * radius);  // exit of |p + t·dir| = r
        double tau = -std::log(reference_transmittance(scene, 0, f3(p)));
        double err = std::fabs(tau - sigma * chord);
        worst = std::max(worst, err);
        sum += err;
        INFO("chord " << chord << " tau " << tau << " sigma*chord " << sigma * chord);
        REQUIRE(err <= bound);
    }
    const double mean = sum / count;
    SUCCEED("sphere: sigma*voxel " << sigma * h << ", bound " << bound << " (" << bound / (sigma * h)
                                << " voxels), max |dtau| " << worst << " (" << worst / (sigma * h) << " voxels), mean "
                                << mean / (sigma * h) << " voxels");
    // The proven bound is loose (it allows the whole shell on both sides); in practice the 0.5
    // iso-surface of the trilinear blur stays within half a voxel of the sphere: check one voxel.
    CHECK(worst <= sigma * h);
}

TEST_CASE("reference transmittance: overlapping volumes add their optical depths", "[shadow_reference]") {
    const Scene both = test::overlapping_scene();
    Scene only_a = both, only_b = both;
    only_a.volumes = {both.volumes[0]};
    only_b.volumes = {both.volumes[1]};
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> uni(-0.35, 0.35);
    int shadowed_by_both = 0;
    double worst = 0;
    for (int light = 0; light < int(both.lights.size()); ++light)
        for (int i = 0; i < 100; ++i) {
            Vec3 p{float(uni(rng)), float(uni(rng)), float(uni(rng))};
            double t = reference_transmittance(both, light, p);
            double ta = reference_transmittance(only_a, light, p), tb = reference_transmittance(only_b, light, p);
            if (ta < 0.99 && tb < 0.99) ++shadowed_by_both;
            double rel = std::fabs(t - ta * tb) / std::max(ta * tb, 1e-300);
            worst = std::max(worst, rel);
            REQUIRE(rel < 1e-12);
        }
    SUCCEED("overlap: max relative |T - Ta*Tb| " << worst << ", " << shadowed_by_both << " rays shadowed by both");
    CHECK(shadowed_by_both >= 20);  // the check is not vacuous

    // Two constant boxes overlapping: τ = σ₁·chord₁ + σ₂·chord₂ exactly.
    Scene two;
    VolumeInstance a, b;
    a.volume = constant_volume({4, 4, 4}, 1.f);
    a.transfer_function = constant_tf(0.2f);
    a.transform = make_transform({-0.25f, 0, 0}, {0, 0, 0}, {0.25f, 0.25f, 0.25f});  // [−0.75, 0.25]×[−0.5, 0.5]²
    b.volume = constant_volume({4, 4, 4}, 1.f);
    b.transfer_function = constant_tf(0.5f);
    b.transform = make_transform({0.25f, 0, 0}, {0, 0, 0}, {0.25f, 0.25f, 0.25f});  // [−0.25, 0.75]×[−0.5, 0.5]²
    two.volumes = {a, b};
    two.lights = {directional({-1, 0, 0})};  // towards +x
    const double sa = sigma_of(0.2f, 0.25), sb = sigma_of(0.5f, 0.25);
    for (float x : {-0.7f, -0.3f, 0.f, 0.2f, 0.5f}) {
        double chord_a = std::max(0.0, 0.25 - double(x)), chord_b = 0.75 - std::max(double(x), -0.25);
        double expected = std::exp(-sa * chord_a - sb * chord_b);
        CHECK(reference_transmittance(two, 0, {x, 0.1f, -0.2f}) == Approx(expected).epsilon(1e-9));
    }
}

TEST_CASE("reference transmittance: edge cases stay in [0, 1]", "[shadow_reference]") {
    auto valid = [](double t) { return std::isfinite(t) && t >= 0.0 && t <= 1.0; };
    Scene scene = test::sphere_scene(24);  // box [−0.5, 0.5]³

    SECTION("light inside a volume") {
        scene.lights = {point_light({0, 0, 0}), point_light({0.1, -0.2, 0.05})};
        for (int light = 0; light < 2; ++light)
            for (Vec3 p : {Vec3{0.3f, 0.1f, 0.f}, Vec3{0.9f, 0.9f, 0.9f}, Vec3{0.f, 0.f, 0.f}, Vec3{-0.45f, 0.4f, 0.2f}}) {
                double t = reference_transmittance(scene, light, p);
                CHECK(valid(t));
            }
        CHECK(reference_transmittance(scene, 0, {0.3f, 0.f, 0.f}) < 1.0);  // the sphere is dense at the centre
        CHECK(reference_transmittance(scene, 0, {0.f, 0.f, 0.f}) == 1.0);   // p at the light: empty segment
    }
    SECTION("light exactly on a box face, edge and corner") {
        for (Vec3 lp : {Vec3{0.5f, 0.1f, 0.2f}, Vec3{-0.5f, 0.f, 0.f}, Vec3{0.5f, 0.5f, 0.f}, Vec3{0.5f, 0.5f, 0.5f}}) {
            scene.lights = {point_light(d3(lp))};
            for (Vec3 p : {Vec3{0.f, 0.f, 0.f}, Vec3{0.5f, 0.2f, 0.1f}, Vec3{2.f, 0.f, 0.f}, lp})
                CHECK(valid(reference_transmittance(scene, 0, p)));
        }
        scene.lights = {point_light({0.5, 0, 0})};
        CHECK(reference_transmittance(scene, 0, {-0.5f, 0.f, 0.f}) < 1e-3);  // through the whole sphere
    }
    SECTION("directional light along an axis, p on faces and edges") {
        for (D3 d : {D3{0, 0, -1}, D3{1, 0, 0}, D3{0, -1, 0}, D3{0, 0, 1}}) {
            scene.lights = {directional(d)};
            for (Vec3 p : {Vec3{0.f, 0.f, 0.f}, Vec3{0.5f, 0.5f, 0.f}, Vec3{-0.5f, 0.f, 0.5f}, Vec3{0.5f, 0.5f, 0.5f},
                           Vec3{0.f, 0.f, -3.f}, Vec3{0.6f, 0.f, 0.f}}) {
                double t = reference_transmittance(scene, 0, p);
                CHECK(valid(t));
            }
        }
        scene.lights = {directional({0, 0, -1})};
        CHECK(reference_transmittance(scene, 0, {0.f, 0.f, -0.45f}) < 1e-3);
        CHECK(reference_transmittance(scene, 0, {0.6f, 0.f, -0.45f}) == 1.0);  // beside the box
    }
    SECTION("1x1x1 volume") {
        Scene one;
        VolumeInstance vi;
        vi.volume = constant_volume({1, 1, 1}, 0.8f);
        vi.transfer_function = test::ramp_tf(0.2f, 0.6f, 0.4f);  // α = 0.4 at 0.8
        vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.5f, 0.5f, 0.5f});  // box [−0.25, 0.25]³
        one.volumes = {vi};
        one.lights = {directional({0, 0, -1}), point_light({0.1, 0.1, 0.1}), directional({-1, -2, -3})};
        for (int light = 0; light < 3; ++light)
            for (Vec3 p : {Vec3{0.f, 0.f, 0.f}, Vec3{0.25f, 0.25f, 0.25f}, Vec3{0.f, 0.f, -1.f}, Vec3{0.1f, 0.1f, 0.1f}})
                CHECK(valid(reference_transmittance(one, light, p)));
        const double sigma = sigma_of(0.4f, 0.5);
        CHECK(reference_transmittance(one, 0, {0.f, 0.f, -1.f}) == Approx(std::exp(-sigma * 0.5)).epsilon(1e-9));
    }
    SECTION("opacity 1 everywhere (stiff)") {
        Scene stiff;
        VolumeInstance vi;
        vi.volume = constant_volume({8, 8, 8}, 0.5f);
        vi.transfer_function = constant_tf(1.f);
        vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.125f, 0.125f, 0.125f});  // box [−0.5, 0.5]³
        stiff.volumes = {vi};
        stiff.lights = {directional({0.3, -0.2, -1}), point_light({0.2, 0.1, 0}), point_light({0, 0, 3})};
        for (int light = 0; light < 3; ++light)
            for (Vec3 p : {Vec3{0.f, 0.f, 0.f}, Vec3{0.5f, 0.5f, 0.5f}, Vec3{0.f, 0.f, -2.f}, Vec3{0.2f, 0.1f, 0.f}}) {
                for (double step : {0.05, 1.0, 7.0}) {
                    double t = reference_transmittance(stiff, light, p, step);
                    CHECK(valid(t));
                }
            }
        // σ is capped at −ln(10⁻⁶) per opacity unit (one voxel, 0.125): across the box T = 10⁻⁴⁸.
        const double sigma_max = -std::log(1e-6) / 0.125;
        stiff.lights = {directional({0, 0, -1})};
        CHECK(reference_transmittance(stiff, 0, {0.f, 0.f, -0.5f}) == Approx(std::exp(-sigma_max * 1.0)).epsilon(1e-9));
        CHECK(reference_transmittance(stiff, 0, {0.f, 0.f, 0.4f}) == Approx(std::exp(-sigma_max * 0.1)).epsilon(1e-6));
    }
    SECTION("bad arguments") {
        REQUIRE_THROWS_WITH(reference_transmittance(scene, 1, {0, 0, 0}), Catch::Contains("light index"));
        REQUIRE_THROWS_WITH(reference_transmittance(scene, -1, {0, 0, 0}), Catch::Contains("light index"));
        REQUIRE_THROWS_AS(reference_transmittance(scene, 0, {0, 0, 0}, 0.0), Error);
        Scene empty;
        REQUIRE_THROWS_WITH(reference_transmittance(empty, 0, {0, 0, 0}), Catch::Contains("light index"));
    }
}

namespace {

DeepShadowMap random_map(std::mt19937& rng, int width, int height) {
    DeepShadowMap map;
    map.width = width, map.height = height;
    map.light_name = "lights[1].+x";
    std::uniform_int_distribution<int> count(1, 20);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    map.first.push_back(0);
    for (int texel = 0; texel < width * height; ++texel) {
        int n = uni(rng) < 0.3f ? 0 : count(rng);
        float depth = 0.5f + 3.f * uni(rng), opacity = 0.f;
        for (int k = 0; k < n; ++k) {
            depth += 0.2f * uni(rng);
            opacity = std::min(1.f, opacity + 0.1f * uni(rng));
            map.nodes.push_back({depth, opacity});
        }
        map.first.push_back(std::uint32_t(map.nodes.size()));
    }
    return map;
}

bool exists(const std::string& path) { return std::filesystem::exists(path); }

}  // namespace

TEST_CASE("deep EXR: round trip, scanline deep file", "[shadow_reference]") {
    std::mt19937 rng(11);
    DeepShadowMap map = random_map(rng, 13, 7);
    for (std::size_t i = 0; i < 16; ++i) map.world_to_camera[i] = float(i) + 0.5f, map.world_to_ndc[i] = -float(i);
    const std::string path = test::temp_dir() + "/dsm_roundtrip.exr";
    write_deep_exr(map, path);
    REQUIRE(exists(path));
    CHECK_FALSE(exists(path + ".part.exr"));

    const DeepShadowMap back = read_deep_exr(path);
    CHECK(back.width == map.width);
    CHECK(back.height == map.height);
    CHECK(back.light_name == map.light_name);
    CHECK(back.first == map.first);
    REQUIRE(back.nodes.size() == map.nodes.size());
    // depths exact; opacities through float per-sample alphas (measured max error 6e-8)
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < map.nodes.size(); ++i)
        if (back.nodes[i].depth != map.nodes[i].depth || std::fabs(back.nodes[i].opacity - map.nodes[i].opacity) > 1e-6f) ++mismatches;
    CHECK(mismatches == 0);
    CHECK(back.world_to_camera == map.world_to_camera);
    CHECK(back.world_to_ndc == map.world_to_ndc);
    std::size_t empty = 0;
    for (int t = 0; t < map.width * map.height; ++t) empty += map.first[t] == map.first[t + 1];
    CHECK(empty > 0);  // the map does have fully lit texels

    // OpenImageIO's view of the file: deep, scanline, A/Z/ZBack, ZBack = Z.
    auto in = OIIO::ImageInput::open(path);
    REQUIRE(in);
    const OIIO::ImageSpec& spec = in->spec();
    CHECK(std::string(in->format_name()) == "openexr");
    CHECK(spec.deep);
    CHECK(spec.tile_width == 0);
    REQUIRE(spec.nchannels == 3);
    CHECK(spec.channelnames[0] == "A");
    CHECK(spec.channelnames[1] == "Z");
    CHECK(spec.channelnames[2] == "ZBack");
    CHECK(spec.get_string_attribute("sombra:light") == "lights[1].+x");
    CHECK(spec.get_int_attribute("sombra:format") == 2);
    // OpenEXR's worldToCamera holds Imath's row-vector matrix: the transpose of the map's
    const OIIO::ParamValue* camera = spec.find_attribute("worldToCamera", OIIO::TypeMatrix);
    REQUIRE(camera);
    CHECK(static_cast<const float*>(camera->data())[1] == map.world_to_camera[4]);
    CHECK(spec.find_attribute("worldToNDC", OIIO::TypeMatrix));
    OIIO::DeepData dd;
    REQUIRE(in->read_native_deep_image(0, 0, dd));
    bool zback_is_z = true;
    for (int64_t p = 0; p < dd.pixels(); ++p)
        for (int s = 0; s < dd.samples(p); ++s) zback_is_z &= dd.deep_value(p, 1, s) == dd.deep_value(p, 2, s);
    CHECK(zback_is_z);
    in->close();

    // An all-empty map (fully lit) round-trips too.
    DeepShadowMap lit;
    lit.width = 3, lit.height = 2;
    lit.first.assign(7, 0);
    write_deep_exr(lit, path);
    const DeepShadowMap lit_back = read_deep_exr(path);
    CHECK(lit_back.first == lit.first);
    CHECK(lit_back.nodes.empty());
    CHECK(lit_back.light_name.empty());
}

TEST_CASE("deep EXR: invalid maps throw and leave no file", "[shadow_reference]") {
    std::mt19937 rng(12);
    const DeepShadowMap good = random_map(rng, 6, 5);
    const std::string path = test::temp_dir() + "/dsm_invalid.exr";
    auto rejects = [&](const DeepShadowMap& map, const std::string& field) {
        std::filesystem::remove(path);
        REQUIRE_THROWS_WITH(write_deep_exr(map, path), Catch::Contains(path + ": " + field));
        CHECK_FALSE(exists(path));
        CHECK_FALSE(exists(path + ".part.exr"));
    };
    // a texel with at least two nodes
    std::size_t texel = 0;
    while (good.first[texel + 1] - good.first[texel] < 2) ++texel;

    DeepShadowMap unsorted = good;
    std::swap(unsorted.nodes[good.first[texel]].depth, unsorted.nodes[good.first[texel] + 1].depth);
    rejects(unsorted, "nodes[");
    DeepShadowMap decreasing = good;
    decreasing.first[texel + 1] = decreasing.first[texel + 2] + 1;
    rejects(decreasing, "first[");
    DeepShadowMap short_last = good;
    short_last.nodes.pop_back();
    rejects(short_last, "first");
    DeepShadowMap wrong_size = good;
    wrong_size.first.pop_back();
    rejects(wrong_size, "first");
    DeepShadowMap nan_depth = good;
    nan_depth.nodes[0].depth = std::numeric_limits<float>::quiet_NaN();
    rejects(nan_depth, "nodes[0].depth");
    DeepShadowMap no_width = good;
    no_width.width = 0;
    rejects(no_width, "width");
    DeepShadowMap no_height = good;
    no_height.height = -1;
    rejects(no_height, "height");
}

TEST_CASE("deep EXR: reading a file that is not a deep EXR throws", "[shadow_reference]") {
    const std::string dir = test::temp_dir();
    Image image;
    image.width = 4, image.height = 3;
    image.rgba.assign(4 * 3 * 4, 0.5f);
    write_image(image, dir + "/flat.png");
    write_image(image, dir + "/flat.exr");
    REQUIRE_THROWS_WITH(read_deep_exr(dir + "/flat.png"), Catch::Contains("not a deep OpenEXR file"));
    REQUIRE_THROWS_WITH(read_deep_exr(dir + "/flat.exr"), Catch::Contains("not a deep OpenEXR file"));
    REQUIRE_THROWS_AS(read_deep_exr(dir + "/does-not-exist.exr"), Error);
    {
        std::FILE* f = std::fopen((dir + "/garbage.exr").c_str(), "wb");
        REQUIRE(f);
        std::fputs("this is not an image", f);
        std::fclose(f);
    }
    REQUIRE_THROWS_AS(read_deep_exr(dir + "/garbage.exr"), Error);
}

namespace {

// A deep EXR written with OpenImageIO: `samples[texel]` holds (A, Z, ZBack) triples; with `light`,
// the file carries sombra's light attribute (as sombra's files before format 2 did).
using Sample = std::array<float, 3>;
void write_deep_file(const std::string& path, int width, int height, const std::vector<std::vector<Sample>>& samples,
                     const char* light) {
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"A", "Z", "ZBack"};
    spec.alpha_channel = 0, spec.z_channel = 1, spec.deep = true;
    spec.attribute("compression", "zips");
    if (light) spec.attribute("sombra:light", light);
    OIIO::DeepData deep;
    deep.init(spec);
    for (std::size_t t = 0; t < samples.size(); ++t) deep.set_samples(int64_t(t), int(samples[t].size()));
    for (std::size_t t = 0; t < samples.size(); ++t)
        for (std::size_t s = 0; s < samples[t].size(); ++s)
            for (int c = 0; c < 3; ++c) deep.set_deep_value(int64_t(t), c, int(s), samples[t][s][std::size_t(c)]);
    auto out = OIIO::ImageOutput::create("openexr");
    REQUIRE((out->open(path, spec) && out->write_deep_image(deep) && out->close()));
}

}  // namespace

TEST_CASE("deep EXR: sombra's old files (A = accumulated opacity, no sombra:format) still read", "[shadow_reference]") {
    std::mt19937 rng(13);
    const DeepShadowMap map = random_map(rng, 5, 4);
    std::vector<std::vector<Sample>> samples(std::size_t(map.width * map.height));
    for (std::size_t t = 0; t < samples.size(); ++t)
        for (std::uint32_t n = map.first[t]; n < map.first[t + 1]; ++n)
            samples[t].push_back({map.nodes[n].opacity, map.nodes[n].depth, map.nodes[n].depth});
    const std::string path = test::temp_dir() + "/dsm_old_format.exr";
    write_deep_file(path, map.width, map.height, samples, "lights[1].+x");
    const DeepShadowMap back = read_deep_exr(path);
    CHECK(back.first == map.first);
    REQUIRE(back.nodes.size() == map.nodes.size());
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < map.nodes.size(); ++i)
        mismatches += back.nodes[i].depth != map.nodes[i].depth || back.nodes[i].opacity != map.nodes[i].opacity;
    CHECK(mismatches == 0);  // bit for bit: A was stored as it is
    CHECK(back.world_to_camera == DeepShadowMap().world_to_camera);  // old files do not place the map
}

TEST_CASE("deep EXR: files of other tools (per-sample alpha, any order, volumetric samples)", "[shadow_reference]") {
    const std::string path = test::temp_dir() + "/dsm_foreign.exr";
    // texel 0: two point samples out of order; texel 1: a volumetric sample [2, 3] then a point at 4
    write_deep_file(path, 2, 1, {{{0.5f, 3.f, 3.f}, {0.2f, 1.f, 1.f}}, {{0.5f, 2.f, 3.f}, {1.f, 4.f, 4.f}}}, nullptr);
    const DeepShadowMap map = read_deep_exr(path);
    REQUIRE(map.first == std::vector<std::uint32_t>{0, 2, 5});
    const std::vector<std::array<float, 2>> expected = {{1.f, 0.2f}, {3.f, 0.6f}, {2.f, 0.f}, {3.f, 0.5f}, {4.f, 1.f}};
    for (std::size_t i = 0; i < expected.size(); ++i) {
        INFO("node " << i);
        CHECK(map.nodes[i].depth == expected[i][0]);
        CHECK(map.nodes[i].opacity == Approx(expected[i][1]).margin(1e-6));
    }
    CHECK(map.light_name.empty());

    write_deep_file(path, 1, 1, {{{1.5f, 1.f, 1.f}}}, nullptr);
    CHECK(test::error_of([&] { read_deep_exr(path); }) ==
          path + ": texel (0, 0) sample 0 A: must lie in [0, 1], got 1.500000");
    write_deep_file(path, 1, 1, {{{0.5f, 1.f, 3.f}, {0.5f, 2.f, 2.f}}}, nullptr);
    CHECK_THAT(test::error_of([&] { read_deep_exr(path); }),
               Catch::StartsWith(path + ": texel (0, 0) sample 1 Z: overlaps the sample before it"));
}

TEST_CASE("deep EXR: OpenImageIO's flatten of every texel gives the map's opacity, A in [0, 1]", "[shadow_reference]") {
    std::mt19937 rng(14);
    DeepShadowMap map = random_map(rng, 16, 9);
    // stiff cases: opacity above 1 (compression overshoot), an opaque node followed by more nodes
    std::size_t texel = 0;
    while (map.first[texel + 1] == map.first[texel]) ++texel;
    map.nodes[map.first[texel + 1] - 1].opacity = 1.02f;  // the texel's last node: opacity stays non-decreasing
    texel = 0;
    while (map.first[texel + 1] - map.first[texel] < 3) ++texel;
    map.nodes[map.first[texel]].opacity = 1.f;
    for (std::uint32_t n = map.first[texel] + 1; n < map.first[texel + 1]; ++n) map.nodes[n].opacity = 1.f;
    const std::string path = test::temp_dir() + "/dsm_flatten.exr";
    write_deep_exr(map, path);

    OIIO::ImageBuf deep(path);
    REQUIRE(deep.read());
    const OIIO::DeepData& dd = *deep.deepdata();
    double worst_node = 0;
    for (std::size_t t = 0; t < std::size_t(map.width * map.height); ++t) {
        double transmittance = 1;  // OpenEXR's front-to-back "over" of the samples up to each node
        for (std::uint32_t n = map.first[t]; n < map.first[t + 1]; ++n) {
            const float a = dd.deep_value(int64_t(t), 0, int(n - map.first[t]));
            REQUIRE((a >= 0.f && a <= 1.f));
            transmittance *= 1 - a;
            worst_node = std::max(worst_node, std::fabs(1 - transmittance - std::clamp(map.nodes[n].opacity, 0.f, 1.f)));
        }
    }
    CHECK(worst_node < 1e-6);

    OIIO::ImageBuf flat = OIIO::ImageBufAlgo::flatten(deep);
    REQUIRE(!flat.has_error());
    const int a_channel = flat.spec().channelindex("A");
    REQUIRE(a_channel >= 0);
    double worst_far = 0;
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x) {
            const std::size_t t = std::size_t(y * map.width + x);
            const double far = map.first[t] == map.first[t + 1] ? 0.0 : std::clamp(map.nodes[map.first[t + 1] - 1].opacity, 0.f, 1.f);
            worst_far = std::max(worst_far, std::fabs(flat.getchannel(x, y, 0, a_channel) - far));
        }
    INFO("max |flatten A − opacity at the far end| " << worst_far);
    CHECK(worst_far < 1e-6);
    const DeepShadowMap back = read_deep_exr(path);
    CHECK(back.nodes[map.first[texel + 1] - 1].opacity == 1.f);  // opaque stays opaque, no NaN
}
