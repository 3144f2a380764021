/* Ray-ellipsoid intersection, the README's model, shapes: solve against the unit sphere in the ellipsoid's own
 * space (p + [a b c] x), where t is the same because the direction is mapped but not renormalised. */
#ifndef ELLIPSOID_CL
#define ELLIPSOID_CL

#include "ray.h"
#include "types.h"

inline vec3 mat3_apply(const __global float *m, vec3 v) /* row-major m times v */
{
    return v3(mad(m[0], v.x, mad(m[1], v.y, m[2] * v.z)), mad(m[3], v.x, mad(m[4], v.y, m[5] * v.z)),
              mad(m[6], v.x, mad(m[7], v.y, m[8] * v.z)));
}

inline vec3 mat3_apply_transposed(const __global float *m, vec3 v)
{
    return v3(mad(m[0], v.x, mad(m[3], v.y, m[6] * v.z)), mad(m[1], v.x, mad(m[4], v.y, m[7] * v.z)),
              mad(m[2], v.x, mad(m[5], v.y, m[8] * v.z)));
}

/* t in [tmin, tmax] (the near root, else the far one) or +inf; *q: the hit in unit-sphere space.
 *
 * Stable quadratic (Haines et al., Ray Tracing Gems ch. 7): with a = d.d, h = o.d, c = o.o - 1 the
 * discriminant h^2 - a c is rewritten as a (1 - |o - (h/a) d|^2), which does not cancel when the ray
 * passes far from the centre, and the two roots are q/a and c/q with q = -(h + sign(h) sqrt(disc)), so
 * neither root is a difference of nearly equal numbers. */
inline vfloat intersect_ellipsoid(__global const Ellipsoid *e, Ray r, vfloat tmin, vfloat tmax, vec3 *q)
{
    vec3 o = mat3_apply(e->world_to_unit, v3_sub(r.o, v3_uniform(e->center)));
    vec3 d = mat3_apply(e->world_to_unit, r.d);
    vfloat a = v3_dot(d, d), h = v3_dot(o, d), c = v3_dot(o, o) - 1.0f;
    vec3 f = v3_madd(o, -h / a, d);
    vfloat disc = a * (1.0f - v3_dot(f, f));
    vfloat root = -(h + copysign(sqrt(fmax(disc, 0.0f)), h));
    vfloat t0 = root / a, t1 = c / root;
    vfloat t_near = fmin(t0, t1), t_far = fmax(t0, t1);
    vfloat t = select(t_far, t_near, t_near >= tmin);
    *q = v3_madd(o, t, d);
    return select((vfloat)(INFINITY), t, (disc >= 0.0f) & (t >= tmin) & (t <= tmax));
}

/* World-space unit normal at unit-sphere point q: the inverse-transpose of [a b c] applied to q. */
inline vec3 ellipsoid_normal(__global const Ellipsoid *e, vec3 q)
{
    return v3_normalize(mat3_apply_transposed(e->world_to_unit, q));
}

#endif
