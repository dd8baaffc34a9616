// sombra tests — low-pass filtered shadows (Ament et al. 2014): the light-aligned summed-area
// tables built by cl/sat_build.cl and the filtered optical depth of cl/lowpass.h against the CPU
// reference (tests/reference/sat_ref.h), precision, analytic media, shadow rays, extreme cases.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>

#include "reference/sat_ref.h"
#include "geometry/scene_upload.h"
#include "shadows/sat_grid.h"
#include "test_support.h"

using namespace sombra;
using D3 = shadows::D3;

namespace {

struct BuiltSat {
    packing::PackedScene packed;
    packing::DeviceScene device;
    shadows::DeviceSat sat;
};

BuiltSat build(const Scene& scene, std::size_t max_entries = std::size_t(1) << 24, int lanes = 0, double coarsen_across = 1) {
    auto& rt = test::context().runtime();
    BuiltSat b;
    b.packed = packing::pack_scene(scene);
    b.device = packing::upload_scene(rt, scene, b.packed, false);
    b.sat = shadows::build_light_sats(rt, scene, b.packed, b.device, max_entries, lanes, coarsen_across);
    return b;
}

Light directional(const D3& direction) {
    Light l;
    l.direction = {float(direction[0]), float(direction[1]), float(direction[2])};
    return l;
}

// One volume of n³ voxels scaled to the world box [−0.5, 0.5]³ (rotated by `rotate_deg`).
Scene one_volume(std::shared_ptr<const Volume> volume, const TransferFunction& tf, std::vector<Light> lights,
                 const Vec3& rotate_deg = {0, 0, 0}) {
    Scene s;
    VolumeInstance vi;
    float scale = 1.f / float(volume->dims[0]);
    vi.volume = std::move(volume);
    vi.transfer_function = tf;
    vi.transform = make_transform({0, 0, 0}, rotate_deg, {scale, scale, scale});
    s.volumes.push_back(vi);
    s.lights = std::move(lights);
    s.width = s.height = 32;
    return s;
}

std::vector<Vec3> random_points(int count, float half, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-half, half);
    std::vector<Vec3> points;
    for (int i = 0; i < count; ++i) points.push_back({u(rng), u(rng), u(rng)});
    return points;
}

// The lookups' arithmetic of lowpass() below (SatOptions::precision): the kernel-vs-reference
// tests run once in double and once in float (the path of devices without cl_khr_fp64).
std::string lookup_precision = "auto";

std::vector<double> lowpass(const Scene& scene, int light, const std::vector<Vec3>& points, float filter,
                            const std::string& kernel = "box", ShadowTechnique technique = ShadowTechnique::Lowpass,
                            float cone_deg = 10.f) {
    RenderOptions o;
    o.shadows = technique;
    o.sat.precision = lookup_precision;
    o.sat.cone_angle_deg = cone_deg;
    o.sat.filter_width = filter;
    o.sat.filter_kernel = kernel;
    return shadow_transmittance(test::context(), scene, light, points, o).transmittance;
}

std::vector<double> shadow_rays(const Scene& scene, int light, const std::vector<Vec3>& points) {
    RenderOptions o;
    o.shadows = ShadowTechnique::Rays;
    return shadow_transmittance(test::context(), scene, light, points, o).transmittance;
}

D3 d3(const Vec3& v) { return {v[0], v[1], v[2]}; }

// |T_lowpass − T_shadow rays| of light 0 over the points, mean and max, for W = 1 and W = 9.
struct RayErrors {
    double mean[2] = {0, 0}, worst[2] = {0, 0};
};
RayErrors errors_to_rays(const Scene& scene, const std::vector<Vec3>& points, const std::string& kernel = "box") {
    auto rays = shadow_rays(scene, 0, points);
    RayErrors r;
    float widths[2] = {1.f, 9.f};
    for (int w = 0; w < 2; ++w) {
        auto t = lowpass(scene, 0, points, widths[w], kernel);
        for (std::size_t i = 0; i < points.size(); ++i) {
            REQUIRE(std::isfinite(t[i]));
            double e = std::fabs(t[i] - rays[i]);
            r.mean[w] += e / double(points.size()), r.worst[w] = std::max(r.worst[w], e);
        }
    }
    return r;
}

Scene cloud_scene() {
    return one_volume(std::make_shared<const Volume>(make_cloud_noise(20, 5)), test::ramp_tf(0.1f, 0.6f, 0.6f),
                      {directional({0.3, -0.5, -0.8})}, {20.f, 35.f, 0.f});
}

}  // namespace

TEST_CASE("CSAT: device cells and box sums match the CPU reference on a random volume", "[lowpass]") {
    Scene scene = cloud_scene();
    BuiltSat b = build(scene);
    REQUIRE(b.sat.frames.size() == 1);
    const shadows::SatFrame& frame = b.sat.frames[0];
    auto table = shadows::read_sat(test::context().runtime(), b.sat, b.sat.offsets[0], frame.entries());
    reference::CellGrid device = reference::cells_of_table(table, frame.dims);
    reference::CellGrid ref = reference::sat_cells(scene, frame, shadows::sat_frame_light_axes(b.sat, 0));
    double max_cell = *std::max_element(ref.cells.begin(), ref.cells.end()), worst = 0;
    REQUIRE(max_cell > 0.05);
    for (std::size_t i = 0; i < ref.cells.size(); ++i) worst = std::max(worst, std::fabs(device.cells[i] - ref.cells[i]));
    CHECK(worst <= 2e-3 * max_cell);  // transfer-function table vs direct evaluation
    std::mt19937 rng(3);
    for (int trial = 0; trial < 300; ++trial) {
        std::array<int, 3> lo, hi;
        for (int a = 0; a < 3; ++a) {
            std::uniform_int_distribution<int> pick(0, frame.dims[std::size_t(a)]);
            int x = pick(rng), y = pick(rng);
            lo[std::size_t(a)] = std::min(x, y), hi[std::size_t(a)] = std::max(x, y);
        }
        double sat = double(std::int64_t(reference::sat_box(table, frame.dims, lo, hi))) / SOMBRA_SAT_UNITS_PER_TAU;
        double brute = reference::box_sum(ref, {double(lo[0]), double(lo[1]), double(lo[2])}, {double(hi[0]), double(hi[1]), double(hi[2])});
        double brute_device = reference::box_sum(device, {double(lo[0]), double(lo[1]), double(lo[2])}, {double(hi[0]), double(hi[1]), double(hi[2])});
        CHECK(sat == Approx(brute_device).margin(1e-9));  // integer sums are exact
        CHECK(sat == Approx(brute).epsilon(3e-3).margin(1e-4));
    }
}

TEST_CASE("CSAT and SSAT resamples: packets of 4, 8 and 16 columns build the tables one column per work-item builds", "[lowpass][lanes]") {
    // a directional light (CSAT, oblique: cells cut voxels at every angle) and a point light inside
    // the volume's box (SSAT over the whole sphere); a near-opaque voxel wall exercises the stiff
    // split; grid sides that are not multiples of the packet leave lanes idle
    Scene scene = cloud_scene();
    scene.lights.clear();
    scene.lights.push_back(directional({0.4, -0.7, 0.59}));
    Light point;
    point.type = LightType::Point;
    point.position = {0.05f, -0.1f, 0.02f};
    scene.lights.push_back(point);
    const bool pocl = test::context().device().platform.find("Portable Computing Language") != std::string::npos;
    for (bool stiff : {false, true}) {
        INFO((stiff ? "with" : "without") << " a near-opaque wall");
        if (stiff) scene.volumes[0].transfer_function = test::ramp_tf(0.5f, 0.52f, 0.999f);
        BuiltSat one = build(scene, std::size_t(1) << 18, 1);
        REQUIRE(one.sat.frames.size() == 1);
        REQUIRE(shadows::sat_table_count(one.sat) == 2);
        const std::size_t entries = std::size_t(one.sat.bytes / sizeof(cl_ulong));
        auto all = [&](const BuiltSat& b) { return shadows::read_sat(test::context().runtime(), b.sat, 0, entries); };
        const std::vector<std::uint64_t> reference = all(one);
        REQUIRE(std::count(reference.begin(), reference.end(), std::uint64_t(0)) < std::ptrdiff_t(entries));
        for (int lanes : {4, 8, 16}) {
            INFO(lanes << " lanes");
            BuiltSat packets = build(scene, std::size_t(1) << 18, lanes);
            REQUIRE(packets.sat.bytes == one.sat.bytes);
            const std::vector<std::uint64_t> table = all(packets);
            std::size_t differ = 0;
            std::uint64_t worst = 0;  // |Δ| of the fixed-point sums (a contracted multiply-add may round a cell differently)
            for (std::size_t e = 0; e < entries; ++e)
                if (table[e] != reference[e]) {
                    ++differ;
                    worst = std::max(worst, table[e] > reference[e] ? table[e] - reference[e] : reference[e] - table[e]);
                }
            INFO(differ << " of " << entries << " entries differ, by at most " << worst << " units");
            CHECK(double(worst) / SOMBRA_SAT_UNITS_PER_TAU <= 1e-5);
            if (pocl) CHECK(differ == 0);  // measured: not one bit on PoCL
        }
    }
}

