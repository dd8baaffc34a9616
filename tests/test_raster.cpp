// The tile rasterizer (cl/raster.cl, Knecht §4.1.1) against the per-pixel reference
// (tests/reference/raster_ref.cpp), and the fill rule's promises: no cracks, no double coverage
// inside a surface, even coverage of closed meshes, nothing from degenerate triangles.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <cstdio>
#include <random>

#include "reference/raster_ref.h"
#include "geometry/rasterizer.h"
#include "test_support.h"

using namespace sombra;
using reference::TileList;

namespace {

host::Runtime& rt() { return test::context().runtime(); }

RasterScreenGpu screen_of(int w, int h) {
    raster::View v;
    v.width = w, v.height = h;
    return raster::make_screen(v);
}

// The kernel's tile lists, sorted like the reference's; checks the chunk layout on the way.
std::vector<TileList> kernel_lists(const raster::HostTiles& h) {
    std::vector<TileList> lists(h.count.size());
    std::size_t entries = 0, chunks = 0;
    for (std::size_t t = 0; t < lists.size(); ++t) {
        REQUIRE(h.first_chunk[t] == chunks);  // chunks of a tile are consecutive, tiles in order
        chunks += (h.count[t] + SOMBRA_TILE_CHUNK - 1) / SOMBRA_TILE_CHUNK;
        for (std::size_t k = 0; k < h.count[t]; ++k) {
            std::size_t at = std::size_t(h.first_chunk[t]) * SOMBRA_TILE_CHUNK + k;
            lists[t].push_back({h.ids[at], h.masks[at]});
        }
        entries += h.count[t];
        std::sort(lists[t].begin(), lists[t].end());
    }
    CHECK(entries == h.stats.entries);
    CHECK(chunks == h.stats.chunks);
    CHECK(h.stats.wasted_slots == chunks * SOMBRA_TILE_CHUNK - entries);
    CHECK(h.stats.overflow == 0);
    return lists;
}

std::vector<TileList> run_kernel(const std::vector<ScreenTriangleGpu>& tris, int w, int h, raster::Stats* stats = nullptr) {
    auto host = raster::read_back(rt(), raster::rasterize(rt(), tris, screen_of(w, h)));
    if (stats) *stats = host.stats;
    return kernel_lists(host);
}

// Coverage count per pixel from tile lists.
std::vector<int> counts_of(const std::vector<TileList>& lists, int w, int h) {
    std::vector<int> counts(std::size_t(w) * h, 0);
    const int tiles_x = (w + 7) / 8;
    for (std::size_t t = 0; t < lists.size(); ++t)
        for (auto& [id, mask] : lists[t])
            for (int b = 0; b < 64; ++b)
                if (mask >> b & 1) {
                    int px = int(t % tiles_x) * 8 + b % 8, py = int(t / tiles_x) * 8 + b / 8;
                    REQUIRE(px < w);
                    REQUIRE(py < h);
                    ++counts[std::size_t(py) * w + px];
                }
    return counts;
}

void require_same(const std::vector<TileList>& kernel, const std::vector<TileList>& ref) {
    REQUIRE(kernel.size() == ref.size());
    std::size_t differing = 0, entries = 0;
    for (std::size_t t = 0; t < ref.size(); ++t) {
        differing += kernel[t] != ref[t];
        entries += ref[t].size();
    }
    INFO(differing << " of " << ref.size() << " tiles differ; " << entries << " reference entries");
    CHECK(differing == 0);
}

constexpr int kSub = 1 << SOMBRA_SUBPIXEL_BITS;

ScreenTriangleGpu tri(std::array<std::array<long, 2>, 3> c, cl_uint id = 0) {
    ScreenTriangleGpu t{};
    for (int k = 0; k < 3; ++k) t.x.s[k] = cl_int(c[k][0]), t.y.s[k] = cl_int(c[k][1]);
    t.source = id;
    return t;
}

std::shared_ptr<const Mesh> mesh_of(std::vector<std::array<float, 3>> p, std::vector<std::array<std::uint32_t, 3>> t) {
    Mesh m;
    m.positions = std::move(p), m.triangles = std::move(t);
    return std::make_shared<const Mesh>(m);
}

// The single screen triangle of one world triangle (wholly inside the view).
ScreenTriangleGpu project_one(std::vector<std::array<float, 3>> corners, const raster::View& v) {
    MeshInstance mi;
    mi.mesh = mesh_of(std::move(corners), {{0, 1, 2}});
    auto proj = raster::project_meshes({mi}, v);
    REQUIRE(proj.triangles.size() == 1);
    return proj.triangles[0];
}

// Corner k of t lies on the centre of pixel (px, py), within the snapping.
void check_corner_on_pixel(const ScreenTriangleGpu& t, int k, int px, int py) {
    CHECK(std::abs(t.x.s[k] - (px * kSub + kSub / 2)) <= 1);
    CHECK(std::abs(t.y.s[k] - (py * kSub + kSub / 2)) <= 1);
}

// The real meshes centred in front of a camera at 512² (teapot 992, bunny 3674 triangles).
raster::Projection real_mesh_view(const std::string& file, const Vec3& rotate, raster::View* view_out) {
    *view_out = raster::camera_view(test::mesh_camera(), 512, 512);
    return raster::project_meshes({test::centred_mesh(file, rotate)}, *view_out);
}

}  // namespace

