#include "clustering/convex_body.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace sombra::clustering {
namespace {

// Distances below this fraction of a body's scale count as zero (points on a plane, repeated corners).
constexpr double kRelativeTolerance = 1e-9;

// Newell's normal: its length is twice the polygon's area.
Point newell_normal(const Polygon& polygon) {
    Point n(0.0);
    for (std::size_t i = 0; i < polygon.size(); ++i) {
        const Point& a = polygon[i];
        const Point& b = polygon[(i + 1) % polygon.size()];
        n += Point((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    return n;
}

// Drops corners within `tolerance` of the previous one (cyclically).
Polygon without_repeats(const Polygon& polygon, double tolerance) {
    Polygon out;
    for (const Point& p : polygon)
        if (out.empty() || glm::length(p - out.back()) > tolerance) out.push_back(p);
    while (out.size() > 1 && glm::length(out.front() - out.back()) <= tolerance) out.pop_back();
    return out;
}

// A face worth keeping: three corners or more and an area above tolerance².
bool is_face(const Polygon& polygon, double tolerance) {
    return polygon.size() >= 3 && 0.5 * glm::length(newell_normal(polygon)) > tolerance * tolerance;
}

// The plane of a face, its normal pointing away from `inside`.
Plane outward_plane(const Polygon& face, const Point& inside) {
    Point n = glm::normalize(newell_normal(face));
    if (glm::dot(n, inside - face[0]) > 0) n = -n;
    return {n, glm::dot(n, face[0])};
}

// Convex hull (counter-clockwise about `normal`) of points lying in a plane with that normal:
// Andrew's monotone chain in 2D coordinates of the plane; collinear and repeated points are dropped.
Polygon planar_hull(const std::vector<Point>& points, const Point& normal, double tolerance) {
    if (points.size() < 3) return {};
    const Point helper = std::fabs(normal.x) < 0.9 ? Point(1, 0, 0) : Point(0, 1, 0);
    const Point u = glm::normalize(glm::cross(helper, normal)), v = glm::cross(normal, u);
    struct Entry {
        double s, t;
        Point p;
    };
    std::vector<Entry> entries;
    for (const Point& p : points) entries.push_back({glm::dot(p, u), glm::dot(p, v), p});
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.s < b.s || (a.s == b.s && a.t < b.t); });
    auto turn = [](const Entry& o, const Entry& a, const Entry& b) { return (a.s - o.s) * (b.t - o.t) - (a.t - o.t) * (b.s - o.s); };
    const double min_turn = tolerance * tolerance;
    std::vector<Entry> hull(2 * entries.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < entries.size(); ++i) {  // lower chain
        while (k >= 2 && turn(hull[k - 2], hull[k - 1], entries[i]) <= min_turn) --k;
        hull[k++] = entries[i];
    }
    for (std::size_t i = entries.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
        while (k >= lower && turn(hull[k - 2], hull[k - 1], entries[i]) <= min_turn) --k;
        hull[k++] = entries[i];
    }
    Polygon polygon;
    for (std::size_t i = 0; i + 1 < k; ++i) polygon.push_back(hull[i].p);  // the last repeats the first
    return without_repeats(polygon, tolerance);
}

// The faces that `front` marks are replaced: each corner goes to moved(corner), and each edge
// between a front face and another face becomes the quad (a, b, moved(b), moved(a)) (a triangle
// when both move to one point). Front faces whose moved copy is flat vanish. Used by hull_with_point
// and sweep; edges are matched by exact corner coordinates.
ConvexBody extrude(const ConvexBody& body, const std::vector<bool>& front, const std::function<Point(const Point&)>& moved) {
    const double tolerance = kRelativeTolerance * body.scale();
    auto has_edge = [](const Polygon& face, const Point& a, const Point& b) {
        for (std::size_t i = 0; i < face.size(); ++i) {
            const Point& p = face[i];
            const Point& q = face[(i + 1) % face.size()];
            if ((p == a && q == b) || (p == b && q == a)) return true;
        }
        return false;
    };
    ConvexBody out;
    for (std::size_t f = 0; f < body.faces.size(); ++f) {
        const Polygon& face = body.faces[f];
        if (!front[f]) {
            out.faces.push_back(face);
            continue;
        }
        Polygon cap;
        for (const Point& p : face) cap.push_back(moved(p));
        cap = without_repeats(cap, tolerance);
        if (is_face(cap, tolerance)) out.faces.push_back(cap);
        for (std::size_t i = 0; i < face.size(); ++i) {
            const Point& a = face[i];
            const Point& b = face[(i + 1) % face.size()];
            for (std::size_t g = 0; g < body.faces.size(); ++g)
                if (g != f && !front[g] && has_edge(body.faces[g], a, b)) {
                    Polygon side = without_repeats({a, b, moved(b), moved(a)}, tolerance);
                    if (is_face(side, tolerance)) out.faces.push_back(side);
                }
        }
    }
    return out;
}

// A hexahedron from its corners c[i], bits 0, 1, 2 of i choosing the high side in x, y, z (of a
// box, or of a frustum's across and depth); the faces share the corners exactly.
ConvexBody hexahedron(const std::array<Point, 8>& c) {
    ConvexBody body;
    body.faces = {{c[0], c[2], c[3], c[1]}, {c[4], c[5], c[7], c[6]}, {c[0], c[1], c[5], c[4]},
                  {c[2], c[6], c[7], c[3]}, {c[0], c[4], c[6], c[2]}, {c[1], c[3], c[7], c[5]}};
    return body;
}

}  // namespace

std::vector<Point> ConvexBody::vertices() const {
    const double tolerance = kRelativeTolerance * scale();
    std::vector<Point> out;
    for (const Polygon& face : faces)
        for (const Point& p : face)
            if (std::none_of(out.begin(), out.end(), [&](const Point& q) { return glm::length(p - q) <= tolerance; }))
                out.push_back(p);
    return out;
}

Point ConvexBody::centroid() const {
    std::vector<Point> corners = vertices();
    Point sum(0.0);
    for (const Point& p : corners) sum += p;
    return corners.empty() ? sum : sum / double(corners.size());
}

double ConvexBody::volume() const {
    const Point c = centroid();
    double v = 0;
    for (const Polygon& face : faces)
        for (std::size_t i = 1; i + 1 < face.size(); ++i)
            v += std::fabs(glm::dot(face[0] - c, glm::cross(face[i] - c, face[i + 1] - c))) / 6.0;
    return v;
}

bool ConvexBody::contains(const Point& p, double tolerance) const {
    if (empty()) return false;
    for (const Plane& plane : face_planes(*this))
        if (plane.signed_distance(p) > tolerance) return false;
    return true;
}

double ConvexBody::scale() const {
    double s = 1;
    for (const Polygon& face : faces)
        for (const Point& p : face) s = std::max({s, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    return s;
}

ConvexBody box_body(const Point& lo, const Point& hi) {
    if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return {};
    std::array<Point, 8> c;
    for (int i = 0; i < 8; ++i) c[std::size_t(i)] = Point(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    return hexahedron(c);
}

ConvexBody frustum_body(const Point& eye, const Point& forward, const Point& up, double tan_x, double tan_y, double near,
                        double far) {
    const Point z = glm::normalize(forward), x = glm::normalize(glm::cross(z, up)), y = glm::cross(x, z);
    std::array<Point, 8> c;
    for (int i = 0; i < 8; ++i) {
        const double depth = i & 4 ? far : near;
        c[std::size_t(i)] = eye + depth * (z + (i & 1 ? tan_x : -tan_x) * x + (i & 2 ? tan_y : -tan_y) * y);
    }
    return hexahedron(c);
}

ConvexBody clip(const ConvexBody& body, const Plane& plane) {
    const double tolerance = kRelativeTolerance * std::max(body.scale(), std::fabs(plane.offset));
    ConvexBody out;
    std::vector<Point> on_plane;  // corners the cut leaves on the plane: the hole's rim
    bool face_in_plane = false;   // a face already closes the cut
    for (const Polygon& face : body.faces) {
        Polygon kept;
        bool all_on_plane = true;
        for (std::size_t i = 0; i < face.size(); ++i) {
            const Point& a = face[i];
            const Point& b = face[(i + 1) % face.size()];
            const double da = plane.signed_distance(a), db = plane.signed_distance(b);
            all_on_plane = all_on_plane && std::fabs(da) <= tolerance;
            if (da <= tolerance) kept.push_back(a);
            if (std::fabs(da) <= tolerance) on_plane.push_back(a);
            if ((da < -tolerance && db > tolerance) || (da > tolerance && db < -tolerance)) {
                const Point crossing = a + (da / (da - db)) * (b - a);
                kept.push_back(crossing);
                on_plane.push_back(crossing);
            }
        }
        kept = without_repeats(kept, tolerance);
        if (!is_face(kept, tolerance)) continue;
        face_in_plane = face_in_plane || all_on_plane;
        out.faces.push_back(kept);
    }
    if (!face_in_plane) {
        Polygon cap = planar_hull(on_plane, plane.normal, tolerance);
        if (is_face(cap, tolerance)) out.faces.push_back(cap);
    }
    if (out.faces.size() < 4) return {};  // nothing, or a flat remainder
    return out;
}

ConvexBody clip(ConvexBody body, const std::vector<Plane>& planes) {
    for (const Plane& plane : planes) {
        if (body.empty()) break;
        body = clip(body, plane);
    }
    return body;
}

std::vector<Plane> box_planes(const Point& lo, const Point& hi) {
    return {{{-1, 0, 0}, -lo.x}, {{1, 0, 0}, hi.x}, {{0, -1, 0}, -lo.y},
            {{0, 1, 0}, hi.y},   {{0, 0, -1}, -lo.z}, {{0, 0, 1}, hi.z}};
}

std::vector<Plane> face_planes(const ConvexBody& body) {
    const Point inside = body.centroid();
    std::vector<Plane> planes;
    for (const Polygon& face : body.faces) planes.push_back(outward_plane(face, inside));
    return planes;
}

ConvexBody hull_with_point(const ConvexBody& body, const Point& apex) {
    const double tolerance = kRelativeTolerance * std::max(body.scale(), glm::length(apex));
    std::vector<bool> sees_apex;
    for (const Plane& plane : face_planes(body)) sees_apex.push_back(plane.signed_distance(apex) > tolerance);
    if (std::none_of(sees_apex.begin(), sees_apex.end(), [](bool b) { return b; })) return body;  // apex inside
    return extrude(body, sees_apex, [&](const Point&) { return apex; });
}

ConvexBody sweep(const ConvexBody& body, const Point& offset) {
    std::vector<bool> leading;  // faces facing the sweep direction move; the others stay
    for (const Plane& plane : face_planes(body)) leading.push_back(glm::dot(plane.normal, offset) > kRelativeTolerance * glm::length(offset));
    return extrude(body, leading, [&](const Point& p) { return p + offset; });
}

}  // namespace sombra::clustering
