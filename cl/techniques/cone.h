/* sombra — shadow technique "cone": cone shadows, a baseline of Ament Table 1 (Schlegel et al.
 * 2011): the cone of half angle cone_angle_deg towards each light as a series of growing cubes
 * read from one SAT aligned with the first volume. Interface: techniques/technique.h. */
#include "techniques/sat_tables.h"

typedef struct {
    SatTables tables;
} ShadowState;
#define SHADOW_STATE_INIT(s) SAT_TABLES_INIT((s).tables)

/* The cone's optical depth towards one light from world point p (its axis: to the light); 0 where
 * not `active`, as a march of no length: over the shipped scenes that was faster than a branch
 * around the call or a loop over the lanes (docs/lowpass.md, "Idle lanes look nothing up"). */
static inline float cone_lane(__global const ulong* sat, __global const SatGridGpu* g, __global const LightGpu* light, float3 p, bool active) {
    bool directional = light->type == SOMBRA_LIGHT_DIRECTIONAL;
    float3 to_light = directional ? -light->direction.xyz : light->position.xyz - p;
    float reach = !active ? 0.0f : directional ? INFINITY : length(to_light);
    return sat_cone_depth(sat, g, p, to_light / fmax(length(to_light), 1e-30f), reach);
}

static inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint m, lfloat3 p, lmask lanes) {
    __global const SatGridGpu* g = &s->tables.sat_grids[m];
#define CONE_LANE(c) cone_lane(s->tables.sat, g, &scene->lights[m], SAT_LANE_POINT(p, c), LC(lanes, c) != 0)
    lfloat depth = LFROM_LANES(CONE_LANE);
#undef CONE_LANE
    return exp(-depth);
}
