// Clustering for clustered deep shadow maps (Knecht §3.4, Alg. 4.2, 4.3): convex bodies, the
// LiSPSM transform, distances and greedy clusters, focused views. Hand-computed cases, known
// layouts and properties over random scenes.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "clustering/clustering.h"

using namespace sombra;
using namespace sombra::clustering;

namespace {

// The camera of the hand-computed cases: at the origin looking along −z, 90° in x and y.
CameraView axis_camera(double near, double far) {
    CameraView c;
    c.eye = {0, 0, 0}, c.forward = {0, 0, -1}, c.up = {0, 1, 0};
    c.tan_half_y = 1, c.aspect = 1, c.near = near, c.far = far;
    return c;
}

LightView spot_view(const Point& position, const Point& forward, double tan_half, double near) {
    return {true, position, forward, tan_half, near};
}

LightView directional_view(const Point& direction) { return {false, Point(0.0), direction}; }

bool finite(const Point& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

bool finite(const FocusedView& v) {
    return finite(v.eye) && finite(v.forward) && finite(v.up) && std::isfinite(v.fov_x) && std::isfinite(v.fov_y) &&
           std::isfinite(v.half_width) && std::isfinite(v.half_height) && std::isfinite(v.near) && std::isfinite(v.far);
}

// A volume of dims voxels of spacing 1 centred at `centre` (the clustering reads only its box).
VolumeInstance box_volume(const std::string& name, const Point& centre, std::array<int, 3> dims) {
    auto volume = std::make_shared<Volume>();
    volume->dims = dims;
    VolumeInstance v;
    v.volume = volume;
    v.name = name;
    v.transform = make_transform({float(centre.x), float(centre.y), float(centre.z)}, {0, 0, 0}, {1, 1, 1});
    return v;
}

Light make_light(LightType type, const Point& position, const Point& direction, float cone_deg = 30) {
    Light l;
    l.type = type;
    l.position = {float(position.x), float(position.y), float(position.z)};
    l.direction = {float(direction.x), float(direction.y), float(direction.z)};
    l.cone_angle_deg = cone_deg;
    return l;
}

// Two groups of three 2-voxel cubes, 40 apart, seen from 60 away.
Scene two_groups(const Light& light) {
    Scene s;
    for (int g = 0; g < 2; ++g)
        for (int k = 0; k < 3; ++k)
            s.volumes.push_back(box_volume("g" + std::to_string(g) + "_" + std::to_string(k), {g * 40.0 - 20 + 1.5 * k, 0, 0}, {2, 2, 2}));
    s.camera.position = {0, 10, 60};
    s.camera.look_at = {0, 0, 0};
    s.camera.fov_y_deg = 60;
    s.lights = {light};
    return s;
}

// Every object exactly once: in one cluster or among the ignored.
void require_partition(const LightClusters& lc, std::size_t objects) {
    std::vector<int> seen(objects, 0);
    for (const Cluster& c : lc.clusters) {
        CHECK_FALSE(c.members.empty());
        for (std::size_t o : c.members) ++seen.at(o);
    }
    for (std::size_t o : lc.ignored) ++seen.at(o);
    for (std::size_t o = 0; o < objects; ++o) CHECK(seen[o] == 1);
}

}  // namespace

TEST_CASE("clustering: clipping a cube closes the hole with the cut's convex hull", "[clustering]") {
    const ConvexBody cube = box_body({0, 0, 0}, {1, 1, 1});
    CHECK(cube.volume() == Approx(1));
    const ConvexBody half = clip(cube, Plane{{1, 0, 0}, 0.5});
    CHECK(half.faces.size() == 6);
    CHECK(half.volume() == Approx(0.5));
    // the plane x + y + z = 1.5 cuts a hexagon: seven faces, half the cube by symmetry
    const ConvexBody corner = clip(cube, Plane{glm::normalize(Point(1, 1, 1)), 1.5 / std::sqrt(3.0)});
    CHECK(corner.faces.size() == 7);
    CHECK(corner.volume() == Approx(0.5));
    CHECK(corner.vertices().size() == 10);  // 4 kept corners + 6 on the cut
    CHECK(clip(cube, Plane{{1, 0, 0}, -0.1}).empty());
    CHECK(clip(cube, Plane{{1, 0, 0}, 1}).volume() == Approx(1));  // touching plane: unchanged
    CHECK(clip(cube, Plane{{1, 0, 0}, 0}).empty());                // only a face left: flat, empty
}

TEST_CASE("clustering: the convex hull of the camera frustum and a light position", "[clustering]") {
    // near 1, far 3, 90°: the frustum's volume is 4/3 (3³ − 1³)
    const ConvexBody V = axis_camera(1, 3).body();
    CHECK(V.volume() == Approx(4.0 / 3.0 * 26));
    SECTION("light inside the frustum: M = V") {
        const ConvexBody M = hull_with_point(V, {0, 0, -2});
        CHECK(M.faces.size() == V.faces.size());
        CHECK(M.volume() == Approx(V.volume()));
    }
    SECTION("light behind the camera: M is the pyramid from the light over the far face") {
        // (0, 0, 2) lies outside the near face and all four sides: it sees all but the far face
        const ConvexBody M = hull_with_point(V, {0, 0, 2});
        CHECK(M.faces.size() == 5);
        CHECK(M.volume() == Approx(6.0 * 6.0 * 5.0 / 3.0));
        for (const Point& p : V.vertices()) CHECK(M.contains(p, 1e-9));
    }
    SECTION("light beside the frustum: V and the light are inside M") {
        const ConvexBody M = hull_with_point(V, {5, 1, -2});
        CHECK(M.volume() > V.volume());
        CHECK(M.contains({5, 1, -2}, 1e-9));
        for (const Point& p : V.vertices()) CHECK(M.contains(p, 1e-9));
    }
    SECTION("directional light: V swept towards the light") {
        // the far face (6 × 6) swept 10 along +z, plus V on top of the sweep
        const ConvexBody M = sweep(V, {0, 0, 10});
        CHECK(M.volume() == Approx(360 + 4.0 / 3.0 * 26));
    }
}

TEST_CASE("clustering: the body B, hand-computed", "[clustering]") {
    const CameraView camera = axis_camera(0.003, 3);
    SECTION("spot light inside the camera frustum") {
        // S = [−1, 1]² × [−3, −1] lies inside V; the spot at z = −0.5 (45°) cuts it: cross-sections
        // (2t)² for depths t = −0.5 − z in [0.5, 1], 2² beyond: 4/3 (1 − 1/8) + 6
        const ConvexBody B = convex_body_B(camera, spot_view({0, 0, -0.5}, {0, 0, -1}, 1, 1e-3), {-1, -1, -3}, {1, 1, -1});
        CHECK(B.volume() == Approx(4.0 / 3.0 * 0.875 + 6));
    }
    SECTION("spot light behind the camera") {
        // S = [−4, 4]² × [−3, 1] holds V; M is the pyramid from (0, 0, 2) over V's far face (60),
        // S cuts its tip above z = 1 (side 1.2, height 1: 0.48); the spot's 45° cone holds the rest
        const ConvexBody B = convex_body_B(camera, spot_view({0, 0, 2}, {0, 0, -1}, 1, 1e-3), {-4, -4, -3}, {4, 4, 1});
        CHECK(B.volume() == Approx(60 - 0.48));
    }
    SECTION("directional light along the view") {
        // V swept towards the light (+z) through S: the far face's 6 × 6 from z = −3 to 1
        const ConvexBody B = convex_body_B(camera, directional_view({0, 0, -1}), {-4, -4, -3}, {4, 4, 1});
        CHECK(B.volume() == Approx(144));
    }
    SECTION("a scene box outside everything: B is empty") {
        CHECK(convex_body_B(camera, spot_view({0, 0, -0.5}, {0, 0, -1}, 1, 1e-3), {10, 10, 10}, {11, 11, 11}).empty());
    }
}

TEST_CASE("clustering: LiSPSM transform with the light perpendicular to the view, hand-computed", "[clustering]") {
    // Light from above, B = S = [−1, 1]² × [−3, −1]. Light space: y = +y, z = −z (the view), x = −x.
    // B's depths along the view are 1 … 3, so n = 1 + √3 (sin γ = 1), d = 2, P's centre at
    // light-space (0, 0, 1 − n), its near-plane extents ±1 in x and y.
    const CameraView camera = axis_camera(0.003, 3);
    const LightView light = directional_view({0, -1, 0});
    const ConvexBody B = convex_body_B(camera, light, {-1, -1, -3}, {1, 1, -1});
    REQUIRE(B.volume() == Approx(8));
    const Lispsm t = make_lispsm(B, camera, light);
    REQUIRE(t.warped);
    const double n = 1 + std::sqrt(3.0), f = n + 2;
    CHECK(t.sin_gamma == Approx(1));
    CHECK(t.n == Approx(n));
    CHECK(t.f == Approx(f));
    CHECK(t.left == Approx(-1));
    CHECK(t.right == Approx(1));
    // world (0.5, 0, −2): light space (−0.5, 0, 2), 1 + n from the centre
    const Point q = t.apply({0.5, 0, -2});
    CHECK(q.x == Approx(-0.5 * n / (n + 1)));
    CHECK(q.y == Approx(((f + n) - 2 * f * n / (n + 1)) / (f - n)));
    CHECK(q.z == Approx(0).margin(1e-12));
    // B's near corners map to map x = ±1, map y = −1; the light's side of B to depth −1
    const Point near_corner = t.apply({-1, 1, -1});
    CHECK(near_corner.x == Approx(1));
    CHECK(near_corner.y == Approx(-1));
    CHECK(near_corner.z == Approx(-1));
    CHECK(t.apply({1, -1, -3}).y == Approx(1));
}

TEST_CASE("clustering: LiSPSM falls back to a uniform map for a light along the view", "[clustering]") {
    const CameraView camera = axis_camera(0.003, 3);
    const Point lo{-1, -1, -3}, hi{1, 1, -1};
    for (const LightView& light : {directional_view({0, 0, -1}), directional_view({0, 0, 1}), spot_view({0, 0, 2}, {0, 0, -1}, 1, 1e-3)}) {
        const ConvexBody B = convex_body_B(camera, light, lo, hi);
        REQUIRE_FALSE(B.empty());
        const Lispsm t = make_lispsm(B, camera, light);
        CHECK_FALSE(t.warped);
        CHECK(t.sin_gamma == Approx(0).margin(1e-9));
        for (const Point& c : B.vertices()) {
            const Point q = t.apply(c);
            REQUIRE(finite(q));
            CHECK(std::fabs(q.x) <= 1 + 1e-9);
            CHECK(std::fabs(q.y) <= 1 + 1e-9);
            CHECK(std::fabs(q.z) <= 1 + 1e-9);
        }
        if (!light.perspective) {  // uniform: an affine map, midpoints stay midpoints
            const Point a = t.apply({-1, 0.5, -3}), b = t.apply({1, -1, -1.5}), m = t.apply({0, -0.25, -2.25});
            CHECK(m.x == Approx(0.5 * (a.x + b.x)));
            CHECK(m.y == Approx(0.5 * (a.y + b.y)));
            CHECK(m.z == Approx(0.5 * (a.z + b.z)));
        }
    }
}

TEST_CASE("clustering: LiSPSM of a spot light inside the camera frustum maps B into the unit cube", "[clustering]") {
    const CameraView camera = axis_camera(0.003, 3);
    const LightView light = spot_view({0, 0.5, -0.5}, glm::normalize(Point(0, -1, -1)), 1.5, 1e-3);
    const ConvexBody B = convex_body_B(camera, light, {-1, -1, -3}, {1, 1, -1});
    REQUIRE_FALSE(B.empty());
    const Lispsm t = make_lispsm(B, camera, light);
    CHECK(t.warped);
    Point lo(INFINITY), hi(-INFINITY);
    for (const Point& c : B.vertices()) {
        const Point q = t.apply(c);
        REQUIRE(finite(q));
        lo = glm::min(lo, q), hi = glm::max(hi, q);
    }
    CHECK(lo.x == Approx(-1));
    CHECK(hi.x == Approx(1));
    CHECK(lo.y == Approx(-1));
    CHECK(hi.y == Approx(1));
    CHECK(lo.z >= -1 - 1e-9);
    CHECK(hi.z <= 1 + 1e-9);
}

TEST_CASE("clustering: greedy clusters of known distance tables", "[clustering]") {
    // objects 0-2 near each other (1 apart), 3-4 near each other, the groups 10 apart
    const std::size_t n = 5;
    std::vector<double> d(n * n, 0);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            if (i != j) d[i * n + j] = (i < 3) == (j < 3) ? 1 : 10;
    using Groups = std::vector<std::vector<std::size_t>>;
    auto sorted = [](Groups g) {
        for (auto& c : g) std::sort(c.begin(), c.end());
        std::sort(g.begin(), g.end());
        return g;
    };
    CHECK(sorted(greedy_clusters(n, d, 2, 4)) == Groups{{0, 1, 2}, {3, 4}});
    CHECK(sorted(greedy_clusters(n, d, 2, 1)) == Groups{{0, 1, 2, 3, 4}});
    CHECK(sorted(greedy_clusters(n, d, 20, 4)) == Groups{{0, 1, 2, 3, 4}});
    CHECK(sorted(greedy_clusters(n, d, 0.5, 8)) == Groups{{0}, {1}, {2}, {3}, {4}});
    CHECK(greedy_clusters(1, {0}, 1, 4) == Groups{{0}});
    CHECK(greedy_clusters(0, {}, 1, 4).empty());
    CHECK(automatic_d0({1, 3, 2}) == Approx(4));
    CHECK(automatic_d0({0, 0}) > 0);
    CHECK(extreme_point_distance({0, 0, 0}, {1, 1, 0}, {3, 4, 0}, {1, 2, 0}) == Approx(5));
}

TEST_CASE("clustering: random distance tables put every object in exactly one of at most m clusters", "[clustering]") {
    std::mt19937 rng(14);
    std::uniform_real_distribution<double> unit(0, 1);
    for (int trial = 0; trial < 200; ++trial) {
        const std::size_t n = std::size_t(rng() % 12);
        const int m = 1 + int(rng() % 5);
        std::vector<double> d(n * n, 0);
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = i + 1; j < n; ++j) d[i * n + j] = d[j * n + i] = double(rng() % 4) * unit(rng);  // ties too
        const auto clusters = greedy_clusters(n, d, unit(rng), m);
        CHECK(clusters.size() <= std::size_t(m));
        std::vector<int> seen(n, 0);
        for (const auto& c : clusters) {
            CHECK_FALSE(c.empty());
            for (std::size_t o : c) ++seen.at(o);
        }
        for (int s : seen) CHECK(s == 1);
    }
}

