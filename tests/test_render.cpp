// Camera pass: kernel against the double-precision CPU reference, feature switches, public API.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "reference/raycaster_ref.h"
#include "test_support.h"
#include "shared/phase.h"
#include "shared/types.h"

using namespace sombra;

namespace {

RenderResult render_with(const Scene& scene, RenderOptions options = test::unshadowed()) {
    return render(test::context(), scene, options);
}

void require_matches_reference(const Scene& scene, RenderOptions options, reference::ReferenceOptions ref_options) {
    RenderResult kernel = render_with(scene, options);
    Image ref = reference::render_reference(scene, scene.width, scene.height, ref_options);
    auto d = test::compare(kernel.image, ref);
    INFO("max |kernel − reference| = " << d.max_abs << ", mean = " << d.mean_abs);
    REQUIRE(d.non_finite == 0);
    // measured on PoCL: max ≈ 6e-5, mean ≈ 4e-7 (float kernel vs double reference, 1024-entry TF table)
    CHECK(d.mean_abs < 1e-4);
    CHECK(d.max_abs < 2e-3);
}

}  // namespace

TEST_CASE("camera pass matches the CPU reference: one sphere, directional light", "[render]") {
    Scene s = test::sphere_scene();
    require_matches_reference(s, test::unshadowed(), {});
}

TEST_CASE("camera pass matches the CPU reference: overlapping rotated volumes, spot + point + directional", "[render]") {
    Scene s = test::overlapping_scene();
    SECTION("buffer storage, central differences") { require_matches_reference(s, test::unshadowed(), {}); }
    SECTION("Sobel gradients") {
        RenderOptions o = test::unshadowed();
        o.gradient = GradientMethod::Sobel;
        reference::ReferenceOptions r;
        r.sobel = true;
        require_matches_reference(s, o, r);
    }
    SECTION("3D image storage with the linear sampler") {
        RenderOptions o = test::unshadowed();
        o.volume_storage = VolumeStorage::Image;
        require_matches_reference(s, o, {});
    }
}

TEST_CASE("every packet width matches the reference, also where the image width is not a multiple of it", "[render][lanes]") {
    Scene s = test::overlapping_scene();
    s.width = 45, s.height = 29;
    Image ref = reference::render_reference(s, s.width, s.height);
    for (int lanes : {1, 4, 8, 16}) {
        RenderOptions o = test::unshadowed();
        o.lanes = lanes;
        RenderResult r = render_with(s, o);
        auto d = test::compare(r.image, ref);
        INFO(lanes << " lanes: max " << d.max_abs << ", mean " << d.mean_abs);
        REQUIRE(d.non_finite == 0);
        CHECK(d.mean_abs < 1e-4);
        CHECK(d.max_abs < 2e-3);
    }
}

TEST_CASE("shadow-ray baseline matches the CPU reference and darkens what lies behind", "[render][shadows]") {
    Scene s = test::overlapping_scene();
    s.width = 40, s.height = 30;
    RenderOptions o = test::unshadowed();
    o.shadows = ShadowTechnique::Rays;
    o.shadow_cache = ShadowCacheMode::Off;  // every sample marches, as the reference does
    reference::ReferenceOptions r;
    r.shadow_rays = true;
    require_matches_reference(s, o, r);
    // shadows only remove light: no pixel gets brighter than without them
    RenderResult lit = render_with(s), shadowed = render_with(s, o);
    double darker = 0;
    for (std::size_t i = 0; i < lit.image.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        REQUIRE(shadowed.image.rgba[i] <= lit.image.rgba[i] + 1e-5f);
        darker += lit.image.rgba[i] - shadowed.image.rgba[i];
    }
    CHECK(darker > 1.0);  // and some light is blocked
}

TEST_CASE("shadow ray step: a finer step moves the rays closer to the reference, and refills the shadow cache", "[render][shadows]") {
    Scene s = test::overlapping_scene();  // a noise cloud and Gaussian blobs: a coarse step misses detail
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-0.35f, 0.35f);
    std::vector<Vec3> points(400);
    for (auto& p : points) p = {u(rng), u(rng), u(rng)};
    std::vector<double> reference(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) reference[i] = reference_transmittance(s, 0, points[i]);
    RenderOptions o = test::unshadowed();
    o.shadows = ShadowTechnique::Rays;
    auto mean_error = [&](float step) {
        o.rays.step = step;
        std::vector<double> t = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
        double sum = 0;
        for (std::size_t i = 0; i < t.size(); ++i) sum += std::fabs(t[i] - reference[i]);
        return sum / double(t.size());
    };
    double coarse = mean_error(8.f), unit = mean_error(1.f), fine = mean_error(0.25f);
    INFO("mean |T - reference|: step 8 " << coarse << ", step 1 " << unit << ", step 0.25 " << fine);
    CHECK(unit < coarse);
    CHECK(fine < unit);

    // the step is part of the preparation's key: the cache is refilled and the image changes
    s.width = s.height = 24;
    o.shadow_cache = ShadowCacheMode::On;
    o.rays.step = 1.f;
    Image unit_image = render_with(s, o).image;
    o.rays.step = 8.f;
    RenderResult coarse_render = render_with(s, o);
    CHECK(coarse_render.stats.shadow_cache_entries_built > 0);
    CHECK(test::compare(coarse_render.image, unit_image).max_abs > 1e-4);
}

