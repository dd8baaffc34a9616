// Polyhedral volume bounds and the one segment traversal over box bounds and fragments (issue 4;
// Knecht §3.1.2, §4.1.2): a volume is active only inside its box AND inside its closed bound mesh.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

#include "test_support.h"

using namespace sombra;

namespace {

// A closed cube [-h, h]³ wound outwards, optionally with a zero-area triangle (degenerate: skipped).
std::shared_ptr<const Mesh> cube_mesh(float h, bool with_degenerate = false) {
    auto m = std::make_shared<Mesh>();
    m->positions = {{-h, -h, -h}, {h, -h, -h}, {h, h, -h}, {-h, h, -h}, {-h, -h, h}, {h, -h, h}, {h, h, h}, {-h, h, h}};
    m->triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                    {2, 3, 7}, {2, 7, 6}, {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
    if (with_degenerate) m->triangles.push_back({0, 0, 6});
    m->source = "cube";
    return m;
}

// A constant medium of n³ voxels, voxel size 1/32 (box [-n/64, n/64]³), α per voxel = alpha.
VolumeInstance constant_medium(int n, float alpha) {
    VolumeInstance vi;
    vi.volume = test::constant_volume({n, n, n}, 1.f);
    vi.transfer_function = test::constant_tf(alpha);
    vi.spacing = {1.f / 32, 1.f / 32, 1.f / 32};
    vi.name = "medium";
    return vi;
}

// The 32³ medium bounded by a cube of half size 0.25, and the 16³ medium whose box is that cube:
// the same volume with no density outside the mesh.
Scene bounded_scene(bool bounded) {
    Scene s;
    VolumeInstance vi = constant_medium(bounded ? 32 : 16, 0.06f);
    if (bounded) vi.bound.mesh = cube_mesh(0.25f);
    s.volumes.push_back(vi);
    s.camera.position = {0.9f, 0.7f, 1.6f};
    s.camera.fov_y_deg = 35.f;
    s.background = {0.1f, 0.2f, 0.3f};
    s.width = 45, s.height = 29;
    Light l;
    l.type = LightType::Directional;
    l.direction = {-0.3f, -0.5f, -0.8f};
    s.lights.push_back(l);
    return s;
}

RenderOptions exact_options(int lanes) {
    RenderOptions o;
    o.lanes = lanes;
    o.volume_storage = VolumeStorage::Buffer;
    o.termination_transmittance = 0.f;
    o.shadow_cache = ShadowCacheMode::Off;  // auto may choose differently for 1 and 8 lanes
    return o;
}

MeshInstance quad(float half, float z0, float opacity) { return test::quad(half, z0, opacity); }

std::string write_file(const std::string& name, const std::string& text) {
    std::string path = test::temp_dir() + "/" + name;
    std::ofstream(path) << text;
    return path;
}

}  // namespace

TEST_CASE("bounds: a volume bounded by a cube mesh renders as the volume with no density outside it, 1 and 8 lanes",
          "[bounds][render][lanes]") {
    Scene bounded = bounded_scene(true), cropped = bounded_scene(false), unbounded = bounded_scene(true);
    unbounded.volumes[0].bound = {};
    for (ShadowTechnique shadows : {ShadowTechnique::None, ShadowTechnique::Rays}) {
        RenderOptions o1 = exact_options(1), o8 = exact_options(8);
        o1.shadows = o8.shadows = shadows;
        RenderResult one = render(test::context(), bounded, o1), eight = render(test::context(), bounded, o8);
        RenderResult ref = render(test::context(), cropped, o1), whole = render(test::context(), unbounded, o1);
        auto d = test::compare(one.image, ref.image), lanes = test::compare(one.image, eight.image);
        auto box = test::compare(one.image, whole.image);
        INFO("shadows " << int(shadows) << ": vs cropped max " << d.max_abs << " mean " << d.mean_abs << "; 1 vs 8 lanes max "
                        << lanes.max_abs << "; vs unbounded mean " << box.mean_abs);
        REQUIRE(d.non_finite == 0);
        CHECK(d.mean_abs < 2e-3);   // boundaries: fragment depth vs slab test, float noise
        CHECK(d.max_abs < 0.05);    // at most one sample's worth at a silhouette
        CHECK(lanes.max_abs == 0);  // packets compute what one lane computes
        CHECK(one.stats.samples == eight.stats.samples);
        CHECK(box.mean_abs > 0.01);  // the bound does cut the volume
        // samples are taken inside the bound only: about the cropped volume's count, far fewer than the box's
        CHECK(std::fabs(double(one.stats.samples) - double(ref.stats.samples)) < 0.02 * double(ref.stats.samples));
        CHECK(whole.stats.samples > 2 * one.stats.samples);
    }
}

TEST_CASE("bounds: a camera inside the bound (parity of the fragments) sees what it sees inside the cropped box",
          "[bounds][render]") {
    Scene bounded = bounded_scene(true), cropped = bounded_scene(false);
    for (Scene* s : {&bounded, &cropped}) {
        s->camera.position = {0.05f, -0.03f, 0.1f};
        s->camera.look_at = {0.3f, 0.2f, -1.f};
    }
    for (int lanes : {1, 8}) {
        RenderResult in = render(test::context(), bounded, exact_options(lanes));
        RenderResult ref = render(test::context(), cropped, exact_options(lanes));
        auto d = test::compare(in.image, ref.image);
        INFO(lanes << " lanes: max " << d.max_abs << " mean " << d.mean_abs);
        REQUIRE(d.non_finite == 0);
        CHECK(d.mean_abs < 2e-3);
        CHECK(in.stats.samples > 0);
        // every ray starts inside the medium: no pixel shows the bare background
        std::size_t bare = 0;
        for (std::size_t i = 0; i < in.image.rgba.size(); i += 4) bare += in.image.rgba[i + 3] < 0.05f;
        CHECK(bare == 0);
    }
}

TEST_CASE("bounds: shadow rays and deep shadow maps through a sphere-mesh bound match the reference with the bound",
          "[bounds][shadows][dsm]") {
    Scene s;
    VolumeInstance vi = constant_medium(32, 0.08f);
    vi.bound.mesh = std::make_shared<const Mesh>(make_uv_sphere(12, 24, 0.3f));
    vi.bound.transform = make_transform({0.1f, 0.f, 0.f}, {0, 0, 0}, {1.f, 1.f, 1.3f});
    s.volumes.push_back(vi);
    Light l;
    l.type = LightType::Directional;
    l.direction = {0.f, 0.f, -1.f};
    s.lights.push_back(l);
    std::vector<Vec3> points;
    for (float x = -0.4f; x <= 0.41f; x += 0.1f)
        for (float y = -0.35f; y <= 0.36f; y += 0.07f) points.push_back({x + 0.013f, y + 0.007f, -0.45f});
    Scene no_bound = s;
    no_bound.volumes[0].bound = {};
    double max_ray = 0, max_dsm = 0, max_gap = 0, mean_dsm = 0;
    RenderOptions rays;
    rays.shadows = ShadowTechnique::Rays;
    rays.volume_storage = VolumeStorage::Buffer;
    RenderOptions dsm = rays;
    dsm.shadows = ShadowTechnique::Dsm;
    dsm.dsm.resolution = 128;
    dsm.dsm.epsilon = 0.002f;
    std::vector<double> ray_t = shadow_transmittance(test::context(), s, 0, points, rays).transmittance;
    std::vector<double> dsm_t = shadow_transmittance(test::context(), s, 0, points, dsm).transmittance;
    for (std::size_t i = 0; i < points.size(); ++i) {
        double ref = reference_transmittance(s, 0, points[i]);
        max_ray = std::max(max_ray, std::fabs(ray_t[i] - ref));
        max_dsm = std::max(max_dsm, std::fabs(dsm_t[i] - ref));
        mean_dsm += std::fabs(dsm_t[i] - ref) / double(points.size());
        max_gap = std::max(max_gap, reference_transmittance(s, 0, points[i]) - reference_transmittance(no_bound, 0, points[i]));
        REQUIRE(std::isfinite(ray_t[i]));
        REQUIRE(std::isfinite(dsm_t[i]));
    }
    INFO("max |rays − ref| " << max_ray << ", max |DSM − ref| " << max_dsm << " (mean " << mean_dsm << "), bound lets through "
                             << max_gap << " more");
    CHECK(max_gap > 0.3);   // the bound matters at these points
    CHECK(max_ray < 0.03);  // step quantization of the jittered march
    CHECK(mean_dsm < 0.02);
    CHECK(max_dsm < 0.25);  // texels across the sphere's silhouette are filtered bilinearly
}

TEST_CASE("bounds: DSM generation with a bound in packets of 8 texels stores the nodes of 1 lane", "[bounds][dsm][lanes]") {
    Scene s = bounded_scene(true);
    s.volumes[0].bound.mesh = std::make_shared<const Mesh>(make_uv_sphere(8, 16, 0.3f));
    s.meshes.push_back(quad(0.2f, 0.05f, 0.5f));  // a surface inside the bound: both kinds of fragment
    s.lights[0].direction = {0.2f, 0.1f, -1.f};
    for (bool tables : {false, true}) {
        RenderOptions o;
        o.dsm.resolution = 37;
        o.dsm.epsilon = 0.01f;
        o.dsm.precompression = tables;
        o.volume_storage = VolumeStorage::Buffer;
        RenderOptions one = o, eight = o;
        one.lanes = 1, eight.lanes = 8;
        auto a = build_deep_shadow_maps(test::context(), s, 0, one);
        auto b = build_deep_shadow_maps(test::context(), s, 0, eight);
        REQUIRE(a.size() == b.size());
        INFO("tables " << tables);
        CHECK(a[0].nodes.size() > 0);
        CHECK(a[0].first == b[0].first);
        bool same = a[0].nodes.size() == b[0].nodes.size();
        for (std::size_t i = 0; same && i < a[0].nodes.size(); ++i)
            same = a[0].nodes[i].depth == b[0].nodes[i].depth && a[0].nodes[i].opacity == b[0].nodes[i].opacity;
        CHECK(same);
    }
}

TEST_CASE("segments: a segment between two surfaces with no volume takes no samples", "[bounds][segments][render]") {
    Scene s = bounded_scene(false);
    s.volumes[0].transform = make_transform({0.f, 0.f, -0.6f}, {0, 0, 0}, {1, 1, 1});  // behind both quads
    s.camera.position = {0.f, 0.f, 2.f};
    RenderResult volume_only = render(test::context(), s, exact_options(8));
    s.meshes.push_back(quad(0.6f, 0.5f, 0.3f));
    s.meshes.push_back(quad(0.6f, 0.2f, 0.3f));
    RenderResult with = render(test::context(), s, exact_options(8));
    CHECK(volume_only.stats.samples > 0);
    CHECK(with.stats.samples == volume_only.stats.samples);  // the segment between the quads is not marched
    Scene quads_only = s;
    quads_only.volumes[0].transform = make_transform({3.f, 0.f, 0.f}, {0, 0, 0}, {1, 1, 1});  // out of view
    RenderResult r = render(test::context(), quads_only, exact_options(8));
    CHECK(r.stats.samples == 0);
}

TEST_CASE("bounds: axis-aligned rays along the bound's faces and a degenerate bound triangle give finite pixels",
          "[bounds][render][numerics]") {
    Scene s = bounded_scene(true);
    s.volumes[0].bound.mesh = cube_mesh(0.25f, true);
    s.camera.position = {0.25f, 0.25f, 2.f};  // rays through the cube's edge x = y = 0.25, parallel to four faces
    s.camera.look_at = {0.25f, 0.25f, 0.f};
    for (ShadowTechnique shadows : {ShadowTechnique::Rays, ShadowTechnique::Dsm}) {
        RenderOptions o = exact_options(8);
        o.shadows = shadows;
        o.dsm.resolution = 64;
        s.lights[0].direction = {0.f, 0.f, -1.f};  // shadow rays parallel to four faces too
        RenderResult r = render(test::context(), s, o);
        std::size_t non_finite = 0;
        for (float v : r.image.rgba) non_finite += !std::isfinite(v);
        CHECK(non_finite == 0);
        CHECK(r.stats.samples > 0);
    }
}

TEST_CASE("bounds: scene JSON reads a bound mesh, and missing, malformed or open meshes and low-pass shadows fail clearly",
          "[bounds][scene]") {
    const std::string bunny = test::data_path("meshes/bunny.obj"), wall = test::data_path("meshes/wall.obj");
    auto scene_with = [&](const std::string& bound) {
        return "{\"volumes\": [{\"generator\": {\"type\": \"sphere\", \"size\": 16}, \"transfer_function\": "
               "{\"rgb_points\": [0, 1, 1, 1], \"opacity_points\": [0, 0, 1, 0.5]}, \"bounds\": " +
               bound + "}], \"lights\": [{\"type\": \"directional\", \"direction\": [0, 0, -1]}]}";
    };
    Scene s = load_scene(write_file("ok.json", scene_with("{\"mesh\": \"" + bunny + "\", \"transform\": {\"scale\": 80}}")));
    REQUIRE(s.volumes[0].bound.mesh);
    CHECK(s.volumes[0].bound.mesh->triangles.size() > 1000);
    CHECK(s.volumes[0].bound.transform[0] == 80.f);
    std::string missing = write_file("missing.json", scene_with("{\"mesh\": \"no_such.obj\"}"));
    CHECK_THROWS_WITH(load_scene(missing), Catch::Contains("missing.json: volumes[0].bounds.mesh:") && Catch::Contains("no_such.obj"));
    std::string open = write_file("open.json", scene_with("{\"mesh\": \"" + wall + "\"}"));
    CHECK_THROWS_WITH(load_scene(open), Catch::Contains("volumes[0].bounds.mesh:") && Catch::Contains("wall.obj") &&
                                            Catch::Contains("not closed"));
    std::string garbage = write_file("garbage.obj", "v 0 0 nonsense\nf 1 2 3 4 5\n");
    std::string bad = write_file("bad.json", scene_with("{\"mesh\": \"" + garbage + "\"}"));
    CHECK_THROWS_WITH(load_scene(bad), Catch::Contains("volumes[0].bounds.mesh:") && Catch::Contains("garbage.obj"));
    std::string typo = write_file("typo.json", scene_with("{\"mesh\": \"" + bunny + "\", \"scale\": 2}"));
    CHECK_THROWS_WITH(load_scene(typo), Catch::Contains("volumes[0].bounds: unknown key 'scale'"));
    for (ShadowTechnique t : {ShadowTechnique::Lowpass, ShadowTechnique::Ao, ShadowTechnique::Cone}) {
        RenderOptions o;
        o.shadows = t;
        o.width = o.height = 8;
        CHECK_THROWS_WITH(render(test::context(), s, o),
                          Catch::Contains("ok.json: volumes[0].bounds: polyhedral bounds are not supported by --shadows"));
    }
}

TEST_CASE("bounds: auto estimates the marked fill of shadow rays on volume lattices from the per-sample pass, per camera sample",
          "[bounds][shadow_cache]") {
    // shadow rays across a polyhedral bound fill volume lattices, each point's ray marched whole:
    // the probe that marked takes the marked points ÷ the frame's camera samples (as the marking
    // pass counted them) times the per-sample pass's shadow time (shadow_cache.cpp)
    auto frame = [](const Scene& s, ShadowTechnique technique) {
        forget_shadow_cache_choices();
        Context context(test::device_selector());
        RenderOptions o;
        o.shadows = technique;
        o.shadow_cache = ShadowCacheMode::Auto;
        o.width = o.height = 64;
        ::setenv("SOMBRA_TEST_MARK_IN_PROBE", "1", 1);  // (the tests run without auto's history: tests/main.cpp)
        RenderResult r = render(context, s, o);
        ::unsetenv("SOMBRA_TEST_MARK_IN_PROBE");
        return r;
    };
    const RenderResult rays = frame(bounded_scene(true), ShadowTechnique::Rays);
    const RenderStats& s = rays.stats;
    REQUIRE(s.shadow_cache_auto_marked == "in probe");
    REQUIRE(s.shadow_cache_light_lattices == 0);
    REQUIRE(s.samples > 0);
    REQUIRE(s.shadow_cache_points_marked > 0);
    CHECK(s.shadow_cache_estimated_marked_points_per_sample ==
          Approx(double(s.shadow_cache_points_marked) / double(s.samples)).epsilon(1e-6));
    if (!s.stage_ms.count("shadow_cache_measure"))  // (a measured fill replaces the estimate)
        CHECK(s.shadow_cache_estimated_fill_ms ==
              Approx(std::max(0.0, s.shadow_cache_estimated_per_sample_ms - s.shadow_cache_estimated_cached_ms) *
                     s.shadow_cache_estimated_marked_points_per_sample).epsilon(1e-9));
    // not where the rays fill light lattices (no bound), nor for a technique that does not march
    // each point's path
    const RenderResult unbounded = frame(bounded_scene(false), ShadowTechnique::Rays);
    CHECK(unbounded.stats.shadow_cache_light_lattices > 0);
    CHECK(unbounded.stats.shadow_cache_estimated_marked_points_per_sample == -1);
    const RenderResult dsm = frame(bounded_scene(true), ShadowTechnique::Dsm);
    CHECK(dsm.stats.shadow_cache_auto_marked == "in probe");
    CHECK(dsm.stats.shadow_cache_estimated_marked_points_per_sample == -1);
}
