/* Camera rays, docs/model.md, camera: pinhole at `position`, image plane at focal length f. */
#ifndef CAMERA_CL
#define CAMERA_CL

#include "ray.h"
#include "types.h"
#include "vmath.h"

/* (x, y): continuous pixel coordinates, x in [0, W) to the right, y in [0, H) downwards (row 0 on top). */
inline Ray generate_camera_ray(__constant const Camera *cam, vfloat x, vfloat y, float inv_w, float inv_h)
{
    vfloat sx = MAD(2.0f * inv_w, x, -1.0f) * cam->scale_x;
    vfloat sy = MAD(-2.0f * inv_h, y, 1.0f) * cam->scale_y;
    vec3 d = v3_scale(v3_uniform(cam->forward), (vfloat)(cam->focal_length));
    d = v3_madd(d, sx, v3_uniform(cam->right));
    d = v3_madd(d, sy, v3_uniform(cam->up));
    Ray r = {v3_uniform(cam->position), v3_normalize(d)};
    return r;
}

/* Ray differentials (Igehy 1999; pbrt-v4 section 10.1): where the camera rays of the neighbouring pixel
 * samples, `spacing` pixels to the right and below, meet the tangent plane (point p, normal n) of the hit
 * of the ray with unit direction d. Returns their offsets from p. */
inline void camera_footprint(__constant const Camera *cam, float spacing, float inv_w, float inv_h, vec3 d, vec3 p,
                             vec3 n, vec3 *dpdx, vec3 *dpdy)
{
    vec3 o = v3_uniform(cam->position);
    vec3 dir = v3_scale(d, cam->focal_length / v3_dot(d, v3_uniform(cam->forward))); /* f forward + sx right + sy up */
    vec3 dx = v3_madd(dir, (vfloat)(2.0f * spacing * inv_w * cam->scale_x), v3_uniform(cam->right));
    vec3 dy = v3_madd(dir, (vfloat)(-2.0f * spacing * inv_h * cam->scale_y), v3_uniform(cam->up));
    vfloat plane = v3_dot(v3_sub(p, o), n);
    *dpdx = v3_sub(v3_madd(o, plane / v3_dot(dx, n), dx), p);
    *dpdy = v3_sub(v3_madd(o, plane / v3_dot(dy, n), dy), p);
}

#endif
