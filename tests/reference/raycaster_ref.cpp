#include "reference/raycaster_ref.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "shared/hash.h"

namespace sombra::reference {
namespace {

using V3 = std::array<double, 3>;
V3 operator+(V3 a, V3 b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 operator-(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 operator*(double s, V3 a) { return {s * a[0], s * a[1], s * a[2]}; }
double dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm(V3 a) { return std::sqrt(dot(a, a)); }
V3 unit(V3 a) { return (1.0 / norm(a)) * a; }
V3 cross(V3 a, V3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
V3 from(const Vec3& v) { return {v[0], v[1], v[2]}; }

// Affine map as 3×3 + translation.
struct Affine {
    double m[3][3];
    V3 t;
    V3 point(V3 p) const { return direction(p) + t; }
    V3 direction(V3 d) const {
        return {m[0][0] * d[0] + m[0][1] * d[1] + m[0][2] * d[2], m[1][0] * d[0] + m[1][1] * d[1] + m[1][2] * d[2],
                m[2][0] * d[0] + m[2][1] * d[1] + m[2][2] * d[2]};
    }
    Affine inverse() const {
        Affine r{};
        double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                int a = (j + 1) % 3, b = (j + 2) % 3, c = (i + 1) % 3, d = (i + 2) % 3;
                r.m[i][j] = (m[a][c] * m[b][d] - m[a][d] * m[b][c]) / det;  // adjugate / det
            }
        r.t = -1.0 * r.direction(t);
        return r;
    }
};

struct RefVolume {
    const VolumeInstance* instance;
    Affine world_to_voxel;
    double step, opacity_unit;
    bool stiff;  // σ·step ≥ 2 somewhere on the kernel's table grid: light passes split at voxel planes
};

// Extinction per world unit: σ = −ln(1 − α) / opacity_unit, α = 1 capped at T = 1e-6 (docs/scenes.md).
double extinction(const TransferFunction& tf, double value, double unit) {
    double alpha = std::clamp(double(tf.opacity(float(value))), 0.0, 1.0);
    double cap = -std::log(1e-6) / unit;
    return alpha >= 1.0 ? cap : std::min(cap, -std::log1p(-alpha) / unit);
}

RefVolume prepare(const VolumeInstance& vi) {
    const Volume& v = *vi.volume;
    Affine grid{}, object{};
    for (int i = 0; i < 3; ++i) {
        grid.m[i][i] = vi.spacing[i];
        grid.t[i] = -0.5 * (v.dims[i] - 1) * vi.spacing[i];
        for (int j = 0; j < 3; ++j) object.m[i][j] = vi.transform[i * 4 + j];
        object.t[i] = vi.transform[i * 4 + 3];
    }
    Affine voxel_to_world{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) voxel_to_world.m[i][j] = object.m[i][0] * grid.m[0][j] + object.m[i][1] * grid.m[1][j] + object.m[i][2] * grid.m[2][j];
    voxel_to_world.t = object.point(grid.t);
    double voxel_size = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j)
        voxel_size = std::min(voxel_size, norm({voxel_to_world.m[0][j], voxel_to_world.m[1][j], voxel_to_world.m[2][j]}));
    double unit = vi.opacity_unit > 0 ? vi.opacity_unit : voxel_size;
    const TransferFunction& tf = vi.transfer_function;
    double max_sigma = 0;
    for (int i = 0; i < 1024; ++i)  // the kernel's table grid (src/geometry/scene_upload.h kTransferTableSize)
        max_sigma = std::max(max_sigma, extinction(tf, tf.domain_min() + (tf.domain_max() - tf.domain_min()) * i / 1023.0, unit));
    double step = vi.step_voxels * voxel_size;
    return {&vi, voxel_to_world.inverse(), step, unit, float(max_sigma) * float(step) >= 2.f};
}

V3 gradient(const Volume& v, V3 p, bool sobel) {
    auto s = [&](double dx, double dy, double dz) { return sample_trilinear(v, p[0] + dx, p[1] + dy, p[2] + dz); };
    if (!sobel) return {0.5 * (s(1, 0, 0) - s(-1, 0, 0)), 0.5 * (s(0, 1, 0) - s(0, -1, 0)), 0.5 * (s(0, 0, 1) - s(0, 0, -1))};
    V3 g{0, 0, 0};
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                double wx = 2 - std::abs(dx), wy = 2 - std::abs(dy), wz = 2 - std::abs(dz), f = s(dx, dy, dz);
                g = g + V3{f * dx * wy * wz, f * dy * wx * wz, f * dz * wx * wy};
            }
    return (1.0 / 32.0) * g;
}

// Phong with several lights and attenuation (Knecht Eq. 3.9, slides' phongShading), shadow = 1.
V3 shade(const Scene& scene, const Material& mat, V3 color, V3 p, V3 normal, V3 to_viewer, const std::vector<double>& shadow) {
    V3 result = (mat.ambient * scene.ambient_intensity) * color;
    bool has_normal = dot(normal, normal) > 0;
    if (has_normal && dot(normal, to_viewer) < 0) normal = -1.0 * normal;
    for (std::size_t m = 0; m < scene.lights.size(); ++m) {
        const Light& l = scene.lights[m];
        V3 to_light;
        double f = 1;
        if (l.type == LightType::Directional) {
            to_light = -1.0 * unit(from(l.direction));
        } else {
            V3 d = from(l.position) - p;
            double dist = norm(d);
            to_light = dist > 0 ? (1.0 / dist) * d : V3{0, 0, 1};
            f = 1.0 / (l.att_constant + l.att_linear * dist + l.att_quadratic * dist * dist);
            if (l.type == LightType::Spot) {
                double half = l.cone_angle_deg * M_PI / 180.0;
                double e0 = std::cos(half), e1 = std::cos(half * (1 - l.cone_softness));
                if (e1 <= e0) e1 = e0 + 1e-6;
                double x = std::clamp((dot(-1.0 * to_light, unit(from(l.direction))) - e0) / (e1 - e0), 0.0, 1.0);
                f *= x * x * (3 - 2 * x);
            }
        }
        if (f <= 0) continue;
        V3 lit;
        if (has_normal) {
            double n_dot_l = std::max(dot(normal, to_light), 0.0);
            V3 r = (2 * dot(normal, to_light)) * normal - to_light;
            double highlight = n_dot_l > 0 && mat.specular > 0 ? std::pow(std::max(dot(r, to_viewer), 0.0), mat.shininess) : 0;
            lit = (mat.diffuse * n_dot_l) * color + (mat.specular * highlight) * V3{1, 1, 1};
        } else {
            lit = mat.diffuse * color;
        }
        V3 lc = double(l.intensity) * from(l.color);
        result = result + (f * shadow[m]) * V3{lit[0] * lc[0], lit[1] * lc[1], lit[2] * lc[2]};
    }
    return result;
}

// Mean extinction over an interval along which the value runs linearly from front to back
// (pre-integration, Engel et al. 2001): the transfer function evaluated directly at 16 midpoints.
double preintegrated_extinction(const TransferFunction& tf, double front, double back, double unit) {
    if (front == back) return extinction(tf, front, unit);
    const int n = 16;
    double sum = 0;
    for (int k = 0; k < n; ++k) sum += extinction(tf, front + (k + 0.5) / n * (back - front), unit);
    return sum / n;
}

// Narrows [t0, t1] to where o + t·d lies in the box [lo, hi] (slab test); empty when t0 ≥ t1.
void narrow_to_box(V3 o, V3 d, V3 lo, V3 hi, double& t0, double& t1) {
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(d[a]) < 1e-30) {
            if (o[a] < lo[a] || o[a] > hi[a]) t0 = INFINITY, t1 = -INFINITY;
        } else {
            double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
        }
    }
}