TEST_CASE("CSAT precision: 64-bit fixed point against a double SAT (float32 for comparison)", "[lowpass]") {
    reference::CellGrid grid;
    grid.dims = {128, 128, 128};
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> value(0.0, 0.25);
    for (std::size_t i = 0; i < 128u * 128u * 128u; ++i) grid.cells.push_back(i % 7 == 0 ? 0.0 : value(rng));
    auto exact = reference::build_sat<double>(grid, [](double x) { return x; });
    auto fixed = reference::build_sat<std::uint64_t>(grid, [](double x) { return shadows::sat_fixed_point(x); });
    auto single = reference::build_sat<float>(grid, [](double x) { return float(x); });
    double fixed_max = 0, fixed_mean = 0, float_max = 0, float_mean = 0, bound_violations = 0;
    const int trials = 3000;
    for (int trial = 0; trial < trials; ++trial) {
        std::array<int, 3> lo, hi;
        std::uniform_int_distribution<int> pick(0, 128);
        for (std::size_t a = 0; a < 3; ++a) {
            int x = pick(rng), y = pick(rng);
            lo[a] = std::min(x, y), hi[a] = std::max(x, y);
        }
        double reference = reference::sat_box(exact, grid.dims, lo, hi);
        double cells = double(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        double f = double(std::int64_t(reference::sat_box(fixed, grid.dims, lo, hi))) / SOMBRA_SAT_UNITS_PER_TAU;
        double s = reference::sat_box(single, grid.dims, lo, hi);
        double ef = std::fabs(f - reference), es = std::fabs(s - reference);
        // per cell: rounding to a unit (2^-23) and τ's float rounding (2^-24 relative)
        // (+ the double SAT's own cancellation, ~10⁻¹¹ here)
        if (ef > cells * std::ldexp(1.0, -23) + reference * std::ldexp(1.0, -24) + 1e-8) ++bound_violations;
        fixed_max = std::max(fixed_max, ef), fixed_mean += ef / trials;
        float_max = std::max(float_max, es), float_mean += es / trials;
    }
    std::printf("SAT precision, 128³ random cells, %d boxes, |box − double SAT| max/mean: fixed point %.3g/%.3g, "
                "float32 %.3g/%.3g\n", trials, fixed_max, fixed_mean, float_max, float_mean);
    CHECK(bound_violations == 0);
    CHECK(fixed_max < 1e-3);
    CHECK(fixed_max * 100 < float_max);
}

TEST_CASE("CSAT: the kernel's filtered optical depth matches the CPU reference", "[lowpass]") {
    lookup_precision = GENERATE(as<std::string>{}, "double", "float");
    INFO("lookups in " << lookup_precision);
    Scene scene = cloud_scene();
    BuiltSat b = build(scene);
    const shadows::SatFrame& frame = b.sat.frames[0];
    reference::CellGrid device = reference::cells_of_table(shadows::read_sat(test::context().runtime(), b.sat, b.sat.offsets[0], frame.entries()), frame.dims);
    reference::CellGrid ref = reference::sat_cells(scene, frame, shadows::sat_frame_light_axes(b.sat, 0));
    auto points = random_points(300, 0.6f, 5);
    for (int width : {1, 3, 6}) {
        auto t = lowpass(scene, 0, points, float(width));
        for (std::size_t i = 0; i < points.size(); ++i) {
            INFO("W " << width << " point " << i);
            double own = reference::filtered_depth(device, frame, 2, true, width, d3(points[i]));
            double direct = reference::filtered_depth(ref, frame, 2, true, width, d3(points[i]));
            CHECK(t[i] == Approx(std::exp(-own)).margin(2e-5));
            CHECK(t[i] == Approx(std::exp(-direct)).margin(2e-3));
        }
    }
}

TEST_CASE("CSAT: a one-voxel filter approaches the shadow rays, wider filters depart", "[lowpass]") {
    Scene scene = one_volume(std::make_shared<const Volume>(make_gaussian_blobs(32, 6, 4)), test::ramp_tf(0.1f, 0.8f, 0.3f),
                             {directional({-0.4, -0.7, -0.5})});
    auto points = random_points(400, 0.4f, 9);
    RayErrors e = errors_to_rays(scene, points);
    std::printf("CSAT vs shadow rays, |ΔT| mean/max: W=1 %.4f/%.4f, W=9 %.4f/%.4f\n", e.mean[0], e.worst[0], e.mean[1], e.worst[1]);
    CHECK(e.mean[0] < 0.01);
    CHECK(e.worst[0] < 0.06);
    CHECK(e.mean[0] < e.mean[1]);
}

TEST_CASE("CSAT: homogeneous medium against exp(−σ·d), oblique and axis-aligned lights", "[lowpass]") {
    const int n = 32;
    const float alpha = 0.04f;
    double sigma = -std::log(1.0 - alpha) * n;  // per world unit: opacity_unit = one voxel = 1/n
    auto volume = test::constant_volume({n, n, n}, 1.f);
    for (D3 dir : {D3{-0.3, -0.5, -0.8}, D3{0, 0, -1}, D3{1, 0, 0}, D3{0, -1, 0}}) {
        Scene scene = one_volume(volume, test::constant_tf(alpha), {directional(dir)});
        double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        D3 toward = {-dir[0] / len, -dir[1] / len, -dir[2] / len};
        shadows::SatFrame frame = shadows::make_csat_frame(packing::pack_scene(scene), toward, std::size_t(1) << 24);
        auto chord = [&](const D3& p) {  // to the box face [−0.5, 0.5]³ towards the light
            double d = INFINITY;
            for (std::size_t a = 0; a < 3; ++a)
                if (toward[a] != 0) d = std::min(d, ((toward[a] > 0 ? 0.5 : -0.5) - p[a]) / toward[a]);
            return std::max(d, 0.0);
        };
        bool axis = std::fabs(std::fabs(toward[0]) + std::fabs(toward[1]) + std::fabs(toward[2]) - 1) < 1e-9;
        auto points = random_points(150, 0.3f, 2);
        for (int width : {1, 5}) {
            auto t = lowpass(scene, 0, points, float(width));
            for (std::size_t i = 0; i < points.size(); ++i) {
                // Ament Eq. 4 with the exact τ of 16 × 16 sub-rays over the W × W patch across l
                double expected = 0, w = double(width) / n;
                for (int a = 0; a < 16; ++a)
                    for (int b = 0; b < 16; ++b) {
                        double u = ((a + 0.5) / 16 - 0.5) * (width > 1 ? w : 0), v = ((b + 0.5) / 16 - 0.5) * (width > 1 ? w : 0);
                        D3 p;
                        for (std::size_t r = 0; r < 3; ++r) p[r] = points[i][r] + u * frame.axes[0][r] + v * frame.axes[1][r];
                        expected += sigma * chord(p) / 256;
                    }
                INFO("direction " << dir[0] << "," << dir[1] << "," << dir[2] << " W " << width << " point " << i);
                // axis-aligned: the cells are the voxels; oblique: the cells' staircase boundary
                CHECK(-std::log(t[i]) == Approx(expected).epsilon(axis ? 1e-4 : 0.03).margin(axis ? 1e-4 : 1.5 * sigma / n));
            }
        }
    }
}

// A cone's axis from p (unit vector towards the light) and its reach (distance to a point light,
// +∞ for a directional one), as cl/techniques/cone.h takes them.
std::pair<D3, double> cone_axis(const Light& l, const D3& p) {
    D3 towards = {-l.direction[0], -l.direction[1], -l.direction[2]};
    double reach = INFINITY;
    if (l.type == LightType::Point) {
        towards = {l.position[0] - p[0], l.position[1] - p[1], l.position[2] - p[2]};
        reach = std::sqrt(towards[0] * towards[0] + towards[1] * towards[1] + towards[2] * towards[2]);
    }
    double len = std::sqrt(towards[0] * towards[0] + towards[1] * towards[1] + towards[2] * towards[2]);
    for (double& x : towards) x /= len;
    return {towards, reach};
}

// n³ voxels, non-zero (0.5 to 1 in a pattern of 5 levels) only in [12, 28)³.
std::shared_ptr<const Volume> blob_in_box(int n) {
    Volume blob;
    blob.dims = {n, n, n};
    blob.voxels.assign(blob.voxel_count(), 0.f);
    for (int z = 12; z < 28; ++z)
        for (int y = 12; y < 28; ++y)
            for (int x = 12; x < 28; ++x) blob.voxels[std::size_t(x + n * (y + n * z))] = 0.5f + 0.5f * float((x * 7 + y * 3 + z) % 5) / 4.f;
    blob.source = "blob";
    blob.update_range();
    return std::make_shared<const Volume>(std::move(blob));
}

TEST_CASE("low-pass tables span the occupied bricks: a blob in an empty box, points all around it", "[lowpass]") {
    // 40³ voxels, non-zero only in [12, 28)³: the CSAT and SSAT cover the blob's bricks, not the
    // box, and points outside the tables (beside, before, behind the blob) read the same depths as
    // the shadow rays do (W = 1, the test above)
    const int n = 40;
    auto volume = blob_in_box(n);
    Light point;
    point.type = LightType::Point;
    point.position = {0.9f, 0.7f, 0.8f};
    for (const Light& light : {directional({-0.4, -0.7, -0.5}), directional({0, 0, -1}), point}) {
        Scene scene = one_volume(volume, test::ramp_tf(0.2f, 0.6f, 0.3f), {light});
        packing::PackedScene packed = packing::pack_scene(scene);
        double voxel = 0;
        auto whole = shadows::scene_corners(packed, voxel), occupied = shadows::occupied_corners(packed, voxel);
        REQUIRE(occupied.size() == 8);
        // bricks 2..6 of 10 (brick b: voxels [4b, 4b + 4]; voxel 12 is brick 2's too): voxels
        // [7.5, 28.5], the volume's centre 19.5 at the origin
        D3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
        for (const D3& c : occupied)
            for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
        for (std::size_t a = 0; a < 3; ++a) {
            CHECK(lo[a] == Approx((7.5 - 19.5) / n));
            CHECK(hi[a] == Approx((28.5 - 19.5) / n));
        }
        BuiltSat b = build(scene);
        if (light.type == LightType::Directional) {
            REQUIRE(b.sat.frames.size() == 1);
            D3 toward = {-light.direction[0], -light.direction[1], -light.direction[2]};
            double len = std::sqrt(toward[0] * toward[0] + toward[1] * toward[1] + toward[2] * toward[2]);
            for (double& t : toward) t /= len;
            shadows::SatFrame frame = b.sat.frames[0];
            shadows::SatFrame box = shadows::make_sat_frame(whole, voxel, frame.axes, std::size_t(1) << 24);
            CHECK(frame.entries() * 3 < box.entries());
        } else {
            REQUIRE(b.sat.spheres.size() == 1);
            CHECK(shadows::ssat_entries(b.sat.spheres[0]) > 0);
        }
        auto points = random_points(400, 0.48f, 13);
        auto t = lowpass(scene, 0, points, 1.f);
        auto rays = shadow_rays(scene, 0, points);
        // the segment from p towards the light (to infinity for a directional light) against the
        // occupied box grown by two voxels (the W = 1 box and its interpolation): a miss must give T = 1
        auto misses = [&](const Vec3& p) {
            D3 d;
            double t_end = INFINITY;
            if (light.type == LightType::Directional) {
                for (std::size_t a = 0; a < 3; ++a) d[a] = -light.direction[a];
            } else {
                for (std::size_t a = 0; a < 3; ++a) d[a] = light.position[a] - p[a];
                t_end = 1;
            }
            double t0 = 0, t1 = t_end;
            for (std::size_t a = 0; a < 3; ++a) {
                double l = lo[a] - 2.0 / n - p[a], h = hi[a] + 2.0 / n - p[a];
                if (d[a] == 0) {
                    if (l > 0 || h < 0) return true;
                    continue;
                }
                double ta = l / d[a], tb = h / d[a];
                t0 = std::max(t0, std::min(ta, tb)), t1 = std::min(t1, std::max(ta, tb));
            }
            return t0 > t1;
        };
        double mean = 0;
        int outside = 0, unshadowed = 0, far_off = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            REQUIRE(std::isfinite(t[i]));
            double e = std::fabs(t[i] - rays[i]);
            mean += e / double(points.size());
            far_off += e > 0.1 ? 1 : 0;  // the sharp blob's shadow edges: the box filter's own blur
            bool inside = true;
            for (std::size_t a = 0; a < 3; ++a) inside &= points[i][a] > lo[a] && points[i][a] < hi[a];
            outside += inside ? 0 : 1;
            if (misses(points[i])) {
                ++unshadowed;
                INFO("point " << i << " misses the blob: T " << t[i]);
                CHECK(t[i] == 1.0);
            }
        }
        INFO("light type " << int(light.type) << ": |ΔT| mean " << mean << ", " << far_off << " points off by > 0.1, "
             << outside << " outside the tables, " << unshadowed << " out of the blob's shadow");
        CHECK(outside > 300);
        CHECK(unshadowed > 100);
        CHECK(mean < 0.01);
        CHECK(far_off <= 8);
    }
}

