#include "reference/sat_ref.h"

#include <algorithm>
#include <cmath>

#include "reference/raycaster_ref.h"

namespace sombra::reference {

CellGrid sat_cells(const Scene& whole_scene, const shadows::SatFrame& frame, unsigned light_axes) {
    Scene scene = whole_scene;  // the volumes of the table's group only
    scene.volumes.clear();
    for (std::size_t v = 0; v < whole_scene.volumes.size(); ++v)
        if (frame.volume_mask & (1u << v)) scene.volumes.push_back(whole_scene.volumes[v]);
    unsigned axes = light_axes & 7u ? light_axes & 7u : 7u;
    CellGrid g;
    g.dims = frame.dims;
    g.cells.reserve(std::size_t(g.dims[0]) * g.dims[1] * g.dims[2]);
    for (int k = 0; k < g.dims[2]; ++k)
        for (int j = 0; j < g.dims[1]; ++j)
            for (int i = 0; i < g.dims[0]; ++i) {
                shadows::D3 p = frame.cell_centre(i, j, k);
                double tau = 0;
                int count = 0;
                for (int a = 0; a < 3; ++a) {
                    if (!(axes & (1u << a))) continue;
                    Vec3 lo, hi;
                    for (int c = 0; c < 3; ++c) {
                        double half = 0.5 * frame.cell(std::size_t(a)) * frame.axes[std::size_t(a)][std::size_t(c)];
                        lo[std::size_t(c)] = float(p[std::size_t(c)] - half), hi[std::size_t(c)] = float(p[std::size_t(c)] + half);
                    }
                    tau += segment_optical_depth(scene, lo, hi), ++count;
                }
                g.cells.push_back(tau / count);
            }
    return g;
}

CellGrid ssat_cells(const Scene& whole_scene, const SsatGridGpu& grid) {
    Scene scene = whole_scene;  // the volumes of the table's group only
    scene.volumes.clear();
    for (std::size_t v = 0; v < whole_scene.volumes.size(); ++v)
        if (grid.volume_mask & (1u << v)) scene.volumes.push_back(whole_scene.volumes[v]);
    CellGrid g;
    g.dims = {grid.dims.s[0], grid.dims.s[1], grid.dims.s[2]};
    auto v = [](const cl_float4& f, int i) { return double(f.s[i]); };
    for (int k = 0; k < g.dims[2]; ++k)
        for (int j = 0; j < g.dims[1]; ++j)
            for (int i = 0; i < g.dims[0]; ++i) {
                double phi = v(grid.start, 0) + (i + 0.5) * v(grid.cell, 0);
                double theta0 = v(grid.start, 1) + j * v(grid.cell, 1), theta = theta0 + 0.5 * v(grid.cell, 1);
                double r0 = v(grid.start, 2) + k * v(grid.cell, 2), r1 = r0 + v(grid.cell, 2);
                double w = (std::cos(theta0) - std::cos(theta0 + v(grid.cell, 1))) / v(grid.cell, 1);
                double d[3] = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
                Vec3 a, b;  // the cell's radial segment
                for (int c = 0; c < 3; ++c) {
                    double along = d[0] * v(grid.axes[0], c) + d[1] * v(grid.axes[1], c) + d[2] * v(grid.axes[2], c);
                    a[std::size_t(c)] = float(v(grid.light, c) + r0 * along), b[std::size_t(c)] = float(v(grid.light, c) + r1 * along);
                }
                g.cells.push_back(segment_optical_depth(scene, a, b) * w);
            }
    return g;
}

CellGrid cells_of_table(const std::vector<std::uint64_t>& table, const std::array<int, 3>& dims) {
    CellGrid g;
    g.dims = dims;
    auto s = [&](int i, int j, int k) {
        return table[std::size_t(i) + std::size_t(dims[0] + 1) * (std::size_t(j) + std::size_t(dims[1] + 1) * std::size_t(k))];
    };
    for (int k = 1; k <= dims[2]; ++k)
        for (int j = 1; j <= dims[1]; ++j)
            for (int i = 1; i <= dims[0]; ++i) {
                std::uint64_t q = s(i, j, k) - s(i - 1, j, k) - s(i, j - 1, k) - s(i, j, k - 1) + s(i - 1, j - 1, k) +
                                  s(i - 1, j, k - 1) + s(i, j - 1, k - 1) - s(i - 1, j - 1, k - 1);
                g.cells.push_back(double(std::int64_t(q)) / SOMBRA_SAT_UNITS_PER_TAU);
            }
    return g;
}

double box_sum(const CellGrid& grid, const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
        first[a] = std::max(0, int(std::floor(std::max(lo[a], -1.0))));
        last[a] = std::min(grid.dims[a] - 1, int(std::ceil(std::min(hi[a], double(grid.dims[a]) + 1))) - 1);
    }
    auto overlap = [&](int a, int c) { return std::max(0.0, std::min(hi[a], c + 1.0) - std::max(lo[a], double(c))); };
    double sum = 0;
    for (int k = first[2]; k <= last[2]; ++k)
        for (int j = first[1]; j <= last[1]; ++j)
            for (int i = first[0]; i <= last[0]; ++i) sum += overlap(0, i) * overlap(1, j) * overlap(2, k) * grid.at(i, j, k);
    return sum;
}

