// sombra — the camera pass on the host, and the shadow queries that share its preparation.
#include <atomic>
#include <chrono>
#include <cstring>
#include <cmath>
#include <functional>
#include <numeric>
#include <sstream>

#include <nlohmann/json.hpp>

#include "host/tiled_launch.h"
#include "render/scene_upload.h"
#include "render/surfaces.h"
#include "shadows/dsm_builder.h"
#include "shadows/dsm_views.h"
#include "shadows/sat_grid.h"
#include "shadows/sat_update.h"
#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra {
namespace {

using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point start) {
    return std::chrono::duration<double, std::milli>(clock_type::now() - start).count();
}

const char* shadow_technique_name(ShadowTechnique t) {
    switch (t) {
        case ShadowTechnique::Lowpass: return "lowpass";
        case ShadowTechnique::Ao: return "ao";
        case ShadowTechnique::Cone: return "cone";
        default: return "this technique";
    }
}

bool uses_sat(const RenderOptions& o) {
    return o.shadows == ShadowTechnique::Lowpass || o.shadows == ShadowTechnique::Ao || o.shadows == ShadowTechnique::Cone;
}

// -D defines for the camera pass: what this scene and these options need, nothing more.
std::vector<std::string> camera_pass_defines(const Scene& scene, const RenderOptions& options, bool use_images,
                                             int lanes) {
    std::vector<std::string> defines = shadows::volume_pass_defines(scene, use_images, options.empty_space_skipping);
    defines.push_back("SOMBRA_LANES=" + std::to_string(lanes));
    defines.push_back("SOMBRA_LIGHT_SLOTS=" + std::to_string(std::max<std::size_t>(scene.lights.size(), 1)));
    if (options.gradient == GradientMethod::Sobel) defines.push_back("SOMBRA_SOBEL");
    if (!scene.lights.empty()) defines.push_back("SOMBRA_HAS_LIGHTS");
    if (options.shading == ShadingModel::Scattering) defines.push_back("SOMBRA_SCATTERING");
    if (!scene.lights.empty() && uses_sat(options) && options.lowpass_cache) defines.push_back("SOMBRA_LOWPASS_CACHED");
    if (surfaces::has_fragments(scene)) defines.push_back("SOMBRA_HAS_MESHES");
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Rays && surfaces::has_bounds(scene))
        defines.push_back("SOMBRA_HAS_BOUNDS");  // shadow rays cross the bounds (the other passes see their fragments)
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Rays) defines.push_back("SOMBRA_SHADOW_RAYS");
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Ao) defines.push_back("SOMBRA_LOWPASS_AO");
    if (!scene.lights.empty() && options.shadows == ShadowTechnique::Cone) defines.push_back("SOMBRA_LOWPASS_CONE");
    if (!scene.lights.empty() && uses_sat(options)) {
        defines.push_back("SOMBRA_SHADOW_LOWPASS");
        if (options.lowpass_filter_kernel == "gauss") defines.push_back("SOMBRA_LOWPASS_GAUSS");
        else if (options.lowpass_filter_kernel != "box")
            throw Error("--filter-kernel: must be box or gauss, got '" + options.lowpass_filter_kernel + "'");
    }
    bool maps = options.shadows == ShadowTechnique::Dsm || options.shadows == ShadowTechnique::ShadowMap;
    if (!scene.lights.empty() && maps) {
        defines.push_back("SOMBRA_SHADOW_DSM");
        if (options.shadows == ShadowTechnique::ShadowMap) defines.push_back("SOMBRA_SHADOW_BINARY");
        for (auto& d : memory::make_dsm_storage(options.dsm_storage)->defines()) defines.push_back(d);
    }
    return defines;
}

// Everything the kernels read, on the device: the packed scene, and the deep shadow maps when the
// shadow technique needs them (built only then).
struct PreparedScene {
    packing::PackedScene packed;
    packing::DeviceScene device;
    shadows::DeviceDsm dsm;
    shadows::DeviceSat sat;  // low-pass shadows: light-aligned summed-area tables
    surfaces::DeviceSurfaces surfaces;  // scenes with meshes
    surfaces::ShadowBvh shadow_bvh;     // shadow rays through meshes: the triangles' hierarchy
    surfaces::ShadowBvh bound_bvh;      // shadow rays through polyhedral bounds: theirs
    bool use_images = false, use_dsm = false, use_sat = false;
    std::uint64_t serial = 0;  // tells preparations apart (what is derived from one is kept with its serial)
    bool ray_meshes = false;  // shadow rays cross the mesh triangles (render.cl SOMBRA_SHADOW_RAY_MESHES)
};

