// sombra — scene description: volumes, lights, camera, background. Loaded from JSON.
#pragma once
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sombra/mesh.h"
#include "sombra/transfer_function.h"
#include "sombra/volume.h"

namespace sombra {

using Vec3 = std::array<float, 3>;

struct Material {
    float ambient = 0.3f, diffuse = 0.7f, specular = 0.2f, shininess = 20.f;  // Knecht Eq. 3.8
};

// A polyhedral bound (issue 4; Knecht §3.1.2): a closed mesh; the volume is active only where a
// point lies inside its box AND inside this mesh (parity of crossings along a ray). `transform`
// maps the mesh into the volume's object frame (where the volume is centred at the origin, before
// VolumeInstance::transform), so the bound moves with the volume.
struct VolumeBound {
    std::shared_ptr<const Mesh> mesh;  // null: the volume is bounded by its box alone
    std::array<float, 16> transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // row-major
};

struct VolumeInstance {
    std::shared_ptr<const Volume> volume;
    // Object → world: the volume is centred at the origin of its object frame, voxel (i, j, k) at
    // ((i − (nx−1)/2)·sx, …); then this row-major 4×4 affine matrix applies.
    std::array<float, 16> transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::array<float, 3> spacing{1, 1, 1};  // voxel size in object units (from the file unless set)
    TransferFunction transfer_function;
    float step_voxels = 0.5f;    // ray step as a fraction of the smallest world voxel size
    float opacity_unit = 0.f;    // world length the TF opacities refer to; 0 = one (smallest) voxel
    Material material;
    VolumeBound bound;           // JSON "bounds": {"mesh": FILE, "transform": …}
    std::string name;
    // World box the volume is active in, on top of its voxel box: everything by default. A rank of
    // a distributed render (sombra/distributed.h) holds its region's voxels plus a ghost layer for
    // interpolation, and this box stops every ray at the region's faces.
    Vec3 clip_min{-INFINITY, -INFINITY, -INFINITY}, clip_max{INFINITY, INFINITY, INFINITY};
    bool clipped() const {
        for (int a = 0; a < 3; ++a)
            if (std::isfinite(clip_min[std::size_t(a)]) || std::isfinite(clip_max[std::size_t(a)])) return true;
        return false;
    }
};

// A mesh placed in the scene: translucent geometry. Its triangles are rasterized into the camera
// pass and into every light's deep shadow maps (docs/meshes.md): they cast and receive shadows.
struct MeshMaterial {
    Vec3 color{0.8f, 0.8f, 0.8f};
    float opacity = 1.f;  // of one surface crossing, in [0, 1]
    Material phong;
};

struct MeshInstance {
    std::shared_ptr<const Mesh> mesh;
    std::array<float, 16> transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // object → world, row-major
    MeshMaterial material;
    std::string name;
};

enum class LightType { Directional, Spot, Point };

// A light type by name, as scene files spell it: "directional", "spot", "point" (or "omni");
// otherwise throws sombra::Error "unknown light type 'NAME' (directional, spot, point)".
LightType parse_light_type(const std::string& name);
const char* light_type_name(LightType type);  // "directional", "spot", "point"

struct Light {
    LightType type = LightType::Directional;
    Vec3 position{0, 0, 0};   // spot, point
    Vec3 direction{0, 0, -1}; // directional, spot: direction the light travels
    Vec3 color{1, 1, 1};
    float intensity = 1.f;
    float cone_angle_deg = 30.f;  // spot: half angle of the cone
    float cone_softness = 0.1f;   // spot: fraction of the cone over which the edge fades
    float att_constant = 1.f, att_linear = 0.f, att_quadratic = 0.f;  // point, spot
};

// A scene without "camera" gets fit_camera's (Scene::camera_fitted); these are the defaults of a
// "camera" block's missing keys.
struct Camera {
    Vec3 position{0, 0, 3};
    Vec3 look_at{0, 0, 0};
    Vec3 up{0, 1, 0};
    float fov_y_deg = 40.f;
};

struct Scene {
    std::vector<VolumeInstance> volumes;
    std::vector<MeshInstance> meshes;
    std::vector<Light> lights;
    Camera camera;
    bool camera_fitted = false;  // no "camera" in the file: fitted to the objects (fit_scene_camera)
    Vec3 background{0, 0, 0};
    float ambient_intensity = 1.f;  // i_a
    int width = 512, height = 512;  // default image size (the CLI can override)
    std::string source;             // file it came from
    // The file's "render" block as written: option key → its JSON value, in file order; read by
    // scene_render_options (render.h) against the options' declarations.
    std::vector<std::pair<std::string, std::string>> render_settings;
};

// Loads a scene file. Volume and mesh paths are relative to the scene file's folder. Unknown keys,
// wrong types and impossible values throw sombra::Error naming the file and the field
// (e.g. "scene.json: lights[1].cone_angle_deg: must lie in (0, 90]").
Scene load_scene(const std::string& path, const VolumeLoadOptions& options = {});

// World points of a CSV file, one "x,y,z" per line (',', ';' or blanks between; '#' comments and
// blank lines skipped), at most limits::kMaxPoints; throws "FILE: line N: …" for anything else.
std::vector<Vec3> load_points_csv(const std::string& path);

// The rules scene files enforce on one volume or light, for those built in code (Python, C++):
// the first field that breaks them, named as the JSON names it ("step_voxels", "cone_angle_deg"),
// and what is wrong; nothing when all hold. NaN breaks every rule. The scene loader, the Python
// module (at add_volume / add_light / set_camera) and validate_scene (at every render) apply these same checks.
struct FieldProblem {
    std::string field, what;
};
std::optional<FieldProblem> volume_problem(const VolumeInstance& volume);  // spacing, step_voxels, opacity_unit
std::optional<FieldProblem> light_problem(const Light& light);  // direction, color, intensity, cone, attenuation
std::optional<FieldProblem> camera_problem(const Camera& camera);  // position, look_at, up, fov_y_deg
// Makes a directional or spot light's direction a unit vector, as scene files are read (after
// light_problem found it non-zero).
void normalize_light_direction(Light& light);

// Checks values that make no sense (camera at its look-at point, zero-size volumes, …) and every
// volume's and light's fields (volume_problem, light_problem): throws "WHERE: FIELD: what".
void validate_scene(const Scene& scene, const std::string& where);

// World transform (row-major) of a volume's bound mesh: VolumeInstance::transform · bound.transform.
std::array<float, 16> bound_to_world(const VolumeInstance& volume);

// An axis-aligned box in world units; empty (lo > hi) until a point is added.
struct Box3 {
    Vec3 lo{3e38f, 3e38f, 3e38f}, hi{-3e38f, -3e38f, -3e38f};
    void add(const Vec3& p);
    void add(const Box3& b);
    bool empty() const { return lo[0] > hi[0]; }
    Vec3 center() const { return {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2}; }
};
// World bounds: a volume's voxel cells (its box ± half a voxel, through its transform), a mesh's
// vertices through its transform, and the union of every volume and mesh of a scene.
Box3 world_bounds(const VolumeInstance& volume);
Box3 world_bounds(const MeshInstance& mesh);
Box3 world_bounds(const Scene& scene);

// The world axis that is up in a scene's files: +y when every volume comes from an OpenVDB file
// (OpenVDB, Houdini, Blender exports: Y up) or the scene holds meshes only (OBJ/PLY: Y up); else +z
// (medical images in RAS+: +z superior; arrays stored as z slices).
Vec3 natural_up(const Scene& scene);

// The fitted camera: a three-quarter view from above-front of `box` (35° around `up` from the
// front, 20° above; the front is +y for up = +z, the patient's anterior in RAS+, and +z for
// up = +y), looking at the box's centre with a vertical field of view of fov_y_deg, as close as
// every corner of the box stays inside the width × height image with a 4 % margin on each side.
Camera fit_camera(const Box3& box, const Vec3& up, int width, int height, float fov_y_deg = 40.f);
// Sets scene.camera to fit_camera(world_bounds(scene), natural_up(scene), width, height) and
// camera_fitted; load_scene does it (at the scene's image size) for a file without "camera".
void fit_scene_camera(Scene& scene, int width, int height);

// The key light of a fitted view: directional, from over the camera's left shoulder (from the
// camera's position seen from the centre, turned 40° up and 40° left), so that shadows fall to
// the lower right, in view.
Light key_light(const Camera& camera);

// Transfer-function presets for volume scenes, each derived from the volume's statistics
// (VolumeStatistics; fg p = a percentile of the voxels above the background, docs/volume-scenes.md):
//   ct   opacity 0 up to fg p75, 0.05 at fg p95, 0.6 at fg p99, 0.9 at the maximum: the densest
//        tissue (bone, contrast, metal) opaque; colours dark red → bone → white
//   mri  opacity 0 up to fg p25, 0.05 at fg p50, 0.25 at fg p95, 0.6 at the maximum: the
//        tissue's upper three quarters, skin and brain; colours flesh → white
//   fog  opacity 0 at the background threshold, 0.1 at fg p50, 0.3 at fg p99, 0.5 at the
//        maximum (per voxel): a translucent medium; near-white
//   auto ct when the values go below −200 (Hounsfield units) or span more than 1000 (a 12-bit
//        range); fog for OpenVDB files and for values within [0, 1] whose background holds more
//        than 40 % of the voxels (densities); ct when the background holds less than 20 % (the
//        data fill the box, a crop: only the densest quarter can show); mri otherwise (a head
//        in air)
enum class TransferPreset { Auto, Ct, Mri, Fog };
TransferPreset parse_transfer_preset(const std::string& name);  // "auto", "ct", "mri", "fog"; else throws
const char* transfer_preset_name(TransferPreset preset);
// Auto resolved by the rules above; `format` is VolumeLoadReport::format.
TransferPreset choose_transfer_preset(const VolumeStatistics& statistics, const std::string& format);
TransferFunction preset_transfer_function(const VolumeStatistics& statistics, TransferPreset preset);  // not Auto

// A scene made from one volume file (`sombra render VOLUME`): the volume where its file places
// it, the transfer function of the preset, fit_camera at width × height, key_light, a dark
// background (grey-blue for fog) and ambient 0.5.
struct VolumeScene {
    Scene scene;
    VolumeStatistics statistics;
    VolumeLoadReport report;
    TransferPreset preset = TransferPreset::Auto;  // the one used (never Auto)
};
VolumeScene volume_scene(const std::string& path, TransferPreset preset, int width = 512, int height = 512,
                         const VolumeLoadOptions& options = {});

// The scene as a scene file that loads back to the same scene (for volume scenes: every volume
// read from a file, where its file places it, and no meshes; otherwise throws naming the volume
// or mesh). Volume paths are written relative to scene_path's folder (absolute when they share
// none, or when scene_path is empty); `render` is written as the file's "render" block (an
// object, may be empty).
std::string scene_file_text(const Scene& scene, const std::string& scene_path, const std::string& render_block_json = "{}");
// The scene as a scene file that loads back to it from any folder, for a scene whose camera, image
// size, lights or volumes' transfer functions were changed after loading (`sombra view`'s "save
// scene"): the file it came from (scene.source) with those written over it, its "render" block
// replaced and its relative file paths made absolute; a scene made from a volume file as
// scene_file_text writes it with absolute paths. Throws naming the file when it no longer holds
// the scene's volumes and meshes.
std::string edited_scene_file_text(const Scene& scene, const std::string& render_block_json = "{}");

// What `sombra info` prints, as one JSON object (docs/volume-scenes.md): for a volume file (read
// with NaN/Inf counted and set to 0) its format, voxel type, dims, spacing, world bounds,
// placement, value range, percentiles, background, histogram, non-finite count and the preset
// auto picks; for a scene every object's world bounds, the lights, the camera and whether it was
// fitted. Throws sombra::Error "FILE: FIELD: what" as load_volume and load_scene do.
std::string volume_info_json(const std::string& path, const std::string& grid = "");
std::string scene_info_json(const std::string& path);

// Whether a path names a scene file: a .json file that is not a raw volume's header (an object
// with a "raw" key, data/README.md "Raw volumes"). Anything else is read as a volume.
bool is_scene_file(const std::string& path);

// 4×4 row-major helpers for VolumeInstance::transform and MeshInstance::transform.
std::array<float, 16> make_transform(const Vec3& translate, const Vec3& rotate_deg_xyz, const Vec3& scale);

}  // namespace sombra
