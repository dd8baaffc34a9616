// sombra — ground-truth transmittance (shadows.h: reference_transmittance).
//
// This file is the independent yardstick every shadow technique is measured against. It shares no
// code with the kernels (cl/) nor with the test references (tests/reference/): everything it needs
// — the voxel ↔ world affine maps, the box clipping, trilinear interpolation, the extinction of
// the transfer function and the quadrature — is written out here, in double precision, in small
// functions that each do one thing.
//
//   T(p → light) = exp(−τ),   τ = Σ_volumes ∫_segment σ_v(x) ds                      (Beer–Lambert)
//   σ_v(x)       = −ln(1 − α(f_v(x))) / opacity_unit_v                     (docs/scenes.md: opacity convention)
//   ∫_a^b σ ds   = Σ_pieces (t₁ − t₀) · (1/(f₁ − f₀)) ∫_{f₀}^{f₁} σ(f) df                (pre-integrated)
//
// The segment is cut where it crosses a plane of voxel centres (there the trilinear interpolant f_v
// changes form), each cell's part into pieces of at most h₀ = step_voxels × the volume's smallest
// world voxel size, and f is taken linear over each piece between its end values f₀, f₁. The
// integral of σ over the value range is in closed form: α is linear between the transfer
// function's opacity points, and ∫ −ln(1 − α) df = [u − u ln u]/α' with u = 1 − α. So a stiff
// medium (α → 1, where σ has a log singularity) is integrated exactly, not sampled: along a ray
// parallel to a voxel axis f is linear and the whole integral is exact (issue 27 item 3: the
// one-voxel wall of opacity 0.999999 within 10⁻⁴ of its closed form; the midpoint rule it replaces
// was off by up to 0.029). f_v is the trilinear interpolation of the voxels (positions clamped to
// [0, dims − 1]). Overlapping volumes add their
// optical depths. A volume with a polyhedral bound integrates only where the ray is inside the
// closed mesh (parity of its crossings). Meshes: every triangle the segment crosses (watertight
// edge tests in double against every triangle of every mesh, brute force) multiplies T by
// 1 − its mesh's opacity:
//
//   T = exp(−τ) · Π_{triangles crossed} (1 − a_mesh)
//
// No spot cone, no distance attenuation: transmittance only.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "sombra/error.h"
#include "sombra/shadows.h"