// What a light's deep shadow maps depend on besides the volumes: where it is and how it shines
// (not its colour, intensity or attenuation, which only shading reads).
std::string light_view_key(const Light& l) {
    std::ostringstream key;
    key.precision(9);
    key << int(l.type) << ' ' << l.cone_angle_deg;
    for (float f : l.position) key << ' ' << f;
    for (float f : l.direction) key << ' ' << f;
    return key.str();
}

void copy_sat_stats(const shadows::DeviceSat& sat, RenderStats& stats) {
    stats.sat_tables = int(sat.frames.size());
    for (const SsatGridGpu& g : sat.spheres) stats.sat_tables += g.dims.s[3] != 0;
    stats.sat_bytes = sat.bytes;
}

// Everything the prepared scene depends on except the lights: volumes (identity, size, a sample
// of their voxels, placement, transfer function, step, material), the number of lights and of
// their views, and the options that shape the device data and the deep shadow maps — not the
// camera, the image size or the shading options.
std::string volumes_key(const Scene& scene, const RenderOptions& o, bool use_images, int dsm_lanes) {
    std::ostringstream key;
    key.precision(9);
    for (const VolumeInstance& vi : scene.volumes) {
        const Volume& v = *vi.volume;
        key << "V" << shadows::volume_data_key(v);
        for (float f : vi.transform) key << ' ' << f;
        for (float f : vi.spacing) key << ' ' << f;
        for (auto& c : vi.transfer_function.color_points) key << ' ' << c.x << ' ' << c.r << ' ' << c.g << ' ' << c.b;
        for (auto& a : vi.transfer_function.opacity_points) key << ' ' << a.x << ' ' << a.alpha;
        key << ' ' << vi.step_voxels << ' ' << vi.opacity_unit << ' ' << vi.material.ambient << ' ' << vi.material.diffuse
            << ' ' << vi.material.specular << ' ' << vi.material.shininess;
    }
    for (const MeshInstance& mi : scene.meshes) {  // by identity: meshes are immutable once shared
        key << "M" << static_cast<const void*>(mi.mesh.get());
        for (float f : mi.transform) key << ' ' << f;
        const MeshMaterial& m = mi.material;
        key << ' ' << m.color[0] << ' ' << m.color[1] << ' ' << m.color[2] << ' ' << m.opacity << ' ' << m.phong.ambient << ' '
            << m.phong.diffuse << ' ' << m.phong.specular << ' ' << m.phong.shininess;
    }
    key << " L";
    for (const Light& l : scene.lights) key << ' ' << (l.type == LightType::Point ? 6 : 1);  // views per light
    bool maps = o.shadows == ShadowTechnique::Dsm || o.shadows == ShadowTechnique::ShadowMap;  // one preparation
    key << " O" << (maps ? 99 : int(o.shadows)) << ' ' << o.dsm_resolution << ' ' << o.dsm_epsilon << ' ' << o.dsm_storage << ' '
        << o.dsm_precompression << ' ' << o.dsm_prefilter << ' ' << o.dsm_prefilter_jitter << ' ' << o.dsm_prefilter_seed << ' '
        << use_images << ' ' << o.lowpass_max_entries;
    if (maps) key << ' ' << dsm_lanes;  // same maps, but asking for other packets builds them so
    return key.str();  // the low-pass tables have their own keys (update_sat_tables)
}


void copy_dsm_stats(const memory::DsmStats& d, const std::string& storage, RenderStats& stats) {
    stats.dsm_views = d.views;
    stats.dsm_views_generated = d.views_generated;
    stats.dsm_storage = storage;
    stats.dsm_nodes = d.nodes;
    stats.dsm_mean_nodes_per_texel = d.mean_nodes_per_texel;
    stats.dsm_max_nodes_per_texel = d.max_nodes_per_texel;
    stats.dsm_bytes_used = d.bytes_used;
    stats.dsm_bytes_wasted = d.bytes_wasted;
    stats.dsm_capped_texels = d.capped_texels;
}

shadows::DsmBuildOptions dsm_build_options(const RenderOptions& o) {
    return {o.dsm_resolution, o.dsm_epsilon, o.dsm_storage, o.dsm_precompression, o.dsm_prefilter, o.dsm_prefilter_jitter,
            o.dsm_prefilter_seed, o.lanes};
}

PreparedScene prepare_anew(host::Runtime& runtime, const Scene& scene, const RenderOptions& options, RenderStats& stats);