template <typename T>
std::vector<T> build_sat(const CellGrid& grid, T (*convert)(double)) {
    const auto& n = grid.dims;
    std::size_t sx = 1, sy = std::size_t(n[0] + 1), sz = sy * std::size_t(n[1] + 1);
    std::vector<T> s(sz * std::size_t(n[2] + 1), T(0));
    for (int k = 1; k <= n[2]; ++k)
        for (int j = 1; j <= n[1]; ++j)
            for (int i = 1; i <= n[0]; ++i) {
                std::size_t e = i * sx + j * sy + k * sz;
                s[e] = convert(grid.at(i - 1, j - 1, k - 1)) + s[e - sx] + s[e - sy] + s[e - sz] - s[e - sx - sy] -
                       s[e - sx - sz] - s[e - sy - sz] + s[e - sx - sy - sz];
            }
    return s;
}

template <typename T>
T sat_box(const std::vector<T>& sat, const std::array<int, 3>& dims, const std::array<int, 3>& lo, const std::array<int, 3>& hi) {
    auto s = [&](int i, int j, int k) {
        return sat[std::size_t(i) + std::size_t(dims[0] + 1) * (std::size_t(j) + std::size_t(dims[1] + 1) * std::size_t(k))];
    };
    return s(hi[0], hi[1], hi[2]) - s(lo[0], hi[1], hi[2]) - s(hi[0], lo[1], hi[2]) - s(hi[0], hi[1], lo[2]) +
           s(lo[0], lo[1], hi[2]) + s(lo[0], hi[1], lo[2]) + s(hi[0], lo[1], lo[2]) - s(lo[0], lo[1], lo[2]);
}

template std::vector<double> build_sat(const CellGrid&, double (*)(double));
template std::vector<float> build_sat(const CellGrid&, float (*)(double));
template std::vector<std::uint64_t> build_sat(const CellGrid&, std::uint64_t (*)(double));
template double sat_box(const std::vector<double>&, const std::array<int, 3>&, const std::array<int, 3>&, const std::array<int, 3>&);
template float sat_box(const std::vector<float>&, const std::array<int, 3>&, const std::array<int, 3>&, const std::array<int, 3>&);
template std::uint64_t sat_box(const std::vector<std::uint64_t>&, const std::array<int, 3>&, const std::array<int, 3>&,
                               const std::array<int, 3>&);

namespace {

// The box of Ament Eq. 10 in cell units: W × W across `axis` centred on p, along it to the face
// towards the light.
void patch_box(const CellGrid& grid, const shadows::SatFrame& frame, int axis, bool positive, int width,
               const std::array<double, 3>& p, std::array<double, 3>& lo, std::array<double, 3>& hi) {
    for (std::size_t a = 0; a < 3; ++a) {
        double c = 0;
        for (std::size_t r = 0; r < 3; ++r) c += (p[r] - frame.origin[r]) * frame.axes[a][r];
        c /= frame.cell(a);
        if (int(a) != axis) lo[a] = c - 0.5 * width, hi[a] = c + 0.5 * width;
        else if (positive) lo[a] = c, hi[a] = grid.dims[a];
        else lo[a] = 0, hi[a] = c;
    }
}

double normal_mass(double a, double b) { return 0.5 * (std::erf(b / std::sqrt(2.0)) - std::erf(a / std::sqrt(2.0))); }

}  // namespace

double filtered_depth(const CellGrid& grid, const shadows::SatFrame& frame, int axis, bool positive, int width,
                      const std::array<double, 3>& p) {
    std::array<double, 3> lo, hi;
    patch_box(grid, frame, axis, positive, width, p, lo, hi);
    return box_sum(grid, lo, hi) / double(width * width);
}

