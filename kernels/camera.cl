/* Camera rays, docs/model.md, camera: Mitsuba's perspective (a pinhole at `position`, image plane at focal
 * length f), thinlens (HAS_THIN_LENS) and orthographic (HAS_ORTHOGRAPHIC) sensors, each with its near and far
 * clip planes. */
#ifndef CAMERA_CL
#define CAMERA_CL

#include "ray.h"
#include "types.h"
#include "vmath.h"
#if HAS_THIN_LENS
#include "warp.cl"
#endif

/* The camera ray through the film point (x, y) in the whole film's continuous pixel coordinates, x in [0, W)
 * to the right, y in [0, H) downwards (row 0 on top), and for a thin lens through the lens point of `lens` in
 * [0, 1)^2 (no other camera reads it). *tmax: where the far clip plane ends it. As Mitsuba's sensors do, the
 * ray starts on the near clip plane and ends on the far one, both at a distance along the view axis: t =
 * clip / cos(the ray's angle to the view); Mitsuba's plane is that of its lens, so the thin lens's too. The
 * pinhole's default clips (0 and infinity) leave its rays as they were: o + d * 0 = o. */
inline Ray generate_camera_ray(__constant const Camera *cam, vfloat x, vfloat y, vec2 lens, vfloat *tmax)
{
    const float inv_w = 1.0f / cam->film_width, inv_h = 1.0f / cam->film_height;
    vfloat sx = MAD(2.0f * inv_w, x, -1.0f) * cam->scale_x;
    vfloat sy = MAD(-2.0f * inv_h, y, 1.0f) * cam->scale_y;
#if HAS_ORTHOGRAPHIC /* Mitsuba's orthographic: parallel rays from the near plane's point */
    vec3 o = v3_madd(v3_uniform(cam->position), (vfloat)(cam->near_clip), v3_uniform(cam->forward));
    o = v3_madd(v3_madd(o, sx, v3_uniform(cam->right)), sy, v3_uniform(cam->up));
    Ray r = {o, v3_uniform(cam->forward)};
    *tmax = (vfloat)(cam->far_clip - cam->near_clip);
    return r;
#else
    vec3 d = v3_scale(v3_uniform(cam->forward), (vfloat)(cam->focal_length));
    d = v3_madd(d, sx, v3_uniform(cam->right));
    d = v3_madd(d, sy, v3_uniform(cam->up));
    vec3 o = v3_uniform(cam->position);
#if HAS_THIN_LENS /* Mitsuba's thinlens: from a point of the lens through the film point's on the focal plane */
    vec2 disk = uniform_disk_concentric(lens);
    vec3 aperture = v3_add(v3_scale(v3_uniform(cam->right), disk.x * cam->lens_radius),
                           v3_scale(v3_uniform(cam->up), disk.y * cam->lens_radius));
    d = v3_sub(v3_scale(d, (vfloat)(cam->focus_distance / cam->focal_length)), aperture);
    o = v3_add(o, aperture);
#endif
    d = v3_normalize(d);
    const vfloat inv_cos = 1.0f / v3_dot(d, v3_uniform(cam->forward));
    const vfloat near_t = cam->near_clip * inv_cos;
    Ray r = {v3_madd(o, near_t, d), d};
    *tmax = cam->far_clip * inv_cos - near_t;
    return r;
#endif
}

/* Ray differentials (Igehy 1999; pbrt-v4 section 10.1): where the camera rays of the neighbouring pixel
 * samples, `spacing` pixels to the right and below, meet the tangent plane (point p, normal n) of the hit
 * of the ray with unit direction d. Returns their offsets from p. A thin lens takes the pinhole's through the
 * lens's centre and p (pbrt-v4's CameraBase::GenerateRayDifferential does the same); an orthographic camera's
 * neighbours are its ray moved along the film. */
inline void camera_footprint(__constant const Camera *cam, float spacing, float inv_w, float inv_h, vec3 d, vec3 p,
                             vec3 n, vec3 *dpdx, vec3 *dpdy)
{
#if HAS_ORTHOGRAPHIC
    vec3 f = v3_uniform(cam->forward);
    vec3 dx = v3_scale(v3_uniform(cam->right), (vfloat)(2.0f * spacing * inv_w * cam->scale_x));
    vec3 dy = v3_scale(v3_uniform(cam->up), (vfloat)(-2.0f * spacing * inv_h * cam->scale_y));
    vfloat along = v3_dot(f, n);
    *dpdx = v3_madd(dx, -v3_dot(dx, n) / along, f);
    *dpdy = v3_madd(dy, -v3_dot(dy, n) / along, f);
#else
    vec3 o = v3_uniform(cam->position);
#if HAS_THIN_LENS
    d = v3_sub(p, o);
#endif
    vec3 dir = v3_scale(d, cam->focal_length / v3_dot(d, v3_uniform(cam->forward))); /* f forward + sx right + sy up */
    vec3 dx = v3_madd(dir, (vfloat)(2.0f * spacing * inv_w * cam->scale_x), v3_uniform(cam->right));
    vec3 dy = v3_madd(dir, (vfloat)(-2.0f * spacing * inv_h * cam->scale_y), v3_uniform(cam->up));
    vfloat plane = v3_dot(v3_sub(p, o), n);
    *dpdx = v3_sub(v3_madd(o, plane / v3_dot(dx, n), dx), p);
    *dpdy = v3_sub(v3_madd(o, plane / v3_dot(dy, n), dy), p);
#endif
}

#endif