// Regenerates, in `prepared`, the deep shadow maps of the lights marked in `changed` and uploads
// every light's shading parameters; the others' maps are kept (Knecht §3.2 "Deep Shadow Map
// Re-Generation": a DSM is rebuilt only when its light or the scene changed).
// Returns the number of views generated.
int update_lights(host::Runtime& runtime, const Scene& scene, const RenderOptions& options, const std::vector<bool>& changed,
                   PreparedScene& prepared, RenderStats& stats) {
    auto start = clock_type::now();
    prepared.packed.lights = packing::pack_lights(scene);
    std::vector<DsmViewGpu> views;
    if (prepared.use_dsm) views = shadows::make_dsm_views(scene, prepared.packed, options.dsm_resolution);
    if (!prepared.packed.lights.empty())  // OpenCL forbids writing 0 bytes
        runtime.queue().enqueueWriteBuffer(prepared.device.lights, CL_TRUE, 0,
                                           prepared.packed.lights.size() * sizeof(LightGpu), prepared.packed.lights.data());
    stats.stage_ms["host_prepare"] = ms_since(start);
    if (!prepared.use_dsm) return 0;
    std::vector<bool> regenerate(views.size(), false);
    bool any = false;
    for (std::size_t i = 0; i < scene.lights.size(); ++i) {
        const LightGpu& l = prepared.packed.lights[i];
        for (cl_uint v = l.view_first; v < l.view_first + l.view_count; ++v) regenerate[v] = changed[i];
        any = any || changed[i];
    }
    if (!any) return 0;
    // superseded nodes stay in the pools of the on-demand backends until the set is built anew
    if (prepared.dsm.storage->garbage_fraction() > 0.5)
        prepared.dsm = shadows::build_deep_shadow_maps(runtime, scene, prepared.packed, prepared.device, views,
                                                       dsm_build_options(options));
    else
        shadows::regenerate_deep_shadow_maps(runtime, scene, prepared.packed, prepared.device, views, dsm_build_options(options),
                                             prepared.dsm, regenerate);
    for (auto& [stage, ms] : prepared.dsm.stats.stage_ms) stats.stage_ms[stage] = ms;
    return prepared.dsm.stats.views_generated;
}

// Ament Alg. 1, first pass: rebuilds the low-pass tables whose inputs changed, keeps the others
// (shadows/sat_update.h); frees them when the technique needs none.
void update_sat_tables(host::Runtime& runtime, const Scene& scene, const RenderOptions& options, PreparedScene& p,
                       RenderStats& stats) {
    if (!p.use_sat) return shadows::release_sats(runtime);
    shadows::SatUpdateCounts counts;
    p.sat = shadows::update_sats(runtime, scene, p.packed, p.device, options.shadows == ShadowTechnique::Lowpass,
                                 options.lowpass_max_entries, counts);
    for (auto& [stage, ms] : p.sat.stage_ms) stats.stage_ms[stage] = ms;
    stats.sat_tables_built = counts.built, stats.sat_tables_reused = counts.reused;
    copy_sat_stats(p.sat, stats);
}

// The prepared scene of the last call when nothing it depends on changed (a moved camera
// rebuilds nothing: Knecht §3.2 "Deep Shadow Map Re-Generation"), with the maps of moved lights
// regenerated, else a new one.
std::shared_ptr<PreparedScene> prepare(host::Runtime& runtime, const Scene& scene, const RenderOptions& options,
                                       RenderStats& stats) {
    validate_scene(scene, scene.source);
    bool use_images = options.storage == VolumeStorage::Image ||
                      (options.storage == VolumeStorage::Auto && runtime.info().is_gpu);
    struct Kept {
        std::string key;
        std::vector<std::string> light_keys;
        std::shared_ptr<PreparedScene> prepared;
    };
    std::string key = volumes_key(scene, options, use_images, host::packet_lanes(runtime, options.lanes));
    std::vector<std::string> light_keys;
    for (const Light& l : scene.lights) light_keys.push_back(light_view_key(l));
    auto& slot = runtime.kept_state("renderer.prepared_scene");
    auto kept = std::static_pointer_cast<Kept>(slot);
    if (kept && kept->key == key) {
        std::vector<bool> changed(light_keys.size());
        for (std::size_t i = 0; i < light_keys.size(); ++i) changed[i] = light_keys[i] != kept->light_keys[i];
        stats.reused_preparation = true;
        int generated = update_lights(runtime, scene, options, changed, *kept->prepared, stats);
        kept->light_keys = light_keys;
        if (kept->prepared->use_dsm) {
            copy_dsm_stats(kept->prepared->dsm.stats, options.dsm_storage, stats);
            stats.dsm_views_generated = generated;
        }
        update_sat_tables(runtime, scene, options, *kept->prepared, stats);
        return kept->prepared;
    }
    slot.reset();  // free the old device data before allocating the new
    auto fresh = std::make_shared<Kept>();
    fresh->key = key;
    fresh->light_keys = light_keys;
    fresh->prepared = std::make_shared<PreparedScene>(prepare_anew(runtime, scene, options, stats));
    update_sat_tables(runtime, scene, options, *fresh->prepared, stats);
    slot = fresh;
    return fresh->prepared;
}

