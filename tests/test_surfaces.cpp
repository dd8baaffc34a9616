// Translucent surfaces in the camera pass (issue 4): fragments composited in depth order with the
// volume samples, α = the material's opacity.
#include <catch2/catch.hpp>

#include <cmath>

#include "test_support.h"

using namespace sombra;

namespace {

MeshInstance quad(float half, float z0, float opacity, Vec3 color) { return test::quad(half, z0, opacity, color); }

// Meshes alone before a uniform background, no lights: ambient k_a i_a c only.
Scene quad_scene() {
    Scene s;
    s.camera.position = {0, 0, 3};
    s.background = {0.2f, 0.4f, 0.6f};
    s.width = 37, s.height = 29;
    return s;
}

std::array<float, 3> pixel(const Image& im, int x, int y) {
    const float* p = &im.rgba[(std::size_t(y) * im.width + x) * 4];
    return {p[0], p[1], p[2]};
}

}  // namespace

TEST_CASE("surfaces: a translucent quad of opacity a attenuates the background by exactly a", "[surfaces][render]") {
    for (float a : {0.f, 0.25f, 0.6f, 1.f}) {
        Scene s = quad_scene();
        Vec3 c{1.f, 0.5f, 0.25f};
        s.meshes.push_back(quad(0.5f, 0.f, a, c));
        float ka = s.meshes[0].material.phong.ambient;
        for (int lanes : {1, 8}) {
            RenderOptions o;
            o.lanes = lanes;
            Image im = render(test::context(), s, o).image;
            INFO("opacity " << a << ", lanes " << lanes);
            auto centre = pixel(im, s.width / 2, s.height / 2), corner = pixel(im, 0, 0);
            for (int k = 0; k < 3; ++k) {
                CHECK(centre[k] == Approx(a * ka * c[k] + (1 - a) * s.background[k]).margin(1e-6));
                CHECK(corner[k] == Approx(s.background[k]).margin(1e-6));
            }
            CHECK(im.rgba[(std::size_t(s.height / 2) * im.width + s.width / 2) * 4 + 3] == Approx(a).margin(1e-6));
        }
    }
}

TEST_CASE("surfaces: two quads composite front to back, whatever the mesh order", "[surfaces][render]") {
    Scene s = quad_scene();
    Vec3 c1{1.f, 0.f, 0.f}, c2{0.f, 1.f, 0.f};
    s.meshes.push_back(quad(0.5f, 0.f, 0.5f, c2));   // behind
    s.meshes.push_back(quad(0.3f, 0.5f, 0.4f, c1));  // in front, smaller
    s.meshes[1].material.phong.ambient = 0.8f;
    Image im = render(test::context(), s, {}).image;
    auto centre = pixel(im, s.width / 2, s.height / 2);
    float k1 = 0.8f, k2 = s.meshes[0].material.phong.ambient;
    for (int k = 0; k < 3; ++k)
        CHECK(centre[k] == Approx(0.4f * k1 * c1[k] + 0.6f * (0.5f * k2 * c2[k] + 0.5f * s.background[k])).margin(1e-6));
}

TEST_CASE("surfaces: a quad in front of a volume attenuates it by its opacity — an opaque one hides it", "[surfaces][render]") {
    Scene s = test::sphere_scene();
    s.lights.clear();
    RenderOptions o;
    o.termination_transmittance = 0.f;  // exact: no ray stops early
    Image volume_only = render(test::context(), s, o).image;
    Vec3 c{0.2f, 0.9f, 0.4f};
    for (float a : {0.3f, 1.f}) {
        Scene with = s;
        with.meshes.push_back(quad(3.f, 1.f, a, c));  // covers the whole image, between camera and sphere
        float ka = with.meshes[0].material.phong.ambient;
        Image im = render(test::context(), with, o).image;
        double max_err = 0;
        for (std::size_t i = 0; i < im.rgba.size(); i += 4)
            for (int k = 0; k < 3; ++k)
                max_err = std::max(max_err, std::abs(double(im.rgba[i + k]) - (a * ka * c[k] + (1 - a) * volume_only.rgba[i + k])));
        INFO("opacity " << a);
        CHECK(max_err < 1e-5);
    }
}

