// Clustered deep shadow maps (Knecht §3.4.3–3.4.4): one focused map per object cluster holding
// only its members, lookups multiplied over a light's clusters (Eq. 3.12), regeneration only when
// a cluster changes. Against the brute-force reference, against unclustered maps, across the
// storage backends.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "sombra/sombra.h"
#include "test_support.h"

using namespace sombra;

namespace {

// Two smoke-like volumes 1.2 apart across the light, seen together by the camera; a spot or point
// light above them, or a directional light from above.
Scene two_smokes(LightType type) {
    Scene s;
    for (float x : {-0.6f, 0.6f}) {
        VolumeInstance vi;
        vi.volume = std::make_shared<const Volume>(make_gaussian_blobs(20, 5, x < 0 ? 5u : 9u));
        vi.name = x < 0 ? "left" : "right";
        vi.transfer_function = test::ramp_tf(0.05f, 0.9f, 0.3f);
        vi.transform = make_transform({x, 0, 0}, {0, 0, 0}, {0.4f / 20, 0.4f / 20, 0.4f / 20});
        s.volumes.push_back(vi);
    }
    Light l;
    l.type = type;
    l.position = {0.1f, 2.5f, 0.3f};
    l.direction = {-0.04f, -1.f, -0.12f};
    l.cone_angle_deg = 45.f;
    s.lights.push_back(l);
    s.camera.position = {0, 1.0f, 3.2f};
    s.camera.look_at = {0, -0.2f, 0};
    s.width = s.height = 32;
    return s;
}

// Points in and below the two volumes (in their shadows and beside them).
std::vector<Vec3> shadow_points(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> x(-1.0f, 1.0f), y(-0.9f, 0.25f), z(-0.3f, 0.3f);
    std::vector<Vec3> p(static_cast<std::size_t>(n));
    for (auto& q : p) q = {x(rng), y(rng), z(rng)};
    return p;
}

RenderOptions dsm_options(int resolution, int clusters, float distance = 0.f) {
    RenderOptions o;
    o.shadows = ShadowTechnique::Dsm;
    o.dsm.resolution = resolution;
    o.dsm.epsilon = 0.01f;
    o.dsm.clusters = clusters;
    o.dsm.cluster_distance = distance;
    o.shadow_cache = ShadowCacheMode::Off;
    return o;
}

struct Errors {
    double mean = 0, max = 0;
    std::size_t bad = 0;  // non-finite or outside [0, 1]
};

Errors against_reference(const Scene& s, const std::vector<Vec3>& points, const std::vector<double>& values) {
    Errors e;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!(values[i] >= 0 && values[i] <= 1)) ++e.bad;
        double d = std::fabs(values[i] - reference_transmittance(s, 0, points[i]));
        e.mean += d, e.max = std::max(e.max, d);
    }
    e.mean /= double(points.size());
    return e;
}

// The largest opacity any texel of the map reaches.
double largest_opacity(const DeepShadowMap& map) {
    double largest = 0;
    for (const DsmNode& n : map.nodes) largest = std::max(largest, double(n.opacity));
    return largest;
}

}  // namespace

TEST_CASE("clustered DSM against the brute-force reference, every light type", "[clustered_dsm]") {
    const auto points = shadow_points(300, 23);
    for (LightType type : {LightType::Directional, LightType::Spot, LightType::Point}) {
        Scene s = two_smokes(type);
        ShadowQuery clustered = shadow_transmittance(test::context(), s, 0, points, dsm_options(96, 4));
        ShadowQuery plain = shadow_transmittance(test::context(), s, 0, points, dsm_options(96, 0));
        Errors c = against_reference(s, points, clustered.transmittance);
        Errors p = against_reference(s, points, plain.transmittance);
        INFO("light type " << int(type) << ": clustered mean " << c.mean << " max " << c.max << "; unclustered mean " << p.mean
                           << " max " << p.max);
        // the two volumes are far apart in light space: a cluster each, one view each
        REQUIRE(clustered.stats.dsm_clusters.size() == 2);
        for (const RenderStats::Cluster& cluster : clustered.stats.dsm_clusters) CHECK(cluster.members.size() == 1);
        CHECK(clustered.stats.dsm_views == 2);
        CHECK(c.bad == 0);
        // the tolerance of the unclustered maps ([dsm] "against the brute-force reference")
        CHECK(c.mean < 0.01);
        CHECK(c.max < 0.06);
        // each cluster's map spans its volume only, so its texels are finer than a map of both
        CHECK(c.mean <= p.mean * 1.1 + 1e-4);
    }
}