TEST_CASE("clustering: two far groups make two clusters, m = 1 makes one", "[clustering]") {
    const Light lights[] = {make_light(LightType::Directional, {}, {0.3, -1, -0.2}),
                            make_light(LightType::Spot, {0, 60, 10}, {0, -1, -0.1}, 40),
                            make_light(LightType::Point, {0, 30, 5}, {0, -1, 0})};
    for (const Light& light : lights) {
        INFO("light type " << int(light.type));
        const Scene scene = two_groups(light);
        const auto result = cluster_lights(scene, {4, 0});
        REQUIRE(result.size() == 1);
        const LightClusters& lc = result[0];
        require_partition(lc, 6);
        CHECK(lc.ignored.empty());
        REQUIRE(lc.clusters.size() == 2);
        for (const Cluster& c : lc.clusters) {
            REQUIRE(c.members.size() == 3);
            CHECK(c.members[2] - c.members[0] == 2);  // 0-2 or 3-5: one group each
            CHECK(c.views.size() == 1);
        }
        const auto one = cluster_lights(scene, {1, 0});
        REQUIRE(one[0].clusters.size() == 1);
        CHECK(one[0].clusters[0].members.size() == 6);
        const auto fixed = cluster_lights(scene, {4, 1e-9});  // d0 that nothing meets: m singletons
        CHECK(fixed[0].clusters.size() == 4);
        require_partition(fixed[0], 6);
    }
}