TEST_CASE("surfaces: an opaque quad through a volume's centre hides what lies behind it", "[surfaces][render]") {
    Scene s = test::sphere_scene();
    s.lights.clear();
    s.camera.position = {0.f, 0.f, 2.2f};
    Scene front = s, back = s;
    front.meshes.push_back(quad(3.f, 0.f, 1.f, {0.f, 0.f, 0.f}));  // black: shows only what lies before it
    back.meshes.push_back(quad(3.f, -0.6f, 1.f, {0.f, 0.f, 0.f}));  // behind the sphere
    RenderOptions o;
    o.termination_transmittance = 0.f;  // exact: no ray stops early
    Image im_front = render(test::context(), front, o).image, im_back = render(test::context(), back, o).image;
    Image volume_only = render(test::context(), s, o).image;
    auto mid = [&](const Image& im) { return pixel(im, s.width / 2, s.height / 2); };
    // behind the sphere: the volume's own colour (background hidden); at its centre: less of it
    std::size_t centre = (std::size_t(s.height / 2) * s.width + s.width / 2) * 4;
    float t_volume = 1.f - volume_only.rgba[centre + 3];
    REQUIRE(t_volume < 0.9f);  // the sphere is visible there
    for (int k = 0; k < 3; ++k) {
        CHECK(mid(im_back)[k] == Approx(mid(volume_only)[k] - t_volume * s.background[k]).margin(1e-5));
        CHECK(mid(im_front)[k] < mid(im_back)[k]);
        CHECK(mid(im_front)[k] > 0.f);
    }
}

namespace {

// A spot light at z = 2 straight down over an opaque floor at z = −1: the quad of half side 0.3 at
// z = 0 projects its edge x = ±0.3 to ±0.375 on the plane z = −0.5.
Scene spot_over_floor_scene() {
    Scene s = quad_scene();
    Light spot;
    spot.type = LightType::Spot;
    spot.position = {0.f, 0.f, 2.f};
    spot.direction = {0.f, 0.f, -1.f};
    spot.cone_angle_deg = 40.f;
    s.lights.push_back(spot);
    s.meshes.push_back(quad(1.5f, -1.f, 1.f, {0.5f, 0.5f, 0.5f}));  // the opaque floor
    return s;
}
constexpr float kProjectedEdge = 0.375f;

// Inside the projection (2 points), outside it (2), above the quad, below it on the floor.
const std::vector<Vec3> kQuadShadowPoints{{0.f, 0.f, -0.5f},  {0.2f, -0.25f, -0.5f}, {0.6f, 0.f, -0.5f},
                                          {0.f, -0.55f, -0.5f}, {0.f, 0.f, 0.5f},     {0.f, 0.f, -0.9f}};
const float kQuadShadowExpected[] = {0, 0, 1, 1, 1, 0};  // 0: 1 − a, 1: lit

RenderOptions dsm_options_128() {
    RenderOptions o;
    o.shadows = ShadowTechnique::Dsm;
    o.dsm.resolution = 128;
    return o;
}

}  // namespace

TEST_CASE("surfaces in deep shadow maps: a quad of opacity a leaves 1 − a behind it, exactly its projection", "[surfaces][dsm]") {
    Scene s = spot_over_floor_scene();
    RenderOptions o = dsm_options_128();
    for (float a : {1.f, 0.35f}) {
        Scene with = s;
        with.meshes.push_back(quad(0.3f, 0.f, a, {1.f, 1.f, 1.f}));
        auto t = shadow_transmittance(test::context(), with, 0, kQuadShadowPoints, o).transmittance;
        INFO("opacity " << a);
        for (std::size_t i = 0; i < t.size(); ++i) {
            double expected = kQuadShadowExpected[i] ? 1.0 : 1 - a;
            CHECK(t[i] == Approx(expected).margin(1e-5));
            // the reference too; points 0 and 5 see the light through the quad's diagonal, the edge
            // its two triangles share: crossed once (watertight), not twice
            CHECK(reference_transmittance(with, 0, kQuadShadowPoints[i]) == Approx(expected).margin(1e-12));
        }
        // and the shadow rays (watertight in the kernels as well: cl/ray_triangle.h), 8 and 1 lanes
        for (int lanes : {8, 1}) {
            RenderOptions rays;
            rays.shadows = ShadowTechnique::Rays;
            rays.lanes = lanes;
            auto r = shadow_transmittance(test::context(), with, 0, kQuadShadowPoints, rays).transmittance;
            for (std::size_t i = 0; i < r.size(); ++i) {
                INFO("shadow ray, point " << i << ", " << lanes << " lanes");
                CHECK(r[i] == Approx(kQuadShadowExpected[i] ? 1.0 : 1 - a).margin(1e-6));
            }
        }
        // lanes do not change the maps
        RenderOptions one = o;
        one.lanes = 1;
        auto t1 = shadow_transmittance(test::context(), with, 0, kQuadShadowPoints, one).transmittance;
        for (std::size_t i = 0; i < t.size(); ++i) CHECK(t1[i] == t[i]);
    }
}

