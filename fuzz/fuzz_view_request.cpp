// `sombra view`'s request bodies (docs/viewer.md "Requests"): the input is the body of a POST
// /api/frame, parsed and checked against a small scene with a spot, a directional and a point
// light (view_frame: what the server does before it renders). Bad input may only end in a
// sombra::Error; the server answers those 400.
#include <nlohmann/json.hpp>

#include "fuzz_support.h"
#include "sombra/scene.h"
#include "sombra/volume.h"
#include "view/view_session.h"

namespace {

sombra::Scene small_scene() {
    sombra::Scene scene;
    sombra::VolumeInstance volume;
    volume.volume = std::make_shared<const sombra::Volume>(sombra::make_sphere(8));
    volume.transfer_function.color_points = {{0.f, 1.f, 1.f, 1.f}};
    volume.transfer_function.opacity_points = {{0.f, 0.f}, {1.f, 0.5f}};
    scene.volumes.push_back(volume);
    sombra::Light spot, directional, point;
    spot.type = sombra::LightType::Spot, spot.position = {0, 0, 3}, spot.direction = {0, 0, -1};
    point.type = sombra::LightType::Point, point.position = {2, 2, 2};
    scene.lights = {spot, directional, point};
    return scene;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const sombra::Scene scene = small_scene();
    const nlohmann::json request = nlohmann::json::parse(data, data + size, nullptr, false);
    if (request.is_discarded()) return 0;  // the server answers "request: the body is not JSON"
    sombra::fuzz::expect_clean([&] { sombra::view::view_frame(scene, sombra::RenderOptions{}, request); });
    return 0;
}