TEST_CASE("clustering: objects that miss B are ignored", "[clustering]") {
    Scene scene = two_groups(make_light(LightType::Directional, {}, {0, -1, 0}));
    scene.volumes.push_back(box_volume("behind", {0, 0, 200}, {2, 2, 2}));  // behind the camera
    const auto result = cluster_lights(scene, {4, 0});
    CHECK(result[0].ignored == std::vector<std::size_t>{6});
    require_partition(result[0], 7);
}

TEST_CASE("clustering: a point light inside an object focuses per cube face", "[clustering]") {
    Scene scene;
    scene.volumes.push_back(box_volume("around", {0, 0, 0}, {4, 4, 4}));
    scene.camera.position = {0, 3, 20};
    scene.lights = {make_light(LightType::Point, {0.5, 0.2, -0.3}, {0, -1, 0})};
    const auto result = cluster_lights(scene, {4, 0});
    REQUIRE(result[0].clusters.size() == 1);
    CHECK(result[0].clusters[0].views.size() == 6);
}

TEST_CASE("clustering: bad options name the flag", "[clustering]") {
    const Scene scene = two_groups(make_light(LightType::Directional, {}, {0, -1, 0}));
    CHECK_THROWS_WITH(cluster_lights(scene, {0, 0}), Catch::Contains("--clusters"));
    CHECK_THROWS_WITH(cluster_lights(scene, {65, 0}), Catch::Contains("--clusters"));
    CHECK_THROWS_WITH(cluster_lights(scene, {4, NAN}), Catch::Contains("--cluster-distance"));
}

