#include "geometry/rasterizer.h"
#include "host/kernel_args.h"
#include "math_constants.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "sombra/error.h"

namespace sombra::raster {
namespace {

using Vec = std::array<double, 3>;

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) {
    double l = std::sqrt(dot(a, a));
    return {a[0] / l, a[1] / l, a[2] / l};
}
template <typename T>
Vec to_vec(const T& v) { return {double(v[0]), double(v[1]), double(v[2])}; }

// Homogeneous view-space corner: X = qx / extent_x, Y = qy / extent_y, Z = view z, W = Z or 1.
struct Clip {
    double X, Y, Z, W;
    bool operator<(const Clip& o) const {
        return std::tie(X, Y, Z, W) < std::tie(o.X, o.Y, o.Z, o.W);
    }
};

constexpr int kPlanes = 5;      // near, then the guard band's four sides
constexpr double kGuard = 2.0;  // |ndc| ≤ 2: screen ± half its size

double plane_distance(const Clip& c, int plane, double near_depth) {
    switch (plane) {
        case 0: return c.Z - near_depth;
        case 1: return kGuard * c.W - c.X;
        case 2: return kGuard * c.W + c.X;
        case 3: return kGuard * c.W - c.Y;
        default: return kGuard * c.W + c.Y;
    }
}

// Sutherland–Hodgman against one plane. The crossing point of an edge is computed from its
// corners in a fixed order, so that two triangles sharing the edge get the same point.
std::vector<Clip> clip_polygon(const std::vector<Clip>& in, int plane, double near_depth) {
    std::vector<Clip> out;
    for (std::size_t i = 0; i < in.size(); ++i) {
        Clip a = in[i], b = in[(i + 1) % in.size()];
        double da = plane_distance(a, plane, near_depth), db = plane_distance(b, plane, near_depth);
        if (da >= 0) out.push_back(a);
        if ((da >= 0) != (db >= 0)) {
            if (b < a) std::swap(a, b), std::swap(da, db);
            double t = da / (da - db);
            out.push_back({a.X + t * (b.X - a.X), a.Y + t * (b.Y - a.Y), a.Z + t * (b.Z - a.Z), a.W + t * (b.W - a.W)});
        }
    }
    return out;
}

constexpr double kSubpixel = double(1 << SOMBRA_SUBPIXEL_BITS);

// Snapped screen triangle of three clip-space corners; q and the plane from the snapped corners.
ScreenTriangleGpu screen_triangle(const Clip* c, const View& view) {
    ScreenTriangleGpu t{};
    double x[3], y[3], q[3];
    cl_int* xs[3] = {&t.x.s[0], &t.x.s[1], &t.x.s[2]};
    cl_int* ys[3] = {&t.y.s[0], &t.y.s[1], &t.y.s[2]};
    for (int k = 0; k < 3; ++k) {
        double sx = (c[k].X / c[k].W * 0.5 + 0.5) * view.width - view.pixel_shift;
        double sy = (c[k].Y / c[k].W * 0.5 + 0.5) * view.height - view.pixel_shift;
        *xs[k] = cl_int(std::llround(sx * kSubpixel));
        *ys[k] = cl_int(std::llround(sy * kSubpixel));
        x[k] = *xs[k] / kSubpixel, y[k] = *ys[k] / kSubpixel;
        q[k] = view.perspective ? 1.0 / c[k].W : c[k].Z;
    }
    double det = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    double dqdx = 0, dqdy = 0;
    if (det != 0) {
        dqdx = ((q[1] - q[0]) * (y[2] - y[0]) - (q[2] - q[0]) * (y[1] - y[0])) / det;
        dqdy = ((x[1] - x[0]) * (q[2] - q[0]) - (x[2] - x[0]) * (q[1] - q[0])) / det;
    }
    t.depth_plane = {{float(q[0]), float(dqdx), float(dqdy), 0.f}};
    return t;
}

void check_size(const View& view) {
    if (view.width < 1 || view.height < 1 || view.width > 16384 || view.height > 16384)
        throw Error("rasterizer: width and height must lie in [1, 16384]");
}

}  // namespace

View camera_view(const Camera& camera, int width, int height, double near_depth) {
    View v;
    Vec forward = normalized(sub(to_vec(camera.look_at), to_vec(camera.position)));
    Vec right = normalized(cross(forward, to_vec(camera.up)));
    Vec up = cross(right, forward);
    double tan_half = std::tan(0.5 * double(camera.fov_y_deg) * kPi / 180.0);
    v.origin = to_vec(camera.position);
    v.axis_x = right;
    v.axis_y = {-up[0], -up[1], -up[2]};  // screen y down (cl/render.cl: sy = 1 − 2(y + ½)/H)
    v.axis_z = forward;
    v.extent_x = tan_half * double(width) / double(height);
    v.extent_y = tan_half;
    v.near_depth = near_depth;
    v.width = width, v.height = height;
    return v;
}

