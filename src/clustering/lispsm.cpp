#include "clustering/lispsm.h"

#include <algorithm>
#include <cmath>

namespace sombra::clustering {
namespace {

constexpr double kMinSinGamma = 0.01;  // below: the light runs (nearly) along the view; no warp
constexpr double kMaxWarpRatio = 1e4;  // n / d above this warps by less than 0.01 %: no warp

// Unit vector perpendicular to `axis` (unit).
Point any_perpendicular(const Point& axis) {
    const Point helper = std::fabs(axis.y) < 0.9 ? Point(0, 1, 0) : Point(1, 0, 0);
    return glm::normalize(glm::cross(helper, axis));
}

// Widens [lo, hi] to at least `minimum` so that divisions by the extent stay finite.
void widen(double& lo, double& hi, double minimum) {
    if (hi - lo >= minimum) return;
    const double middle = 0.5 * (lo + hi);
    lo = middle - 0.5 * minimum, hi = middle + 0.5 * minimum;
}

}  // namespace

ConvexBody CameraView::body() const {
    return frustum_body(eye, forward, up, tan_half_y * aspect, tan_half_y, near, far);
}

void LightView::frame(Point& x, Point& y, Point& z) const {
    z = glm::normalize(forward);
    x = any_perpendicular(z);
    y = glm::cross(z, x);
}

std::vector<Plane> LightView::planes() const {
    if (!perspective) return {};
    Point x, y, z;
    frame(x, y, z);
    std::vector<Plane> out;
    for (const Point& side : {x, -x, y, -y}) {
        const Point normal = glm::normalize(side - tan_half * z);  // dot(side, q) <= tan_half · dot(z, q)
        out.push_back({normal, glm::dot(normal, position)});
    }
    out.push_back({-z, -glm::dot(z, position) - near});
    return out;
}

Point LightView::to_parallel(const Point& world) const {
    if (!perspective) return world;
    Point x, y, z;
    frame(x, y, z);
    const Point d = world - position;
    const double depth = std::max(glm::dot(d, z), near);
    return {glm::dot(d, x) / (depth * tan_half), glm::dot(d, y) / (depth * tan_half), 1.0 - near / depth};
}

ConvexBody convex_body_B(const CameraView& camera, const LightView& light, const Point& scene_lo, const Point& scene_hi) {
    const ConvexBody V = camera.body();
    ConvexBody M;
    if (light.perspective) {
        M = hull_with_point(V, light.position);
    } else {  // the light's position is at infinity: sweep V towards it until past the scene box
        const double reach = 2 * (glm::length(scene_hi - scene_lo) + glm::length(camera.eye - 0.5 * (scene_lo + scene_hi)) + camera.far);
        M = sweep(V, -glm::normalize(light.forward) * reach);
    }
    return clip(clip(M, box_planes(scene_lo, scene_hi)), light.planes());
}

Point Lispsm::light_space(const Point& world) const {
    const Point p = light.to_parallel(world);
    return {glm::dot(p, axis_x), glm::dot(p, axis_y), glm::dot(p, axis_z)};
}

Point Lispsm::apply(const Point& world) const {
    const Point p = light_space(world);
    if (!warped)  // uniform: B's light-space box to [−1, 1]³
        return {2 * (p.x - lo.x) / (hi.x - lo.x) - 1, 2 * (p.z - lo.z) / (hi.z - lo.z) - 1, 2 * (hi.y - p.y) / (hi.y - lo.y) - 1};
    const Point r = p - projection_centre;
    const double depth = std::max(r.z, n);
    const double on_near_x = r.x * n / depth, on_near_y = r.y * n / depth;
    const double X = (2 * on_near_x - (right + left)) / (right - left);
    const double Y = (2 * on_near_y - (top + bottom)) / (top - bottom);
    const double Z = ((f + n) - 2 * f * n / depth) / (f - n);  // n → −1, f → 1
    return {X, Z, -Y};
}

Lispsm make_lispsm(const ConvexBody& B, const CameraView& camera, const LightView& light) {
    Lispsm t;
    t.light = light;
    const std::vector<Point> corners = B.vertices();
    const Point centroid = B.centroid();
    const Point view = glm::normalize(camera.forward);
    const Point light_dir = light.perspective ? glm::normalize(centroid - light.position) : glm::normalize(light.forward);
    t.sin_gamma = glm::length(glm::cross(view, light_dir));

    // Light space in the parallel space: y against the light, z the view made perpendicular to it.
    // A perspective light carries the view direction at B's centroid through its projection.
    Point view_parallel = view;
    if (light.perspective) {
        Point x, y, z;
        light.frame(x, y, z);
        const double step = 1e-4 * glm::dot(centroid - light.position, z);
        view_parallel = light.to_parallel(centroid + step * view) - light.to_parallel(centroid);
    }
    const Point light_parallel = light.perspective ? Point(0, 0, 1) : light_dir;
    t.axis_y = -light_parallel;
    const Point across = view_parallel - glm::dot(view_parallel, t.axis_y) * t.axis_y;
    const double sin_parallel = glm::length(view_parallel) > 0 ? glm::length(across) / glm::length(view_parallel) : 0.0;
    t.axis_z = sin_parallel > 1e-9 ? glm::normalize(across) : any_perpendicular(t.axis_y);
    t.axis_x = glm::cross(t.axis_y, t.axis_z);

    t.lo = Point(INFINITY), t.hi = Point(-INFINITY);
    for (const Point& c : corners) {
        const Point p = t.light_space(c);
        t.lo = glm::min(t.lo, p), t.hi = glm::max(t.hi, p);
    }
    const double span = std::max(1e-12, glm::length(t.hi - t.lo));
    widen(t.lo.x, t.hi.x, 1e-9 * span), widen(t.lo.y, t.hi.y, 1e-9 * span), widen(t.lo.z, t.hi.z, 1e-9 * span);

    if (t.sin_gamma < kMinSinGamma || sin_parallel < kMinSinGamma) return t;  // uniform

    // n_opt in world units, from B's depths along the view (Wimmer 2004 §5.2, with 1 / sin γ)
    double z_near = INFINITY, z_far = -INFINITY, d_lo = INFINITY, d_hi = -INFINITY;
    const Point world_z = glm::normalize(view - glm::dot(view, light_dir) * light_dir);
    for (const Point& c : corners) {
        const double depth = glm::dot(c - camera.eye, view);
        z_near = std::min(z_near, depth), z_far = std::max(z_far, depth);
        d_lo = std::min(d_lo, glm::dot(c, world_z)), d_hi = std::max(d_hi, glm::dot(c, world_z));
    }
    z_near = std::max(z_near, camera.near);
    z_far = std::max(z_far, z_near);
    const double n_world = (z_near + std::sqrt(z_far * z_near)) / t.sin_gamma;
    const double ratio = n_world / std::max(d_hi - d_lo, 1e-300);
    if (!(ratio <= kMaxWarpRatio)) return t;  // uniform

    const double d = t.hi.z - t.lo.z;
    t.n = ratio * d, t.f = t.n + d;
    // P's centre of projection: the eye's x (clamped to B; the middle of B when the eye lies behind
    // a perspective light), B's middle in y, n before B's near plane
    double centre_x = 0.5 * (t.lo.x + t.hi.x);
    Point lx, ly, lz;
    light.frame(lx, ly, lz);
    if (!light.perspective || glm::dot(camera.eye - light.position, lz) >= light.near)
        centre_x = std::clamp(t.light_space(camera.eye).x, t.lo.x, t.hi.x);
    t.projection_centre = Point(centre_x, 0.5 * (t.lo.y + t.hi.y), t.lo.z - t.n);
    t.left = t.bottom = INFINITY, t.right = t.top = -INFINITY;
    for (const Point& c : corners) {
        const Point r = t.light_space(c) - t.projection_centre;
        const double x = r.x * t.n / r.z, y = r.y * t.n / r.z;
        t.left = std::min(t.left, x), t.right = std::max(t.right, x);
        t.bottom = std::min(t.bottom, y), t.top = std::max(t.top, y);
    }
    widen(t.left, t.right, 1e-9 * span), widen(t.bottom, t.top, 1e-9 * span);
    t.warped = true;
    return t;
}

}  // namespace sombra::clustering
