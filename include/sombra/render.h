// sombra — rendering a scene into an image, with per-stage statistics.
#pragma once
#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "sombra/device.h"
#include "sombra/options.h"
#include "sombra/progress.h"
#include "sombra/scene.h"
#include "sombra/shadows.h"

namespace sombra {

enum class GradientMethod { CentralDifferences, Sobel };
enum class VolumeStorage { Auto, Buffer, Image };  // Auto: buffer on CPU devices, image on GPUs
// The shadow term of Knecht Eq. 3.9. None: 1 everywhere. Rays: the shadow-ray baseline, marching
// from every visible sample to every light over the same segments as the camera rays. Dsm: deep
// shadow maps built by ray casting from each light, compressed with error bound DsmOptions::epsilon.
// ShadowMap: the binary shadow-map baseline — per texel the depth where opacity reaches 1/2,
// lit before it and dark behind (2×2 percentage-closer filtering); taken from the same light
// rays as the DSM, so it costs what a DSM costs to build.
// Lowpass: low-pass filtered soft shadows (Ament et al. 2014): exp(−τ̄), τ̄ the optical depth
// box-filtered over SatOptions::filter_width × filter_width voxels across the light, read in
// constant time from a light-aligned summed-area table: a Cartesian one (CSAT) per group of
// orthodirectional directional lights, a spherical one (SSAT) per point or spot light.
// Ao, Cone: the baselines of Ament Table 1 (Schlegel et al. 2011) on one SAT aligned with the first
// volume: SAT ambient occlusion (mean σ in a cube of filter_width voxels around the
// sample; no direction, the same term for every light) and cone shadows (the cone of half angle
// cone_angle_deg towards each light as a series of growing cubes read from that SAT).
enum class ShadowTechnique { None, Rays, Dsm, ShadowMap, Lowpass, Ao, Cone };

// The techniques' names ("none", "rays", "dsm", "shadowmap", "lowpass", "ao", "cone"), from the
// registry of technique modules; parse_shadow_technique throws an Error naming --shadows (with a
// suggestion for a near miss) for any other name.
std::vector<std::string> shadow_technique_names();
const char* shadow_technique_name(ShadowTechnique technique);
const char* shadow_technique_summary(ShadowTechnique technique);  // one line: what it is
ShadowTechnique parse_shadow_technique(const std::string& name);

// Phong: local illumination from gradient normals (course slides; Knecht Eq. 3.9). Scattering:
// single scattering with shadows (Ament et al. 2014 Eq. 1–3): each sample scatters
// c·[k_a i_a + Σ_m 4π p(θ_m) i_m f_m T_m] towards the viewer, p the Henyey–Greenstein phase of
// asymmetry phase_g (0 isotropic, > 0 forward), scaled by 4π so isotropic scattering has unit gain.
enum class ShadingModel { Phong, Scattering };

// The shadow cache (the EG 2009 course's "3D texture caching", Ament et al. 2014 Alg. 1): per
// volume and light a lattice of the shadow term over the volume's voxels (at most 2^23 points,
// coarser for larger volumes), filled by the technique itself (DSM lookups, shadow rays, low-pass
// tables) and kept on the Context until that light, the scene's volumes or meshes, or the
// technique's options change; camera samples read it trilinearly. Surfaces evaluate the technique
// per fragment. On: always. Off: every sample evaluates the technique. Auto: on when the entries
// to fill have fewer lattice points than the volume samples this frame is estimated to take
// (kept entries cost nothing: a moved camera keeps the cache on).
enum class ShadowCacheMode { Auto, On, Off };
// Which lattice points a shadow cache fill evaluates: Visible, those the frame's samples read
// (a marking camera pass finds them; the same view again fills nothing, a frame from another
// view on the Context completes the lattice), or All, every point near a possibly visible brick
// at once (no marking pass). The images are the same.
enum class ShadowCacheFill { Visible, All };

// The deep-shadow-map storage backends ("atlas", "chunked", "chunked-ondemand", "compact"), from
// the backend registry (src/memory/dsm_storage.cpp): the values of DsmOptions::storage.
std::vector<std::string> dsm_storage_names();

// The deep-shadow-map options (techniques dsm and shadowmap; declared in
// src/techniques/deep_shadow_maps.cpp). Every one keys the maps except cluster_hysteresis.
struct DsmOptions {
    int resolution = 512;   // texels per side of every deep shadow map view
    float epsilon = 0.02f;  // compression error bound (Knecht Eq. 3.1)
    // What ε bounds: "absolute" (the nodes hold the opacity α = 1 − T, |α' − α| ≤ ε: where less
    // than ≈ ε of the light is left the map may be black) or "relative" (they hold the optical
    // depth τ = −ln T, |τ' − τ| ≤ ε: T' within a factor e^±ε of T wherever light is left, and
    // within e^ε − 1 ≈ ε absolutely; cl/shared/dsm_value.h). docs/deep-shadow-maps.md measures both.
    std::string error = "relative";
    // A factor on each volume's step for the rays from the light (the pre-compressed tables follow
    // it; the camera rays keep their step). Larger is faster and coarser along the light: on the
    // CT at 512², ε 0.01, 2 makes generation 1.55× faster for +14 % point error and +54 % image
    // error against the reference (bench/README.md). In [0.01, 16].
    float step = 1.f;
    // Storage backend: "atlas" (3D-texture-like atlas of layer blocks allocated per tile on
    // demand, Hadwiger §3.4 / Knecht Eq. 4.7–4.10), "chunked" (64-node chunks per 8×8 tile with
    // atomics and linked lists, Knecht Alg. 4.1), "chunked-ondemand" or "compact" (count, prefix
    // sum, write).
    std::string storage = "atlas";
    // How lookups read the maps: "packed" (after each build, every texel's nodes are copied into
    // one run, the compact layout; lookups of every storage then cost the same) or "native" (in
    // the storage's own layout, as Hadwiger and Knecht read them). Identical images.
    std::string lookup = "packed";
    // Pre-compressed visibility tables (Hadwiger §3.2): each step of a one-volume segment is
    // replaced by its precomputed, compressed visibility, so isosurfaces of step transfer
    // functions cast shadows from where they lie rather than from the next sample.
    bool precompression = false;
    // Pre-filtering (Lokovic–Veach; Hadwiger §3.1): "none", "box" (each texel averages 2×2
    // sub-pixel rays), "tent" (4×4 weighted 1 3 3 1 per axis) or "5tap" (the centre ½ and the 4
    // corners ⅛ each; cl/shared/prefilter.h), combined exactly and compressed again. With
    // prefilter_jitter, each sub-pixel ray lies at a hashed position (seeded by prefilter_seed)
    // in its own cell instead of the cell's centre.
    std::string prefilter = "none";
    bool prefilter_jitter = true;
    unsigned prefilter_seed = 1;
    // Clustered deep shadow maps (Knecht §3.4): per light at most `clusters` clusters of objects
    // near one another in light space (LiSPSM, Alg. 4.2), each with its own resolution² map
    // focused on its members; a lookup multiplies the clusters' transmittances (Eq. 3.12).
    // Objects that cannot shadow what the camera sees are left out. 0: off, else [1, 64].
    // cluster_distance: the threshold d0 in [0, 10] (0: automatic).
    int clusters = 0;
    float cluster_distance = 0.f;
    // Against popping when the clusters follow a moving camera (on a kept Context): the previous
    // frame's clusters stay while they hold the same objects and their largest member distance is
    // at most (1 + cluster_hysteresis) times that of the clusters found anew. In [0, 10].
    float cluster_hysteresis = 0.25f;
};

// The summed-area-table family (lowpass, ao, cone; declared in src/techniques/sat_shadows.cpp).
struct SatOptions {
    // Filter width W in voxels of the scene's finest volume (Ament §4.2.1: U = V = W/2); ao: the
    // cube side. Changing it rebuilds no table while W ≤ cells_across_patch.
    float filter_width = 3.f;
    // lowpass: the W × W patch spans at least this many table cells across the light: W > N coarsens
    // the CSAT and SSAT cells across the light to W/N voxels (fewer cells, a faster build; the box
    // filter's width grows by ≤ √(1 + 3/N²) − 1, 2.3 % at 8); ao: the cube of side W spans at least
    // N cells (W > N coarsens every cell to W/N voxels). 0: cells of the finest voxel whatever W.
    float cells_across_patch = 8.f;
    // "box" (Ament Eq. 11–13) or "gauss": a Gaussian with σ = W/4 over the W × W patch, as 5 × 5
    // sub-boxes of the same tables (Ament §4.3, Eq. 25).
    std::string filter_kernel = "box";
    // The tables of one CSAT frame or one point light (a table per group of volumes) hold at most
    // max_entries 64-bit entries together (cells coarsen beyond that; the default keeps them
    // ≤ 128 MiB).
    std::size_t max_entries = std::size_t(1) << 24;
    float cone_angle_deg = 10.f;  // cone: half angle of the cones
    // Arithmetic of the lookups' positions and weights (cl/lowpass.h): "auto" (double where the
    // device has cl_khr_fp64, else float), "double" (an error on a device without it) or "float".
    // The box sums are exact integers either way.
    std::string precision = "auto";
};

// The shadow-ray baseline (declared in src/techniques/rays.cpp).
enum class RayCacheLattice { Light, Volume };

struct RayOptions {
    // A factor on each volume's step for the shadow rays only (the camera rays keep theirs);
    // smaller is finer and slower. In [0.01, 16].
    float step = 1.f;
    // The shadow cache's lattices: Light (columns along each light's rays where the volume lies
    // to one side of the light, one march per column: src/render/shadow_cache_columns.cpp) or
    // Volume (the volume's voxel axes, one ray per point).
    RayCacheLattice cache_lattice = RayCacheLattice::Light;
};

// Every option's name, range, default and help: its declaration (sombra/options.h).
struct RenderOptions {
    int width = 0, height = 0;  // 0: the scene's size
    GradientMethod gradient = GradientMethod::CentralDifferences;
    ShadingModel shading = ShadingModel::Phong;
    float phase_g = 0.f;  // Henyey–Greenstein g in (−1, 1), ShadingModel::Scattering only
    ShadowTechnique shadows = ShadowTechnique::Dsm;  // deep shadow maps unless told (None: no shadows)
    ShadowCacheMode shadow_cache = ShadowCacheMode::Auto;  // every technique with a shadow term
    ShadowCacheFill shadow_cache_fill = ShadowCacheFill::Visible;
    VolumeStorage volume_storage = VolumeStorage::Auto;
    bool empty_space_skipping = true;
    float termination_transmittance = 1e-3f;  // early ray termination threshold on t_acc
    unsigned jitter_seed = 1;
    // Rays per work-item, marched together in OpenCL vector types (1, 4, 8 or 16), in the camera
    // pass, in DSM generation and in the low-pass tables' resampling (neighbouring pixels / texels
    // / table columns); 0 = auto: on CPU devices (PoCL runs them on the SIMD units) 8 in the camera
    // pass and the native float vector width in the light passes (16 with AVX-512, else 8), 1 on
    // GPUs. The maps and tables do not depend on it.
    int lanes = 0;
    DsmOptions dsm;
    SatOptions sat;
    RayOptions rays;
    // Reports of the call's long stages (sombra/progress.h); empty: silent. Must not throw.
    ProgressCallback progress;
};

// The options by key (sombra/options.h; "shadows", "dsm_resolution", …), values as text: the
// names of a Choice ("dsm", "sobel"), numbers, "true"/"false". An unknown key or a value the
// option's declaration refuses throws sombra::Error naming the key.
std::vector<std::string> render_option_values(const std::string& key);  // a Choice's names, in order
void set_render_option(RenderOptions& options, const std::string& key, const std::string& value);
std::string render_option_value(const RenderOptions& options, const std::string& key);
// Throws sombra::Error naming the key of the first option whose value its declaration refuses
// (render, shadow_transmittance and build_deep_shadow_maps call it first).
void check_render_options(const RenderOptions& options);
// The options of a scene file's "render" block (Scene::render_settings) over the defaults; an
// unknown key or a refused value throws "FILE: render.KEY: …". The CLI starts from them (its
// flags override), as the Python module does when no options object is given.
RenderOptions scene_render_options(const Scene& scene);
// One option given as a JSON value (`true`, `512`, `"dsm"`), as a scene file's "render" block and
// `sombra view`'s requests give them: an unknown key throws "WHERE: unknown key 'K'" (with a
// suggestion), a refused value "WHERE.KEY: …" (WHERE: "FILE: render", "options").
void set_render_option_json(RenderOptions& options, const std::string& key, const std::string& json_value, const std::string& where);

// Linear RGB + alpha (coverage = 1 − t_acc), background already composited into RGB.
struct Image {
    int width = 0, height = 0;
    std::vector<float> rgba;  // row-major, top row first
    // The background composited into rgba (render() sets the scene's): write_image takes it out
    // again for EXR, which holds premultiplied radiance over transparent black.
    Vec3 background{0, 0, 0};
};

struct RenderStats {
    std::string device;
    std::map<std::string, double> stage_ms;  // from OpenCL profiling events
    unsigned long long samples = 0;          // volume samples taken (all volumes)
    double msamples_per_s = 0;               // samples / camera-pass kernel time
    // OpenCL programs this call compiled from source, and loaded from the on-disk program cache
    // (SOMBRA_KERNEL_CACHE; a program built earlier in the process counts as neither)
    int programs_compiled = 0, programs_loaded = 0;
    // deep shadow maps (ShadowTechnique::Dsm): views, nodes, memory
    int dsm_views = 0;
    unsigned long long dsm_nodes = 0;
    double dsm_mean_nodes_per_texel = 0;
    unsigned dsm_max_nodes_per_texel = 0;
    unsigned long long dsm_bytes_used = 0, dsm_bytes_wasted = 0;
    unsigned long long dsm_capped_texels = 0;  // texels that hit the atlas layer cap
    int dsm_views_generated = 0;  // by this call: all views, those of the lights that moved, or none
    std::string dsm_storage;
    // clustered deep shadow maps (DsmOptions::clusters > 0): every light's clusters, their
    // members (object names as `sombra clusters` prints them) and focused views
    struct ClusterView {
        bool orthographic = false;
        double fov_x_deg = 0, fov_y_deg = 0;      // perspective
        double half_width = 0, half_height = 0;   // orthographic
        double near = 0, far = 0;                 // depths along the view from the light (its near plane)
    };
    struct Cluster {
        int light = 0;
        std::vector<std::string> members;
        std::vector<ClusterView> views;
    };
    std::vector<Cluster> dsm_clusters;
    std::vector<std::vector<std::string>> dsm_ignored_objects;  // per light: objects that miss B (shadow nothing seen)
    // low-pass shadows (ShadowTechnique::Lowpass): summed-area tables and their memory
    int sat_tables = 0;
    unsigned long long sat_bytes = 0;
    // each table: CSAT, SSAT or the baselines' volume-aligned SAT, the lights that read it, the
    // volumes it holds, its cells, their size in finest voxels (an SSAT's angles at its farthest
    // radius), its memory, and its build time this call (0 when kept)
    struct SatTable {
        std::string kind;
        std::vector<int> lights;
        std::vector<std::string> volumes;
        std::array<int, 3> cells{0, 0, 0};
        std::array<double, 3> cell_voxels{0, 0, 0};
        unsigned long long bytes = 0;
        double build_ms = 0;
        bool reused = false;
    };
    std::vector<SatTable> sat_table_list;
    // the shadow cache (ShadowCacheMode): whether this frame read it, its size, the lattice points
    // it had to fill (near possibly visible bricks), and what auto measured when it had to fill:
    // its small runs' kernel time and the frame's estimated fill, cached camera pass and per-sample
    // camera pass (ms); the volume lattices are read when kShadowCacheAutoMargin × (fill + cached) < per sample
    bool shadow_cache_used = false;
    unsigned long long shadow_cache_bytes = 0;
    unsigned long long shadow_cache_points_to_fill = 0;
    // the visible fill (ShadowCacheFill::Visible) ran its marking pass (stage "shadow_cache_mark"):
    // the lattice points the frame's samples read that were not filled yet, all of which it filled
    bool shadow_cache_visible_fill = false;
    unsigned long long shadow_cache_points_marked = 0;
    // entries on a light lattice (columns along the light's rays, RayCacheLattice::Light)
    int shadow_cache_light_lattices = 0;
    double shadow_cache_probe_ms = 0, shadow_cache_estimated_fill_ms = 0, shadow_cache_estimated_cached_ms = 0,
           shadow_cache_estimated_per_sample_ms = 0;
    // the share of the points to fill that auto estimated a marking pass would find, from marking
    // passes over sampled rows, before it decided whether to run that pass (−1: not estimated)
    double shadow_cache_estimated_marked_share = -1;
    // and the fill of those points, from the sampled rows' points filled on the probe's blocks
    // (light lattices) or from the per-sample pass (a technique that marches each point's path to
    // the light, on volume lattices) (−1: not estimated)
    double shadow_cache_estimated_marked_fill_ms = -1;
    // on such volume lattices, the marked points ÷ the frame's camera samples by which auto
    // estimated their fill: of the marking pass, else estimated from the sampled rows (−1: not
    // estimated)
    double shadow_cache_estimated_marked_points_per_sample = -1;
    // the pixels auto's probe rendered per sample that a frame then evaluating per sample kept
    // (the camera pass rendered the others)
    unsigned long long shadow_cache_probe_pixels_kept = 0;
    // With SOMBRA_AUTO_PROBE_ALL set, auto's probe runs every stage whatever the earlier ones
    // found, and reports each (bench/probe_accuracy.py): what it estimates ("fill",
    // "per_sample", "cached"), the stage ("blocks 2 every 64", "scout 1", "launch 3", …), the
    // stage's kernel time and the estimate of the whole after it.
    struct ProbeStage {
        std::string quantity, stage;
        double ms = 0, estimate_ms = 0;
    };
    std::vector<ProbeStage> shadow_cache_probe_stages;
    // auto made no new choice: this frame (scene, camera, size, options, device) was rendered
    // before in this process, and chose as then (forget_shadow_cache_choices); the estimates are then's
    bool shadow_cache_auto_remembered = false;
    // where auto's probe ran the visible fill's marking pass: "in probe" (after its first launch,
    // the later stages weighing the marked points' fill), "after probe", or "" (not marked)
    std::string shadow_cache_auto_marked;
    // auto chose without a probe, from the times earlier processes measured for this frame with
    // the cache on and off (ms, < 0: not measured; docs/shadows.md "Auto across processes")
    bool shadow_cache_auto_history = false;
    double shadow_cache_history_on_ms = -1, shadow_cache_history_off_ms = -1;
    // tables (CSAT, SSAT, volume-aligned SAT) and shadow cache entries (volume × light) built by
    // this call because their inputs changed, and kept from the previous call on the Context
    int sat_tables_built = 0, sat_tables_reused = 0;
    int shadow_cache_entries_built = 0, shadow_cache_entries_reused = 0;
    // the shadow cache's surface part (scenes with meshes): whether this frame's surface fragments
    // read it, its points (mesh triangle corners, shared corners once), for auto the points it had
    // to fill (points × lights whose entries are stale) against the surface fragments × lights the
    // frame shades at most, and its entries (one per light) built by this call and kept
    bool shadow_cache_surfaces_used = false;
    unsigned long long shadow_cache_surface_points = 0, shadow_cache_surface_points_to_fill = 0,
                       shadow_cache_estimated_fragments = 0;
    int shadow_cache_surface_entries_built = 0, shadow_cache_surface_entries_reused = 0;
    // true when the scene's device data of the previous call on this Context were reused (only
    // the camera, image size, shading options or lights changed); the deep shadow maps of lights
    // that did not move are reused too (dsm_views_generated counts those regenerated)
    bool reused_preparation = false;
    int width = 0, height = 0;
    // A distributed render (sombra/distributed.h): this rank of how many, its region's objects,
    // the bytes of compressed maps it sent to the others and received from them, of its partial
    // image sent to rank 0, and the process's peak resident memory; on rank 0, every rank's stats
    // as JSON, in rank order.
    int rank = -1, ranks = 0;
    int region_volumes = 0, region_meshes = 0;
    unsigned long long region_voxels = 0;
    unsigned long long map_bytes_sent = 0, map_bytes_received = 0, image_bytes_sent = 0, peak_memory_bytes = 0;
    std::vector<std::string> rank_stats;
    std::string to_json() const;
};

struct RenderResult {
    Image image;
    RenderStats stats;
};

RenderResult render(Context& context, const Scene& scene, const RenderOptions& options = {});

// The shadow cache's auto measures whether the cache pays for a frame, and remembers the choice
// for the process: the same frame (scene, camera, size, options, device) rendered again, on any
// Context, chooses the same and so renders the same image (measured times vary from run to run).
// This forgets the choices (up to 4096 are kept, the oldest dropped first): the next frames measure.
void forget_shadow_cache_choices();
// Auto reads the volume lattices when margin × (fill + cached camera pass) < per-sample camera
// pass: a close call evaluates per sample (no lattice error) and flips less from run to run.
constexpr double kShadowCacheAutoMargin = 1.1;

// Transmittance (1 − α) from world points to one light by options.shadows (Rays or Dsm, with the
// options' DSM resolution and ε), computed by the same kernel code the camera pass runs.
struct ShadowQuery {
    std::vector<double> transmittance;  // one per point
    RenderStats stats;                  // preparation and DSM build times, DSM sizes
};
ShadowQuery shadow_transmittance(Context& context, const Scene& scene, int light_index, const std::vector<Vec3>& points,
                                 const RenderOptions& options);

// The deep shadow maps of one light (1 view, or 6 cube faces +x −x +y −y +z −z of a point
// light; with options.dsm.clusters, the views of each cluster, named lights[i].cluster<k>.<j>),
// built with options.dsm.resolution / epsilon and read back to the host.
std::vector<DeepShadowMap> build_deep_shadow_maps(Context& context, const Scene& scene, int light_index,
                                                  const RenderOptions& options, RenderStats* stats = nullptr);

// The sub-pixel maps a pre-filtered DSM of one light merges (options.dsm.prefilter ≠ "none"),
// each generated with ε/2: for every view of the light, its sub-maps in order (box, tent: one map
// at twice the resolution; 5tap: centres, corners; cl/shared/prefilter.h). For tests and tools.
std::vector<DeepShadowMap> build_prefilter_sub_maps(Context& context, const Scene& scene, int light_index,
                                                    const RenderOptions& options);

// PNG (8-bit sRGB) or EXR (float linear) by extension, through OpenImageIO. Writes to a temporary
// file in the same folder and renames it, so a failed write leaves no partial file.
void write_image(const Image& image, const std::string& path);
Image read_image(const std::string& path);  // for tests and tools
// The image as PNG file bytes (8-bit sRGB, as write_image writes a .png), in memory: `sombra view`'s frames.
std::vector<unsigned char> encode_png(const Image& image);

}  // namespace sombra
