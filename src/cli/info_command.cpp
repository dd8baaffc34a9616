#include "cli/info_command.h"

#include <cmath>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "sombra/error.h"
#include "sombra/scene.h"

namespace sombra::cli {
namespace {

using nlohmann::json;

std::string number(double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return text;
}
std::string vec_text(const Vec3& v, const char* between = ", ") {
    return number(v[0]) + between + number(v[1]) + between + number(v[2]);
}
std::string box_text(const Box3& b) {
    return "x [" + number(b.lo[0]) + ", " + number(b.hi[0]) + "]  y [" + number(b.lo[1]) + ", " + number(b.hi[1]) + "]  z [" +
           number(b.lo[2]) + ", " + number(b.hi[2]) + "]  (size " +
           vec_text({b.hi[0] - b.lo[0], b.hi[1] - b.lo[1], b.hi[2] - b.lo[2]}, " × ") + ")";
}
std::string percentiles_text(const json& values) {  // percentiles_json's object
    std::string text;
    for (double p : VolumeStatistics::kPercentiles) {
        const std::string key = "p" + std::to_string(int(p));
        text += (text.empty() ? "" : "  ") + key + " " + number(values[key]);
    }
    return text;
}

void print_volume(const json& j) {
    std::cout << j["file"].get<std::string>() << ": " << j["format"].get<std::string>() << " volume\n";
    const auto dims = j["dims"].get<std::array<int, 3>>();
    std::cout << "  dimensions    " << dims[0] << " × " << dims[1] << " × " << dims[2] << " (" << j["voxels"].get<std::size_t>()
              << " voxels)\n";
    const std::string type = j["voxel_type"].get<std::string>();
    std::cout << "  voxel type    " << (type.empty() ? "unknown" : type) << "\n";
    if (j.contains("grid")) std::cout << "  grid          " << j["grid"].get<std::string>() << "\n";
    std::cout << "  spacing       " << vec_text(j["spacing"].get<Vec3>(), " × ") << "\n";
    Box3 box;
    box.lo = j["world_bounds"]["min"].get<Vec3>(), box.hi = j["world_bounds"]["max"].get<Vec3>();
    std::cout << "  world bounds  " << box_text(box) << "\n";
    const auto m = j["placement"].get<std::array<float, 16>>();
    std::cout << "  placement     centre (" << vec_text({m[3], m[7], m[11]}) << "); axes x → (" << vec_text({m[0], m[4], m[8]})
              << "), y → (" << vec_text({m[1], m[5], m[9]}) << "), z → (" << vec_text({m[2], m[6], m[10]}) << ")\n";
    std::cout << "  values        min " << number(j["min"]) << ", max " << number(j["max"]) << ", mean " << number(j["mean"]) << "\n";
    std::cout << "  percentiles   " << percentiles_text(j["percentiles"]) << "\n";
    const double share = 100.0 * j["background"]["voxels"].get<double>() / std::max(1.0, j["voxels"].get<double>());
    std::cout << "  background    ≤ " << number(j["background"]["threshold"]) << ": " << number(share) << " % of the voxels\n";
    std::cout << "  above it      " << percentiles_text(j["foreground_percentiles"]) << "\n";
    std::cout << "  non-finite    " << j["non_finite"].get<std::size_t>() << "\n";
    const auto counts = j["histogram"]["counts"].get<std::vector<std::size_t>>();
    std::size_t most = 1;
    for (std::size_t c : counts) most = std::max(most, c);
    std::cout << "  histogram     (" << counts.size() << " bins; bars on a log scale)\n";
    const double lo = j["min"], width = (j["max"].get<double>() - lo) / double(counts.size());
    for (std::size_t i = 0; i < counts.size(); ++i) {
        char label[64];
        std::snprintf(label, sizeof label, "    %11.5g – %-11.5g ", lo + width * double(i), lo + width * double(i + 1));
        const int bar = counts[i] == 0 ? 0 : 1 + int(std::round(39.0 * std::log1p(double(counts[i])) / std::log1p(double(most))));
        std::cout << label << std::string(std::size_t(bar), '#') << std::string(std::size_t(41 - bar), ' ') << counts[i] << "\n";
    }
    std::cout << "  preset        " << j["preset"].get<std::string>() << " (what `sombra render FILE` uses with --preset auto)\n";
}

void print_scene(const json& j) {
    std::cout << j["file"].get<std::string>() << ": scene, " << j["image"]["width"] << " × " << j["image"]["height"] << " pixels\n";
    const auto box_of = [](const json& b) {
        Box3 box;
        box.lo = b["min"].get<Vec3>(), box.hi = b["max"].get<Vec3>();
        return box_text(box);
    };
    for (const json& o : j["objects"])
        std::cout << "  " << o["type"].get<std::string>() << " " << o["name"].get<std::string>() << " ("
                  << o["file"].get<std::string>() << "): " << box_of(o["world_bounds"]) << "\n";
    std::cout << "  all objects   " << box_of(j["world_bounds"]) << "\n";
    for (std::size_t i = 0; i < j["lights"].size(); ++i) {
        const json& l = j["lights"][i];
        std::cout << "  light " << i << "       " << l["type"].get<std::string>();
        if (l.contains("position")) std::cout << " at (" << vec_text(l["position"].get<Vec3>()) << ")";
        if (l.contains("direction")) std::cout << " towards (" << vec_text(l["direction"].get<Vec3>()) << ")";
        std::cout << ", colour (" << vec_text(l["color"].get<Vec3>()) << ") × " << number(l["intensity"]) << "\n";
    }
    const json& c = j["camera"];
    std::cout << "  camera        at (" << vec_text(c["position"].get<Vec3>()) << ") looking at (" << vec_text(c["look_at"].get<Vec3>())
              << "), up (" << vec_text(c["up"].get<Vec3>()) << "), fov_y " << number(c["fov_y_deg"]) << "°"
              << (c["fitted"].get<bool>() ? " (fitted: the file has no \"camera\")" : "") << "\n";
}

}  // namespace

void add_info_command(CLI::App& app, InfoCommand& command) {
    command.app = app.add_subcommand("info", "describe a volume file (size, placement, values) or a scene (bounds, lights, camera)");
    command.app->add_option("file", command.path, "a volume file (any format `render` reads) or a scene (JSON)")->required();
    command.app->add_flag("--json", command.json, "print one JSON object instead of text");
    command.app->add_option("--grid", command.grid, ".vdb: the grid to read (default: \"density\", else the first float grid)");
}

int run_info_command(const InfoCommand& command) {
    const bool scene = is_scene_file(command.path);
    if (scene && !command.grid.empty()) throw sombra::Error("--grid: applies to a .vdb volume file, not a scene");
    const json j = json::parse(scene ? scene_info_json(command.path) : volume_info_json(command.path, command.grid));
    if (command.json) std::cout << j.dump(2) << "\n";
    else if (scene) print_scene(j);
    else print_volume(j);
    return 0;
}

}  // namespace sombra::cli
