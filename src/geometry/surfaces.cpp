#include "geometry/surfaces.h"

#include <algorithm>
#include <cmath>

#include "geometry/bvh.h"

namespace sombra::surfaces {
namespace {

using V3 = std::array<double, 3>;

V3 transform_point(const std::array<float, 16>& m, const std::array<float, 3>& p) {
    V3 r{};
    for (int i = 0; i < 3; ++i) r[i] = m[i * 4] * p[0] + m[i * 4 + 1] * p[1] + m[i * 4 + 2] * p[2] + m[i * 4 + 3];
    return r;
}

// Normals transform with the inverse transpose of the 3×3 part, ∝ its cofactor matrix (the scale
// and sign do not matter: normals are normalized and shading turns them to the viewer).
V3 transform_normal(const std::array<float, 16>& m, const std::array<float, 3>& n) {
    auto a = [&](int r, int c) { return double(m[r * 4 + c]); };
    double cof[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            cof[r][c] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
        }
    V3 out{};
    for (int r = 0; r < 3; ++r) out[r] = cof[r][0] * n[0] + cof[r][1] * n[1] + cof[r][2] * n[2];
    return out;
}

cl_float4 f4(const V3& v, double w = 0) { return {{float(v[0]), float(v[1]), float(v[2]), float(w)}}; }

V3 unit(const V3& v) {
    double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return l > 0 ? V3{v[0] / l, v[1] / l, v[2] / l} : V3{0, 0, 0};
}

// Triangle `tri` of `mesh` moved to the world by `transform`; corner.w = w.
SurfaceTriangleGpu world_triangle(const Mesh& mesh, const std::array<std::uint32_t, 3>& tri, const std::array<float, 16>& transform,
                                  float w) {
    V3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = transform_point(transform, mesh.positions[tri[std::size_t(k)]]);
    V3 e1{p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    V3 e2{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    V3 face = unit({e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]});
    SurfaceTriangleGpu t{};
    t.corner = f4(p[0], w), t.corner1 = f4(p[1]), t.corner2 = f4(p[2]);
    for (int k = 0; k < 3; ++k) {
        V3 n = mesh.normals.empty() ? face : unit(transform_normal(transform, mesh.normals[tri[std::size_t(k)]]));
        t.normal[k] = f4(n);
    }
    return t;
}

}  // namespace

PackedSurfaces pack_surfaces(const Scene& scene) {
    PackedSurfaces out;
    for (const MeshInstance& mi : scene.meshes) {
        const MeshMaterial& mat = mi.material;
        SurfaceMaterialGpu g{};
        g.color = {{mat.color[0], mat.color[1], mat.color[2], mat.opacity}};
        g.ambient = mat.phong.ambient, g.diffuse = mat.phong.diffuse, g.specular = mat.phong.specular;
        g.shininess = mat.phong.shininess;
        out.materials.push_back(g);
        for (const auto& tri : mi.mesh->triangles) out.triangles.push_back(world_triangle(*mi.mesh, tri, mi.transform, mat.opacity));
    }
    return out;
}

bool has_bounds(const Scene& scene) {
    for (const VolumeInstance& vi : scene.volumes)
        if (vi.bound.mesh) return true;
    return false;
}

bool has_fragments(const Scene& scene) { return !scene.meshes.empty() || has_bounds(scene); }

std::vector<SurfaceTriangleGpu> pack_bounds(const Scene& scene, std::vector<VolumeGpu>& volumes) {
    std::vector<SurfaceTriangleGpu> out;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeInstance& vi = scene.volumes[i];
        volumes[i].bound_first = cl_uint(out.size());
        if (vi.bound.mesh)
            for (const auto& tri : vi.bound.mesh->triangles)
                out.push_back(world_triangle(*vi.bound.mesh, tri, bound_to_world(vi), float(i)));
        volumes[i].bound_count = cl_uint(out.size()) - volumes[i].bound_first;
    }
    return out;
}

DeviceSurfaces upload_surfaces(host::Runtime& rt, const PackedSurfaces& p) {
    DeviceSurfaces d;
    d.triangle_count = cl_uint(p.triangles.size());
    d.triangles = host::make_buffer(rt, CL_MEM_READ_ONLY, p.triangles.size() * sizeof(SurfaceTriangleGpu), p.triangles.data(),
                                    "surface triangles");
    d.materials = host::make_buffer(rt, CL_MEM_READ_ONLY, p.materials.size() * sizeof(SurfaceMaterialGpu), p.materials.data(),
                                    "surface materials");
    return d;
}

ShadowBvh upload_shadow_bvh(host::Runtime& rt, const std::vector<SurfaceTriangleGpu>& triangles, const std::string& what) {
    bvh::Hierarchy h = bvh::build(triangles);
    std::vector<SurfaceTriangleGpu> ordered = bvh::reorder(triangles, h);
    ShadowBvh d;
    d.node_count = cl_uint(h.nodes.size());
    d.triangles = host::make_buffer(rt, CL_MEM_READ_ONLY, ordered.size() * sizeof(SurfaceTriangleGpu), ordered.data(),
                                    what + " triangles");
    d.nodes = host::make_buffer(rt, CL_MEM_READ_ONLY, h.nodes.size() * sizeof(BvhNodeGpu), h.nodes.data(), what + " BVH");
    return d;
}

ViewFragments view_fragments(host::Runtime& rt, const Scene& scene, const raster::View& view, const std::vector<bool>& meshes_held,
                             cl_uint volume_mask) {
    // surfaces first, then every volume's bound mesh: one fragment list (Knecht §3.1.2)
    std::vector<MeshInstance> meshes = scene.meshes;
    std::vector<cl_uint> bound_volume;
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const VolumeInstance& vi = scene.volumes[i];
        if (!vi.bound.mesh) continue;
        MeshInstance bound;
        bound.mesh = vi.bound.mesh;
        bound.transform = bound_to_world(vi);
        meshes.push_back(bound);
        bound_volume.push_back(cl_uint(i));
    }
    ViewFragments v;
    raster::Projection projection = raster::project_meshes(meshes, view);
    for (ScreenTriangleGpu& t : projection.triangles)
        if (t.mesh >= scene.meshes.size()) t.flags |= SOMBRA_TRI_BOUND, t.mesh = bound_volume[t.mesh - scene.meshes.size()];
    auto held = [&](const ScreenTriangleGpu& t) {
        if (t.flags & SOMBRA_TRI_BOUND) return (volume_mask >> t.mesh & 1u) != 0;  // volumes: < SOMBRA_MAX_VOLUMES = 32
        return meshes_held.empty() || meshes_held[t.mesh];
    };
    if (!meshes_held.empty() || volume_mask != ~0u)
        projection.triangles.erase(std::remove_if(projection.triangles.begin(), projection.triangles.end(),
                                                  [&](const ScreenTriangleGpu& t) { return !held(t); }),
                                   projection.triangles.end());
    v.tiles = raster::rasterize(rt, projection.triangles, raster::make_screen(view));
    v.fragments = raster::sort_fragments(rt, v.tiles);
    return v;
}

}  // namespace sombra::surfaces