PreparedScene prepare_anew(host::Runtime& runtime, const Scene& scene, const RenderOptions& options, RenderStats& stats) {
    static std::atomic<std::uint64_t> next_serial{1};
    PreparedScene prepared;
    prepared.serial = next_serial++;
    auto start = clock_type::now();
    prepared.packed = packing::pack_scene(scene);
    prepared.use_dsm = (options.shadows == ShadowTechnique::Dsm || options.shadows == ShadowTechnique::ShadowMap) &&
                       !scene.lights.empty();
    std::vector<DsmViewGpu> views;
    if (prepared.use_dsm) views = shadows::make_dsm_views(scene, prepared.packed, options.dsm_resolution);
    stats.stage_ms["host_prepare"] = ms_since(start);

    prepared.use_images = options.storage == VolumeStorage::Image ||
                          (options.storage == VolumeStorage::Auto && runtime.info().is_gpu);
    prepared.device = packing::upload_scene(runtime, scene, prepared.packed, prepared.use_images);
    stats.stage_ms["upload"] = prepared.device.upload_ms;
    prepared.ray_meshes = options.shadows == ShadowTechnique::Rays && !scene.lights.empty() && surfaces::has_fragments(scene);
    if (surfaces::has_fragments(scene)) {
        surfaces::PackedSurfaces packed_surfaces = surfaces::pack_surfaces(scene);
        prepared.surfaces = surfaces::upload_surfaces(runtime, packed_surfaces);
        if (prepared.ray_meshes) {
            auto bvh_start = clock_type::now();
            prepared.shadow_bvh = surfaces::upload_shadow_bvh(runtime, packed_surfaces.triangles, "shadow-ray");
            if (!prepared.packed.bound_triangles.empty())
                prepared.bound_bvh = surfaces::upload_shadow_bvh(runtime, prepared.packed.bound_triangles, "volume bound");
            stats.stage_ms["bvh_build"] = ms_since(bvh_start);
        }
    }
    if (prepared.use_dsm) {
        prepared.dsm = shadows::build_deep_shadow_maps(runtime, scene, prepared.packed, prepared.device, views,
                                                       dsm_build_options(options));
        for (auto& [stage, ms] : prepared.dsm.stats.stage_ms) stats.stage_ms[stage] = ms;
        copy_dsm_stats(prepared.dsm.stats, options.dsm_storage, stats);
    }
    prepared.use_sat = uses_sat(options) && !scene.lights.empty();
    if (prepared.use_sat)  // the light-aligned tables are built over boxes: polyhedral bounds are not in them
        for (std::size_t i = 0; i < scene.volumes.size(); ++i)
            if (scene.volumes[i].bound.mesh)
                throw file_error(scene.source, "volumes[" + std::to_string(i) + "].bounds",
                                 std::string("polyhedral bounds are not supported by --shadows ") + shadow_technique_name(options.shadows));
    if (prepared.use_sat && runtime.device().getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() == 0)  // cl/lowpass.h reads corners in double
        throw Error("--shadows: the summed-area-table techniques need double precision, which " + runtime.info().name + " lacks");
    return prepared;
}

// The arguments render.cl's kernels share, in their order; returns the next argument index.
int set_scene_args(cl::Kernel& kernel, const PreparedScene& p, const cl::Buffer& camera) {
    int arg = 0;
    if (p.use_images) kernel.setArg(arg++, p.device.voxel_image);
    else kernel.setArg(arg++, p.device.voxel_buffer);
    kernel.setArg(arg++, p.device.occupancy);
    kernel.setArg(arg++, p.device.tf_tables);
    kernel.setArg(arg++, p.device.volumes);
    kernel.setArg(arg++, p.device.lights);
    kernel.setArg(arg++, camera);
    return arg;
}

int set_dsm_args(cl::Kernel& kernel, int arg, const PreparedScene& p) {
    if (!p.use_dsm) return arg;
    kernel.setArg(arg++, p.dsm.views_buffer);
    return p.dsm.storage->bind_for_reading(kernel, arg);
}

// The low-pass tables and their per-light grids (with this call's filter width); keeps the
// grid buffers alive in `grids`.
int set_sat_args(host::Runtime& runtime, cl::Kernel& kernel, int arg, const PreparedScene& p, const RenderOptions& o,
                 shadows::SatGridBuffers& grids) {
    if (!p.use_sat) return arg;
    if (!(o.lowpass_filter_width >= 0.f && o.lowpass_filter_width <= 4096.f))
        throw Error("--filter: the filter width must lie in [0, 4096] voxels");
    if (!(o.cone_angle_deg > 0.f && o.cone_angle_deg <= 60.f)) throw Error("--cone-angle: must lie in (0, 60] degrees");
    grids = shadows::upload_sat_grids(runtime, p.sat, o.lowpass_filter_width, o.cone_angle_deg);
    kernel.setArg(arg++, p.sat.data);
    kernel.setArg(arg++, grids.cartesian);
    kernel.setArg(arg++, grids.spherical);
    return arg;
}

