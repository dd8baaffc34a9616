#include "shadows/sat_grid.h"

#include "host/kernel_args.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <type_traits>

#include "host/tiled_launch.h"
#include "math_constants.h"
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

// A unit vector ⟂ w, from the world axis least aligned with w.
D3 perpendicular(const D3& w) {
    int least = 0;
    for (int a = 1; a < 3; ++a)
        if (std::fabs(w[std::size_t(a)]) < std::fabs(w[std::size_t(least)])) least = a;
    D3 e{0, 0, 0};
    e[std::size_t(least)] = 1;
    return normalized(cross(e, w));
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

// The 8 world corners of volume v's voxel-coordinate box [lo, hi], appended to `corners`.
void add_box_corners(const packing::PackedScene& packed, std::size_t v, const double lo[3], const double hi[3], std::vector<D3>& corners) {
    const auto& m = packed.voxel_to_world[v];
    for (int corner = 0; corner < 8; ++corner) {
        double q[3];
        for (int a = 0; a < 3; ++a) q[a] = (corner >> a) & 1 ? hi[a] : lo[a];
        D3 p;
        for (int r = 0; r < 3; ++r) p[std::size_t(r)] = m[std::size_t(4 * r)] * q[0] + m[std::size_t(4 * r + 1)] * q[1] + m[std::size_t(4 * r + 2)] * q[2] + m[std::size_t(4 * r + 3)];
        corners.push_back(p);
    }
}

}  // namespace

std::vector<D3> scene_corners(const packing::PackedScene& packed, double& voxel_size) {
    std::vector<D3> corners;
    voxel_size = INFINITY;
    for (std::size_t v = 0; v < packed.volumes.size(); ++v) {
        const auto& m = packed.voxel_to_world[v];
        const auto& dims = packed.volumes[v].dims.s;
        for (int c = 0; c < 3; ++c) voxel_size = std::min(voxel_size, std::sqrt(double(m[c]) * m[c] + double(m[4 + c]) * m[4 + c] + double(m[8 + c]) * m[8 + c]));
        const double lo[3] = {-0.5, -0.5, -0.5}, hi[3] = {dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5};
        add_box_corners(packed, v, lo, hi, corners);
    }
    return corners;
}

std::vector<std::vector<D3>> occupied_corners_per_volume(const packing::PackedScene& packed, double& voxel_size) {
    scene_corners(packed, voxel_size);
    std::vector<std::vector<D3>> out(packed.volumes.size());
    for (std::size_t v = 0; v < packed.volumes.size(); ++v) {
        const VolumeGpu& g = packed.volumes[v];
        int lo[3] = {INT_MAX, INT_MAX, INT_MAX}, hi[3] = {-1, -1, -1};  // occupied brick range
        for (int bz = 0; bz < g.brick_dims.s[2]; ++bz)
            for (int by = 0; by < g.brick_dims.s[1]; ++by)
                for (int bx = 0; bx < g.brick_dims.s[0]; ++bx) {
                    std::size_t b = g.brick_offset + std::size_t(bx) + std::size_t(g.brick_dims.s[0]) * (std::size_t(by) + std::size_t(g.brick_dims.s[1]) * std::size_t(bz));
                    if (!packed.occupancy[b]) continue;
                    const int at[3] = {bx, by, bz};
                    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], at[a]), hi[a] = std::max(hi[a], at[a]);
                }
        if (hi[0] < 0) continue;
        // voxel coordinates, out to the voxel boundaries (cells of one voxel stay the voxels, as on
        // the whole box); the outer bricks reach the box's faces (clamped reads)
        double q_lo[3], q_hi[3];
        for (int a = 0; a < 3; ++a) {
            q_lo[a] = SOMBRA_BRICK_SIZE * lo[a] - 0.5;
            q_hi[a] = std::min(SOMBRA_BRICK_SIZE * hi[a] + SOMBRA_BRICK_SIZE, g.dims.s[a] - 1) + 0.5;
        }
        add_box_corners(packed, v, q_lo, q_hi, out[v]);
    }
    return out;
}

std::vector<D3> occupied_corners(const packing::PackedScene& packed, double& voxel_size) {
    std::vector<D3> corners;
    for (const std::vector<D3>& c : occupied_corners_per_volume(packed, voxel_size)) corners.insert(corners.end(), c.begin(), c.end());
    return corners.empty() ? scene_corners(packed, voxel_size) : corners;
}

D3 SatFrame::cell_centre(int i, int j, int k) const {
    D3 p = origin;
    double c[3] = {i + 0.5, j + 0.5, k + 0.5};
    for (int a = 0; a < 3; ++a)
        for (int r = 0; r < 3; ++r) p[std::size_t(r)] += c[a] * cell(std::size_t(a)) * axes[std::size_t(a)][std::size_t(r)];
    return p;
}

namespace {
// r_v = l × r_u so that r_u × r_v = l (Ament Eq. 9)
std::array<D3, 3> csat_axes(const D3& towards_light) {
    D3 w = normalized(towards_light);
    D3 u = perpendicular(w), v = cross(w, u);
    return {u, v, w};
}

// A frame with `axes` around the volumes' occupied bricks (the CSATs).
SatFrame make_occupied_frame(const packing::PackedScene& packed, const std::array<D3, 3>& axes, std::size_t max_entries) {
    double voxel = 0;
    std::vector<D3> corners = occupied_corners(packed, voxel);
    return make_sat_frame(corners, voxel, axes, max_entries);
}
}  // namespace

