/* sombra — the shadow technique of a render.cl program: one module header, chosen by the one
 * define the host's technique module adds (src/techniques/registry.cpp). Every module header
 * provides the same four things, so render.cl names no technique:
 *   SHADOW_TERM        1 when the technique attenuates light (0: none)
 *   SHADOW_PARAMS      its kernel parameters, each after a comma (bound in this order by the host
 *                      module's bind(), checked by name: src/host/kernel_args.h)
 *   ShadowState        what its transmittance function reads, and SHADOW_STATE_INIT(s) filling
 *                      it from SHADOW_PARAMS
 *   shadow_transmittance(volume_data, const SceneRefs*, ShadowState*, uint light, lfloat3 p, lmask lanes)
 *                      transmittance from world point p towards the light, per lane. */
#ifndef SOMBRA_TECHNIQUE_H
#define SOMBRA_TECHNIQUE_H
#include "scene_refs.h"

#if defined(SOMBRA_TECHNIQUE_RAYS)
#include "techniques/rays.h"
#elif defined(SOMBRA_TECHNIQUE_DSM)
#include "techniques/dsm.h"
#elif defined(SOMBRA_TECHNIQUE_SHADOWMAP)
#include "techniques/shadowmap.h"
#elif defined(SOMBRA_TECHNIQUE_LOWPASS)
#include "techniques/lowpass.h"
#elif defined(SOMBRA_TECHNIQUE_AO)
#include "techniques/ao.h"
#elif defined(SOMBRA_TECHNIQUE_CONE)
#include "techniques/cone.h"
#else
#include "techniques/none.h"
#endif
#endif