// The part [t0, t1] ⊂ [t_min, t_max] of origin + t·dir inside the volume's box [−0.5, dims − 0.5]
// (slab test in voxel space; affine maps keep t) and inside the instance's world clip box
// (infinite unless clipped); empty when t0 ≥ t1.
void box_span(const RefVolume& rv, V3 origin, V3 dir, double t_min, double t_max, double& t0, double& t1) {
    const auto& dims = rv.instance->volume->dims;
    const auto& clip_min = rv.instance->clip_min;
    const auto& clip_max = rv.instance->clip_max;
    t0 = t_min, t1 = t_max;
    narrow_to_box(rv.world_to_voxel.point(origin), rv.world_to_voxel.direction(dir), {-0.5, -0.5, -0.5},
                  {dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5}, t0, t1);
    narrow_to_box(origin, dir, {clip_min[0], clip_min[1], clip_min[2]}, {clip_max[0], clip_max[1], clip_max[2]}, t0, t1);
}

// Calls visit(t, delta, active volumes) for every point of the ray origin + t·dir, t in [0, t_max],
// over homogeneous segments (sorted box entries/exits; step = smallest of the active volumes): each
// segment's start (delta 0), its samples start + (k + jitter)·step strictly inside it, and its end;
// delta is the length from the previous point (cl/traversal.h). Stops when visit returns false.
template <typename Visit>
void march_segments(const std::vector<RefVolume>& volumes, V3 origin, V3 dir, double t_max, double jitter, Visit visit) {
    std::vector<double> enter(volumes.size()), exit(volumes.size()), bounds;
    for (std::size_t i = 0; i < volumes.size(); ++i) {
        box_span(volumes[i], origin, dir, 0.0, t_max, enter[i], exit[i]);
        if (enter[i] < exit[i]) bounds.push_back(enter[i]), bounds.push_back(exit[i]);
    }
    std::sort(bounds.begin(), bounds.end());
    for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
        double a = bounds[s], b = bounds[s + 1], mid = 0.5 * (a + b), step = INFINITY;
        std::vector<std::size_t> active;
        for (std::size_t i = 0; i < volumes.size(); ++i)
            if (enter[i] <= mid && mid < exit[i]) active.push_back(i), step = std::min(step, volumes[i].step);
        if (active.empty() || !(b > a)) continue;
        if (!visit(a, 0.0, active)) return;
        double previous = a;
        for (double k = jitter > 0 ? 0 : 1;; k += 1) {
            double t = a + (k + jitter) * step;
            if (t >= b) break;
            if (!visit(t, t - previous, active)) return;
            previous = t;
        }
        if (!visit(b, b - previous, active)) return;
    }
}