TEST_CASE("clustering: focused views hold every member's box, nothing is NaN (random layouts)", "[clustering]") {
    std::mt19937 rng(1414);
    std::uniform_real_distribution<double> coordinate(-30, 30), unit(-1, 1);
    for (int trial = 0; trial < 150; ++trial) {
        Scene scene;
        const int objects = 1 + int(rng() % 9);
        for (int o = 0; o < objects; ++o) {
            VolumeInstance v = box_volume("v" + std::to_string(o), {coordinate(rng), coordinate(rng), coordinate(rng)},
                                          {1 + int(rng() % 12), 1 + int(rng() % 12), 1 + int(rng() % 12)});
            v.transform = make_transform({float(coordinate(rng)), float(coordinate(rng)), float(coordinate(rng))},
                                         {float(180 * unit(rng)), float(180 * unit(rng)), float(180 * unit(rng))},
                                         {float(1.5 + unit(rng)), float(1.5 + unit(rng)), float(1.5 + unit(rng))});
            scene.volumes.push_back(v);
        }
        scene.camera.position = {float(2 * coordinate(rng)), float(2 * coordinate(rng)), float(2 * coordinate(rng))};
        scene.camera.look_at = {float(0.3 * coordinate(rng)), float(0.3 * coordinate(rng)), float(0.3 * coordinate(rng))};
        scene.camera.fov_y_deg = float(20 + 60 * (0.5 + 0.5 * unit(rng)));
        const Point direction = glm::normalize(Point(unit(rng), unit(rng), unit(rng)) + Point(0, 0, 1e-3));
        const LightType type = LightType(rng() % 3);
        const Point position(1.5 * coordinate(rng), 1.5 * coordinate(rng), 1.5 * coordinate(rng));
        const Point to_middle = glm::normalize(-position + Point(1e-3, 0, 0));
        scene.lights = {make_light(type, position, type == LightType::Spot ? to_middle : direction, float(10 + 80 * (0.5 + 0.5 * unit(rng))))};
        const ClusterOptions options{1 + int(rng() % 5), rng() % 3 == 0 ? 0.5 * (1 + unit(rng)) : 0.0};
        INFO("trial " << trial << ", light type " << int(type) << ", m " << options.max_clusters);

        const auto all = scene_objects(scene);
        const LightClusters lc = cluster_lights(scene, options).at(0);
        require_partition(lc, all.size());
        CHECK(lc.clusters.size() <= std::size_t(options.max_clusters));
        CHECK(std::isfinite(lc.d0));
        for (const ViewSpace& s : lc.spaces)
            for (const Point& c : s.B.vertices()) CHECK(finite(s.lispsm.apply(c)));
        Point lo(INFINITY), hi(-INFINITY);
        for (const SceneObject& o : all) lo = glm::min(lo, o.lo), hi = glm::max(hi, o.hi);
        const std::vector<LightView> views = light_views(scene.lights[0], lo, hi);
        const double tolerance = 1e-7 * (glm::length(hi - lo) + glm::length(position));
        for (const Cluster& c : lc.clusters) {
            CHECK_FALSE(c.views.empty());
            for (const FocusedView& v : c.views) REQUIRE(finite(v));
            for (std::size_t m : c.members) {
                ConvexBody box = box_body(all[m].lo, all[m].hi);
                if (type == LightType::Spot) box = clip(box, views[0].planes());  // the box within the cone
                for (const Point& corner : box.vertices()) {
                    if (type == LightType::Point && glm::length(corner - position) < std::sqrt(3.0) * views[0].near) continue;
                    bool inside = false;
                    for (const FocusedView& v : c.views) inside = inside || v.contains(corner, tolerance);
                    CHECK(inside);
                }
            }
        }
    }
}

