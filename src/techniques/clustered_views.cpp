// sombra — clustered deep shadow map views (clustered_views.h).
#include "techniques/clustered_views.h"

#include <cmath>

#include "math_constants.h"
#include "sombra/error.h"

namespace sombra::techniques {
namespace {

cl_float4 f4(const clustering::Point& v, float w = 0.f) {
    cl_float4 r;
    r.s[0] = float(v.x), r.s[1] = float(v.y), r.s[2] = float(v.z), r.s[3] = w;
    return r;
}


}  // namespace

DsmViewGpu focused_dsm_view(const clustering::FocusedView& f, int resolution) {
    DsmViewGpu v{};
    // DsmViewGpu's frame: axis_x = axis_y × axis_z (dsm_views.cpp), with axis_y = up and axis_z = forward
    v.axis_x = f4(glm::cross(f.up, f.forward)), v.axis_y = f4(f.up), v.axis_z = f4(f.forward);
    v.resolution = cl_uint(resolution);
    const double widen = 1.0 + 2.0 / resolution;  // one texel beyond the members on each side
    const double depth_margin = 1e-3 * (f.far - f.near) + 1e-6 * std::max(std::fabs(f.far), 1.0);
    if (f.orthographic) {
        const double near = f.near - depth_margin;
        v.perspective = 0;
        v.origin = f4(f.eye + near * f.forward, 1.f);  // the centre of the near plane; depth from there
        v.extent_x = float(f.half_width * widen), v.extent_y = float(f.half_height * widen);
        v.near_depth = 0.f, v.far_depth = float(f.far + depth_margin - near);
    } else {
        v.perspective = 1;
        v.origin = f4(f.eye, 1.f);
        const double tan_x = std::tan(0.5 * f.fov_x) * widen, tan_y = std::tan(0.5 * f.fov_y) * widen;
        v.extent_x = float(tan_x), v.extent_y = float(tan_y);
        // depth is the distance from the light: at least the depth along forward, at most that
        // over the cosine of the frustum's corner ray
        v.near_depth = float(std::max(f.near - depth_margin, 0.0));
        v.far_depth = float((f.far + depth_margin) * std::sqrt(1.0 + tan_x * tan_x + tan_y * tan_y));
    }
    return v;
}

ClusteredViews make_clustered_views(const Scene& scene, int resolution,
                                    const clustering::ClusterOptions& options) {
    ClusteredViews out;
    out.objects = clustering::scene_objects(scene);
    out.lights = clustering::cluster_lights(scene, options);
    out.options = options;
    out.options.previous = nullptr;
    for (std::size_t li = 0; li < out.lights.size(); ++li) {
        DsmLightViews range{cl_uint(out.views.size()), 0};
        const std::vector<clustering::Cluster>& clusters = out.lights[li].clusters;
        for (std::size_t c = 0; c < clusters.size(); ++c) {
            cl_uint volume_mask = 0;
            std::vector<bool> meshes(scene.meshes.size(), false);
            for (std::size_t o : clusters[c].members) {
                const clustering::SceneObject& object = out.objects[o];
                if (object.is_volume) volume_mask |= 1u << object.scene_index;  // < SOMBRA_MAX_VOLUMES = 32
                else meshes[object.scene_index] = true;
            }
            for (const clustering::FocusedView& focus : clusters[c].views) {
                DsmViewGpu v = focused_dsm_view(focus, resolution);
                v.volume_mask = volume_mask;
                v.cluster = cl_uint(c);
                out.views.push_back(v);
                out.meshes.push_back(meshes);
            }
        }
        range.count = cl_uint(out.views.size()) - range.first;
        out.light_views.push_back(range);
    }
    if (out.views.empty()) {
        // every object misses B for every light: no light has a view, but the storage backends
        // need one to exist — a placeholder that holds nothing and that no light refers to
        DsmViewGpu placeholder{};
        placeholder.axis_x = f4({1, 0, 0}), placeholder.axis_y = f4({0, 1, 0}), placeholder.axis_z = f4({0, 0, 1});
        placeholder.extent_x = placeholder.extent_y = 1.f;
        placeholder.resolution = cl_uint(resolution);
        placeholder.volume_mask = 0;
        out.views.push_back(placeholder);
        out.meshes.emplace_back(scene.meshes.size(), false);
    }
    const std::size_t texels = std::size_t(resolution) * std::size_t(resolution);
    if (out.views.size() * texels >= 0xffffffffull) throw Error("--dsm-res: too many texels for 32-bit indices");
    for (std::size_t i = 0; i < out.views.size(); ++i) out.views[i].first_texel = cl_uint(i * texels);
    return out;
}

void add_cluster_stats(const ClusteredViews& clustered, RenderStats& stats) {
    stats.dsm_clusters.clear();
    stats.dsm_ignored_objects.clear();
    for (const clustering::LightClusters& light : clustered.lights) {
        std::vector<std::string> ignored;
        for (std::size_t o : light.ignored) ignored.push_back(clustered.objects[o].name);
        stats.dsm_ignored_objects.push_back(ignored);
        for (const clustering::Cluster& c : light.clusters) {
            RenderStats::Cluster cluster;
            cluster.light = int(light.light);
            for (std::size_t o : c.members) cluster.members.push_back(clustered.objects[o].name);
            for (const clustering::FocusedView& f : c.views)
                cluster.views.push_back({f.orthographic, f.fov_x * kDegreesPerRadian, f.fov_y * kDegreesPerRadian, f.half_width, f.half_height, f.near, f.far});
            stats.dsm_clusters.push_back(cluster);
        }
    }
}

}  // namespace sombra::techniques