TEST_CASE("raster: kernel masks equal the per-pixel reference on random triangle soups", "[raster]") {
    std::mt19937 rng(1234);
    for (int round = 0; round < 3; ++round) {
        const int w = round == 0 ? 100 : 61 + 40 * round, h = round == 0 ? 75 : 37 + 50 * round;
        std::uniform_int_distribution<long> px(-30 * kSub, (w + 30) * kSub), py(-30 * kSub, (h + 30) * kSub);
        std::uniform_int_distribution<int> kind(0, 9), small(-12 * kSub, 12 * kSub), pix(0, std::max(w, h));
        // shared corners (a mesh-like soup); a third of them on pixel centres or pixel corners (ties)
        std::vector<std::array<long, 2>> corners;
        for (int i = 0; i < 300; ++i) {
            std::array<long, 2> c{px(rng), py(rng)};
            int k = kind(rng);
            if (k < 2) c = {pix(rng) * long(kSub) + kSub / 2, pix(rng) * long(kSub) + kSub / 2};
            else if (k < 3) c = {pix(rng) * long(kSub), pix(rng) * long(kSub)};
            corners.push_back(c);
        }
        std::uniform_int_distribution<std::size_t> pick(0, corners.size() - 1);
        std::vector<ScreenTriangleGpu> tris;
        for (int i = 0; i < 400; ++i) {
            auto a = corners[pick(rng)];
            int k = kind(rng);
            std::array<long, 2> b, c;
            if (k < 6) {  // small triangles near a
                b = {a[0] + small(rng), a[1] + small(rng)};
                c = {a[0] + small(rng), a[1] + small(rng)};
            } else if (k < 8) {  // large ones from shared corners
                b = corners[pick(rng)], c = corners[pick(rng)];
            } else if (k < 9) {  // collinear
                b = {a[0] + 3 * kSub, a[1] + kSub}, c = {a[0] + 9 * kSub, a[1] + 3 * kSub};
            } else {  // two coincident corners
                b = a, c = {a[0] + small(rng), a[1] + small(rng)};
            }
            tris.push_back(tri({a, b, c}, cl_uint(i)));
            if (k == 7) tris.push_back(tri({a, c, b}, cl_uint(i)));  // coincident duplicate, other winding
        }
        raster::Stats stats;
        auto kernel = run_kernel(tris, w, h, &stats);
        require_same(kernel, reference::tile_lists(tris, w, h));
        CHECK(stats.entries > 100);
    }
}

