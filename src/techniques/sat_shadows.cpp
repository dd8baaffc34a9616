// sombra — shadow techniques "lowpass", "ao" and "cone" (cl/techniques/lowpass.h, ao.h, cone.h):
// summed-area tables over the scene's extinction (Ament et al. 2014), light-aligned for lowpass,
// one volume-aligned table for the ao and cone baselines; by default the camera pass reads the
// shadow term from the shadow cache filled from them (Ament Alg. 1). The tables live in a pool
// the module keeps between calls: a table whose inputs did not change is not rebuilt
// (src/shadows/sat_update.h).
#include <algorithm>
#include <ostream>

#include "shadows/sat_update.h"
#include "sombra/error.h"
#include "techniques/option_declarations.h"
#include "techniques/technique.h"

namespace sombra::techniques {

// The options of SatOptions (render.h). Only the tables' size limit keys the tables; the filter
// width, kernel and cone angle are read per lookup (the shadow cache keys its entries by them).
const std::vector<OptionSpec>& sat_option_specs() {
    static const std::vector<OptionSpec> specs = [] {
        using T = ShadowTechnique;
        const std::vector<T> family{T::Lowpass, T::Ao, T::Cone};
        const std::vector<Declaration> d = {
            declare("lowpass_filter_width", "--filter", [](auto& o) -> auto& { return o.sat.filter_width; },
                    "lowpass: filter width W (the softness of the shadows); ao: the cube's side")
                .range(0, 4096).unit("voxels").only(family).commands(kRenderCommand | kVisibilityCommand),
            declare("lowpass_filter_kernel", "--filter-kernel", [](auto& o) -> auto& { return o.sat.filter_kernel; },
                    "lowpass: box (one SAT box) or gauss (5×5 sub-boxes, Ament Eq. 25)")
                .choices({"box", "gauss"}).only({T::Lowpass}).commands(kRenderCommand | kVisibilityCommand),
            declare("lowpass_max_entries", "--sat-max-entries", [](auto& o) -> auto& { return o.sat.max_entries; },
                    "summed-area tables: at most this many 64-bit entries in the tables of one frame or point light (cells coarsen beyond)")
                .range(1 << 12, double(SOMBRA_SAT_MAX_ENTRIES)).unit("entries").only(family).keys()
                .commands(kRenderCommand | kVisibilityCommand),
            declare("lowpass_cells_across", "--sat-cells-across", [](auto& o) -> auto& { return o.sat.cells_across_patch; },
                    "lowpass: the filter's patch spans at least N table cells across the light, a wider W coarsening the cells "
                    "across the light by W/N; ao: the cube spans at least N cells, a wider W coarsening every cell by W/N "
                    "(0: cells of the finest voxel whatever W, so that changing W rebuilds no table)")
                .range(0, 64).unit("cells").only({T::Lowpass, T::Ao}).commands(kRenderCommand | kVisibilityCommand),
            declare("lowpass_precision", "--sat-precision", [](auto& o) -> auto& { return o.sat.precision; },
                    "summed-area-table lookups in auto (double where the device has it), double or float arithmetic")
                .choices({"auto", "double", "float"}).only(family).commands(kRenderCommand | kVisibilityCommand),
            declare("cone_angle_deg", "--cone-angle", [](auto& o) -> auto& { return o.sat.cone_angle_deg; },
                    "cone: half angle of the shadow cones")
                .range(0, 60).open_min().unit("degrees").only({T::Cone}),
        };
        return std::vector<OptionSpec>(d.begin(), d.end());
    }();
    return specs;
}

namespace {

class SatShadows final : public ShadowModule {
public:
    void add_defines(const Scene&, const RenderOptions& options, std::vector<std::string>& defines) const override {
        defines.push_back(std::string("SOMBRA_TECHNIQUE_") + (options.shadows == ShadowTechnique::Ao     ? "AO"
                                                              : options.shadows == ShadowTechnique::Cone ? "CONE"
                                                                                                         : "LOWPASS"));
        if (options.sat.filter_kernel == "gauss") defines.push_back("SOMBRA_LOWPASS_GAUSS");
        // the device is the Context's, fixed for the module's life; the option may change per call
        if (options.sat.precision == "double" && !device_has_double_)
            throw Error("--sat-precision: double, but " + device_name_ + " has no double precision (cl_khr_fp64); use auto or float");
        if (options.sat.precision == "double" || (options.sat.precision == "auto" && device_has_double_))
            defines.push_back("SOMBRA_SAT_FP64");
    }

    void add_key(const RenderOptions& options, int, std::ostream& key) const override {
        add_option_keys(sat_option_specs(), options, key);
    }

