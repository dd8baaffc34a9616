// sombra — what `sombra info` tells about a volume file or a scene, as JSON (docs/volume-scenes.md).
#include <nlohmann/json.hpp>

#include "scene/scene_json.h"
#include "sombra/scene.h"

namespace sombra {
namespace {

using nlohmann::json;

json box_json(const Box3& b) { return {{"min", vec_json(b.lo)}, {"max", vec_json(b.hi)}}; }

json percentiles_json(const std::array<double, 7>& values) {
    json j = json::object();
    for (std::size_t i = 0; i < values.size(); ++i) j["p" + std::to_string(int(VolumeStatistics::kPercentiles[i]))] = values[i];
    return j;
}

json volume_json(const std::string& path, const Volume& volume, const VolumeLoadReport& report, const VolumeStatistics& s) {
    VolumeInstance placed;
    placed.volume = std::shared_ptr<const Volume>(&volume, [](const Volume*) {});
    placed.spacing = volume.spacing;
    placed.transform = volume.placement;
    json j = {{"file", path},
              {"kind", "volume"},
              {"format", report.format},
              {"voxel_type", volume.stored_type},
              {"dims", volume.dims},
              {"voxels", s.voxels},
              {"spacing", volume.spacing},
              {"world_bounds", box_json(world_bounds(placed))},
              {"placement", volume.placement},
              {"min", s.min},
              {"max", s.max},
              {"mean", s.mean},
              {"percentiles", percentiles_json(s.percentiles)},
              {"background", {{"threshold", s.background_threshold}, {"voxels", s.background_voxels}}},
              {"foreground_percentiles", percentiles_json(s.foreground_percentiles)},
              {"non_finite", report.non_finite_replaced},
              {"histogram", {{"min", s.min}, {"max", s.max}, {"counts", s.histogram}}},
              {"preset", transfer_preset_name(choose_transfer_preset(s, report.format))}};
    if (!report.grid.empty()) j["grid"] = report.grid;
    return j;
}

json scene_json(const std::string& path, const Scene& scene) {
    json objects = json::array();
    for (const VolumeInstance& vi : scene.volumes)
        objects.push_back({{"type", "volume"}, {"name", vi.name}, {"file", vi.volume ? vi.volume->source : ""},
                           {"dims", vi.volume ? vi.volume->dims : std::array<int, 3>{}}, {"world_bounds", box_json(world_bounds(vi))}});
    for (const MeshInstance& mi : scene.meshes)
        objects.push_back({{"type", "mesh"}, {"name", mi.name}, {"file", mi.mesh ? mi.mesh->source : ""},
                           {"triangles", mi.mesh ? mi.mesh->triangles.size() : 0}, {"world_bounds", box_json(world_bounds(mi))}});
    json camera = camera_json(scene.camera);
    camera["fitted"] = scene.camera_fitted;
    return {{"file", path},
            {"kind", "scene"},
            {"objects", objects},
            {"world_bounds", box_json(world_bounds(scene))},
            {"lights", lights_json(scene.lights)},
            {"camera", camera},
            {"image", {{"width", scene.width}, {"height", scene.height}}}};
}

}  // namespace

std::string volume_info_json(const std::string& path, const std::string& grid) {
    VolumeLoadOptions options;
    options.non_finite = NonFinitePolicy::Sanitize;  // counted, not refused: set to 0 as --non-finite sanitize does
    options.grid = grid;
    VolumeLoadReport report;
    const Volume volume = load_volume(path, options, &report);
    return volume_json(path, volume, report, volume_statistics(volume)).dump();
}

std::string scene_info_json(const std::string& path) { return scene_json(path, load_scene(path)).dump(); }

}  // namespace sombra