TEST_CASE("raster: the real teapot and bunny at 512² match the reference", "[raster][mesh]") {
    for (std::string file : {"meshes/teapot.obj", "meshes/bunny.obj"}) {
        raster::View view;
        auto proj = real_mesh_view(file, {-60.f, 20.f, 0.f}, &view);
        INFO(file);
        CHECK(proj.culled == 0);
        CHECK(proj.clipped == 0);
        CHECK(proj.triangles.size() == proj.source_triangles);
        raster::Stats stats;
        auto t0 = std::chrono::steady_clock::now();
        auto kernel = run_kernel(proj.triangles, 512, 512, &stats);
        double wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        require_same(kernel, reference::tile_lists(proj.triangles, 512, 512));
        std::printf("raster %s 512x512: %zu triangles, %zu entries in %zu chunks (%zu wasted slots, max %zu per tile), "
                    "count %.2f ms + write %.2f ms (kernels), %.1f ms with transfers\n",
                    file.c_str(), stats.triangles, stats.entries, stats.chunks, stats.wasted_slots,
                    stats.max_tile_entries, stats.count_ms, stats.write_ms, wall_ms);
        for (auto& t : proj.triangles)
            for (float c : t.depth_plane.s) REQUIRE(std::isfinite(c));
    }
}

TEST_CASE("raster: closed meshes cover every pixel an even number of times", "[raster][mesh]") {
    SECTION("bunny (closed: every edge in two triangles)") {
        raster::View view;
        auto proj = real_mesh_view("meshes/bunny.obj", {10.f, 70.f, 5.f}, &view);
        auto counts = counts_of(run_kernel(proj.triangles, 512, 512), 512, 512);
        std::size_t odd = 0, covered = 0;
        for (int c : counts) odd += c % 2, covered += c > 0;
        CHECK(odd == 0);
        CHECK(covered > 20000);
    }
    SECTION("UV sphere, perspective and orthographic") {
        MeshInstance mi;
        mi.mesh = std::make_shared<const Mesh>(make_uv_sphere(17, 29, 0.6f));
        mi.transform = make_transform({0.05f, -0.1f, 0.f}, {30.f, 10.f, 0.f}, {1, 1, 1});
        for (bool perspective : {true, false}) {
            raster::View v;
            v.origin = {0, 0, -3};
            v.perspective = perspective;
            v.extent_x = v.extent_y = perspective ? 0.3 : 0.8;
            v.width = 203, v.height = 131;
            auto proj = raster::project_meshes({mi}, v);
            auto counts = counts_of(run_kernel(proj.triangles, v.width, v.height), v.width, v.height);
            std::size_t odd = 0, twice = 0;
            for (int c : counts) odd += c % 2, twice += c == 2;
            CHECK(odd == 0);
            CHECK(twice > 5000);
            std::size_t back = 0;
            for (auto& t : proj.triangles) back += t.flags & SOMBRA_TRI_BACK_FACING;
            CHECK(back > proj.triangles.size() / 3);
            CHECK(back < proj.triangles.size() * 2 / 3);
        }
    }
}

