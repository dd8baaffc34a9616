// Deep shadow maps: generation against a CPU reference, transmittance against the brute-force
// reference for every light type, ε extremes, stiff cases, deep EXR export.
#include <functional>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <sstream>

#include "reference/raycaster_ref.h"
#include "geometry/scene_upload.h"
#include "host/runtime.h"
#include "shadows/dsm_views.h"
#include "shared/hash.h"
#include "shared/prefilter.h"
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
    o.dsm.resolution = resolution;
    o.dsm.epsilon = epsilon;
    return o;
}

// Both sets of maps hold the same views with bit-identical nodes.
void require_same_nodes(const std::vector<DeepShadowMap>& maps, const std::vector<DeepShadowMap>& reference,
                        const std::string& what) {
    REQUIRE(maps.size() == reference.size());
    for (std::size_t v = 0; v < maps.size(); ++v) {
        INFO(what << ", view " << v);
        REQUIRE(maps[v].first == reference[v].first);
        REQUIRE(maps[v].nodes.size() == reference[v].nodes.size());
        for (std::size_t i = 0; i < maps[v].nodes.size(); ++i) {
            REQUIRE(maps[v].nodes[i].depth == reference[v].nodes[i].depth);
            REQUIRE(maps[v].nodes[i].opacity == reference[v].nodes[i].opacity);
        }
    }
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
        RenderOptions binary = dsm_options(128, 0.01f);
        binary.shadows = ShadowTechnique::ShadowMap;
        Errors m = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, binary).transmittance);
        INFO("light type " << int(type) << ": shadow rays mean " << r.mean << " max " << r.max << "; DSM mean " << d.mean
                           << " max " << d.max << "; binary shadow map mean " << m.mean << " max " << m.max);
        CHECK(m.non_finite == 0);
        CHECK(m.mean > 2 * d.mean);  // semi-transparent media are what binary shadow maps get wrong
        CHECK(r.non_finite == 0);
        CHECK(d.non_finite == 0);
        // measured: shadow rays mean 1.2e-3, max 0.021; DSM (128², ε 0.01) mean 2.7e-3, max 0.029
        CHECK(r.mean < 5e-3);
        CHECK(r.max < 0.05);
        CHECK(d.mean < 0.01);
        CHECK(d.max < 0.06);
    }
}

TEST_CASE("relative DSM bound with every storage, pre-filter and pre-compression: near the reference, never darker by ε", "[dsm]") {
    auto points = random_points(300, 0.45f, 23);
    for (LightType type : {LightType::Spot, LightType::Point}) {
        Scene s = smoke_scene(type);
        RenderOptions absolute = dsm_options(64, 0.01f);
        const Errors a = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, absolute).transmittance);
        struct Variant {
            const char* name;
            std::function<void(RenderOptions&)> set;
        };
        const Variant variants[] = {{"atlas", [](RenderOptions&) {}},
                                    {"chunked", [](RenderOptions& o) { o.dsm.storage = "chunked"; }},
                                    {"compact native", [](RenderOptions& o) { o.dsm.storage = "compact", o.dsm.lookup = "native"; }},
                                    {"box pre-filter", [](RenderOptions& o) { o.dsm.prefilter = "box"; }},
                                    {"pre-compression", [](RenderOptions& o) { o.dsm.precompression = true; }}};
        for (const Variant& v : variants) {
            RenderOptions o = absolute;
            o.dsm.error = "relative";
            v.set(o);
            const Errors r = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, o).transmittance);
            INFO("light type " << int(type) << ", " << v.name << ": relative mean " << r.mean << " max " << r.max
                               << "; absolute (atlas) mean " << a.mean << " max " << a.max);
            CHECK(r.non_finite == 0);
            // measured: relative 0.6–1.1× the absolute bound's mean error at ε 0.01, 64²
            CHECK(r.mean < 1.5 * a.mean + 1e-3);
            CHECK(r.max < 0.08);
        }
    }
}

namespace {

// V'(z) of one texel (Knecht Eq. 3.7), clamped like the kernel's lookup; for maps of optical
// depth (DsmOptions::error "relative") τ = −ln(1 − opacity) is what is linear between nodes.
double texel_opacity(const DeepShadowMap& map, std::size_t texel, double z) {
    std::uint32_t begin = map.first[texel], end = map.first[texel + 1];
    if (begin == end || z < map.nodes[begin].depth) return 0;
    if (z >= map.nodes[end - 1].depth) return std::clamp<double>(map.nodes[end - 1].opacity, 0, 1);
    std::uint32_t i = begin;
    while (map.nodes[i + 1].depth <= z) ++i;
    const DsmNode &a = map.nodes[i], &b = map.nodes[i + 1];
    double f = b.depth > a.depth ? (z - a.depth) / (b.depth - a.depth) : 1;
    if (map.interpolation == DeepShadowMap::Interpolation::OpticalDepth) {
        auto depth_of = [](double opacity) { return -std::log1p(-std::clamp(opacity, 0.0, 1.0 - 1e-12)); };
        return -std::expm1(-(depth_of(a.opacity) + f * (depth_of(b.opacity) - depth_of(a.opacity))));
    }
    return std::clamp(a.opacity + f * (b.opacity - a.opacity), 0.0, 1.0);
}

// The ray through (nx, ny) ∈ [−1, 1]² of a view's image plane (cl/dsm_view.h dsm_view_ray).
void texel_ray(const DsmViewGpu& v, float nx, float ny, Vec3& origin, Vec3& dir) {
    Vec3 across;
    for (int k = 0; k < 3; ++k) across[k] = nx * v.extent_x * v.axis_x.s[k] + ny * v.extent_y * v.axis_y.s[k];
    for (int k = 0; k < 3; ++k) {
        origin[k] = v.perspective ? v.origin.s[k] : v.origin.s[k] + across[k];
        dir[k] = v.perspective ? v.axis_z.s[k] + across[k] : v.axis_z.s[k];
    }
}

}  // namespace

