/* A ray per lane: origin o, direction d (unit for camera rays, unnormalised for shadow segments). */
#ifndef RAY_H
#define RAY_H

#include "lanes.h"

typedef struct { vec3 o, d; } Ray;

inline vec3 ray_at(Ray r, vfloat t) { return v3_madd(r.o, t, r.d); }

/* Where a secondary ray leaves a surface. The float32 hit point is off the true surface by a few ulps
 * of its largest coordinate (plus the error of t, worst at grazing ellipsoid hits); pushing it along the
 * face-forwarded normal n by 2^-12 of that scale leaves a margin of ~2^9 over the worst error seen, yet
 * is far below any feature size of a scene in units of about 1 (0.25 mm at 1 m). */
#define RAY_OFFSET_REL 2.44140625e-4f /* 2^-12 */

inline vec3 offset_ray_origin(vec3 p, vec3 n)
{
    return v3_madd(p, RAY_OFFSET_REL * (1.0f + v3_max_abs(p)), n);
}

#endif