TEST_CASE("AO and cone SAT span the occupied bricks: points inside, beside and outside it read the whole box's depths", "[lowpass]") {
    // the blob above: the baselines' volume-aligned SAT covers its bricks (voxels [7.5, 28.5]), not
    // the 40³ box. The whole box's cells lie on the same lattice (cells of one voxel, boundaries at
    // voxel boundaries) and are σ = 0 outside that table, so AO at points in and around the volume
    // and cones from points inside the table read what the whole box's table gives. A cone from a
    // point outside the table starts where its axis enters it (the whole box's march would start
    // at the point): it matches the reference on the table and nearly the whole box's.
    const int n = 40;
    Light point;
    point.type = LightType::Point;
    point.position = {0.9f, 0.7f, 0.8f};
    Scene scene = one_volume(blob_in_box(n), test::ramp_tf(0.2f, 0.6f, 0.3f),
                             {directional({-0.4, -0.7, -0.5}), point});
    auto& rt = test::context().runtime();
    packing::PackedScene packed = packing::pack_scene(scene);
    packing::DeviceScene device_scene = packing::upload_scene(rt, scene, packed, false);
    shadows::DeviceSat sat = shadows::build_volume_sat(rt, scene, packed, device_scene, std::size_t(1) << 24);
    REQUIRE(sat.frames.size() == 1);
    const shadows::SatFrame& fitted = sat.frames[0];
    double voxel = 0;
    std::vector<D3> box_corners = shadows::scene_corners(packed, voxel);
    shadows::SatFrame whole = shadows::make_sat_frame(box_corners, voxel, fitted.axes, std::size_t(1) << 24);
    for (std::size_t a = 0; a < 3; ++a) {
        CHECK(fitted.dims[a] == 21);
        CHECK(whole.dims[a] == n);
    }
    CHECK(fitted.cell_size == Approx(1.0 / n));
    reference::CellGrid cells = reference::sat_cells(scene, whole, shadows::sat_frame_light_axes(sat, 0));
    reference::CellGrid table_cells = reference::sat_cells(scene, fitted, shadows::sat_frame_light_axes(sat, 0));
    auto points = random_points(300, 0.7f, 31);  // the box is [−0.5, 0.5]³; the table [−0.3, 0.225]³
    int outside = 0;
    for (const Vec3& p : points)
        outside += std::fabs(p[0] + 0.0375) > 0.2625 || std::fabs(p[1] + 0.0375) > 0.2625 || std::fabs(p[2] + 0.0375) > 0.2625;
    CHECK(outside > 200);
    for (int width : {1, 5}) {
        auto t = lowpass(scene, 0, points, float(width), "box", ShadowTechnique::Ao);
        for (std::size_t i = 0; i < points.size(); ++i) {
            INFO("AO width " << width << " point " << i);
            CHECK(t[i] == Approx(std::exp(-reference::ambient_depth(cells, whole, width, d3(points[i])))).margin(2e-5));
        }
    }
    int shadowed_outside = 0, outside_cones = 0;
    double box_change = 0, box_change_sum = 0;
    for (int light = 0; light < 2; ++light)
        for (float angle : {3.f, 15.f}) {
            auto t = lowpass(scene, light, points, 1.f, "box", ShadowTechnique::Cone, angle);
            const Light& l = scene.lights[std::size_t(light)];
            for (std::size_t i = 0; i < points.size(); ++i) {
                D3 p = d3(points[i]);
                auto [towards, reach] = cone_axis(l, p);
                double cone_tan = std::tan(angle * M_PI / 180);
                double on_table = std::exp(-reference::cone_depth(table_cells, fitted, cone_tan, p, towards, reach));
                double on_box = std::exp(-reference::cone_depth(cells, whole, cone_tan, p, towards, reach));
                INFO("cone light " << light << " angle " << angle << " point " << i << ": T on the whole box " << on_box);
                CHECK(t[i] == Approx(on_table).margin(1e-4));
                bool in_table = std::fabs(p[0] + 0.0375) < 0.2625 && std::fabs(p[1] + 0.0375) < 0.2625 && std::fabs(p[2] + 0.0375) < 0.2625;
                if (in_table) {
                    CHECK(t[i] == Approx(on_box).margin(1e-4));
                } else {
                    box_change = std::max(box_change, std::fabs(t[i] - on_box)), box_change_sum += std::fabs(t[i] - on_box), ++outside_cones;
                    shadowed_outside += on_box < 0.9;
                }
            }
        }
    CHECK(shadowed_outside > 50);  // cones from outside the table that reach the blob
    // the cubes' positions along the axis shift (they start at the table, not at the point)
    WARN("cones from outside the table against the whole box's march: mean |dT| " << box_change_sum / outside_cones << ", max " << box_change);
    CHECK(box_change_sum / outside_cones < 0.01);
    CHECK(box_change < 0.1);
}

