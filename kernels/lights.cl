/* Rectangular area lights, sampled at points (u, v) in [0, 1)^2 of a sample pattern (samplers.cl). */
#ifndef LIGHTS_CL
#define LIGHTS_CL

#include "samplers.cl"

/* The point of the light at (u, v) in [0, 1)^2: c + (u - 1/2) sx t + (v - 1/2) sy b. */
inline vec3 light_point(__global const Light *light, vec2 uv)
{
    __global const Rectangle *r = &light->shape;
    vfloat du = (2.0f * uv.x - 1.0f) * r->half_x, dv = (2.0f * uv.y - 1.0f) * r->half_y;
    return v3(mad(du, r->tangent.x, mad(dv, r->bitangent.x, r->center.x)),
              mad(du, r->tangent.y, mad(dv, r->bitangent.y, r->center.y)),
              mad(du, r->tangent.z, mad(dv, r->bitangent.z, r->center.z)));
}

#endif
