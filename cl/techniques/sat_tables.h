/* sombra — what the summed-area-table techniques (techniques/lowpass.h, ao.h, cone.h) share: the
 * tables (lowpass.h) and per light the grid of its Cartesian (CSAT) or spherical (SSAT) table as
 * kernel parameters and state, and exp(−τ̄) of a per-lane optical depth. */
#ifndef SOMBRA_SAT_TABLES_H
#define SOMBRA_SAT_TABLES_H
#define SHADOW_TERM 1
#include "lowpass.h"

#define SHADOW_PARAMS , __global const ulong *sat, __global const SatGridGpu *sat_grids, __global const SsatGridGpu *ssat_grids
typedef struct {
    __global const ulong* sat;
    __global const SatGridGpu* sat_grids;
    __global const SsatGridGpu* ssat_grids;
} SatTables;
#define SAT_TABLES_INIT(t) (t).sat = sat, (t).sat_grids = sat_grids, (t).ssat_grids = ssat_grids;

/* One world point per lane: (float3) of lane c of p, for the scalar SAT lookups. */
#define SAT_LANE_POINT(p, c) (float3)(LC((p).x, c), LC((p).y, c), LC((p).z, c))
/* Lane c's optical depth by `lookup` in the lanes asked for, 0 in the others: an idle lane's point
 * can be anywhere (the camera's, far outside every table, where a cone would march to it). */
#define SAT_LANE_IF(lanes, c, lookup) (LC(lanes, c) ? (lookup) : 0.0f)
#endif
