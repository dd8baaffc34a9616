// sombra — the deep-shadow-map entry points of the API (render.h): one light's maps, built as the
// renderer builds them (the dsm module, src/techniques/deep_shadow_maps.h), read back by the module.
#include "host/progress.h"
#include "render/preparation.h"
#include "shadows/dsm_builder.h"
#include "shadows/dsm_views.h"

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
    pipeline::Prepared prepared = pipeline::prepare(context, scene, dsm_options, stats, light_index);  // that light's maps only
    std::vector<DeepShadowMap> maps = prepared.technique.read_back_maps(runtime, std::size_t(light_index));
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
    const packing::PackedScene& packed = prepared.packed;
    std::vector<DsmLightViews> light_views;
    std::vector<DsmViewGpu> views = shadows::make_dsm_views(scene, packed, options.dsm.resolution, &light_views);
    shadows::SubPixelDsm sub =
        shadows::build_sub_pixel_maps(runtime, scene, packed, prepared.device, views, options.dsm, options.lanes);
    const DsmLightViews& light = light_views[std::size_t(light_index)];
    std::vector<DeepShadowMap> maps;
    for (cl_uint v = light.first * sub.layout.maps; v < (light.first + light.count) * sub.layout.maps; ++v) {
        maps.push_back(shadows::read_back_map(runtime, sub.dsm, v));
        maps.back().light_name = "lights[" + std::to_string(light_index) + "].sub" + std::to_string(v);
    }
    return maps;
}

}  // namespace sombra