TEST_CASE("clustered DSM: each cluster's map holds its members only, and lookups multiply the clusters (Eq. 3.12)",
          "[clustered_dsm]") {
    // `front` lies above `back` along a directional light, shifted by a quarter of its width: one
    // map of both reaches the opacity of the two together; split into two clusters (d0 tiny), each
    // map holds one of them
    Scene s;
    for (float y : {0.5f, -0.5f}) {
        VolumeInstance vi;
        vi.volume = test::constant_volume({8, 8, 8}, 1.f);
        vi.name = y > 0 ? "front" : "back";
        vi.transfer_function = test::constant_tf(y > 0 ? 0.05f : 0.2f);
        vi.transform = make_transform({y > 0 ? 0.1f : 0.f, y, 0}, {0, 0, 0}, {0.05f, 0.05f, 0.05f});
        s.volumes.push_back(vi);
    }
    s.meshes.push_back(test::quad(0.15f, 0.f, 0.5f));  // a translucent quad in the plane z = 0, beside them
    s.meshes.back().transform = make_transform({1.2f, 0, 0}, {90, 0, 0}, {1, 1, 1});
    Light l;
    l.type = LightType::Directional;
    l.direction = {0, -1, 0};
    s.lights.push_back(l);
    s.camera.position = {0.5f, 0.5f, 4.f};
    s.camera.look_at = {0.5f, 0, 0};

    std::vector<DeepShadowMap> together = build_deep_shadow_maps(test::context(), s, 0, dsm_options(32, 1));
    RenderStats stats;
    std::vector<DeepShadowMap> apart = build_deep_shadow_maps(test::context(), s, 0, dsm_options(32, 3, 1e-6f), &stats);
    REQUIRE(together.size() == 1);
    REQUIRE(apart.size() == 3);
    REQUIRE(stats.dsm_clusters.size() == 3);
    // through 8 voxels of opacity α per voxel each (test::constant_tf): 1 − (1 − α)⁸
    const double front = 1 - std::pow(0.95, 8), back = 1 - std::pow(0.8, 8), both = 1 - (1 - front) * (1 - back);
    CHECK(largest_opacity(together[0]) == Approx(both).margin(0.02));
    for (std::size_t c = 0; c < apart.size(); ++c) {
        const std::vector<std::string>& members = stats.dsm_clusters[c].members;
        REQUIRE(members.size() == 1);
        INFO("cluster " << c << " (" << members[0] << "): map " << apart[c].light_name << ", largest opacity " << largest_opacity(apart[c]));
        CHECK(apart[c].light_name == "lights[0].cluster" + std::to_string(c) + ".0");
        const double expected = members[0] == "front" ? front : members[0] == "back" ? back : 0.5;  // the quad: one step of 0.5
        CHECK(largest_opacity(apart[c]) == Approx(expected).margin(0.02));
    }
    // behind both, the product of the two clusters' transmittances is the transmittance of both
    std::vector<Vec3> below;
    for (float x : {-0.05f, 0.f, 0.12f})
        for (float z : {-0.1f, 0.05f}) below.push_back({x, -1.f, z});
    below.push_back({1.2f, -0.5f, 0.f});  // in the quad's shadow: 1 − 0.5
    ShadowQuery product = shadow_transmittance(test::context(), s, 0, below, dsm_options(32, 3, 1e-6f));
    for (std::size_t i = 0; i < below.size(); ++i) {
        INFO("point " << i);
        CHECK(product.transmittance[i] == Approx(reference_transmittance(s, 0, below[i])).margin(0.02));
    }
    CHECK(product.transmittance.back() == Approx(0.5).margin(0.01));
}