// The value of each volume at the previous point of a march; the mean extinction of volume i
// over the interval to point q (pre-integrated, for the camera pass) or its optical depth (light
// passes); stiff volumes split at the ray's crossings of voxel-centre planes in both, as the kernels do.
struct IntervalValues {
    std::vector<double> front;
    std::vector<V3> front_voxel;
    explicit IntervalValues(std::size_t n) : front(n, 0.0), front_voxel(n, V3{0, 0, 0}) {}
    double value_at(const RefVolume& rv, V3 pv) const { return sample_trilinear(*rv.instance->volume, pv[0], pv[1], pv[2]); }
    // (a stiff volume's interval integrated in pieces, as depth() does: cl/render.cl)
    double sigma(const RefVolume& rv, std::size_t i, V3 q, double delta, double* value_out = nullptr) {
        V3 pv = rv.world_to_voxel.point(q);
        double value = value_at(rv, pv);
        if (rv.stiff && delta > 0) {
            if (value_out) *value_out = value;
            return depth(rv, i, q, delta) / delta;
        }
        double sigma = preintegrated_extinction(rv.instance->transfer_function, front[i], value, rv.opacity_unit);
        front[i] = value, front_voxel[i] = pv;
        if (value_out) *value_out = value;
        return sigma;
    }
    double depth(const RefVolume& rv, std::size_t i, V3 q, double delta) {
        V3 a = front_voxel[i], b = rv.world_to_voxel.point(q);
        double value = value_at(rv, b), front_value = front[i];
        front[i] = value, front_voxel[i] = b;
        if (!(delta > 0)) return 0;
        const TransferFunction& tf = rv.instance->transfer_function;
        std::vector<double> cuts;  // fractions of the interval: pieces of ≤ 1 voxel per axis, then voxel-centre planes
        if (rv.stiff) {
            double longest = 0;
            for (int axis = 0; axis < 3; ++axis) longest = std::max(longest, std::fabs(b[axis] - a[axis]));
            int pieces = std::clamp(int(std::ceil(longest - 1e-3)), 1, 16);  // cl/traversal.h SOMBRA_STIFF_MAX_PIECES
            for (int j = 0; j < pieces; ++j) {
                double u0 = double(j) / pieces, u1 = double(j + 1) / pieces;
                if (j > 0) cuts.push_back(u0);
                V3 pa = a + u0 * (b - a), pb = a + u1 * (b - a);
                for (int axis = 0; axis < 3; ++axis) {
                    double f0 = std::floor(pa[axis]), f1 = std::floor(pb[axis]);
                    if (f0 == f1) continue;
                    double u = (std::max(f0, f1) - a[axis]) / (b[axis] - a[axis]);
                    if (u > u0 && u < u1) cuts.push_back(u);
                }
            }
        }
        std::sort(cuts.begin(), cuts.end());
        cuts.push_back(1.0);
        double tau = 0, u0 = 0, v0 = front_value;
        for (double u : cuts) {
            V3 p = a + u * (b - a);
            double v1 = u < 1.0 ? value_at(rv, p) : value;
            tau += preintegrated_extinction(tf, v0, v1, rv.opacity_unit) * (u - u0) * delta;
            u0 = u, v0 = v1;
        }
        return tau;
    }
};

