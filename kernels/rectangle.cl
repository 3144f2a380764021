/* Ray-rectangle intersection, the README's model, shapes: the plane hit, then |(p-c).t| <= sx/2, |(p-c).b| <= sy/2. */
#ifndef RECTANGLE_CL
#define RECTANGLE_CL

#include "ray.h"
#include "types.h"

/* t of the hit in [tmin, tmax], or +inf. A ray parallel to the plane gets t = +-inf or NaN: a miss. */
inline vfloat intersect_rectangle(__global const Rectangle *rect, Ray r, vfloat tmin, vfloat tmax)
{
    vec3 n = v3_uniform(rect->normal);
    vec3 co = v3_sub(v3_uniform(rect->center), r.o);
    vfloat t = v3_dot(co, n) / v3_dot(r.d, n);
    vec3 rel = v3_madd(v3_scale(co, -1.0f), t, r.d); /* p - c, without forming p */
    vint inside = (fabs(v3_dot(rel, v3_uniform(rect->tangent))) <= rect->half_x)
                & (fabs(v3_dot(rel, v3_uniform(rect->bitangent))) <= rect->half_y);
    return select((vfloat)(INFINITY), t, inside & (t >= tmin) & (t <= tmax));
}

#endif