TEST_CASE("DSM generation kernel against the CPU reference: |V' − V| ≤ ε at every sample", "[dsm]") {
    for (const char* bound : {"absolute", "relative"})
    for (LightType type : {LightType::Directional, LightType::Spot}) {
        Scene s = smoke_scene(type);
        const int res = 24;
        const bool relative = std::string(bound) == "relative";
        for (float epsilon : {0.f, 0.01f, 0.05f}) {
            RenderOptions o = dsm_options(res, epsilon);
            o.dsm.error = bound;
            auto maps = build_deep_shadow_maps(test::context(), s, 0, o);
            REQUIRE(maps.size() == 1);
            CHECK((maps[0].interpolation == DeepShadowMap::Interpolation::OpticalDepth) == relative);
            packing::PackedScene packed = packing::pack_scene(s);
            DsmViewGpu v = shadows::make_dsm_views(s, packed, res)[0];
            double worst = 0;
            std::size_t samples = 0, nodes = 0;
            for (int y = 0; y < res; ++y)
                for (int x = 0; x < res; ++x) {
                    Vec3 origin, dir;
                    texel_ray(v, ((x + 0.5f) / res) * 2 - 1, ((y + 0.5f) / res) * 2 - 1, origin, dir);
                    auto reference = reference::visibility_samples(s, origin, dir, sombra_pixel_jitter(x, y, 0));
                    std::size_t texel = std::size_t(y) * res + x;
                    for (auto& r : reference) {
                        // relative: |τ' − τ| ≤ ε where the kernel kept marching (T ≥ its termination 10⁻⁴)
                        const double got = texel_opacity(maps[0], texel, r.t);
                        if (!relative) worst = std::max(worst, std::fabs(got - r.alpha));
                        else if (r.alpha < 1 - 2e-4) worst = std::max(worst, std::fabs(std::log1p(-got) - std::log1p(-double(r.alpha))));
                    }
                    samples += reference.size();
                    nodes += maps[0].first[texel + 1] - maps[0].first[texel];
                }
            INFO(bound << ", light " << int(type) << ", ε = " << epsilon << ": max |V' − V| (relative: |τ' − τ|) " << worst
                       << ", " << nodes << " nodes for " << samples << " samples");
            CHECK(worst <= epsilon + (relative ? 5e-4 : 2e-4));  // float kernel vs double reference
            CHECK(nodes <= samples + res * res);
        }
    }
}

TEST_CASE("DSM: ε ≥ 1 leaves one segment per texel — empty space leaves no node", "[dsm]") {
    Scene s = smoke_scene(LightType::Spot);
    auto maps = build_deep_shadow_maps(test::context(), s, 0, dsm_options(32, 1.f));
    std::size_t empty = 0;
    for (std::size_t t = 0; t + 1 < maps[0].first.size(); ++t) {
        std::uint32_t n = maps[0].first[t + 1] - maps[0].first[t];
        CHECK(n <= 2);
        empty += n == 0;
    }
    CHECK(empty > 0);  // the cone is wider than the volume: rays that miss it store nothing
}

TEST_CASE("DSM and shadow rays stay finite and bounded in stiff and degenerate set-ups", "[dsm][numerics]") {
    struct Case {
        const char* name;
        LightType type;
        Vec3 position, direction;
    };
    const Case cases[] = {
        {"point light inside the volume", LightType::Point, {0.05f, 0.02f, 0.01f}, {0, 0, -1}},
        {"spot light on a box face", LightType::Spot, {0.f, 0.f, 0.5f}, {0, 0, -1}},
        {"directional light along an axis", LightType::Directional, {0, 0, 0}, {0, 0, -1}},
        {"directional light along another axis", LightType::Directional, {0, 0, 0}, {1, 0, 0}},
    };
    auto points = random_points(200, 0.6f, 3);
    for (const Case& c : cases) {
        for (bool stiff : {false, true}) {
            Scene s = smoke_scene(c.type);
            s.volumes[0].transform = make_transform({0, 0, 0}, {0, 0, 0}, {1.f / 24, 1.f / 24, 1.f / 24});
            s.lights[0].position = c.position;
            s.lights[0].direction = c.direction;
            if (stiff) s.volumes[0].opacity_unit = 1e-5f;  // σΔ ≫ 1: one step saturates
            for (ShadowTechnique technique : {ShadowTechnique::Rays, ShadowTechnique::Dsm}) {
                RenderOptions o = dsm_options(48, 0.02f);
                o.shadows = technique;
                auto values = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
                Errors e = against_reference(s, points, values);
                INFO(c.name << (stiff ? ", stiff" : "") << ", " << (technique == ShadowTechnique::Dsm ? "DSM" : "rays")
                            << ": mean error " << e.mean << ", max " << e.max);
                CHECK(e.non_finite == 0);
                // measured (48² DSM): rays ≤ 6e-3; DSM ≤ 9e-3, but 0.08 for a saturating medium
                // lit from its face, where the shadow is a step that 48² bilinear texels blur
                double bound = technique == ShadowTechnique::Rays ? 0.01 : (stiff ? 0.1 : 0.02);
                CHECK(e.mean < bound);
                RenderResult r = render(test::context(), s, o);
                std::size_t bad = 0;
                for (float v : r.image.rgba) bad += !std::isfinite(v);
                CHECK(bad == 0);
            }
        }
    }
}

TEST_CASE("DSM of a one-voxel volume and of a volume the transfer function makes empty", "[dsm][numerics]") {
    Scene s = smoke_scene(LightType::Point);
    s.volumes[0].volume = std::make_shared<const Volume>(make_slab(1, 0, 0.f, 1.f, 1.f));
    s.volumes[0].transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.3f, 0.3f, 0.3f});
    auto maps = build_deep_shadow_maps(test::context(), s, 0, dsm_options(16, 0.01f));
    CHECK(maps.size() == 6);
    std::size_t nodes = 0;
    for (auto& m : maps) nodes += m.nodes.size();
    CHECK(nodes > 0);
    s.volumes[0].transfer_function.opacity_points = {{0.f, 0.f}, {1.f, 0.f}};
    maps = build_deep_shadow_maps(test::context(), s, 0, dsm_options(16, 0.01f));
    nodes = 0;
    for (auto& m : maps) nodes += m.nodes.size();
    CHECK(nodes == 0);
    RenderResult r = render(test::context(), s, dsm_options(16, 0.01f));
    for (float v : r.image.rgba) REQUIRE(std::isfinite(v));
}

