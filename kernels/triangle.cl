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

inline vfloat v3_component(vec3 v, vint k) { return select(select(v.z, v.y, k == 1), v.x, k == 0); }

inline RayShear ray_shear(Ray r)
{
    vfloat ax = fabs(r.d.x), ay = fabs(r.d.y), az = fabs(r.d.z);
    vint kz = select(select((vint)(2), (vint)(1), ay > az), (vint)(0), (ax > ay) & (ax > az));
    vint kx = select(kz + 1, (vint)(0), kz == 2);
    vint ky = select(kx + 1, (vint)(0), kx == 2);
    vfloat dz = v3_component(r.d, kz);
    vint flip = dz < 0.0f; /* keep the winding: swap kx and ky when looking down -z */
    vint tmp = kx;
    kx = select(kx, ky, flip);
    ky = select(ky, tmp, flip);
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
    return v3(mad(s.sx, az, v3_component(a, s.kx)), mad(s.sy, az, v3_component(a, s.ky)), az * s.sz);
}

/* t in [tmin, tmax] or +inf; *b1, *b2: barycentric weights of v1 and v2. */
inline vfloat intersect_triangle(__global const Triangle *tri, Ray r, RayShear s, vfloat tmin, vfloat tmax,
                                 vfloat *b1, vfloat *b2)
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
    vfloat inv_det = 1.0f / det;
    vfloat t = (e0 * a.z + e1 * b.z + e2 * c.z) * inv_det;
    *b1 = e1 * inv_det;
    *b2 = e2 * inv_det;
    vint hit = !mixed & (det != 0.0f) & (t >= tmin) & (t <= tmax);
    return select((vfloat)(INFINITY), t, hit);
}

#endif