View dsm_view(const DsmViewGpu& d) {
    View v;
    v.origin = to_vec(d.origin.s);
    v.axis_x = to_vec(d.axis_x.s), v.axis_y = to_vec(d.axis_y.s), v.axis_z = to_vec(d.axis_z.s);
    v.perspective = d.perspective != 0;
    v.extent_x = d.extent_x, v.extent_y = d.extent_y;
    v.near_depth = v.perspective ? std::max(1e-6, double(d.near_depth)) : 0.0;
    v.width = v.height = int(d.resolution);
    v.pixel_shift = d.ray_shift;
    return v;
}

Projection project_meshes(const std::vector<MeshInstance>& meshes, const View& view) {
    check_size(view);
    Projection out;
    cl_uint source = 0;
    for (std::size_t mi = 0; mi < meshes.size(); ++mi) {
        if (!meshes[mi].mesh) throw Error("rasterizer: mesh instance " + std::to_string(mi) + " has no mesh");
        const Mesh& mesh = *meshes[mi].mesh;
        const auto& m = meshes[mi].transform;
        std::vector<Vec> world(mesh.positions.size());
        std::vector<Clip> clip(mesh.positions.size());
        for (std::size_t i = 0; i < world.size(); ++i) {
            Vec p = to_vec(mesh.positions[i]);
            for (int r = 0; r < 3; ++r) world[i][r] = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            Vec d = sub(world[i], view.origin);
            double qz = dot(d, view.axis_z);
            clip[i] = {dot(d, view.axis_x) / view.extent_x, dot(d, view.axis_y) / view.extent_y, qz, view.perspective ? qz : 1.0};
        }
        for (const auto& tri : mesh.triangles) {
            ++out.source_triangles;
            cl_uint id = source++;
            Clip c[3] = {clip[tri[0]], clip[tri[1]], clip[tri[2]]};
            bool finite = true;
            for (auto& k : c) finite = finite && std::isfinite(k.X) && std::isfinite(k.Y) && std::isfinite(k.Z);
            if (!finite) { ++out.non_finite; continue; }
            bool all_inside = true, outside = false;
            for (int p = 0; p < kPlanes; ++p) {
                int in = 0;
                for (auto& k : c) in += plane_distance(k, p, view.near_depth) >= 0;
                all_inside = all_inside && in == 3;
                outside = outside || in == 0;
            }
            if (outside) { ++out.culled; continue; }
            Vec n = cross(sub(world[tri[1]], world[tri[0]]), sub(world[tri[2]], world[tri[0]]));
            double facing = view.perspective ? dot(n, sub(world[tri[0]], view.origin)) : dot(n, view.axis_z);
            cl_uint flags = facing > 0 ? SOMBRA_TRI_BACK_FACING : 0u;
            std::vector<Clip> poly(c, c + 3);
            if (!all_inside) {
                for (int p = 0; p < kPlanes && poly.size() >= 3; ++p) poly = clip_polygon(poly, p, view.near_depth);
                if (poly.size() < 3) { ++out.culled; continue; }
                ++out.clipped;
            }
            for (std::size_t k = 1; k + 1 < poly.size(); ++k) {  // fan: the pieces share their diagonals
                Clip piece[3] = {poly[0], poly[k], poly[k + 1]};
                ScreenTriangleGpu t = screen_triangle(piece, view);
                t.source = id, t.mesh = cl_uint(mi), t.flags = flags;
                out.triangles.push_back(t);
            }
        }
    }
    return out;
}

RasterScreenGpu make_screen(const View& view) {
    check_size(view);
    RasterScreenGpu s{};
    s.width = cl_uint(view.width), s.height = cl_uint(view.height);
    s.tiles_x = (s.width + SOMBRA_TILE_SIZE - 1) / SOMBRA_TILE_SIZE;
    s.tiles_y = (s.height + SOMBRA_TILE_SIZE - 1) / SOMBRA_TILE_SIZE;
    s.perspective = view.perspective ? 1 : 0;
    s.extent_x = float(view.extent_x), s.extent_y = float(view.extent_y);
    s.pixel_shift = float(view.pixel_shift);
    return s;
}

