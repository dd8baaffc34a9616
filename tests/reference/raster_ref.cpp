#include "reference/raster_ref.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace sombra::reference {
namespace {

// Sign of a lexicographic triple: the first non-zero entry decides.
int lex_sign(std::int64_t a, std::int64_t b, std::int64_t c) {
    std::int64_t v = a != 0 ? a : (b != 0 ? b : c);
    return (v > 0) - (v < 0);
}

}  // namespace

bool covers(const ScreenTriangleGpu& t, int px, int py) {
    const std::int64_t x[3] = {t.x.s[0], t.x.s[1], t.x.s[2]}, y[3] = {t.y.s[0], t.y.s[1], t.y.s[2]};
    const std::int64_t area2 = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if (area2 == 0) return false;
    const std::int64_t s = area2 > 0 ? 1 : -1;
    const std::int64_t half = 1 << (SOMBRA_SUBPIXEL_BITS - 1);
    const std::int64_t cx = (std::int64_t(px) << SOMBRA_SUBPIXEL_BITS) + half;
    const std::int64_t cy = (std::int64_t(py) << SOMBRA_SUBPIXEL_BITS) + half;
    for (int e = 0; e < 3; ++e) {
        int a = e, b = (e + 1) % 3;
        std::int64_t dx = x[b] - x[a], dy = y[b] - y[a];
        std::int64_t E = dx * (cy - y[a]) - dy * (cx - x[a]);
        // E(P + δ) = E + ε·dy − ε²·dx for δ = (−ε, −ε²); inside: s·E(P + δ) > 0
        if (lex_sign(s * E, s * dy, -s * dx) <= 0) return false;
    }
    return true;
}

namespace {

// Calls f(px, py) for every pixel the triangle covers (pixels of the corners' box, one pixel more
// on each side, tested one by one).
template <typename F>
void for_each_covered(const ScreenTriangleGpu& t, int width, int height, F&& f) {
    auto lo = [](const cl_int4& v) { return std::min({v.s[0], v.s[1], v.s[2]}) >> SOMBRA_SUBPIXEL_BITS; };
    auto hi = [](const cl_int4& v) { return std::max({v.s[0], v.s[1], v.s[2]}) >> SOMBRA_SUBPIXEL_BITS; };
    int x0 = std::max(0, lo(t.x) - 1), x1 = std::min(width - 1, hi(t.x) + 1);
    int y0 = std::max(0, lo(t.y) - 1), y1 = std::min(height - 1, hi(t.y) + 1);
    for (int py = y0; py <= y1; ++py)
        for (int px = x0; px <= x1; ++px)
            if (covers(t, px, py)) f(px, py);
}

}  // namespace

std::vector<TileList> tile_lists(const std::vector<ScreenTriangleGpu>& triangles, int width, int height) {
    const int tn = SOMBRA_TILE_SIZE, tiles_x = (width + tn - 1) / tn, tiles_y = (height + tn - 1) / tn;
    std::vector<TileList> lists(std::size_t(tiles_x) * std::size_t(tiles_y));
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        std::map<std::size_t, std::uint64_t> masks;
        for_each_covered(triangles[i], width, height, [&](int px, int py) {
            masks[std::size_t(py / tn) * tiles_x + px / tn] |= std::uint64_t(1) << ((py % tn) * tn + px % tn);
        });
        for (auto& [tile, mask] : masks) lists[tile].push_back({std::uint32_t(i), mask});
    }
    for (auto& l : lists) std::sort(l.begin(), l.end());
    return lists;
}

std::vector<int> coverage_counts(const std::vector<ScreenTriangleGpu>& triangles, int width, int height) {
    std::vector<int> counts(std::size_t(width) * std::size_t(height), 0);
    for (const auto& t : triangles)
        for_each_covered(t, width, height, [&](int px, int py) { ++counts[std::size_t(py) * width + px]; });
    return counts;
}

}  // namespace sombra::reference

namespace sombra::reference {

std::vector<WorldTriangle> world_triangles(const std::vector<MeshInstance>& meshes) {
    std::vector<WorldTriangle> out;
    for (const auto& mi : meshes)
        for (const auto& t : mi.mesh->triangles) {
            WorldTriangle w;
            for (int k = 0; k < 3; ++k) {
                const auto& p = mi.mesh->positions[t[k]];
                const auto& m = mi.transform;
                for (int r = 0; r < 3; ++r)
                    w[k][r] = double(m[r * 4]) * p[0] + double(m[r * 4 + 1]) * p[1] + double(m[r * 4 + 2]) * p[2] + m[r * 4 + 3];
            }
            out.push_back(w);
        }
    return out;
}

std::vector<std::vector<Fragment>> fragments(const std::vector<ScreenTriangleGpu>& triangles,
                                             const std::vector<WorldTriangle>& world, const raster::View& view) {
    using V = std::array<double, 3>;
    auto sub = [](const V& a, const V& b) { return V{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
    auto dot = [](const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    const int w = view.width, h = view.height;
    std::vector<std::vector<Fragment>> out(std::size_t(w) * h);
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        const WorldTriangle& c = world[triangles[i].source];
        V e1 = sub(c[1], c[0]), e2 = sub(c[2], c[0]);
        V n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for_each_covered(triangles[i], w, h, [&](int px, int py) {
            double nx = ((px + 0.5) / w * 2 - 1) * view.extent_x, ny = ((py + 0.5) / h * 2 - 1) * view.extent_y;
            V across{nx * view.axis_x[0] + ny * view.axis_y[0], nx * view.axis_x[1] + ny * view.axis_y[1],
                     nx * view.axis_x[2] + ny * view.axis_y[2]};
            V o = view.origin, d = view.axis_z;
            if (view.perspective) {
                d = {d[0] + across[0], d[1] + across[1], d[2] + across[2]};
                double len = std::sqrt(dot(d, d));
                d = {d[0] / len, d[1] / len, d[2] / len};
            } else {
                o = {o[0] + across[0], o[1] + across[1], o[2] + across[2]};
            }
            out[std::size_t(py) * w + px].push_back({dot(n, sub(c[0], o)) / dot(n, d), std::uint32_t(i)});
        });
    }
    for (auto& f : out)
        std::sort(f.begin(), f.end(), [](const Fragment& a, const Fragment& b) { return a.depth < b.depth; });
    return out;
}

}  // namespace sombra::reference
