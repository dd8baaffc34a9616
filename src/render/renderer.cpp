// sombra — the camera pass on the host, and the shadow queries that share its preparation. The
// shadow technique is a module (src/techniques/technique.h): this file names none.
#include <chrono>
#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "host/kernel_args.h"
#include "host/tiled_launch.h"
#include "render/preparation.h"
#include "shadows/dsm_builder.h"  // volume_pass_defines
#include "shadows/sat_update.h"  // volume_data_key
#include "sombra/error.h"
#include "sombra/render.h"

namespace sombra {
namespace pipeline {
namespace {

using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point start) {
    return std::chrono::duration<double, std::milli>(clock_type::now() - start).count();
}

// What a light's shadow data depend on: where it is and how it shines (not its colour,
// intensity or attenuation, which only shading reads).
std::string light_view_key(const Light& l) {
    std::ostringstream key;
    key.precision(9);
    key << int(l.type) << ' ' << l.cone_angle_deg;
    for (float f : l.position) key << ' ' << f;
    for (float f : l.direction) key << ' ' << f;
    return key.str();
}

// Everything the prepared scene depends on except the lights, in parts (preparation.h SceneKeys):
// volumes (identity, size, a sample of their voxels, placement, transfer function, step,
// material), meshes, the number of lights and of their views, and the options that shape the
// device data (the technique adds its own) — not the camera, the image size or the shading options.
SceneKeys scene_keys(const Scene& scene, const RenderOptions& o, bool use_images, const techniques::ShadowModule& technique, int lanes) {
    SceneKeys keys;
    std::ostringstream materials, meshes, options;
    for (std::ostringstream* s : {&materials, &meshes, &options}) s->precision(9);
    for (const VolumeInstance& vi : scene.volumes) {
        std::ostringstream placement, content;
        placement.precision(9), content.precision(9);
        const Volume& v = *vi.volume;
        placement << v.dims[0] << ' ' << v.dims[1] << ' ' << v.dims[2];
        for (float f : vi.transform) placement << ' ' << f;
        for (float f : vi.spacing) placement << ' ' << f;
        for (float f : vi.clip_min) placement << ' ' << f;
        for (float f : vi.clip_max) placement << ' ' << f;
        keys.volume_identity.push_back(shadows::volume_identity(v));
        content << shadows::volume_sample_key(v);
        for (auto& c : vi.transfer_function.color_points) content << ' ' << c.x << ' ' << c.r << ' ' << c.g << ' ' << c.b;
        for (auto& a : vi.transfer_function.opacity_points) content << ' ' << a.x << ' ' << a.alpha;
        content << ' ' << vi.step_voxels << ' ' << vi.opacity_unit;
        materials << ' ' << vi.material.ambient << ' ' << vi.material.diffuse << ' ' << vi.material.specular << ' ' << vi.material.shininess;
        keys.volume_placement.push_back(placement.str());
        keys.volume_content.push_back(content.str());
    }
    std::ostringstream mesh_identity;
    for (const MeshInstance& mi : scene.meshes) {  // by identity: meshes are immutable once shared
        mesh_identity << "M" << static_cast<const void*>(mi.mesh.get()) << ' ';
        const Mesh& mesh = *mi.mesh;  // and a sample of their corners (auto's choices key by content)
        static_assert(sizeof(mesh.positions[0]) == 3 * sizeof(float), "positions are packed floats");
        meshes << "M " << mesh.positions.size() << ' ' << mesh.triangles.size() << ' ' << mesh.normals.size() << ' '
               << shadows::sampled_checksum(mesh.positions.empty() ? nullptr : mesh.positions[0].data(), 3 * mesh.positions.size());
        for (float f : mi.transform) meshes << ' ' << f;
        const MeshMaterial& m = mi.material;
        meshes << ' ' << m.color[0] << ' ' << m.color[1] << ' ' << m.color[2] << ' ' << m.opacity << ' ' << m.phong.ambient << ' '
               << m.phong.diffuse << ' ' << m.phong.specular << ' ' << m.phong.shininess;
    }
    options << " L";
    for (const Light& l : scene.lights) options << ' ' << (l.type == LightType::Point ? 6 : 1);  // views per light
    options << " O" << use_images << " T";
    technique.add_key(o, lanes, options);
    keys.materials = materials.str(), keys.mesh_identity = mesh_identity.str(), keys.meshes = meshes.str(), keys.options = options.str();
    return keys;
}

// With fragments: the surface lookups' per-light bias distances (they follow the lights).
void upload_surface_bias(host::Runtime& runtime, const Scene& scene, PreparedScene& p) {
    if (!surfaces::has_fragments(scene)) return;
    std::vector<float> bias = surface_bias_distances(p);
    p.surface_bias = host::make_buffer(runtime, CL_MEM_READ_ONLY, bias.size() * sizeof(float), bias.data(), "surface bias");
}

// Packs the lights, lets the technique lay out its per-light data in them, uploads them.
void upload_lights(host::Runtime& runtime, const Scene& scene, const RenderOptions& options, PreparedScene& p,
                   techniques::ShadowModule& technique) {
    p.packed.lights = packing::pack_lights(scene);
    technique.plan_lights(scene, p.packed, options);
    if (!p.packed.lights.empty())  // OpenCL forbids writing 0 bytes
        runtime.queue().enqueueWriteBuffer(p.device.lights, CL_TRUE, 0, p.packed.lights.size() * sizeof(LightGpu),
                                           p.packed.lights.data());
    upload_surface_bias(runtime, scene, p);
}

std::unique_ptr<PreparedScene> prepare_anew(host::Runtime& runtime, const Scene& scene, const RenderOptions& options,
                                            bool use_images, techniques::ShadowModule& technique, RenderStats& stats) {
    auto prepared = std::make_unique<PreparedScene>();
    auto start = clock_type::now();
    prepared->packed = packing::pack_scene(scene);
    technique.plan_lights(scene, prepared->packed, options);
    stats.stage_ms["host_prepare"] = ms_since(start);
    prepared->use_images = use_images;
    prepared->device = packing::upload_scene(runtime, scene, prepared->packed, use_images);
    stats.stage_ms["upload"] = prepared->device.upload_ms;
    if (surfaces::has_fragments(scene)) {
        prepared->packed_surfaces = surfaces::pack_surfaces(scene);
        prepared->surfaces = surfaces::upload_surfaces(runtime, prepared->packed_surfaces);
        upload_surface_bias(runtime, scene, *prepared);
    }
    return prepared;
}

}  // namespace

// -D defines for the camera pass: what this scene and these options need, nothing more.
std::vector<std::string> camera_pass_defines(const Scene& scene, const RenderOptions& options, const Prepared& p, int lanes,
                                             bool surface_cache, bool mark_shadow_cache) {
    std::vector<std::string> defines = shadows::volume_pass_defines(scene, p.scene.use_images, options.empty_space_skipping);
    defines.push_back("SOMBRA_LANES=" + std::to_string(lanes));
    defines.push_back("SOMBRA_LIGHT_SLOTS=" + std::to_string(std::max<std::size_t>(scene.lights.size(), 1)));
    if (options.gradient == GradientMethod::Sobel) defines.push_back("SOMBRA_SOBEL");
    if (!scene.lights.empty()) defines.push_back("SOMBRA_HAS_LIGHTS");
    if (options.shading == ShadingModel::Scattering) defines.push_back("SOMBRA_SCATTERING");
    if (surfaces::has_fragments(scene)) defines.push_back("SOMBRA_HAS_MESHES");
    p.technique.add_defines(scene, options, defines);
    if (mark_shadow_cache) defines.push_back("SOMBRA_SHADOW_CACHE_MARK");
    if (surface_cache) defines.push_back("SOMBRA_SURFACE_SHADOW_CACHE");
    return defines;
}

// The arguments render.cl's kernels share (SCENE_PARAMS, cl/scene_refs.h).
void bind_scene(host::KernelArgs& args, const PreparedScene& p, const cl::Buffer& camera) {
    if (p.use_images) args("volume_data", p.device.voxel_image);
    else args("volume_data", p.device.voxel_buffer);
    args("occupancy", p.device.occupancy)("tf_tables", p.device.tf_tables)("volumes", p.device.volumes)("lights", p.device.lights);
    args("camera", camera);
}

int check_light(const Scene& scene, int light_index) {
    if (light_index < 0 || light_index >= int(scene.lights.size()))
        throw Error("--light: the scene has " + std::to_string(scene.lights.size()) + " lights; " +
                    std::to_string(light_index) + " is not one of them");
    return light_index;
}

// The prepared scene of the last call when nothing it depends on changed (a moved camera
// rebuilds nothing), with the technique told which lights moved; else a new one. The module is
// kept while the technique's family is (dsm and shadowmap share maps, the SAT techniques tables).
Prepared prepare(Context& context, const Scene& scene, const RenderOptions& options, RenderStats& stats, int only_light) {
    host::Runtime& runtime = context.runtime();
    detail::KeptScenes& kept = context.kept_scenes();
    check_render_options(options);
    validate_scene(scene, scene.source);
    bool use_images = options.volume_storage == VolumeStorage::Image ||
                      (options.volume_storage == VolumeStorage::Auto && runtime.info().is_gpu);
    auto family = scene.lights.empty() ? techniques::make_no_shadows : techniques::entry(options.shadows).make;
    if (kept.technique_family != family || !kept.technique) {  // free the old device data before allocating the new
        kept = detail::KeptScenes();
        kept.technique = techniques::make_module(scene, options.shadows);
        kept.technique_family = family;
    }
    techniques::ShadowModule& technique = *kept.technique;
    RankExchange* exchange = context.rank_exchange();
    if (exchange && !technique.crosses_ranks())
        throw Error(std::string("--shadows ") + shadow_technique_name(options.shadows) +
                    ": a distributed render exchanges deep shadow maps between ranks; use dsm, shadowmap or none");
    SceneKeys keys = scene_keys(scene, options, use_images, technique, host::packet_lanes(runtime, options.lanes));
    std::string key = keys.whole();
    std::vector<std::string> light_keys;
    for (const Light& l : scene.lights) light_keys.push_back(light_view_key(l));
    std::vector<bool> needed(scene.lights.size(), true);
    if (only_light >= 0) needed.assign(scene.lights.size(), false), needed.at(std::size_t(only_light)) = true;
    if (kept.prepared && kept.prepared->key == key) {
        PreparedScene& p = *kept.prepared;
        std::vector<bool> moved(light_keys.size());
        for (std::size_t i = 0; i < light_keys.size(); ++i) moved[i] = light_keys[i] != p.light_keys[i];
        stats.reused_preparation = true;
        auto start = clock_type::now();
        upload_lights(runtime, scene, options, p, technique);
        stats.stage_ms["host_prepare"] = ms_since(start);
        technique.update_lights({runtime, scene, p.packed, p.packed_surfaces, p.device, options, p.use_images, &needed, exchange}, moved,
                                stats);
        p.light_keys = light_keys;
    } else {
        kept.prepared.reset();  // the shadow cache stays: its entries have their own keys
        std::unique_ptr<PreparedScene> fresh = prepare_anew(runtime, scene, options, use_images, technique, stats);
        fresh->key = key;
        fresh->keys = keys;
        fresh->light_keys = light_keys;
        try {
            technique.prepare(
                {runtime, scene, fresh->packed, fresh->packed_surfaces, fresh->device, options, fresh->use_images, &needed, exchange}, stats);
        } catch (...) {
            kept = detail::KeptScenes();  // nothing half-built stays for the next call
            throw;
        }
        kept.prepared = std::move(fresh);
    }
    const PreparedScene& p = *kept.prepared;
    technique.refresh({runtime, scene, p.packed, p.packed_surfaces, p.device, options, p.use_images, &needed}, stats);
    technique.add_stats(stats);
    return {p, technique};
}

namespace {

// shadow_probe (render.cl, one lane): the shadow term towards `light` at `count` world points,
// always evaluated by the technique (never the cache); returns the kernel's time in ms.
double run_shadow_probe(host::Runtime& runtime, const Scene& scene, const Prepared& prepared, const RenderOptions& options,
                        int light, const cl::Buffer& points, std::size_t count, const cl::Buffer& out) {
    CameraGpu camera = packing::pack_camera(scene, scene.width, scene.height);
    camera.jitter_seed = options.jitter_seed;
    cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
    cl::Kernel kernel(runtime.program("render.cl", camera_pass_defines(scene, options, prepared, 1)), "shadow_probe");
    host::KernelArgs args(kernel);
    bind_scene(args, prepared.scene, camera_buffer);
    args("light_index", cl_uint(light))("points", points)("transmittance", out);
    prepared.technique.bind(args, runtime, options);
    args.done();
    return host::run_tiled(runtime, kernel, cl::NDRange(count), cl::NullRange);
}

}  // namespace
}  // namespace pipeline