TEST_CASE("raster: triangles sharing edges cover their union exactly once", "[raster]") {
    const int w = 64, h = 48;
    SECTION("two triangles, the shared edge through pixel centres") {
        // quad (2.5, 2.5) (50.3, 4.1) (42.5, 22.5) (5.2, 40.7); diagonal (2.5, 2.5)–(42.5, 22.5), slope ½
        std::array<long, 2> a{2 * kSub + kSub / 2, 2 * kSub + kSub / 2}, b{50 * kSub + 77, 4 * kSub + 26},
            c{42 * kSub + kSub / 2, 22 * kSub + kSub / 2}, d{5 * kSub + 51, 40 * kSub + 179};
        for (int flip = 0; flip < 2; ++flip) {
            std::vector<ScreenTriangleGpu> tris = {tri({a, b, c}, 0), flip ? tri({a, d, c}, 1) : tri({c, d, a}, 1)};
            auto kernel = run_kernel(tris, w, h);
            require_same(kernel, reference::tile_lists(tris, w, h));
            auto counts = counts_of(kernel, w, h);
            int on_diagonal = 0;
            for (int py = 0; py < h; ++py)
                for (int px = 0; px < w; ++px) {
                    int n = counts[std::size_t(py) * w + px];
                    REQUIRE(n <= 1);
                    // every centre strictly inside the (convex) quad is covered: no crack
                    double x = px + 0.5, y = py + 0.5;
                    auto side = [&](std::array<long, 2> p, std::array<long, 2> q) {
                        return (q[0] - p[0]) / double(kSub) * (y - p[1] / double(kSub)) -
                               (q[1] - p[1]) / double(kSub) * (x - p[0] / double(kSub));
                    };
                    bool inside = side(a, b) > 0 && side(b, c) > 0 && side(c, d) > 0 && side(d, a) > 0;
                    if (inside) REQUIRE(n == 1);
                    if (side(a, c) == 0 && inside) ++on_diagonal;
                }
            CHECK(on_diagonal >= 15);  // the tie case was exercised
        }
    }
    SECTION("a fan around a vertex on a pixel centre") {
        const long cx = 30 * kSub + kSub / 2, cy = 20 * kSub + kSub / 2;
        std::vector<std::array<long, 2>> rim;
        for (int k = 0; k < 11; ++k) {
            double phi = 2 * 3.14159265358979 * k / 11 + 0.1;
            double r = (k % 2 ? 15 : 19) * kSub;
            long x = cx + std::lround(r * std::cos(phi)), y = cy + std::lround(r * std::sin(phi));
            if (k % 3 == 0) x = (x / kSub) * kSub + kSub / 2, y = (y / kSub) * kSub + kSub / 2;  // rim on centres
            rim.push_back({x, y});
        }
        rim.push_back({cx + 12 * kSub, cy});  // a rim vertex level with the centre
        rim.push_back({cx, cy - 14 * kSub});  // and one straight above
        std::sort(rim.begin(), rim.end(), [&](auto& p, auto& q) {
            return std::atan2(double(p[1] - cy), double(p[0] - cx)) < std::atan2(double(q[1] - cy), double(q[0] - cx));
        });
        std::vector<ScreenTriangleGpu> tris;
        for (std::size_t k = 0; k < rim.size(); ++k) tris.push_back(tri({std::array<long, 2>{cx, cy}, rim[k], rim[(k + 1) % rim.size()]}, cl_uint(k)));
        auto kernel = run_kernel(tris, w, h);
        require_same(kernel, reference::tile_lists(tris, w, h));
        auto counts = counts_of(kernel, w, h);
        for (int c : counts) REQUIRE(c <= 1);
        CHECK(counts[20 * w + 30] == 1);  // the centre vertex itself: exactly one triangle owns it
        for (int py = 12; py <= 28; ++py)  // a disc well inside the rim: no crack
            for (int px = 22; px <= 38; ++px)
                if ((px - 30) * (px - 30) + (py - 20) * (py - 20) <= 64) REQUIRE(counts[std::size_t(py) * w + px] == 1);
    }
}

TEST_CASE("raster: degenerate, edge-on, off-screen and near-plane triangles", "[raster]") {
    raster::View v;
    v.origin = {0, 0, 0};
    v.extent_x = v.extent_y = 0.5;
    v.near_depth = 0.1;
    v.width = v.height = 40;
    MeshInstance mi;
    mi.mesh = mesh_of(
        {
            {-0.3f, -0.3f, 2}, {0.3f, -0.2f, 2}, {0.f, 0.3f, 2},    // 0–2 an ordinary triangle
            {0.1f, 0.1f, 1},                                       // 3
            {0.f, -0.2f, 1}, {0.f, -0.2f, 2}, {0.f, 0.2f, 4},      // 4–6 in the plane x = 0 through the eye
            {5.f, 5.f, 2}, {6.f, 5.f, 2}, {5.f, 6.f, 2},           // 7–9 beyond the guard band
            {0.f, 0.f, -1}, {0.2f, 0.f, -1}, {0.f, 0.2f, -1},      // 10–12 behind the eye
            {-0.2f, -0.2f, -1}, {0.2f, -0.1f, 3}, {0.f, 0.25f, 3},  // 13–15 crossing the near plane
            {1.4f, 0.f, 2}, {1.6f, 0.f, 2}, {1.5f, 0.2f, 2},        // 16–18 off-screen, inside the guard band
        },
        {{0, 1, 2}, {0, 1, 2}, {2, 1, 0},  // 0–2 coincident duplicates (both windings)
         {3, 3, 3}, {0, 0, 1}, {0, 1, 1},  // 3–5 corners coincide
         {0, 3, 1},                        // 6 a sliver (valid)
         {7, 8, 9}, {10, 11, 12},          // 7, 8 culled
         {13, 14, 15},                     // 9 clipped
         {4, 5, 6},                        // 10 edge-on
         {16, 17, 18}});                   // 11 off-screen, kept
    auto proj = raster::project_meshes({mi}, v);
    CHECK(proj.source_triangles == 12);
    CHECK(proj.triangles.size() >= 10);
    CHECK(proj.culled == 2);   // off-screen beyond the guard band, behind the eye
    CHECK(proj.clipped == 1);  // crossing the near plane
    for (auto& t : proj.triangles)
        for (float c : t.depth_plane.s) REQUIRE(std::isfinite(c));
    auto kernel = run_kernel(proj.triangles, v.width, v.height);
    require_same(kernel, reference::tile_lists(proj.triangles, v.width, v.height));
    std::map<cl_uint, std::size_t> pixels_of;  // source triangle → pixels covered
    for (auto& list : kernel)
        for (auto& [i, mask] : list) pixels_of[proj.triangles[i].source] += std::size_t(__builtin_popcountll(mask));
    CHECK(pixels_of[0] > 50);
    CHECK(pixels_of[0] == pixels_of[1]);
    CHECK(pixels_of[0] == pixels_of[2]);
    for (cl_uint zero : {3u, 4u, 5u, 10u, 11u}) CHECK(pixels_of.count(zero) == 0);  // zero-area, edge-on, off-screen
    CHECK(pixels_of[9] > 0);  // the clipped triangle's visible part
    auto counts = counts_of(kernel, v.width, v.height);
    for (int c : counts) CHECK(c < 8);
}

