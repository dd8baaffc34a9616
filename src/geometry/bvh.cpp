#include "geometry/bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace sombra::bvh {
namespace {

struct Box {
    std::array<float, 3> lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::infinity()};
    std::array<float, 3> hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity()};
    void grow(const std::array<float, 3>& p) {
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
    }
    void grow(const Box& b) {
        grow(b.lo);
        grow(b.hi);
    }
    bool empty() const { return lo[0] > hi[0]; }
    double half_area() const {
        if (empty()) return 0.0;
        double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
        return dx * dy + dy * dz + dz * dx;
    }
};

struct Item {
    Box box;
    std::array<float, 3> centroid;
    std::uint32_t index;
};

constexpr int kBins = 12;
// SAH splits above this depth, median splits below: a tree over n triangles is at most
// kSahDepth + log2(n) deep (SOMBRA_BVH_MAX_DEPTH in cl/shared/types.h bounds the kernels' stack).
constexpr int kSahDepth = 32;

class Builder {
public:
    Builder(std::vector<Item>& items, unsigned leaf_size, Hierarchy& out) : items_(items), leaf_(leaf_size), out_(out) {}

    // Appends the subtree over items_[begin, end) depth first; returns its node index.
    std::uint32_t node(std::size_t begin, std::size_t end, int depth = 0) {
        std::uint32_t index = std::uint32_t(out_.nodes.size());
        out_.nodes.emplace_back();
        Box bounds, centroids;
        for (std::size_t i = begin; i < end; ++i) bounds.grow(items_[i].box), centroids.grow(items_[i].centroid);
        // deep down (a lopsided SAH tree), median splits: depth stays below SOMBRA_BVH_MAX_DEPTH
        std::size_t mid = end - begin <= leaf_ ? begin : split(begin, end, bounds, centroids, depth >= kSahDepth);
        BvhNodeGpu& n = out_.nodes[index];
        n.box_min = {{bounds.lo[0], bounds.lo[1], bounds.lo[2], 0.f}};
        n.box_max = {{bounds.hi[0], bounds.hi[1], bounds.hi[2], 0.f}};
        if (mid == begin) {  // leaf
            n.first = std::uint32_t(out_.order.size());
            n.count = std::uint32_t(end - begin);
            for (std::size_t i = begin; i < end; ++i) out_.order.push_back(items_[i].index);
            return index;
        }
        node(begin, mid, depth + 1);
        std::uint32_t second = node(mid, end, depth + 1);
        out_.nodes[index].first = second;  // (the vector may have moved: index again)
        out_.nodes[index].count = 0;
        return index;
    }

private:
    // Partitions [begin, end) at the cheapest of the binned SAH planes; a leaf (returns begin)
    // when no plane beats testing every triangle and they fit in a leaf, else the median.
    std::size_t split(std::size_t begin, std::size_t end, const Box& bounds, const Box& centroids, bool median) {
        std::size_t count = end - begin;
        double best_cost = std::numeric_limits<double>::infinity();
        int best_axis = -1, best_plane = 0;
        for (int axis = 0; axis < 3 && !median; ++axis) {
            float lo = centroids.lo[axis], extent = centroids.hi[axis] - lo;
            if (!(extent > 0.f)) continue;
            std::array<Box, kBins> bins;
            std::array<std::size_t, kBins> in_bin{};
            for (std::size_t i = begin; i < end; ++i) {
                int b = bin_of(items_[i].centroid[axis], lo, extent);
                bins[b].grow(items_[i].box);
                ++in_bin[b];
            }
            // sweep: left areas and counts from the front, then the right side from the back
            std::array<double, kBins> left_area{};
            std::array<std::size_t, kBins> left_count{};
            Box left;
            std::size_t n = 0;
            for (int b = 0; b < kBins - 1; ++b) {
                left.grow(bins[b]), n += in_bin[b];
                left_area[b] = left.half_area(), left_count[b] = n;
            }
            Box right;
            std::size_t m = 0;
            for (int b = kBins - 1; b > 0; --b) {
                right.grow(bins[b]), m += in_bin[b];
                if (left_count[b - 1] == 0 || m == 0) continue;
                double cost = left_area[b - 1] * double(left_count[b - 1]) + right.half_area() * double(m);
                if (cost < best_cost) best_cost = cost, best_axis = axis, best_plane = b;
            }
        }
        double leaf_cost = bounds.half_area() * double(count);
        if (best_axis < 0 || !(best_cost < leaf_cost)) {
            if (count <= leaf_ && !median) return begin;
            // all centroids in one bin or no gain: split at the median of the widest centroid axis
            int axis = 0;
            for (int a = 1; a < 3; ++a)
                if (centroids.hi[a] - centroids.lo[a] > centroids.hi[axis] - centroids.lo[axis]) axis = a;
            std::size_t mid = begin + count / 2;
            std::nth_element(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(mid),
                             items_.begin() + std::ptrdiff_t(end),
                             [axis](const Item& a, const Item& b) { return a.centroid[axis] < b.centroid[axis]; });
            return mid;
        }
        float lo = centroids.lo[best_axis], extent = centroids.hi[best_axis] - lo;
        auto middle = std::partition(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(end),
                                     [&](const Item& it) { return bin_of(it.centroid[best_axis], lo, extent) < best_plane; });
        return std::size_t(middle - items_.begin());
    }

    static int bin_of(float c, float lo, float extent) {
        return std::min(kBins - 1, std::max(0, int(float(kBins) * (c - lo) / extent)));
    }

    std::vector<Item>& items_;
    std::size_t leaf_;
    Hierarchy& out_;
};

}  // namespace

Hierarchy build(const std::vector<SurfaceTriangleGpu>& triangles, unsigned leaf_size) {
    Hierarchy h;
    if (triangles.empty()) return h;
    std::vector<Item> items(triangles.size());
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        const SurfaceTriangleGpu& t = triangles[i];
        Item& it = items[i];
        for (const cl_float4* c : {&t.corner, &t.corner1, &t.corner2}) it.box.grow(std::array<float, 3>{c->s[0], c->s[1], c->s[2]});
        // padded a little, so that float rounding in the kernels' slab test never misses a triangle
        // lying in a box face (a flat wall's box has no thickness)
        float scale = 1.f;
        for (int a = 0; a < 3; ++a) scale = std::max({scale, std::abs(it.box.lo[a]), std::abs(it.box.hi[a])});
        for (int a = 0; a < 3; ++a) it.box.lo[a] -= 1e-5f * scale, it.box.hi[a] += 1e-5f * scale;
        for (int a = 0; a < 3; ++a) it.centroid[a] = 0.5f * (it.box.lo[a] + it.box.hi[a]);
        it.index = std::uint32_t(i);
    }
    h.nodes.reserve(2 * triangles.size());
    h.order.reserve(triangles.size());
    Builder(items, std::max(1u, leaf_size), h).node(0, items.size());
    return h;
}

std::vector<SurfaceTriangleGpu> reorder(const std::vector<SurfaceTriangleGpu>& triangles, const Hierarchy& h) {
    std::vector<SurfaceTriangleGpu> out;
    out.reserve(h.order.size());
    for (std::uint32_t i : h.order) out.push_back(triangles[i]);
    return out;
}

}  // namespace sombra::bvh
