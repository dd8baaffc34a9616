#include "reference/raster_ref.h"

#include <algorithm>
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