// Shadow rays in a scene with meshes: the world-space triangles (opacity in corner.w) in BVH order,
// the hierarchy's nodes and their count; with polyhedral volume bounds, the bound triangles
// (render.cl BOUND_PARAMS).
int set_shadow_mesh_args(cl::Kernel& kernel, int arg, const PreparedScene& p) {
    if (p.ray_meshes) {
        kernel.setArg(arg++, p.shadow_bvh.triangles);
        kernel.setArg(arg++, p.shadow_bvh.nodes);
        kernel.setArg(arg++, p.shadow_bvh.node_count);
    }
    if (p.ray_meshes && !p.packed.bound_triangles.empty()) {
        kernel.setArg(arg++, p.bound_bvh.triangles);
        kernel.setArg(arg++, p.bound_bvh.nodes);
        kernel.setArg(arg++, p.bound_bvh.node_count);
    }
    return arg;
}

int check_light(const Scene& scene, int light_index) {
    if (light_index < 0 || light_index >= int(scene.lights.size()))
        throw Error("--light: the scene has " + std::to_string(scene.lights.size()) + " lights; " +
                    std::to_string(light_index) + " is not one of them");
    return light_index;
}

}  // namespace

std::string RenderStats::to_json() const {
    nlohmann::json j;
    j["device"] = device;
    j["width"] = width;
    j["height"] = height;
    j["samples"] = samples;
    j["msamples_per_s"] = msamples_per_s;
    j["stage_ms"] = stage_ms;
    j["reused_preparation"] = reused_preparation;
    if (dsm_views > 0) {
        j["dsm"] = {{"views", dsm_views},
                    {"nodes", dsm_nodes},
                    {"mean_nodes_per_texel", dsm_mean_nodes_per_texel},
                    {"max_nodes_per_texel", dsm_max_nodes_per_texel},
                    {"bytes_used", dsm_bytes_used},
                    {"bytes_wasted", dsm_bytes_wasted},
                    {"capped_texels", dsm_capped_texels},
                    {"views_generated", dsm_views_generated},
                    {"storage", dsm_storage}};
    }
    if (sat_tables > 0)
        j["sat"] = {{"tables", sat_tables}, {"bytes", sat_bytes}, {"shadow_cache_bytes", shadow_cache_bytes},
                    {"tables_built", sat_tables_built}, {"tables_reused", sat_tables_reused},
                    {"cache_entries_built", shadow_cache_entries_built}, {"cache_entries_reused", shadow_cache_entries_reused}};
    return j.dump(2);
}

namespace {

// shadow_probe (render.cl, one lane): the shadow term towards `light` at `count` world points;
// returns the kernel's time in ms. Always the uncached evaluation.
double run_shadow_probe(host::Runtime& runtime, const Scene& scene, const PreparedScene& prepared, const RenderOptions& options,
                        int light, const cl::Buffer& points, std::size_t count, const cl::Buffer& out) {
    CameraGpu camera = packing::pack_camera(scene, scene.width, scene.height);
    camera.jitter_seed = options.jitter_seed;
    cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
    RenderOptions probe_options = options;
    probe_options.lowpass_cache = false;
    cl::Kernel kernel(runtime.program("render.cl", camera_pass_defines(scene, probe_options, prepared.use_images, 1)),
                      "shadow_probe");
    int arg = set_scene_args(kernel, prepared, camera_buffer);
    kernel.setArg(arg++, cl_uint(light));
    kernel.setArg(arg++, points);
    kernel.setArg(arg++, out);
    shadows::SatGridBuffers sat_grids;
    set_shadow_mesh_args(kernel, set_sat_args(runtime, kernel, set_dsm_args(kernel, arg, prepared), prepared, probe_options, sat_grids),
                         prepared);
    return host::run_tiled(runtime, kernel, cl::NDRange(count), cl::NullRange);
}

// Ament Alg. 1, first pass (updateShadowCache): the shadow cache of the SAT techniques
// (ShadowCacheGpu), built by shadow_probe at each volume's lattice points for every light. Kept on
// the Context; an entry (volume × light) is rebuilt only when its key changed
// (shadows::shadow_cache_keys), the others stay in place.
struct ShadowCache {
    std::vector<ShadowCacheGpu> layout;
    std::vector<std::string> keys;  // per entry; empty: not built
    cl::Buffer values, table;
    std::size_t bytes = 0;
};

constexpr std::size_t kShadowCachePoints = std::size_t(1) << 21;  // per volume and light

std::array<int, 3> cache_lattice(const std::array<int, 3>& dims) {
    std::array<int, 3> n = dims;
    while (std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]) > kShadowCachePoints)
        for (int& a : n) a = std::max(1, (a + 1) / 2);
    return n;
}

