// The bounding-volume hierarchy over mesh triangles (src/geometry/bvh.h): structure invariants, and a
// plain C++ walk of it finds exactly the triangles a brute-force test of every triangle finds, on
// random soups (with degenerate triangles) and the real meshes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <set>

#include "geometry/bvh.h"
#include "sombra/sombra.h"
#include "test_support.h"

using namespace sombra;

namespace {

using D3 = std::array<double, 3>;

SurfaceTriangleGpu triangle(const D3& a, const D3& b, const D3& c) {
    SurfaceTriangleGpu t{};
    t.corner = {{float(a[0]), float(a[1]), float(a[2]), 0.5f}};
    t.corner1 = {{float(b[0]), float(b[1]), float(b[2]), 0.f}};
    t.corner2 = {{float(c[0]), float(c[1]), float(c[2]), 0.f}};
    return t;
}

std::vector<SurfaceTriangleGpu> mesh_triangles(const Mesh& m) {
    std::vector<SurfaceTriangleGpu> out;
    for (const auto& t : m.triangles) {
        auto p = [&](int k) {
            const auto& q = m.positions[t[std::size_t(k)]];
            return D3{q[0], q[1], q[2]};
        };
        out.push_back(triangle(p(0), p(1), p(2)));
    }
    return out;
}

// Möller–Trumbore in double on the float data: does o + t·d cross the triangle for 0 < t < t_max?
bool crosses(const SurfaceTriangleGpu& tri, const D3& o, const D3& d, double t_max) {
    D3 e1{double(tri.corner1.s[0]) - tri.corner.s[0], double(tri.corner1.s[1]) - tri.corner.s[1], double(tri.corner1.s[2]) - tri.corner.s[2]};
    D3 e2{double(tri.corner2.s[0]) - tri.corner.s[0], double(tri.corner2.s[1]) - tri.corner.s[1], double(tri.corner2.s[2]) - tri.corner.s[2]};
    auto cross = [](const D3& a, const D3& b) { return D3{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; };
    auto dot = [](const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    D3 n = cross(e1, e2), p = cross(d, e2);
    double det = dot(p, e1);
    if (!(det * det > 1e-14 * dot(n, n))) return false;
    D3 tv{o[0] - tri.corner.s[0], o[1] - tri.corner.s[1], o[2] - tri.corner.s[2]};
    double u = dot(tv, p) / det;
    D3 q = cross(tv, e1);
    double v = dot(d, q) / det, t = dot(q, e2) / det;
    return u >= 0 && v >= 0 && u + v <= 1 && t > 0 && t < t_max;
}

bool box_hit(const BvhNodeGpu& n, const D3& o, const D3& d, double t_max) {
    double t0 = 0, t1 = t_max;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
            if (o[a] < n.box_min.s[a] || o[a] > n.box_max.s[a]) return false;
            continue;
        }
        double ta = (n.box_min.s[a] - o[a]) / d[a], tb = (n.box_max.s[a] - o[a]) / d[a];
        t0 = std::max(t0, std::min(ta, tb)), t1 = std::min(t1, std::max(ta, tb));
    }
    return t0 <= t1;
}

// Input indices of the triangles the ray crosses, found by walking the hierarchy.
std::set<std::uint32_t> walk(const bvh::Hierarchy& h, const std::vector<SurfaceTriangleGpu>& ordered, const D3& o,
                             const D3& d, double t_max, std::size_t* visited) {
    std::set<std::uint32_t> hits;
    if (h.nodes.empty()) return hits;
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
        std::uint32_t i = stack.back();
        stack.pop_back();
        const BvhNodeGpu& n = h.nodes[i];
        ++*visited;
        if (!box_hit(n, o, d, t_max)) continue;
        if (n.count == 0) {
            stack.push_back(n.first);
            stack.push_back(i + 1);
            continue;
        }
        for (std::uint32_t k = n.first; k < n.first + n.count; ++k)
            if (crosses(ordered[k], o, d, t_max)) hits.insert(h.order[k]);
    }
    return hits;
}

std::set<std::uint32_t> brute_force(const std::vector<SurfaceTriangleGpu>& tris, const D3& o, const D3& d, double t_max) {
    std::set<std::uint32_t> hits;
    for (std::uint32_t i = 0; i < tris.size(); ++i)
        if (crosses(tris[i], o, d, t_max)) hits.insert(i);
    return hits;
}

