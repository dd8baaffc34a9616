// sombra — a scene's parts written as scene-file JSON (docs/scenes.md): one writer for the
// scene files sombra saves (framing.cpp), `sombra info` (info.cpp) and the viewer's state
// (src/view/view_session.cpp), so that all three spell every field alike.
#pragma once
#include <nlohmann/json.hpp>

#include <vector>

#include "sombra/scene.h"

namespace sombra {

nlohmann::json vec_json(const Vec3& v);
nlohmann::json camera_json(const Camera& camera);
// Every field the scene format reads for the light's type: type, color, intensity; position and
// attenuation (point, spot); direction (directional, spot); cone angle and softness (spot).
nlohmann::json light_json(const Light& light);
nlohmann::json lights_json(const std::vector<Light>& lights);
nlohmann::json transfer_function_json(const TransferFunction& tf);

}  // namespace sombra