std::string RenderStats::to_json() const {
    nlohmann::json j;
    j["device"] = device;
    j["width"] = width;
    j["height"] = height;
    j["samples"] = samples;
    j["msamples_per_s"] = msamples_per_s;
    j["stage_ms"] = stage_ms;
    j["reused_preparation"] = reused_preparation;
    j["programs"] = {{"compiled", programs_compiled}, {"loaded_from_cache", programs_loaded}};
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
        if (!dsm_clusters.empty() || !dsm_ignored_objects.empty()) {
            nlohmann::json lights = nlohmann::json::array();
            for (const auto& ignored : dsm_ignored_objects) lights.push_back({{"ignored", ignored}, {"clusters", nlohmann::json::array()}});
            for (const Cluster& c : dsm_clusters) {
                nlohmann::json views = nlohmann::json::array();
                for (const ClusterView& v : c.views) {
                    nlohmann::json view = {{"projection", v.orthographic ? "orthographic" : "perspective"}, {"near", v.near}, {"far", v.far}};
                    if (v.orthographic) view["half_width"] = v.half_width, view["half_height"] = v.half_height;
                    else view["fov_x_deg"] = v.fov_x_deg, view["fov_y_deg"] = v.fov_y_deg;
                    views.push_back(view);
                }
                lights[std::size_t(c.light)]["clusters"].push_back({{"members", c.members}, {"views", views}});
            }
            j["dsm"]["lights"] = lights;
        }
    }
    if (sat_tables > 0) {
        j["sat"] = {{"tables", sat_tables}, {"bytes", sat_bytes}, {"tables_built", sat_tables_built}, {"tables_reused", sat_tables_reused}};
        j["sat"]["per_table"] = nlohmann::json::array();
        for (const SatTable& t : sat_table_list)
            j["sat"]["per_table"].push_back({{"kind", t.kind}, {"lights", t.lights}, {"volumes", t.volumes}, {"cells", t.cells},
                                             {"cell_voxels", t.cell_voxels},
                                             {"bytes", t.bytes}, {"build_ms", t.build_ms}, {"reused", t.reused}});
    }
    if (shadow_cache_points_to_fill > 0 || shadow_cache_used || shadow_cache_surface_points > 0) {
        j["shadow_cache"] = {{"used", shadow_cache_used},
                             {"bytes", shadow_cache_bytes},
                             {"entries_built", shadow_cache_entries_built},
                             {"entries_reused", shadow_cache_entries_reused},
                             {"points_to_fill", shadow_cache_points_to_fill},
                             {"visible_fill", shadow_cache_visible_fill},
                             {"points_marked", shadow_cache_points_marked},
                             {"light_lattices", shadow_cache_light_lattices}};
        if (shadow_cache_probe_ms > 0 || shadow_cache_auto_remembered || shadow_cache_auto_history)
            j["shadow_cache"]["auto"] = {{"remembered", shadow_cache_auto_remembered},
                                         {"from_history", shadow_cache_auto_history},
                                         {"marked", shadow_cache_auto_marked},
                                         {"history_on_ms", shadow_cache_history_on_ms},
                                         {"history_off_ms", shadow_cache_history_off_ms},
                                         {"probe_ms", shadow_cache_probe_ms},
                                         {"pixels_kept", shadow_cache_probe_pixels_kept},
                                         {"estimated_fill_ms", shadow_cache_estimated_fill_ms},
                                         {"estimated_cached_camera_pass_ms", shadow_cache_estimated_cached_ms},
                                         {"estimated_per_sample_camera_pass_ms", shadow_cache_estimated_per_sample_ms},
                                         {"estimated_marked_share", shadow_cache_estimated_marked_share},
                                         {"estimated_marked_fill_ms", shadow_cache_estimated_marked_fill_ms},
                                         {"estimated_marked_points_per_sample", shadow_cache_estimated_marked_points_per_sample}};
        for (const ProbeStage& stage : shadow_cache_probe_stages)
            j["shadow_cache"]["auto"]["stages"].push_back(
                {{"quantity", stage.quantity}, {"stage", stage.stage}, {"ms", stage.ms}, {"estimate_ms", stage.estimate_ms}});
        if (shadow_cache_surface_points > 0)
            j["shadow_cache"]["surfaces"] = {{"used", shadow_cache_surfaces_used},
                                             {"points", shadow_cache_surface_points},
                                             {"entries_built", shadow_cache_surface_entries_built},
                                             {"entries_reused", shadow_cache_surface_entries_reused},
                                             {"points_to_fill", shadow_cache_surface_points_to_fill},
                                             {"estimated_fragments", shadow_cache_estimated_fragments}};
    }
    if (ranks > 0) {
        j["distributed"] = {{"rank", rank},
                            {"ranks", ranks},
                            {"region_volumes", region_volumes},
                            {"region_meshes", region_meshes},
                            {"region_voxels", region_voxels},
                            {"map_bytes_sent", map_bytes_sent},
                            {"map_bytes_received", map_bytes_received},
                            {"image_bytes_sent", image_bytes_sent},
                            {"peak_memory_bytes", peak_memory_bytes}};
        if (!rank_stats.empty()) {
            j["distributed"]["per_rank"] = nlohmann::json::array();
            for (const std::string& r : rank_stats) j["distributed"]["per_rank"].push_back(nlohmann::json::parse(r));
        }
    }
    return j.dump(2);
}


