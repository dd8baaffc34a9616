#include "cli/clusters_command.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "clustering/clustering.h"
#include "math_constants.h"
#include "render/staged_outputs.h"
#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra::cli {
namespace {

// Six significant digits: enough to read, stable across platforms' last bits.
double rounded(double value) {
    if (value == 0 || !std::isfinite(value)) return value;
    const double scale = std::pow(10.0, 5 - int(std::floor(std::log10(std::fabs(value)))));
    return std::round(value * scale) / scale;
}

// Components below 10⁻⁹ of the largest are rounding noise (a forward of (2e-16, 0, −1)): 0.
nlohmann::json vector_json(const clustering::Point& p) {
    const double largest = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    auto component = [&](double c) { return std::fabs(c) < 1e-9 * largest ? 0.0 : rounded(c); };
    return {component(p.x), component(p.y), component(p.z)};
}

nlohmann::json view_json(const clustering::FocusedView& v) {
    nlohmann::json j = {{"projection", v.orthographic ? "orthographic" : "perspective"},
                        {"eye", vector_json(v.eye)},
                        {"forward", vector_json(v.forward)},
                        {"up", vector_json(v.up)},
                        {"near", rounded(v.near)},
                        {"far", rounded(v.far)}};
    if (v.orthographic) {
        j["half_width"] = rounded(v.half_width), j["half_height"] = rounded(v.half_height);
    } else {
        j["fov_x_deg"] = rounded(v.fov_x * kDegreesPerRadian), j["fov_y_deg"] = rounded(v.fov_y * kDegreesPerRadian);
    }
    return j;
}

nlohmann::json clusters_json(const Scene& scene, const std::vector<clustering::SceneObject>& objects,
                             const std::vector<clustering::LightClusters>& lights, bool automatic) {
    auto names = [&](const std::vector<std::size_t>& indices) {
        nlohmann::json list = nlohmann::json::array();
        for (std::size_t i : indices) list.push_back(objects[i].name);
        return list;
    };
    nlohmann::json out = {{"scene", scene.source}, {"lights", nlohmann::json::array()}};
    for (const clustering::LightClusters& lc : lights) {
        nlohmann::json light = {{"light", lc.light},
                                {"type", light_type_name(scene.lights[lc.light].type)},
                                {"d0", rounded(lc.d0)},
                                {"d0_automatic", automatic},
                                {"ignored", names(lc.ignored)},
                                {"clusters", nlohmann::json::array()}};
        for (const clustering::Cluster& c : lc.clusters) {
            nlohmann::json views = nlohmann::json::array();
            for (const clustering::FocusedView& v : c.views) views.push_back(view_json(v));
            light["clusters"].push_back({{"members", names(c.members)}, {"views", views}});
        }
        out["lights"].push_back(light);
    }
    return out;
}

std::string vector_text(const nlohmann::json& v) {
    std::ostringstream s;
    s << "(" << v[0].get<double>() << ", " << v[1].get<double>() << ", " << v[2].get<double>() << ")";
    return s.str();
}

// The JSON as plain text: one block per light, one line per cluster and per view.
std::string clusters_text(const nlohmann::json& j) {
    std::ostringstream s;
    for (const nlohmann::json& light : j["lights"]) {
        s << "light " << light["light"].get<std::size_t>() << " (" << light["type"].get<std::string>() << "): "
          << light["clusters"].size() << " cluster" << (light["clusters"].size() == 1 ? "" : "s") << ", d0 "
          << light["d0"].get<double>() << (light["d0_automatic"].get<bool>() ? " (automatic)" : "");
        if (!light["ignored"].empty()) {
            s << ", outside B:";
            for (const nlohmann::json& name : light["ignored"]) s << " " << name.get<std::string>();
        }
        s << "\n";
        for (std::size_t c = 0; c < light["clusters"].size(); ++c) {
            const nlohmann::json& cluster = light["clusters"][c];
            s << "  cluster " << c << ":";
            for (const nlohmann::json& name : cluster["members"]) s << " " << name.get<std::string>();
            s << "\n";
            for (const nlohmann::json& v : cluster["views"]) {
                s << "    " << v["projection"].get<std::string>() << " eye " << vector_text(v["eye"]) << " forward "
                  << vector_text(v["forward"]);
                if (v.contains("fov_x_deg"))
                    s << " fov " << v["fov_x_deg"].get<double>() << "° × " << v["fov_y_deg"].get<double>() << "°";
                else
                    s << " size " << 2 * v["half_width"].get<double>() << " × " << 2 * v["half_height"].get<double>();
                s << " near " << v["near"].get<double>() << " far " << v["far"].get<double>() << "\n";
            }
        }
    }
    return s.str();
}

// The scene with every object coloured by its cluster of light `light` (Knecht Fig. 5.8): a
// palette colour per cluster (volumes: every transfer-function colour point; meshes: the
// material), grey for objects outside B; opacities and shapes as they are.
Scene tinted_by_cluster(Scene scene, const std::vector<clustering::SceneObject>& objects, const clustering::LightClusters& lc) {
    static const Vec3 palette[] = {{0.90f, 0.30f, 0.25f}, {0.25f, 0.65f, 0.95f}, {0.35f, 0.85f, 0.35f}, {0.95f, 0.80f, 0.20f},
                                   {0.75f, 0.40f, 0.90f}, {0.20f, 0.85f, 0.80f}, {0.95f, 0.55f, 0.15f}, {0.95f, 0.45f, 0.70f}};
    auto paint = [&](std::size_t object, const Vec3& colour) {
        const clustering::SceneObject& o = objects[object];
        if (o.is_volume)
            for (auto& point : scene.volumes[o.scene_index].transfer_function.color_points)
                point.r = colour[0], point.g = colour[1], point.b = colour[2];
        else
            scene.meshes[o.scene_index].material.color = colour;
    };
    for (std::size_t object = 0; object < objects.size(); ++object) paint(object, {0.45f, 0.45f, 0.45f});
    for (std::size_t c = 0; c < lc.clusters.size(); ++c)
        for (std::size_t object : lc.clusters[c].members) paint(object, palette[c % (sizeof palette / sizeof palette[0])]);
    return scene;
}

}  // namespace

