/* sombra — shadow technique "lowpass": low-pass filtered soft shadows (Ament et al. 2014),
 * exp(−τ̄) with τ̄ the optical depth box-filtered (or with SOMBRA_LOWPASS_GAUSS Gaussian-filtered)
 * across the light, from the light's CSAT (directional lights, Ament Eq. 4, 13, 15) or SSAT
 * (point and spot lights, Eq. 24). A light without a table falls back to the shadow ray
 * (shadow_ray.h, volumes only). Interface: techniques/technique.h. */
#include "techniques/sat_tables.h"
#include "shadow_ray.h"

typedef struct {
    SatTables tables;
    ShadowRayGeometry no_geometry; /* the fallback crosses volumes only */
} ShadowState;
#define SHADOW_STATE_INIT(s) SAT_TABLES_INIT((s).tables)

static inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint m, lfloat3 p, lmask lanes) {
    __global const SatGridGpu* g = &s->tables.sat_grids[m];
    __global const SsatGridGpu* sphere = &s->tables.ssat_grids[m];
    lfloat depth;
    if (g->dims.w != 0) {
        depth = (lfloat)(0.0f);
        for (;;) { /* the light's tables, one per group of volumes: their depths add */
#define CSAT_LANE(c) SAT_LANE_IF(lanes, c, csat_filtered_depth(s->tables.sat, g, SAT_LANE_POINT(p, c)))
            depth += LFROM_LANES(CSAT_LANE);
#undef CSAT_LANE
            if (g->next == 0) break;
            g = &s->tables.sat_grids[g->next];
        }
    } else if (sphere->dims.w != 0) {
        depth = (lfloat)(0.0f);
        for (;;) { /* the light's tables, one per group of volumes: their depths add */
#define SSAT_LANE(c) SAT_LANE_IF(lanes, c, ssat_filtered_depth(s->tables.sat, sphere, SAT_LANE_POINT(p, c)))
            depth += LFROM_LANES(SSAT_LANE);
#undef SSAT_LANE
            if (sphere->next == 0) break;
            sphere = &s->tables.ssat_grids[sphere->next];
        }
    } else {
        return shadow_ray(volume_data, scene, &s->no_geometry, &scene->lights[m], p, lanes);
    }
    return exp(-depth);
}
