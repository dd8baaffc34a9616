#include "clustering/clustering.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "math_constants.h"
#include "sombra/error.h"

namespace sombra::clustering {
namespace {

constexpr double kFocusMargin = 1e-5;  // relative slack around focused views (float consumers)
const double kMaxFocusTan = std::tan(60.0 * kPi / 180.0);  // wider: focus per cube face

// Unit vector of v, or `fallback` for a (near) zero vector.
Point unit_or(const Point& v, const Point& fallback) {
    const double length = glm::length(v);
    return length > 1e-300 && std::isfinite(length) ? v / length : fallback;
}

Point to_point(const Vec3& v) { return {v[0], v[1], v[2]}; }

// The axis-aligned box of points put through a row-major affine 4×4 transform.
void transformed_box(const std::array<float, 16>& m, const std::vector<Point>& points, Point& lo, Point& hi) {
    lo = Point(INFINITY), hi = Point(-INFINITY);
    for (const Point& p : points) {
        Point w;
        for (std::size_t r = 0; r < 3; ++r)
            w[int(r)] = m[r * 4] * p.x + m[r * 4 + 1] * p.y + m[r * 4 + 2] * p.z + m[r * 4 + 3];
        lo = glm::min(lo, w), hi = glm::max(hi, w);
    }
}

std::vector<LightView> cube_faces(const Point& position, double near) {
    std::vector<LightView> faces;
    for (const Point& axis : {Point(1, 0, 0), Point(-1, 0, 0), Point(0, 1, 0), Point(0, -1, 0), Point(0, 0, 1), Point(0, 0, -1)})
        faces.push_back({true, position, axis, 1.0, near});
    return faces;
}

FocusedView orthographic_focus(const Point& direction, const std::vector<Point>& points) {
    LightView light{false, Point(0.0), direction};
    Point x, y, z;
    light.frame(x, y, z);
    Point lo(INFINITY), hi(-INFINITY);
    for (const Point& p : points) {
        const Point q(glm::dot(p, x), glm::dot(p, y), glm::dot(p, z));
        lo = glm::min(lo, q), hi = glm::max(hi, q);
    }
    const double pad = kFocusMargin * std::max(glm::length(hi - lo), 1e-12);
    FocusedView v;
    v.orthographic = true;
    v.forward = z, v.up = y;
    v.eye = 0.5 * (lo.x + hi.x) * x + 0.5 * (lo.y + hi.y) * y + (lo.z - pad) * z;
    v.half_width = 0.5 * (hi.x - lo.x) + pad, v.half_height = 0.5 * (hi.y - lo.y) + pad;
    v.near = 0, v.far = hi.z - lo.z + 2 * pad;
    return v;
}

// Perspective focus from `apex` (§3.4.2 steps 2-4): the axis is turned to the middle of the
// points' tangent ranges a few times (exact in one axis, converging in two); of the axes tried
// (the first one included) the one with the smallest image (tan_x · tan_y) is kept. The fields of
// view are the largest tangents in that axis's frame, so every point is inside whatever the
// convergence. Nothing when a point lies at or behind the apex plane or a tangent exceeds max_tan.
std::optional<FocusedView> perspective_focus(const Point& apex, const std::vector<Point>& points, const Point& initial_forward,
                                             double max_tan) {
    double reach = 0;
    for (const Point& p : points) reach = std::max(reach, glm::length(p - apex));
    Point forward = unit_or(initial_forward, Point(0, 0, 0));
    if (points.empty() || forward == Point(0, 0, 0) || !(reach > 0)) return std::nullopt;
    std::optional<FocusedView> best;
    double best_image = INFINITY;
    for (int turn = 0; turn < 6; ++turn) {
        Point x, y, z;
        LightView{true, apex, forward}.frame(x, y, z);
        double lo_x = INFINITY, hi_x = -INFINITY, lo_y = INFINITY, hi_y = -INFINITY, near = INFINITY, far = 0;
        for (const Point& p : points) {
            const Point d = p - apex;
            const double depth = glm::dot(d, z);
            if (!(depth > 1e-9 * reach)) return best;
            const double tan_x = glm::dot(d, x) / depth, tan_y = glm::dot(d, y) / depth;
            lo_x = std::min(lo_x, tan_x), hi_x = std::max(hi_x, tan_x), lo_y = std::min(lo_y, tan_y), hi_y = std::max(hi_y, tan_y);
            near = std::min(near, depth), far = std::max(far, depth);
        }
        const double tan_x = std::max(-lo_x, hi_x), tan_y = std::max(-lo_y, hi_y);
        if (tan_x <= max_tan && tan_y <= max_tan && tan_x * tan_y < best_image) {
            best_image = tan_x * tan_y;
            FocusedView v;
            v.eye = apex, v.forward = z, v.up = y;
            v.fov_x = 2 * std::atan(tan_x * (1 + kFocusMargin) + kFocusMargin);
            v.fov_y = 2 * std::atan(tan_y * (1 + kFocusMargin) + kFocusMargin);
            v.near = near * (1 - kFocusMargin), v.far = far * (1 + kFocusMargin);
            best = v;
        }
        forward = glm::normalize(z + 0.5 * (lo_x + hi_x) * x + 0.5 * (lo_y + hi_y) * y);
    }
    return best;
}

}  // namespace

bool FocusedView::contains(const Point& p, double tolerance) const {
    const Point right = glm::cross(up, forward);
    const Point d = p - eye;
    const double depth = glm::dot(d, forward), across_x = std::fabs(glm::dot(d, right)), across_y = std::fabs(glm::dot(d, up));
    if (depth < near - tolerance || depth > far + tolerance) return false;
    if (orthographic) return across_x <= half_width + tolerance && across_y <= half_height + tolerance;
    return across_x <= depth * std::tan(0.5 * fov_x) + tolerance && across_y <= depth * std::tan(0.5 * fov_y) + tolerance;
}

std::vector<SceneObject> scene_objects(const Scene& scene) {
    std::vector<SceneObject> objects;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeInstance& v = scene.volumes[i];
        if (!v.volume) continue;
        Point half;
        for (int a = 0; a < 3; ++a) half[a] = 0.5 * v.volume->dims[std::size_t(a)] * v.spacing[std::size_t(a)];
        std::vector<Point> corners;
        for (int c = 0; c < 8; ++c) corners.emplace_back(c & 1 ? half.x : -half.x, c & 2 ? half.y : -half.y, c & 4 ? half.z : -half.z);
        SceneObject o{v.name.empty() ? "volume " + std::to_string(i) : v.name, true, i, {}, {}};
        transformed_box(v.transform, corners, o.lo, o.hi);
        objects.push_back(o);
    }
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        const MeshInstance& m = scene.meshes[i];
        if (!m.mesh || m.mesh->positions.empty()) continue;
        std::vector<Point> vertices;
        for (const auto& p : m.mesh->positions) vertices.emplace_back(p[0], p[1], p[2]);
        SceneObject o{m.name.empty() ? "mesh " + std::to_string(i) : m.name, false, i, {}, {}};
        transformed_box(m.transform, vertices, o.lo, o.hi);
        objects.push_back(o);
    }
    Point lo(INFINITY), hi(-INFINITY);
    for (const SceneObject& o : objects) lo = glm::min(lo, o.lo), hi = glm::max(hi, o.hi);
    const double thickness = 1e-6 * std::max(objects.empty() ? 0.0 : glm::length(hi - lo), 1.0);
    for (SceneObject& o : objects)
        for (int a = 0; a < 3; ++a)
            if (o.hi[a] - o.lo[a] < thickness) {
                const double middle = 0.5 * (o.lo[a] + o.hi[a]);
                o.lo[a] = middle - 0.5 * thickness, o.hi[a] = middle + 0.5 * thickness;
            }
    return objects;
}

