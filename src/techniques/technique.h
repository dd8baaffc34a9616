// sombra — a shadow technique as a module: the host half of cl/techniques/<name>.h. The renderer
// (src/render/renderer.cpp) drives any module through this interface and names none; the registry
// (registry.cpp) maps names to modules. Adding a technique: a class here-beside, a kernel header
// in cl/techniques/, one registry row and one line in cl/techniques/technique.h.
#pragma once
#include <iosfwd>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "geometry/scene_upload.h"
#include "geometry/surfaces.h"
#include "host/kernel_args.h"
#include "host/runtime.h"
#include "sombra/render.h"

namespace sombra::techniques {

// What a module's preparation reads: the scene, as packed and on the device, and the options.
struct SceneOnDevice {
    host::Runtime& runtime;
    const Scene& scene;
    const packing::PackedScene& packed;
    const surfaces::PackedSurfaces& surfaces;  // the meshes' world-space triangles (none without meshes)
    const packing::DeviceScene& device;
    const RenderOptions& options;
    bool use_images;
    // The lights whose shadow data this call reads (one flag per light); nullptr: every light. A
    // module may leave the others' data unbuilt, and must build it when a later call needs it.
    const std::vector<bool>* lights_needed = nullptr;
    bool needs_light(std::size_t light) const { return !lights_needed || (light < lights_needed->size() && (*lights_needed)[light]); }
    // A distributed render: the module exchanges its shadow data with the other ranks
    // (sombra/distributed.h); nullptr: one process.
    RankExchange* exchange = nullptr;
};

class ShadowModule {
public:
    virtual ~ShadowModule() = default;
    // The -D defines of the passes that read the shadow term (render.cl): SOMBRA_TECHNIQUE_<NAME>
    // selects cl/techniques/<name>.h; the rest are the module's own.
    virtual void add_defines(const Scene& scene, const RenderOptions& options, std::vector<std::string>& defines) const = 0;
    // Whether the technique attenuates light (SHADOW_TERM of its kernel header; none: false).
    virtual bool has_shadow_term() const { return true; }
    // Whether its shadow term multiplies along a light's rays and its kernels define
    // shadow_cache_fill_columns (SOMBRA_SHADOW_COLUMNS): the shadow cache then uses light lattices
    // (src/render/shadow_cache_columns.cpp).
    virtual bool fills_light_columns(const RenderOptions&) const { return false; }
    // Whether its shadow data can be exchanged between the ranks of a distributed render, so that
    // every rank's lookups see every region's objects (a technique without shadows trivially can).
    virtual bool crosses_ranks() const { return !has_shadow_term(); }
    // Appends what the module's device data depend on among the options (the renderer keys the
    // scene's preparation by it; the volumes, meshes and light count are keyed already).
    virtual void add_key(const RenderOptions& options, int lanes, std::ostream& key) const;
    // Called after the scene's lights are packed (a new preparation, or lights changed): the
    // module plans its per-light data (the deep shadow maps' views of each light).
    virtual void plan_lights(const Scene& scene, const packing::PackedScene& packed, const RenderOptions& options);
    // Builds the device data for a newly prepared scene.
    virtual void prepare(const SceneOnDevice& on_device, RenderStats& stats);
    // Lights marked in `moved` changed their view (position, direction, type, cone): rebuilds what
    // depends on them. Called on a kept preparation (not after prepare()).
    virtual void update_lights(const SceneOnDevice& on_device, const std::vector<bool>& moved, RenderStats& stats);
    // Called on every render with the kept or new preparation: state that depends on the options
    // a preparation is not keyed by (the low-pass tables keep their own keys).
    virtual void refresh(const SceneOnDevice& on_device, RenderStats& stats);
    // Binds SHADOW_PARAMS of its kernel header, in order.
    virtual void bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions& options) const;
    // Copies its sizes (maps, tables) into the statistics.
    virtual void add_stats(RenderStats& stats) const;
    // The key of each shadow cache entry (src/render/shadow_cache.cpp; volume-major, entry
    // i · lights + m): an entry is refilled when its key changes. Empty (the default): the
    // renderer keys every entry by the whole preparation, the technique and the entry's light.
    virtual std::vector<std::string> shadow_cache_keys(const SceneOnDevice& on_device) const;
    // What the module's data for `light` depend on beyond the scene, the options and the light's
    // view (the generic shadow cache keys add it): the clustered deep shadow maps' views, which
    // follow the camera. Empty by default.
    virtual std::string light_data_key(std::size_t light) const;
    // The maps of one light read back to the host, each named by its light and view (the API's
    // build_deep_shadow_maps); throws for a technique without maps.
    virtual std::vector<DeepShadowMap> read_back_maps(host::Runtime& runtime, std::size_t light) const;
};

// One row of the registry: the technique, its name on the command line and in scene files, what
// it is, and its module.
struct TechniqueEntry {
    ShadowTechnique technique;
    const char* name;
    const char* summary;
    std::unique_ptr<ShadowModule> (*make)(ShadowTechnique technique);
};
const std::vector<TechniqueEntry>& registry();
const TechniqueEntry& entry(ShadowTechnique technique);

// The module of `technique` for a scene (None when it has no lights: nothing casts a shadow term).
std::unique_ptr<ShadowModule> make_module(const Scene& scene, ShadowTechnique technique);

// The modules (each in its own .cpp).
std::unique_ptr<ShadowModule> make_no_shadows(ShadowTechnique);
std::unique_ptr<ShadowModule> make_shadow_rays(ShadowTechnique);
std::unique_ptr<ShadowModule> make_deep_shadow_maps(ShadowTechnique);  // Dsm and ShadowMap
std::unique_ptr<ShadowModule> make_sat_shadows(ShadowTechnique);       // Lowpass, Ao and Cone

}  // namespace sombra::techniques