SatFrame make_csat_frame(const packing::PackedScene& packed, const D3& towards_light, std::size_t max_entries) {
    return make_occupied_frame(packed, csat_axes(towards_light), max_entries);
}

SatFrame make_shared_csat_frame(const packing::PackedScene& packed, const D3& towards_light, std::size_t max_entries) {
    return make_occupied_frame(packed, shared_csat_axes(towards_light), max_entries);
}

std::array<D3, 3> shared_csat_axes(const D3& towards_light) {
    std::array<D3, 3> axes = csat_axes(towards_light);
    auto major = [](const D3& a) {  // index of the largest |component| (the first of equals)
        std::size_t m = 0;
        for (std::size_t r = 1; r < 3; ++r)
            if (std::fabs(a[r]) > std::fabs(a[m])) m = r;
        return m;
    };
    for (D3& a : axes) {
        double sign = a[major(a)] < 0 ? -1.0 : 1.0;
        for (double& c : a) c = sign * c + 0.0;  // + 0.0: no −0, so equal frames have equal bits
    }
    std::sort(axes.begin(), axes.end(), [&](const D3& a, const D3& b) {
        return major(a) != major(b) ? major(a) < major(b) : a < b;
    });
    return axes;
}

SatFrame make_volume_sat_frame(const packing::PackedScene& packed, std::size_t max_entries, double coarsen) {
    if (packed.voxel_to_world.empty()) throw Error("--shadows: the scene has no volume to build a summed-area table of");
    const auto& m = packed.voxel_to_world[0];
    D3 x = normalized({m[0], m[4], m[8]}), y = normalized({m[1], m[5], m[9]});
    y = normalized({y[0] - dot(x, y) * x[0], y[1] - dot(x, y) * x[1], y[2] - dot(x, y) * x[2]});  // orthogonal even under shear
    double voxel = 0;
    std::vector<D3> corners = occupied_corners(packed, voxel);  // σ is 0 outside them
    return make_sat_frame(corners, voxel, {x, y, cross(x, y)}, max_entries, coarsen);
}

SatFrame make_sat_frame(const std::vector<D3>& corners, double voxel_size, const std::array<D3, 3>& axes, std::size_t max_entries,
                        double coarsen) {
    SatFrame f;
    f.axes = axes;
    f.voxel_size = voxel_size;
    if (corners.empty() || !(f.voxel_size > 0)) throw Error("--shadows lowpass: the scene has no volume to build a summed-area table of");
    D3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const D3& p : corners)
        for (std::size_t a = 0; a < 3; ++a) {
            double c = dot(p, f.axes[a]);
            lo[a] = std::min(lo[a], c), hi[a] = std::max(hi[a], c);
        }
    f.cell_size = f.voxel_size * std::max(coarsen, 1.0);
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

namespace {

// What a light sees of a set of boxes (8 corners each) in spherical coordinates about it (Ament
// §4.2.3): the frame (x towards the boxes' centre), the (φ, θ) rectangle and the radial range, or
// the whole sphere when the light lies inside the boxes' bounds or sees them over more than 80°.
struct SphereSpan {
    D3 x, y, z;
    double phi_lo = 0, phi_hi = 0, theta_lo = 0, theta_hi = 0, r_min = 0, r_max = 0;
    double reach = kPi;  // the largest angle from x to a direction into the boxes (with the margin)
    double r_ref = 0;  // the distance at which an angular cell spans one voxel (k = 1)
    bool whole = false;
};

SphereSpan sphere_span(const std::vector<D3>& corners, const D3& light) {
    D3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const D3& c : corners)
        for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
    D3 centre, outside{0, 0, 0};
    for (std::size_t a = 0; a < 3; ++a) {
        centre[a] = 0.5 * (lo[a] + hi[a]);
        outside[a] = std::max({lo[a] - light[a], light[a] - hi[a], 0.0});
    }
    SphereSpan s;
    s.r_min = std::sqrt(dot(outside, outside));
    for (const D3& c : corners) {
        D3 d = {c[0] - light[0], c[1] - light[1], c[2] - light[2]};
        s.r_max = std::max(s.r_max, std::sqrt(dot(d, d)));
    }
    D3 to_centre = {centre[0] - light[0], centre[1] - light[1], centre[2] - light[2]};
    double centre_distance = std::sqrt(dot(to_centre, to_centre));
    s.x = centre_distance > 1e-9 * s.r_max ? normalized(to_centre) : D3{1, 0, 0};
    s.z = perpendicular(s.x), s.y = cross(s.z, s.x);
    // angles the boxes subtend: points along every box edge (θ's extremes may lie inside an edge)
    s.whole = s.r_min <= 0;
    double phi_lo = INFINITY, phi_hi = -INFINITY, theta_lo = INFINITY, theta_hi = -INFINITY, least_cos = 1;
    for (std::size_t box = 0; !s.whole && box < corners.size(); box += 8)
        for (int c0 = 0; c0 < 8; ++c0)
            for (int axis = 0; axis < 3; ++axis) {
                int c1 = c0 | (1 << axis);
                if (c1 == c0) continue;
                for (int t = 0; t <= 32; ++t) {
                    D3 d;
                    for (std::size_t r = 0; r < 3; ++r)
                        d[r] = corners[box + std::size_t(c0)][r] + (corners[box + std::size_t(c1)][r] - corners[box + std::size_t(c0)][r]) * t / 32.0 - light[r];
                    double len = std::sqrt(dot(d, d)), px = dot(d, s.x) / len;
                    if (px < std::cos(80.0 * kPi / 180.0)) s.whole = true;  // a cone wider than 80°
                    least_cos = std::min(least_cos, px);
                    double phi = std::atan2(dot(d, s.y), dot(d, s.x)), theta = std::acos(std::clamp(dot(d, s.z) / len, -1.0, 1.0));
                    phi_lo = std::min(phi_lo, phi), phi_hi = std::max(phi_hi, phi);
                    theta_lo = std::min(theta_lo, theta), theta_hi = std::max(theta_hi, theta);
                }
            }
    double margin = 0.02 * std::max(phi_hi - phi_lo, theta_hi - theta_lo);
    if (s.whole) s.phi_lo = -kPi, s.phi_hi = kPi, s.theta_lo = 0, s.theta_hi = kPi, s.r_min = 0;
    else s.phi_lo = phi_lo - margin, s.phi_hi = phi_hi + margin, s.theta_lo = std::max(theta_lo - margin, 0.0),
         s.theta_hi = std::min(theta_hi + margin, kPi);
    s.r_ref = s.whole ? 0.5 * s.r_max : centre_distance;
    // the silhouette of a box seen from outside is made of its edges: no direction into it lies
    // farther from x than the farthest edge point, up to the sampling (covered by the margin) and
    // the float cosine (1e-3 rad at least)
    if (!s.whole) s.reach = std::min(std::acos(std::clamp(least_cos, -1.0, 1.0)) + std::max(2 * margin, 1e-3), kPi);
    return s;
}

