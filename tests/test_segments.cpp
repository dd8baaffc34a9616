// The fragment stage (cl/segments.cl, Knecht §3.1.2): per pixel the covering triangles sorted by
// depth, against the per-pixel reference (ray–plane depths in double) and a sphere's analytic depths.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "reference/raster_ref.h"
#include "geometry/fragments.h"
#include "test_support.h"

using namespace sombra;

namespace {

host::Runtime& rt() { return test::context().runtime(); }

raster::HostFragments run(const raster::Projection& proj, const raster::View& view) {
    auto tiles = raster::rasterize(rt(), proj.triangles, raster::make_screen(view));
    auto screen = tiles.screen;
    return raster::read_back(rt(), raster::sort_fragments(rt(), tiles), screen);
}

// Kernel lists == reference lists as sets of triangles, sorted, and depths as close as snapping
// the corners to 1/256 pixel allows: the snapped plane's q is off by ≤ |∇q|₁ / 512 inside the
// triangle (allowed: twice that, in depth units, plus 1e-5 relative for float arithmetic).
void require_matches_reference(const raster::HostFragments& k, const std::vector<std::vector<reference::Fragment>>& ref,
                               const raster::Projection& proj, bool perspective) {
    REQUIRE(k.first.size() == ref.size() + 1);
    std::size_t wrong_sets = 0, unsorted = 0, total = 0;
    double worst = 0;  // error / allowed error
    for (std::size_t p = 0; p < ref.size(); ++p) {
        std::vector<std::pair<std::uint32_t, double>> a, b;
        for (auto i = k.first[p]; i < k.first[p + 1]; ++i) {
            const FragmentGpu& f = k.fragments[i];
            if (i > k.first[p] && f.depth < k.fragments[i - 1].depth) ++unsorted;
            a.push_back({f.triangle, f.depth});
        }
        for (auto& f : ref[p]) b.push_back({f.triangle, f.depth});
        std::sort(a.begin(), a.end()), std::sort(b.begin(), b.end());
        total += b.size();
        if (a.size() != b.size()) { ++wrong_sets; continue; }
        for (std::size_t j = 0; j < a.size(); ++j) {
            if (a[j].first != b[j].first) { ++wrong_sets; break; }
            const auto& plane = proj.triangles[a[j].first].depth_plane.s;
            double depth = b[j].second, dq = (std::abs(plane[1]) + std::abs(plane[2])) / 256.0;
            double allowed = 1e-5 * std::abs(depth) + dq * (perspective ? depth * depth : 1.0);
            worst = std::max(worst, std::abs(a[j].second - depth) / allowed);
        }
    }
    INFO(total << " fragments; " << wrong_sets << " pixels with other triangles, " << unsorted
               << " unsorted pairs, worst depth error / allowed " << worst);
    CHECK(k.stats.fragments == total);
    CHECK(wrong_sets == 0);
    CHECK(unsorted == 0);
    CHECK(worst <= 1.0);
}

}  // namespace

TEST_CASE("segments: sorted fragments of the teapot and bunny match the reference", "[segments][mesh]") {
    for (std::string file : {"meshes/teapot.obj", "meshes/bunny.obj"}) {
        INFO(file);
        MeshInstance mi = test::centred_mesh(file, {-60.f, 20.f, 0.f});
        auto world = reference::world_triangles({mi});
        raster::View persp = raster::camera_view(test::mesh_camera(), 512, 512), ortho;
        ortho.origin = {0.1, 0.2, -2};
        ortho.perspective = false;
        ortho.extent_x = 0.7, ortho.extent_y = 0.5;
        ortho.width = 300, ortho.height = 213;
        for (const raster::View& view : {persp, ortho}) {
            auto proj = raster::project_meshes({mi}, view);
            auto k = run(proj, view);
            require_matches_reference(k, reference::fragments(proj.triangles, world, view), proj, view.perspective);
            if (view.perspective)
                std::printf("segments %s 512x512: %zu fragments (max %zu per pixel), count %.2f ms + sort %.2f ms (kernels)\n",
                            file.c_str(), k.stats.fragments, k.stats.max_per_pixel, k.stats.count_ms, k.stats.write_ms);
        }
    }
}

TEST_CASE("segments: a sphere's fragments are its front and back at the analytic depths", "[segments]") {
    const double radius = 0.6;
    MeshInstance mi;
    mi.mesh = std::make_shared<const Mesh>(make_uv_sphere(48, 96, float(radius)));
    raster::View v;
    v.origin = {0.1, -0.05, -2.5};
    v.extent_x = v.extent_y = 0.3;
    v.width = v.height = 160;
    auto proj = raster::project_meshes({mi}, v);
    auto k = run(proj, v);
    std::size_t checked = 0;
    for (int py = 0; py < v.height; ++py)
        for (int px = 0; px < v.width; ++px) {
            std::size_t p = std::size_t(py) * v.width + px, n = k.first[p + 1] - k.first[p];
            // the ray through the pixel centre; distance of the sphere centre from it
            double d[3] = {((px + 0.5) / v.width * 2 - 1) * v.extent_x, ((py + 0.5) / v.height * 2 - 1) * v.extent_y, 1};
            double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            double oc[3] = {-v.origin[0], -v.origin[1], -v.origin[2]};
            double along = (oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2]) / len;
            double miss2 = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - along * along;
            REQUIRE(n % 2 == 0);
            REQUIRE(n <= 2);  // convex
            if (miss2 > 0.8 * 0.8 * radius * radius) continue;  // keep away from the silhouette
            REQUIRE(n == 2);
            const FragmentGpu& front = k.fragments[k.first[p]];
            const FragmentGpu& back = k.fragments[k.first[p] + 1];
            CHECK((proj.triangles[front.triangle].flags & SOMBRA_TRI_BACK_FACING) == 0);
            CHECK((proj.triangles[back.triangle].flags & SOMBRA_TRI_BACK_FACING) != 0);
            double half = std::sqrt(radius * radius - miss2);
            CHECK(front.depth == Approx(along - half).epsilon(2e-3));
            CHECK(back.depth == Approx(along + half).epsilon(2e-3));
            ++checked;
        }
    CHECK(checked > 5000);
}

TEST_CASE("segments: no triangles, no fragments", "[segments]") {
    raster::View v;
    v.width = 20, v.height = 9;
    auto k = run(raster::Projection{}, v);
    CHECK(k.stats.fragments == 0);
    CHECK(std::all_of(k.first.begin(), k.first.end(), [](cl_uint f) { return f == 0; }));
}