// Entry (volume i, light m) of the cache: its lattice and its place in the values.
std::vector<ShadowCacheGpu> cache_layout(const Scene& scene) {
    std::vector<ShadowCacheGpu> table;
    std::size_t total = 0;
    for (const VolumeInstance& vi : scene.volumes) {
        std::array<int, 3> n = cache_lattice(vi.volume->dims);
        for (std::size_t m = 0; m < scene.lights.size(); ++m) {
            ShadowCacheGpu c{};
            for (int a = 0; a < 3; ++a) {
                c.dims.s[a] = n[std::size_t(a)];
                c.spacing.s[a] = n[std::size_t(a)] > 1 ? float(vi.volume->dims[std::size_t(a)] - 1) / float(n[std::size_t(a)] - 1) : 1.f;
            }
            c.offset = cl_uint(total);
            total += std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]);
            table.push_back(c);
        }
    }
    if (total > 0xffffffffull) throw Error("shadow cache: more than 2^32 entries");
    return table;
}

// World positions of a volume's lattice points (c: any of its entries).
std::vector<cl_float4> lattice_points(const ShadowCacheGpu& c, const std::array<float, 16>& m /* voxel to world, row-major */) {
    std::vector<cl_float4> points;
    for (int z = 0; z < c.dims.s[2]; ++z)
        for (int y = 0; y < c.dims.s[1]; ++y)
            for (int x = 0; x < c.dims.s[0]; ++x) {
                float v[3] = {x * c.spacing.s[0], y * c.spacing.s[1], z * c.spacing.s[2]};
                cl_float4 p{};
                for (int r = 0; r < 3; ++r) p.s[r] = m[std::size_t(4 * r)] * v[0] + m[std::size_t(4 * r + 1)] * v[1] + m[std::size_t(4 * r + 2)] * v[2] + m[std::size_t(4 * r + 3)];
                p.s[3] = 1.f;
                points.push_back(p);
            }
    return points;
}

std::shared_ptr<ShadowCache> shadow_cache(host::Runtime& runtime, const Scene& scene, const PreparedScene& prepared,
                                          const RenderOptions& options, RenderStats& stats) {
    std::vector<ShadowCacheGpu> layout = cache_layout(scene);
    std::vector<std::string> keys = shadows::shadow_cache_keys(
        scene, prepared.packed, prepared.sat, shadows::extinction_keys(scene, prepared.packed, prepared.use_images), options);
    auto& slot = runtime.kept_state("renderer.shadow_cache");
    auto cache = std::static_pointer_cast<ShadowCache>(slot);
    bool same_layout = cache && cache->layout.size() == layout.size() &&
                       std::equal(layout.begin(), layout.end(), cache->layout.begin(), [](const ShadowCacheGpu& a, const ShadowCacheGpu& b) {
                           return std::memcmp(&a, &b, sizeof(ShadowCacheGpu)) == 0;
                       });
    if (!same_layout) {  // other volumes or lights: a new cache
        slot.reset();
        cache = std::make_shared<ShadowCache>();
        cache->layout = layout;
        cache->keys.assign(layout.size(), std::string());
        std::size_t total = layout.empty() ? 0 : layout.back().offset + std::size_t(layout.back().dims.s[0]) * layout.back().dims.s[1] * layout.back().dims.s[2];
        cache->values = host::make_buffer(runtime, CL_MEM_READ_WRITE, std::max<std::size_t>(total, 1) * sizeof(float), nullptr, "shadow cache");
        cache->table = host::make_buffer(runtime, CL_MEM_READ_ONLY, std::max<std::size_t>(layout.size(), 1) * sizeof(ShadowCacheGpu),
                                         layout.empty() ? nullptr : layout.data(), "shadow cache table");
        cache->bytes = total * sizeof(float);
        slot = cache;
    }
    double ms = 0;
    std::size_t lights = scene.lights.size();
    // a unit per entry to build: those whose key changed
    host::ProgressStage stage(runtime.progress(), "shadow cache", double(std::inner_product(
        keys.begin(), keys.end(), cache->keys.begin(), std::size_t(0), std::plus<>(), std::not_equal_to<>())));
    for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
        std::vector<std::size_t> stale;
        for (std::size_t m = 0; m < lights; ++m)
            if (cache->keys[i * lights + m] != keys[i * lights + m]) stale.push_back(m);
        stats.shadow_cache_entries_reused += int(lights - stale.size());
        if (stale.empty()) continue;
        std::vector<cl_float4> points = lattice_points(layout[i * lights], prepared.packed.voxel_to_world[i]);
        cl::Buffer point_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, points.size() * sizeof(cl_float4), points.data(), "shadow cache points");
        cl::Buffer out = host::make_buffer(runtime, CL_MEM_READ_WRITE, points.size() * sizeof(float), nullptr, "shadow cache entries");
        for (std::size_t m : stale) {
            cache->keys[i * lights + m].clear();
            ms += run_shadow_probe(runtime, scene, prepared, options, int(m), point_buffer, points.size(), out);
            runtime.queue().enqueueCopyBuffer(out, cache->values, 0, layout[i * lights + m].offset * sizeof(float), points.size() * sizeof(float));
            runtime.queue().finish();
            cache->keys[i * lights + m] = keys[i * lights + m];
            ++stats.shadow_cache_entries_built;
        }
    }
    if (stats.shadow_cache_entries_built > 0) stats.stage_ms["shadow_cache"] = ms;
    return cache;
}

}  // namespace