// Cells along φ, θ, r: k voxels along r and max(k, k_across) at the reference distance across.
std::array<int, 3> sphere_cells(const SphereSpan& s, double voxel, double k, double k_across) {
    double across = voxel * std::max(k, k_across) / s.r_ref;
    return {std::max(1, int(std::ceil((s.phi_hi - s.phi_lo) / across))), std::max(1, int(std::ceil((s.theta_hi - s.theta_lo) / across))),
            std::max(1, int(std::ceil((s.r_max - s.r_min) / (voxel * k))))};
}

std::size_t cells_entries(const std::array<int, 3>& dims) {
    return std::size_t(dims[0] + 1) * std::size_t(dims[1] + 1) * std::size_t(dims[2] + 1);
}

SsatGridGpu sphere_grid(const SphereSpan& s, const std::array<int, 3>& dims, const D3& light, cl_uint volume_mask) {
    SsatGridGpu g{};
    g.axes[0] = f4(s.x), g.axes[1] = f4(s.y), g.axes[2] = f4(s.z);
    g.light = f4(light);
    g.start = f4({s.phi_lo, s.theta_lo, s.r_min});
    g.cell = f4({(s.phi_hi - s.phi_lo) / dims[0], (s.theta_hi - s.theta_lo) / dims[1], (s.r_max - s.r_min) / dims[2]});
    g.dims = {{dims[0], dims[1], dims[2], 1}};
    g.wrap_phi = s.whole ? 1 : 0;
    g.tau_per_unit = 1.f / SOMBRA_SAT_UNITS_PER_TAU;
    g.volume_mask = volume_mask;
    g.cos_reach = s.reach >= kPi ? -1.f : float(std::cos(s.reach)), g.sin_reach = s.reach >= kPi ? 0.f : float(std::sin(s.reach));
    return g;
}

// > 0: the distance between the axis-aligned bounds of two sets of points along the axis where
// they are farthest apart; ≤ 0: the bounds overlap.
double box_gap(const std::vector<D3>& a, const std::vector<D3>& b) {
    double gap = -INFINITY;
    for (std::size_t axis = 0; axis < 3; ++axis) {
        double a_lo = INFINITY, a_hi = -INFINITY, b_lo = INFINITY, b_hi = -INFINITY;
        for (const D3& p : a) a_lo = std::min(a_lo, p[axis]), a_hi = std::max(a_hi, p[axis]);
        for (const D3& p : b) b_lo = std::min(b_lo, p[axis]), b_hi = std::max(b_hi, p[axis]);
        gap = std::max({gap, b_lo - a_hi, a_lo - b_hi});
    }
    return gap;
}

// Groups of volumes whose occupied boxes overlap (merged by their union boxes until no two
// overlap), each with its volumes' corners; volumes without an occupied brick are left out, and
// when no volume has one, one group of all the volumes' whole boxes (a table of zeros).
struct VolumeGroup {
    std::vector<D3> corners;
    cl_uint mask = 0;
};
std::vector<VolumeGroup> volume_groups(const packing::PackedScene& packed, const std::vector<std::vector<D3>>& per_volume) {
    std::vector<VolumeGroup> groups;
    for (std::size_t v = 0; v < per_volume.size(); ++v)
        if (!per_volume[v].empty()) groups.push_back({per_volume[v], cl_uint(1) << v});
    if (groups.empty()) {
        double voxel = 0;
        VolumeGroup all{scene_corners(packed, voxel), 0};
        for (std::size_t v = 0; v < packed.volumes.size(); ++v) all.mask |= cl_uint(1) << v;
        groups.push_back(all);
    }
    for (bool merged = true; merged;) {
        merged = false;
        for (std::size_t a = 0; a < groups.size() && !merged; ++a)
            for (std::size_t b = a + 1; b < groups.size() && !merged; ++b)
                if (box_gap(groups[a].corners, groups[b].corners) <= 0) {
                    groups[a].corners.insert(groups[a].corners.end(), groups[b].corners.begin(), groups[b].corners.end());
                    groups[a].mask |= groups[b].mask;
                    groups.erase(groups.begin() + std::ptrdiff_t(b));
                    merged = true;
                }
    }
    return groups;
}

}  // namespace