TEST_CASE("clustering: the clusters do not depend on the scene's scale", "[clustering]") {
    for (const Light& light : {make_light(LightType::Directional, {}, {0.3, -1, -0.2}), make_light(LightType::Point, {0, 30, 5}, {0, -1, 0})}) {
        const Scene scene = two_groups(light);
        const auto reference = cluster_lights(scene, {4, 0}).at(0);
        CHECK(reference.spaces.size() == (light.type == LightType::Point ? 6u : 1u));
        for (float scale : {1e-3f, 1e3f}) {
            INFO("scale " << scale << ", light type " << int(light.type));
            Scene scaled = scene;
            for (VolumeInstance& v : scaled.volumes) v.spacing = {scale, scale, scale};
            for (VolumeInstance& v : scaled.volumes)
                for (int r = 0; r < 3; ++r) v.transform[std::size_t(r * 4 + 3)] *= scale;
            for (float& c : scaled.camera.position) c *= scale;
            for (float& c : scaled.lights[0].position) c *= scale;
            const auto result = cluster_lights(scaled, {4, 0}).at(0);
            REQUIRE(result.clusters.size() == reference.clusters.size());
            for (std::size_t c = 0; c < result.clusters.size(); ++c) {
                CHECK(result.clusters[c].members == reference.clusters[c].members);
                REQUIRE(result.clusters[c].views.size() == reference.clusters[c].views.size());
                CHECK(result.clusters[c].views[0].fov_x == Approx(reference.clusters[c].views[0].fov_x).epsilon(1e-4));
                CHECK(result.clusters[c].views[0].far == Approx(scale * reference.clusters[c].views[0].far).epsilon(1e-4));
            }
            CHECK(result.d0 == Approx(reference.d0).epsilon(1e-4));
        }
    }
}