DeviceTiles rasterize(host::Runtime& rt, const std::vector<ScreenTriangleGpu>& triangles, const RasterScreenGpu& screen) {
    DeviceTiles d;
    d.screen = screen;
    d.stats.triangles = triangles.size();
    const std::size_t tiles = std::size_t(screen.tiles_x) * screen.tiles_y;
    const auto n = cl_uint(triangles.size());
    auto& q = rt.queue();
    d.screen_buffer = host::make_buffer(rt, CL_MEM_READ_ONLY, sizeof screen, &screen, "rasterizer screen");
    d.triangles = host::make_buffer(rt, CL_MEM_READ_ONLY, triangles.size() * sizeof(ScreenTriangleGpu),
                                    triangles.data(), "rasterizer triangles");
    std::vector<cl_uint> count(tiles, 0), first(tiles, 0);
    d.count = host::make_buffer(rt, CL_MEM_READ_WRITE, tiles * sizeof(cl_uint), count.data(), "tile counts");
    cl::Program& program = rt.program("raster.cl", {});
    if (n > 0) {  // pass 1: entries per tile
        cl::Kernel k(program, "raster_count");
        host::KernelArgs{k}("tris", d.triangles)("triangle_count", n)("screen", d.screen_buffer)("counts", d.count).done();
        cl::Event e;
        q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n), cl::NullRange, nullptr, &e);
        q.enqueueReadBuffer(d.count, CL_TRUE, 0, tiles * sizeof(cl_uint), count.data());
        d.stats.count_ms = host::Runtime::event_ms(e);
    }
    std::size_t chunks = 0;  // prefix sum over whole chunks per tile
    for (std::size_t t = 0; t < tiles; ++t) {
        first[t] = cl_uint(chunks);
        chunks += (count[t] + SOMBRA_TILE_CHUNK - 1) / SOMBRA_TILE_CHUNK;
        d.stats.entries += count[t];
        d.stats.max_tile_entries = std::max<std::size_t>(d.stats.max_tile_entries, count[t]);
    }
    if (chunks * SOMBRA_TILE_CHUNK > 0xFFFFFFFFull) throw Error("rasterizer: more than 2^32 tile entries");
    d.stats.chunks = chunks;
    d.stats.wasted_slots = chunks * SOMBRA_TILE_CHUNK - d.stats.entries;
    const std::size_t slots = chunks * SOMBRA_TILE_CHUNK;
    d.first_chunk = host::make_buffer(rt, CL_MEM_READ_ONLY, tiles * sizeof(cl_uint), first.data(), "tile chunks");
    d.masks = host::make_buffer(rt, CL_MEM_READ_WRITE, slots * sizeof(cl_ulong), nullptr, "tile coverage masks");
    d.ids = host::make_buffer(rt, CL_MEM_READ_WRITE, slots * sizeof(cl_uint), nullptr, "tile triangle ids");
    if (d.stats.entries > 0) {  // pass 2: write the masks into the allocated chunks
        std::vector<cl_uint> zeros(tiles + 1, 0);
        cl::Buffer fill = host::make_buffer(rt, CL_MEM_READ_WRITE, tiles * sizeof(cl_uint), zeros.data(), "tile fill");
        cl::Buffer overflow = host::make_buffer(rt, CL_MEM_READ_WRITE, sizeof(cl_uint), zeros.data(), "raster overflow");
        cl::Kernel k(program, "raster_write");
        host::KernelArgs{k}("tris", d.triangles)("triangle_count", n)("screen", d.screen_buffer)("counts", d.count)(
            "first_chunk", d.first_chunk)("fill", fill)("masks", d.masks)("ids", d.ids)("overflow", overflow).done();
        cl::Event e;
        q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n), cl::NullRange, nullptr, &e);
        cl_uint lost = 0;
        q.enqueueReadBuffer(overflow, CL_TRUE, 0, sizeof lost, &lost);
        d.stats.write_ms = host::Runtime::event_ms(e);
        d.stats.overflow = lost;
        if (lost) throw Error("rasterizer: " + std::to_string(lost) + " tile entries found no slot (count and write passes disagree)");
    }
    return d;
}

HostTiles read_back(host::Runtime& rt, const DeviceTiles& d) {
    HostTiles h;
    h.screen = d.screen;
    h.stats = d.stats;
    const std::size_t tiles = std::size_t(d.screen.tiles_x) * d.screen.tiles_y, slots = d.stats.chunks * SOMBRA_TILE_CHUNK;
    h.count.resize(tiles), h.first_chunk.resize(tiles), h.masks.resize(slots), h.ids.resize(slots);
    auto& q = rt.queue();
    q.enqueueReadBuffer(d.count, CL_FALSE, 0, tiles * sizeof(cl_uint), h.count.data());
    q.enqueueReadBuffer(d.first_chunk, CL_FALSE, 0, tiles * sizeof(cl_uint), h.first_chunk.data());
    if (slots) {
        q.enqueueReadBuffer(d.masks, CL_FALSE, 0, slots * sizeof(cl_ulong), h.masks.data());
        q.enqueueReadBuffer(d.ids, CL_FALSE, 0, slots * sizeof(cl_uint), h.ids.data());
    }
    q.finish();
    return h;
}

}  // namespace sombra::raster