std::vector<SatFrame> plan_csat_tables(const packing::PackedScene& packed, const std::array<D3, 3>& axes, std::size_t max_entries,
                                       const std::array<double, 3>& cell_scale) {
    double voxel = 0;
    std::vector<std::vector<D3>> per_volume = occupied_corners_per_volume(packed, voxel);
    if (packed.volumes.empty() || !(voxel > 0)) throw Error("--shadows lowpass: the scene has no volume to build a summed-area table of");
    std::vector<VolumeGroup> groups = volume_groups(packed, per_volume);
    // each group's bounds along the axes, and all groups' (the lattice's frame, as make_sat_frame)
    std::vector<D3> lo(groups.size(), D3{INFINITY, INFINITY, INFINITY}), hi(groups.size(), D3{-INFINITY, -INFINITY, -INFINITY});
    D3 all_lo{INFINITY, INFINITY, INFINITY}, all_hi{-INFINITY, -INFINITY, -INFINITY};
    for (std::size_t g = 0; g < groups.size(); ++g)
        for (const D3& p : groups[g].corners)
            for (std::size_t a = 0; a < 3; ++a) {
                double c = dot(p, axes[a]);
                lo[g][a] = std::min(lo[g][a], c), hi[g][a] = std::max(hi[g][a], c);
                all_lo[a] = std::min(all_lo[a], c), all_hi[a] = std::max(all_hi[a], c);
            }
    // the finest cell (the smallest voxel, 5 % steps coarser) at which the tables hold at most
    // max_entries together and each at most SOMBRA_SAT_MAX_ENTRIES; each table covers its group's
    // cells of one lattice centred on all the groups' bounds (one group: make_sat_frame's frame)
    std::vector<SatFrame> tables;
    for (double h = voxel;; h *= 1.05) {
        tables.clear();
        std::size_t total = 0, largest = 0;
        double start[3];
        int all_dims[3];
        for (std::size_t a = 0; a < 3; ++a) {
            const double cell = h * cell_scale[a];
            all_dims[a] = std::max(1, int(std::ceil((all_hi[a] - all_lo[a]) / cell - 1e-6)));
            start[a] = 0.5 * (all_lo[a] + all_hi[a]) - 0.5 * all_dims[a] * cell;
        }
        for (std::size_t g = 0; g < groups.size(); ++g) {
            SatFrame f;
            f.axes = axes, f.cell_size = h, f.cell_scale = cell_scale, f.voxel_size = voxel, f.volume_mask = groups[g].mask;
            f.origin = {0, 0, 0};
            for (std::size_t a = 0; a < 3; ++a) {
                const double cell = h * cell_scale[a];
                int first = std::clamp(int(std::floor((lo[g][a] - start[a]) / cell + 1e-6)), 0, all_dims[a] - 1);
                int last = std::clamp(int(std::ceil((hi[g][a] - start[a]) / cell - 1e-6)), first + 1, all_dims[a]);
                f.dims[a] = last - first;
                for (std::size_t r = 0; r < 3; ++r) f.origin[r] += (start[a] + first * cell) * axes[a][r];
            }
            total += f.entries(), largest = std::max(largest, f.entries());
            tables.push_back(f);
        }
        if (total <= max_entries && largest <= SOMBRA_SAT_MAX_ENTRIES) break;
    }
    return tables;
}

std::vector<SsatGridGpu> plan_ssat_tables(const packing::PackedScene& packed, const D3& light, std::size_t max_entries,
                                          double coarsen_across) {
    double voxel = 0;
    std::vector<std::vector<D3>> per_volume = occupied_corners_per_volume(packed, voxel);
    if (packed.volumes.empty() || !(voxel > 0)) throw Error("--shadows lowpass: the scene has no volume to build a summed-area table of");
    std::vector<VolumeGroup> groups = volume_groups(packed, per_volume);
    // one cell size factor k for every table of the light: the smallest (in 5 % steps) at which
    // they hold at most max_entries together and each at most SOMBRA_SAT_MAX_ENTRIES
    std::vector<SphereSpan> spans;
    std::vector<double> k_across;  // per table: coarsen_across voxels at its farthest radius
    for (const VolumeGroup& g : groups) {
        spans.push_back(sphere_span(g.corners, light));
        k_across.push_back(coarsen_across * spans.back().r_ref / spans.back().r_max);
    }
    double k = 1;
    for (;; k *= 1.05) {
        std::size_t total = 0, largest = 0;
        for (std::size_t i = 0; i < spans.size(); ++i) {
            std::size_t e = cells_entries(sphere_cells(spans[i], voxel, k, k_across[i]));
            total += e, largest = std::max(largest, e);
        }
        if (total <= max_entries && largest <= SOMBRA_SAT_MAX_ENTRIES) break;
    }
    std::vector<SsatGridGpu> tables;
    for (std::size_t i = 0; i < groups.size(); ++i)
        tables.push_back(sphere_grid(spans[i], sphere_cells(spans[i], voxel, k, k_across[i]), light, groups[i].mask));
    return tables;
}