    void prepare(const SceneOnDevice& s, RenderStats&) override {
        // the tables are built over boxes: polyhedral bounds are not in them
        for (std::size_t i = 0; i < s.scene.volumes.size(); ++i)
            if (s.scene.volumes[i].bound.mesh)
                throw file_error(s.scene.source, "volumes[" + std::to_string(i) + "].bounds",
                                 std::string("polyhedral bounds are not supported by --shadows ") + shadow_technique_name(s.options.shadows));
        device_has_double_ = s.runtime.device().getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() != 0;
        device_name_ = s.runtime.info().name;
    }

    // Ament Alg. 1, first pass: rebuilds the tables whose inputs changed, keeps the others.
    void refresh(const SceneOnDevice& s, RenderStats& stats) override {
        shadows::SatUpdateCounts counts;
        sat_ = shadows::update_sats(s.runtime, s.scene, s.packed, s.device, s.options.shadows == ShadowTechnique::Lowpass,
                                    s.options.sat.max_entries, s.options.lanes, pool_, counts,
                                    s.options.shadows == ShadowTechnique::Cone  // the cone's width is its angle, not W
                                        ? 1.0
                                        : shadows::sat_cell_coarsening(s.options.sat.filter_width, s.options.sat.cells_across_patch));
        for (auto& [stage, ms] : sat_.stage_ms) stats.stage_ms[stage] = ms;
        light_aligned_ = s.options.shadows == ShadowTechnique::Lowpass;
        volume_names_.clear();
        for (std::size_t v = 0; v < s.scene.volumes.size(); ++v)
            volume_names_.push_back(s.scene.volumes[v].name.empty() ? "volume " + std::to_string(v) : s.scene.volumes[v].name);
        stats.sat_tables_built = counts.built, stats.sat_tables_reused = counts.reused;
    }

    // SHADOW_PARAMS of cl/techniques/sat_tables.h: the tables and their per-light grids for this
    // call's filter width and cone angle
    void bind(host::KernelArgs& args, host::Runtime& runtime, const RenderOptions& o) const override {
        grids_ = shadows::upload_sat_grids(runtime, sat_, o.sat.filter_width, o.sat.cone_angle_deg);
        args("sat", sat_.data)("sat_grids", grids_.cartesian)("ssat_grids", grids_.spherical);
    }

    void add_stats(RenderStats& stats) const override {
        stats.sat_tables = int(sat_.frames.size());
        for (const SsatGridGpu& g : sat_.spheres) stats.sat_tables += g.dims.s[3] != 0;
        stats.sat_bytes = sat_.bytes;
        stats.sat_table_list.clear();
        for (std::size_t t = 0; t < shadows::sat_table_count(sat_); ++t) {
            RenderStats::SatTable table;
            table.kind = t >= sat_.frames.size() ? "SSAT" : light_aligned_ ? "CSAT" : "volume SAT";
            for (std::size_t l = 0; l < sat_.light_frame.size(); ++l) {  // the lights (grids also holds their further tables)
                std::vector<std::size_t> read = shadows::light_sat_tables(sat_, l);
                if (std::find(read.begin(), read.end(), t) != read.end()) table.lights.push_back(int(l));
            }
            const cl_uint volumes = shadows::sat_table_volumes(sat_, t, volume_names_.size());
            for (std::size_t v = 0; v < volume_names_.size(); ++v)
                if (volumes & (cl_uint(1) << v)) table.volumes.push_back(volume_names_[v]);
            table.cells = shadows::sat_table_cells(sat_, t);
            table.cell_voxels = shadows::sat_table_cell_voxels(sat_, t);
            table.bytes = shadows::sat_table_entries(sat_, t) * sizeof(cl_ulong);
            table.build_ms = t < sat_.table_build_ms.size() ? sat_.table_build_ms[t] : 0.0;
            table.reused = !(table.build_ms > 0);
            stats.sat_table_list.push_back(table);
        }
    }

    // finer than the renderer's keys: an entry depends on the tables its lookups read (Ament Alg. 1),
    // and the volumes' extinction keys refresh computed for them (a sample of each volume's voxels:
    // computed again, 3–5 ms a frame on the cup array's 48 volumes)
    std::vector<std::string> shadow_cache_keys(const SceneOnDevice& s) const override {
        return shadows::shadow_cache_keys(s.scene, s.packed, sat_, sat_.extinction, s.options);
    }

private:
    bool device_has_double_ = true;  // cl_khr_fp64: SOMBRA_SAT_FP64 (cl/lowpass.h) unless float is asked for
    std::string device_name_;
    shadows::SatPool pool_;
    shadows::DeviceSat sat_;
    std::vector<std::string> volume_names_;  // for the per-table stats
    bool light_aligned_ = true;              // lowpass's CSAT/SSAT, not AO's or cone's volume-aligned SAT
    mutable shadows::SatGridBuffers grids_;  // kept alive while the kernel that binds them runs
};

}  // namespace

std::unique_ptr<ShadowModule> make_sat_shadows(ShadowTechnique) { return std::make_unique<SatShadows>(); }

}  // namespace sombra::techniques