TEST_CASE("shadow rays through the edge two triangles share cross one of them (watertight), whatever the light",
          "[surfaces][shadows]") {
    // points under the quad's diagonal (the edge its triangles share), lights straight above them
    // and oblique, so that every shadow ray meets the diagonal exactly or within rounding
    Scene s;
    s.camera.position = {0, 0, 3};
    const float a = 0.4f;
    s.meshes.push_back(quad(0.3f, 0.f, a, {1.f, 1.f, 1.f}));
    for (Vec3 direction : {Vec3{0.f, 0.f, -1.f}, Vec3{0.3f, 0.3f, -1.f}, Vec3{-0.7f, -0.7f, -1.f}, Vec3{0.1f, 0.1f, -0.37f}}) {
        // each point's ray to the light meets the plane z = 0 on the diagonal x = y, |x| ≤ 0.246
        std::vector<Vec3> points;
        const float rise = 0.5f / -direction[2];
        for (int i = -20; i <= 20; ++i)
            points.push_back({0.0123f * float(i) + direction[0] * rise, 0.0123f * float(i) + direction[1] * rise, -0.5f});
        Light light;
        light.type = LightType::Directional;
        light.direction = direction;
        s.lights = {light};
        RenderOptions rays;
        rays.shadows = ShadowTechnique::Rays;
        for (int lanes : {8, 1}) {
            rays.lanes = lanes;
            auto t = shadow_transmittance(test::context(), s, 0, points, rays).transmittance;
            for (std::size_t i = 0; i < t.size(); ++i) {
                INFO("light direction (" << direction[0] << ", " << direction[1] << ", " << direction[2] << "), point " << i
                                         << ", " << lanes << " lanes");
                CHECK(t[i] == Approx(1 - a).margin(1e-6));
                CHECK(reference_transmittance(s, 0, points[i]) == Approx(1 - a).margin(1e-12));
            }
        }
    }
}

namespace {

// Where T first rises through 1 − a/2 along x (linear between the sweep's points), or NaN.
double crossing(const std::vector<float>& xs, const std::vector<double>& t, double level) {
    for (std::size_t i = 1; i < xs.size(); ++i)
        if ((t[i - 1] - level) * (t[i] - level) <= 0 && t[i] != t[i - 1])
            return xs[i - 1] + (level - t[i - 1]) / (t[i] - t[i - 1]) * (xs[i] - xs[i - 1]);
    return std::nan("");
}

double mean_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.size(); ++i) sum += std::fabs(a[i] - b[i]);
    return sum / double(a.size());
}

}  // namespace