namespace {

// Prefix sums along grid axes 0 and 1 of one table (axis 2 was summed by its resample kernel).
double scan_table(host::Runtime& runtime, cl::Kernel& scan, const cl::Buffer& data, std::size_t offset, cl_int4 n) {
    double ms = 0;
    cl::Event event;
    for (cl_uint axis = 0; axis < 2; ++axis) {
        host::KernelArgs{scan}("sat", data)("data_offset", cl_uint(offset))("n", n)("axis", axis).done();
        std::size_t other = std::size_t(axis == 0 ? n.s[1] : n.s[0]);
        runtime.queue().enqueueNDRangeKernel(scan, cl::NullRange, cl::NDRange(other, std::size_t(n.s[2])), cl::NullRange,
                                             nullptr, &event);
        event.wait();
        ms += host::Runtime::event_ms(event);
    }
    return ms;
}

// The arguments every resample kernel starts with.
void bind_volumes(host::KernelArgs& args, const packing::PackedScene& packed, const packing::DeviceScene& device_scene,
                  const cl::Buffer& data) {
    if (device_scene.uses_images) args("volume_data", device_scene.voxel_image);
    else args("volume_data", device_scene.voxel_buffer);
    args("tf_tables", device_scene.tf_tables)("volumes", device_scene.volumes)("volume_count", cl_uint(packed.volumes.size()));
    args("occupancy", device_scene.occupancy)("sat", data);
}

// One light's view of CSAT frame f stored at `offset`, the light along grid axis `axis`.
SatGridGpu sat_grid(const SatFrame& f, std::size_t offset, int axis, bool positive) {
    SatGridGpu g{};
    for (std::size_t a = 0; a < 3; ++a) {
        D3 row = {f.axes[a][0] / f.cell(a), f.axes[a][1] / f.cell(a), f.axes[a][2] / f.cell(a)};
        g.to_grid[a] = f4(row, -dot(row, f.origin));
    }
    g.dims = {{f.dims[0], f.dims[1], f.dims[2], 1}};
    g.light_axis = cl_uint(axis);
    g.light_positive = positive ? 1 : 0;
    g.tau_per_unit = 1.f / SOMBRA_SAT_UNITS_PER_TAU;
    g.cell_size = float(f.cell(std::size_t(axis == 0 ? 1 : 0)));  // across the light (the filter's patch)
    g.filter_cells = 1;
    g.data_offset = cl_uint(offset);
    return g;
}

// Bit-exact text of a value (the table keys compare inputs exactly).
template <typename T>
std::string bits(const T& value) {
    static_assert(std::is_trivially_copyable<T>::value, "bits: plain data only");
    const auto* bytes = reinterpret_cast<const unsigned char*>(&value);
    static const char* hex = "0123456789abcdef";
    std::string s;
    for (std::size_t i = 0; i < sizeof(T); ++i) s += hex[bytes[i] >> 4], s += hex[bytes[i] & 15];
    return s;
}

// The SSATs, in the grid array's order (every light's first, in light order, then the rest): table
// frames.size() + i is sat.spheres[sphere_lights[i]].
std::vector<std::size_t> sphere_lights(const DeviceSat& sat) {
    std::vector<std::size_t> lights;
    for (std::size_t l = 0; l < sat.spheres.size(); ++l)
        if (sat.spheres[l].dims.s[3] != 0) lights.push_back(l);
    return lights;
}

// Places `sat`'s tables one after the other into a fresh buffer and builds them all.
void build_all(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
               const packing::DeviceScene& device_scene, DeviceSat& sat) {
    std::size_t total = 0;
    for (std::size_t t = 0; t < sat_table_count(sat); ++t) {
        place_sat_table(sat, t, total);
        total += sat_table_entries(sat, t);
    }
    if (total > 0xffffffffull) throw Error("--shadows lowpass: summed-area tables exceed 2^32 entries");
    sat.bytes = total * sizeof(cl_ulong);
    sat.data = host::make_buffer(runtime, CL_MEM_READ_WRITE, std::max<std::size_t>(sat.bytes, 8), nullptr, "summed-area tables");
    host::ProgressStage stage(runtime.progress(), "summed-area tables", double(sat_table_count(sat)));
    for (std::size_t t = 0; t < sat_table_count(sat); ++t) build_sat_table(runtime, scene, packed, device_scene, sat, t);
}

}  // namespace

cl_uint sat_frame_light_axes(const DeviceSat& sat, std::size_t frame) {
    cl_uint axes = 0;
    for (std::size_t g = 0; g < sat.grids.size() && g < sat.grid_frame.size(); ++g)
        if (sat.grid_frame[g] == int(frame)) axes |= 1u << sat.grids[g].light_axis;
    return axes;
}