TEST_CASE("raster: projection follows the camera pass and DSM pixel conventions", "[raster]") {
    Camera cam;
    cam.position = {0.5f, 1.f, 3.f};
    cam.look_at = {0.f, 0.2f, 0.f};
    cam.fov_y_deg = 50.f;
    const int w = 64, h = 40;
    raster::View v = raster::camera_view(cam, w, h);
    // cl/render.cl: pixel (x, y) looks along forward + sx·right·tan·aspect + sy·up·tan
    auto point_of_pixel = [&](double x, double y, double dist) {
        double sx = (x + 0.5) / w * 2 - 1, sy = 1 - (y + 0.5) / h * 2;
        std::array<double, 3> d;
        for (int i = 0; i < 3; ++i)
            d[i] = v.axis_z[i] + sx * v.extent_x * v.axis_x[i] - sy * v.extent_y * v.axis_y[i];
        double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        return std::array<float, 3>{float(cam.position[0] + dist * d[0] / len), float(cam.position[1] + dist * d[1] / len),
                                    float(cam.position[2] + dist * d[2] / len)};
    };
    auto t = project_one({point_of_pixel(10, 7, 2.0), point_of_pixel(50, 9, 2.5), point_of_pixel(20, 33, 3.0)}, v);
    check_corner_on_pixel(t, 0, 10, 7);
    check_corner_on_pixel(t, 2, 20, 33);
    CHECK(reference::covers(t, 25, 15));
}

TEST_CASE("raster: clipped quads stay watertight (guard band, near plane)", "[raster]") {
    raster::View v;
    v.origin = {0, 1, 0};
    v.axis_y = {0, -1, 0};  // screen y down
    v.axis_z = {0, 0, 1};
    v.axis_x = {-1, 0, 0};
    v.extent_x = 0.6, v.extent_y = 0.4;
    v.near_depth = 0.05;
    v.width = 77, v.height = 53;
    SECTION("a huge wall in front: every pixel exactly once") {
        MeshInstance wall;
        wall.mesh = mesh_of({{-500, -300, 4}, {700, -400, 5}, {600, 500, 6}, {-400, 450, 3}, {1, 2, 4.5f}},
                            {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {4, 4, 0}});  // a fan around a point on screen
        auto proj = raster::project_meshes({wall}, v);
        CHECK(proj.clipped == 5);  // the degenerate one too
        CHECK(proj.culled == 0);
        auto counts = counts_of(run_kernel(proj.triangles, v.width, v.height), v.width, v.height);
        for (int c : counts) REQUIRE(c == 1);
    }
    SECTION("a ground plane through the near plane: below the horizon once, above never") {
        MeshInstance ground;
        ground.mesh = mesh_of({{-50, 0, -50}, {50, 0, -50}, {50, 0, 60}, {-50, 0, 60}, {0, 0, 3}},
                              {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}});  // a fan around a point ahead
        auto proj = raster::project_meshes({ground}, v);
        CHECK(proj.clipped >= 2);
        auto kernel = run_kernel(proj.triangles, v.width, v.height);
        require_same(kernel, reference::tile_lists(proj.triangles, v.width, v.height));
        auto counts = counts_of(kernel, v.width, v.height);
        for (int py = 0; py < v.height; ++py)
            for (int px = 0; px < v.width; ++px) {
                double ny = ((py + 0.5) / v.height * 2 - 1) * v.extent_y;  // ray direction's screen-down part
                // the plane y = 0 lies 1 below the eye; far rows below the horizon end within the quad
                int expected = ny > 0.03 ? 1 : (ny < 0 ? 0 : -1);
                if (expected >= 0) REQUIRE(counts[std::size_t(py) * v.width + px] == expected);
                else REQUIRE(counts[std::size_t(py) * v.width + px] <= 1);
            }
    }
}

