// sombra — object clustering for clustered deep shadow maps (Knecht §3.4, Alg. 4.2), the geometric
// half: which objects share a deep shadow map, and the light view focused on each cluster.
// One DSM per cluster and their product in the lookup (Eq. 3.12): src/techniques/clustered_views.h
// and cl/techniques/dsm.h.
#pragma once
#include <string>
#include <vector>

#include "clustering/lispsm.h"
#include "sombra/scene.h"

namespace sombra::clustering {

// An object of the scene: volumes first (index = volume index), then meshes (index = volume count
// + mesh index), each with its world-space axis-aligned box.
struct SceneObject {
    std::string name;
    bool is_volume = true;
    std::size_t scene_index = 0;  // into Scene::volumes or Scene::meshes
    Point lo, hi;
};

// Volumes: the box of the voxel cells (±dims·spacing/2 in the object frame) through the transform;
// meshes: the box of their transformed vertices. Boxes thinner than 10⁻⁶ of the scene are
// thickened to that, so that a flat quad still has an inside.
std::vector<SceneObject> scene_objects(const Scene& scene);

// The camera frustum V for a scene box: the scene's camera and aspect (width / height), far = the
// farthest box corner along the view, near = far / 1000 (the scene has no clipping planes).
CameraView camera_view(const Scene& scene, const Point& scene_lo, const Point& scene_hi);

// The light's views (Alg. 4.2 line 1): a spot light one pyramid around its cone (half angle capped
// at 89°), a point light the six cube faces (+x, −x, +y, −y, +z, −z), a directional light one.
// Perspective views cut at near = 10⁻³ of the scene box's diagonal.
std::vector<LightView> light_views(const Light& light, const Point& scene_lo, const Point& scene_hi);

// A view focused on a cluster (Knecht §3.4.2): perspective from the light, or orthographic for a
// directional light, symmetric about `forward` (across: up × forward and up). near/far are
// depths along `forward` from `eye`.
struct FocusedView {
    bool orthographic = false;
    Point eye{0, 0, 0}, forward{0, 0, -1}, up{0, 1, 0};  // forward, up: unit, perpendicular
    double fov_x = 0, fov_y = 0;                         // perspective: full angles in radians
    double half_width = 0, half_height = 0;              // orthographic: half extents across
    double near = 0, far = 0;
    bool contains(const Point& p, double tolerance) const;  // inside, or within `tolerance` (world units)
};

struct Cluster {
    std::vector<std::size_t> members;  // indices into scene_objects(scene)
    // Usually one view. A perspective light whose cluster surrounds it (or needs more than 120° of
    // field of view) gets the cube faces that see part of it, each focused on its part.
    std::vector<FocusedView> views;
};

// The distances d_ij between the objects for one light (Knecht §3.4.1, Alg. 4.2 lines 1-6).
struct ObjectDistances {
    std::vector<std::size_t> relevant;  // objects whose boxes meet B in at least one view
    std::vector<double> d;              // |relevant|², row-major, in the order of `relevant`
    std::vector<double> size;           // per relevant object: smaller side of its projected box (max over views)
    double at(std::size_t i, std::size_t j) const { return d[i * relevant.size() + j]; }
};

// One light view's B and LiSPSM transform, kept for inspection.
struct ViewSpace {
    LightView view;
    ConvexBody B;
    Lispsm lispsm;  // meaningless when B is empty
};

struct LightClusters {
    std::size_t light = 0;
    std::vector<ViewSpace> spaces;      // one per light view
    std::vector<std::size_t> ignored;   // objects whose boxes miss B in every view
    double d0 = 0;                      // the threshold used
    std::vector<Cluster> clusters;
};

struct ClusterOptions {
    int max_clusters = 4;   // m, per light, in [1, 64]
    double distance = 0;    // d0; ≤ 0: automatic_d0
    // Against popping (beyond Knecht, whose §6 names it future work): the previous frame's
    // clusters of each light (light order; none: cluster from scratch) are kept while they hold
    // the same objects, are at most m, and their spread (the largest distance between two members
    // of a cluster, now) is at most (1 + hysteresis) times the spread of the clusters found anew.
    const std::vector<std::vector<std::vector<std::size_t>>>* previous = nullptr;  // [light][cluster] → members
    double hysteresis = 0;  // ≥ 0
};

// The largest distance between two members of one cluster (0 for singletons); `relevant` and
// `distances` as in ObjectDistances, members as scene object indices.
double cluster_spread(const std::vector<std::vector<std::size_t>>& clusters, const ObjectDistances& distances);

// The extreme-point distance of two projected boxes (Knecht §3.4.1): the larger of the distances
// between their (min x, min y) corners and between their (max x, max y) corners.
double extreme_point_distance(const Point& lo_a, const Point& hi_a, const Point& lo_b, const Point& hi_b);

// Pairs that share no light view (a point light's objects in different faces) are this far apart:
// more than any two points of B's [−1, 1]² can be.
constexpr double kSeparatedDistance = 3.0;

ObjectDistances object_distances(const std::vector<SceneObject>& objects, const std::vector<ViewSpace>& spaces);

// Automatic d0: twice the median projected object size, so that objects whose projected boxes lie
// less than about one typical object size apart share a cluster (10⁻⁶ when every size is 0). The
// size of a projected box is its smaller side: LiSPSM stretches B to [−1, 1] in map x and y
// separately, so where the scene is flat in one map axis every object spans most of that axis,
// and only the other axis, the one the objects are spread along, tells near from far.
double automatic_d0(const std::vector<double>& sizes);

// Greedy clustering of Knecht Alg. 4.2 lines 8-35 over objects 0 … n−1 with distances d (n²,
// row-major): pairs by descending distance; each object joins the first cluster all of whose
// members lie within d0 of it, else opens a new cluster while fewer than m exist, else joins the
// nearest cluster (the one whose farthest member is nearest; §3.4.1 step 3). Every object ends
// in exactly one cluster; clusters are listed in the order they were opened.
std::vector<std::vector<std::size_t>> greedy_clusters(std::size_t n, const std::vector<double>& d, double d0, int m);

// The views of a light focused on a cluster (Knecht §3.4.2). `members`: the members' boxes, each
// clipped by the light frustum for a spot light (§3.4.2 step 1). Focusing on the members' corners
// rather than on the cluster's one bounding box is tighter and holds the same objects (a frustum
// is convex). Directional light: one orthographic view along the light around them. Spot and
// point lights: the orientation turned to their middle, the narrowest symmetric fields of view in
// x and y, near and far at the nearest and farthest corner. When they surround the light or would
// need more than 120°, one such view per cube face that sees some of them (each box clipped by
// that face's frustum, cut at `near`). Every corner lies in one of the views (in the per-face
// case, corners nearer than √3·near to the light excepted). No corners: no view.
std::vector<FocusedView> focus_cluster(const Light& light, const std::vector<ConvexBody>& members, double near);

// Clusters for every light of the scene, in light order (Knecht Alg. 4.2 for each light).
// Throws sombra::Error naming --clusters / --cluster-distance for options out of range.
std::vector<LightClusters> cluster_lights(const Scene& scene, const ClusterOptions& options);

}  // namespace sombra::clustering
