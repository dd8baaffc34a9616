// sombra — what the renderer keeps on a Context between calls, typed: the prepared scene (packed,
// on the device), the shadow technique's module with its device data, and the shadow cache. A
// moved camera rebuilds nothing; moved lights rebuild what depends on them (Knecht §3.2
// "Deep Shadow Map Re-Generation").
#pragma once
#include <array>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geometry/scene_upload.h"
#include "geometry/surfaces.h"
#include "render/shadow_cache_history.h"
#include "sombra/render.h"
#include "techniques/technique.h"

namespace sombra {
namespace pipeline {

// What a prepared scene depends on besides the lights (renderer.cpp scene_keys), in the parts the
// shadow cache's keys take apart: per volume its identity (the Volume's address), placement and
// content (size, a sample of the voxels, transfer function, step), the volumes' shading
// materials, the meshes' identities and content, and the options with the technique's.
struct SceneKeys {
    std::vector<std::string> volume_identity, volume_placement, volume_content;
    std::string materials, mesh_identity, meshes, options;
    std::string volume(std::size_t i) const { return volume_identity[i] + " " + volume_content[i]; }
    std::string surfaces() const { return mesh_identity + meshes; }
    std::string whole() const { return identities() + content(); }
    // without the identities: the same for two copies of the same data (auto's remembered choices;
    // a sample of the voxels may collide, so data caches key by whole())
    std::string content() const {
        std::string key;
        for (std::size_t i = 0; i < volume_placement.size(); ++i) key += "V" + volume_placement[i] + " " + volume_content[i];
        return key + " " + materials + meshes + options;
    }
    std::string identities() const {
        std::string key;
        for (const std::string& identity : volume_identity) key += identity + " ";
        return key + mesh_identity + " | ";
    }
};

struct PreparedScene {
    std::string key;                      // what it depends on besides the lights: keys.whole()
    SceneKeys keys;
    std::vector<std::string> light_keys;  // where each light is and how it shines
    packing::PackedScene packed;
    packing::DeviceScene device;
    surfaces::PackedSurfaces packed_surfaces;  // scenes with meshes: world-space triangles and materials
    surfaces::DeviceSurfaces surfaces;         // the same on the device
    cl::Buffer surface_bias;                   // with fragments, per light: surface_bias_distances, uploaded with the lights
    bool use_images = false;
};

// The shadow cache (render.h ShadowCacheMode; Ament Alg. 1): per volume and light a lattice of the
// shadow term over the volume's voxels, filled by the technique (render.cl shadow_cache_fill); an
// entry (volume × light) is refilled only when its key changed (shadow_cache.cpp).
// Its surface part (scenes with meshes): the shadow term per light at a barycentric lattice of
// points on each mesh triangle (k = 1: its corners; big triangles finer), looked up where a
// fragment there would look it up (surfaces.h surface_shadow_lookup), filled by render.cl
// surface_shadow_cache_fill; fragments interpolate it over their lattice cell.
struct SurfaceShadowCache {
    std::string points_key;                // the meshes' key (SceneKeys::meshes) the points were planned for
    std::size_t source_triangles = 0;      // the meshes' triangles they were planned for
    double spacing = 0;                    // the lattice's spacing on the triangles (shadow_cache.cpp surface_lattice)
    std::size_t planned_points = 0;        // the points at that spacing, counted before any is made
    std::vector<cl_float4> points;         // per point: position, unit normal (world); made for the first fill
    // per source triangle: its first point and k; point (i, j), i + j ≤ k, at barycentric weights
    // (1 − (i + j)/k, i/k, j/k) is first + j·(k + 1) − j·(j − 1)/2 + i
    std::vector<cl_uint> triangles;
    std::vector<std::string> keys;         // per light; empty: not filled
    cl::Buffer point_buffer, triangle_buffer, values;  // values: point · lights + light
    std::size_t bytes = 0;
    std::size_t point_count() const { return planned_points; }
};

struct ShadowCache {
    std::vector<ShadowCacheGpu> layout;
    std::vector<std::string> keys;  // per entry; empty: not filled
    cl::Buffer values, table;
    // `values` made and not yet set: set to 1 before the first fill (shadow_cache.cpp define_values;
    // a frame that then evaluates per sample never touches its pages)
    bool values_undefined = false;
    // the visible fill (ShadowCacheFill::Visible): bit masks over the lattice points
    // (ShadowCacheGpu.mark_offset) — the cells the marking pass marked, the points filled so far
    // under the entry's key, the points this frame fills — and the count of the last; per entry,
    // complete: every point a sample can read is filled (a fill of all points), else the view
    // (the frame's CameraGpu, the scene's key and the entry's light's: prepare_volume_fill) whose points were filled
    cl::Buffer marks, filled, need, need_count;
    std::size_t mark_words = 0;
    std::vector<bool> complete;
    std::vector<std::string> filled_view;
    std::size_t bytes = 0;
    SurfaceShadowCache surfaces;
    bool volumes_used = false, surfaces_used = false;  // what this frame reads (render.cl shadow_cache_reads, SOMBRA_SURFACE_SHADOW_CACHE)
    // auto's history to record once the frame's camera pass is timed (record_auto_history)
    struct PendingHistory {
        std::string key;
        AutoHistory history;
        std::chrono::steady_clock::time_point started;  // when auto chose
        double probe_ms = 0;                             // wall time of its probe, if any
    };
    std::optional<PendingHistory> history_pending;
};

// The scene prepared for `options` and the module of its technique, both kept on the Context.
struct Prepared {
    const PreparedScene& scene;
    techniques::ShadowModule& technique;
};
// only_light ≥ 0: the call reads that light's shadow data only (techniques may leave the others'
// unbuilt until a call needs them: SceneOnDevice::lights_needed).
Prepared prepare(Context& context, const Scene& scene, const RenderOptions& options, RenderStats& stats, int only_light = -1);

int check_light(const Scene& scene, int light_index);

// -D defines of render.cl's kernels for this scene and these options, SOMBRA_LANES = lanes
// (renderer.cpp), and the arguments they share (SCENE_PARAMS, cl/scene_refs.h).
std::vector<std::string> camera_pass_defines(const Scene& scene, const RenderOptions& options, const Prepared& p, int lanes,
                                             bool surface_cache = false, bool mark_shadow_cache = false);
void bind_scene(host::KernelArgs& args, const PreparedScene& p, const cl::Buffer& camera);

// The camera of a frame of width × height: the scene's camera with the options' termination,
// jitter seed and phase asymmetry.
CameraGpu frame_camera(const Scene& scene, const RenderOptions& options, int width, int height);

// What the camera pass reads besides the prepared scene and the technique: the view's fragments
// (mesh scenes) and the shadow cache's parts (null: evaluated per sample / fragment).
struct CameraPassReads {
    const surfaces::ViewFragments* fragments = nullptr;
    const cl::Buffer *volume_cache = nullptr, *volume_cache_table = nullptr;
    // the visible fill's marking pass (SOMBRA_SHADOW_CACHE_MARK): with volume_cache_table, marks
    // the lattice cells the cached pass would read here instead of reading volume_cache
    const cl::Buffer* volume_cache_marks = nullptr;
    const SurfaceShadowCache* surface_cache = nullptr;
    // where the pass writes: its launch rows one after the other, or (image_rows) at the image's
    // rows, as auto's probe writes its per-sample launches into the frame's image; and the packets
    // it leaves as they are, a bit per packet of the image (row · packets per row + packet): those
    // the probe rendered per sample, in a frame that then evaluates per sample
    bool image_rows = false;
    const cl::Buffer* rendered_packets = nullptr;
};
// The frame's image and sample counts, which auto's probe (shadow_cache_for_frame) renders its
// per-sample launches into; `rendered_packets` (CameraPassReads) when the frame then evaluates per
// sample and keeps them.
struct FrameImage {
    cl::Buffer image, sample_counts;
    std::optional<cl::Buffer> rendered_packets;
};
// Packets of an image of `width` × `height` noted as rendered: a bit per packet (row · packets per
// row + packet, CameraPassReads.rendered_packets), and the pixels they hold.
struct RenderedPackets {
    RenderedPackets(int width, int height, int lanes);
    void add(int y, int packet);  // (a packet noted twice counts once)
    std::vector<cl_uint> bits;
    unsigned long long pixels = 0;
private:
    int width_, lanes_, row_packets_;
};
// render.cl's render_camera for `camera` (its width × the rows first_row, first_row + row_stride, …)
// into `image` and `sample_counts` (one row per row rendered); returns the kernel time (ms). The
// render and the shadow cache's auto probe run it.
double run_camera_pass(host::Runtime& runtime, const Scene& scene, const Prepared& prepared, const RenderOptions& options, int lanes,
                       const CameraGpu& camera, const CameraPassReads& reads, const cl::Buffer& image, const cl::Buffer& sample_counts,
                       RenderStats* stats = nullptr);

// Per light, the distance surface fragments' shadow lookups are biased in proportion to (cl/surfaces.h
// surface_shadow_lookup; render.cl's surface_bias): the light's reach over the scene's box (volumes
// and meshes) — its diagonal, or a positional light's distance to its farthest corner — to which
// the texels of its maps are proportional; a camera move does not change it (shadow_cache.cpp).
std::vector<float> surface_bias_distances(const PreparedScene& p);

// Auto reads the volume lattices when their fill and the camera pass reading them take less than
// the per-sample pass by a margin (render.h kShadowCacheAutoMargin).
constexpr bool shadow_cache_pays(double fill_ms, double cached_ms, double per_sample_ms) {
    return kShadowCacheAutoMargin * (fill_ms + cached_ms) < per_sample_ms;
}

// Whether marking the points a frame reads can pay: the marking pass costs about a cached pass,
// and saves at most the fill of the points it leaves out (both the probe's marking condition,
// visible_fill_worth_marking, and the frame's fill after an unmarked choice ask it).
constexpr bool marking_may_pay(double fill_ms, double cached_ms) { return 2 * cached_ms < fill_ms; }

// Whether auto measures the visible fill on a part of its points (shadow_cache.cpp
// measure_marked_fill) before it decides: when the probe's estimate for the marked points does not
// pay but a kMeasureFillBelow times lower one would (the probe's blocks ran 1.2–4.6× the visible
// fill's time per point on the CT and the MRI). Not where the estimate pays but a higher one would
// not (tried 2026-12-07 at twice, bench/README.md "Marking on short frames"): the measurement's
// bands of 4 rows fill at about half the speed of the frame's fill, so that the MRI's cone at 256²
// and the CT's at 512², which read the cache either way, came out 1.13× against 1.01–1.07×, while
// bounded_smoke's shadow rays at 128², which its estimate had sent to the cache (1.22×), paid the
// marking and the measurement before evaluating per sample (1.24×).
constexpr double kMeasureFillBelow = 3;
constexpr bool marked_fill_worth_measuring(double fill_ms, double cached_ms, double per_sample_ms) {
    return !shadow_cache_pays(fill_ms, cached_ms, per_sample_ms) && shadow_cache_pays(fill_ms / kMeasureFillBelow, cached_ms, per_sample_ms);
}

// Whether auto's probe runs the visible fill's marking pass (shadow_cache.cpp; docs/shadows.md
// "Auto"). The pass costs about a cached camera pass and is wasted when the points it marks then
// do not pay, so it runs only when the cache would pay at 1/kVisibleFillBound of the probe's fill
// of every point (the shipped scenes mark 18–62 % of the points, at less per point than the
// probe's blocks), the cached pass costs under half that fill, and either the pass is at most
// 1/kMarkingCachedShare of the per-sample pass or, on a per-sample pass of at least
// kMarkingBestCaseMinMs, that best case saves at least the pass. The second arm: the CT's and the
// MRI's cone shadows at 512² and 256² (per-sample pass 1.4–4.6 s, 3–7× the cached one) were left
// per sample on the fill of every point, 1.3–1.4× the visible fill's frames. Not on shorter
// frames, whose estimates come from launches of a few milliseconds and spread by ± 40 %, and
// whose scenes mark more of their points (48–73 %): two_smokes_wall's cone at 128² (per sample
// 55–75 ms) marked, then stayed per sample, 1.31×; the head in fog's AO at 128² (per sample
// estimated at 460–500 ms, 4–5× the cached pass) marked 48 % and then read the cache, 1.19–1.32×
// the per-sample frame (the floor was 300 ms until 2026-12-07; the second arm's cases that paid
// had per-sample passes of 1.4 s and more). The first arm at a tenth, not an eighth (until
// 2026-12-07): the smoke's cone at 128² (cached pass 1/7.3–1/8.7 of the per-sample one) marked
// 58 % and measured them, 60–70 ms on a 400 ms frame that then evaluated per sample, 1.11–1.26×
// (bench/README.md "Marking on short frames").
constexpr double kVisibleFillBound = 8, kMarkingCachedShare = 10, kMarkingBestCaseMinMs = 700;
constexpr bool visible_fill_worth_marking(double fill_ms, double cached_ms, double per_sample_ms) {
    const double best_case_ms = kShadowCacheAutoMargin * (fill_ms / kVisibleFillBound + 2 * cached_ms);  // marking, fill, cached pass
    return marking_may_pay(fill_ms, cached_ms) && best_case_ms < per_sample_ms &&
           (kMarkingCachedShare * cached_ms <= per_sample_ms ||
            (per_sample_ms >= kMarkingBestCaseMinMs && per_sample_ms - best_case_ms >= cached_ms));
}

// Whether marking pays on the share of the points estimated before the marking pass
// (shadow_cache.cpp estimate_marked_share; a negative share: not estimated, marking may pay): the
// pass (about a cached camera pass) and the fill of that share of the points, then the cached
// pass, against the per-sample pass. Where it pays only on a per-sample pass above
// 1/kMarkedShareClear of the scout's estimate, a close call, the per-sample pass is measured
// again on whole rows first (shadow_cache.cpp probe_volume_costs): the scout's packets read it
// 1.4–2.4× high where marking lost at 128² (bench/README.md "The marked share, sampled").
constexpr double kMarkedShareClear = 2;
constexpr bool marked_share_pays(double share, double fill_ms, double cached_ms, double per_sample_ms) {
    return share < 0 || shadow_cache_pays(share * fill_ms + cached_ms, cached_ms, per_sample_ms);
}

// Whether a scout that decided for the cache measures the fill again, every 32 rows, before the
// frame decides whether to mark: the coarse fill's blocks ran 1.6–3× low on the MRI's shadow rays
// at 256², so that marking_may_pay failed where marking paid.
constexpr double kCoarseFillLow = 3;
constexpr bool marking_close_call(double coarse_fill_ms, double cached_ms) {
    return !marking_may_pay(coarse_fill_ms, cached_ms) && marking_may_pay(kCoarseFillLow * coarse_fill_ms, cached_ms);
}

// Auto fills the surface part when the frame's surface fragments × lights are at least
// kSurfaceFragmentsPerPoint times the points × stale lights to fill. Not every fragment counted is
// shaded (those behind an opaque one are not): on the cups a fragment's cached read saved 0–0.9
// of what a point's fill cost (the six techniques at 256² and 512², PoCL). With fragments 1.06 ×
// the points (256²) the fill cost 1.0–3.7× what it saved (AO saved nothing), with 4.2 × (512²)
// 0.4–0.75× (docs/shadows.md "Auto").
constexpr double kSurfaceFragmentsPerPoint = 3;
constexpr bool surface_shadow_cache_pays(double points_to_fill, double fragment_evaluations) {
    return kSurfaceFragmentsPerPoint * points_to_fill <= fragment_evaluations;
}

// Points of a cache lattice (dims.x · dims.y · dims.z).
std::size_t lattice_points(const ShadowCacheGpu& c);

// The points of lattice `c` that are corners of a cell marked in `marks` (a whole marks buffer,
// ShadowCacheGpu.mark_offset): what render.cl's shadow_cache_need covers, counted on the host
// (auto's estimate of the marked share, shadow_cache.cpp estimate_marked_share).
// With `cover_words` (a whole buffer's size), those points' bits are written there.
std::size_t marked_corner_points(const std::vector<cl_uint>& marks, const ShadowCacheGpu& c, std::vector<cl_uint>* cover_words = nullptr);

constexpr std::size_t kShadowCachePoints = std::size_t(1) << 23;  // a volume lattice's points, per volume and light (32 MiB)

// A volume lattice's voxel → lattice map (ShadowCacheGpu.voxel_to_lattice: diag(1 / spacing)).
void set_volume_lattice_map(ShadowCacheGpu& c);

// The light lattice (src/render/shadow_cache_columns.cpp) of volume `volume` for `light`, made
// from the volume lattice (its planes, spacing, offsets and masks' place are re-set by the
// caller), or none: a positional light inside or too near the volume's slabs on every axis, or
// columns that would have to be spaced over 3× the volume lattice's to fit 4× its points or 2²⁴.
std::optional<ShadowCacheGpu> light_lattice(const ShadowCacheGpu& volume_lattice, const VolumeGpu& volume, const LightGpu& light,
                                            float step_voxels);

// Voxel coordinates of point (x, y, z) of a lattice, volume or light (cl/render.cl
// column_point_voxel).
std::array<double, 3> lattice_point_voxel(const ShadowCacheGpu& c, double x, double y, double z);

// Auto's probe lattices: of each lattice, blocks of `block` neighbouring rows along y and z (of a
// light lattice along y, and every k-th packet of `lanes` columns along x), `stride` rows apart,
// about (block / stride)² of its points; on a small lattice closer, until 4 blocks lie along each
// axis, within 4 × that share (ShadowCacheGpu.row_block, row_block_stride, block_origin).
std::vector<ShadowCacheGpu> probe_lattices(const std::vector<ShadowCacheGpu>& layout, int block, int stride, int lanes);

// The point of full lattice `full` (volume or light lattice) at which point (x, y, z) of its probe
// lattice `small` (probe_lattices) lies: {x, y, z} indices, as render.cl's fills place the points
// (lattice_voxel, ShadowCacheGpu.block_origin).
std::array<int, 3> probe_point_in_lattice(const ShadowCacheGpu& small, const ShadowCacheGpu& full, int x, int y, int z, int lanes);

// The probe lattices' masks for a marked fill of the points `frame_marks` sets (a whole mask buffer of
// the frame's lattices, ShadowCacheGpu.mark_offset; shadow_cache.cpp probe_volume_costs: the points
// the share estimate's sampled rows need): a point of small lattice e is set where its point in
// layout[e] (probe_point_in_lattice) is set; entries not in `entries` are left empty. Sets the
// small lattices' mark_offset and mark_row_words.
std::vector<cl_uint> probe_block_marks(std::vector<ShadowCacheGpu>& small, const std::vector<ShadowCacheGpu>& layout,
                                       const std::vector<cl_uint>& frame_marks, const std::vector<bool>& entries, int lanes);

// Auto's probe camera launches (shadow_cache.cpp probe_volume_costs) over `frame`'s image of
// `lanes`-pixel packets: kProbeRowsPerLaunch rows spread over the image, row_stride apart, every
// kProbePacketStride-th packet of each (of images under 256 rows every (4 · 256 / height)-th: a
// launch is about 1/64 of the image), staggered from row to row; the probe moves first_row and
// first_packet from launch to launch. Where that stride passes a row's packets (images under
// about 90² at 8 lanes), one packet a row and proportionally fewer rows: a stride past the row's
// packets left every row whose staggered offset lies past them empty, so that a 64² launch's
// packets lay in its first and last rows, on the background (the head in fog's shadow rays at
// 64²: the per-sample pass estimated at 0.19 s against 2.9 s, and left per sample, 3.5× the cache).
CameraGpu probe_launch_camera(CameraGpu frame, int lanes);

// The packets a launch of render_camera (cl/render.cl) renders: {image row, packet index}, in
// launch row j (image row first_row + j · row_stride) every packet_stride-th packet from
// (first_packet + j) mod packet_stride.
std::vector<std::array<int, 2>> camera_launch_packets(const CameraGpu& camera, int lanes);

// Tests: auto's probe lattices (probe_lattices(…, block, stride, …)) of the frame's cache layout,
// filled as the probe fills them (one launch per kind of lattice, shadow_cache.cpp
// fill_small_lattices) or, one_launch false, entry by entry as the frame's fill launches; their
// values one after the other (points a sample cannot read hold 1).
std::vector<float> probe_fill_values(Context& context, const Scene& scene, const RenderOptions& options, int block, int stride,
                                     bool one_launch);

// The shadow cache this frame reads, its stale entries filled, or nullptr when every sample and
// fragment evaluates the technique (options.shadow_cache). Auto weighs the volume part by
// measuring (small runs of the fill and of the camera pass both ways) and the surface part by
// counting: surface points to fill against the frame's surface fragments × lights. Auto's choice
// is remembered for the process: the same frame again chooses the same (forget_shadow_cache_choices
// in render.h). `fragments`:
// the frame's view fragments (mesh scenes; else null); `frame`: the frame's image, which a frame
// that then evaluates per sample takes from the probe as FrameImage says — shadow_cache.cpp.
const ShadowCache* shadow_cache_for_frame(Context& context, const Scene& scene, const Prepared& prepared,
                                          const RenderOptions& options, int width, int height, int lanes,
                                          const surfaces::ViewFragments* fragments, FrameImage& frame, RenderStats& stats);
// After the frame's camera pass: a frame whose auto choice was new in this process and filled
// every entry records the wall time its mode took, unless it compiled code on the way (its
// kernels' times in `stats`; shadow_cache_history.h).
void record_auto_history(Context& context, const RenderStats& stats);

}  // namespace pipeline

namespace detail {
struct KeptScenes {
    std::unique_ptr<pipeline::PreparedScene> prepared;
    std::unique_ptr<techniques::ShadowModule> technique;
    decltype(techniques::TechniqueEntry::make) technique_family = nullptr;  // the registry's factory
    std::unique_ptr<pipeline::ShadowCache> shadow_cache;
};
}  // namespace detail

}  // namespace sombra