TEST_CASE("CSAT: empty and saturated volumes give finite transmittance in [0, 1]", "[lowpass]") {
    auto points = random_points(100, 0.7f, 4);
    Scene empty = one_volume(test::constant_volume({12, 12, 12}, 0.f), test::constant_tf(0.f), {directional({0.2, -1, -0.3})});
    for (double t : lowpass(empty, 0, points, 3.f)) CHECK(t == 1.0);
    Scene stiff = one_volume(test::constant_volume({12, 12, 12}, 1.f), test::constant_tf(1.f), {directional({0.2, -1, -0.3})});
    auto inner = random_points(50, 0.3f, 6);
    for (float width : {0.f, 1.f, 7.f, 40.f}) {
        for (double t : lowpass(stiff, 0, points, width)) CHECK((std::isfinite(t) && t >= 0.0 && t <= 1.0));
        if (width <= 1.f)  // wider boxes reach past the volume, where σ = 0
            for (double t : lowpass(stiff, 0, inner, width)) CHECK(t < 1e-3);
    }
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    RenderResult r = render(test::context(), stiff, o);
    for (float v : r.image.rgba) REQUIRE(std::isfinite(v));
    CHECK(r.stats.sat_tables == 1);
    o.sat.filter_width = -1.f;
    CHECK_THROWS_WITH(render(test::context(), stiff, o), Catch::Contains("lowpass_filter_width"));
}

TEST_CASE("CSAT: six orthodirectional lights share one table and stay close to separately built ones", "[lowpass]") {
    std::vector<Light> six;
    for (D3 d : {D3{1, 0, 0}, D3{-1, 0, 0}, D3{0, 1, 0}, D3{0, -1, 0}, D3{0, 0, 1}, D3{0, 0, -1}}) six.push_back(directional(d));
    auto volume = std::make_shared<const Volume>(make_cloud_noise(20, 8));
    Scene all = one_volume(volume, test::ramp_tf(0.1f, 0.6f, 0.5f), six);
    BuiltSat shared = build(all);
    CHECK(shared.sat.frames.size() == 1);  // Ament §4.2.2: one CSAT for the six lights
    CHECK(shadows::sat_frame_light_axes(shared.sat, 0) == 7u);  // lights along all three axes
    // A table of one light integrates each cell along that light's axis; the shared one along all
    // three, averaged (cl/sat_build.cl): the same within the cells' anisotropy, not bit for bit.
    auto points = random_points(150, 0.55f, 12);
    double worst = 0, sum = 0;
    int count = 0;
    for (int l = 0; l < 6; ++l) {
        Scene alone = one_volume(volume, test::ramp_tf(0.1f, 0.6f, 0.5f), {six[std::size_t(l)]});
        for (float width : {1.f, 4.f}) {
            auto a = lowpass(all, l, points, width), b = lowpass(alone, 0, points, width);
            for (std::size_t i = 0; i < points.size(); ++i) {
                INFO("light " << l << " W " << width << " point " << i);
                CHECK(std::isfinite(a[i]));
                worst = std::max(worst, std::fabs(a[i] - b[i])), sum += std::fabs(a[i] - b[i]), ++count;
            }
        }
    }
    INFO("shared vs own table |ΔT| mean " << sum / count << " max " << worst);
    CHECK(sum / count < 0.005);
    CHECK(worst < 0.05);
}

namespace {

Light point_light(const D3& position) {
    Light l;
    l.type = LightType::Point;
    l.position = {float(position[0]), float(position[1]), float(position[2])};
    return l;
}

// Σ over random integer boxes of a device table against brute-force sums of the reference cells.
void check_box_sums(const std::vector<std::uint64_t>& table, const reference::CellGrid& ref, unsigned seed) {
    std::mt19937 rng(seed);
    reference::CellGrid device = reference::cells_of_table(table, ref.dims);
    for (int trial = 0; trial < 300; ++trial) {
        std::array<int, 3> lo, hi;
        for (std::size_t a = 0; a < 3; ++a) {
            std::uniform_int_distribution<int> pick(0, ref.dims[a]);
            int x = pick(rng), y = pick(rng);
            lo[a] = std::min(x, y), hi[a] = std::max(x, y);
        }
        std::array<double, 3> flo = {double(lo[0]), double(lo[1]), double(lo[2])}, fhi = {double(hi[0]), double(hi[1]), double(hi[2])};
        double sat = double(std::int64_t(reference::sat_box(table, ref.dims, lo, hi))) / SOMBRA_SAT_UNITS_PER_TAU;
        CHECK(sat == Approx(reference::box_sum(device, flo, fhi)).margin(1e-9));  // integer sums are exact
        CHECK(sat == Approx(reference::box_sum(ref, flo, fhi)).epsilon(3e-3).margin(2e-4));
    }
}

// The largest |device − reference| over a table's cells, against the largest reference cell.
void check_cells(const std::vector<std::uint64_t>& table, const reference::CellGrid& ref) {
    reference::CellGrid device = reference::cells_of_table(table, ref.dims);
    double max_cell = *std::max_element(ref.cells.begin(), ref.cells.end()), worst = 0;
    REQUIRE(max_cell > 0.01);
    for (std::size_t i = 0; i < ref.cells.size(); ++i) worst = std::max(worst, std::fabs(device.cells[i] - ref.cells[i]));
    CHECK(worst <= 5e-3 * max_cell);
}

// Mean |T_lowpass − T_shadow rays| (W = 1) of light 0 over the points, and how many points the
// shadow rays find in a shadow (T < 0.9).
std::pair<double, int> agreement_with_rays(const Scene& scene, const std::vector<Vec3>& points) {
    auto t = lowpass(scene, 0, points, 1.f);
    auto rays = shadow_rays(scene, 0, points);
    double mean = 0;
    int shadowed = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        REQUIRE(std::isfinite(t[i]));
        mean += std::fabs(t[i] - rays[i]) / double(points.size());
        shadowed += rays[i] < 0.9 ? 1 : 0;
    }
    return {mean, shadowed};
}

// Three 16³ clouds, 0.25 wide, at x = −0.6 (A), +0.6 (B) and +0.7 (C, overlapping B).
Scene three_clouds(std::vector<Light> lights) {
    auto cloud = std::make_shared<const Volume>(make_cloud_noise(16, 3));
    Scene scene;
    for (float at : {-0.6f, 0.6f, 0.7f}) {
        VolumeInstance vi;
        vi.volume = cloud;
        vi.transfer_function = test::ramp_tf(0.1f, 0.6f, 0.6f);
        vi.transform = make_transform({at, 0, 0}, {0, 0, 0}, {0.25f / 16, 0.25f / 16, 0.25f / 16});
        scene.volumes.push_back(vi);
    }
    scene.lights = std::move(lights);
    scene.width = scene.height = 32;
    return scene;
}

}  // namespace

