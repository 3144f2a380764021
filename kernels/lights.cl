/* Rectangular area lights, sampled through a host-built table of (u, v) points in [0, 1)^2. */
#ifndef LIGHTS_CL
#define LIGHTS_CL

#include "types.h"

/* The point of the light at table entry (u, v): c + (u - 1/2) sx t + (v - 1/2) sy b. */
inline vec3 light_point(__global const Light *light, float2 uv)
{
    __global const Rectangle *r = &light->shape;
    float du = (2.0f * uv.x - 1.0f) * r->half_x, dv = (2.0f * uv.y - 1.0f) * r->half_y;
    return v3_splat(mad(du, r->tangent.x, mad(dv, r->bitangent.x, r->center.x)),
                    mad(du, r->tangent.y, mad(dv, r->bitangent.y, r->center.y)),
                    mad(du, r->tangent.z, mad(dv, r->bitangent.z, r->center.z)));
}

#endif
