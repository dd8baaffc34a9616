// sombra — shadow techniques "lowpass", "ao" and "cone" (cl/techniques/lowpass.h, ao.h, cone.h):
// summed-area tables over the scene's extinction (Ament et al. 2014), light-aligned for lowpass,
// one volume-aligned table for the ao and cone baselines; by default the camera pass reads the
// shadow term from the shadow cache filled from them (Ament Alg. 1). The tables live in a pool
// the module keeps between calls: a table whose inputs did not change is not rebuilt
// (src/shadows/sat_update.h).
#include <ostream>

#include "shadows/sat_update.h"
#include "sombra/error.h"
#include "techniques/technique.h"

namespace sombra::techniques {
namespace {

class SatShadows final : public ShadowModule {
public:
    void add_defines(const Scene&, const RenderOptions& options, std::vector<std::string>& defines) const override {
        defines.push_back(std::string("SOMBRA_TECHNIQUE_") + (options.shadows == ShadowTechnique::Ao     ? "AO"
                                                              : options.shadows == ShadowTechnique::Cone ? "CONE"
                                                                                                         : "LOWPASS"));
        if (options.lowpass_filter_kernel == "gauss") defines.push_back("SOMBRA_LOWPASS_GAUSS");
        else if (options.lowpass_filter_kernel != "box")
            throw Error("--filter-kernel: must be box or gauss, got '" + options.lowpass_filter_kernel + "'");
    }

    void add_key(const RenderOptions& options, int, std::ostream& key) const override { key << options.lowpass_max_entries; }

    void prepare(const SceneOnDevice& s, RenderStats&) override {
        // the tables are built over boxes: polyhedral bounds are not in them
        for (std::size_t i = 0; i < s.scene.volumes.size(); ++i)
            if (s.scene.volumes[i].bound.mesh)
                throw file_error(s.scene.source, "volumes[" + std::to_string(i) + "].bounds",
                                 std::string("polyhedral bounds are not supported by --shadows ") + shadow_technique_name(s.options.shadows));
        if (s.runtime.device().getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() == 0)  // cl/lowpass.h reads corners in double
            throw Error("--shadows: the summed-area-table techniques need double precision, which " + s.runtime.info().name + " lacks");
    }

    // Ament Alg. 1, first pass: rebuilds the tables whose inputs changed, keeps the others.
    void refresh(const SceneOnDevice& s, RenderStats& stats) override {
        shadows::SatUpdateCounts counts;
        sat_ = shadows::update_sats(s.runtime, s.scene, s.packed, s.device, s.options.shadows == ShadowTechnique::Lowpass,
                                    s.options.lowpass_max_entries, pool_, counts);
        for (auto& [stage, ms] : sat_.stage_ms) stats.stage_ms[stage] = ms;
        stats.sat_tables_built = counts.built, stats.sat_tables_reused = counts.reused;
    }

    // SHADOW_PARAMS of cl/techniques/sat_tables.h: the tables and their per-light grids for this
    // call's filter width and cone angle
    void bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions& o) const override {
        if (!(o.lowpass_filter_width >= 0.f && o.lowpass_filter_width <= 4096.f))
            throw Error("--filter: the filter width must lie in [0, 4096] voxels");
        if (!(o.cone_angle_deg > 0.f && o.cone_angle_deg <= 60.f)) throw Error("--cone-angle: must lie in (0, 60] degrees");
        grids_ = shadows::upload_sat_grids(runtime, sat_, o.lowpass_filter_width, o.cone_angle_deg);
        args("sat", sat_.data)("sat_grids", grids_.cartesian)("ssat_grids", grids_.spherical);
    }

    void add_stats(RenderStats& stats) const override {
        stats.sat_tables = int(sat_.frames.size());
        for (const SsatGridGpu& g : sat_.spheres) stats.sat_tables += g.dims.s[3] != 0;
        stats.sat_bytes = sat_.bytes;
    }

    // finer than the renderer's keys: an entry depends on the tables its lookups read (Ament Alg. 1)
    std::vector<std::string> shadow_cache_keys(const SceneOnDevice& s) const override {
        return shadows::shadow_cache_keys(s.scene, s.packed, sat_, shadows::extinction_keys(s.scene, s.packed, s.use_images),
                                          s.options);
    }

private:
    shadows::SatPool pool_;
    shadows::DeviceSat sat_;
    mutable shadows::SatGridBuffers grids_;  // kept alive while the kernel that binds them runs
};

}  // namespace

std::unique_ptr<ShadowModule> make_sat_shadows(ShadowTechnique) { return std::make_unique<SatShadows>(); }

}  // namespace sombra::techniques