TEST_CASE("raster: a DSM view's pixels are its texels, depths its ray distances", "[raster][segments]") {
    for (cl_uint perspective : {1u, 0u}) {
        DsmViewGpu d{};
        d.axis_x = {{0, 1, 0, 0}}, d.axis_y = {{0, 0, 1, 0}}, d.axis_z = {{1, 0, 0, 0}};
        d.origin = {{-3, 0.2f, 0.1f, 0}};
        d.extent_x = perspective ? 0.4f : 1.2f, d.extent_y = perspective ? 0.3f : 0.9f;
        d.resolution = 32, d.perspective = perspective, d.near_depth = 0.5f;
        raster::View v = raster::dsm_view(d);
        // cl/dsm_view.h dsm_view_ray for texel (x, y) at distance t
        auto on_ray = [&](double x, double y, double t) {
            double nx = (x + 0.5) / 32 * 2 - 1, ny = (y + 0.5) / 32 * 2 - 1;
            std::array<double, 3> across{0, nx * d.extent_x, ny * d.extent_y}, o{-3, 0.2, 0.1}, dir{1, 0, 0};
            if (perspective) {
                dir = {1, across[1], across[2]};
                double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
                for (auto& c : dir) c /= len;
            } else {
                for (int i = 0; i < 3; ++i) o[i] += across[i];
            }
            return std::array<float, 3>{float(o[0] + t * dir[0]), float(o[1] + t * dir[1]), float(o[2] + t * dir[2])};
        };
        auto t = project_one({on_ray(3, 4, 2.0), on_ray(28, 6, 2.5), on_ray(10, 29, 3.0)}, v);
        check_corner_on_pixel(t, 1, 28, 6);
        // the depth plane gives the ray distance at the corners (within the snapping error)
        double q = t.depth_plane.s[0];
        CHECK((perspective ? 1.0 / q * std::sqrt(1 + std::pow((3.5 / 16 - 1) * 0.4, 2) + std::pow((4.5 / 16 - 1) * 0.3, 2)) : q) ==
              Approx(2.0).epsilon(1e-3));
    }
}

TEST_CASE("raster: a crowded tile is never truncated (more than Knecht's 64 chunks)", "[raster]") {
    // 4500 triangles over a 16×12 screen: every tile holds 4500 entries = 71 chunks
    std::vector<ScreenTriangleGpu> tris;
    std::mt19937 rng(7);
    std::uniform_int_distribution<long> jitter(0, kSub - 1);
    for (int i = 0; i < 4500; ++i)
        tris.push_back(tri({std::array<long, 2>{-20 * kSub - jitter(rng), -10 * kSub}, {60 * kSub, -8 * kSub - jitter(rng)},
                            {-4 * kSub, 50 * kSub + jitter(rng)}},
                           cl_uint(i)));
    raster::Stats stats;
    auto kernel = run_kernel(tris, 16, 12, &stats);
    CHECK(stats.max_tile_entries == 4500);
    CHECK(stats.entries == 4 * 4500);
    CHECK(stats.chunks == 4 * 71);
    require_same(kernel, reference::tile_lists(tris, 16, 12));
    for (int c : counts_of(kernel, 16, 12)) CHECK(c == 4500);
}
