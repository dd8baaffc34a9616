// sombra — shadow technique "rays" (cl/techniques/rays.h): in scenes with meshes, the BVH of the
// world-space triangles the shadow rays cross, and of the polyhedral volume bounds; the rays' step
// factor (RayOptions::step) as a define.
#include <charconv>
#include <chrono>
#include <ostream>
#include <string>

#include "geometry/surfaces.h"
#include "techniques/option_declarations.h"
#include "techniques/technique.h"

namespace sombra::techniques {

// The options of RayOptions (render.h); the step keys the preparation, so the shadow cache's
// entries (keyed by it) are refilled when it changes.
const std::vector<OptionSpec>& ray_option_specs() {
    static const std::vector<OptionSpec> specs = {
        declare("shadow_ray_step", "--ray-step", [](auto& o) -> auto& { return o.rays.step; },
                "rays: factor on each volume's step for the shadow rays (< 1: finer)")
            .range(0.01, 16)  // 100× finer at most (1e-30 would never end)
            .only({ShadowTechnique::Rays})
            .keys()
            .commands(kRenderCommand | kVisibilityCommand),
        declare_enum<RayCacheLattice>("ray_cache_lattice", "--ray-cache-lattice", [](auto& o) -> auto& { return o.rays.cache_lattice; },
                                      "rays: the shadow cache's lattice per volume and light: light (columns along the light's rays, "
                                      "one march fills a column; where the volume lies to one side of a positional light) or volume "
                                      "(the voxel axes, one ray per point)",
                                      {{"light", RayCacheLattice::Light}, {"volume", RayCacheLattice::Volume}})
            .only({ShadowTechnique::Rays})
            .commands(kRenderCommand),
    };
    return specs;
}

namespace {

// The shortest decimal that reads back as `value`, as an OpenCL float literal ("0.25f", "2.0f").
std::string float_literal(float value) {
    char text[32];
    std::string digits(text, std::to_chars(text, text + sizeof text, value).ptr);
    if (digits.find_first_of(".e") == std::string::npos) digits += ".0";
    return digits + "f";
}

class ShadowRays final : public ShadowModule {
public:
    void add_defines(const Scene& scene, const RenderOptions& options, std::vector<std::string>& defines) const override {
        defines.push_back("SOMBRA_TECHNIQUE_RAYS");
        // shadow rays cross the bounds (the other passes see their fragments)
        if (surfaces::has_bounds(scene)) defines.push_back("SOMBRA_HAS_BOUNDS");
        if (options.rays.step != 1.f) defines.push_back("SOMBRA_SHADOW_RAY_STEP=" + float_literal(options.rays.step));
    }

    void add_key(const RenderOptions& options, int, std::ostream& key) const override {
        add_option_keys(ray_option_specs(), options, key);
    }

    void prepare(const SceneOnDevice& s, RenderStats& stats) override {
        *this = ShadowRays();  // a module outlives preparations: nothing of the previous scene stays
        if (!surfaces::has_fragments(s.scene)) return;
        auto start = std::chrono::steady_clock::now();
        meshes_ = true;
        shadow_bvh_ = surfaces::upload_shadow_bvh(s.runtime, s.surfaces.triangles, "shadow-ray");
        bounds_ = !s.packed.bound_triangles.empty();
        if (bounds_) bound_bvh_ = surfaces::upload_shadow_bvh(s.runtime, s.packed.bound_triangles, "volume bound");
        stats.stage_ms["bvh_build"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    }

    bool fills_light_columns(const RenderOptions& options) const override { return options.rays.cache_lattice == RayCacheLattice::Light; }

    // SHADOW_MESH_PARAMS and SHADOW_BOUND_PARAMS of cl/techniques/rays.h
    void bind(host::KernelArgs& args, host::Runtime&, const RenderOptions&) const override {
        if (!meshes_) return;
        args("shadow_triangles", shadow_bvh_.triangles)("shadow_bvh", shadow_bvh_.nodes)("shadow_bvh_nodes", shadow_bvh_.node_count);
        if (bounds_) args("bound_triangles", bound_bvh_.triangles)("bound_bvh", bound_bvh_.nodes)("bound_bvh_nodes", bound_bvh_.node_count);
    }

private:
    bool meshes_ = false, bounds_ = false;
    surfaces::ShadowBvh shadow_bvh_, bound_bvh_;
};

}  // namespace

std::unique_ptr<ShadowModule> make_shadow_rays(ShadowTechnique) { return std::make_unique<ShadowRays>(); }

}  // namespace sombra::techniques
