/* sombra — what every kernel of render.cl reads about the scene (the arguments its kernels share),
 * gathered once per work-item and handed to shading and to the shadow technique
 * (techniques/technique.h). */
#ifndef SOMBRA_SCENE_REFS_H
#define SOMBRA_SCENE_REFS_H
#include "shared/types.h"
#include "lanes.h"

typedef struct {
    __global const CameraGpu* camera;
    __global const LightGpu* lights;
    __global const VolumeGpu* volumes;
    __global const float* tf_tables;
    __global const uchar* occupancy;
    lfloat jitter; /* the pixel's (or point's) offset of the first sample, in steps */
} SceneRefs;

#define SCENE_PARAMS                                                                                          \
    VOLUME_DATA_PARAM, __global const uchar *occupancy, __global const float *tf_tables,                       \
        __global const VolumeGpu *volumes, __global const LightGpu *lights, __global const CameraGpu *camera

static inline SceneRefs scene_refs(__global const CameraGpu* camera, __global const LightGpu* lights, __global const VolumeGpu* volumes,
                            __global const float* tf_tables, __global const uchar* occupancy, lfloat jitter) {
    SceneRefs s;
    s.camera = camera;
    s.lights = lights;
    s.volumes = volumes;
    s.tf_tables = tf_tables;
    s.occupancy = occupancy;
    s.jitter = jitter;
    return s;
}
#endif