bool inside(const BvhNodeGpu& outer, const cl_float4& lo, const cl_float4& hi) {
    for (int a = 0; a < 3; ++a)
        if (lo.s[a] < outer.box_min.s[a] || hi.s[a] > outer.box_max.s[a]) return false;
    return true;
}

// Every triangle once, leaves within the size, children and triangles inside their node's box.
void check_structure(const bvh::Hierarchy& h, const std::vector<SurfaceTriangleGpu>& tris, unsigned leaf_size) {
    std::vector<std::uint32_t> sorted = h.order;
    std::sort(sorted.begin(), sorted.end());
    REQUIRE(sorted.size() == tris.size());
    for (std::uint32_t i = 0; i < sorted.size(); ++i) REQUIRE(sorted[i] == i);
    std::size_t leaf_triangles = 0;
    for (std::uint32_t i = 0; i < h.nodes.size(); ++i) {
        const BvhNodeGpu& n = h.nodes[i];
        if (n.count == 0) {
            REQUIRE(n.first > i + 1);
            REQUIRE(n.first < h.nodes.size());
            REQUIRE(inside(n, h.nodes[i + 1].box_min, h.nodes[i + 1].box_max));
            REQUIRE(inside(n, h.nodes[n.first].box_min, h.nodes[n.first].box_max));
            continue;
        }
        REQUIRE(n.count <= leaf_size);
        leaf_triangles += n.count;
        for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
            const SurfaceTriangleGpu& t = tris[h.order[k]];
            for (const cl_float4* p : {&t.corner, &t.corner1, &t.corner2}) REQUIRE(inside(n, *p, *p));
        }
    }
    REQUIRE(leaf_triangles == tris.size());
    // the kernels' walk keeps at most one pending node per level, plus the root
    std::vector<int> depth(h.nodes.size(), 0);
    int deepest = 0;
    for (std::uint32_t i = 0; i < h.nodes.size(); ++i) {
        deepest = std::max(deepest, depth[i]);
        if (h.nodes[i].count == 0) depth[i + 1] = depth[h.nodes[i].first] = depth[i] + 1;
    }
    REQUIRE(deepest + 1 < SOMBRA_BVH_MAX_DEPTH);
}

// Random rays through the soup's region; the walk must find the brute-force set for each, and on
// average visit far fewer nodes than there are triangles.
void check_rays(const std::vector<SurfaceTriangleGpu>& tris, unsigned seed, double visit_fraction_bound) {
    bvh::Hierarchy h = bvh::build(tris);
    check_structure(h, tris, 4);
    std::vector<SurfaceTriangleGpu> ordered = bvh::reorder(tris, h);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    std::size_t visited = 0, hits = 0;
    const int rays = 400;
    for (int r = 0; r < rays; ++r) {
        D3 o{u(rng), u(rng), u(rng)}, d{u(rng), u(rng), u(rng)};
        if (r % 7 == 0) d = D3{0, 0, r % 2 ? 1.0 : -1.0};  // axis-aligned rays: slabs parallel to two axes
        double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (len < 1e-6) continue;
        for (double& c : d) c /= len;
        double t_max = r % 3 == 0 ? 1e30 : 1.0 + 2.0 * (u(rng) + 1.5) / 3.0;
        auto expected = brute_force(tris, o, d, t_max);
        auto found = walk(h, ordered, o, d, t_max, &visited);
        hits += expected.size();
        REQUIRE(found == expected);
    }
    INFO("triangles " << tris.size() << ", nodes visited per ray " << double(visited) / rays << ", hits " << hits);
    CHECK(hits > 0);
    CHECK(double(visited) / rays < visit_fraction_bound * double(tris.size()));
}

}  // namespace

TEST_CASE("bvh: a walk finds exactly the triangles brute force finds (random soups)", "[bvh]") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> pos(-1.0, 1.0), size(-0.2, 0.2);
    for (int soup = 0; soup < 4; ++soup) {
        std::vector<SurfaceTriangleGpu> tris;
        for (int i = 0; i < 600; ++i) {
            D3 a{pos(rng), pos(rng), pos(rng)};
            D3 b{a[0] + size(rng), a[1] + size(rng), a[2] + size(rng)}, c{a[0] + size(rng), a[1] + size(rng), a[2] + size(rng)};
            if (i % 17 == 0) c = b;                                   // degenerate: repeated corner
            if (i % 23 == 0) c = D3{2 * b[0] - a[0], 2 * b[1] - a[1], 2 * b[2] - a[2]};  // collinear
            if (i % 29 == 0) b = c = a;                               // a point
            if (i % 31 == 0) a[2] = b[2] = c[2] = 0.25;               // flat in z: a box without thickness
            tris.push_back(triangle(a, b, c));
        }
        check_rays(tris, unsigned(soup), 0.5);
    }
}