TEST_CASE("sombra dsm writes a deep EXR that reads back as the built map", "[dsm][cli]") {
    std::string dir = test::temp_dir();
    std::string scene = test::data_path("scenes/default.json");
    std::string out = dir + "/shadow.exr";
    std::string command = std::string(SOMBRA_CLI) + " dsm " + scene + " --light 0 --dsm-res 32 --eps 0.05 -o " + out +
                          " 2>/dev/null";
    REQUIRE(std::system(command.c_str()) == 0);
    DeepShadowMap read = read_deep_exr(out);
    auto built = build_deep_shadow_maps(test::context(), load_scene(scene), 0, dsm_options(32, 0.05f));
    REQUIRE(read.width == 32);
    REQUIRE(read.first == built[0].first);
    REQUIRE(read.nodes.size() == built[0].nodes.size());
    std::size_t mismatches = 0;  // opacity through float per-sample alphas, clamped to [0, 1]
    for (std::size_t i = 0; i < read.nodes.size(); ++i)
        mismatches += read.nodes[i].depth != built[0].nodes[i].depth ||
                      std::fabs(read.nodes[i].opacity - std::clamp(built[0].nodes[i].opacity, 0.f, 1.f)) > 1e-6f;
    CHECK(mismatches == 0);
    CHECK(read.light_name == "lights[0]");
    CHECK(read.world_to_ndc == built[0].world_to_ndc);
    CHECK(read.interpolation == DeepShadowMap::Interpolation::OpticalDepth);  // the default relative bound says so

    // a map of opacity (--dsm-error absolute) says that and reads back the same
    const std::string absolute_out = dir + "/absolute.exr";
    command = std::string(SOMBRA_CLI) + " dsm " + scene + " --light 0 --dsm-res 32 --eps 0.05 --dsm-error absolute -o " +
              absolute_out + " 2>/dev/null";
    REQUIRE(std::system(command.c_str()) == 0);
    RenderOptions absolute = dsm_options(32, 0.05f);
    absolute.dsm.error = "absolute";
    auto absolute_built = build_deep_shadow_maps(test::context(), load_scene(scene), 0, absolute);
    DeepShadowMap absolute_read = read_deep_exr(absolute_out);
    CHECK(absolute_read.interpolation == DeepShadowMap::Interpolation::Opacity);
    REQUIRE(absolute_read.nodes.size() == absolute_built[0].nodes.size());
    double worst_node = 0;
    for (std::size_t i = 0; i < absolute_read.nodes.size(); ++i)
        worst_node = std::max(worst_node, double(std::fabs(absolute_read.nodes[i].opacity -
                                                            std::clamp(absolute_built[0].nodes[i].opacity, 0.f, 1.f))));
    CHECK(worst_node <= 1e-6);

    // OpenImageIO's flatten (oiiotool --flatten) of every texel: the DSM's opacity at the far end
    OIIO::ImageBuf deep(out);
    OIIO::ImageBuf flat = OIIO::ImageBufAlgo::flatten(deep);
    REQUIRE(!flat.has_error());
    const int a = flat.spec().channelindex("A");
    double worst = 0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            const std::size_t t = std::size_t(y * 32 + x);
            const std::uint32_t end = built[0].first[t + 1];
            const float far = end == built[0].first[t] ? 0.f : std::clamp(built[0].nodes[end - 1].opacity, 0.f, 1.f);
            worst = std::max(worst, double(std::fabs(flat.getchannel(x, y, 0, a) - far)));
        }
    INFO("max |flatten A − DSM opacity at the far end| " << worst);
    CHECK(worst < 1e-6);
}

// What another tool can do with a deep EXR alone: place a world point with the header's
// worldToNDC / worldToCamera, read the texels' opacity at its depth (bilinear, as the renderer).
TEST_CASE("deep EXR: the header's matrices place the map: lookups from the file alone match the renderer", "[dsm]") {
    for (LightType type : {LightType::Directional, LightType::Spot, LightType::Point}) {
        Scene s = smoke_scene(type);
        const int res = 32;
        RenderOptions o = dsm_options(res, 0.02f);
        std::vector<DeepShadowMap> maps;
        for (const DeepShadowMap& built : build_deep_shadow_maps(test::context(), s, 0, o)) {
            const std::string path = test::temp_dir() + "/placed.exr";
            write_deep_exr(built, path);
            maps.push_back(read_deep_exr(path));
        }
        auto points = random_points(400, 0.5f, 34);
        auto kernel = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
        double worst = 0;
        int placed = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            for (const DeepShadowMap& map : maps) {
                auto apply = [&](const std::array<float, 16>& m, int row) {
                    return double(m[std::size_t(row) * 4]) * points[i][0] + double(m[std::size_t(row) * 4 + 1]) * points[i][1] +
                           double(m[std::size_t(row) * 4 + 2]) * points[i][2] + double(m[std::size_t(row) * 4 + 3]);
                };
                const double w = apply(map.world_to_ndc, 3);
                if (w <= 0) continue;
                const double ndc_x = apply(map.world_to_ndc, 0) / w, ndc_y = apply(map.world_to_ndc, 1) / w;
                if (ndc_x < 0 || ndc_x > 1 || ndc_y < 0 || ndc_y > 1) continue;
                const double cx = apply(map.world_to_camera, 0), cy = apply(map.world_to_camera, 1), cz = apply(map.world_to_camera, 2);
                // sombra's depth (docs/deep_exr.md): distance from the light, camera z for directional lights
                const double depth = type == LightType::Directional ? cz : std::sqrt(cx * cx + cy * cy + cz * cz);
                const double u = ndc_x * res - 0.5, v = ndc_y * res - 0.5;
                const int x0 = int(std::floor(u)), y0 = int(std::floor(v));
                const double fu = u - x0, fv = v - y0;
                auto at = [&](int x, int y) {
                    x = std::clamp(x, 0, res - 1), y = std::clamp(y, 0, res - 1);
                    return texel_opacity(map, std::size_t(y) * res + std::size_t(x), depth);
                };
                const double alpha = (1 - fv) * ((1 - fu) * at(x0, y0) + fu * at(x0 + 1, y0)) +
                                     fv * ((1 - fu) * at(x0, y0 + 1) + fu * at(x0 + 1, y0 + 1));
                worst = std::max(worst, std::fabs(kernel[i] - (1 - alpha)));
                ++placed;
                break;
            }
        }
        INFO("light type " << int(type) << ": " << placed << " points placed, max |kernel − file lookup| " << worst);
        CHECK(placed > 300);
        CHECK(worst < 1e-4);
    }
}

TEST_CASE("every storage backend stores the same nodes and renders the same image", "[dsm][storage]") {
    Scene s = smoke_scene(LightType::Point);
    s.lights.push_back(smoke_scene(LightType::Spot).lights[0]);
    s.lights[1].position = {-1.f, 0.3f, 0.2f};
    s.lights[1].direction = {1.f, -0.3f, -0.2f};
    RenderOptions base = dsm_options(40, 0.02f);
    base.volume_storage = VolumeStorage::Buffer;
    base.shadow_cache = ShadowCacheMode::Off;  // the maps' lookups, not auto's per-storage choice
    base.dsm.storage = "compact";
    base.dsm.precompression = GENERATE(false, true);  // the tables go through every backend too
    auto reference_maps = build_deep_shadow_maps(test::context(), s, 0, base);
    RenderResult reference_image = render(test::context(), s, base);
    for (const char* storage : {"atlas", "chunked", "chunked-ondemand"})
        for (const char* lookup : {"packed", "native"}) {  // read back from the packed copy, or in place
            RenderOptions o = base;
            o.dsm.storage = storage;
            o.dsm.lookup = lookup;
            require_same_nodes(build_deep_shadow_maps(test::context(), s, 0, o), reference_maps, storage);
            RenderResult r = render(test::context(), s, o);
            auto d = test::compare(r.image, reference_image.image);
            INFO(storage << ", " << lookup << " lookups: max image difference " << d.max_abs);
            CHECK(d.max_abs <= 1e-5);
            CHECK(r.stats.dsm_nodes == reference_image.stats.dsm_nodes);
            CHECK(r.stats.dsm_bytes_used > 0);
        }
}

