// sombra — light space perspective shadow maps (Wimmer, Scherzer, Purgathofer 2004, "Light Space
// Perspective Shadow Maps"; Knecht §2.4.2 and §4.5) as the clustering of Knecht §3.4.1 uses them:
// the body B (Alg. 4.3) and the transform of world points into LiSPSM's post-perspective space.
#pragma once
#include <vector>

#include "clustering/convex_body.h"

namespace sombra::clustering {

// The camera's view frustum V (the scene has no near/far planes: see camera_view in clustering.h).
struct CameraView {
    Point eye{0, 0, 3}, forward{0, 0, -1}, up{0, 1, 0};
    double tan_half_y = 0.364, aspect = 1;  // tan(fov_y / 2); width / height
    double near = 0.01, far = 10;
    ConvexBody body() const;
};

// One view of a light (Knecht Alg. 4.2 line 1): a spot light's cone as a square pyramid, one of a
// point light's six cube faces, or a directional light (parallel rays along `forward`).
struct LightView {
    bool perspective = false;
    Point position{0, 0, 0};  // the apex (perspective)
    Point forward{0, 0, -1};  // the direction light travels along the view's axis
    double tan_half = 1;      // perspective: tangent of the half angle, in x and in y
    double near = 0;          // perspective: B and the objects are cut here, off the apex
    // The light frustum L: four sides and the near plane (none for a directional light).
    std::vector<Plane> planes() const;
    // The light's own projection, after which its rays are parallel to +z (Wimmer 2004 §4.3: a
    // point light becomes a directional one): (x/z, y/z in units of tan_half, 1 − near/z) in the
    // view's frame. A directional light: the identity. Points nearer than the near plane are moved
    // onto it (B and the clipped objects have none).
    Point to_parallel(const Point& world) const;
    // Orthonormal frame of the view: x, y across, z = forward (up hint world y, or x when parallel).
    void frame(Point& x, Point& y, Point& z) const;
};

// B = M ∩ S ∩ L (Knecht §2.4.2, Alg. 4.3): M the convex hull of V and the light's position; for a
// directional light V swept towards the light past the scene box S. Empty when they do not meet.
ConvexBody convex_body_B(const CameraView& camera, const LightView& light, const Point& scene_lo, const Point& scene_hi);

// The LiSPSM transform of one light view. Formulation (Wimmer et al. 2004 §3-4, as Knecht §2.4.2
// summarises it), applied after the light's own projection LightView::to_parallel:
//  - light space: y = the inverse light direction, z = the view direction at B's centroid made
//    perpendicular to y, x = y × z;
//  - P: a perspective looking along +z whose near and far planes bound B in z, centre of
//    projection at x = the eye's x (clamped to B), y = the middle of B in y, n before B's near plane;
//    its sides bound B's projection on the near plane;
//  - n: Wimmer's n_opt = (z_n + √(z_f·z_n)) / sin γ in world units (z_n, z_f: B's nearest and
//    farthest depth along the camera's view, z_n at least the camera's near; γ: the angle between
//    the view and light directions), carried into the light's projected space as the ratio n / d
//    (d: the depth of B along light-space z), which is what sets the warp;
//  - uniform fallback: when sin γ < 0.01 (light along the view direction) or n / d > 10⁴, P is
//    replaced by the orthographic box around B in light space (no warp, no division by ~0).
// apply() maps to (map x, map y, depth): map x, y ∈ [−1, 1] over B (P's post-perspective x and z:
// the shadow map plane), depth = P's post-perspective −y, growing away from the light.
struct Lispsm {
    LightView light;
    bool warped = false;                // false: the uniform (orthographic) fallback
    double sin_gamma = 0;               // in world space
    Point axis_x{1, 0, 0}, axis_y{0, 1, 0}, axis_z{0, 0, 1};  // light space, in the parallel space
    Point lo{-1, -1, -1}, hi{1, 1, 1};  // B's extents in light space
    Point projection_centre{0, 0, 0};   // P's, in light space (warped)
    double n = 1, f = 2;                // P's near and far distances from its centre (warped)
    double left = -1, right = 1, bottom = -1, top = 1;  // P's sides on its near plane (warped)

    Point light_space(const Point& world) const;  // before P
    // Points of B (or of bodies clipped to B) map into [−1, 1]³; a point nearer to P's centre of
    // projection than its near plane (B has none) is moved onto that plane first, so every finite
    // input gives a finite output.
    Point apply(const Point& world) const;
};

// Expects a non-empty B.
Lispsm make_lispsm(const ConvexBody& B, const CameraView& camera, const LightView& light);

}  // namespace sombra::clustering