TEST_CASE("clustering: degenerate scenes give finite views", "[clustering]") {
    auto require_finite = [](const Scene& scene) {
        for (const LightClusters& lc : cluster_lights(scene, {4, 0})) {
            CHECK(std::isfinite(lc.d0));
            for (const ViewSpace& s : lc.spaces)
                for (const Point& c : s.B.vertices()) CHECK(finite(s.lispsm.apply(c)));
            for (const Cluster& c : lc.clusters)
                for (const FocusedView& v : c.views) CHECK(finite(v));
        }
    };
    const Light lights[] = {make_light(LightType::Directional, {}, {0, 0, -1}), make_light(LightType::Spot, {0, 0, 60}, {0, 0, -1}, 90),
                            make_light(LightType::Point, {0, 10, 60}, {0, -1, 0}), make_light(LightType::Point, {-21, -1, -1}, {0, -1, 0})};
    Scene scene = two_groups(lights[0]);
    scene.lights.assign(std::begin(lights), std::end(lights));  // along the view, at the camera, on a box corner
    SECTION("lights along the view, at the camera and on a box corner") { require_finite(scene); }
    SECTION("a flat mesh and a point-sized mesh") {
        auto quad = std::make_shared<Mesh>();
        quad->positions = {{-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}};
        auto dot = std::make_shared<Mesh>();
        dot->positions = {{3, 3, 3}};
        MeshInstance a, b;
        a.mesh = quad, b.mesh = dot;
        scene.meshes = {a, b};
        require_finite(scene);
        const auto objects = scene_objects(scene);
        for (const SceneObject& o : objects) CHECK(glm::all(glm::lessThan(o.lo, o.hi)));
    }
    SECTION("the camera inside an object") {
        scene.camera.position = {-20, 0, 0};
        scene.camera.look_at = {20, 0, 0};
        require_finite(scene);
    }
    SECTION("every object at one place") {
        for (VolumeInstance& v : scene.volumes) v.transform = make_transform({1, 2, 3}, {0, 0, 0}, {1, 1, 1});
        require_finite(scene);
        CHECK(cluster_lights(scene, {4, 0})[0].clusters.size() == 1);
    }
    SECTION("no objects, no lights") {
        Scene empty;
        CHECK(cluster_lights(empty, {4, 0}).empty());
        empty.lights = {lights[1]};
        const auto result = cluster_lights(empty, {4, 0});
        REQUIRE(result.size() == 1);
        CHECK(result[0].clusters.empty());
    }
}