RenderResult render(Context& context, const Scene& scene, const RenderOptions& options) {
    host::Runtime& runtime = context.runtime();
    int width = options.width > 0 ? options.width : scene.width;
    int height = options.height > 0 ? options.height : scene.height;
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        throw Error("--width/--height: must lie in [1, 16384]");
    int lanes = host::packet_lanes(runtime, options.lanes);

    host::ProgressScope progress(runtime.progress(), options.progress);
    RenderResult result;
    RenderStats& stats = result.stats;
    stats.device = runtime.info().name;
    stats.width = width, stats.height = height;
    std::shared_ptr<PreparedScene> kept = prepare(runtime, scene, options, stats);
    const PreparedScene& prepared = *kept;

    CameraGpu camera = packing::pack_camera(scene, width, height);
    camera.termination_transmittance = options.termination_transmittance;
    camera.jitter_seed = options.jitter_seed;
    if (!(options.phase_g > -1.f && options.phase_g < 1.f)) throw Error("--phase-g: must lie in (-1, 1)");
    camera.phase_g = options.phase_g;
    std::size_t pixels = std::size_t(width) * std::size_t(height);
    cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
    cl::Buffer image_buffer = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_float4), nullptr, "image");
    cl::Buffer count_buffer = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_uint), nullptr, "sample counts");

    auto build_start = clock_type::now();
    cl::Program& program = runtime.program("render.cl", camera_pass_defines(scene, options, prepared.use_images, lanes));
    stats.stage_ms["program_build"] = ms_since(build_start);
    cl::Kernel kernel(program, "render_camera");
    int arg = set_scene_args(kernel, prepared, camera_buffer);
    kernel.setArg(arg++, image_buffer);
    kernel.setArg(arg++, count_buffer);
    shadows::SatGridBuffers sat_grids;
    arg = set_sat_args(runtime, kernel, set_dsm_args(kernel, arg, prepared), prepared, options, sat_grids);
    std::shared_ptr<ShadowCache> cache;
    if (prepared.use_sat && options.lowpass_cache) {
        cache = shadow_cache(runtime, scene, prepared, options, stats);
        kernel.setArg(arg++, cache->values);
        kernel.setArg(arg++, cache->table);
        stats.shadow_cache_bytes = cache->bytes;
    }
    arg = set_shadow_mesh_args(kernel, arg, prepared);
    surfaces::ViewFragments fragments;
    if (surfaces::has_fragments(scene)) {  // the camera view's fragments (Knecht §3.1: raster → segments)
        fragments = surfaces::view_fragments(runtime, scene, raster::camera_view(scene.camera, width, height));
        stats.stage_ms["camera_raster"] = fragments.tiles.stats.count_ms + fragments.tiles.stats.write_ms;
        stats.stage_ms["camera_fragments"] = fragments.fragments.stats.count_ms + fragments.fragments.stats.write_ms;
        for (const cl::Buffer* b : std::initializer_list<const cl::Buffer*>{&fragments.fragments.first, &fragments.fragments.fragments, &fragments.tiles.triangles,
                                    &prepared.surfaces.triangles, &prepared.surfaces.materials})
            kernel.setArg(arg++, *b);
    }

    double kernel_ms = host::in_stage(runtime.progress(), "camera pass", 1, [&] { return host::run_packets(runtime, kernel, width, height, lanes); });
    stats.stage_ms["camera_pass"] = kernel_ms;

    result.image.width = width, result.image.height = height;
    result.image.background = scene.background;
    result.image.rgba.resize(pixels * 4);
    std::vector<cl_uint> counts(pixels);
    cl::Event event;
    runtime.queue().enqueueReadBuffer(image_buffer, CL_TRUE, 0, pixels * sizeof(cl_float4), result.image.rgba.data(), nullptr, &event);
    double readback_ms = host::Runtime::event_ms(event);
    runtime.queue().enqueueReadBuffer(count_buffer, CL_TRUE, 0, pixels * sizeof(cl_uint), counts.data(), nullptr, &event);
    stats.stage_ms["readback"] = readback_ms + host::Runtime::event_ms(event);
    for (cl_uint c : counts) stats.samples += c;
    stats.msamples_per_s = kernel_ms > 0 ? double(stats.samples) / (kernel_ms * 1e3) : 0.0;
    return result;
}

