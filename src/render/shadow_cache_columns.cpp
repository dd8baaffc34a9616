// sombra — the shadow cache's light lattices (ShadowCacheGpu.column_axes, cl/shared/types.h): for a
// technique whose shadow term multiplies along a light's ray (shadow rays: T(p) = T(p → q) · T(q)
// for q between p and the light), a lattice whose columns run along the light's rays, so that the
// fill marches each column once (cl/render.cl shadow_cache_fill_columns) instead of one ray from
// every point. Built in the volume's voxel space on the axis c the light's rays cross most
// steeply: the lattice's planes are the volume lattice's planes along c, point z = 0 nearest the
// light; within a plane the columns are spaced as the volume lattice's points are (a point light:
// at the plane farthest from it, finer nearer).
#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "render/preparation.h"

namespace sombra::pipeline {

namespace {

// A light's lattice holds at most kMaxLatticeGrowth times the volume lattice's points (a steep
// shear or a point light near the volume fans the columns out past the box), and at most
// kMaxLightLatticePoints (64 MiB): at 2× and 2²³ the MRI's columns were 1.46× the voxel apart and
// its image error 45 % over the volume lattice's, at 4× and 2²⁴ 6 % (docs/shadows.md). Beyond, its
// columns are spaced wider, by at most kMaxCoarsening at the plane farthest from the light (a
// point light next to the volume: the head in fog's, 2.5–2.9×, at the image error of its volume
// lattices within 2 %; finer nearer the light), else the volume lattice.
constexpr double kMaxLatticeGrowth = 4.0, kMaxCoarsening = 3.0;
constexpr std::size_t kMaxLightLatticePoints = std::size_t(1) << 24;

std::array<double, 3> apply_linear(const cl_float4 rows[3], const std::array<double, 3>& v, double w) {
    std::array<double, 3> r{};
    for (int k = 0; k < 3; ++k) r[std::size_t(k)] = rows[k].s[0] * v[0] + rows[k].s[1] * v[1] + rows[k].s[2] * v[2] + rows[k].s[3] * w;
    return r;
}

struct Across {  // one axis across the columns: v = base + slope · v_c + w · (origin + i · step)
    double base = 0, slope = 0, origin = 0, step = 1;
    int points = 1;
};

}  // namespace

std::array<double, 3> lattice_point_voxel(const ShadowCacheGpu& c, double x, double y, double z) {
    if (!c.column_axes.s[3]) return {x * c.spacing.s[0], y * c.spacing.s[1], z * c.spacing.s[2]};
    const cl_float4& along = c.column_along;
    const double v_c = along.s[0] + z * along.s[1], w = along.s[2] * v_c + along.s[3];
    std::array<double, 3> v{};
    const double index[2] = {x, y};
    for (int k = 0; k < 2; ++k) {
        const cl_float4& a = c.column_across[k];
        v[std::size_t(c.column_axes.s[k])] = a.s[0] + a.s[1] * v_c + w * (a.s[2] + index[k] * a.s[3]);
    }
    v[std::size_t(c.column_axes.s[2])] = v_c;
    return v;
}

void set_volume_lattice_map(ShadowCacheGpu& c) {
    for (int r = 0; r < 4; ++r) c.voxel_to_lattice[r] = cl_float4{{0, 0, 0, 0}};
    for (int a = 0; a < 3; ++a) c.voxel_to_lattice[a].s[a] = 1.f / c.spacing.s[a];
    c.voxel_to_lattice[3].s[3] = 1.f;
    c.column_axes = cl_int4{{0, 1, 2, 0}};
}

std::optional<ShadowCacheGpu> light_lattice(const ShadowCacheGpu& volume_lattice, const VolumeGpu& volume, const LightGpu& light,
                                            float step_voxels) {
    const std::array<int, 3> dims = {volume.dims.s[0], volume.dims.s[1], volume.dims.s[2]};
    const bool directional = light.type == SOMBRA_LIGHT_DIRECTIONAL;
    // in voxel space: a directional light's direction of travel, or a positional light's position
    const std::array<double, 3> d = apply_linear(volume.world_to_voxel, {light.direction.s[0], light.direction.s[1], light.direction.s[2]}, 0.0);
    const std::array<double, 3> l = apply_linear(volume.world_to_voxel, {light.position.s[0], light.position.s[1], light.position.s[2]}, 1.0);
    const double volume_points = double(lattice_points(volume_lattice));
    std::optional<ShadowCacheGpu> best;
    std::pair<double, double> best_score;  // (coarsening, points): the finest columns, then the fewest points
    for (int c = 0; c < 3; ++c) {
        const int a = c == 0 ? 1 : 0, b = c == 2 ? 1 : 2;
        const double hi_c = dims[std::size_t(c)] - 1, s_c = volume_lattice.spacing.s[c];
        double w_far = 1;  // |w| at the plane farthest from a point light
        bool light_on_high_side;
        if (directional) {
            if (std::abs(d[std::size_t(c)]) < 1e-6 * std::hypot(d[0], d[1], d[2])) continue;
            light_on_high_side = d[std::size_t(c)] < 0;  // the light lies where its rays come from
        } else {
            // the light must lie outside the slab along c, a lattice cell and a step clear of it,
            // so that w = v_c − l_c keeps its sign over every point a sample reads
            const double margin = volume_lattice.reach;
            if (l[std::size_t(c)] > -margin && l[std::size_t(c)] < hi_c + margin) continue;
            light_on_high_side = l[std::size_t(c)] >= hi_c + margin;
            w_far = std::max(std::abs(0 - l[std::size_t(c)]), std::abs(hi_c - l[std::size_t(c)]));
        }
        Across across[2];
        for (int k = 0; k < 2; ++k) {
            const int axis = k == 0 ? a : b;
            const double hi = dims[std::size_t(axis)] - 1;
            Across& s = across[k];
            // the columns' coordinate over the box's corners: the extremes of u = v_a − slope · v_c
            // (directional) or of (v_a − l_a) / (v_c − l_c) (positional), both monotonic per axis
            double lo_u = INFINITY, hi_u = -INFINITY;
            for (double va : {0.0, hi})
                for (double vc : {0.0, hi_c}) {
                    const double u = directional ? va - d[std::size_t(axis)] / d[std::size_t(c)] * vc
                                                 : (va - l[std::size_t(axis)]) / (vc - l[std::size_t(c)]);
                    lo_u = std::min(lo_u, u), hi_u = std::max(hi_u, u);
                }
            s.base = directional ? 0 : l[std::size_t(axis)];
            s.slope = directional ? d[std::size_t(axis)] / d[std::size_t(c)] : 0;
            s.origin = lo_u;
            s.step = volume_lattice.spacing.s[axis] / w_far;
            s.points = int(std::ceil((hi_u - lo_u) / s.step - 1e-6)) + 1;
        }
        const int planes = volume_lattice.dims.s[c];
        const double budget = std::min(kMaxLatticeGrowth * volume_points, double(kMaxLightLatticePoints));
        const double finest = double(across[0].points) * double(across[1].points) * double(planes);
        const double coarsening = std::max(1.0, std::sqrt(finest / budget));
        if (coarsening > kMaxCoarsening) continue;
        for (Across& s : across) {
            const double range = (s.points - 1) * s.step;
            s.step *= coarsening;
            s.points = int(std::ceil(range / s.step - 1e-6)) + 1;
        }
        const std::pair<double, double> score = {coarsening, double(across[0].points) * double(across[1].points) * double(planes)};
        if (best && score >= best_score) continue;
        ShadowCacheGpu g = volume_lattice;
        g.dims = cl_int4{{across[0].points, across[1].points, planes, 0}};
        g.spacing = cl_float4{{1, 1, 1, 0}};  // index units (auto's probe blocks rows along y)
        g.column_axes = cl_int4{{a, b, c, 1}};
        const double along_first = light_on_high_side ? hi_c : 0, along_step = light_on_high_side ? -s_c : s_c;
        const double w_slope = directional ? 0 : 1, w_offset = directional ? 1 : -l[std::size_t(c)];
        g.column_along = cl_float4{{float(along_first), float(along_step), float(w_slope), float(w_offset)}};
        for (int k = 0; k < 2; ++k)
            g.column_across[k] = cl_float4{{float(across[k].base), float(across[k].slope), float(across[k].origin), float(across[k].step)}};
        // voxel → lattice (cl/render.cl lattice_cell): x = (v_a − base − slope · v_c − origin · w) / (step · w)
        for (int r = 0; r < 4; ++r) g.voxel_to_lattice[r] = cl_float4{{0, 0, 0, 0}};
        for (int k = 0; k < 2; ++k) {
            const int axis = k == 0 ? a : b;
            const Across& s = across[k];
            cl_float4& row = g.voxel_to_lattice[k];
            row.s[axis] = float(1 / s.step);
            row.s[c] = float(-(s.slope + s.origin * w_slope) / s.step);
            row.s[3] = float(-(s.base + s.origin * w_offset) / s.step);
        }
        g.voxel_to_lattice[2].s[c] = float(1 / along_step);
        g.voxel_to_lattice[2].s[3] = float(-along_first / along_step);
        g.voxel_to_lattice[3].s[c] = float(w_slope);
        g.voxel_to_lattice[3].s[3] = float(w_offset);
        // a sample reads its cell's points: the farthest apart along a column (its steepest ray)
        // or across it (at the far plane: the volume lattice's spacing, times the coarsening)
        double along_length = 0;
        for (double u0 : {across[0].origin, across[0].origin + (across[0].points - 1) * across[0].step})
            for (double u1 : {across[1].origin, across[1].origin + (across[1].points - 1) * across[1].step}) {
                const double slope0 = directional ? across[0].slope : u0, slope1 = directional ? across[1].slope : u1;
                along_length = std::max(along_length, s_c * std::sqrt(1 + slope0 * slope0 + slope1 * slope1));
            }
        g.reach = float(std::max({along_length, coarsening * volume_lattice.spacing.s[a], coarsening * volume_lattice.spacing.s[b]}) +
                        step_voxels + 1.0);
        best = g;
        best_score = score;
    }
    return best;
}

}  // namespace sombra::pipeline