CameraView camera_view(const Scene& scene, const Point& scene_lo, const Point& scene_hi) {
    CameraView c;
    c.eye = to_point(scene.camera.position);
    c.forward = unit_or(to_point(scene.camera.look_at) - c.eye, Point(0, 0, -1));
    const Point up = to_point(scene.camera.up);
    const bool up_usable = glm::length(glm::cross(c.forward, up)) > 1e-9 * glm::length(up);  // validate_scene checks it too
    c.up = up_usable ? up : std::fabs(c.forward.y) < 0.9 ? Point(0, 1, 0) : Point(1, 0, 0);
    c.tan_half_y = std::tan(0.5 * double(scene.camera.fov_y_deg) * kPi / 180.0);
    c.aspect = scene.height > 0 ? double(scene.width) / double(scene.height) : 1.0;
    double far = 0;
    for (int i = 0; i < 8; ++i) {
        const Point corner(i & 1 ? scene_hi.x : scene_lo.x, i & 2 ? scene_hi.y : scene_lo.y, i & 4 ? scene_hi.z : scene_lo.z);
        far = std::max(far, glm::dot(corner - c.eye, c.forward));
    }
    c.far = std::max(far, 1e-3 * std::max(glm::length(scene_hi - scene_lo), 1e-9));
    c.near = c.far / 1000;
    return c;
}