TEST_CASE("packed lookups read the same maps as native ones: identical images and stats, one copy per build", "[dsm][storage]") {
    Scene s = smoke_scene(LightType::Point);
    s.lights.push_back(smoke_scene(LightType::Directional).lights[0]);
    RenderOptions base = dsm_options(48, 0.01f);
    base.volume_storage = VolumeStorage::Buffer;
    base.shadow_cache = ShadowCacheMode::Off;  // the maps' lookups, not auto's per-lookup choice
    const bool pocl = test::context().device().platform.find("Portable Computing Language") != std::string::npos;
    INFO(test::context().device().platform);
    for (const char* storage : {"atlas", "chunked", "chunked-ondemand"}) {
        RenderOptions native = base, packed = base;
        native.dsm.storage = packed.dsm.storage = storage;
        native.dsm.lookup = "native";
        packed.dsm.lookup = "packed";
        RenderResult a = render(test::context(), s, native), b = render(test::context(), s, packed);
        INFO(storage);
        // the same nodes read in the same order: on PoCL not one bit differs; another compiler may
        // contract the two lookups' arithmetic differently (Intel's CPU runtime): ≤ 1e-7
        REQUIRE(a.image.rgba.size() == b.image.rgba.size());
        if (pocl) CHECK(std::equal(a.image.rgba.begin(), a.image.rgba.end(), b.image.rgba.begin()));
        else CHECK(test::compare(a.image, b.image).max_abs <= 1e-7);
        CHECK(a.stats.dsm_nodes == b.stats.dsm_nodes);
        CHECK(b.stats.stage_ms.count("dsm_pack") == 1);
        CHECK(a.stats.stage_ms.count("dsm_pack") == 0);
        // the copy: every node once more (8 bytes, + 1 spare) and an offset per texel (+ 1); the
        // chunked storage then keeps its write arrays (12 bytes per slot) instead of the float4 texture
        unsigned long long copy = (unsigned long long)(b.stats.dsm_views * 48 * 48 + 1) * 4 + (b.stats.dsm_nodes + 1) * 8;
        if (std::string(storage) == "atlas") CHECK(b.stats.dsm_bytes_used == a.stats.dsm_bytes_used + copy);
        else CHECK(b.stats.dsm_bytes_used >= copy + b.stats.dsm_nodes * 12);
    }
    RenderOptions bad = base;
    bad.dsm.lookup = "sideways";
    CHECK_THROWS_WITH(render(test::context(), s, bad), Catch::Contains("dsm_lookup") && Catch::Contains("sideways"));
}

TEST_CASE("DSM generation in packets of 8 texels stores the nodes of one texel per work-item", "[dsm][storage][lanes]") {
    // two overlapping volumes (segments of one and of two volumes), a resolution that is not a
    // multiple of 8 (padding lanes and columns), a spot light and a point light's cube faces
    Scene s = smoke_scene(LightType::Spot);
    VolumeInstance second = s.volumes[0];
    second.transform = make_transform({0.3f, 0.1f, 0.f}, {0.f, 35.f, 10.f}, {1.f / 30, 1.f / 24, 1.f / 20});
    s.volumes.push_back(second);
    s.lights.push_back(smoke_scene(LightType::Point).lights[0]);
    RenderOptions base = dsm_options(37, 0.02f);
    base.volume_storage = VolumeStorage::Buffer;
    base.dsm.precompression = GENERATE(false, true);
    for (const std::string& storage : sombra::dsm_storage_names()) {
        base.dsm.storage = storage;
        RenderOptions scalar = base;
        scalar.lanes = 1;
        // every light's maps come from one preparation per lane count
        std::vector<std::vector<DeepShadowMap>> reference;
        for (int light : {0, 1}) reference.push_back(build_deep_shadow_maps(test::context(), s, light, scalar));
        for (int lanes : {8, 16}) {  // 16: the default on AVX-512 CPUs (host::generation_lanes)
            RenderOptions packets = base;
            packets.lanes = lanes;
            for (int light : {0, 1}) {
                std::size_t nodes = 0;
                for (const auto& map : reference[light]) nodes += map.nodes.size();
                CHECK(nodes > 0);
                require_same_nodes(build_deep_shadow_maps(test::context(), s, light, packets), reference[light],
                                   std::string(storage) + (base.dsm.precompression ? ", tables" : "") + ", light " +
                                       std::to_string(light) + ", " + std::to_string(lanes) + " lanes");
            }
        }
    }
}

TEST_CASE("default packet widths: 8 in the camera pass, the native float vector width in DSM generation", "[dsm][lanes]") {
    host::Runtime& runtime = test::context().runtime();
    CHECK(host::generation_lanes(runtime, 4) == 4);  // asked for: taken
    CHECK(host::packet_lanes(runtime, 16) == 16);
    CHECK_THROWS_WITH(host::generation_lanes(runtime, 3), Catch::Contains("--lanes"));
    if (runtime.info().is_gpu) {
        CHECK(host::generation_lanes(runtime, 0) == 1);
        CHECK(host::packet_lanes(runtime, 0) == 1);
        return;
    }
    const cl_uint native = runtime.device().getInfo<CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT>();
    INFO("native float vector width " << native);
    CHECK(host::packet_lanes(runtime, 0) == 8);
    CHECK(host::generation_lanes(runtime, 0) == (native >= 16 ? 16 : 8));
}

TEST_CASE("chunked storage with counted allocation wastes < 10 % — Knecht's on-demand chunks waste more", "[dsm][storage]") {
    Scene s = smoke_scene(LightType::Spot);
    RenderOptions o = dsm_options(64, 0.01f);
    o.dsm.storage = "chunked";
    RenderResult counted = render(test::context(), s, o);
    o.dsm.storage = "chunked-ondemand";
    RenderResult on_demand = render(test::context(), s, o);
    INFO("counted: used " << counted.stats.dsm_bytes_used << " wasted " << counted.stats.dsm_bytes_wasted
                          << "; on demand: used " << on_demand.stats.dsm_bytes_used << " wasted " << on_demand.stats.dsm_bytes_wasted);
    CHECK(double(counted.stats.dsm_bytes_wasted) < 0.1 * double(counted.stats.dsm_bytes_used));
    CHECK(on_demand.stats.dsm_bytes_wasted > counted.stats.dsm_bytes_wasted);
}

TEST_CASE("atlas layer cap: hit, counted and reported, never written past", "[dsm][storage][numerics]") {
    Scene s = smoke_scene(LightType::Directional);
    s.volumes[0].step_voxels = 0.04f;  // ~600 samples per ray
    s.volumes[0].transfer_function = test::ramp_tf(0.0f, 1.0f, 0.02f);
    RenderOptions o = dsm_options(16, 0.f);  // ε = 0: a node per sample, past the 256-layer cap
    o.dsm.error = "absolute";                // (optical depth is linear where the ramp's opacity is: fewer nodes)
    o.dsm.storage = "atlas";
    RenderResult r = render(test::context(), s, o);
    INFO("capped texels " << r.stats.dsm_capped_texels << ", max nodes " << r.stats.dsm_max_nodes_per_texel);
    CHECK(r.stats.dsm_capped_texels > 0);
    CHECK(r.stats.dsm_max_nodes_per_texel <= 256);
    for (float v : r.image.rgba) REQUIRE(std::isfinite(v));
    o.dsm.storage = "compact";  // no cap: the same texels keep every node
    CHECK(render(test::context(), s, o).stats.dsm_max_nodes_per_texel > 256);
}