// Transmittance from p to the light along a shadow ray (same segments and jitter as camera rays),
// stopped once the optical depth passes −ln 10⁻⁶, as the kernel does.
double shadow_ray_transmittance(const std::vector<RefVolume>& volumes, const Light& l, V3 p, double jitter) {
    V3 dir;
    double t_max = INFINITY;
    if (l.type == LightType::Directional) {
        dir = -1.0 * unit(from(l.direction));
    } else {
        V3 d = from(l.position) - p;
        t_max = norm(d);
        dir = (1.0 / std::max(t_max, 1e-30)) * d;
    }
    double optical_depth = 0;
    IntervalValues values(volumes.size());
    march_segments(volumes, p, dir, t_max, jitter, [&](double t, double delta, const std::vector<std::size_t>& active) {
        V3 q = p + t * dir;
        for (std::size_t i : active) optical_depth += values.depth(volumes[i], i, q, delta);
        return !(optical_depth > 13.8155);
    });
    return std::exp(-optical_depth);
}

}  // namespace

std::vector<VisibilitySample> visibility_samples(const Scene& scene, const Vec3& origin, const Vec3& dir, double jitter,
                                                 double stop_transmittance) {
    std::vector<RefVolume> volumes;
    for (const auto& vi : scene.volumes) volumes.push_back(prepare(vi));
    std::vector<VisibilitySample> out;
    double transmittance = 1;
    V3 o = from(origin), d = unit(from(dir));
    IntervalValues values(volumes.size());
    march_segments(volumes, o, d, INFINITY, jitter, [&](double t, double delta, const std::vector<std::size_t>& active) {
        V3 q = o + t * d;
        double depth = 0;
        for (std::size_t i : active) depth += values.depth(volumes[i], i, q, delta);
        transmittance *= std::exp(-depth);
        if (delta > 0) out.push_back({t, 1 - transmittance});
        return transmittance >= stop_transmittance;
    });
    return out;
}

double segment_optical_depth(const Scene& scene, const Vec3& a, const Vec3& b) {
    V3 o = from(a), d = from(b) - o;
    double length = norm(d);
    if (!(length > 0)) return 0;
    d = (1.0 / length) * d;
    double depth = 0;
    for (const auto& vi : scene.volumes) {
        RefVolume rv = prepare(vi);
        double t0, t1;
        box_span(rv, o, d, 0.0, length, t0, t1);
        if (!(t0 < t1)) continue;
        int steps = std::clamp(int(std::ceil((t1 - t0) / rv.step - 1e-3)), 1, 4096);
        IntervalValues values(1);
        values.depth(rv, 0, o + t0 * d, 0.0);  // the value at the entry
        for (int s = 1; s <= steps; ++s) {
            double t = s == steps ? t1 : t0 + s * (t1 - t0) / steps;
            depth += values.depth(rv, 0, o + t * d, (t1 - t0) / steps);
        }
    }
    return depth;
}

double extinction_at_point(const Scene& scene, const Vec3& p) {
    double sigma = 0;
    for (const auto& vi : scene.volumes) {
        RefVolume rv = prepare(vi);
        V3 q = rv.world_to_voxel.point(from(p));
        bool inside = true;
        for (int a = 0; a < 3; ++a)
            inside = inside && q[a] >= -0.5 && q[a] <= vi.volume->dims[a] - 0.5 && p[a] >= vi.clip_min[a] && p[a] <= vi.clip_max[a];
        if (inside) sigma += extinction(vi.transfer_function, sample_trilinear(*vi.volume, q[0], q[1], q[2]), rv.opacity_unit);
    }
    return sigma;
}