std::vector<LightView> light_views(const Light& light, const Point& scene_lo, const Point& scene_hi) {
    const double near = 1e-3 * std::max(glm::length(scene_hi - scene_lo), 1e-9);
    const Point direction = unit_or(to_point(light.direction), Point(0, 0, -1));
    switch (light.type) {
        case LightType::Directional: return {LightView{false, Point(0.0), direction}};
        case LightType::Spot: {
            const double half_angle = std::min(double(light.cone_angle_deg), 89.0) * kPi / 180.0;
            return {LightView{true, to_point(light.position), direction, std::tan(half_angle), near}};
        }
        case LightType::Point: return cube_faces(to_point(light.position), near);
    }
    return {};
}

double extreme_point_distance(const Point& lo_a, const Point& hi_a, const Point& lo_b, const Point& hi_b) {
    const double d_min = std::hypot(lo_a.x - lo_b.x, lo_a.y - lo_b.y);
    const double d_max = std::hypot(hi_a.x - hi_b.x, hi_a.y - hi_b.y);
    return std::max(d_min, d_max);
}

ObjectDistances object_distances(const std::vector<SceneObject>& objects, const std::vector<ViewSpace>& spaces) {
    // Per view and object, the projected box of the object's part inside B: the box corners
    // transformed one by one (§3.4.1: the transform is a perspective), clipped to B first so that
    // no corner lies behind P's centre of projection; the parts outside B cast no visible shadow.
    struct Projected {
        bool present = false;
        Point lo, hi;
    };
    std::vector<std::vector<Projected>> projected(spaces.size(), std::vector<Projected>(objects.size()));
    for (std::size_t v = 0; v < spaces.size(); ++v) {
        if (spaces[v].B.empty()) continue;
        const std::vector<Plane> planes = face_planes(spaces[v].B);
        for (std::size_t o = 0; o < objects.size(); ++o) {
            const ConvexBody part = clip(box_body(objects[o].lo, objects[o].hi), planes);
            if (part.empty()) continue;
            Projected& p = projected[v][o];
            p.present = true, p.lo = Point(INFINITY), p.hi = Point(-INFINITY);
            for (const Point& corner : part.vertices()) {
                const Point q = spaces[v].lispsm.apply(corner);
                p.lo = glm::min(p.lo, q), p.hi = glm::max(p.hi, q);
            }
        }
    }
    ObjectDistances out;
    for (std::size_t o = 0; o < objects.size(); ++o)
        for (std::size_t v = 0; v < spaces.size(); ++v)
            if (projected[v][o].present) {
                out.relevant.push_back(o);
                break;
            }
    const std::size_t n = out.relevant.size();
    out.d.assign(n * n, 0.0);
    out.size.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t v = 0; v < spaces.size(); ++v) {
            const Projected& p = projected[v][out.relevant[i]];
            if (p.present) out.size[i] = std::max(out.size[i], std::min(p.hi.x - p.lo.x, p.hi.y - p.lo.y));
        }
    // Alg. 4.2 line 5: the largest distance over the views that see both
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            double d = -1;
            for (std::size_t v = 0; v < spaces.size(); ++v) {
                const Projected& a = projected[v][out.relevant[i]];
                const Projected& b = projected[v][out.relevant[j]];
                if (a.present && b.present) d = std::max(d, extreme_point_distance(a.lo, a.hi, b.lo, b.hi));
            }
            out.d[i * n + j] = out.d[j * n + i] = d < 0 ? kSeparatedDistance : d;
        }
    return out;
}

