// sombra — convex polyhedra as lists of polygons, clipped by planes (Knecht Alg. 4.3, after the
// SbClip of Coin3D the thesis uses): the body B of light space perspective shadow maps
// (Wimmer et al. 2004; Knecht §2.4.2) is built with these.
#pragma once
#include <array>
#include <vector>

#include <glm/glm.hpp>

namespace sombra::clustering {

using Point = glm::dvec3;
using Polygon = std::vector<Point>;  // planar, convex; winding not relied on (normals face away from the body's centre)

// The half-space dot(normal, p) <= offset is kept; `normal` points out of it.
struct Plane {
    Point normal{0, 0, 1};
    double offset = 0;
    double signed_distance(const Point& p) const { return glm::dot(normal, p) - offset; }
};

// A closed convex polyhedron (possibly empty: no faces).
struct ConvexBody {
    std::vector<Polygon> faces;

    bool empty() const { return faces.empty(); }
    std::vector<Point> vertices() const;  // each corner once
    Point centroid() const;               // mean of the vertices (an interior point of a non-flat body)
    double volume() const;
    bool contains(const Point& p, double tolerance) const;  // inside or within `tolerance` of every face plane
    double scale() const;                                   // largest |coordinate| of a vertex, at least 1
};

// An axis-aligned box as a body (six quads); empty when any side is negative.
ConvexBody box_body(const Point& lo, const Point& hi);

// A pyramid frustum: apex `eye` looking along `forward` (`up` fixes the roll), half-angle tangents
// tan_x, tan_y, cut at depths near and far along `forward` (0 < near < far).
ConvexBody frustum_body(const Point& eye, const Point& forward, const Point& up, double tan_x, double tan_y,
                        double near, double far);

// The body cut by the plane, keeping dot(normal, p) <= offset. Knecht Alg. 4.3 lines 10 and 12:
// clipping every face leaves a hole in the plane; it is closed by a new face, the convex hull
// (Andrew's monotone chain, a Graham-scan variant) of the points the cut leaves on the plane.
ConvexBody clip(const ConvexBody& body, const Plane& plane);
ConvexBody clip(ConvexBody body, const std::vector<Plane>& planes);

// The six planes bounding an axis-aligned box.
std::vector<Plane> box_planes(const Point& lo, const Point& hi);

// The face planes of a body, outward (for clipping another body by it).
std::vector<Plane> face_planes(const ConvexBody& body);

// Convex hull of the body and a point: M = V ∪ l of Knecht Alg. 4.3 lines 2-8, built from the faces
// that do not see `apex` and one triangle from each silhouette edge to `apex` (the body itself when
// `apex` lies inside). Alg. 4.3 adds triangles over every edge of every face that sees l and keeps
// those faces, which leaves them inside the body; here M's faces are its boundary only. Expects a
// body whose faces share their corners exactly (frustum_body).
ConvexBody hull_with_point(const ConvexBody& body, const Point& apex);

// The body swept by `offset` (its Minkowski sum with the segment [0, offset]): M for a directional
// light, whose position is at infinity along −(light direction).
ConvexBody sweep(const ConvexBody& body, const Point& offset);

}  // namespace sombra::clustering