TEST_CASE("CSAT per group of volumes: one lattice, a table per group, and the lookups add up", "[lowpass]") {
    // A alone, B and C together: two tables on the lattice of the one frame over all three, which
    // would be mostly the empty gap between them
    Scene scene = three_clouds({directional({0.3, -1.0, 0.2})});
    BuiltSat b = build(scene);
    std::vector<std::size_t> tables = shadows::light_sat_tables(b.sat, 0);
    REQUIRE(tables.size() == 2);
    REQUIRE(b.sat.frames.size() == 2);
    const shadows::SatFrame &first = b.sat.frames[0], &second = b.sat.frames[1];
    CHECK(first.next == 1);
    CHECK(second.next == -1);
    CHECK(first.volume_mask == 1u);
    CHECK(second.volume_mask == 6u);
    CHECK(b.sat.grids.size() == 2);
    CHECK(b.sat.grids[0].next == 1u);
    CHECK(b.sat.grid_frame == std::vector<int>{0, 1});
    packing::PackedScene packed = packing::pack_scene(scene);
    shadows::SatFrame one = shadows::make_shared_csat_frame(packed, {-0.3, 1.0, -0.2}, std::size_t(1) << 24);
    CHECK((first.entries() + second.entries()) * 2 < one.entries());
    for (const shadows::SatFrame* f : {&first, &second}) {
        CHECK(f->cell_size == one.cell_size);
        for (std::size_t a = 0; a < 3; ++a) {  // on the one frame's lattice
            double cells = 0;
            for (std::size_t r = 0; r < 3; ++r) cells += (f->origin[r] - one.origin[r]) * one.axes[a][r] / one.cell_size;
            CHECK(cells == Approx(std::round(cells)).margin(1e-6));
        }
        const std::size_t t = std::size_t(f - &b.sat.frames[0]);
        check_cells(shadows::read_sat(test::context().runtime(), b.sat, b.sat.offsets[t], f->entries()),
                    reference::sat_cells(scene, *f, shadows::sat_frame_light_axes(b.sat, t)));
    }
    // points below the clouds, in the shadows of A and of B + C
    std::vector<Vec3> points;
    std::mt19937 rng(19);
    std::uniform_real_distribution<float> across(0.3f, 1.0f), below(-0.6f, -0.15f), depth(-0.2f, 0.2f);
    for (int i = 0; i < 300; ++i) points.push_back({(i % 2 ? 1 : -1) * across(rng), below(rng), depth(rng)});
    auto [mean, shadowed] = agreement_with_rays(scene, points);
    INFO("|ΔT| mean " << mean << ", " << shadowed << " points in a shadow");
    CHECK(shadowed > 30);
    CHECK(mean < 0.01);
    // --stats names each table's kind and the one light that reads it (grids also holds the
    // light's further tables, which are no lights)
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    scene.width = scene.height = 16;
    RenderStats stats = render(test::context(), scene, o).stats;
    REQUIRE(stats.sat_table_list.size() == 2);
    for (const RenderStats::SatTable& t : stats.sat_table_list) {
        CHECK(t.kind == "CSAT");
        CHECK(t.lights == std::vector<int>{0});
    }
    o.shadows = ShadowTechnique::Ao;
    stats = render(test::context(), scene, o).stats;
    REQUIRE(stats.sat_table_list.size() == 1);
    CHECK(stats.sat_table_list[0].kind == "volume SAT");
}

TEST_CASE("SSAT per group of volumes: apart each its own fitted table, overlapping one, and the lookups add up", "[lowpass]") {
    // three_clouds; the point light just above the gap sees A and B across more than 80° (one
    // table for all would be the whole sphere): A gets its own table, B and C share one, and
    // neither spans the whole sphere
    Scene scene = three_clouds({point_light({0.0, 0.12, 0.02})});
    BuiltSat b = build(scene, std::size_t(1) << 20);
    std::vector<std::size_t> tables = shadows::light_sat_tables(b.sat, 0);
    REQUIRE(tables.size() == 2);
    const SsatGridGpu& first = b.sat.spheres[0];
    REQUIRE(first.next != 0);
    const SsatGridGpu& second = b.sat.spheres[first.next];
    CHECK(second.next == 0);
    CHECK(first.volume_mask == 1u);
    CHECK(second.volume_mask == 6u);
    for (const SsatGridGpu* g : {&first, &second}) {
        CHECK(g->wrap_phi == 0u);
        CHECK(double(g->cell.s[0]) * g->dims.s[0] < M_PI / 2);  // the group's angles, not the sphere
        // device cells against the CPU reference over the table's own volumes
        check_cells(shadows::read_sat(test::context().runtime(), b.sat, g->data_offset, shadows::ssat_entries(*g)),
                    reference::ssat_cells(scene, *g));
    }
    // the lookups sum both tables: points beyond the clouds, in the shadows of A, B and B + C
    std::vector<Vec3> points;
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> beyond(0.75f, 1.2f), height(-0.3f, 0.1f), depth(-0.15f, 0.15f);
    for (int i = 0; i < 300; ++i) points.push_back({(i % 2 ? 1 : -1) * beyond(rng), height(rng), depth(rng)});
    auto [mean, shadowed] = agreement_with_rays(scene, points);
    // 0.020 measured (2026-12-03); one whole-sphere table for all three gave 0.032: its angular
    // cells are a voxel at half the farthest corner's distance, not at each group's
    INFO("|ΔT| mean " << mean << ", " << shadowed << " points in a shadow");
    CHECK(shadowed > 100);
    CHECK(mean < 0.025);
    // --stats lists each table: its kind, light, volumes, cells, memory and build time (0 when kept)
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    scene.width = scene.height = 16;
    Context context(test::device_selector());
    for (bool again : {false, true}) {
        RenderStats stats = render(context, scene, o).stats;
        REQUIRE(stats.sat_table_list.size() == 2);
        unsigned long long bytes = 0;
        for (const RenderStats::SatTable& t : stats.sat_table_list) {
            CHECK(t.kind == "SSAT");
            CHECK(t.lights == std::vector<int>{0});
            CHECK(t.reused == again);
            CHECK((again ? t.build_ms == 0 : t.build_ms > 0));
            CHECK(t.bytes == std::size_t(t.cells[0] + 1) * std::size_t(t.cells[1] + 1) * std::size_t(t.cells[2] + 1) * 8);
            bytes += t.bytes;
        }
        CHECK(bytes == stats.sat_bytes);
        CHECK(stats.sat_table_list[0].volumes == std::vector<std::string>{"volume 0"});
        CHECK(stats.sat_table_list[1].volumes == std::vector<std::string>{"volume 1", "volume 2"});
    }
}

// Light 0's transmittance under low-pass filtering of width W, the cells across the light
// coarsened for patches of cells_across cells (0: cells of the voxel).
std::vector<double> lowpass_cells_across(const Scene& scene, const std::vector<Vec3>& points, float width, float cells_across) {
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    o.sat.filter_width = width;
    o.sat.cells_across_patch = cells_across;
    return shadow_transmittance(test::context(), scene, 0, points, o).transmittance;
}

