/* sombra — shadow technique "ao": SAT ambient occlusion, a baseline of Ament Table 1 (Schlegel et
 * al. 2011): exp(−mean σ·W) in a cube of W voxels around the point, read from one SAT aligned with
 * the first volume; no direction, the same term for every light. Interface: techniques/technique.h. */
#include "techniques/sat_tables.h"

typedef struct {
    SatTables tables;
} ShadowState;
#define SHADOW_STATE_INIT(s) SAT_TABLES_INIT((s).tables)

static inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint m, lfloat3 p, lmask lanes) {
    __global const SatGridGpu* g = &s->tables.sat_grids[m];
#define AO_LANE(c) SAT_LANE_IF(lanes, c, sat_ambient_depth(s->tables.sat, g, SAT_LANE_POINT(p, c)))
    lfloat depth = LFROM_LANES(AO_LANE);
#undef AO_LANE
    return exp(-depth);
}