TEST_CASE("shadow ray step: zero, negative, NaN, steps below 0.01 and above 16 are refused", "[render][shadows]") {
    RenderOptions o = test::unshadowed();
    for (float step : {0.01f, 1.f, 16.f}) {
        o.rays.step = step;
        CHECK_NOTHROW(check_render_options(o));
    }
    for (float step : {0.f, -1.f, 1e-30f, 0.009f, 16.5f, NAN}) {  // 1e-30 would march forever
        o.rays.step = step;
        CHECK_THAT(test::error_of([&] { check_render_options(o); }), Catch::Contains("shadow_ray_step"));
    }
}

TEST_CASE("camera pass without lights shows the transfer function colours only (ambient)", "[render]") {
    Scene s = test::sphere_scene();
    s.lights.clear();
    require_matches_reference(s, test::unshadowed(), {});
}

TEST_CASE("empty-space skipping changes no pixel and takes fewer samples", "[render]") {
    Scene s = test::overlapping_scene();
    // a threshold TF leaves most bricks empty
    s.volumes[0].transfer_function = test::ramp_tf(0.55f, 0.8f, 0.6f);
    RenderOptions with, without;
    with.shadow_cache = without.shadow_cache = ShadowCacheMode::Off;  // auto's choice may differ between the two
    without.empty_space_skipping = false;
    RenderResult a = render_with(s, with), b = render_with(s, without);
    auto d = test::compare(a.image, b.image);
    INFO("max difference " << d.max_abs << ", samples " << a.stats.samples << " vs " << b.stats.samples);
    CHECK(d.max_abs < 1e-5);
    CHECK(a.stats.samples < b.stats.samples);
}

TEST_CASE("early ray termination stops opaque rays", "[render]") {
    Scene s = test::sphere_scene();
    s.volumes[0].transfer_function = test::ramp_tf(0.1f, 0.2f, 1.0f);  // opaque ball
    RenderOptions stop, go_on;
    stop.shadow_cache = go_on.shadow_cache = ShadowCacheMode::Off;  // auto's choice may differ between the two
    go_on.termination_transmittance = 0.f;
    RenderResult a = render_with(s, stop), b = render_with(s, go_on);
    CHECK(a.stats.samples < b.stats.samples);
    CHECK(test::compare(a.image, b.image).max_abs < 2e-3);  // what was cut contributes ≤ 1e-3
}

TEST_CASE("camera inside a volume and a stiff (saturating) medium give finite pixels", "[render][numerics]") {
    Scene s = test::sphere_scene();
    s.camera.position = {0.05f, 0.02f, 0.1f};  // inside the box and the ball
    s.camera.look_at = {0, 0, -1};
    s.volumes[0].opacity_unit = 1e-4f;  // σΔ ≫ 1: one step saturates
    RenderResult r = render_with(s);
    std::size_t bad = 0;
    for (float v : r.image.rgba) bad += !std::isfinite(v);
    CHECK(bad == 0);
    Image ref = reference::render_reference(s, s.width, s.height);
    CHECK(test::compare(r.image, ref).mean_abs < 2e-3);
}

TEST_CASE("axis-aligned rays and a one-voxel volume", "[render][numerics]") {
    Scene s = test::sphere_scene();
    s.volumes[0].volume = std::make_shared<const Volume>(make_slab(1, 0, 0.f, 1.f, 1.f));
    s.volumes[0].transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.5f, 0.5f, 0.5f});
    s.camera.position = {0, 0, 2};  // the centre ray runs exactly along z
    s.lights[0].direction = {0, 0, -1};
    RenderResult r = render_with(s);
    for (float v : r.image.rgba) REQUIRE(std::isfinite(v));
    Image ref = reference::render_reference(s, s.width, s.height);
    CHECK(test::compare(r.image, ref).max_abs < 0.05);
    // the centre pixel sees the voxel: it is not the background
    std::size_t c = (std::size_t(s.height / 2) * s.width + s.width / 2) * 4;
    CHECK(r.image.rgba[c + 3] > 0.1f);
}

TEST_CASE("public API renders the default CT scene", "[render][api]") {
    Scene scene = load_scene(test::data_path("scenes/default.json"));
    RenderOptions o;
    o.width = 64, o.height = 64;
    RenderResult r = render(test::context(), scene, o);
    REQUIRE(r.image.width == 64);
    double coverage = 0;
    for (std::size_t i = 0; i < 64 * 64; ++i) coverage += r.image.rgba[i * 4 + 3];
    coverage /= 64 * 64;
    CHECK(coverage > 0.05);  // the stent graft and vessels cover part of the view
    CHECK(coverage < 0.9);
    CHECK(r.stats.samples > 0);
    CHECK(r.stats.stage_ms.count("camera_pass") == 1);
    CHECK(r.stats.to_json().find("\"device\"") != std::string::npos);
    // round trip through an image file
    std::string png = test::temp_dir() + "/api.png", exr = test::temp_dir() + "/api.exr";
    write_image(r.image, png);
    write_image(r.image, exr);
    Image back = read_image(exr);  // premultiplied: composited over the background it is the render again
    for (std::size_t i = 0; i < back.rgba.size(); i += 4)
        for (std::size_t c = 0; c < 3; ++c) back.rgba[i + c] += (1.f - back.rgba[i + 3]) * r.image.background[c];
    CHECK(test::compare(back, r.image).max_abs < 1e-6);
    CHECK(read_image(png).width == 64);
}