TEST_CASE("deep shadow maps are rebuilt only when the light, the scene or the transfer function changes", "[dsm]") {
    Context context(test::device_selector());  // its own kept state
    Scene s = smoke_scene(LightType::Spot);
    RenderOptions o = dsm_options(32, 0.02f);
    RenderResult first = render(context, s, o);
    CHECK_FALSE(first.stats.reused_preparation);
    CHECK(first.stats.stage_ms.count("dsm_build") == 1);
    s.camera.position = {0.5f, 0.2f, 2.5f};  // the camera moves: nothing to rebuild
    RenderResult moved = render(context, s, o);
    CHECK(moved.stats.reused_preparation);
    CHECK(moved.stats.stage_ms.count("dsm_build") == 0);
    CHECK(moved.stats.dsm_nodes == first.stats.dsm_nodes);
    s.lights[0].position = {0.2f, 1.3f, 0.3f};  // the light moves: its map only
    RenderResult lit = render(context, s, o);
    CHECK(lit.stats.reused_preparation);
    CHECK(lit.stats.dsm_views_generated == 1);
    s.volumes[0].transfer_function.opacity_points.back().alpha = 0.5f;  // the transfer function changes
    CHECK_FALSE(render(context, s, o).stats.reused_preparation);
    CHECK(render(context, s, o).stats.reused_preparation);
}

TEST_CASE("one light's maps build that light's views only, the same maps as a build of all, and the rest when a render needs them", "[dsm]") {
    Scene s = smoke_scene(LightType::Spot);
    Light point = s.lights[0];
    point.type = LightType::Point;
    point.position = {0.9f, -0.4f, 0.6f};
    s.lights.push_back(point);  // light 1: 6 views after light 0's one
    const RenderOptions o = dsm_options(32, 0.02f);
    Context partial(test::device_selector()), whole(test::device_selector()), fresh(test::device_selector());  // each its own kept state
    RenderStats only_stats;
    const auto only = build_deep_shadow_maps(partial, s, 1, o, &only_stats);
    CHECK(only.size() == 6);
    CHECK(only_stats.dsm_views_generated == 6);  // not light 0's
    const RenderResult all = render(whole, s, o);
    CHECK(all.stats.dsm_views_generated == 7);
    RenderStats kept_stats;
    const auto kept = build_deep_shadow_maps(whole, s, 1, o, &kept_stats);
    CHECK(kept_stats.dsm_views_generated == 0);
    require_same_nodes(only, kept, "light 1 alone vs in a build of all");
    // a render on the context that built light 1 alone builds light 0's view then, and nothing else
    const RenderResult after = render(partial, s, o);
    CHECK(after.stats.reused_preparation);
    CHECK(after.stats.dsm_views_generated == 1);
    CHECK(after.image.rgba == render(fresh, s, o).image.rgba);
    // the light-0 query on it now builds nothing
    RenderStats again;
    build_deep_shadow_maps(partial, s, 0, o, &again);
    CHECK(again.dsm_views_generated == 0);
}

TEST_CASE("a moved light regenerates its own maps only, and the image equals a fresh build's", "[dsm]") {
    for (const std::string& storage : sombra::dsm_storage_names()) {
        for (const char* prefilter : {"none", "box", "5tap"}) {
            INFO("storage " << storage << ", prefilter " << prefilter);
            Context context(test::device_selector()), fresh_context(test::device_selector());  // their own kept state
            auto fresh_render = [&](const Scene& scene, const RenderOptions& options) {
                fresh_context.release_prepared_scenes();
                return render(fresh_context, scene, options);
            };
            Scene s = smoke_scene(LightType::Spot);
            Light point = s.lights[0];
            point.type = LightType::Point;
            point.position = {-0.9f, 0.4f, 0.8f};
            s.lights.push_back(point);
            RenderOptions o = dsm_options(24, 0.02f);
            o.dsm.storage = storage;
            o.dsm.prefilter = prefilter;
            o.width = o.height = 48;
            CHECK(render(context, s, o).stats.dsm_views_generated == 7);
            s.lights[1].intensity = 0.5f;  // shading only: no map to regenerate
            RenderResult dimmed = render(context, s, o);
            CHECK(dimmed.stats.dsm_views_generated == 0);
            CHECK(test::compare(dimmed.image, fresh_render(s, o).image).max_abs == 0.0);
            // moving the lights again and again: superseded nodes pile up in the pools until the
            // set is built anew; every image equals the fresh build's
            for (int move = 0; move < 4; ++move) {
                int moved = move % 2;
                s.lights[std::size_t(moved)].position[0] += 0.15f;
                RenderResult updated = render(context, s, o);
                CHECK(updated.stats.reused_preparation);
                CHECK(updated.stats.dsm_views_generated >= (moved == 0 ? 1 : 6));
                RenderResult fresh = fresh_render(s, o);
                CHECK(updated.stats.dsm_nodes == fresh.stats.dsm_nodes);
                CHECK(test::compare(updated.image, fresh.image).max_abs <= 1e-6);
            }
        }
    }
}

namespace {

// Density falls linearly with the radius; the step transfer function makes an isosurface at half
// the radius (Hadwiger Fig. 2–3), lit by a directional light.
Scene isosurface_ball_scene(int n) {
    Volume ball;
    ball.dims = {n, n, n};
    ball.voxels.resize(std::size_t(n) * n * n);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                double c = (n - 1) / 2.0, r = std::sqrt((x - c) * (x - c) + (y - c) * (y - c) + (z - c) * (z - c));
                ball.voxels[std::size_t(x) + n * (std::size_t(y) + n * std::size_t(z))] = float(std::max(0.0, 1.0 - r / c));
            }
    ball.update_range();
    Scene s = smoke_scene(LightType::Directional);
    s.volumes[0].volume = std::make_shared<const Volume>(ball);
    s.volumes[0].transform = make_transform({0, 0, 0}, {0, 0, 0}, {1.f / n, 1.f / n, 1.f / n});
    s.volumes[0].transfer_function.opacity_points = {{0.f, 0.f}, {0.499f, 0.f}, {0.5f, 0.3f}, {1.f, 0.3f}};
    s.lights[0].direction = {0.3f, -1.f, 0.2f};
    return s;
}

}  // namespace