TEST_CASE("surfaces in pre-filtered deep shadow maps, every backend: 1 − a inside the projection, 1 outside, a "
          "monotone symmetric edge",
          "[surfaces][dsm][prefilter]") {
    Scene s = spot_over_floor_scene();
    const float texel = 2.5f * std::tan(40.f * 3.14159265f / 180.f) * 2.f / 128.f;  // on the plane z = −0.5
    // a sweep across the right edge, and its mirror image across the left one
    std::vector<float> xs;
    std::vector<Vec3> points = kQuadShadowPoints;
    for (float x = kProjectedEdge - 4 * texel; x <= kProjectedEdge + 4 * texel; x += 0.125f * texel) xs.push_back(x);
    for (float x : xs) points.push_back({x, 0.f, -0.5f});
    for (float x : xs) points.push_back({-x, 0.f, -0.5f});
    const std::size_t sweep = kQuadShadowPoints.size(), n = xs.size();
    const float a = 0.35f;
    s.meshes.push_back(quad(0.3f, 0.f, a, {1.f, 1.f, 1.f}));
    for (const std::string& storage : sombra::dsm_storage_names())
        for (const char* filter : {"none", "box", "tent", "5tap"})
            for (bool jitter : {false, true}) {
                if (std::string(filter) == "none" && jitter) continue;
                RenderOptions o = dsm_options_128();
                o.dsm.storage = storage;
                o.dsm.prefilter = filter;
                o.dsm.prefilter_jitter = jitter;
                auto t = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
                INFO("storage " << storage << ", prefilter " << filter << (jitter ? ", jittered" : ""));
                // away from the edge (≥ 5 texels): the exact step, whatever the filter
                for (std::size_t i = 0; i < sweep; ++i) CHECK(t[i] == Approx(kQuadShadowExpected[i] ? 1.0 : 1 - a).margin(1e-4));
                // across the edge: from 1 − a to 1, never outside, never falling back (within ε)
                std::vector<double> right(t.begin() + sweep, t.begin() + sweep + n), left(t.begin() + sweep + n, t.end());
                for (const auto* side : {&right, &left}) {
                    CHECK(side->front() == Approx(1 - a).margin(1e-4));
                    CHECK(side->back() == Approx(1.0).margin(1e-4));
                    for (std::size_t i = 0; i < n; ++i) {
                        INFO("x " << xs[i] << ", T " << (*side)[i]);
                        CHECK((*side)[i] >= 1 - a - 1e-4);
                        CHECK((*side)[i] <= 1 + 1e-4);
                        if (i > 0) CHECK((*side)[i] >= (*side)[i - 1] - o.dsm.epsilon);
                    }
                }
                // the edge where it lies: within a texel, and (without jitter) mirror-symmetric —
                // the surfaces of a sub-pixel map sit under its own (shifted) rays
                double x_right = crossing(xs, right, 1 - 0.5 * a), x_left = crossing(xs, left, 1 - 0.5 * a);
                INFO("edge at " << x_right << " and " << -x_left << " (true " << kProjectedEdge << ", texel " << texel << ")");
                CHECK(std::fabs(x_right - kProjectedEdge) < texel);
                CHECK(std::fabs(x_left - kProjectedEdge) < texel);
                if (!jitter) CHECK(std::fabs(x_right - x_left) < 0.05 * texel);
            }
}

TEST_CASE("surfaces inside a volume with pre-compressed tables and pre-filtering: the step multiplies the volume's "
          "transmittance by 1 − a",
          "[surfaces][dsm][precompression][prefilter]") {
    Scene s = spot_over_floor_scene();
    VolumeInstance slab;  // z in [−0.2, 0.2]: the quad at z = 0 lies inside the volume's steps
    slab.volume = std::make_shared<const Volume>(make_slab(16, 2, 0.25f, 0.75f));
    slab.transfer_function = test::ramp_tf(0.3f, 0.7f, 0.12f);
    slab.transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.15f, 0.15f, 0.05f});
    slab.step_voxels = 2.f;  // coarse: the tables matter
    s.volumes.push_back(slab);
    std::vector<Vec3> points = kQuadShadowPoints;
    for (float x : {-0.7f, -0.5f, -0.2f, 0.f, 0.2f, 0.5f, 0.7f}) points.push_back({x, 0.1f, -0.3f});  // in and out, off the edge
    const float a = 0.35f;
    Scene with = s;
    with.meshes.push_back(quad(0.3f, 0.f, a, {1.f, 1.f, 1.f}));
    std::vector<double> reference;
    for (const Vec3& p : points) reference.push_back(reference_transmittance(with, 0, p));
    for (bool tables : {false, true})
        for (const char* filter : {"none", "box", "5tap"}) {
            RenderOptions o = dsm_options_128();
            o.dsm.precompression = tables;
            o.dsm.prefilter = filter;
            auto t = shadow_transmittance(test::context(), with, 0, points, o).transmittance;
            auto volume_only = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
            INFO("prefilter " << filter << (tables ? ", tables" : ""));
            for (std::size_t i = 0; i < kQuadShadowPoints.size(); ++i) {
                INFO("point " << i << ": T " << t[i] << ", volume only " << volume_only[i]);
                if (i == 4) CHECK(t[i] == Approx(1.0).margin(1e-4));  // above both
                else CHECK(t[i] == Approx((kQuadShadowExpected[i] ? 1 : 1 - a) * volume_only[i]).margin(2 * o.dsm.epsilon));
            }
            double error = mean_abs_difference(t, reference);
            INFO("mean |T_dsm − T_ref| = " << error);
            CHECK(error < 0.02);
            WARN("quad inside a slab, prefilter " << filter << (tables ? ", tables" : "") << ": mean |ΔT| " << error);
        }
}

