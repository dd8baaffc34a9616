#include "shadows/sat_grid.h"

#include <algorithm>
#include <cmath>

#include "shadows/dsm_builder.h"
#include "sombra/error.h"

namespace sombra::shadows {
namespace {

double dot(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
D3 cross(const D3& a, const D3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
D3 normalized(const D3& a) {
    double n = std::sqrt(dot(a, a));
    return {a[0] / n, a[1] / n, a[2] / n};
}
cl_float4 f4(const D3& v, double w = 0) { return {{float(v[0]), float(v[1]), float(v[2]), float(w)}}; }

// World corners of every volume's box [−0.5, dims − 0.5] and the smallest world voxel length.
std::vector<D3> scene_corners(const packing::PackedScene& packed, double& voxel_size) {
    std::vector<D3> corners;
    voxel_size = INFINITY;
    for (std::size_t v = 0; v < packed.volumes.size(); ++v) {
        const auto& m = packed.voxel_to_world[v];
        const auto& dims = packed.volumes[v].dims.s;
        for (int c = 0; c < 3; ++c) voxel_size = std::min(voxel_size, std::sqrt(double(m[c]) * m[c] + double(m[4 + c]) * m[4 + c] + double(m[8 + c]) * m[8 + c]));
        for (int corner = 0; corner < 8; ++corner) {
            double q[3];
            for (int a = 0; a < 3; ++a) q[a] = (corner >> a) & 1 ? dims[a] - 0.5 : -0.5;
            D3 p;
            for (int r = 0; r < 3; ++r) p[std::size_t(r)] = m[std::size_t(4 * r)] * q[0] + m[std::size_t(4 * r + 1)] * q[1] + m[std::size_t(4 * r + 2)] * q[2] + m[std::size_t(4 * r + 3)];
            corners.push_back(p);
        }
    }
    return corners;
}

// The axis of `frame` that ±`towards_light` lies along, or −1.
int shared_axis(const SatFrame& frame, const D3& towards_light, bool& positive) {
    for (int a = 0; a < 3; ++a) {
        double c = dot(frame.axes[std::size_t(a)], towards_light);
        if (std::fabs(c) > 1.0 - 1e-6) {
            positive = c > 0;
            return a;
        }
    }
    return -1;
}

}  // namespace

D3 SatFrame::cell_centre(int i, int j, int k) const {
    D3 p = origin;
    double c[3] = {i + 0.5, j + 0.5, k + 0.5};
    for (int a = 0; a < 3; ++a)
        for (int r = 0; r < 3; ++r) p[std::size_t(r)] += c[a] * cell_size * axes[std::size_t(a)][std::size_t(r)];
    return p;
}

SatFrame make_csat_frame(const packing::PackedScene& packed, const D3& towards_light, std::size_t max_entries) {
    SatFrame f;
    D3 w = normalized(towards_light);
    // r_u ⟂ l from the world axis least aligned with l; r_v = l × r_u so that r_u × r_v = l (Ament Eq. 9)
    int least = 0;
    for (int a = 1; a < 3; ++a)
        if (std::fabs(w[std::size_t(a)]) < std::fabs(w[std::size_t(least)])) least = a;
    D3 e{0, 0, 0};
    e[std::size_t(least)] = 1;
    D3 u = normalized(cross(e, w)), v = cross(w, u);
    f.axes = {u, v, w};
    std::vector<D3> corners = scene_corners(packed, f.voxel_size);
    if (corners.empty() || !(f.voxel_size > 0)) throw Error("--shadows lowpass: the scene has no volume to build a summed-area table of");
    D3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const D3& p : corners)
        for (std::size_t a = 0; a < 3; ++a) {
            double c = dot(p, f.axes[a]);
            lo[a] = std::min(lo[a], c), hi[a] = std::max(hi[a], c);
        }
    f.cell_size = f.voxel_size;
    for (;;) {
        for (std::size_t a = 0; a < 3; ++a) f.dims[a] = std::max(1, int(std::ceil((hi[a] - lo[a]) / f.cell_size - 1e-6)));
        if (f.entries() <= std::min<std::size_t>(max_entries, SOMBRA_SAT_MAX_ENTRIES)) break;
        f.cell_size *= 1.05;
    }
    // centred on the bounds: mirrored lights (±l) see the same cells
    f.origin = {0, 0, 0};
    for (std::size_t a = 0; a < 3; ++a) {
        double start = 0.5 * (lo[a] + hi[a]) - 0.5 * f.dims[a] * f.cell_size;
        for (std::size_t r = 0; r < 3; ++r) f.origin[r] += start * f.axes[a][r];
    }
    return f;
}

std::uint64_t sat_fixed_point(double tau) {
    double clamped = std::clamp(tau, 0.0, double(SOMBRA_SAT_MAX_CELL_TAU));
    return std::uint64_t(std::nearbyint(float(float(clamped) * SOMBRA_SAT_UNITS_PER_TAU)));
}

DeviceSat build_light_sats(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                           const packing::DeviceScene& device_scene, std::size_t max_entries) {
    DeviceSat sat;
    std::vector<int> table_of(packed.lights.size(), -1);
    for (std::size_t l = 0; l < packed.lights.size(); ++l) {
        const LightGpu& light = packed.lights[l];
        SatGridGpu g{};
        if (light.type == SOMBRA_LIGHT_DIRECTIONAL) {
            D3 towards = {-light.direction.s[0], -light.direction.s[1], -light.direction.s[2]};
            bool positive = true;
            int axis = -1;
            std::size_t t = 0;
            for (; t < sat.frames.size() && axis < 0; ++t) axis = shared_axis(sat.frames[t], towards, positive);
            if (axis < 0) {  // a new table (Ament Alg. 1: recomputeCSAT)
                sat.frames.push_back(make_csat_frame(packed, towards, max_entries));
                axis = 2, positive = true, t = sat.frames.size();
            }
            const SatFrame& f = sat.frames[t - 1];
            for (std::size_t a = 0; a < 3; ++a) {
                D3 row = {f.axes[a][0] / f.cell_size, f.axes[a][1] / f.cell_size, f.axes[a][2] / f.cell_size};
                g.to_grid[a] = f4(row, -dot(row, f.origin));
            }
            g.dims = {{f.dims[0], f.dims[1], f.dims[2], 1}};
            g.light_axis = cl_uint(axis);
            g.light_positive = positive ? 1 : 0;
            g.tau_per_unit = 1.f / SOMBRA_SAT_UNITS_PER_TAU;
            g.cell_size = float(f.cell_size);
            g.filter_cells = 1;
            table_of[l] = int(t - 1);
        }
        sat.grids.push_back(g);
    }
    std::size_t total = 0;
    for (const SatFrame& f : sat.frames) sat.offsets.push_back(total), total += f.entries();
    if (total > 0xffffffffull) throw Error("--shadows lowpass: summed-area tables exceed 2^32 entries");
    for (std::size_t l = 0; l < sat.grids.size(); ++l)
        if (table_of[l] >= 0) sat.grids[l].data_offset = cl_uint(sat.offsets[std::size_t(table_of[l])]);
    sat.bytes = total * sizeof(cl_ulong);
    sat.data = host::make_buffer(runtime, CL_MEM_READ_WRITE, sat.bytes, nullptr, "summed-area tables");
    if (sat.frames.empty()) return sat;

    cl::Event event;
    runtime.queue().enqueueFillBuffer(sat.data, cl_ulong(0), 0, sat.bytes, nullptr, &event);
    event.wait();
    sat.stage_ms["sat_clear"] = host::Runtime::event_ms(event);
    auto defines = volume_pass_defines(scene, device_scene.uses_images, false);
    defines.push_back("SOMBRA_LANES=1");
    cl::Program& program = runtime.program("sat_build.cl", defines);
    cl::Kernel resample(program, "sat_resample"), scan(program, "sat_scan");
    for (std::size_t t = 0; t < sat.frames.size(); ++t) {
        const SatFrame& f = sat.frames[t];
        cl_int4 n = {{f.dims[0], f.dims[1], f.dims[2], 1}};
        int a = 0;
        if (device_scene.uses_images) resample.setArg(a++, device_scene.voxel_image);
        else resample.setArg(a++, device_scene.voxel_buffer);
        resample.setArg(a++, device_scene.tf_tables);
        resample.setArg(a++, device_scene.volumes);
        resample.setArg(a++, cl_uint(packed.volumes.size()));
        resample.setArg(a++, sat.data);
        resample.setArg(a++, cl_uint(sat.offsets[t]));
        resample.setArg(a++, n);
        resample.setArg(a++, f4(f.origin));
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const D3& r = f.axes[axis];
            resample.setArg(a++, f4({r[0] * f.cell_size, r[1] * f.cell_size, r[2] * f.cell_size}));
        }
        resample.setArg(a++, float(f.cell_size));
        runtime.queue().enqueueNDRangeKernel(resample, cl::NullRange, cl::NDRange(std::size_t(f.dims[0]), std::size_t(f.dims[1])),
                                             cl::NullRange, nullptr, &event);
        event.wait();
        sat.stage_ms["sat_resample"] += host::Runtime::event_ms(event);
        for (cl_uint axis = 0; axis < 2; ++axis) {  // axis 2 was summed by sat_resample
            scan.setArg(0, sat.data);
            scan.setArg(1, cl_uint(sat.offsets[t]));
            scan.setArg(2, n);
            scan.setArg(3, axis);
            std::size_t other = std::size_t(axis == 0 ? f.dims[1] : f.dims[0]);
            runtime.queue().enqueueNDRangeKernel(scan, cl::NullRange, cl::NDRange(other, std::size_t(f.dims[2])),
                                                 cl::NullRange, nullptr, &event);
            event.wait();
            sat.stage_ms["sat_scan"] += host::Runtime::event_ms(event);
        }
    }
    return sat;
}

cl::Buffer upload_sat_grids(host::Runtime& runtime, const DeviceSat& sat, float filter_voxels) {
    std::vector<SatGridGpu> grids = sat.grids;
    for (std::size_t l = 0; l < grids.size(); ++l) {
        if (grids[l].dims.s[3] == 0) continue;
        double cells = std::round(double(filter_voxels) * sat.frames[0].voxel_size / grids[l].cell_size);
        grids[l].filter_cells = cl_uint(std::clamp(cells, 1.0, 4096.0));
    }
    return host::make_buffer(runtime, CL_MEM_READ_ONLY, grids.size() * sizeof(SatGridGpu), grids.data(), "SAT grids");
}

std::vector<std::uint64_t> read_sat(host::Runtime& runtime, const DeviceSat& sat, std::size_t table) {
    std::vector<std::uint64_t> out(sat.frames.at(table).entries());
    runtime.queue().enqueueReadBuffer(sat.data, CL_TRUE, sat.offsets[table] * sizeof(cl_ulong), out.size() * sizeof(cl_ulong),
                                      out.data());
    return out;
}

}  // namespace sombra::shadows