double sample_trilinear(const Volume& v, double x, double y, double z) {
    double p[3] = {std::clamp(x, 0.0, v.dims[0] - 1.0), std::clamp(y, 0.0, v.dims[1] - 1.0), std::clamp(z, 0.0, v.dims[2] - 1.0)};
    int i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        i0[a] = int(std::floor(p[a]));
        i1[a] = std::min(i0[a] + 1, v.dims[a] - 1);
        f[a] = p[a] - i0[a];
    }
    double result = 0;
    for (int c = 0; c < 8; ++c) {
        int ix = c & 1 ? i1[0] : i0[0], iy = c & 2 ? i1[1] : i0[1], iz = c & 4 ? i1[2] : i0[2];
        double w = (c & 1 ? f[0] : 1 - f[0]) * (c & 2 ? f[1] : 1 - f[1]) * (c & 4 ? f[2] : 1 - f[2]);
        result += w * v.at(ix, iy, iz);
    }
    return result;
}

Image render_reference(const Scene& scene, int width, int height, const ReferenceOptions& options) {
    std::vector<RefVolume> volumes;
    for (const auto& vi : scene.volumes) volumes.push_back(prepare(vi));
    const Camera& cam = scene.camera;
    V3 eye = from(cam.position), forward = unit(from(cam.look_at) - eye);
    V3 right = unit(cross(forward, from(cam.up))), up = cross(right, forward);
    double tan_half = std::tan(0.5 * cam.fov_y_deg * M_PI / 180.0), aspect = double(width) / height;

    Image image;
    image.width = width, image.height = height;
    image.rgba.resize(std::size_t(width) * height * 4);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            double sx = ((x + 0.5) / width) * 2 - 1, sy = 1 - ((y + 0.5) / height) * 2;
            V3 dir = unit(forward + (sx * tan_half * aspect) * right + (sy * tan_half) * up);
            double jitter = sombra_pixel_jitter(std::uint32_t(x), std::uint32_t(y), options.jitter_seed);
            V3 radiance{0, 0, 0};
            double transmittance = 1;
            IntervalValues values(volumes.size());
            march_segments(volumes, eye, dir, INFINITY, jitter, [&](double t, double delta, const std::vector<std::size_t>& active) {
                V3 p = eye + t * dir;
                V3 p_light = eye + (t - 0.5 * delta) * dir;  // the light term at the interval's midpoint (cl/render.cl)
                double sigma_sum = 0;
                V3 color_sum{0, 0, 0};
                std::vector<double> shadow;  // transmittance to each light, once per sample
                for (std::size_t i : active) {
                    const VolumeInstance& vi = *volumes[i].instance;
                    V3 pv = volumes[i].world_to_voxel.point(p);
                    double value = 0;
                    double sigma = values.sigma(volumes[i], i, p, delta, &value);
                    if (sigma <= 0 || delta <= 0) continue;
                    auto c = vi.transfer_function.color(float(value));
                    V3 normal{0, 0, 0};
                    if (!scene.lights.empty()) {
                        V3 g = gradient(*vi.volume, pv, options.sobel);
                        double range = vi.transfer_function.domain_max() - vi.transfer_function.domain_min();
                        if (norm(g) * (range > 0 ? 1023.0 / range : 0.0) >= 1e-3) {
                            const auto& m = volumes[i].world_to_voxel.m;  // g_world = Jᵀ g_voxel
                            V3 gw{m[0][0] * g[0] + m[1][0] * g[1] + m[2][0] * g[2], m[0][1] * g[0] + m[1][1] * g[1] + m[2][1] * g[2],
                                  m[0][2] * g[0] + m[1][2] * g[1] + m[2][2] * g[2]};
                            normal = -1.0 * unit(gw);
                        }
                    }
                    if (shadow.empty())
                        for (const Light& l : scene.lights)
                            shadow.push_back(options.shadow_rays ? shadow_ray_transmittance(volumes, l, p_light, jitter) : 1.0);
                    V3 shaded = shade(scene, vi.material, {c[0], c[1], c[2]}, p_light, normal, -1.0 * dir, shadow);
                    sigma_sum += sigma;
                    color_sum = color_sum + sigma * shaded;
                }
                if (sigma_sum > 0) {  // Knecht Eq. 3.10–3.11 with α = 1 − exp(−Σσ̄ Δ) over the interval
                    double alpha = 1 - std::exp(-sigma_sum * delta);
                    radiance = radiance + (alpha * transmittance / sigma_sum) * color_sum;
                    transmittance *= 1 - alpha;
                }
                return transmittance > options.termination_transmittance;
            });
            float* px = &image.rgba[(std::size_t(y) * width + x) * 4];
            for (int c = 0; c < 3; ++c) px[c] = float(radiance[c] + transmittance * scene.background[c]);
            px[3] = float(1 - transmittance);
        }
    return image;
}

}  // namespace sombra::reference
