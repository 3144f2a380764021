/* Rectangular area lights, sampled at points (u, v) in [0, 1)^2 of a sample pattern (samplers.cl), and the
 * shadow segments towards those points. */
#ifndef LIGHTS_CL
#define LIGHTS_CL

#include "ray.h"
#include "samplers.cl"
#include "vmath.h"

/* The point of the light at (u, v) in [0, 1)^2: c + (u - 1/2) sx t + (v - 1/2) sy b. */
inline vec3 light_point(__global const Light *light, vec2 uv)
{
    __global const Rectangle *r = &light->shape;
    vfloat du = (2.0f * uv.x - 1.0f) * r->half_x, dv = (2.0f * uv.y - 1.0f) * r->half_y;
    return v3(MAD(du, r->tangent.x, MAD(dv, r->bitangent.x, r->center.x)),
              MAD(du, r->tangent.y, MAD(dv, r->bitangent.y, r->center.y)),
              MAD(du, r->tangent.z, MAD(dv, r->bitangent.z, r->center.z)));
}

/* A bound on the distance of every light_point() from the light's plane: four roundings of the sum c + du t + dv b
 * (|du| <= sx/2, |dv| <= sy/2; du and dv's own rounding moves the point within the plane), plus du t.n + dv b.n,
 * the stored unit vectors being orthogonal only to within two roundings each (rectangle.cl). */
inline float light_point_error(__global const Light *light)
{
    __global const Rectangle *r = &light->shape;
    float3 n = abs3(f3(r->normal));
    float3 box = abs3(f3(r->center)) + abs3(f3(r->tangent)) * r->half_x + abs3(f3(r->bitangent)) * r->half_y;
    return GAMMA(4) * dot3(n, box) + GAMMA(2) * (r->half_x + r->half_y);
}

/* The shadow segment from `origin` (already off its surface) to the light point q (within q_err of the light's
 * plane): it ends at q pushed off the light toward the origin by q's error, and by that of the segment's
 * direction, which rounds once: the segment's true end o + fl(q' - o) is within one rounding of |q' - o| of
 * q' (pbrt-v4's SpawnRayTo, section 6.8.6). */
inline Ray shadow_segment(vec3 origin, vec3 q, vfloat q_err, vec3 light_normal)
{
    vec3 to_origin = v3_sub(origin, q);
    vec3 n = v3_scale(light_normal, SELECT((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(light_normal, to_origin) < 0.0f));
    vfloat err = q_err + GAMMA(2) * error_along(n, v3_abs(to_origin));
    Ray r = {origin, v3_sub(offset_ray_origin(q, err, n), origin)};
    return r;
}

#endif
