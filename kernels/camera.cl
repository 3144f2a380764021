/* Camera rays, SPEC.md section 1: pinhole at `position`, image plane at focal length f. */
#ifndef CAMERA_CL
#define CAMERA_CL

#include "ray.h"
#include "types.h"

/* (x, y): continuous pixel coordinates, x in [0, W) to the right, y in [0, H) downwards (row 0 on top). */
inline Ray generate_camera_ray(__constant const Camera *cam, vfloat x, vfloat y, float inv_w, float inv_h)
{
    vfloat sx = mad(2.0f * inv_w, x, -1.0f) * cam->scale_x;
    vfloat sy = mad(-2.0f * inv_h, y, 1.0f) * cam->scale_y;
    vec3 d = v3_scale(v3_uniform(cam->forward), (vfloat)(cam->focal_length));
    d = v3_madd(d, sx, v3_uniform(cam->right));
    d = v3_madd(d, sy, v3_uniform(cam->up));
    Ray r = {v3_uniform(cam->position), v3_normalize(d)};
    return r;
}

#endif
