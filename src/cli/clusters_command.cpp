#include "cli/clusters_command.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "clustering/clustering.h"
#include "host/staged_outputs.h"
#include "sombra/error.h"

namespace sombra::cli {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

const char* light_type_name(LightType type) {
    switch (type) {
        case LightType::Directional: return "directional";
        case LightType::Spot: return "spot";
        case LightType::Point: return "point";
    }
    return "?";
}

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
        j["fov_x_deg"] = rounded(v.fov_x * kDegrees), j["fov_y_deg"] = rounded(v.fov_y * kDegrees);
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

}  // namespace

void add_clusters_command(CLI::App& app, ClustersCommand& command) {
    command.app = app.add_subcommand("clusters", "object clusters per light and their focused views (Knecht §3.4; geometry only)");
    command.app->add_option("scene", command.scene_path, "scene file (JSON)")->required();
    command.app->add_option("--clusters", command.max_clusters, "at most M clusters per light, in [1, 64]");
    command.app->add_option("--cluster-distance", command.distance,
                            "distance threshold d0 in LiSPSM map units ([-1, 1] across B; 3 or more: one cluster); "
                            "0: automatic (twice the median projected object size)");
    command.app->add_option("--json", command.json_path, "also write the clusters as JSON to FILE");
}

int run_clusters_command(const ClustersCommand& command, const Scene& scene) {
    if (!command.json_path.empty()) host::StagedOutputs::check_target(command.json_path);
    const clustering::ClusterOptions options{command.max_clusters, command.distance};
    const auto lights = clustering::cluster_lights(scene, options);
    const nlohmann::json j = clusters_json(scene, clustering::scene_objects(scene), lights, !(command.distance > 0));
    if (!command.json_path.empty()) {
        host::StagedOutputs outputs;
        outputs.write(command.json_path, [&](const std::string& staged) {
            std::ofstream out(staged);
            if (!(out << j.dump(2) << '\n') || !out.flush()) throw Error(command.json_path + ": cannot write file");
        });
        outputs.commit();
    }
    std::cout << clusters_text(j);
    return 0;
}

}  // namespace sombra::cli