void add_clusters_command(CLI::App& app, ClustersCommand& command) {
    command.app = app.add_subcommand("clusters", "object clusters per light and their focused views (Knecht §3.4; geometry only)");
    command.app->add_option("scene", command.scene_path, "scene file (JSON)")->required();
    command.app->add_option("--clusters", command.max_clusters, "at most M clusters per light, in [1, 64]");
    command.app->add_option("--cluster-distance", command.distance,
                            "distance threshold d0 in LiSPSM map units ([-1, 1] across B; 3 or more: one cluster); "
                            "0: automatic (twice the median projected object size)");
    command.app->add_option("--json", command.json_path, "also write the clusters as JSON to FILE");
    command.app->add_option("--image", command.image_path,
                            "also render the scene (PNG or EXR, no shadows) with each object tinted by its cluster of --light "
                            "(grey: outside the light's convex body B)");
    command.app->add_option("--light", command.light, "the light whose clusters --image shows");
    command.app->add_option("--width", command.width, "--image width (0: the scene's)");
    command.app->add_option("--height", command.height, "--image height (0: the scene's)");
    command.app->add_option("--device", command.device, "OpenCL device for --image: auto, cpu, gpu or an index");
}

int run_clusters_command(const ClustersCommand& command, const Scene& scene) {
    detail::StagedOutputs::check_targets({command.json_path, command.image_path});
    if (!command.image_path.empty()) {
        if (command.light < 0 || command.light >= int(scene.lights.size()))
            throw Error("--light: the scene has " + std::to_string(scene.lights.size()) + " lights; " + std::to_string(command.light) +
                        " is not one of them");
    }
    const clustering::ClusterOptions options{command.max_clusters, command.distance};
    const auto lights = clustering::cluster_lights(scene, options);
    const nlohmann::json j = clusters_json(scene, clustering::scene_objects(scene), lights, !(command.distance > 0));
    detail::StagedOutputs outputs;  // --json and --image are committed together or not at all
    if (!command.json_path.empty()) {
        outputs.write(command.json_path, [&](const std::string& staged) {
            std::ofstream out(staged);
            if (!(out << j.dump(2) << '\n') || !out.flush()) throw Error(command.json_path + ": cannot write file");
        });
    }
    if (!command.image_path.empty()) {
        const std::vector<clustering::SceneObject> objects = clustering::scene_objects(scene);
        const clustering::LightClusters* clusters = nullptr;
        for (const clustering::LightClusters& lc : lights) clusters = lc.light == std::size_t(command.light) ? &lc : clusters;
        Context context(command.device);
        RenderOptions render_options;
        render_options.width = command.width, render_options.height = command.height;
        const Image image = render(context, tinted_by_cluster(scene, objects, *clusters), render_options).image;
        outputs.write(command.image_path, [&](const std::string& staged) { write_image(image, staged); });
    }
    outputs.commit();
    std::cout << clusters_text(j);
    return 0;
}

}  // namespace sombra::cli
