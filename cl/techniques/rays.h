/* sombra — shadow technique "rays": the shadow-ray baseline, a march from every shaded point to
 * every light (shadow_ray.h); in scenes with meshes the rays cross their triangles, and with
 * SOMBRA_HAS_BOUNDS the polyhedral volume bounds. Interface: techniques/technique.h. */
#define SHADOW_TERM 1
#ifdef SOMBRA_HAS_MESHES
#define SOMBRA_SHADOW_RAY_MESHES /* shadow rays are attenuated by the world-space triangles */
#endif
#include "shadow_ray.h"

#ifdef SOMBRA_SHADOW_RAY_MESHES
#define SHADOW_MESH_PARAMS , __global const SurfaceTriangleGpu *shadow_triangles, __global const BvhNodeGpu *shadow_bvh, \
                           uint shadow_bvh_nodes
#define SHADOW_MESH_INIT(g) (g).shadow_triangles = shadow_triangles, (g).shadow_bvh = shadow_bvh, (g).shadow_bvh_nodes = shadow_bvh_nodes;
#else
#define SHADOW_MESH_PARAMS
#define SHADOW_MESH_INIT(g)
#endif
#ifdef SOMBRA_HAS_BOUNDS
/* every volume's bound triangles in BVH order (corner.w: the volume) and the hierarchy's nodes */
#define SHADOW_BOUND_PARAMS , __global const SurfaceTriangleGpu *bound_triangles, __global const BvhNodeGpu *bound_bvh, uint bound_bvh_nodes
#define SHADOW_BOUND_INIT(g) (g).bound_triangles = bound_triangles, (g).bound_bvh = bound_bvh, (g).bound_bvh_nodes = bound_bvh_nodes;
#else
#define SHADOW_BOUND_PARAMS
#define SHADOW_BOUND_INIT(g)
#endif

#define SHADOW_PARAMS SHADOW_MESH_PARAMS SHADOW_BOUND_PARAMS
typedef struct {
    ShadowRayGeometry geometry;
} ShadowState;
#define SHADOW_STATE_INIT(s) SHADOW_MESH_INIT((s).geometry) SHADOW_BOUND_INIT((s).geometry)

/* The shadow term multiplies along a light's ray (T(p) = T(p → q) · T(q) for q between p and the
 * light): the light lattices' columns are filled by one march each (render.cl
 * shadow_cache_fill_columns). Transmittance along p + t·dir, 0 < t < t_max. */
#define SOMBRA_SHADOW_COLUMNS
static inline lfloat piece_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, lfloat3 p, lfloat3 dir, lfloat t_max,
                                         lmask lanes) {
    return segment_transmittance(volume_data, scene, &s->geometry, p, dir, t_max, lanes);
}

static inline lfloat shadow_transmittance(VOLUME_DATA_PARAM, const SceneRefs* scene, ShadowState* s, uint m, lfloat3 p, lmask lanes) {
    return shadow_ray(volume_data, scene, &s->geometry, &scene->lights[m], p, lanes);
}