namespace pipeline {

CameraGpu frame_camera(const Scene& scene, const RenderOptions& options, int width, int height) {
    CameraGpu camera = packing::pack_camera(scene, width, height);
    camera.termination_transmittance = options.termination_transmittance;
    camera.jitter_seed = options.jitter_seed;
    camera.phase_g = options.phase_g;
    return camera;
}

// How many ways render_camera interleaves a launch's rows of groups (render.cl
// interleaved_launch_row): a CPU device's compute units (its threads); 1 on a GPU, and without
// packets, whose launches leave the group size to the device (Intel's CPU runtime then makes the
// last group smaller, where the interleave needs groups of one size).
cl_uint camera_row_interleave(host::Runtime& runtime, int lanes) {
    if (runtime.camera_row_interleave() > 0) return cl_uint(runtime.camera_row_interleave());
    if (runtime.info().is_gpu || lanes <= 1) return 1u;
    return std::max<cl_uint>(1u, runtime.device().getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>());
}

double run_camera_pass(host::Runtime& runtime, const Scene& scene, const Prepared& prepared, const RenderOptions& options, int lanes,
                       const CameraGpu& camera, const CameraPassReads& reads, const cl::Buffer& image, const cl::Buffer& sample_counts,
                       RenderStats* stats) {
    cl::Buffer camera_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, sizeof(CameraGpu), &camera, "camera");
    auto build_start = std::chrono::steady_clock::now();
    cl::Program& program = runtime.program(
        "render.cl", camera_pass_defines(scene, options, prepared, lanes, reads.surface_cache != nullptr, reads.volume_cache_marks != nullptr));
    if (stats)
        stats->stage_ms["program_build"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - build_start).count();
    cl::Kernel kernel(program, "render_camera");
    host::KernelArgs args(kernel);
    bind_scene(args, prepared.scene, camera_buffer);
    args("image", image)("sample_counts", sample_counts)("row_interleave", camera_row_interleave(runtime, lanes));
    args("write_image_rows", cl_uint(reads.image_rows));
    args("rendered_packets", reads.rendered_packets ? *reads.rendered_packets : camera_buffer)("skip_rendered", cl_uint(reads.rendered_packets != nullptr));
    prepared.technique.bind(args, runtime, options);
    if (reads.volume_cache_marks) {
        args("shadow_cache_marks", *reads.volume_cache_marks)("shadow_cache_table", *reads.volume_cache_table);
    } else if (prepared.technique.has_shadow_term()) {
        // a program with a shadow term reads the volume lattices or not per launch
        // (shadow_cache_reads); a launch that does not binds the camera's buffer in their place,
        // never read
        const bool read_cache = reads.volume_cache != nullptr;
        args("shadow_cache", read_cache ? *reads.volume_cache : camera_buffer)("shadow_cache_table", read_cache ? *reads.volume_cache_table : camera_buffer);
        args("shadow_cache_reads", cl_uint(read_cache));
    }
    if (reads.surface_cache) args("surface_shadow_cache", reads.surface_cache->values)("surface_cache_triangles", reads.surface_cache->triangle_buffer);
    if (reads.fragments) {
        const PreparedScene& p = prepared.scene;
        args("fragment_first", reads.fragments->fragments.first)("fragments", reads.fragments->fragments.fragments);
        args("screen_triangles", reads.fragments->tiles.triangles)("surface_triangles", p.surfaces.triangles);
        args("surface_materials", p.surfaces.materials);
        args("surface_bias", p.surface_bias);
    }
    args.done();
    const cl_uint rows = (camera.height - std::min(camera.first_row, camera.height) + camera.row_stride - 1) / camera.row_stride;
    // a launch row's packets: every packet_stride-th of the image's (CameraGpu); a launch of packets
    // apart (auto's probe) in groups of one packet
    const cl_uint stride = std::max(camera.packet_stride, cl_uint(1)), packets = (camera.width + lanes - 1) / lanes;
    const bool spread = stride > 1 || camera.row_stride > 1;
    return host::run_packets(runtime, kernel, int((packets + stride - 1) / stride) * lanes, int(rows), lanes, 1, 0, spread ? 1 : host::kPacketGroupSide);
}

}  // namespace pipeline