TEST_CASE("pre-compressed visibility tables remove the error of coarse sampling on an isosurface TF", "[dsm][precompression]") {
    const int n = 32;
    Scene s = isosurface_ball_scene(n);
    s.volumes[0].step_voxels = 2.f;  // coarse: two voxels per step
    s.lights[0].direction = {0.3f, -1.f, 0.2f};
    auto points = random_points(3000, 0.3f, 8);  // in and around the isosurface (radius ≈ 0.25)
    RenderOptions plain = dsm_options(96, 0.005f), tables = plain;
    tables.dsm.precompression = true;
    Errors without = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, plain).transmittance);
    Errors with = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, tables).transmittance);
    INFO("mean |T − reference|: equidistant samples " << without.mean << " (max " << without.max << "), pre-compressed "
                                                       << with.mean << " (max " << with.max << ")");
    CHECK(with.non_finite == 0);
    // Both paths integrate each step exactly for density linear between samples (pre-integration,
    // cl/volume_sample.h); the tables also place the rise within the step: measured 0.0117 → 0.0086
    CHECK(with.mean < 0.85 * without.mean);
}

namespace {

// The taps of a pre-filter (cl/shared/prefilter.h): {sub-map, dx, dy, weight}.
std::vector<std::array<int, 4>> prefilter_taps(const std::string& filter) {
    const int box[][4] = SOMBRA_PREFILTER_BOX_TAPS, tent[][4] = SOMBRA_PREFILTER_TENT_TAPS, quincunx[][4] = SOMBRA_PREFILTER_5TAP_TAPS;
    std::vector<std::array<int, 4>> taps;
    auto add = [&](const auto& table) {
        for (const auto& t : table) taps.push_back({t[0], t[1], t[2], t[3]});
    };
    if (filter == "box") add(box);
    if (filter == "tent") add(tent);
    if (filter == "5tap") add(quincunx);
    return taps;
}

bool same_nodes(const DeepShadowMap& a, const DeepShadowMap& b) {
    if (a.first != b.first || a.nodes.size() != b.nodes.size()) return false;
    for (std::size_t i = 0; i < a.nodes.size(); ++i)
        if (a.nodes[i].depth != b.nodes[i].depth || a.nodes[i].opacity != b.nodes[i].opacity) return false;
    return true;
}

}  // namespace

TEST_CASE("pre-filtering: each texel is the weighted sum of its taps' sub-pixel functions within ε", "[dsm][prefilter]") {
    Scene s = smoke_scene(LightType::Spot);
    const int res = 16;
    const float epsilon = 0.02f;
    for (const char* filter : {"box", "tent", "5tap"})
        for (bool jitter : {false, true}) {
            RenderOptions o = dsm_options(res, epsilon);
            o.dsm.prefilter = filter;
            o.dsm.prefilter_jitter = jitter;
            auto lo = build_deep_shadow_maps(test::context(), s, 0, o)[0];
            auto subs = build_prefilter_sub_maps(test::context(), s, 0, o);
            auto taps = prefilter_taps(filter);
            int scale = std::string(filter) == "5tap" ? 1 : 2;
            REQUIRE(subs.size() == (std::string(filter) == "5tap" ? 2u : 1u));
            double total = 0, worst = 0;
            for (auto& t : taps) total += t[3];
            std::size_t checked = 0;
            for (int y = 0; y < res; ++y)
                for (int x = 0; x < res; ++x) {
                    std::vector<std::pair<const DeepShadowMap*, std::size_t>> texels;
                    for (auto& t : taps) {
                        const DeepShadowMap& m = subs[std::size_t(t[0])];
                        int fx = std::clamp(scale * x + t[1], 0, m.width - 1), fy = std::clamp(scale * y + t[2], 0, m.height - 1);
                        texels.push_back({&m, std::size_t(fy) * m.width + fx});
                    }
                    for (auto& [m, texel] : texels)
                        for (std::uint32_t k = m->first[texel]; k < m->first[texel + 1]; ++k) {
                            double z = m->nodes[k].depth, expected = 0;
                            for (std::size_t t = 0; t < taps.size(); ++t)
                                expected += taps[t][3] / total * texel_opacity(*texels[t].first, texels[t].second, z);
                            worst = std::max(worst, std::fabs(texel_opacity(lo, std::size_t(y) * res + x, z) - expected));
                            ++checked;
                        }
                }
            INFO(filter << (jitter ? " jittered" : "") << ": max |V'_filtered − Σ w V'_sub| " << worst << " over " << checked
                        << " depths");
            CHECK(checked > 100);
            CHECK(worst <= 0.5 * epsilon + 1e-4);
        }

    // and the filtered map is a usable shadow: finite, close to the reference
    auto points = random_points(300, 0.45f, 21);
    for (const char* filter : {"box", "tent", "5tap"}) {
        RenderOptions o = dsm_options(64, 0.01f);
        o.dsm.prefilter = filter;
        Errors e = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, o).transmittance);
        INFO(filter << ": mean " << e.mean << ", max " << e.max);
        CHECK(e.non_finite == 0);
        CHECK(e.mean < 0.02);
    }
}

TEST_CASE("pre-filtering: jittered sub-pixel rays stay in their cells and the kernel casts them there", "[dsm][prefilter]") {
    Scene s = smoke_scene(LightType::Spot);
    packing::PackedScene packed = packing::pack_scene(s);
    const int res = 12;
    std::vector<DsmViewGpu> views = shadows::make_dsm_views(s, packed, res);
    for (const char* filter : {"box", "tent", "5tap"}) {
        auto sub = shadows::sub_pixel_views(views, filter, true, 7);
        auto taps = prefilter_taps(filter);
        // each tap's ray, in texels of the view, within ¼ texel of its nominal position
        // (prefilter.h) and, for the box and the 5-tap centre, inside the texel
        double worst = 0;
        int outside = 0;
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x)
                for (auto& t : taps) {
                    const DsmViewGpu& v = sub.views[std::size_t(t[0])];
                    int fx = sub.scale * x + t[1], fy = sub.scale * y + t[2];
                    if (fx < 0 || fy < 0 || fx >= sub.resolution || fy >= sub.resolution) continue;  // clamped taps
                    double pos[2];
                    for (int axis = 0; axis < 2; ++axis) {
                        double p = sombra_texel_ray_coord(cl_uint(fx), cl_uint(fy), cl_uint(axis), v.ray_shift, v.jitter, v.jitter_seed);
                        double ndc = (p / sub.resolution * 2 - 1) * (axis ? v.extent_y / views[0].extent_y : v.extent_x / views[0].extent_x);
                        pos[axis] = (ndc * 0.5 + 0.5) * res;  // texel (x, y) spans [x, x + 1)
                    }
                    double nominal[2];
                    for (int axis = 0; axis < 2; ++axis) {
                        int d = t[1 + axis], c = axis ? y : x;
                        nominal[axis] = sub.scale == 2 ? c + (d + 0.5) / 2 : (t[0] == 0 ? c + 0.5 : c + d);
                        worst = std::max(worst, std::fabs(pos[axis] - nominal[axis]));
                    }
                    bool own_texel = std::string(filter) == "box" || (std::string(filter) == "5tap" && t[0] == 0);
                    if (own_texel && (std::floor(pos[0]) != x || std::floor(pos[1]) != y)) ++outside;
                }
        INFO(filter << ": max |ray − nominal position| " << worst << " texels; " << outside << " rays outside their texel");
        CHECK(worst <= 0.25 + 1e-5);
        CHECK(worst > 0.15);  // jittered
        CHECK(outside == 0);
    }

    // the generation kernel casts the rays at those positions: the 5-tap sub-maps against the CPU
    // reference along the same rays, |V' − V| ≤ ε/2
    RenderOptions o = dsm_options(res, 0.02f);
    o.dsm.prefilter = "5tap";
    o.dsm.prefilter_seed = 7;
    auto maps = build_prefilter_sub_maps(test::context(), s, 0, o);
    auto sub = shadows::sub_pixel_views(views, "5tap", true, 7);
    REQUIRE(maps.size() == 2);
    double worst = 0;
    for (std::size_t m = 0; m < 2; ++m) {
        const DsmViewGpu& v = sub.views[m];
        for (int y = 0; y < sub.resolution; ++y)
            for (int x = 0; x < sub.resolution; ++x) {
                float px = sombra_texel_ray_coord(cl_uint(x), cl_uint(y), 0, v.ray_shift, v.jitter, v.jitter_seed);
                float py = sombra_texel_ray_coord(cl_uint(x), cl_uint(y), 1, v.ray_shift, v.jitter, v.jitter_seed);
                Vec3 origin, dir;
                texel_ray(v, (px / sub.resolution) * 2 - 1, (py / sub.resolution) * 2 - 1, origin, dir);
                auto reference = reference::visibility_samples(s, origin, dir, sombra_pixel_jitter(x, y, cl_uint(m)));
                for (auto& r : reference)
                    worst = std::max(worst, std::fabs(texel_opacity(maps[m], std::size_t(y) * sub.resolution + x, r.t) - r.alpha));
            }
    }
    INFO("jittered 5-tap sub-maps: max |V' − V| " << worst);
    CHECK(worst <= 0.01 + 2e-4);
}

