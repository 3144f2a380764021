/* 3 x 3 matrices stored row-major as 9 floats (the affine-mapped shapes' to_local and to_world: ellipsoid.cl,
 * disk.cl, cylinder.cl) applied to vectors on lanes, and |m| applied to |v| for their error bounds. Each
 * output coordinate is a chain of two MAD()s after a product: at most 5 roundings (ray.h counts a MAD as
 * two), gamma(5) of the |m| |v| that mat3_apply_abs gives. */
#ifndef AFFINE_H
#define AFFINE_H

#include "lanes.h"
#include "vmath.h"

inline vec3 mat3_apply(const __global float *m, vec3 v) /* row-major m times v */
{
    return v3(MAD(m[0], v.x, MAD(m[1], v.y, m[2] * v.z)), MAD(m[3], v.x, MAD(m[4], v.y, m[5] * v.z)),
              MAD(m[6], v.x, MAD(m[7], v.y, m[8] * v.z)));
}

inline vec3 mat3_apply_abs(const __global float *m, vec3 v) /* |m| times v, for error bounds */
{
    return v3(MAD(vabs(m[0]), v.x, MAD(vabs(m[1]), v.y, vabs(m[2]) * v.z)),
              MAD(vabs(m[3]), v.x, MAD(vabs(m[4]), v.y, vabs(m[5]) * v.z)),
              MAD(vabs(m[6]), v.x, MAD(vabs(m[7]), v.y, vabs(m[8]) * v.z)));
}

inline vec3 mat3_apply_transposed(const __global float *m, vec3 v)
{
    return v3(MAD(m[0], v.x, MAD(m[3], v.y, m[6] * v.z)), MAD(m[1], v.x, MAD(m[4], v.y, m[7] * v.z)),
              MAD(m[2], v.x, MAD(m[5], v.y, m[8] * v.z)));
}

/* The same on one lane's float3 (the shading code's per-lane values). */
inline float3 mat3_mul(const __global float *m, float3 v) /* row-major m times v */
{
    return (float3)(dot3((float3)(m[0], m[1], m[2]), v), dot3((float3)(m[3], m[4], m[5]), v),
                    dot3((float3)(m[6], m[7], m[8]), v));
}

inline float3 mat3_mul_transposed(const __global float *m, float3 v)
{
    return (float3)(dot3((float3)(m[0], m[3], m[6]), v), dot3((float3)(m[1], m[4], m[7]), v),
                    dot3((float3)(m[2], m[5], m[8]), v));
}

#endif
