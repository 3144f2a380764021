/* Watertight ray-triangle intersection (Woop, Benthin and Wald, JCGT 2013; pbrt-v4 section 6.5.3).
 *
 * The ray is sheared so that it runs along +z from the origin; the three edge functions are then exact
 * 2-D cross products of the sheared vertices, so a ray through a shared edge or vertex hits at least one
 * of the triangles that share it: no cracks, unlike Moller-Trumbore. */
#ifndef TRIANGLE_CL
#define TRIANGLE_CL

#include "ray.h"
#include "types.h"

/* The per-ray part: axis permutation (kx, ky, kz) with kz the largest |d| component, and the shear. */
typedef struct { vint kx, ky, kz; vfloat sx, sy, sz; } RayShear;

inline vfloat v3_component(vec3 v, vint k) { return SELECT(SELECT(v.z, v.y, k == 1), v.x, k == 0); }

inline RayShear ray_shear(Ray r)
{
    vfloat ax = vabs(r.d.x), ay = vabs(r.d.y), az = vabs(r.d.z);
    vint kz = SELECT(SELECT((vint)(2), (vint)(1), ay > az), (vint)(0), (ax > ay) & (ax > az));
    vint kx = SELECT(kz + 1, (vint)(0), kz == 2);
    vint ky = SELECT(kx + 1, (vint)(0), kx == 2);
    vfloat dz = v3_component(r.d, kz);
    vint flip = dz < 0.0f; /* keep the winding: swap kx and ky when looking down -z */
    vint tmp = kx;
    kx = SELECT(kx, ky, flip);
    ky = SELECT(ky, tmp, flip);
    RayShear s;
    s.kx = kx; s.ky = ky; s.kz = kz;
    s.sz = 1.0f / dz;
    s.sx = -v3_component(r.d, kx) * s.sz;
    s.sy = -v3_component(r.d, ky) * s.sz;
    return s;
}

/* Vertex relative to the ray origin, permuted and sheared: (x, y) in the ray's plane, z along it. */
inline vec3 shear_vertex(Vec3f v, Ray r, RayShear s)
{
    vec3 a = v3_sub(v3_uniform(v), r.o);
    vfloat az = v3_component(a, s.kz);
    return v3(MAD(s.sx, az, v3_component(a, s.kx)), MAD(s.sy, az, v3_component(a, s.ky)), az * s.sz);
}

inline vfloat max3(vfloat a, vfloat b, vfloat c) { return vmax(a, vmax(b, c)); }

/* A bound on the rounding error of t (pbrt-v4 section 6.8.4, "Conservative Ray-Triangle t"), from the
 * sheared vertices a, b, c, the edge functions e and 1/det. pbrt-v4 takes the shear constants as given;
 * here sz = 1/dz rounds like a division (5 roundings, ray.h), which scales every t by up to 5 roundings, and
 * t = sum * (1 / det) takes 6 more: gamma(11) of |t| besides pbrt-v4's terms. */
inline vfloat triangle_t_error(vec3 a, vec3 b, vec3 c, vec3 e, vfloat inv_det, vfloat t)
{
    vfloat max_z = max3(vabs(a.z), vabs(b.z), vabs(c.z));
    vfloat max_x = max3(vabs(a.x), vabs(b.x), vabs(c.x)), max_y = max3(vabs(a.y), vabs(b.y), vabs(c.y));
    vfloat delta_z = GAMMA(3) * max_z;
    vfloat delta_x = GAMMA(5) * (max_x + max_z), delta_y = GAMMA(5) * (max_y + max_z);
    vfloat delta_e = 2.0f * (GAMMA(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    vfloat max_e = max3(vabs(e.x), vabs(e.y), vabs(e.z));
    return 3.0f * (GAMMA(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * vabs(inv_det)
         + GAMMA(11) * vabs(t);
}

/* t of the hit or +inf; *dt: a bound on t's error; *b0, *b1, *b2: the barycentric weights of v0, v1, v2. */
ALWAYS_INLINE vfloat intersect_triangle(__global const Triangle *tri, Ray r, RayShear s, vfloat *dt,
                                        vfloat *b0, vfloat *b1, vfloat *b2)
{
    /* No fused multiply-add in the edge functions: e(a, b) must be exactly -e(b, a), so that the two
     * triangles sharing an edge see the same value with opposite signs. */
#pragma OPENCL FP_CONTRACT OFF
    vec3 a = shear_vertex(tri->v0, r, s), b = shear_vertex(tri->v1, r, s), c = shear_vertex(tri->v2, r, s);
    vfloat e0 = b.x * c.y - b.y * c.x; /* edge v1 v2: weight of v0 */
    vfloat e1 = c.x * a.y - c.y * a.x; /* edge v2 v0: weight of v1 */
    vfloat e2 = a.x * b.y - a.y * b.x; /* edge v0 v1: weight of v2 */
    vint mixed = ((e0 < 0.0f) | (e1 < 0.0f) | (e2 < 0.0f)) & ((e0 > 0.0f) | (e1 > 0.0f) | (e2 > 0.0f));
    vfloat det = e0 + e1 + e2;
    vint inside = !mixed & (det != 0.0f);
    *dt = *b0 = *b1 = *b2 = 0.0f;
    if (!ANY(inside)) /* most triangles are missed by every lane: skip t and its bound */
        return (vfloat)(INFINITY);
    vfloat inv_det = 1.0f / det;
    vfloat t = (e0 * a.z + e1 * b.z + e2 * c.z) * inv_det;
    *dt = triangle_t_error(a, b, c, v3(e0, e1, e2), inv_det, t);
    *b0 = e0 * inv_det;
    *b1 = e1 * inv_det;
    *b2 = e2 * inv_det;
    return SELECT((vfloat)(INFINITY), t, inside);
}

/* The point b0 v0 + b1 v1 + b2 v2 and *err, its distance from the triangle's plane along n: pbrt-v4's
 * gamma(7) bound on the interpolation (section 6.8.5) plus 4 roundings for OpenCL's division in a hit's b's
 * (a light sample's are fewer: emitters.cl). The corners are each lane's own (emitters.cl's samples). */
inline vec3 corners_point(vec3 v0, vec3 v1, vec3 v2, vec3 n, vfloat b0, vfloat b1, vfloat b2, vfloat *err)
{
    vec3 p = v3_madd(v3_madd(v3_scale(v2, b2), b1, v1), b0, v0);
    vec3 box = v3_add(v3_abs(v3_scale(v0, b0)), v3_add(v3_abs(v3_scale(v1, b1)), v3_abs(v3_scale(v2, b2))));
    *err = GAMMA(11) * error_along(n, box);
    return p;
}

/* corners_point of one triangle, the same in every lane. */
inline vec3 triangle_point(__global const Triangle *tri, vfloat b0, vfloat b1, vfloat b2, vfloat *err)
{
    return corners_point(v3_uniform(tri->v0), v3_uniform(tri->v1), v3_uniform(tri->v2), v3_uniform(tri->normal),
                         b0, b1, b2, err);
}

#endif