TEST_CASE("low-pass cells across the light follow a wide filter (--sat-cells-across)", "[lowpass]") {
    const std::size_t cap = std::size_t(1) << 24;
    Scene scene = cloud_scene();  // 20³ voxels, rotated; one oblique directional light
    packing::PackedScene packed = packing::pack_scene(scene);
    const shadows::DeviceSat fine = shadows::plan_light_sats(packed, cap);
    // W ≤ N keeps the voxel cells bit for bit (the tables' keys are equal)
    CHECK(shadows::sat_table_geometry_key(shadows::plan_light_sats(packed, cap, shadows::sat_cell_coarsening(8, 8)), 0) ==
          shadows::sat_table_geometry_key(fine, 0));
    CHECK(shadows::sat_cell_coarsening(24, 0) == 1.0);
    // W = 2N: cells twice as wide across the light, as long along it
    const double coarsening = shadows::sat_cell_coarsening(16, 8);
    REQUIRE(coarsening == 2.0);
    const shadows::DeviceSat coarse = shadows::plan_light_sats(packed, cap, coarsening);
    const std::size_t axis = coarse.grids[0].light_axis;
    const bool positive = coarse.grids[0].light_positive != 0;
    const shadows::SatFrame &f = fine.frames[0], &c = coarse.frames[0];
    for (std::size_t a = 0; a < 3; ++a) CHECK(c.cell(a) == Approx(f.cell(a) * (a == axis ? 1.0 : 2.0)));
    CHECK(c.dims[axis] == f.dims[axis]);
    CHECK(c.entries() * 3 < f.entries());
    CHECK(shadows::sat_table_geometry_key(coarse, 0) != shadows::sat_table_geometry_key(fine, 0));
    // lights along two axes of one frame: each filters across the other's axis, so no coarsening
    Scene two_lights = scene;
    two_lights.lights = {directional({0, 0, -1}), directional({1, 0, 0})};
    const shadows::DeviceSat shared = shadows::plan_light_sats(packing::pack_scene(two_lights), cap, coarsening);
    REQUIRE(shared.frames.size() == 1);
    for (std::size_t a = 0; a < 3; ++a) CHECK(shared.frames[0].cell_scale[a] == 1.0);

    // the coarse table's cells and lookups against the CPU reference over the same cells (the
    // resample of anisotropic cells is exact) and against the box filter over the voxel cells
    BuiltSat b = build(scene, cap, 0, coarsening);
    REQUIRE(b.sat.frames.size() == 1);
    const shadows::SatFrame& built = b.sat.frames[0];
    const reference::CellGrid coarse_ref = reference::sat_cells(scene, built, shadows::sat_frame_light_axes(b.sat, 0));
    check_cells(shadows::read_sat(test::context().runtime(), b.sat, b.sat.offsets[0], built.entries()), coarse_ref);
    const reference::CellGrid fine_ref = reference::sat_cells(scene, f, shadows::sat_frame_light_axes(fine, 0));
    auto points = random_points(300, 0.6f, 5);
    auto t = lowpass_cells_across(scene, points, 16.f, 8.f), t_fine = lowpass_cells_across(scene, points, 16.f, 0.f);
    double mean = 0, worst = 0, depth_mean = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        INFO("point " << i);
        const double ideal = reference::filtered_depth(fine_ref, f, int(axis), positive, 16, d3(points[i]));
        CHECK(t[i] == Approx(std::exp(-reference::filtered_depth(coarse_ref, built, int(axis), positive, 8, d3(points[i])))).margin(2e-3));
        CHECK(t_fine[i] == Approx(std::exp(-ideal)).margin(2e-3));
        mean += std::fabs(t[i] - t_fine[i]) / double(points.size()), worst = std::max(worst, std::fabs(t[i] - t_fine[i]));
        depth_mean += ideal / double(points.size());
    }
    std::printf("CSAT W = 16, cells of 2 voxels across vs 1: |ΔT| mean %.5f max %.5f (mean τ̄ %.3f)\n", mean, worst, depth_mean);
    CHECK(depth_mean > 0.1);  // the points are in a shadow worth measuring
    CHECK(mean < 5e-3);
    CHECK(worst < 0.03);

    // the SSAT of a point light: coarser across, the same along r, lookups close to the fine table's
    Scene point = scene;
    point.lights = {point_light({1.6, 0.5, -0.4})};
    packing::PackedScene point_packed = packing::pack_scene(point);
    const SsatGridGpu fine_sphere = shadows::plan_ssat_tables(point_packed, {1.6, 0.5, -0.4}, cap).front();
    const SsatGridGpu coarse_sphere = shadows::plan_ssat_tables(point_packed, {1.6, 0.5, -0.4}, cap, coarsening).front();
    CHECK(coarse_sphere.cell.s[2] == fine_sphere.cell.s[2]);
    CHECK(coarse_sphere.cell.s[0] > 1.3f * fine_sphere.cell.s[0]);
    CHECK(coarse_sphere.cell.s[1] > 1.3f * fine_sphere.cell.s[1]);
    t = lowpass_cells_across(point, points, 16.f, 8.f), t_fine = lowpass_cells_across(point, points, 16.f, 0.f);
    mean = 0, worst = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
        mean += std::fabs(t[i] - t_fine[i]) / double(points.size()), worst = std::max(worst, std::fabs(t[i] - t_fine[i]));
    std::printf("SSAT W = 16, coarser cells across: |ΔT| mean %.5f max %.5f\n", mean, worst);
    CHECK(mean < 5e-3);
    CHECK(worst < 0.03);

    // SAT ambient occlusion: its cube of W voxels spans at least N cells, every axis coarsened;
    // cone shadows (whose width is their angle) keep voxel cells
    const shadows::DeviceSat volume_fine = shadows::plan_volume_sat(packed, cap);
    const shadows::DeviceSat volume_coarse = shadows::plan_volume_sat(packed, cap, coarsening);
    for (std::size_t a = 0; a < 3; ++a) CHECK(volume_coarse.frames[0].cell(a) == Approx(2.0 * volume_fine.frames[0].cell(a)));
    auto ambient = [&](float cells_across, ShadowTechnique technique, float width = 16.f) {
        RenderOptions o;
        o.shadows = technique;
        o.sat.filter_width = width;
        o.sat.cells_across_patch = cells_across;
        return shadow_transmittance(test::context(), scene, 0, points, o).transmittance;
    };
    t = ambient(8.f, ShadowTechnique::Ao), t_fine = ambient(0.f, ShadowTechnique::Ao);
    mean = 0, worst = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
        mean += std::fabs(t[i] - t_fine[i]) / double(points.size()), worst = std::max(worst, std::fabs(t[i] - t_fine[i]));
    // less than a cube one voxel wider moves it (AO's depth is the cube's mean σ × W/2: larger
    // than the low-pass patch's share of a shadow)
    const std::vector<double> t_wider = ambient(0.f, ShadowTechnique::Ao, 17.f);
    double wider = 0;
    for (std::size_t i = 0; i < points.size(); ++i) wider += std::fabs(t_wider[i] - t_fine[i]) / double(points.size());
    std::printf("AO W = 16, cells of 2 voxels vs 1: |ΔT| mean %.5f max %.5f (W = 17: %.5f)\n", mean, worst, wider);
    CHECK(mean < wider);
    CHECK(mean < 0.01);
    CHECK(worst < 0.03);
    CHECK(ambient(8.f, ShadowTechnique::Cone) == ambient(0.f, ShadowTechnique::Cone));

    // on a kept Context: a W change up to N rebuilds no table, one beyond it rebuilds them
    Context context(test::device_selector());
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    o.width = o.height = 16;
    o.sat.filter_width = 3.f;
    CHECK(render(context, scene, o).stats.sat_tables_built == 1);
    o.sat.filter_width = 8.f;
    RenderStats same_tables = render(context, scene, o).stats;
    CHECK(same_tables.sat_tables_built == 0);
    CHECK(same_tables.sat_tables_reused == 1);
    o.sat.filter_width = 16.f;
    CHECK(render(context, scene, o).stats.sat_tables_built == 1);
}

TEST_CASE("SSAT: device cells and box sums match the CPU reference, light outside and inside", "[lowpass]") {
    for (D3 light : {D3{1.6, 0.5, -0.4}, D3{0.1, -0.05, 0.15}}) {
        Scene scene = one_volume(std::make_shared<const Volume>(make_cloud_noise(16, 3)), test::ramp_tf(0.1f, 0.6f, 0.6f),
                                 {point_light(light)}, {10.f, -20.f, 5.f});
        BuiltSat b = build(scene, std::size_t(1) << 18);
        const SsatGridGpu& g = b.sat.spheres[0];
        REQUIRE(g.dims.s[3] == 1);
        CHECK(g.wrap_phi == (light[0] < 1 ? 1u : 0u));
        auto table = shadows::read_sat(test::context().runtime(), b.sat, g.data_offset, shadows::ssat_entries(g));
        reference::CellGrid ref = reference::ssat_cells(scene, g);
        reference::CellGrid device = reference::cells_of_table(table, ref.dims);
        double max_cell = *std::max_element(ref.cells.begin(), ref.cells.end()), worst = 0;
        REQUIRE(max_cell > 0.01);
        for (std::size_t i = 0; i < ref.cells.size(); ++i) worst = std::max(worst, std::fabs(device.cells[i] - ref.cells[i]));
        INFO("light " << light[0] << "," << light[1] << "," << light[2]);
        CHECK(worst <= 5e-3 * max_cell);
        check_box_sums(table, ref, 7);
    }
}