TEST_CASE("pre-filtering: jitter is deterministic per seed — 5tap renders with every storage backend", "[dsm][prefilter]") {
    Scene s = smoke_scene(LightType::Spot);
    RenderOptions o = dsm_options(24, 0.02f);
    o.shadow_cache = ShadowCacheMode::Off;  // auto's choice may differ between storages
    o.dsm.prefilter = "5tap";
    auto first = build_deep_shadow_maps(test::context(), s, 0, o)[0];
    o.dsm.prefilter_seed = 2;
    auto other_seed = build_deep_shadow_maps(test::context(), s, 0, o)[0];
    o.dsm.prefilter_jitter = false;
    auto unjittered = build_deep_shadow_maps(test::context(), s, 0, o)[0];
    o.dsm.prefilter_jitter = true;
    o.dsm.prefilter_seed = 1;
    auto again = build_deep_shadow_maps(test::context(), s, 0, o)[0];  // rebuilt: the options changed in between
    CHECK(same_nodes(first, again));
    CHECK_FALSE(same_nodes(first, other_seed));
    CHECK_FALSE(same_nodes(first, unjittered));

    RenderResult reference_image;
    for (const std::string& storage : sombra::dsm_storage_names()) {
        o.dsm.storage = storage;
        auto map = build_deep_shadow_maps(test::context(), s, 0, o)[0];
        INFO(storage);
        CHECK(same_nodes(map, first));
        for (const DsmNode& n : map.nodes) REQUIRE((std::isfinite(n.depth) && n.opacity >= 0.f && n.opacity <= 1.f));
        RenderResult r = render(test::context(), s, o);
        for (float v : r.image.rgba) REQUIRE(std::isfinite(v));
        if (reference_image.image.rgba.empty()) reference_image = r;
        CHECK(test::compare(r.image, reference_image.image).max_abs <= 1e-5);
    }
}

TEST_CASE("DSM lookup kernel against a CPU lookup of the read-back map (projection, Eq. 3.7, bilinear)", "[dsm]") {
    for (const char* bound : {"absolute", "relative"})
    for (LightType type : {LightType::Directional, LightType::Spot}) {
        Scene s = smoke_scene(type);
        const int res = 32;
        for (const char* storage : {"atlas", "chunked", "compact"}) {
            RenderOptions o = dsm_options(res, 0.02f);
            o.dsm.storage = storage;
            o.dsm.error = bound;
            auto map = build_deep_shadow_maps(test::context(), s, 0, o)[0];
            packing::PackedScene packed = packing::pack_scene(s);
            DsmViewGpu v = shadows::make_dsm_views(s, packed, res)[0];
            auto points = random_points(500, 0.5f, 33);
            auto kernel = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
            double worst = 0;
            for (std::size_t i = 0; i < points.size(); ++i) {
                double d[3], q[3];
                for (int k = 0; k < 3; ++k) d[k] = points[i][k] - v.origin.s[k];
                for (int k = 0; k < 3; ++k)
                    q[k] = d[0] * (&v.axis_x)[k].s[0] + d[1] * (&v.axis_x)[k].s[1] + d[2] * (&v.axis_x)[k].s[2];
                double nx = q[0], ny = q[1], depth = q[2];
                if (v.perspective) {
                    if (q[2] <= 0) continue;
                    nx = q[0] / q[2], ny = q[1] / q[2], depth = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                }
                nx /= v.extent_x, ny /= v.extent_y;
                double alpha = 0;
                if (std::fabs(nx) <= 1 && std::fabs(ny) <= 1) {
                    double u = (nx * 0.5 + 0.5) * res - 0.5, w = (ny * 0.5 + 0.5) * res - 0.5;
                    int x0 = int(std::floor(u)), y0 = int(std::floor(w));
                    double fu = u - x0, fw = w - y0;
                    auto at = [&](int x, int y) {
                        x = std::clamp(x, 0, res - 1), y = std::clamp(y, 0, res - 1);
                        return texel_opacity(map, std::size_t(y) * res + x, depth);
                    };
                    alpha = (1 - fw) * ((1 - fu) * at(x0, y0) + fu * at(x0 + 1, y0)) + fw * ((1 - fu) * at(x0, y0 + 1) + fu * at(x0 + 1, y0 + 1));
                }
                worst = std::max(worst, std::fabs(kernel[i] - (1 - alpha)));
            }
            INFO(bound << ", " << storage << ", light " << int(type) << ": max |kernel − CPU| " << worst);
            CHECK(worst < 1e-4);
        }
    }
}