namespace {

// The sphere scene with the volume only, and points below it on the directional light's ray.
std::vector<Vec3> points_under_sphere() {
    const double lx = 0.3, ly = 0.5, lz = 0.8, n = std::sqrt(lx * lx + ly * ly + lz * lz);  // towards the light
    std::vector<Vec3> points;
    for (float d : {0.f, 0.2f, 0.45f, 0.7f})
        for (float off : {-0.1f, 0.f, 0.15f})
            points.push_back({float(-d * lx / n) + off, float(-d * ly / n), float(-d * lz / n) - off});
    return points;
}

}  // namespace

TEST_CASE("shadow rays and the reference cross meshes: a quad of opacity a leaves (1 − a) × the volume's transmittance",
          "[surfaces][shadows]") {
    Scene s = test::sphere_scene();
    std::vector<Vec3> points = points_under_sphere();
    points.push_back({0.f, 0.f, 1.f});  // above the quad: not shadowed by it
    RenderOptions o;
    o.shadows = ShadowTechnique::Rays;
    auto volume_only = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
    for (float a : {0.f, 0.3f, 0.75f, 1.f}) {
        Scene with = s;
        with.meshes.push_back(quad(1.5f, 0.8f, a, {1.f, 1.f, 1.f}));  // above the sphere, across every ray
        // edge-on (in a plane containing the light's direction) and degenerate triangles cross nothing
        auto extra = std::make_shared<Mesh>();
        extra->positions = {{0.f, 0.f, 0.6f}, {0.3f, 0.5f, 1.4f}, {0.f, 0.f, 1.4f}, {0.1f, 0.1f, 0.7f}, {0.2f, 0.2f, 0.7f}};
        extra->triangles = {{0, 1, 2}, {3, 4, 3}, {0, 0, 0}};
        extra->source = "edge-on";
        MeshInstance edge = with.meshes[0];
        edge.mesh = extra;
        with.meshes.push_back(edge);
        auto rays = shadow_transmittance(test::context(), with, 0, points, o).transmittance;
        INFO("opacity " << a);
        for (std::size_t i = 0; i + 1 < points.size(); ++i) {
            INFO("point " << i);
            REQUIRE(std::isfinite(rays[i]));
            CHECK(rays[i] == Approx((1 - a) * volume_only[i]).margin(1e-6));
            double ref = reference_transmittance(with, 0, points[i]), ref_volume = reference_transmittance(s, 0, points[i]);
            CHECK(ref == Approx((1 - a) * ref_volume).margin(1e-12));
            if (a == 1.f) CHECK(rays[i] == 0.f);
            if (a == 1.f) CHECK(ref == 0.0);
        }
        CHECK(rays.back() == Approx(1.0).margin(1e-6));
        CHECK(reference_transmittance(with, 0, points.back()) == Approx(1.0).margin(1e-12));
    }
}