TEST_CASE("clustered DSM: every storage backend builds the same nodes", "[clustered_dsm]") {
    for (LightType type : {LightType::Spot, LightType::Point}) {
        Scene s = two_smokes(type);
        std::vector<DeepShadowMap> reference = build_deep_shadow_maps(test::context(), s, 0, dsm_options(24, 2));
        REQUIRE(reference.size() >= 2);
        for (const std::string& storage : dsm_storage_names()) {
            RenderOptions o = dsm_options(24, 2);
            o.dsm.storage = storage;
            std::vector<DeepShadowMap> maps = build_deep_shadow_maps(test::context(), s, 0, o);
            REQUIRE(maps.size() == reference.size());
            for (std::size_t v = 0; v < maps.size(); ++v) {
                INFO(storage << ", light type " << int(type) << ", view " << v);
                CHECK(maps[v].light_name == reference[v].light_name);
                REQUIRE(maps[v].first == reference[v].first);
                REQUIRE(maps[v].nodes.size() == reference[v].nodes.size());
                bool same = true;
                for (std::size_t i = 0; i < maps[v].nodes.size(); ++i)
                    same = same && maps[v].nodes[i].depth == reference[v].nodes[i].depth &&
                           maps[v].nodes[i].opacity == reference[v].nodes[i].opacity;
                CHECK(same);
            }
        }
    }
}

TEST_CASE("clustered DSM: a camera move that keeps the clusters regenerates nothing, one that changes them does",
          "[clustered_dsm]") {
    Scene s = two_smokes(LightType::Spot);
    Context context(test::device_selector()), fresh(test::device_selector());
    RenderOptions o = dsm_options(48, 4);
    RenderResult first = render(context, s, o);
    CHECK(first.stats.dsm_views_generated == 2);

    s.camera.position = {0.05f, 1.02f, 3.2f};  // a small move: the same clusters, the same focus
    RenderResult moved = render(context, s, o);
    CHECK(moved.stats.reused_preparation);
    CHECK(moved.stats.dsm_views_generated == 0);
    CHECK(test::compare(moved.image, render(fresh, s, o).image).max_abs < 1e-6);

    // the camera turned to the left volume only: the right one cannot shadow what it sees (it misses
    // B), so it leaves its cluster and the left volume's map is all that is left
    s.camera.position = {-0.6f, 0.3f, 1.0f};
    s.camera.look_at = {-0.6f, -0.3f, 0};
    s.camera.fov_y_deg = 30.f;
    RenderResult turned = render(context, s, o);
    INFO("clusters after the turn: " << turned.stats.dsm_clusters.size());
    CHECK(turned.stats.dsm_clusters.size() == 1);
    CHECK(turned.stats.dsm_views_generated >= 1);
    REQUIRE(turned.stats.dsm_ignored_objects.size() == 1);
    CHECK(turned.stats.dsm_ignored_objects[0] == std::vector<std::string>{"right"});
    CHECK(test::compare(turned.image, render(fresh, s, o).image).max_abs < 1e-6);
}

TEST_CASE("clustered DSM: options out of range name their key", "[clustered_dsm]") {
    Scene s = two_smokes(LightType::Spot);
    for (int clusters : {-1, 65})
        CHECK_THROWS_WITH(render(test::context(), s, dsm_options(16, clusters)), Catch::Contains("dsm_clusters"));
    for (float distance : {-1.f, 11.f, NAN})
        CHECK_THROWS_WITH(render(test::context(), s, dsm_options(16, 2, distance)), Catch::Contains("dsm_cluster_distance"));
}

TEST_CASE("clustered DSM: a camera that sees nothing any object could shadow leaves every light without maps", "[clustered_dsm]") {
    Scene s = two_smokes(LightType::Spot);
    s.camera.position = {0, 0, 3.2f};
    s.camera.look_at = {0, 0, 10};  // looking away from both volumes
    for (const std::string& storage : dsm_storage_names()) {
        INFO(storage);
        Context context(test::device_selector());
        RenderOptions o = dsm_options(16, 4);
        o.dsm.storage = storage;
        RenderResult away = render(context, s, o);
        CHECK(away.stats.dsm_clusters.empty());
        REQUIRE(away.stats.dsm_ignored_objects.size() == 1);
        CHECK(away.stats.dsm_ignored_objects[0].size() == 2);
        CHECK(away.stats.dsm_nodes == 0);
        CHECK(build_deep_shadow_maps(context, s, 0, o).empty());
        // turning back to the volumes builds their maps on the same Context
        s.camera.look_at = {0, -0.2f, 0};
        RenderResult back = render(context, s, o);
        CHECK(back.stats.dsm_clusters.size() == 2);
        CHECK(back.stats.dsm_views_generated >= 1);
        CHECK(test::compare(back.image, render(test::context(), s, o).image).max_abs < 1e-6);
        s.camera.look_at = {0, 0, 10};
    }
}
