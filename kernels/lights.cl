/* Rectangular area lights, sampled at points (u, v) in [0, 1)^2 of a sample pattern (samplers.cl). */
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

#endif