TEST_CASE("bvh: coincident triangles and a single triangle", "[bvh]") {
    std::vector<SurfaceTriangleGpu> same(40, triangle({0, 0, 0}, {1, 0, 0}, {0, 1, 0}));  // all centroids equal
    bvh::Hierarchy h = bvh::build(same);
    check_structure(h, same, 4);
    std::size_t visited = 0;
    CHECK(walk(h, bvh::reorder(same, h), {0.2, 0.2, -1}, {0, 0, 1}, 1e30, &visited).size() == 40);
    std::vector<SurfaceTriangleGpu> one{triangle({0, 0, 0}, {1, 0, 0}, {0, 1, 0})};
    h = bvh::build(one);
    REQUIRE(h.nodes.size() == 1);
    CHECK(h.nodes[0].count == 1);
    CHECK(bvh::build({}).nodes.empty());
}

TEST_CASE("bvh: the teapot and the bunny", "[bvh]") {
    for (const char* file : {"meshes/teapot.obj", "meshes/bunny.obj"}) {
        Mesh m = load_mesh(test::data_path(file));
        // scaled into the rays' region [-1.5, 1.5]³
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (auto& p : m.positions)
            for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
        float scale = 2.f / std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
        for (auto& p : m.positions)
            for (int a = 0; a < 3; ++a) p[a] = (p[a] - 0.5f * (lo[a] + hi[a])) * scale;
        INFO(file);
        check_rays(mesh_triangles(m), 11, 0.1);
    }
}

TEST_CASE("shadow rays through the BVH cross what the brute-force reference crosses (the bunny, three light types)",
          "[bvh][surfaces][shadows]") {
    Scene s;
    s.camera.position = {0, 0, 3};
    MeshInstance bunny = test::centred_mesh("meshes/bunny.obj", {0.f, 30.f, 0.f});
    bunny.material.opacity = 0.3f;
    s.meshes.push_back(bunny);
    MeshInstance teapot = test::centred_mesh("meshes/teapot.obj", {90.f, 0.f, 0.f});
    teapot.material.opacity = 0.55f;
    teapot.transform[3] = 0.4f, teapot.transform[7] = 0.3f;  // shifted: the two overlap in part
    s.meshes.push_back(teapot);
    Light directional;
    directional.type = LightType::Directional;
    directional.direction = {0.3f, -0.4f, -1.f};
    Light point;
    point.type = LightType::Point;
    point.position = {0.2f, 0.1f, 2.f};
    Light spot = point;
    spot.type = LightType::Spot;
    spot.position = {-1.5f, 0.2f, 0.3f};
    spot.direction = {1.5f, -0.2f, -0.3f};
    spot.cone_angle_deg = 60.f;
    s.lights = {directional, point, spot};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-0.9f, 0.9f);
    std::vector<Vec3> points;
    for (int i = 0; i < 150; ++i) points.push_back({u(rng), u(rng), u(rng) - 0.3f});
    RenderOptions o;
    o.shadows = ShadowTechnique::Rays;
    for (int light = 0; light < 3; ++light) {
        auto rays = shadow_transmittance(test::context(), s, light, points, o).transmittance;
        int agree = 0, shadowed = 0;
        double worst = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            double ref = reference_transmittance(s, light, points[i]);
            REQUIRE(std::isfinite(rays[i]));
            double d = std::abs(rays[i] - ref);
            worst = std::max(worst, d);
            agree += d < 1e-5;
            shadowed += ref < 0.99;
        }
        INFO("light " << light << ": " << agree << " of " << points.size() << " agree within 1e-5, " << shadowed
                      << " shadowed, worst |ΔT| " << worst);
        CHECK(shadowed > 20);  // the meshes do shadow these points
        // float (kernel) and double (reference) may disagree on a ray grazing a shared edge
        CHECK(agree >= int(points.size()) - 2);
    }
}