TEST_CASE("clustering: hysteresis keeps the previous clusters only while they are nearly as tight", "[clustering]") {
    const Scene scene = two_groups(make_light(LightType::Directional, {}, {0, -1, 0}));
    const auto fresh = cluster_lights(scene, {4, 0});
    REQUIRE(fresh[0].clusters.size() == 2);
    // the previous frame split the groups differently: g0_2 with the other group
    const std::vector<std::vector<std::vector<std::size_t>>> odd = {{{0, 1}, {2, 3, 4, 5}}};
    ClusterOptions options{4, 0, &odd, 0.25};
    CHECK(cluster_lights(scene, options)[0].clusters.size() == 2);
    CHECK(cluster_lights(scene, options)[0].clusters[0].members == fresh[0].clusters[0].members);  // far worse: found anew
    options.hysteresis = 1e6;  // any spread is close enough: kept
    const auto kept = cluster_lights(scene, options);
    REQUIRE(kept[0].clusters.size() == 2);
    CHECK(kept[0].clusters[1].members == std::vector<std::size_t>{2, 3, 4, 5});
    CHECK(kept[0].clusters[1].views.size() == 1);  // focused on its members as now
    // a previous clustering that misses an object, or has more clusters than m, is never kept
    const std::vector<std::vector<std::vector<std::size_t>>> missing = {{{0, 1, 2}, {3, 4}}};
    options.previous = &missing;
    CHECK(cluster_lights(scene, options)[0].clusters[1].members.size() == 3);
    const std::vector<std::vector<std::vector<std::size_t>>> many = {{{0}, {1}, {2}, {3}, {4}, {5}}};
    options.previous = &many;
    CHECK(cluster_lights(scene, options)[0].clusters.size() == 2);
    options.hysteresis = -1;
    CHECK_THROWS_WITH(cluster_lights(scene, options), Catch::Contains("--cluster-hysteresis"));
}
