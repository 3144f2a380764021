/* Ray-rectangle intersection, docs/model.md, shapes: the plane hit, then |(p-c).t| <= sx/2, |(p-c).b| <= sy/2. */
#ifndef RECTANGLE_CL
#define RECTANGLE_CL

#include "ray.h"
#include "types.h"

/* num = (c - o).n, the origin's distance from the rectangle's plane along its normal (co = c - o), and
 * e_num, its rounding bound: c - o rounds once and a 3-term dot product of mads at most three times, 5 in
 * all. Shared with intersect.cl's culling of shadow rays, which relies on the same num and bound. */
inline vfloat plane_num(__global const Rectangle *rect, vec3 co) { return v3_dot(co, v3_uniform(rect->normal)); }
inline vfloat plane_num_error(__global const Rectangle *rect, vec3 co)
{
    return GAMMA(5) * error_along(v3_uniform(rect->normal), v3_abs(co));
}

/* t of the plane crossing where it lies inside the rectangle, else +inf (also for a ray in the plane);
 * *dt: a bound on t's rounding error; (*u, *v): the crossing's coordinates along the tangent and bitangent
 * from the centre. t = num / den with num = (c - o).n (plane_num, bound e_num) and den = d.n (a 3-term
 * dot product: e_den takes 4 roundings), and t = num * (1 / den) six times (ray.h). An origin on the
 * plane to within rounding has |num| <= e_num, so dt >= |t|: never a hit; one farther off is told apart by the sign of t. Where no lane's t lies in
 * (0, tmax], no caller can take the hit (ray.h's ranges need t > dt >= 0): the rest is skipped. */
inline vfloat intersect_rectangle(__global const Rectangle *rect, Ray r, vfloat tmax, vfloat *dt, vfloat *u,
                                  vfloat *v)
{
    vec3 n = v3_uniform(rect->normal);
    vec3 co = v3_sub(v3_uniform(rect->center), r.o);
    vfloat num = plane_num(rect, co), inv_den = 1.0f / v3_dot(r.d, n);
    vfloat t = num * inv_den;
    *dt = *u = *v = 0.0f;
    if (!ANY((t > 0.0f) & (t <= tmax))) /* behind every lane, or beyond: most planes of a room */
        return (vfloat)(INFINITY);
    vec3 rel = v3_madd(v3_scale(co, -1.0f), t, r.d); /* p - c, without forming p */
    *u = v3_dot(rel, v3_uniform(rect->tangent));
    *v = v3_dot(rel, v3_uniform(rect->bitangent));
    vint inside = (vabs(*u) <= rect->half_x) & (vabs(*v) <= rect->half_y);
    if (!ANY(inside)) /* most shapes are missed by every lane: skip the bound */
        return (vfloat)(INFINITY);
    /* dt = |t| (e_num / |num| + e_den / |den| + gamma(5)), without the two divisions */
    vfloat e_num = plane_num_error(rect, co), e_den = GAMMA(4) * error_along(n, v3_abs(r.d));
    *dt = MAD(vabs(t), e_den, e_num) * vabs(inv_den) + GAMMA(6) * vabs(t);
    return SELECT((vfloat)(INFINITY), t, inside);
}

/* The point at (u, v) on the rectangle, c + u t + v b, and *err: its distance from the plane (c, n), at most
 * four roundings of the sum plus u t.n + v b.n, where the stored unit vectors are orthogonal only to
 * within two roundings each. */
inline vec3 rectangle_point(__global const Rectangle *rect, vfloat u, vfloat v, vfloat *err)
{
    vec3 t = v3_uniform(rect->tangent), b = v3_uniform(rect->bitangent);
    vec3 p = v3_madd(v3_madd(v3_uniform(rect->center), v, b), u, t);
    vec3 box = v3_add(v3_abs(v3_uniform(rect->center)), v3_add(v3_abs(v3_scale(t, u)), v3_abs(v3_scale(b, v))));
    *err = GAMMA(4) * error_along(v3_uniform(rect->normal), box) + GAMMA(2) * (vabs(u) + vabs(v));
    return p;
}

#endif
