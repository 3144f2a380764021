/* The scene as the kernel sees it: the host's buffers and counts, gathered in one private struct.
 * HAS_RECTANGLES, HAS_TRIANGLES and HAS_ELLIPSOIDS (set by the host from the scene) leave out the code
 * of shape kinds a scene lacks; the kernel's arguments stay the same in every variant. */
#ifndef SCENE_H
#define SCENE_H

#include "types.h"

typedef struct {
    __global const Rectangle *rectangles;
    __global const Triangle *triangles;
    __global const Ellipsoid *ellipsoids;
    __global const Light *lights;
    __global const Material *materials;
    __constant const RenderParams *params;
} Scene;

#endif