RenderResult render(Context& context, const Scene& scene, const RenderOptions& options) {
    auto held = context.exclusive();  // one call at a time on a Context (sombra/device.h)
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
    const int compiled_before = runtime.programs_compiled(), loaded_before = runtime.programs_loaded();
    pipeline::Prepared prepared = pipeline::prepare(context, scene, options, stats);

    surfaces::ViewFragments fragments;
    if (surfaces::has_fragments(scene)) {  // the camera view's fragments (Knecht §3.1: raster → segments); SURFACE_PARAMS
        fragments = surfaces::view_fragments(runtime, scene, raster::camera_view(scene.camera, width, height));
        stats.stage_ms["camera_raster"] = fragments.tiles.stats.count_ms + fragments.tiles.stats.write_ms;
        stats.stage_ms["camera_fragments"] = fragments.fragments.stats.count_ms + fragments.fragments.stats.write_ms;
    }
    // the shadow cache is filled first: its fill binds the technique's per-call buffers anew
    const std::size_t pixels = std::size_t(width) * std::size_t(height);
    pipeline::FrameImage frame{host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_float4), nullptr, "image"),
                               host::make_buffer(runtime, CL_MEM_WRITE_ONLY, pixels * sizeof(cl_uint), nullptr, "sample counts"), {}};
    const pipeline::ShadowCache* cache = pipeline::shadow_cache_for_frame(context, scene, prepared, options, width, height, lanes,
                                                                          surfaces::has_fragments(scene) ? &fragments : nullptr, frame, stats);
    bool cached = cache && cache->volumes_used, surfaces_cached = cache && cache->surfaces_used;

    const CameraGpu camera = pipeline::frame_camera(scene, options, width, height);
    const cl::Buffer &image_buffer = frame.image, &count_buffer = frame.sample_counts;
    pipeline::CameraPassReads reads;
    if (frame.rendered_packets) reads.rendered_packets = &*frame.rendered_packets;  // auto's probe's per-sample pixels, kept
    if (surfaces::has_fragments(scene)) reads.fragments = &fragments;
    if (cached) reads.volume_cache = &cache->values, reads.volume_cache_table = &cache->table;
    if (surfaces_cached) reads.surface_cache = &cache->surfaces;
    double kernel_ms = host::in_stage(runtime.progress(), "camera pass", 1, [&] {
        return pipeline::run_camera_pass(runtime, scene, prepared, options, lanes, camera, reads, image_buffer, count_buffer, &stats);
    });
    stats.stage_ms["camera_pass"] = kernel_ms;
    pipeline::record_auto_history(context, stats);

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
    stats.programs_compiled = runtime.programs_compiled() - compiled_before;
    stats.programs_loaded = runtime.programs_loaded() - loaded_before;
    return result;
}

