/* Instances of shape groups (Mitsuba's shapegroup and instance; types.h's Instance): a two-level hierarchy. The
 * top level's leaves hold the scene's shapes and, each alone in its leaf, the instances; an instance's group
 * keeps its triangles once, in its own space, under a BVH of their own. A traversal that reaches an instance
 * carries its rays into the group's space (pbrt-v4 section 7.1.4's TransformedPrimitive; Mitsuba's instance
 * does the same), traverses the group's tree there and brings the hits it found back (bvh.cl): the affine map
 * leaves a ray's t unchanged, since the direction is mapped but not renormalised.
 *
 * Error bounds: a hit's point and normal are mapped to the world, its bound grows with them: the local bound
 * carried by |A|, the map's own rounding, and the rounding the next ray's origin takes when it is carried back
 * into the group's space (so that a ray leaving the surface there still starts on the side it leaves to). */
#ifndef INSTANCES_CL
#define INSTANCES_CL

#include "affine.h"
#include "ray.h"
#include "types.h"

/* The ray r in instance `in`'s group space: o -> to_local (o - center), d -> to_local d. */
inline Ray instance_ray(__global const Instance *in, Ray r)
{
    Ray in_group = {mat3_apply(in->to_local, v3_sub(r.o, v3_uniform(in->center))), mat3_apply(in->to_local, r.d)};
    return in_group;
}

/* The world point of the group-space point p within err of its surface along the unit normal n (both in the
 * group's space), the world unit normal *n_world (the inverse transpose of the map: it keeps the side a normal
 * points to, and faces a ray as the local one faced the local ray), and *err_world. The bound: the local error
 * err n carried by |A| (A = to_world), the map's own 5 roundings and the centre's sum, plus 3 for A and its
 * stored inverse each being rounded once from one float64 pair; and the next ray's origin o carried back by
 * to_local (o - center): gamma(6) of |to_local| |A p| there, carried by |A| into the world. */
inline vec3 instance_point(__global const Instance *in, vec3 p, vec3 n, vfloat err, vec3 *n_world, vfloat *err_world)
{
    vec3 centre = v3_uniform(in->center);
    vec3 offset = mat3_apply(in->to_world, p);
    vec3 world = v3_add(centre, offset);
    *n_world = v3_normalize(mat3_apply_transposed(in->to_local, n));
    vec3 carried = mat3_apply_abs(in->to_world, v3_scale(v3_abs(n), err * (1.0f + GAMMA(5))));
    vec3 mapped = v3_add(v3_scale(mat3_apply_abs(in->to_world, v3_abs(p)), GAMMA(9)),
                         v3_scale(v3_abs(centre), GAMMA(1)));
    vec3 back = v3_scale(mat3_apply_abs(in->to_world, mat3_apply_abs(in->to_local, v3_abs(offset))), GAMMA(6));
    *err_world = error_along(*n_world, v3_add(carried, v3_add(mapped, back)));
    return world;
}

#endif