std::vector<std::size_t> light_sat_tables(const DeviceSat& sat, std::size_t light) {
    std::vector<std::size_t> tables;
    if (light < sat.light_frame.size() && sat.light_frame[light] >= 0) {
        for (int t = sat.light_frame[light]; t >= 0; t = sat.frames[std::size_t(t)].next) tables.push_back(std::size_t(t));
        return tables;
    }
    std::vector<std::size_t> order = sphere_lights(sat);
    if (light >= sat.spheres.size() || sat.spheres[light].dims.s[3] == 0) return tables;
    for (std::size_t s = light;; s = sat.spheres[s].next) {
        tables.push_back(sat.frames.size() + std::size_t(std::find(order.begin(), order.end(), s) - order.begin()));
        if (sat.spheres[s].next == 0) break;
    }
    return tables;
}

std::size_t sat_table_count(const DeviceSat& sat) { return sat.frames.size() + sphere_lights(sat).size(); }

std::size_t sat_table_entries(const DeviceSat& sat, std::size_t table) {
    if (table < sat.frames.size()) return sat.frames[table].entries();
    return ssat_entries(sat.spheres[sphere_lights(sat).at(table - sat.frames.size())]);
}

std::array<int, 3> sat_table_cells(const DeviceSat& sat, std::size_t table) {
    if (table < sat.frames.size()) return sat.frames[table].dims;
    const SsatGridGpu& g = sat.spheres[sphere_lights(sat).at(table - sat.frames.size())];
    return {g.dims.s[0], g.dims.s[1], g.dims.s[2]};
}

std::array<double, 3> sat_table_cell_voxels(const DeviceSat& sat, std::size_t table) {
    if (table < sat.frames.size()) {
        const SatFrame& f = sat.frames[table];
        return {f.cell(0) / sat.voxel_size, f.cell(1) / sat.voxel_size, f.cell(2) / sat.voxel_size};
    }
    const SsatGridGpu& g = sat.spheres[sphere_lights(sat).at(table - sat.frames.size())];
    const double r_far = double(g.start.s[2]) + double(g.dims.s[2]) * double(g.cell.s[2]);
    return {double(g.cell.s[0]) * r_far / sat.voxel_size, double(g.cell.s[1]) * r_far / sat.voxel_size, double(g.cell.s[2]) / sat.voxel_size};
}

cl_uint sat_table_volumes(const DeviceSat& sat, std::size_t table, std::size_t volume_count) {
    if (table >= sat.frames.size()) return sat.spheres[sphere_lights(sat).at(table - sat.frames.size())].volume_mask;
    return sat.frames[table].volume_mask & (volume_count >= 32 ? ~cl_uint(0) : (cl_uint(1) << volume_count) - 1);
}

std::size_t sat_table_offset(const DeviceSat& sat, std::size_t table) {
    if (table < sat.frames.size()) return sat.offsets[table];
    return sat.spheres[sphere_lights(sat).at(table - sat.frames.size())].data_offset;
}

void place_sat_table(DeviceSat& sat, std::size_t table, std::size_t offset) {
    if (offset + sat_table_entries(sat, table) > 0xffffffffull)
        throw Error("--shadows lowpass: summed-area tables exceed 2^32 entries");
    if (table >= sat.frames.size()) {
        sat.spheres[sphere_lights(sat).at(table - sat.frames.size())].data_offset = cl_uint(offset);
        return;
    }
    sat.offsets[table] = offset;
    for (std::size_t g = 0; g < sat.grids.size(); ++g)
        if (sat.grid_frame[g] == int(table)) sat.grids[g].data_offset = cl_uint(offset);
}

std::string sat_table_geometry_key(const DeviceSat& sat, std::size_t table) {
    if (table >= sat.frames.size()) {
        SsatGridGpu g = sat.spheres[sphere_lights(sat).at(table - sat.frames.size())];
        g.data_offset = 0, g.half_width = 0, g.next = 0;  // where it is stored, the filter, the chain: not its cells
        return "SSAT " + bits(g);
    }
    const SatFrame& f = sat.frames[table];
    return "CSAT " + bits(f.axes) + ' ' + bits(f.origin) + ' ' + bits(f.dims) + ' ' + bits(f.cell_size) + ' ' + bits(f.cell_scale) + ' ' + bits(f.volume_mask) + " axes " +
           std::to_string(sat_frame_light_axes(sat, table));
}

// The zero borders S(0, ·, ·), S(·, 0, ·), S(·, ·, 0) of a table of n cells: the resamples write
// every other entry, so only these ((n+1)² per face, not the whole table) are cleared, in one launch.
double clear_table_borders(host::Runtime& runtime, cl::Program& program, const cl::Buffer& data, std::size_t offset, cl_int4 n) {
    cl::Kernel clear(program, "sat_clear_borders");
    host::KernelArgs{clear}("sat", data)("data_offset", cl_uint(offset))("n", n).done();
    // faces (y, z), (x, z), (x, y): the first index spans x or y, the second y or z
    const std::size_t a = std::size_t(std::max(n.s[0], n.s[1])) + 1, b = std::size_t(std::max(n.s[1], n.s[2])) + 1;
    cl::Event event;
    runtime.queue().enqueueNDRangeKernel(clear, cl::NullRange, cl::NDRange(a, b, 3), cl::NullRange, nullptr, &event);
    event.wait();
    return host::Runtime::event_ms(event);
}

namespace {
double total_ms(const DeviceSat& sat) {
    double ms = 0;
    for (const auto& stage : sat.stage_ms) ms += stage.second;
    return ms;
}
void build_one_table(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                     const packing::DeviceScene& device_scene, DeviceSat& sat, std::size_t table);
}  // namespace