namespace sombra {
namespace {

// ---- small double-precision vector algebra ----

using D3 = std::array<double, 3>;

D3 to_d3(const Vec3& v) { return {double(v[0]), double(v[1]), double(v[2])}; }
D3 add(const D3& a, const D3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
D3 sub(const D3& a, const D3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
D3 scale(double s, const D3& a) { return {s * a[0], s * a[1], s * a[2]}; }
D3 cross(const D3& a, const D3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
double dot(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double length(const D3& a) { return std::sqrt(dot(a, a)); }
bool finite(const D3& a) { return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]); }

// x ↦ M·x + t, M a 3×3 matrix stored row-major.
struct Affine {
    std::array<std::array<double, 3>, 3> m{};
    D3 t{0, 0, 0};

    D3 apply_linear(const D3& x) const {
        return {m[0][0] * x[0] + m[0][1] * x[1] + m[0][2] * x[2],
                m[1][0] * x[0] + m[1][1] * x[1] + m[1][2] * x[2],
                m[2][0] * x[0] + m[2][1] * x[1] + m[2][2] * x[2]};
    }
    D3 apply_point(const D3& x) const { return add(apply_linear(x), t); }
};

// (A∘B)(x) = A(B(x)) = A.m·B.m·x + (A.m·B.t + A.t)
Affine compose(const Affine& a, const Affine& b) {
    Affine r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
    r.t = a.apply_point(b.t);
    return r;
}

double determinant(const Affine& a) {
    const auto& m = a.m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// Inverse of x ↦ M·x + t is y ↦ M⁻¹·y − M⁻¹·t, with M⁻¹ = adj(M)/det(M) (cofactor formula).
Affine inverse(const Affine& a, const std::string& where) {
    const double det = determinant(a);
    if (!std::isfinite(det) || det == 0.0) throw Error(where + ": transform is singular (zero determinant)");
    const auto& m = a.m;
    Affine r;
    r.m[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
    r.m[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
    r.m[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
    r.m[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det;
    r.m[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
    r.m[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
    r.m[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
    r.m[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
    r.m[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
    r.t = scale(-1.0, r.apply_linear(a.t));
    return r;
}

// ---- one volume in world space ----

// Voxel (i, j, k) → object frame: ((i − (nx−1)/2)·sx, (j − (ny−1)/2)·sy, (k − (nz−1)/2)·sz)  (scene.h)
Affine voxel_to_object(const VolumeInstance& vi) {
    Affine a;
    for (int axis = 0; axis < 3; ++axis) {
        const double s = vi.spacing[std::size_t(axis)];
        a.m[axis][axis] = s;
        a.t[axis] = -0.5 * double(vi.volume->dims[std::size_t(axis)] - 1) * s;
    }
    return a;
}

// Object → world: the affine part of the row-major 4×4 `transform` (last row is 0 0 0 1).
Affine object_to_world(const VolumeInstance& vi) {
    Affine a;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) a.m[r][c] = vi.transform[std::size_t(r * 4 + c)];
        a.t[r] = vi.transform[std::size_t(r * 4 + 3)];
    }
    return a;
}

// World length of one voxel step along voxel axis j = |column j of the voxel → world matrix|;
// the smallest of the three is "the volume's smallest world voxel size".
double smallest_voxel_size(const Affine& voxel_to_world) {
    double smallest = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j)
        smallest = std::min(smallest, length({voxel_to_world.m[0][j], voxel_to_world.m[1][j], voxel_to_world.m[2][j]}));
    return smallest;
}

struct PreparedVolume {
    const Volume* volume = nullptr;
    const TransferFunction* tf = nullptr;
    Affine world_to_voxel;
    double voxel_size = 0;    // smallest world voxel size
    double opacity_unit = 0;  // world length the TF opacities refer to
    Vec3 clip_min, clip_max;  // VolumeInstance's world clip box
};

PreparedVolume prepare(const VolumeInstance& vi, const std::string& where) {
    if (!vi.volume) throw Error(where + ": no volume data");
    const Volume& v = *vi.volume;
    if (v.dims[0] < 1 || v.dims[1] < 1 || v.dims[2] < 1 || v.voxels.size() != v.voxel_count())
        throw Error(where + ": volume has no voxels or a voxel count that does not match its dims");
    const Affine voxel_to_world = compose(object_to_world(vi), voxel_to_object(vi));
    PreparedVolume pv;
    pv.volume = &v;
    pv.tf = &vi.transfer_function;
    pv.world_to_voxel = inverse(voxel_to_world, where);
    pv.voxel_size = smallest_voxel_size(voxel_to_world);
    pv.opacity_unit = vi.opacity_unit > 0.f ? double(vi.opacity_unit) : pv.voxel_size;  // 0 = one voxel
    pv.clip_min = vi.clip_min, pv.clip_max = vi.clip_max;
    return pv;
}

// ---- sampling ----

// Trilinear interpolation at voxel-space position x (voxel (i, j, k) at integer coordinates),
// clamp-to-edge: x is first clamped to [0, dims − 1] on each axis.
double sample_trilinear(const Volume& v, const D3& x) {
    int lo[3], hi[3];
    double w[3];  // weight of the upper neighbour
    for (int a = 0; a < 3; ++a) {
        const int n = v.dims[std::size_t(a)];
        const double c = std::clamp(x[std::size_t(a)], 0.0, double(n - 1));
        lo[a] = std::min(int(std::floor(c)), n - 1);
        hi[a] = std::min(lo[a] + 1, n - 1);
        w[a] = c - double(lo[a]);
    }
    double result = 0;
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const double weight = (dx ? w[0] : 1 - w[0]) * (dy ? w[1] : 1 - w[1]) * (dz ? w[2] : 1 - w[2]);
                if (weight == 0) continue;
                result += weight * double(v.at(dx ? hi[0] : lo[0], dy ? hi[1] : lo[1], dz ? hi[2] : lo[2]));
            }
    return result;
}

// σ = −ln(1 − α)/opacity_unit (docs/scenes.md, "Opacity convention"), α = TF opacity of the value.
// α = 1 would be σ = ∞: it is capped at transmittance 10⁻⁶ per opacity unit, σ_max = −ln(10⁻⁶)/unit,
// and, as in TransferFunction::table, no σ exceeds that cap.
double extinction(const TransferFunction& tf, double value, double opacity_unit) {
    const double alpha = std::clamp(double(tf.opacity(float(value))), 0.0, 1.0);
    const double sigma_max = -std::log(1e-6) / opacity_unit;
    if (alpha >= 1.0) return sigma_max;
    return std::min(sigma_max, -std::log1p(-alpha) / opacity_unit);  // log1p(−α) = ln(1 − α)
}

// ---- geometry of the shadow segment ----

// The shadow segment: origin + t·dir, t ∈ [0, t_end], |dir| = 1 (so t is a world length).
struct Segment {
    D3 origin;
    D3 dir;
    double t_end;  // +∞ for a directional light
};

struct Interval {
    double t0, t1;
    bool empty() const { return !(t1 > t0); }
};

// Narrows `in` to where o + t·d lies in the box [lo, hi] (slab method).
Interval clip_to_slabs(Interval in, const D3& o, const D3& d, const D3& lo, const D3& hi) {
    for (std::size_t a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {  // parallel to this pair of faces: inside the slab or never
            if (o[a] < lo[a] || o[a] > hi[a]) return {0.0, 0.0};
            continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        in.t0 = std::max(in.t0, ta);
        in.t1 = std::min(in.t1, tb);
    }
    return in;
}

// Clips the segment against the volume's box [−½, dims − ½]³ in voxel space, and against its
// world clip box. An affine map sends origin + t·dir to o' + t·d', so the parameter t is the same
// in both spaces.
Interval clip_to_box(const PreparedVolume& pv, const Segment& s) {
    const D3 dims{double(pv.volume->dims[0]), double(pv.volume->dims[1]), double(pv.volume->dims[2])};
    Interval in = clip_to_slabs({0.0, s.t_end}, pv.world_to_voxel.apply_point(s.origin), pv.world_to_voxel.apply_linear(s.dir),
                                {-0.5, -0.5, -0.5}, {dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5});
    return clip_to_slabs(in, s.origin, s.dir, to_d3(pv.clip_min), to_d3(pv.clip_max));
}

// −ln u capped as `extinction` caps σ (u = 1 − α ≥ 10⁻⁶), and its antiderivative in u.
constexpr double kMinTransmittance = 1e-6;
double capped_depth(double u) { return -std::log(std::max(u, kMinTransmittance)); }
double depth_antiderivative(double u) {  // ∫ −ln u du = u − u ln u, continued linearly below the cap
    if (u >= kMinTransmittance) return u > 0 ? u - u * std::log(u) : 0.0;
    return depth_antiderivative(kMinTransmittance) + (u - kMinTransmittance) * -std::log(kMinTransmittance);
}

// ∫_a^b −ln(1 − α(f)) df over one stretch where α is linear, from α_a to α_b (capped as σ is).
double linear_alpha_depth(double a, double b, double alpha_a, double alpha_b) {
    const double ua = 1 - std::clamp(alpha_a, 0.0, 1.0), ub = 1 - std::clamp(alpha_b, 0.0, 1.0);
    if (std::fabs(ub - ua) <= 1e-9) return (b - a) * capped_depth(0.5 * (ua + ub));  // error O(Δu²)
    // f ↦ u is linear: df = du · (b − a)/(u_b − u_a)
    return (b - a) / (ub - ua) * (depth_antiderivative(ub) - depth_antiderivative(ua));
}

// The opacity of the transfer function at f in double precision (clamped at the ends), and the
// closed-form ∫_{f0}^{f1} σ(f) df across its linear pieces.
double extinction_integral(const TransferFunction& tf, double f0, double f1, double opacity_unit) {
    if (f1 < f0) return -extinction_integral(tf, f1, f0, opacity_unit);
    const auto& points = tf.opacity_points;
    const auto alpha_at = [&](double f) {
        if (f <= points.front().x) return double(points.front().alpha);
        if (f >= points.back().x) return double(points.back().alpha);
        auto upper = std::upper_bound(points.begin(), points.end(), f, [](double v, const auto& p) { return v < p.x; });
        const auto &pa = *(upper - 1), &pb = *upper;
        const double w = pb.x > pa.x ? (f - pa.x) / (double(pb.x) - pa.x) : 1.0;
        return double(pa.alpha) + (double(pb.alpha) - pa.alpha) * w;
    };
    double depth = 0, from = f0;
    for (const auto& p : points) {  // α is linear between consecutive breakpoints
        if (!(p.x > from && p.x < f1)) continue;
        depth += linear_alpha_depth(from, p.x, alpha_at(from), alpha_at(p.x));
        from = p.x;
    }
    depth += linear_alpha_depth(from, f1, alpha_at(from), alpha_at(f1));
    return depth / opacity_unit;
}

// The mean of σ over a piece along which the value runs linearly from f0 to f1.
double mean_extinction(const PreparedVolume& pv, double f0, double f1) {
    if (std::fabs(f1 - f0) <= 1e-9 * (1 + std::fabs(f0))) return extinction(*pv.tf, 0.5 * (f0 + f1), pv.opacity_unit);
    return extinction_integral(*pv.tf, f0, f1, pv.opacity_unit) / (f1 - f0);
}

// ∫ σ_v ds over [t0, t1]: cut at the planes of voxel centres, pieces ≤ h₀, each pre-integrated.
double integrate(const PreparedVolume& pv, const Segment& s, double t0, double t1, double step_voxels) {
    const D3 o = pv.world_to_voxel.apply_point(s.origin), d = pv.world_to_voxel.apply_linear(s.dir);
    std::vector<double> cuts{t0, t1};
    for (int a = 0; a < 3; ++a) {
        if (d[std::size_t(a)] == 0.0) continue;
        const double x0 = o[std::size_t(a)] + t0 * d[std::size_t(a)], x1 = o[std::size_t(a)] + t1 * d[std::size_t(a)];
        const double lo = std::max(0.0, std::ceil(std::min(x0, x1))),
                     hi = std::min(double(pv.volume->dims[std::size_t(a)] - 1), std::floor(std::max(x0, x1)));
        for (double k = lo; k <= hi; k += 1) {
            const double t = (k - o[std::size_t(a)]) / d[std::size_t(a)];
            if (t > t0 && t < t1) cuts.push_back(t);
        }
    }
    std::sort(cuts.begin(), cuts.end());
    const double h0 = step_voxels * pv.voxel_size;
    const auto value_at = [&](double t) {
        return sample_trilinear(*pv.volume, pv.world_to_voxel.apply_point(add(s.origin, scale(t, s.dir))));
    };
    double tau = 0;
    for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
        const double a = cuts[c], b = cuts[c + 1];
        if (!(b > a)) continue;
        const double n = std::max(1.0, std::ceil((b - a) / h0));
        double t_prev = a, f_prev = value_at(a);
        for (double k = 1; k <= n; k += 1) {
            const double t = k == n ? b : a + (b - a) * (k / n);
            const double f = value_at(t);
            tau += (t - t_prev) * mean_extinction(pv, f_prev, f);
            t_prev = t, f_prev = f;
        }
    }
    return tau;
}

// τ_v over the part of the segment inside the volume's box and inside `inside` (sorted, disjoint
// intervals of t where the volume is active: its polyhedral bound, or all of [0, ∞)).
double optical_depth(const PreparedVolume& pv, const Segment& s, const std::vector<Interval>& inside, double step_voxels) {
    const Interval box = clip_to_box(pv, s);
    if (box.empty()) return 0.0;
    double tau = 0;
    for (const Interval& in : inside) {
        const double t0 = std::max(box.t0, in.t0), t1 = std::min(box.t1, in.t1);
        if (t1 > t0) tau += integrate(pv, s, t0, t1, step_voxels);
    }
    return tau;
}

// From p towards the light: directional lights along −direction to infinity; spot and point
// lights to their position.
Segment shadow_segment(const Light& light, const D3& p, const std::string& where) {
    if (light.type == LightType::Directional) {
        const D3 d = to_d3(light.direction);
        const double len = length(d);
        if (!(len > 0) || !std::isfinite(len)) throw Error(where + ".direction: must be a finite non-zero vector");
        return {p, scale(-1.0 / len, d), std::numeric_limits<double>::infinity()};
    }
    const D3 to_light = sub(to_d3(light.position), p);
    if (!finite(to_light)) throw Error(where + ".position: not finite");
    const double dist = length(to_light);
    if (dist == 0.0) return {p, {0, 0, 1}, 0.0};  // p at the light: empty segment, T = 1
    return {p, scale(1.0 / dist, to_light), dist};
}

// ---- meshes ----

// Object → world of a mesh: its row-major 4×4 transform (last row 0 0 0 1).
D3 mesh_point(const std::array<float, 16>& m, const std::array<float, 3>& p) {
    D3 r{};
    for (std::size_t i = 0; i < 3; ++i)
        r[i] = double(m[i * 4]) * p[0] + double(m[i * 4 + 1]) * p[1] + double(m[i * 4 + 2]) * p[2] + double(m[i * 4 + 3]);
    return r;
}

// Which side of the edge p → q the line passes: the sign of the triple product
// [dir, p − o, q − o]. A line through the edge (0) takes the side of the edge's direction (+ when p
// comes before q lexicographically): the two triangles that share an edge run it in opposite
// directions and get exactly opposite products, so a line through it crosses one of them, never
// both and never neither (watertight, as the raster's top-left rule).
int edge_side(const Segment& s, const D3& p, const D3& q) {
    const double w = dot(s.dir, cross(sub(p, s.origin), sub(q, s.origin)));
    if (w != 0) return w > 0 ? 1 : -1;
    return p < q ? 1 : -1;
}

// Parameter t of the crossing of the line s.origin + t·s.dir with triangle (a, b, c), any sign of
// t; NaN when there is none: the line must pass every edge on the same side (Plücker-style edge
// tests, watertight) and meet the plane. A line in the triangle's plane and a degenerate triangle
// cross nothing (nothing is divided by 0). Surfaces and polyhedral bounds use the same test, so a
// line through a shared edge of a closed bound toggles its parity once.
double crossing_t(const Segment& s, const D3& a, const D3& b, const D3& c) {
    const double none = std::numeric_limits<double>::quiet_NaN();
    const D3 n = cross(sub(b, a), sub(c, a));
    const double facing = dot(n, s.dir);
    if (!(std::fabs(facing) > 1e-12 * length(n))) return none;
    const int side = edge_side(s, a, b);
    if (edge_side(s, b, c) != side || edge_side(s, c, a) != side) return none;
    return dot(n, sub(a, s.origin)) / facing;
}

// Π (1 − a) over the triangles of every mesh the segment crosses.
double surfaces_transmittance(const Scene& scene, const Segment& s) {
    double result = 1;
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        const MeshInstance& mi = scene.meshes[i];
        if (!mi.mesh) throw Error("meshes[" + std::to_string(i) + "]: no mesh data");
        const double keep = 1.0 - std::clamp(double(mi.material.opacity), 0.0, 1.0);
        for (const auto& tri : mi.mesh->triangles) {
            const double t = crossing_t(s, mesh_point(mi.transform, mi.mesh->positions[tri[0]]),
                                        mesh_point(mi.transform, mi.mesh->positions[tri[1]]),
                                        mesh_point(mi.transform, mi.mesh->positions[tri[2]]));
            if (t > 0 && t < s.t_end) result *= keep;
        }
    }
    return result;
}

// Where along the ray (t ≥ 0) a volume is active under its polyhedral bound: every crossing of the
// bound mesh at t > 0 toggles inside/outside, and the start is inside when their count is odd
// (parity; the mesh is closed). No bound: all of [0, ∞).
std::vector<Interval> bound_intervals(const VolumeInstance& vi, const Segment& s) {
    const double infinity = std::numeric_limits<double>::infinity();
    if (!vi.bound.mesh) return {{0.0, infinity}};
    const std::array<float, 16> m = bound_to_world(vi);
    const Mesh& mesh = *vi.bound.mesh;
    const Segment line{s.origin, s.dir, infinity};
    std::vector<double> hits;
    for (const auto& tri : mesh.triangles) {
        const double t = crossing_t(line, mesh_point(m, mesh.positions[tri[0]]), mesh_point(m, mesh.positions[tri[1]]),
                                    mesh_point(m, mesh.positions[tri[2]]));
        if (t > 0) hits.push_back(t);
    }
    std::sort(hits.begin(), hits.end());
    bool inside = hits.size() % 2 == 1;
    std::vector<Interval> out;
    double from = 0;
    for (double t : hits) {
        if (inside) out.push_back({from, t});
        inside = !inside, from = t;
    }
    if (inside) out.push_back({from, infinity});
    return out;
}

}  // namespace

double reference_transmittance(const Scene& scene, int light_index, const Vec3& p, double step_voxels) {
    if (light_index < 0 || std::size_t(light_index) >= scene.lights.size())
        throw Error("reference_transmittance: light index " + std::to_string(light_index) + " out of range (scene has " +
                    std::to_string(scene.lights.size()) + " lights)");
    if (!(step_voxels > 0) || !std::isfinite(step_voxels))
        throw Error("reference_transmittance: step_voxels must be a finite positive number");
    const D3 point = to_d3(p);
    if (!finite(point)) throw Error("reference_transmittance: point is not finite");

    const std::string light_where = "lights[" + std::to_string(light_index) + "]";
    const Segment segment = shadow_segment(scene.lights[std::size_t(light_index)], point, light_where);

    double tau = 0;  // overlapping volumes add their optical depths
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        const PreparedVolume pv = prepare(scene.volumes[i], "volumes[" + std::to_string(i) + "]");
        tau += optical_depth(pv, segment, bound_intervals(scene.volumes[i], segment), step_voxels);
    }
    return std::exp(-tau) * surfaces_transmittance(scene, segment);
}

}  // namespace sombra