TEST_CASE("SSAT: homogeneous medium against exp(−σ·d), point light outside, inside and on a face", "[lowpass]") {
    lookup_precision = GENERATE(as<std::string>{}, "double", "float");
    INFO("lookups in " << lookup_precision);
    const int n = 32;
    const float alpha = 0.04f;
    double sigma = -std::log(1.0 - alpha) * n;
    auto volume = test::constant_volume({n, n, n}, 1.f);
    for (D3 light : {D3{1.7, 0.6, 0.9}, D3{0.12, -0.2, 0.05}, D3{0.5, 0.1, -0.1}}) {
        Scene scene = one_volume(volume, test::constant_tf(alpha), {point_light(light)});
        auto points = random_points(150, 0.35f, 3);
        auto t = lowpass(scene, 0, points, 1.f);
        auto rays = shadow_rays(scene, 0, points);
        double mean = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            D3 p = d3(points[i]), d = {light[0] - p[0], light[1] - p[1], light[2] - p[2]};
            double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), chord = len;
            for (std::size_t a = 0; a < 3; ++a)  // from p towards the light, until the box face
                if (d[a] != 0) chord = std::min(chord, ((d[a] > 0 ? 0.5 : -0.5) - p[a]) / (d[a] / len));
            INFO("light " << light[0] << "," << light[1] << "," << light[2] << " point " << i);
            REQUIRE(std::isfinite(t[i]));
            CHECK((t[i] >= 0.0 && t[i] <= 1.0));
            // W = 1 voxel: the pyramid's rays differ from the centre ray by ≤ half a voxel
            CHECK(-std::log(t[i]) == Approx(sigma * chord).epsilon(0.04).margin(2.0 * sigma / n));
            mean += std::fabs(t[i] - rays[i]) / double(points.size());
        }
        CHECK(mean < 0.01);
    }
}

TEST_CASE("SSAT: a one-voxel filter approaches the shadow rays of a point light", "[lowpass]") {
    for (D3 light : {D3{-1.2, 0.8, 0.9}, D3{0.05, 0.1, -0.1}}) {
        Scene scene = one_volume(std::make_shared<const Volume>(make_gaussian_blobs(32, 6, 4)), test::ramp_tf(0.1f, 0.8f, 0.3f),
                                 {point_light(light)});
        auto points = random_points(300, 0.4f, 13);
        RayErrors e = errors_to_rays(scene, points);
        std::printf("SSAT (light %g,%g,%g) vs shadow rays, |ΔT| mean/max: W=1 %.4f/%.4f, W=9 %.4f/%.4f\n", light[0], light[1],
                    light[2], e.mean[0], e.worst[0], e.mean[1], e.worst[1]);
        CHECK(e.mean[0] < 0.01);
        CHECK(e.worst[0] < 0.08);
        CHECK(e.mean[0] < e.mean[1]);
    }
}

TEST_CASE("Gaussian filter (Eq. 25): kernel vs CPU reference, homogeneous medium, closer to shadow rays than the box", "[lowpass]") {
    lookup_precision = GENERATE(as<std::string>{}, "double", "float");
    INFO("lookups in " << lookup_precision);
    Scene scene = cloud_scene();
    BuiltSat b = build(scene);
    const shadows::SatFrame& frame = b.sat.frames[0];
    reference::CellGrid device = reference::cells_of_table(shadows::read_sat(test::context().runtime(), b.sat, b.sat.offsets[0], frame.entries()), frame.dims);
    auto points = random_points(200, 0.6f, 15);
    for (int width : {1, 4, 8}) {  // up to 8: the table built above (a wider W coarsens the cells, --sat-cells-across)
        auto t = lowpass(scene, 0, points, float(width), "gauss");
        for (std::size_t i = 0; i < points.size(); ++i) {
            INFO("W " << width << " point " << i);
            CHECK(t[i] == Approx(std::exp(-reference::gauss_filtered_depth(device, frame, 2, true, width, d3(points[i])))).margin(2e-5));
        }
    }
    // homogeneous cube, light along an axis: every sub-box has the same optical depth
    const int n = 32;
    double sigma = -std::log(1.0 - 0.04) * n;
    auto cube = test::constant_volume({n, n, n}, 1.f);
    auto inner = random_points(100, 0.3f, 16);
    for (Light light : {directional({0, -1, 0}), [] { Light l; l.type = LightType::Point; l.position = {0.1f, 1.5f, -0.2f}; return l; }()}) {
        Scene s = one_volume(cube, test::constant_tf(0.04f), {light});
        auto t = lowpass(s, 0, inner, 5.f, "gauss");
        for (std::size_t i = 0; i < inner.size(); ++i) {
            D3 p = d3(inner[i]);
            double chord = 0.5 - p[1];
            if (light.type == LightType::Point) {  // to the top face y = 0.5, along the ray to the light
                D3 d = {light.position[0] - p[0], light.position[1] - p[1], light.position[2] - p[2]};
                chord = (0.5 - p[1]) * std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / d[1];
            }
            INFO("light type " << int(light.type) << " point " << i);
            CHECK(-std::log(t[i]) == Approx(sigma * chord).epsilon(0.04).margin(2.0 * sigma / n));
        }
    }
    Scene blobs = one_volume(std::make_shared<const Volume>(make_gaussian_blobs(32, 6, 4)), test::ramp_tf(0.1f, 0.8f, 0.3f),
                             {directional({-0.4, -0.7, -0.5})});
    auto many = random_points(300, 0.4f, 9);
    RayErrors box = errors_to_rays(blobs, many), gauss = errors_to_rays(blobs, many, "gauss");
    std::printf("W=9 vs shadow rays, |ΔT| mean: box %.4f, gauss %.4f\n", box.mean[1], gauss.mean[1]);
    CHECK(gauss.mean[1] < box.mean[1]);
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    o.sat.filter_kernel = "tent";
    CHECK_THROWS_WITH(render(test::context(), blobs, o), Catch::Contains("lowpass_filter_kernel"));
}

TEST_CASE("Baselines: SAT ambient occlusion and cone shadows vs CPU reference, homogeneous medium, shadow rays", "[lowpass]") {
    lookup_precision = GENERATE(as<std::string>{}, "double", "float");
    INFO("lookups in " << lookup_precision);
    Scene scene = cloud_scene();
    scene.lights.push_back([] { Light l; l.type = LightType::Point; l.position = {0.9f, 0.7f, -0.4f}; return l; }());
    auto& rt = test::context().runtime();
    packing::PackedScene packed = packing::pack_scene(scene);
    packing::DeviceScene device_scene = packing::upload_scene(rt, scene, packed, false);
    shadows::DeviceSat sat = shadows::build_volume_sat(rt, scene, packed, device_scene, std::size_t(1) << 24);
    const shadows::SatFrame& frame = sat.frames[0];
    reference::CellGrid cells = reference::cells_of_table(shadows::read_sat(rt, sat, 0, frame.entries()), frame.dims);
    auto points = random_points(150, 0.6f, 21);
    for (int width : {1, 4}) {
        auto t = lowpass(scene, 0, points, float(width), "box", ShadowTechnique::Ao);
        for (std::size_t i = 0; i < points.size(); ++i)
            CHECK(t[i] == Approx(std::exp(-reference::ambient_depth(cells, frame, width, d3(points[i])))).margin(2e-5));
    }
    double snapped_change = 0, snapped_sum = 0;  // the largest and the summed |ΔT| the snapped cubes make
    int snapped_count = 0;
    for (int light = 0; light < 2; ++light)
        for (float angle : {3.f, 15.f}) {
            auto t = lowpass(scene, light, points, 1.f, "box", ShadowTechnique::Cone, angle);
            for (std::size_t i = 0; i < points.size(); ++i) {
                D3 p = d3(points[i]);
                auto [towards, reach] = cone_axis(scene.lights[std::size_t(light)], p);
                INFO("light " << light << " angle " << angle << " point " << i);
                double expected = reference::cone_depth(cells, frame, std::tan(angle * M_PI / 180), p, towards, reach);
                CHECK(t[i] == Approx(std::exp(-expected)).margin(1e-4));
                // what snapping the cubes changes (the reference with every cube exact)
                double exact = reference::cone_depth(cells, frame, std::tan(angle * M_PI / 180), p, towards, reach, INFINITY);
                double change = std::abs(std::exp(-expected) - std::exp(-exact));
                snapped_change = std::max(snapped_change, change), snapped_sum += change, ++snapped_count;
            }
        }
    // Snapping cubes of radius ≥ 2 cells moves T on this 20³ noise cloud (features of a cell or two,
    // the worst case for it) by 0.0011 on average, at most 0.060 (docs/lowpass.md); the shipped
    // scenes' images moved by 1e-4 RMS. A wrong snapped box (its volume, its faces) moves it far more.
    WARN("snapped cubes: mean |dT| " << snapped_sum / snapped_count << ", max " << snapped_change);
    CHECK(snapped_change > 0);  // the snapped path ran (a cube of radius ≥ 2 cells met the cloud)
    CHECK(snapped_change < 0.1);
    CHECK(snapped_sum / snapped_count < 0.01);
    // homogeneous cube: AO inside is exp(−σ·W/2 voxels); a narrow cone along an axis is exp(−σ·d)
    const int n = 32;
    double sigma = -std::log(1.0 - 0.04) * n;
    Scene cube = one_volume(test::constant_volume({n, n, n}, 1.f), test::constant_tf(0.04f), {directional({0, 0, -1})});
    auto inner = random_points(100, 0.3f, 22);
    for (double t : lowpass(cube, 0, inner, 6.f, "box", ShadowTechnique::Ao)) CHECK(t == Approx(std::exp(-sigma * 3.0 / n)).epsilon(1e-4));
    auto cone = lowpass(cube, 0, inner, 1.f, "box", ShadowTechnique::Cone, 2.f);
    for (std::size_t i = 0; i < inner.size(); ++i)
        CHECK(-std::log(cone[i]) == Approx(sigma * (0.5 - inner[i][2])).epsilon(0.05).margin(1.0 * sigma / n));
    Scene empty = one_volume(test::constant_volume({8, 8, 8}, 0.f), test::constant_tf(0.f), {directional({0.3, -1, 0.2})});
    for (auto technique : {ShadowTechnique::Ao, ShadowTechnique::Cone})
        for (double t : lowpass(empty, 0, inner, 3.f, "box", technique)) CHECK(t == 1.0);
}