double automatic_d0(const std::vector<double>& sizes) {
    if (sizes.empty()) return 1e-6;
    std::vector<double> sorted = sizes;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t k = sorted.size();
    const double median = k % 2 ? sorted[k / 2] : 0.5 * (sorted[k / 2 - 1] + sorted[k / 2]);
    return std::max(2 * median, 1e-6);
}

std::vector<std::vector<std::size_t>> greedy_clusters(std::size_t n, const std::vector<double>& d, double d0, int m) {
    const std::size_t max_clusters = std::size_t(std::max(m, 1));
    std::vector<std::vector<std::size_t>> clusters;
    if (n == 0) return clusters;
    auto distance = [&](std::size_t i, std::size_t j) { return d[i * n + j]; };
    auto farthest_member = [&](std::size_t x, const std::vector<std::size_t>& c) {
        double far = 0;
        for (std::size_t j : c) far = std::max(far, distance(x, j));
        return far;
    };
    std::vector<bool> placed(n, false);
    auto add = [&](std::size_t x, std::size_t c) { clusters[c].push_back(x), placed[x] = true; };
    auto open = [&](std::vector<std::size_t> members) {
        clusters.emplace_back();
        for (std::size_t x : members) add(x, clusters.size() - 1);
    };
    auto join_fitting = [&](std::size_t x) {  // lines 10-17: a cluster whose members are all within d0
        for (std::size_t c = 0; c < clusters.size() && !placed[x]; ++c)
            if (farthest_member(x, clusters[c]) <= d0) add(x, c);
    };
    auto join_nearest = [&](std::size_t x) {  // line 33, §3.4.1 step 3
        std::size_t best = 0;
        for (std::size_t c = 1; c < clusters.size(); ++c)
            if (farthest_member(x, clusters[c]) < farthest_member(x, clusters[best])) best = c;
        add(x, best);
    };
    auto place_alone = [&](std::size_t x) { clusters.size() < max_clusters ? open({x}) : join_nearest(x); };

    std::vector<std::pair<std::size_t, std::size_t>> pairs;  // line 8: by descending distance
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) pairs.emplace_back(i, j);
    std::stable_sort(pairs.begin(), pairs.end(),
                     [&](const auto& p, const auto& q) { return distance(p.first, p.second) > distance(q.first, q.second); });
    for (const auto& [a, b] : pairs) {
        if (!placed[a]) join_fitting(a);
        if (!placed[b]) join_fitting(b);
        if (placed[a] && placed[b]) continue;
        if (!placed[a] && !placed[b] && distance(a, b) <= d0 && clusters.size() < max_clusters) {
            open({a, b});  // line 19
            continue;
        }
        for (std::size_t x : {a, b})  // lines 21-33
            if (!placed[x]) place_alone(x);
    }
    if (n == 1) open({0});
    return clusters;
}

std::vector<FocusedView> focus_cluster(const Light& light, const std::vector<ConvexBody>& members, double near) {
    auto corners_of = [](const std::vector<ConvexBody>& bodies) {
        std::vector<Point> corners;
        for (const ConvexBody& b : bodies)
            for (const Point& p : b.vertices()) corners.push_back(p);
        return corners;
    };
    const std::vector<Point> corners = corners_of(members);
    if (corners.empty()) return {};
    if (light.type == LightType::Directional) return {orthographic_focus(unit_or(to_point(light.direction), Point(0, 0, -1)), corners)};
    const Point apex = to_point(light.position);
    Point middle(0.0);
    for (const Point& p : corners) middle += p / double(corners.size());
    if (auto view = perspective_focus(apex, corners, middle - apex, kMaxFocusTan)) return {*view};
    std::vector<FocusedView> views;  // the members surround the light, or are too wide: per cube face
    for (const LightView& face : cube_faces(apex, near)) {
        std::vector<ConvexBody> pieces;
        for (const ConvexBody& b : members) pieces.push_back(clip(b, face.planes()));
        const std::vector<Point> piece_corners = corners_of(pieces);
        if (piece_corners.empty()) continue;
        if (auto view = perspective_focus(apex, piece_corners, face.forward, INFINITY)) views.push_back(*view);
    }
    return views;
}

