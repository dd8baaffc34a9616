// Deep shadow maps: generation against a CPU reference, transmittance against the brute-force
// reference for every light type, ε extremes, stiff cases, deep EXR export.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "reference/raycaster_ref.h"
#include "render/scene_upload.h"
#include "shadows/dsm_views.h"
#include "shared/hash.h"
#include "test_support.h"

using namespace sombra;

namespace {

// A smooth, smoke-like volume lit by one light of the given type.
Scene smoke_scene(LightType type) {
    Scene s;
    VolumeInstance vi;
    vi.volume = std::make_shared<const Volume>(make_gaussian_blobs(24, 6, 5));
    vi.transfer_function = test::ramp_tf(0.05f, 0.9f, 0.25f);
    vi.transform = make_transform({0, 0, 0}, {10.f, 20.f, 0.f}, {1.f / 24, 1.f / 24, 1.f / 24});
    s.volumes.push_back(vi);
    Light l;
    l.type = type;
    l.position = {0.3f, 1.2f, 0.4f};
    l.direction = {-0.3f, -1.2f, -0.4f};
    l.cone_angle_deg = 40.f;
    s.lights.push_back(l);
    s.width = s.height = 32;
    return s;
}

std::vector<Vec3> random_points(int n, float half, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-half, half);
    std::vector<Vec3> p(static_cast<std::size_t>(n));
    for (auto& q : p) q = {u(rng), u(rng), u(rng)};
    return p;
}

struct Errors {
    double mean = 0, max = 0;
    std::size_t non_finite = 0;
};

Errors against_reference(const Scene& s, const std::vector<Vec3>& points, const std::vector<double>& values) {
    Errors e;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!std::isfinite(values[i]) || values[i] < 0 || values[i] > 1) ++e.non_finite;
        double d = std::fabs(values[i] - reference_transmittance(s, 0, points[i]));
        e.mean += d, e.max = std::max(e.max, d);
    }
    e.mean /= double(points.size());
    return e;
}

RenderOptions dsm_options(int resolution, float epsilon) {
    RenderOptions o;
    o.shadows = ShadowTechnique::Dsm;
    o.dsm_resolution = resolution;
    o.dsm_epsilon = epsilon;
    return o;
}

}  // namespace

TEST_CASE("DSM and shadow-ray transmittance against the brute-force reference, every light type", "[dsm]") {
    auto points = random_points(400, 0.45f, 17);
    for (LightType type : {LightType::Directional, LightType::Spot, LightType::Point}) {
        Scene s = smoke_scene(type);
        RenderOptions rays;
        rays.shadows = ShadowTechnique::Rays;
        Errors r = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, rays).transmittance);
        Errors d = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, dsm_options(128, 0.01f)).transmittance);
        INFO("light type " << int(type) << ": shadow rays mean " << r.mean << " max " << r.max << "; DSM mean " << d.mean
                           << " max " << d.max);
        CHECK(r.non_finite == 0);
        CHECK(d.non_finite == 0);
        // measured: shadow rays mean 1.2e-3, max 0.021; DSM (128², ε 0.01) mean 2.7e-3, max 0.029
        CHECK(r.mean < 5e-3);
        CHECK(r.max < 0.05);
        CHECK(d.mean < 0.01);
        CHECK(d.max < 0.06);
    }
}

namespace {

// V'(z) of one texel (Knecht Eq. 3.7), clamped like the kernel's lookup.
double texel_opacity(const DeepShadowMap& map, std::size_t texel, double z) {
    std::uint32_t begin = map.first[texel], end = map.first[texel + 1];
    if (begin == end || z < map.nodes[begin].depth) return 0;
    if (z >= map.nodes[end - 1].depth) return std::clamp<double>(map.nodes[end - 1].opacity, 0, 1);
    std::uint32_t i = begin;
    while (map.nodes[i + 1].depth <= z) ++i;
    const DsmNode &a = map.nodes[i], &b = map.nodes[i + 1];
    double f = b.depth > a.depth ? (z - a.depth) / (b.depth - a.depth) : 1;
    return std::clamp(a.opacity + f * (b.opacity - a.opacity), 0.0, 1.0);
}

}  // namespace

TEST_CASE("DSM generation kernel against the CPU reference: |V' − V| ≤ ε at every sample", "[dsm]") {
    for (LightType type : {LightType::Directional, LightType::Spot}) {
        Scene s = smoke_scene(type);
        const int res = 24;
        for (float epsilon : {0.f, 0.01f, 0.05f}) {
            auto maps = build_deep_shadow_maps(test::context(), s, 0, dsm_options(res, epsilon));
            REQUIRE(maps.size() == 1);
            packing::PackedScene packed = packing::pack_scene(s);
            DsmViewGpu v = shadows::make_dsm_views(s, packed, res)[0];
            double worst = 0;
            std::size_t samples = 0, nodes = 0;
            for (int y = 0; y < res; ++y)
                for (int x = 0; x < res; ++x) {
                    float nx = ((x + 0.5f) / res) * 2 - 1, ny = ((y + 0.5f) / res) * 2 - 1;
                    Vec3 across, origin, dir;
                    for (int k = 0; k < 3; ++k) across[k] = nx * v.extent_x * v.axis_x.s[k] + ny * v.extent_y * v.axis_y.s[k];
                    for (int k = 0; k < 3; ++k) {
                        origin[k] = v.perspective ? v.origin.s[k] : v.origin.s[k] + across[k];
                        dir[k] = v.perspective ? v.axis_z.s[k] + across[k] : v.axis_z.s[k];
                    }
                    auto reference = reference::visibility_samples(s, origin, dir, sombra_pixel_jitter(x, y, 0));
                    std::size_t texel = std::size_t(y) * res + x;
                    for (auto& r : reference) worst = std::max(worst, std::fabs(texel_opacity(maps[0], texel, r.t) - r.alpha));
                    samples += reference.size();
                    nodes += maps[0].first[texel + 1] - maps[0].first[texel];
                }
            INFO("light " << int(type) << ", ε = " << epsilon << ": max |V' − V| " << worst << ", " << nodes << " nodes for "
                          << samples << " samples");
            CHECK(worst <= epsilon + 2e-4);  // float kernel vs double reference
            CHECK(nodes <= samples + res * res);
        }
    }
}