void build_sat_table(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                     const packing::DeviceScene& device_scene, DeviceSat& sat, std::size_t table) {
    const double before = total_ms(sat);
    build_one_table(runtime, scene, packed, device_scene, sat, table);
    sat.table_build_ms.resize(sat_table_count(sat), 0.0);
    sat.table_build_ms[table] = total_ms(sat) - before;
}

namespace {
void build_one_table(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                     const packing::DeviceScene& device_scene, DeviceSat& sat, std::size_t table) {
    std::size_t offset = sat_table_offset(sat, table);
    // the resamples march packets of neighbouring columns, as DSM generation does its texels (a
    // table does not depend on the width: it is not in the tables' keys)
    const int lanes = host::generation_lanes(runtime, sat.lanes);
    auto defines = volume_pass_defines(scene, device_scene.uses_images, false);
    defines.push_back("SOMBRA_LANES=" + std::to_string(lanes));
    cl::Program& program = runtime.program("sat_build.cl", defines);
    cl::Kernel scan(program, "sat_scan");
    if (table < sat.frames.size()) {  // Ament Alg. 1: recomputeCSAT
        cl::Kernel resample(program, "sat_resample");
        const SatFrame& f = sat.frames[table];
        cl_int4 n = {{f.dims[0], f.dims[1], f.dims[2], 1}};
        sat.stage_ms["sat_clear"] += clear_table_borders(runtime, program, sat.data, offset, n);
        host::KernelArgs args(resample);
        bind_volumes(args, packed, device_scene, sat.data);
        args("data_offset", cl_uint(offset))("n", n)("origin", f4(f.origin));
        const char* cell_names[3] = {"cell_u", "cell_v", "cell_w"};
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const D3& r = f.axes[axis];
            args(cell_names[axis], f4({r[0] * f.cell(axis), r[1] * f.cell(axis), r[2] * f.cell(axis)}));
        }
        args("cell_length", float(f.cell_size))("light_axes", sat_frame_light_axes(sat, table))("volume_mask", f.volume_mask).done();
        sat.stage_ms["sat_resample"] += host::run_packets(runtime, resample, f.dims[0], f.dims[1], lanes);
        sat.stage_ms["sat_scan"] += scan_table(runtime, scan, sat.data, offset, n);
        return;
    }
    // Ament Alg. 1: recomputeSSAT, one per point light
    cl::Kernel resample_sphere(program, "ssat_resample");
    const SsatGridGpu& sphere = sat.spheres[sphere_lights(sat).at(table - sat.frames.size())];
    sat.stage_ms["sat_clear"] += clear_table_borders(runtime, program, sat.data, offset, sphere.dims);
    cl::Buffer grid = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(SsatGridGpu), &sphere, "SSAT grid");
    host::KernelArgs args(resample_sphere);
    bind_volumes(args, packed, device_scene, sat.data);
    args("grid", grid).done();
    sat.stage_ms["ssat_resample"] += host::run_packets(runtime, resample_sphere, sphere.dims.s[0], sphere.dims.s[1], lanes);
    sat.stage_ms["sat_scan"] += scan_table(runtime, scan, sat.data, offset, sphere.dims);
}
}  // namespace

// The cell scale of a CSAT frame with `axes`: coarsen_across across the light when the scene's
// directional lights all shine along one of its axes, else 1 (a light along another axis would
// filter across that one).
static std::array<double, 3> csat_cell_scale(const packing::PackedScene& packed, const std::array<D3, 3>& axes, double coarsen_across) {
    int lit = -1;
    SatFrame frame;
    frame.axes = axes;
    for (const LightGpu& light : packed.lights) {
        if (light.type != SOMBRA_LIGHT_DIRECTIONAL) continue;
        bool positive = true;
        int axis = shared_axis(frame, {-light.direction.s[0], -light.direction.s[1], -light.direction.s[2]}, positive);
        if (axis < 0) continue;
        if (lit >= 0 && axis != lit) return {1, 1, 1};
        lit = axis;
    }
    std::array<double, 3> scale{1, 1, 1};
    for (int a = 0; a < 3; ++a)
        if (lit >= 0 && a != lit) scale[std::size_t(a)] = std::max(coarsen_across, 1.0);
    return scale;
}