TEST_CASE("single scattering: the Henyey-Greenstein phase integrates to one, isotropic at g = 0", "[render][scattering]") {
    for (float g : {-0.9f, -0.5f, 0.f, 0.3f, 0.8f, 0.95f}) {
        // ∫ p dω = 2π ∫_{-1}^{1} p(μ) dμ, midpoint rule in μ
        const int n = 200000;
        double integral = 0;
        for (int i = 0; i < n; ++i) {
            float mu = -1.f + 2.f * (float(i) + 0.5f) / float(n);
            integral += double(SOMBRA_HG_PHASE(g, mu)) * 2.0 / n;
        }
        integral *= 2.0 * 3.14159265358979;
        INFO("g " << g);
        CHECK(std::fabs(integral - 1.0) < 2e-3);
    }
    CHECK(std::fabs(SOMBRA_HG_PHASE(0.f, 0.37f) - 1.f / (4.f * 3.14159265f)) < 1e-7f);
}

TEST_CASE("single scattering: isotropic equals head-on Phong in a homogeneous medium — forward scattering is brighter towards the light", "[render][scattering]") {
    Scene s;
    VolumeInstance vi;
    vi.volume = test::constant_volume({8, 8, 8}, 0.5f);
    vi.transfer_function = test::constant_tf(0.2f);
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {1.f / 8, 1.f / 8, 1.f / 8});
    vi.material.ambient = 0.f, vi.material.diffuse = 1.f, vi.material.specular = 0.f;
    s.volumes.push_back(vi);
    Light l;
    l.type = LightType::Directional;
    l.direction = {0.2f, -0.3f, 1.f};  // travels towards the camera (at +z)
    s.lights.push_back(l);
    s.camera.position = {0, 0, 2.5f};
    RenderOptions o;
    o.width = o.height = 24;
    o.shadows = ShadowTechnique::Rays;
    o.shadow_cache = ShadowCacheMode::Off;  // auto's choice may differ between the shadings
    Image phong = render(test::context(), s, o).image;
    o.shading = ShadingModel::Scattering;
    Image isotropic = render(test::context(), s, o).image;
    CHECK(test::compare(phong, isotropic).max_abs < 1e-5);
    auto centre = [](const Image& im) { return im.rgba[(std::size_t(im.height / 2) * im.width + im.width / 2) * 4]; };
    o.phase_g = 0.7f;
    float forward = centre(render(test::context(), s, o).image);
    o.phase_g = -0.7f;
    float backward = centre(render(test::context(), s, o).image);
    INFO("backward " << backward << ", isotropic " << centre(isotropic) << ", forward " << forward);
    CHECK(forward > 1.5f * centre(isotropic));
    CHECK(centre(isotropic) > 1.5f * backward);
    o.phase_g = 1.f;
    CHECK_THROWS_WITH(render(test::context(), s, o), Catch::Contains("phase_g"));
}

TEST_CASE("scenes of up to 32 volumes render in packets (24 here) and a 33rd is refused", "[render]") {
    Scene s;
    for (int i = 0; i < 24; ++i) {
        VolumeInstance vi;
        vi.volume = test::constant_volume({4, 4, 4}, 0.5f);
        vi.transfer_function = test::constant_tf(0.3f);
        float x = float(i % 6) * 0.25f - 0.6f, y = float(i / 6) * 0.25f - 0.4f;
        vi.transform = make_transform({x, y, 0}, {0, 0, 0}, {0.04f, 0.04f, 0.04f});
        s.volumes.push_back(vi);
    }
    Light l;
    l.type = LightType::Point;
    l.position = {0.2f, 0.3f, 1.5f};
    s.lights.push_back(l);
    s.camera.position = {0, 0, 2.5f};
    RenderOptions o;
    o.width = o.height = 32;
    o.shadows = ShadowTechnique::Dsm;
    o.dsm.resolution = 32;
    o.shadow_cache = ShadowCacheMode::Off;  // auto's choice may differ between 8 and 1 lanes
    o.lanes = 8;
    Image packets = render(test::context(), s, o).image;
    for (float v : packets.rgba) REQUIRE(std::isfinite(v));
    o.lanes = 1;
    CHECK(test::compare(packets, render(test::context(), s, o).image).max_abs < 1e-5);
    double lit = 0;
    for (float v : packets.rgba) lit += v;
    CHECK(lit > 1.0);  // the volumes show
    while (s.volumes.size() <= SOMBRA_MAX_VOLUMES) s.volumes.push_back(s.volumes.front());
    CHECK_THROWS_WITH(render(test::context(), s, o), Catch::Contains("volumes"));
}