double gauss_filtered_depth(const CellGrid& grid, const shadows::SatFrame& frame, int axis, bool positive, int width,
                            const std::array<double, 3>& p, int k) {
    std::array<double, 3> lo, hi;
    patch_box(grid, frame, axis, positive, width, p, lo, hi);
    std::size_t a0 = axis == 0 ? 1 : 0, a1 = axis == 2 ? 1 : 2;
    double step = double(width) / k, sum = 0, weights = 0;
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            std::array<double, 3> sub_lo = lo, sub_hi = hi;
            sub_lo[a0] = lo[a0] + i * step, sub_hi[a0] = sub_lo[a0] + step;
            sub_lo[a1] = lo[a1] + j * step, sub_hi[a1] = sub_lo[a1] + step;
            double w = normal_mass(-2.0 + 4.0 * i / k, -2.0 + 4.0 * (i + 1) / k) * normal_mass(-2.0 + 4.0 * j / k, -2.0 + 4.0 * (j + 1) / k);
            sum += w * box_sum(grid, sub_lo, sub_hi) / (step * step), weights += w;
        }
    return sum / weights;
}

namespace {
std::array<double, 3> grid_coordinates(const shadows::SatFrame& frame, const std::array<double, 3>& p) {
    std::array<double, 3> c{};
    for (std::size_t a = 0; a < 3; ++a) {
        for (std::size_t r = 0; r < 3; ++r) c[a] += (p[r] - frame.origin[r]) * frame.axes[a][r];
        c[a] /= frame.cell(a);
    }
    return c;
}
}  // namespace

double ambient_depth(const CellGrid& grid, const shadows::SatFrame& frame, int width, const std::array<double, 3>& p) {
    std::array<double, 3> c = grid_coordinates(frame, p), lo, hi;
    double radius = 0.5 * width;
    for (std::size_t a = 0; a < 3; ++a) lo[a] = c[a] - radius, hi[a] = c[a] + radius;
    return box_sum(grid, lo, hi) / (8.0 * radius * radius);
}

double cone_depth(const CellGrid& grid, const shadows::SatFrame& frame, double cone_tan, const std::array<double, 3>& p,
                  const std::array<double, 3>& towards, double reach, double snap_radius) {
    std::array<double, 3> c = grid_coordinates(frame, p), d{};
    for (std::size_t a = 0; a < 3; ++a)
        for (std::size_t r = 0; r < 3; ++r) d[a] += towards[r] * frame.axes[a][r];
    double outside_sq = 0;  // a point outside the grid: its squared distance to the grid box
    for (std::size_t a = 0; a < 3; ++a) {
        double gap = std::max({-c[a], c[a] - grid.dims[a], 0.0});
        outside_sq += gap * gap;
    }
    double t_max = std::min(reach / frame.cell_size, 4.0 * (grid.dims[0] + grid.dims[1] + grid.dims[2]) + std::sqrt(outside_sq));
    double tau = 0, t = 0.5;
    if (outside_sq > 0)  // skip the cubes that miss the grid
        for (int i = 0; i < 256 && t < t_max; ++i) {  // the cubes before the grid
            double radius = std::max(0.5, t * cone_tan), span = std::min(2 * radius, t_max - t);
            bool meets = true;
            for (std::size_t a = 0; a < 3; ++a) {
                double centre = c[a] + (t + 0.5 * span) * d[a];
                meets = meets && centre + radius >= 0 && centre - radius <= grid.dims[a];
            }
            if (meets) break;
            t += span;
        }
    for (int i = 0; i < 256 && t < t_max && tau <= double(SOMBRA_OPAQUE_DEPTH); ++i) {
        double radius = std::max(0.5, t * cone_tan), span = std::min(2 * radius, t_max - t);
        std::array<double, 3> lo, hi;
        bool outside = false;
        for (std::size_t a = 0; a < 3; ++a) {
            double centre = c[a] + (t + 0.5 * span) * d[a];
            lo[a] = centre - radius, hi[a] = centre + radius;
            outside = outside || hi[a] < 0 || lo[a] > grid.dims[a];
        }
        if (outside) break;  // left the grid
        if (radius >= snap_radius) {  // faces on the nearest cell faces
            double volume = 1;
            for (std::size_t a = 0; a < 3; ++a) lo[a] = std::round(lo[a]), hi[a] = std::round(hi[a]), volume *= hi[a] - lo[a];
            tau += box_sum(grid, lo, hi) / volume * span;
        } else
            tau += box_sum(grid, lo, hi) / (8 * radius * radius * radius) * span;
        t += span;
    }
    return tau;
}

}  // namespace sombra::reference