DeviceSat plan_light_sats(const packing::PackedScene& packed, std::size_t max_entries, double coarsen_across) {
    DeviceSat sat;
    scene_corners(packed, sat.voxel_size);
    std::vector<std::vector<SatGridGpu>> extra_grids(packed.lights.size());     // per light: its CSATs after the first
    std::vector<std::vector<int>> extra_frames(packed.lights.size());          // … and their tables
    std::vector<std::vector<SsatGridGpu>> extra_spheres(packed.lights.size());  // per light: its SSATs after the first
    std::vector<int> first_tables;  // the first table of each lattice (a set of tables, one per group of volumes)
    for (std::size_t l = 0; l < packed.lights.size(); ++l) {
        const LightGpu& light = packed.lights[l];
        SatGridGpu g{};
        SsatGridGpu sphere{};
        int frame = -1;
        if (light.type == SOMBRA_LIGHT_DIRECTIONAL) {
            D3 towards = {-light.direction.s[0], -light.direction.s[1], -light.direction.s[2]};
            bool positive = true;
            int axis = -1;
            for (std::size_t i = 0; i < first_tables.size() && axis < 0; ++i)
                if ((axis = shared_axis(sat.frames[std::size_t(first_tables[i])], towards, positive)) >= 0) frame = first_tables[i];
            if (axis < 0) {  // new tables, founded by this light
                const std::array<D3, 3> axes = shared_csat_axes(towards);
                std::vector<SatFrame> tables = plan_csat_tables(packed, axes, max_entries, csat_cell_scale(packed, axes, coarsen_across));
                frame = int(sat.frames.size());
                first_tables.push_back(frame);
                for (std::size_t i = 0; i < tables.size(); ++i) {
                    tables[i].next = i + 1 < tables.size() ? frame + int(i) + 1 : -1;
                    sat.frames.push_back(tables[i]);
                    sat.offsets.push_back(0);
                }
                axis = shared_axis(sat.frames[std::size_t(frame)], towards, positive);
            }
            g = sat_grid(sat.frames[std::size_t(frame)], 0, axis, positive);
            for (int t = sat.frames[std::size_t(frame)].next; t >= 0; t = sat.frames[std::size_t(t)].next) {
                extra_grids[l].push_back(sat_grid(sat.frames[std::size_t(t)], 0, axis, positive));
                extra_frames[l].push_back(t);
            }
        } else {
            extra_spheres[l] = plan_ssat_tables(packed, {light.position.s[0], light.position.s[1], light.position.s[2]}, max_entries, coarsen_across);
            sphere = extra_spheres[l].front();
            extra_spheres[l].erase(extra_spheres[l].begin());
        }
        sat.grids.push_back(g);
        sat.grid_frame.push_back(frame);
        sat.spheres.push_back(sphere);
        sat.light_frame.push_back(frame);
    }
    // each light's further tables after every light's first, chained from it
    for (std::size_t l = 0; l < packed.lights.size(); ++l) {
        cl_uint* link = &sat.grids[l].next;
        for (std::size_t i = 0; i < extra_grids[l].size(); ++i) {
            *link = cl_uint(sat.grids.size());
            sat.grids.push_back(extra_grids[l][i]);
            sat.grid_frame.push_back(extra_frames[l][i]);
            link = &sat.grids.back().next;
        }
        link = &sat.spheres[l].next;
        for (const SsatGridGpu& g : extra_spheres[l]) {
            *link = cl_uint(sat.spheres.size());
            sat.spheres.push_back(g);
            link = &sat.spheres.back().next;
        }
    }
    return sat;
}

DeviceSat plan_volume_sat(const packing::PackedScene& packed, std::size_t max_entries, double coarsen) {
    DeviceSat sat;
    scene_corners(packed, sat.voxel_size);
    sat.frames.push_back(make_volume_sat_frame(packed, max_entries, coarsen));
    sat.offsets.push_back(0);
    sat.grids.assign(std::max<std::size_t>(packed.lights.size(), 1), sat_grid(sat.frames[0], 0, 2, true));
    sat.grid_frame.assign(sat.grids.size(), 0);
    sat.spheres.assign(sat.grids.size(), SsatGridGpu{});
    sat.light_frame.assign(sat.grids.size(), 0);
    return sat;
}

DeviceSat build_light_sats(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                           const packing::DeviceScene& device_scene, std::size_t max_entries, int lanes, double coarsen_across) {
    DeviceSat sat = plan_light_sats(packed, max_entries, coarsen_across);
    sat.lanes = lanes;
    build_all(runtime, scene, packed, device_scene, sat);
    return sat;
}

DeviceSat build_volume_sat(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                           const packing::DeviceScene& device_scene, std::size_t max_entries, int lanes) {
    DeviceSat sat = plan_volume_sat(packed, max_entries);
    sat.lanes = lanes;
    build_all(runtime, scene, packed, device_scene, sat);
    return sat;
}

SatGridBuffers upload_sat_grids(host::Runtime& runtime, const DeviceSat& sat, float filter_voxels, float cone_deg) {
    std::vector<SatGridGpu> grids = sat.grids;
    std::vector<SsatGridGpu> spheres = sat.spheres;
    double width = std::max(double(filter_voxels), 1.0) * sat.voxel_size;  // at least one voxel
    for (SatGridGpu& g : grids)
        if (g.dims.s[3] != 0) {
            g.filter_cells = cl_uint(std::clamp(std::round(width / g.cell_size), 1.0, 4096.0));
            g.cone_tan = float(std::tan(double(cone_deg) * kPi / 180.0));
        }
    for (SsatGridGpu& g : spheres) g.half_width = float(0.5 * width);  // Ament Eq. 16: U = V = W/2
    return {host::make_buffer(runtime, CL_MEM_READ_ONLY, grids.size() * sizeof(SatGridGpu), grids.data(), "SAT grids"),
            host::make_buffer(runtime, CL_MEM_READ_ONLY, spheres.size() * sizeof(SsatGridGpu), spheres.data(), "SSAT grids")};
}

std::vector<std::uint64_t> read_sat(host::Runtime& runtime, const DeviceSat& sat, std::size_t offset, std::size_t entries) {
    std::vector<std::uint64_t> out(entries);
    runtime.queue().enqueueReadBuffer(sat.data, CL_TRUE, offset * sizeof(cl_ulong), entries * sizeof(cl_ulong), out.data());
    return out;
}

}  // namespace sombra::shadows
