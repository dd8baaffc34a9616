#include "shadows/dsm_views.h"

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>

#include "math_constants.h"
#include "shared/hash.h"
#include "sombra/error.h"

namespace sombra::shadows {
namespace {

cl_float4 f4(const glm::vec3& v, float w = 0.f) {
    cl_float4 r;
    r.s[0] = v.x, r.s[1] = v.y, r.s[2] = v.z, r.s[3] = w;
    return r;
}

// An orthonormal frame looking along `forward`, with an up hint that is never parallel to it
// (a directional light along an axis is a stiff case of docs/architecture.md).
void frame(const glm::vec3& forward, glm::vec3& x, glm::vec3& y, glm::vec3& z) {
    z = glm::normalize(forward);
    glm::vec3 hint = std::fabs(z.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    x = glm::normalize(glm::cross(hint, z));
    y = glm::cross(z, x);
}

DsmViewGpu perspective_view(const glm::vec3& position, const glm::vec3& forward, float tan_half,
                            const std::vector<std::array<float, 3>>& corners, int resolution) {
    DsmViewGpu v{};
    glm::vec3 x, y, z;
    frame(forward, x, y, z);
    v.axis_x = f4(x), v.axis_y = f4(y), v.axis_z = f4(z), v.origin = f4(position, 1.f);
    v.extent_x = v.extent_y = tan_half;
    v.resolution = cl_uint(resolution);
    v.perspective = 1;
    // depth = distance from the light: the nearest and farthest box corners bound the objects
    // (near 0 when the light sits inside a box)
    v.near_depth = INFINITY, v.far_depth = 0.f;
    for (auto& c : corners) {
        float d = glm::length(glm::vec3(c[0], c[1], c[2]) - position);
        v.near_depth = std::min(v.near_depth, d), v.far_depth = std::max(v.far_depth, d);
    }
    return v;
}

}  // namespace

std::vector<std::array<float, 3>> scene_box_corners(const packing::PackedScene& packed, const Scene& scene) {
    std::vector<std::array<float, 3>> corners;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const auto& m = packed.voxel_to_world[i];
        const auto& dims = scene.volumes[i].volume->dims;
        for (int c = 0; c < 8; ++c) {
            float p[3] = {c & 1 ? dims[0] - 0.5f : -0.5f, c & 2 ? dims[1] - 0.5f : -0.5f, c & 4 ? dims[2] - 0.5f : -0.5f};
            std::array<float, 3> w{};
            for (int r = 0; r < 3; ++r) w[r] = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            corners.push_back(w);
        }
    }
    for (const MeshInstance& mi : scene.meshes)  // meshes cast shadows too: their vertices bound them
        for (const auto& p : mi.mesh->positions) {
            const auto& m = mi.transform;
            std::array<float, 3> w{};
            for (int r = 0; r < 3; ++r) w[r] = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            corners.push_back(w);
        }
    return corners;
}

std::vector<DsmViewGpu> make_dsm_views(const Scene& scene, const packing::PackedScene& packed, int resolution,
                                       std::vector<DsmLightViews>* light_views) {
    auto corners = scene_box_corners(packed, scene);
    std::vector<DsmViewGpu> views;
    for (std::size_t li = 0; li < scene.lights.size(); ++li) {
        const Light& l = scene.lights[li];
        DsmLightViews range{cl_uint(views.size()), 0};
        glm::vec3 position(l.position[0], l.position[1], l.position[2]);
        glm::vec3 direction(l.direction[0], l.direction[1], l.direction[2]);
        if (l.type == LightType::Spot) {
            views.push_back(perspective_view(position, direction, std::tan(l.cone_angle_deg * float(kPi) / 180.f),
                                             corners, resolution));
        } else if (l.type == LightType::Point) {
            // cube faces +x, −x, +y, −y, +z, −z, each a 90° frustum (tan 45° = 1)
            const glm::vec3 faces[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
            for (const glm::vec3& f : faces) views.push_back(perspective_view(position, f, 1.f, corners, resolution));
        } else {
            // orthographic box around the scene, seen along the light direction
            DsmViewGpu v{};
            glm::vec3 x, y, z;
            frame(direction, x, y, z);
            glm::vec3 lo(INFINITY), hi(-INFINITY);
            for (auto& c : corners) {
                glm::vec3 w(c[0], c[1], c[2]);
                glm::vec3 q(glm::dot(w, x), glm::dot(w, y), glm::dot(w, z));
                lo = glm::min(lo, q), hi = glm::max(hi, q);
            }
            glm::vec3 margin = 1e-3f * (hi - lo) + glm::vec3(1e-6f);  // texels of the border stay inside
            lo -= margin, hi += margin;
            glm::vec3 centre = 0.5f * (lo + hi);
            v.axis_x = f4(x), v.axis_y = f4(y), v.axis_z = f4(z);
            v.origin = f4(centre.x * x + centre.y * y + lo.z * z, 1.f);
            v.extent_x = 0.5f * (hi.x - lo.x), v.extent_y = 0.5f * (hi.y - lo.y);
            v.resolution = cl_uint(resolution);
            v.perspective = 0;
            v.near_depth = 0.f, v.far_depth = hi.z - lo.z;
            views.push_back(v);
        }
        range.count = cl_uint(views.size()) - range.first;
        if (light_views) light_views->push_back(range);
    }
    for (std::size_t i = 0; i < views.size(); ++i) {
        views[i].first_texel = cl_uint(i * std::size_t(resolution) * resolution);
        views[i].volume_mask = ~0u;
    }
    if (views.size() * std::size_t(resolution) * resolution >= 0xffffffffull)
        throw Error("--dsm-res: too many texels for 32-bit indices");
    return views;
}

void place_map(const DsmViewGpu& view, DeepShadowMap& map) {
    const cl_float4 axes[3] = {view.axis_x, view.axis_y, view.axis_z};
    const float handedness[3] = {1.f, -1.f, 1.f};  // left-handed, y up: camera y = −axis_y
    glm::mat4 camera(1.f);                        // glm: column-major, camera[column][row]
    for (int r = 0; r < 3; ++r) {
        float offset = 0.f;
        for (int c = 0; c < 3; ++c) {
            camera[c][r] = handedness[r] * axes[r].s[c];
            offset -= camera[c][r] * view.origin.s[c];
        }
        camera[3][r] = offset;
    }
    // camera → NDC: x/(z·extent) ∈ [−1, 1] (perspective, w = z) or x/extent (orthographic, w = 1)
    // to [0, 1], y flipped (NDC y goes down the rows)
    const float w_from_z = view.perspective ? 1.f : 0.f;
    glm::mat4 projection(0.f);
    projection[0][0] = 0.5f / view.extent_x;
    projection[1][1] = -0.5f / view.extent_y;
    projection[2][0] = projection[2][1] = 0.5f * w_from_z;
    projection[3][0] = projection[3][1] = 0.5f * (1.f - w_from_z);
    projection[2][2] = 1.f;
    projection[2][3] = w_from_z;
    projection[3][3] = 1.f - w_from_z;
    const glm::mat4 ndc = projection * camera;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            map.world_to_camera[std::size_t(r * 4 + c)] = camera[c][r];
            map.world_to_ndc[std::size_t(r * 4 + c)] = ndc[c][r];
        }
}

SubPixelMaps sub_pixel_views(const std::vector<DsmViewGpu>& views, const std::string& filter, bool jitter, unsigned seed) {
    if (filter != "box" && filter != "tent" && filter != "5tap")
        throw Error("--prefilter: unknown filter '" + filter + "' (none, box, tent, 5tap)");
    SubPixelMaps sub;
    int n = views.empty() ? 0 : int(views.front().resolution);
    bool quincunx = filter == "5tap";
    // box, tent: the view at 2N, each ray anywhere in its fine cell (a quarter texel). 5tap: the
    // view widened by one texel (N + 1 texels of the same size, centred), so texel centres are the
    // view's corners; map 0 shifts them by ½ to the view's texel centres. Jitter ±¼ texel keeps
    // each quincunx ray in its own cell (the diamond |dx| + |dy| ≤ ½).
    sub.maps = quincunx ? 2 : 1;
    sub.scale = quincunx ? 1 : 2;
    sub.resolution = quincunx ? n + 1 : 2 * n;
    std::size_t texels = std::size_t(sub.resolution) * sub.resolution;
    if (views.size() * sub.maps * texels >= 0xffffffffull) throw Error("--dsm-res: too many texels for 32-bit indices");
    for (const DsmViewGpu& view : views)
        for (int m = 0; m < sub.maps; ++m) {
            DsmViewGpu v = view;
            v.resolution = cl_uint(sub.resolution);
            v.first_texel = cl_uint(sub.views.size() * texels);
            if (quincunx) {
                float widen = float(n + 1) / float(n);
                v.extent_x *= widen, v.extent_y *= widen;
                v.ray_shift = m == 0 ? 0.5f : 0.f;
            }
            v.jitter = jitter ? (quincunx ? 0.5f : 1.f) : 0.f;
            v.jitter_seed = sombra_hash(seed + sombra_hash(cl_uint(sub.views.size())));
            sub.views.push_back(v);
        }
    return sub;
}

}  // namespace sombra::shadows