TEST_CASE("low-pass tables follow a moved light on a kept Context", "[lowpass]") {
    Context context(test::device_selector()), fresh_context(test::device_selector());  // their own kept state
    Scene scene = cloud_scene();
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    auto points = random_points(200, 0.4f, 3);
    auto before = shadow_transmittance(context, scene, 0, points, o).transmittance;
    scene.lights[0].direction = {-0.6f, -0.5f, 0.3f};
    auto moved = shadow_transmittance(context, scene, 0, points, o).transmittance;
    auto fresh = shadow_transmittance(fresh_context, scene, 0, points, o).transmittance;
    double changed = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        CHECK(moved[i] == fresh[i]);
        changed = std::max(changed, std::fabs(double(moved[i]) - before[i]));
    }
    CHECK(changed > 0.05);
}

TEST_CASE("shadow cache (Ament Alg. 1): close to per-sample evaluation, kept while tables, filter and lights stay", "[lowpass]") {
    Context context(test::device_selector());  // its own kept state
    Scene scene = cloud_scene();
    RenderOptions o;
    o.shadows = ShadowTechnique::Lowpass;
    o.width = o.height = 40;
    o.sat.filter_width = 5.f;
    o.shadow_cache_fill = ShadowCacheFill::All;  // a moved camera then fills nothing (the visible fill tops up)
    for (ShadowTechnique technique : {ShadowTechnique::Lowpass, ShadowTechnique::Ao}) {
        o.shadows = technique;
        o.shadow_cache = ShadowCacheMode::Off;
        Image direct = render(context, scene, o).image;
        o.shadow_cache = ShadowCacheMode::On;
        RenderResult cached = render(context, scene, o);
        CHECK(cached.stats.stage_ms.count("shadow_cache") == 1);
        CHECK(cached.stats.shadow_cache_bytes > 0);
        test::ImageDifference d = test::compare(direct, cached.image);
        INFO("technique " << int(technique) << ": cached vs per-sample mean " << d.mean_abs << " max " << d.max_abs);
        CHECK(d.mean_abs < 2e-3);
        CHECK(d.max_abs < 0.05);
    }
    scene.camera.position = {0.4f, 0.3f, 2.6f};  // the camera moves: the cache stays
    CHECK(render(context, scene, o).stats.stage_ms.count("shadow_cache") == 0);
    o.sat.filter_width = 9.f;  // the filter changes: the cache is rebuilt, the tables are not
    RenderResult wider = render(context, scene, o);
    CHECK(wider.stats.stage_ms.count("shadow_cache") == 1);
    CHECK(wider.stats.reused_preparation);
}

// Devices without cl_khr_fp64 (many GPUs) run the lookups in float (cl/lowpass.h, SatOptions::
// precision): the box sums stay exact integers, so only the positions and weights lose digits.
// Property: every technique and kernel, directional and point lights (outside, inside, on a face),
// over random clouds and the stiff cases (a near-opaque cube, a one-voxel near-opaque wall, an
// empty volume), float agrees with double to 2e-5 in T and is finite in [0, 1].
TEST_CASE("low-pass family: float lookups (no fp64) agree with double on random clouds and stiff media", "[lowpass]") {
    std::vector<std::pair<std::string, Scene>> cases;
    std::vector<Light> lights = {directional({0.3, -0.5, -0.8}), directional({0, 0, -1}), point_light({1.4, 0.6, -0.3}),
                                 point_light({0.05, -0.1, 0.1}), point_light({0.5, 0.1, -0.1})};
    for (unsigned seed : {1u, 2u, 3u})
        cases.push_back({"cloud " + std::to_string(seed),
                         one_volume(std::make_shared<const Volume>(make_cloud_noise(20, seed)), test::ramp_tf(0.1f, 0.6f, 0.6f), lights,
                                    {float(seed * 17), float(seed * 29), 0.f})});
    cases.push_back({"near-opaque cube", one_volume(test::constant_volume({16, 16, 16}, 1.f), test::constant_tf(0.999f), lights)});
    cases.push_back({"empty", one_volume(test::constant_volume({8, 8, 8}, 0.f), test::constant_tf(0.f), lights)});
    {
        const int n = 24;
        Volume wall;
        wall.dims = {n, n, n};
        wall.voxels.assign(wall.voxel_count(), 0.f);
        for (int z = 0; z < n; ++z)
            for (int y = 0; y < n; ++y) wall.voxels[std::size_t((z * n + y) * n + n / 2)] = 1.f;
        wall.update_range();
        cases.push_back({"one-voxel wall", one_volume(std::make_shared<const Volume>(std::move(wall)), test::ramp_tf(0.f, 1.f, 0.999f), lights)});
    }
    auto points = random_points(120, 0.55f, 31);
    struct Variant {
        ShadowTechnique technique;
        const char* kernel;
        float width;
    };
    const Variant variants[] = {{ShadowTechnique::Lowpass, "box", 1.f}, {ShadowTechnique::Lowpass, "box", 7.f},
                                {ShadowTechnique::Lowpass, "gauss", 4.f}, {ShadowTechnique::Ao, "box", 5.f},
                                {ShadowTechnique::Cone, "box", 1.f}};
    double worst = 0;
    for (auto& [name, scene] : cases)
        for (const Variant& v : variants)
            for (int light = 0; light < int(lights.size()); ++light) {
                if (v.technique == ShadowTechnique::Ao && light > 0) continue;  // the same term for every light
                std::vector<double> t[2];
                for (int p = 0; p < 2; ++p) {
                    lookup_precision = p ? "float" : "double";
                    t[p] = lowpass(scene, light, points, v.width, v.kernel, v.technique);
                }
                lookup_precision = "auto";
                for (std::size_t i = 0; i < points.size(); ++i) {
                    INFO(name << ", " << shadow_technique_name(v.technique) << " " << v.kernel << " W " << v.width << ", light " << light
                              << ", point " << i << ": double " << t[0][i] << ", float " << t[1][i]);
                    REQUIRE(std::isfinite(t[1][i]));
                    CHECK((t[1][i] >= 0.0 && t[1][i] <= 1.0));
                    CHECK(std::fabs(t[1][i] - t[0][i]) <= 2e-5);
                    worst = std::max(worst, std::fabs(t[1][i] - t[0][i]));
                }
            }
    std::printf("low-pass family, float vs double lookups: max |ΔT| %.2e over %zu cases\n", worst, cases.size());
}
