#include "scene/scene_json.h"

namespace sombra {

nlohmann::json vec_json(const Vec3& v) { return nlohmann::json::array({v[0], v[1], v[2]}); }

nlohmann::json camera_json(const Camera& c) {
    return {{"position", vec_json(c.position)}, {"look_at", vec_json(c.look_at)}, {"up", vec_json(c.up)}, {"fov_y_deg", c.fov_y_deg}};
}

nlohmann::json light_json(const Light& l) {
    nlohmann::json light = {{"type", light_type_name(l.type)}, {"color", vec_json(l.color)}, {"intensity", l.intensity}};
    if (l.type != LightType::Directional) {
        light["position"] = vec_json(l.position);
        light["attenuation"] = {l.att_constant, l.att_linear, l.att_quadratic};
    }
    if (l.type != LightType::Point) light["direction"] = vec_json(l.direction);
    if (l.type == LightType::Spot) light["cone_angle_deg"] = l.cone_angle_deg, light["cone_softness"] = l.cone_softness;
    return light;
}

nlohmann::json lights_json(const std::vector<Light>& lights) {
    nlohmann::json all = nlohmann::json::array();
    for (const Light& l : lights) all.push_back(light_json(l));
    return all;
}

nlohmann::json transfer_function_json(const TransferFunction& tf) {
    nlohmann::json j = {{"rgb_points", nlohmann::json::array()}, {"opacity_points", nlohmann::json::array()}};
    for (const auto& p : tf.color_points) j["rgb_points"].insert(j["rgb_points"].end(), {p.x, p.r, p.g, p.b});
    for (const auto& p : tf.opacity_points) j["opacity_points"].insert(j["opacity_points"].end(), {p.x, p.alpha});
    return j;
}

}  // namespace sombra
