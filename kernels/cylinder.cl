/* Ray-cylinder intersection: Mitsuba 3's cylinder, open-ended (no caps), the unit cylinder x^2 + y^2 = 1,
 * 0 <= z <= 1 of its local space under the affine map center + to_world x (types.h; the host composes p0,
 * p1 and radius into the map, as Mitsuba does). The ray is mapped into local space, where t is the same (the
 * direction is mapped, not renormalised), and the quadratic in (x, y) is solved as ellipsoid.cl solves the
 * sphere's (pbrt-v4's Cylinder intersects in object space too). */
#ifndef CYLINDER_CL
#define CYLINDER_CL

#include "affine.h"
#include "ray.h"
#include "types.h"

/* t of the hit (the near root if it is ahead and within 0 <= z <= 1, else the far one if that is; +inf for
 * none) and *q, the hit in local space; *t_beyond and *q_beyond, the far root where the hit is the near one
 * and the far one is on the tube too (+inf elsewhere): a shadow ray that passes a see-through cylinder crosses
 * it again there. A hit must be ahead, t > 0; the root that is the surface a ray leaves is no hit.
 *
 * Stable quadratic (Haines et al., Ray Tracing Gems ch. 7), in (x, y) alone: with a = dx^2 + dy^2,
 * h = ox dx + oy dy, c = ox^2 + oy^2 - 1 the discriminant h^2 - a c is a (1 - |f|^2), f = o - (h/a) d in
 * (x, y), which does not cancel when the ray passes far from the axis; the roots are q/a and c/q with
 * q = -(h + sign(h) sqrt(disc)). A ray along the axis (a = 0) gets disc NaN: no hit.
 *
 * c is the origin's own inside/outside test. o = to_local (o_world - center) rounds oc once and a row of
 * MAD()s 5 times (affine.h): ox, oy are within gamma(6) |to_local| |oc| of their exact values, so c is off by
 * at most 2 (|ox| e_x + |oy| e_y) plus its own 3 roundings of ox^2 + oy^2 + 1. Where |c| is within that bound
 * the origin lies on the surface (a ray leaving it, from either side) and the root c/q, the one near 0, is
 * the surface itself: only q/a can be a hit. From the inside wall that is the far wall, ahead. */
inline vfloat cylinder_roots(__global const Cylinder *k, Ray r, vec3 *q, vfloat *t_beyond, vec3 *q_beyond)
{
    vec3 oc = v3_sub(r.o, v3_uniform(k->center));
    vec3 o = mat3_apply(k->to_local, oc);
    vec3 d = mat3_apply(k->to_local, r.d);
    vfloat a = MAD(d.x, d.x, d.y * d.y), h = MAD(o.x, d.x, o.y * d.y), c = MAD(o.x, o.x, o.y * o.y) - 1.0f;
    vfloat s = -h / a;
    vfloat fx = MAD(s, d.x, o.x), fy = MAD(s, d.y, o.y);
    vfloat disc = a * (1.0f - MAD(fx, fx, fy * fy));
    *q = *q_beyond = o;
    *t_beyond = (vfloat)(INFINITY);
    if (!ANY(disc >= 0.0f)) /* missed by every lane: skip the roots and the bound */
        return (vfloat)(INFINITY);
    vec3 e = mat3_apply_abs(k->to_local, v3_abs(oc));
    vfloat dc = 2.0f * GAMMA(6) * MAD(vabs(o.x), e.x, vabs(o.y) * e.y) + GAMMA(3) * (MAD(o.x, o.x, o.y * o.y) + 1.0f);
    vfloat root = -(h + vcopysign(sqrt(vmax(disc, 0.0f)), h));
    vfloat t_far_side = root / a;
    vfloat t_near_origin = SELECT(c / root, (vfloat)(-INFINITY), vabs(c) <= dc);
    vfloat t_near = vmin(t_far_side, t_near_origin), t_far = vmax(t_far_side, t_near_origin);
    vfloat z_near = MAD(t_near, d.z, o.z), z_far = MAD(t_far, d.z, o.z);
    vint near_on = (disc >= 0.0f) & (t_near > 0.0f) & (z_near >= 0.0f) & (z_near <= 1.0f);
    vint far_on = (disc >= 0.0f) & (t_far > 0.0f) & (z_far >= 0.0f) & (z_far <= 1.0f);
    *q = v3_madd(o, SELECT(t_far, t_near, near_on), d);
    *q_beyond = v3_madd(o, t_far, d);
    *t_beyond = SELECT((vfloat)(INFINITY), t_far, near_on & far_on);
    return SELECT(SELECT((vfloat)(INFINITY), t_far, far_on), t_near, near_on);
}

/* cylinder_roots' hit alone: the closest-hit test's (the other root's outputs are unused, and inlined,
 * dropped by the compiler). */
inline vfloat intersect_cylinder(__global const Cylinder *k, Ray r, vec3 *q)
{
    vfloat t_beyond;
    vec3 q_beyond;
    return cylinder_roots(k, r, q, &t_beyond, &q_beyond);
}

/* World-space unit normal at the local point q: to_local^T (q.x, q.y, 0) (the inverse transpose of
 * to_world), outwards, times normal_sign (flip_normals). */
inline vec3 cylinder_normal(__global const Cylinder *k, vec3 q)
{
    vec3 radial = v3(q.x, q.y, (vfloat)(0.0f));
    return v3_scale(v3_normalize(mat3_apply_transposed(k->to_local, radial)), k->normal_sign);
}

/* The world point of the local point (x, y, z), first put back on the tube, (x, y) / |(x, y)| (pbrt-v4
 * section 6.8.5's reprojection), then center + to_world of it: a hit's, or a point a light sample picks
 * (x = cos phi, y = sin phi). *err: its distance from the surface that to_local describes, along the unit
 * normal n. The renormalised (x, y) is on the unit circle to within 7 roundings (the sum of squares, rsqrt as
 * 4, the product), a radial error that to_world carries to at most gamma(7) |to_world| |q| per coordinate;
 * the row of MAD()s takes 5 more, the sum with the centre one (also all the centre's term takes); and
 * to_world and its stored inverse are each rounded once from one float64 pair, which moves the surfaces they
 * describe apart by at most 3 roundings of |to_world| |q| along the normal: gamma(16) of |to_world| |q| in
 * all. z's error moves the point along the tube, not off it. */
inline vec3 cylinder_point(__global const Cylinder *k, vec3 q, vec3 n, vfloat *err)
{
    vfloat inv = rsqrt(MAD(q.x, q.x, q.y * q.y));
    vec3 on_shape = v3(q.x * inv, q.y * inv, q.z);
    vec3 centre = v3_uniform(k->center);
    vec3 p = v3_add(centre, mat3_apply(k->to_world, on_shape));
    vec3 box = v3_add(v3_scale(v3_abs(centre), GAMMA(1)),
                      v3_scale(mat3_apply_abs(k->to_world, v3_abs(on_shape)), GAMMA(16)));
    *err = error_along(n, box);
    return p;
}

#endif
