// A kept Context reuses what a change left valid: deep shadow maps per light, summed-area tables,
// shadow-cache entries (and the visible fill's partly filled ones), the prepared scene. Property:
// over random sequences of the edits a user makes between frames (camera, lights, transfer
// functions, placement), every technique's image on the kept Context equals a render from
// scratch, with the shadow cache on and off. This is how the visible fill's unfilled points
// after a moved light or a clearer volume in front were found (test_lowpass_update.cpp).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "test_support.h"

#include "sombra/sombra.h"

using namespace sombra;

namespace {

// Two 12³ clouds, one in front of the other as the camera first sees them and offset sideways,
// over a translucent floor, under a directional light and a point light.
Scene kept_context_scene() {
    Scene s;
    const float placement[2][3] = {{-0.3f, -0.5f, 0.f}, {0.4f, 0.5f, 0.1f}};
    for (int i = 0; i < 2; ++i) {
        VolumeInstance v;
        v.name = i ? "back" : "front";
        v.volume = std::make_shared<const Volume>(make_cloud_noise(12, 11u + unsigned(i)));
        v.transfer_function = test::ramp_tf(0.05f, 0.5f, i ? 0.5f : 0.8f);
        v.transform = make_transform({placement[i][0], placement[i][1], placement[i][2]}, {0, 0, 0}, {1.f / 12, 1.f / 12, 1.f / 12});
        s.volumes.push_back(v);
    }
    s.meshes.push_back(test::quad(1.2f, -0.45f, 0.7f));
    s.meshes[0].name = "floor";
    Light sun, bulb;
    sun.direction = {0.5f, 0.2f, -1.f};
    bulb.type = LightType::Point;
    bulb.position = {-1.f, 0.5f, 1.5f};
    s.lights = {sun, bulb};
    s.camera.position = {0.f, -3.5f, 0.8f};
    s.camera.up = {0, 0, 1};
    s.width = s.height = 24;
    return s;
}

constexpr int kEditKinds = 10;

// An edit of one of the kinds a user makes between frames, by random amounts; returns what it did.
std::string random_edit(Scene& s, int kind, std::mt19937& rng) {
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    const std::size_t v = std::uniform_int_distribution<std::size_t>(0, s.volumes.size() - 1)(rng);
    switch (kind) {
    case 0: {  // orbit the camera about z
        const float a = 0.6f * u(rng), c = std::cos(a), sn = std::sin(a);
        Vec3& p = s.camera.position;
        p = {c * p[0] - sn * p[1], sn * p[0] + c * p[1], p[2]};
        return "camera orbit";
    }
    case 1:  // dolly
        for (float& x : s.camera.position) x *= 1.f + 0.2f * u(rng);
        return "camera dolly";
    case 2:  // the directional light turns
        s.lights[0].direction = {s.lights[0].direction[0] + 0.8f * u(rng), s.lights[0].direction[1] + 0.8f * u(rng), -1.f};
        return "directional light turned";
    case 3:  // the point light moves
        for (float& x : s.lights[1].position) x += 0.8f * u(rng);
        return "point light moved";
    case 4:  // a volume more or less opaque
        for (auto& a : s.volumes[v].transfer_function.opacity_points) a.alpha = std::min(1.f, a.alpha * (1.f + 0.7f * u(rng)));
        return s.volumes[v].name + " opacity";
    case 5:  // a volume's colour only
        for (auto& c : s.volumes[v].transfer_function.color_points) c.g = 0.5f + 0.5f * u(rng);
        return s.volumes[v].name + " colour";
    case 6:  // a volume moves
        s.volumes[v].transform[3] += 0.15f * u(rng), s.volumes[v].transform[7] += 0.15f * u(rng);
        return s.volumes[v].name + " moved";
    case 7:  // a light's colour and intensity
        s.lights[v % s.lights.size()].color = {1.f, 0.6f + 0.4f * u(rng), 0.8f};
        s.lights[v % s.lights.size()].intensity = 1.f + 0.5f * u(rng);
        return "light colour";
    case 8:  // the floor moves
        s.meshes[0].transform[11] += 0.2f * u(rng);
        return "floor moved";
    default:  // the floor's opacity
        s.meshes[0].material.opacity = 0.5f + 0.4f * u(rng);
        return "floor opacity";
    }
}

}  // namespace

TEST_CASE("kept Context: after random edits every technique renders what a fresh render does", "[modules][cache]") {
    const ShadowTechnique techniques[] = {ShadowTechnique::Dsm,     ShadowTechnique::ShadowMap, ShadowTechnique::Rays,
                                          ShadowTechnique::Lowpass, ShadowTechnique::Ao,        ShadowTechnique::Cone};
    const ShadowCacheMode caches[] = {ShadowCacheMode::On, ShadowCacheMode::Off};
    Context fresh(test::device_selector());
    unsigned seed = 1;
    for (ShadowTechnique technique : techniques)
        for (ShadowCacheMode cache : caches) {
            Context kept(test::device_selector());
            Scene scene = kept_context_scene();
            RenderOptions o;
            o.shadows = technique;
            o.shadow_cache = cache;
            o.dsm.resolution = 32;
            std::mt19937 rng(seed++);
            std::vector<int> kinds(kEditKinds);  // every kind once, in a random order
            std::iota(kinds.begin(), kinds.end(), 0);
            std::shuffle(kinds.begin(), kinds.end(), rng);
            std::string edits = "first frame";
            for (int step = 0; step <= kEditKinds; ++step) {
                if (step > 0) edits += ", " + random_edit(scene, kinds[std::size_t(step - 1)], rng);
                RenderResult r = render(kept, scene, o);
                fresh.release_prepared_scenes();
                RenderResult f = render(fresh, scene, o);
                test::ImageDifference d = test::compare(r.image, f.image);
                INFO(shadow_technique_name(technique) << ", shadow cache " << (cache == ShadowCacheMode::On ? "on" : "off") << ": "
                                                      << edits << ": kept vs fresh max " << d.max_abs << " mean " << d.mean_abs);
                CHECK(d.max_abs <= 1e-6);
            }
        }
}
