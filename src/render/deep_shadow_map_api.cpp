// sombra — the deep-shadow-map entry points of the API (render.h): one light's maps, built as the
// renderer builds them (the dsm module, src/techniques/deep_shadow_maps.h), read back to the host.
#include "host/progress.h"
#include "render/preparation.h"
#include "shadows/dsm_views.h"
#include "techniques/deep_shadow_maps.h"

namespace sombra {

std::vector<DeepShadowMap> build_deep_shadow_maps(Context& context, const Scene& scene, int light_index,
                                                  const RenderOptions& options, RenderStats* stats_out) {
    auto held = context.exclusive();  // one call at a time on a Context (sombra/device.h)
    host::Runtime& runtime = context.runtime();
    pipeline::check_light(scene, light_index);
    host::ProgressScope progress(runtime.progress(), options.progress);
    RenderOptions dsm_options = options;
    dsm_options.shadows = ShadowTechnique::Dsm;
    RenderStats stats;
    stats.device = runtime.info().name;
    pipeline::Prepared prepared = pipeline::prepare(context, scene, dsm_options, stats);
    const shadows::DeviceDsm& dsm = dynamic_cast<const techniques::DeepShadowMaps&>(prepared.technique).maps();
    const LightGpu& light = prepared.scene.packed.lights[std::size_t(light_index)];
    static const char* faces[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
    std::vector<DeepShadowMap> maps;
    cl_uint in_cluster = 0;  // clustered maps: the view's index within its cluster
    for (cl_uint v = 0; v < light.view_count; ++v) {
        const DsmViewGpu& view = dsm.views[light.view_first + v];
        std::string name = "lights[" + std::to_string(light_index) + "]";
        if (options.dsm.clusters > 0) {
            in_cluster = v > 0 && dsm.views[light.view_first + v - 1].cluster == view.cluster ? in_cluster + 1 : 0;
            name += ".cluster" + std::to_string(view.cluster) + "." + std::to_string(in_cluster);
        } else if (light.view_count == 6) {
            name += std::string(".") + faces[v];
        }
        maps.push_back(dsm.storage->read_back(runtime, view, light.view_first + v));
        maps.back().light_name = name;
        shadows::place_map(view, maps.back());
    }
    if (stats_out) *stats_out = stats;
    return maps;
}

std::vector<DeepShadowMap> build_prefilter_sub_maps(Context& context, const Scene& scene, int light_index,
                                                    const RenderOptions& options) {
    auto held = context.exclusive();  // one call at a time on a Context (sombra/device.h)
    host::Runtime& runtime = context.runtime();
    pipeline::check_light(scene, light_index);
    RenderOptions scene_only = options;
    scene_only.shadows = ShadowTechnique::None;  // the scene on the device, no maps
    RenderStats stats;
    const pipeline::PreparedScene& prepared = pipeline::prepare(context, scene, scene_only, stats).scene;
    packing::PackedScene packed = prepared.packed;
    std::vector<DsmViewGpu> views = shadows::make_dsm_views(scene, packed, options.dsm.resolution);
    shadows::SubPixelDsm sub =
        shadows::build_sub_pixel_maps(runtime, scene, packed, prepared.device, views, options.dsm, options.lanes);
    const LightGpu& light = packed.lights[std::size_t(light_index)];
    std::vector<DeepShadowMap> maps;
    for (cl_uint v = light.view_first * sub.layout.maps; v < (light.view_first + light.view_count) * sub.layout.maps; ++v) {
        maps.push_back(sub.dsm.storage->read_back(runtime, sub.dsm.views[v], v));
        maps.back().light_name = "lights[" + std::to_string(light_index) + "].sub" + std::to_string(v);
    }
    return maps;
}

}  // namespace sombra