ShadowQuery shadow_transmittance(Context& context, const Scene& scene, int light_index, const std::vector<Vec3>& points,
                                 const RenderOptions& options) {
    host::Runtime& runtime = context.runtime();
    check_light(scene, light_index);
    host::ProgressScope progress(runtime.progress(), options.progress);
    if (options.shadows == ShadowTechnique::None) throw Error("--shadows: none has no transmittance to query");
    ShadowQuery query;
    query.stats.device = runtime.info().name;
    std::shared_ptr<PreparedScene> kept = prepare(runtime, scene, options, query.stats);
    const PreparedScene& prepared = *kept;
    if (points.empty()) return query;
    std::vector<cl_float4> host_points;
    for (const Vec3& p : points) host_points.push_back({{p[0], p[1], p[2], 1.f}});
    cl::Buffer point_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, host_points.size() * sizeof(cl_float4),
                                                host_points.data(), "points");
    cl::Buffer out = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, points.size() * sizeof(float), nullptr, "transmittance");
    query.stats.stage_ms["shadow_probe"] = run_shadow_probe(runtime, scene, prepared, options, light_index, point_buffer, points.size(), out);
    std::vector<float> values(points.size());
    runtime.queue().enqueueReadBuffer(out, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    query.transmittance.assign(values.begin(), values.end());
    return query;
}

std::vector<DeepShadowMap> build_deep_shadow_maps(Context& context, const Scene& scene, int light_index,
                                                  const RenderOptions& options, RenderStats* stats_out) {
    host::Runtime& runtime = context.runtime();
    check_light(scene, light_index);
    host::ProgressScope progress(runtime.progress(), options.progress);
    RenderOptions dsm_options = options;
    dsm_options.shadows = ShadowTechnique::Dsm;
    RenderStats stats;
    stats.device = runtime.info().name;
    std::shared_ptr<PreparedScene> kept = prepare(runtime, scene, dsm_options, stats);
    const PreparedScene& prepared = *kept;
    const LightGpu& light = prepared.packed.lights[std::size_t(light_index)];
    static const char* faces[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
    std::vector<DeepShadowMap> maps;
    for (cl_uint v = 0; v < light.view_count; ++v) {
        std::string name = "lights[" + std::to_string(light_index) + "]" + (light.view_count == 6 ? std::string(".") + faces[v] : "");
        const DsmViewGpu& view = prepared.dsm.views[light.view_first + v];
        maps.push_back(prepared.dsm.storage->read_back(runtime, view, light.view_first + v));
        maps.back().light_name = name;
    }
    if (stats_out) *stats_out = stats;
    return maps;
}

std::vector<DeepShadowMap> build_prefilter_sub_maps(Context& context, const Scene& scene, int light_index,
                                                    const RenderOptions& options) {
    host::Runtime& runtime = context.runtime();
    check_light(scene, light_index);
    RenderOptions scene_only = options;
    scene_only.shadows = ShadowTechnique::None;  // the scene on the device, no maps
    RenderStats stats;
    std::shared_ptr<PreparedScene> kept = prepare(runtime, scene, scene_only, stats);
    packing::PackedScene packed = kept->packed;
    std::vector<DsmViewGpu> views = shadows::make_dsm_views(scene, packed, options.dsm_resolution);
    shadows::SubPixelDsm sub =
        shadows::build_sub_pixel_maps(runtime, scene, packed, kept->device, views, dsm_build_options(options));
    const LightGpu& light = packed.lights[std::size_t(light_index)];
    std::vector<DeepShadowMap> maps;
    for (cl_uint v = light.view_first * sub.layout.maps; v < (light.view_first + light.view_count) * sub.layout.maps; ++v) {
        maps.push_back(sub.dsm.storage->read_back(runtime, sub.dsm.views[v], v));
        maps.back().light_name = "lights[" + std::to_string(light_index) + "].sub" + std::to_string(v);
    }
    return maps;
}

}  // namespace sombra
