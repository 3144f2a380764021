/* Ray-ellipsoid intersection, docs/model.md, shapes: solve against the unit sphere in the ellipsoid's own
 * space (p + [a b c] x), where t is the same because the direction is mapped but not renormalised. */
#ifndef ELLIPSOID_CL
#define ELLIPSOID_CL

#include "affine.h"
#include "ray.h"
#include "types.h"

/* t of the hit (the near root if it is ahead, else the far one; +inf for none) and *q, the hit in unit-sphere
 * space; *t_beyond and *q_beyond, the far root where the hit is the near one (+inf elsewhere): where a shadow
 * ray passes a see-through ellipsoid it crosses the surface again there. A hit must be ahead, t > 0; the root
 * that is the surface a ray leaves is no hit.
 *
 * Stable quadratic (Haines et al., Ray Tracing Gems ch. 7): with a = d.d, h = o.d, c = o.o - 1 the
 * discriminant h^2 - a c is rewritten as a (1 - |o - (h/a) d|^2), which does not cancel when the ray
 * passes far from the centre, and the two roots are q/a and c/q with q = -(h + sign(h) sqrt(disc)), so
 * neither root is a difference of nearly equal numbers.
 *
 * c is the origin's own inside/outside test. Its rounding error: o = M (o_world - centre) is off by at most
 * gamma(5) |M| |o_world - centre| per coordinate (one subtraction, a 3-term row), so c is off by at most
 * 2 |o|.that + gamma(4) (o.o + 1). Where |c| is within that bound the origin lies on the surface and the
 * root c/q, the one near 0, is the surface itself: only the root q/a can be a hit (ahead when the ray goes
 * inwards: the far side). */
inline vfloat ellipsoid_roots(__global const Ellipsoid *e, Ray r, vec3 *q, vfloat *t_beyond, vec3 *q_beyond)
{
    vec3 oc = v3_sub(r.o, v3_uniform(e->center));
    vec3 o = mat3_apply(e->world_to_unit, oc);
    vec3 d = mat3_apply(e->world_to_unit, r.d);
    vfloat a = v3_dot(d, d), h = v3_dot(o, d), c = v3_dot(o, o) - 1.0f;
    vec3 f = v3_madd(o, -h / a, d);
    vfloat disc = a * (1.0f - v3_dot(f, f));
    *q = *q_beyond = o;
    *t_beyond = (vfloat)(INFINITY);
    if (!ANY(disc >= 0.0f)) /* missed by every lane: skip the roots and the bound */
        return (vfloat)(INFINITY);
    vfloat dc = 2.0f * GAMMA(5) * v3_dot(v3_abs(o), mat3_apply_abs(e->world_to_unit, v3_abs(oc)))
              + GAMMA(4) * (v3_dot(o, o) + 1.0f);
    vfloat root = -(h + vcopysign(sqrt(vmax(disc, 0.0f)), h));
    vfloat t_far_side = root / a;
    vfloat t_near_origin = SELECT(c / root, (vfloat)(-INFINITY), vabs(c) <= dc);
    vfloat t_near = vmin(t_far_side, t_near_origin), t_far = vmax(t_far_side, t_near_origin);
    vfloat t = SELECT(t_far, t_near, t_near > 0.0f);
    *q = v3_madd(o, t, d);
    *t_beyond = SELECT((vfloat)(INFINITY), t_far, (disc >= 0.0f) & (t_near > 0.0f));
    *q_beyond = v3_madd(o, t_far, d);
    return SELECT((vfloat)(INFINITY), t, (disc >= 0.0f) & (t > 0.0f));
}

/* ellipsoid_roots' hit alone: the closest-hit and any-hit tests' (the other root's outputs are unused, and
 * inlined, dropped by the compiler). */
inline vfloat intersect_ellipsoid(__global const Ellipsoid *e, Ray r, vec3 *q)
{
    vfloat t_beyond;
    vec3 q_beyond;
    return ellipsoid_roots(e, r, q, &t_beyond, &q_beyond);
}

/* World-space unit normal at unit-sphere point q: the inverse-transpose of [a b c] applied to q. */
inline vec3 ellipsoid_normal(__global const Ellipsoid *e, vec3 q)
{
    return v3_scale(v3_normalize(mat3_apply_transposed(e->world_to_unit, q)), e->normal_sign);
}

/* The world point of the hit q, first put back on the unit sphere (pbrt-v4 section 6.8.5's reprojection),
 * and *err: its distance from the surface along the unit normal n. q / |q| is on the sphere to within 7
 * roundings (the dot product, rsqrt, the product); [a b c] q takes 3 more (a row of mads) and the sum with
 * the centre one, which is also all the centre's term takes; and [a b c] and its stored inverse are each
 * rounded from one float64 pair, which moves the surfaces they describe apart by at most 3 roundings of
 * |[a b c]| |q| along the normal: gamma(14) of |[a b c]| |q| in all. */
inline vec3 ellipsoid_point(__global const Ellipsoid *e, vec3 q, vec3 n, vfloat *err)
{
    vec3 unit = v3_normalize(q);
    vec3 centre = v3_uniform(e->center);
    vec3 p = v3_add(centre, mat3_apply(e->unit_to_world, unit));
    vec3 box = v3_add(v3_scale(v3_abs(centre), GAMMA(1)),
                      v3_scale(mat3_apply_abs(e->unit_to_world, v3_abs(unit)), GAMMA(14)));
    *err = error_along(n, box);
    return p;
}

#endif
