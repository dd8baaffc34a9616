#include "sombra/transfer_function.h"

#include <algorithm>
#include <cmath>

#include "sombra/error.h"

namespace sombra {
namespace {

// Piecewise-linear interpolation over points sorted by x, clamped at both ends.
template <typename Point, typename Value>
Value interpolate(const std::vector<Point>& points, float x, Value (*value)(const Point&)) {
    if (x <= points.front().x) return value(points.front());
    if (!(x < points.back().x)) return value(points.back());  // also NaN: upper_bound would find end()
    auto upper = std::upper_bound(points.begin(), points.end(), x, [](float v, const Point& p) { return v < p.x; });
    const Point& b = *upper;
    const Point& a = *(upper - 1);
    // in double: b.x - a.x overflows float for points near ±3.4e38
    const float f = b.x > a.x ? float((double(x) - a.x) / (double(b.x) - a.x)) : 1.f;
    Value va = value(a), vb = value(b);
    return va + (vb - va) * f;
}

struct Rgb {
    float r, g, b;
    Rgb operator+(const Rgb& o) const { return {r + o.r, g + o.g, b + o.b}; }
    Rgb operator-(const Rgb& o) const { return {r - o.r, g - o.g, b - o.b}; }
    Rgb operator*(float f) const { return {r * f, g * f, b * f}; }
};

Rgb rgb_of(const TransferFunction::ColorPoint& p) { return {p.r, p.g, p.b}; }
float alpha_of(const TransferFunction::OpacityPoint& p) { return p.alpha; }

}  // namespace

std::array<float, 3> TransferFunction::color(float x) const {
    Rgb c = interpolate(color_points, x, rgb_of);
    return {c.r, c.g, c.b};
}

float TransferFunction::opacity(float x) const { return interpolate(opacity_points, x, alpha_of); }

float TransferFunction::domain_min() const { return std::min(color_points.front().x, opacity_points.front().x); }
float TransferFunction::domain_max() const { return std::max(color_points.back().x, opacity_points.back().x); }

std::vector<std::array<float, 4>> TransferFunction::table(int size, float opacity_unit) const {
    std::vector<std::array<float, 4>> out(std::size_t(std::max(size, 2)));
    float lo = domain_min(), hi = domain_max();
    const float max_sigma = -std::log(1e-6f) / opacity_unit;
    for (std::size_t i = 0; i < out.size(); ++i) {
        const float x = hi > lo ? float(lo + (double(hi) - lo) * double(i) / double(out.size() - 1)) : lo;
        auto c = color(x);
        float alpha = std::clamp(opacity(x), 0.f, 1.f);
        float sigma = alpha >= 1.f ? max_sigma : std::min(max_sigma, -std::log1p(-alpha) / opacity_unit);
        out[i] = {c[0], c[1], c[2], sigma};
    }
    return out;
}

void TransferFunction::validate(const std::string& where) const {
    if (color_points.empty()) throw Error(where + ".rgb_points: needs at least one point");
    if (opacity_points.empty()) throw Error(where + ".opacity_points: needs at least one point");
    auto in_unit = [](float v) { return std::isfinite(v) && v >= 0.f && v <= 1.f; };
    for (std::size_t i = 0; i < color_points.size(); ++i) {
        const auto& p = color_points[i];
        std::string field = where + ".rgb_points[" + std::to_string(i) + "]";
        if (!std::isfinite(p.x)) throw Error(field + ": value is not finite");
        if (!in_unit(p.r) || !in_unit(p.g) || !in_unit(p.b)) throw Error(field + ": colour must lie in [0, 1]");
        if (i > 0 && p.x < color_points[i - 1].x) throw Error(field + ": points must be sorted by value");
    }
    for (std::size_t i = 0; i < opacity_points.size(); ++i) {
        const auto& p = opacity_points[i];
        std::string field = where + ".opacity_points[" + std::to_string(i) + "]";
        if (!std::isfinite(p.x)) throw Error(field + ": value is not finite");
        if (!in_unit(p.alpha)) throw Error(field + ": opacity must lie in [0, 1]");
        if (i > 0 && p.x < opacity_points[i - 1].x) throw Error(field + ": points must be sorted by value");
    }
}

}  // namespace sombra