TEST_CASE("deep shadow maps and shadow rays agree with the reference on a volume shadowing a mesh and a mesh shadowing "
          "a volume",
          "[surfaces][dsm][shadows]") {
    Scene s = test::sphere_scene(32);
    s.lights.clear();
    Light spot;
    spot.type = LightType::Spot;
    spot.position = {0.2f, 0.f, 2.5f};
    spot.direction = {-0.2f, 0.f, -2.5f};
    spot.cone_angle_deg = 35.f;
    s.lights.push_back(spot);
    s.meshes.push_back(quad(1.5f, -0.9f, 0.6f, {0.8f, 0.8f, 0.8f}));  // floor: the volume shadows it
    s.meshes.push_back(quad(0.25f, 0.75f, 0.5f, {1.f, 1.f, 1.f}));    // small sheet above: shadows the volume
    std::vector<Vec3> on_floor, in_volume;
    for (int j = 0; j < 9; ++j)
        for (int i = 0; i < 9; ++i) {
            float x = -0.8f + 0.2f * float(i), y = -0.8f + 0.2f * float(j);
            on_floor.push_back({x, y, -0.88f});
            in_volume.push_back({0.5f * x, 0.5f * y, 0.05f * float((i + j) % 5) - 0.1f});
        }
    for (const auto& [name, points] : {std::pair{"volume shadowing the floor", on_floor}, {"sheet shadowing the volume", in_volume}}) {
        std::vector<double> reference;
        for (const Vec3& p : points) reference.push_back(reference_transmittance(s, 0, p));
        double lo = 1, hi = 0;
        for (double r : reference) lo = std::min(lo, r), hi = std::max(hi, r);
        INFO(name << ": reference T in [" << lo << ", " << hi << "]");
        CHECK(hi - lo > 0.3);  // there is a shadow to get right
        RenderOptions o;
        o.dsm.resolution = 256;
        o.shadows = ShadowTechnique::Dsm;
        auto dsm = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
        o.shadows = ShadowTechnique::Rays;
        auto rays = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
        double dsm_error = mean_abs_difference(dsm, reference), ray_error = mean_abs_difference(rays, reference);
        INFO("mean |T_dsm − T_ref| = " << dsm_error << ", mean |T_rays − T_ref| = " << ray_error);
        CHECK(dsm_error < 0.02);
        CHECK(ray_error < 0.01);
        WARN(name << ": mean |ΔT| DSM " << dsm_error << ", rays " << ray_error);
    }
}

TEST_CASE("shipped mesh scenes (Knecht Fig. 5.2–5.4, 5.12) load and render with deep shadow maps, no NaN", "[surfaces][scenes]") {
    for (const char* name : {"teapot_fog", "two_smokes_wall", "steaming_cups", "cup_array"}) {
        INFO(name);
        Scene s = load_scene(test::data_path(std::string("scenes/") + name + ".json"));
        REQUIRE(!s.meshes.empty());
        RenderOptions o;
        o.width = o.height = 24;
        o.shadows = ShadowTechnique::Dsm;
        o.dsm.resolution = 64;
        Image im = render(test::context(), s, o).image;
        std::size_t bad = 0;
        for (float v : im.rgba) bad += !std::isfinite(v);
        CHECK(bad == 0);
    }
}

TEST_CASE("surfaces: per-fragment shadows darken the side of a floor that faces the camera and the light", "[surfaces][shadows]") {
    // The camera pass looks a light's shadow up only where its term can be non-zero (cl/shading.h
    // light_term_possible): here the floor's upper side faces the camera and the light from above.
    Scene s = test::sphere_scene(32);
    s.meshes.push_back(quad(1.5f, -0.9f, 1.f, {0.8f, 0.8f, 0.8f}));  // opaque floor under the sphere
    RenderOptions none = test::unshadowed();
    none.shadow_cache = ShadowCacheMode::Off;  // per-fragment lookups
    Image plain = render(test::context(), s, none).image;
    Scene volume_only = s;
    volume_only.meshes.clear();
    Image volume = render(test::context(), volume_only, none).image;  // its α: the pixels the sphere covers
    for (ShadowTechnique technique : {ShadowTechnique::Rays, ShadowTechnique::Dsm}) {
        RenderOptions o = none;
        o.shadows = technique;
        o.dsm.resolution = 128;
        Image shadowed = render(test::context(), s, o).image;
        float darkest = 0.f, brightest = 0.f;
        for (std::size_t i = 0; i < plain.rgba.size(); ++i) {
            if (i % 4 == 3) continue;
            brightest = std::max(brightest, shadowed.rgba[i] - plain.rgba[i]);
            if (volume.rgba[i / 4 * 4 + 3] < 1e-6f)  // the floor alone
                darkest = std::max(darkest, plain.rgba[i] - shadowed.rgba[i]);
        }
        INFO(shadow_technique_name(technique) << ": largest darkening of the floor " << darkest);
        CHECK(brightest < 1e-5f);  // shadows only remove light
        CHECK(darkest > 0.2f);     // the sphere's shadow on the floor
    }
}