double cluster_spread(const std::vector<std::vector<std::size_t>>& clusters, const ObjectDistances& distances) {
    auto index = [&](std::size_t object) {
        return std::size_t(std::find(distances.relevant.begin(), distances.relevant.end(), object) - distances.relevant.begin());
    };
    double spread = 0;
    for (const auto& members : clusters)
        for (std::size_t a = 0; a < members.size(); ++a)
            for (std::size_t b = a + 1; b < members.size(); ++b) spread = std::max(spread, distances.at(index(members[a]), index(members[b])));
    return spread;
}

std::vector<LightClusters> cluster_lights(const Scene& scene, const ClusterOptions& options) {
    if (options.max_clusters < 1 || options.max_clusters > 64)
        throw Error("--clusters: must lie in [1, 64], got " + std::to_string(options.max_clusters));
    if (!std::isfinite(options.distance)) throw Error("--cluster-distance: must be a finite number");
    if (!(options.hysteresis >= 0) || !std::isfinite(options.hysteresis)) throw Error("--cluster-hysteresis: must be a finite number ≥ 0");
    const std::vector<SceneObject> objects = scene_objects(scene);
    std::vector<LightClusters> result(scene.lights.size());
    for (std::size_t l = 0; l < scene.lights.size(); ++l) result[l].light = l;
    if (objects.empty()) return result;

    Point lo(INFINITY), hi(-INFINITY);  // the scene box S
    for (const SceneObject& o : objects) lo = glm::min(lo, o.lo), hi = glm::max(hi, o.hi);
    const CameraView camera = camera_view(scene, lo, hi);
    for (std::size_t l = 0; l < scene.lights.size(); ++l) {
        const Light& light = scene.lights[l];
        LightClusters& out = result[l];
        const std::vector<LightView> views = light_views(light, lo, hi);
        for (const LightView& view : views) {  // Alg. 4.2 lines 1-2
            ViewSpace space{view, convex_body_B(camera, view, lo, hi), {}};
            if (!space.B.empty()) space.lispsm = make_lispsm(space.B, camera, view);
            out.spaces.push_back(space);
        }
        const ObjectDistances distances = object_distances(objects, out.spaces);
        for (std::size_t o = 0; o < objects.size(); ++o)
            if (std::find(distances.relevant.begin(), distances.relevant.end(), o) == distances.relevant.end()) out.ignored.push_back(o);
        out.d0 = options.distance > 0 ? options.distance : automatic_d0(distances.size);
        std::vector<std::vector<std::size_t>> groups;
        for (const auto& group : greedy_clusters(distances.relevant.size(), distances.d, out.d0, options.max_clusters)) {
            groups.emplace_back();
            for (std::size_t k : group) groups.back().push_back(distances.relevant[k]);
            std::sort(groups.back().begin(), groups.back().end());
        }
        if (options.previous && l < options.previous->size()) {  // hysteresis: keep last frame's clusters?
            const auto& kept = (*options.previous)[l];
            std::vector<std::size_t> kept_objects, relevant = distances.relevant;
            for (const auto& members : kept) kept_objects.insert(kept_objects.end(), members.begin(), members.end());
            std::sort(kept_objects.begin(), kept_objects.end());
            std::sort(relevant.begin(), relevant.end());
            if (kept_objects == relevant && kept.size() <= std::size_t(options.max_clusters) &&
                cluster_spread(kept, distances) <= (1 + options.hysteresis) * cluster_spread(groups, distances))
                groups = kept;
        }
        for (const auto& group : groups) {
            Cluster cluster;
            cluster.members = group;
            std::vector<ConvexBody> boxes;
            for (std::size_t o : cluster.members) {
                boxes.push_back(box_body(objects[o].lo, objects[o].hi));
                if (light.type == LightType::Spot) boxes.back() = clip(boxes.back(), views.front().planes());  // §3.4.2 step 1
            }
            cluster.views = focus_cluster(light, boxes, views.front().near);
            out.clusters.push_back(cluster);
        }
    }
    return result;
}

}  // namespace sombra::clustering