ShadowQuery shadow_transmittance(Context& context, const Scene& scene, int light_index, const std::vector<Vec3>& points,
                                 const RenderOptions& options) {
    auto held = context.exclusive();  // one call at a time on a Context (sombra/device.h)
    host::Runtime& runtime = context.runtime();
    pipeline::check_light(scene, light_index);
    if (!techniques::make_module(scene, options.shadows)->has_shadow_term())
        throw Error(std::string("--shadows: ") + shadow_technique_name(options.shadows) + " has no transmittance to query");
    host::ProgressScope progress(runtime.progress(), options.progress);
    ShadowQuery query;
    query.stats.device = runtime.info().name;
    pipeline::Prepared prepared = pipeline::prepare(context, scene, options, query.stats, light_index);  // that light's data only
    if (points.empty()) return query;
    std::vector<cl_float4> host_points;
    for (const Vec3& p : points) host_points.push_back({{p[0], p[1], p[2], 1.f}});
    cl::Buffer point_buffer = host::make_buffer(runtime, CL_MEM_READ_ONLY, host_points.size() * sizeof(cl_float4),
                                                host_points.data(), "points");
    cl::Buffer out = host::make_buffer(runtime, CL_MEM_WRITE_ONLY, points.size() * sizeof(float), nullptr, "transmittance");
    query.stats.stage_ms["shadow_probe"] =
        pipeline::run_shadow_probe(runtime, scene, prepared, options, light_index, point_buffer, points.size(), out);
    std::vector<float> values(points.size());
    runtime.queue().enqueueReadBuffer(out, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    query.transmittance.assign(values.begin(), values.end());
    return query;
}

}  // namespace sombra