// Measured (mean |ΔT| in the penumbra, point reference / texel-filtered reference):
//   ball 24²: none 0.084 / 0.056, box 0.112 / 0.056, tent 0.140 / 0.080, 5tap 0.120 / 0.065
//   ball 48²: none 0.067 / 0.042, box 0.073 / 0.036, tent 0.092 / 0.053, 5tap 0.084 / 0.047
//   rods 24²: none 0.232 / 0.164, box 0.267 / 0.140, tent 0.319 / 0.173, 5tap 0.295 / 0.155
//   rods 48²: none 0.123 / 0.091, box 0.144 / 0.078, tent 0.182 / 0.110, 5tap 0.162 / 0.092
// (jitter adds 0.002–0.012). Pre-filtering is a low-pass: it brings the map closer to the
// visibility filtered over the texel (Lokovic–Veach's goal: no aliasing of sub-texel detail),
// but further from the point-sampled reference, which the unfiltered map matches best.
TEST_CASE("pre-filtering: error near a sharp shadow edge against the point and the texel-filtered reference", "[dsm][prefilter]") {
    Scene s = isosurface_ball_scene(32);  // a nearly opaque ball: its shadow has a sharp edge
    bool rods_scene = GENERATE(false, true);
    if (rods_scene) {  // thin rods, a third of a texel wide at 24²
        const int n = 64;
        Volume rods;
        rods.dims = {n, n, n};
        rods.voxels.assign(std::size_t(n) * n * n, 0.f);
        for (int z = 0; z < n; ++z)
            for (int y = 20; y < 44; ++y)
                for (int x = 3; x < n - 3; x += 7) rods.voxels[std::size_t(x + (z * 3) / n) + n * (std::size_t(y) + n * std::size_t(z))] = 1.f;
        rods.update_range();
        s.volumes[0].volume = std::make_shared<const Volume>(rods);
        s.volumes[0].transform = make_transform({0, 0, 0}, {0, 0, 0}, {1.f / n, 1.f / n, 1.f / n});
        s.volumes[0].transfer_function.opacity_points = {{0.f, 0.f}, {1.f, 0.5f}};
        s.lights[0].direction = {0.05f, -1.f, 0.03f};
    }
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> across(-0.45f, 0.45f), below(-0.45f, -0.3f);
    std::vector<Vec3> points(2500);
    for (auto& p : points) p = {across(rng), below(rng), across(rng)};
    std::vector<double> reference(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) reference[i] = reference_transmittance(s, 0, points[i]);
    for (int res : {24, 48}) {
        // what pre-filtering approximates: the reference box-filtered over the texel's footprint
        // (4×4 points across the light's image plane)
        packing::PackedScene packed = packing::pack_scene(s);
        DsmViewGpu v = shadows::make_dsm_views(s, packed, res)[0];
        double tx = 2.0 * v.extent_x / res, ty = 2.0 * v.extent_y / res;
        std::map<std::string, std::vector<double>> values;
        for (const char* filter : {"none", "box", "tent", "5tap"})
            for (bool jitter : {false, true}) {
                if (std::string(filter) == "none" && jitter) continue;
                RenderOptions o = dsm_options(res, 0.01f);
                o.dsm.prefilter = filter;
                o.dsm.prefilter_jitter = jitter;
                values[std::string(filter) + (jitter ? "+jitter" : "")] = shadow_transmittance(test::context(), s, 0, points, o).transmittance;
            }
        // the penumbra: points where the reference or any map is neither lit nor shadowed
        auto partial = [](double t) { return t > 0.02 && t < 0.98; };
        std::vector<std::size_t> penumbra;
        for (std::size_t i = 0; i < points.size(); ++i) {
            bool in = partial(reference[i]);
            for (auto& [name, t] : values) in = in || partial(t[i]);
            if (in) penumbra.push_back(i);
        }
        std::map<std::size_t, double> filtered;
        for (std::size_t i : penumbra) {
            double sum = 0;
            for (int b = 0; b < 4; ++b)
                for (int a = 0; a < 4; ++a) {
                    Vec3 q = points[i];
                    for (int k = 0; k < 3; ++k) q[k] += float(((a + 0.5) / 4 - 0.5) * tx * v.axis_x.s[k] + ((b + 0.5) / 4 - 0.5) * ty * v.axis_y.s[k]);
                    sum += reference_transmittance(s, 0, q);
                }
            filtered[i] = sum / 16;
        }
        std::map<std::string, double> point_error, filtered_error;
        std::ostringstream report;
        for (auto& [name, t] : values) {
            for (std::size_t i : penumbra) {
                REQUIRE(std::isfinite(t[i]));
                point_error[name] += std::fabs(t[i] - reference[i]) / double(penumbra.size());
                filtered_error[name] += std::fabs(t[i] - filtered[i]) / double(penumbra.size());
            }
            report << name << " " << point_error[name] << " / " << filtered_error[name] << "; ";
        }
        INFO((rods_scene ? "rods " : "ball ") << res << "², " << penumbra.size()
                                              << " penumbra points, mean |ΔT| point / filtered reference: " << report.str());
        CHECK(penumbra.size() > 100);
        if (rods_scene) CHECK(filtered_error["box"] < 0.95 * filtered_error["none"]);  // sub-texel detail
    }
}

TEST_CASE("DSM generation step (dsm_step): coarser steps from the light stay within the reference tolerance", "[dsm]") {
    auto points = random_points(300, 0.45f, 29);
    for (LightType type : {LightType::Directional, LightType::Point}) {
        Scene s = smoke_scene(type);
        RenderOptions base = dsm_options(128, 0.01f);
        Errors fine = against_reference(s, points, shadow_transmittance(test::context(), s, 0, points, base).transmittance);
        for (bool precompression : {false, true}) {
            RenderOptions coarse = base;
            coarse.dsm.step = 2.f;
            coarse.dsm.precompression = precompression;  // its tables follow the step
            ShadowQuery q = shadow_transmittance(test::context(), s, 0, points, coarse);
            Errors e = against_reference(s, points, q.transmittance);
            INFO("light type " << int(type) << ", precompression " << precompression << ": step 1 mean " << fine.mean << " max "
                               << fine.max << "; step 2 mean " << e.mean << " max " << e.max);
            CHECK(e.non_finite == 0);
            CHECK(e.mean < 0.01);  // the tolerance of step 1 ("against the brute-force reference")
            CHECK(e.max < 0.06);
            CHECK(e.mean < 2 * fine.mean + 1e-3);
        }
        // a different step marches other points: other maps
        RenderOptions coarse = base;
        coarse.dsm.step = 2.f;
        auto a = build_deep_shadow_maps(test::context(), s, 0, base), b = build_deep_shadow_maps(test::context(), s, 0, coarse);
        std::size_t nodes_a = 0, nodes_b = 0;
        for (auto& m : a) nodes_a += m.nodes.size();
        for (auto& m : b) nodes_b += m.nodes.size();
        CHECK(nodes_a != nodes_b);
    }
    Scene s = smoke_scene(LightType::Spot);
    for (float step : {0.f, -1.f, 17.f, NAN}) {
        RenderOptions o = dsm_options(16, 0.01f);
        o.dsm.step = step;
        CHECK_THROWS_WITH(render(test::context(), s, o), Catch::Contains("dsm_step"));
    }
}
