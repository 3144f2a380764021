/* The local geometry of a hit for texturing: texture coordinates (u, v), the derivatives dp/du and dp/dv of
 * the shape's uv parameterisation, the shading frame they define, and the (u, v) footprint of a pixel
 * sample from ray differentials (pbrt-v4 sections 6.1-6.5 and 10.1).
 *
 * Scalar code, run once per lane (material.cl): the shapes that lanes hit differ. */
#ifndef SURFACE_CL
#define SURFACE_CL

#include "types.h"
#include "vmath.h"

typedef struct {
    float2 uv;
    float3 dpdu, dpdv;
    float3 n;       /* the shape's own unit normal, not turned toward the ray */
    float3 tangent; /* unit direction of dpdu, defined where dpdu vanishes (an ellipsoid's poles) too */
} SurfacePoint;

typedef struct { float3 t, b, n; } Frame;

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

/* u along the tangent, v along the bitangent, both in [0, 1] over the rectangle (the README's model,
 * texture coordinates). */
inline SurfacePoint surface_rectangle(__global const Rectangle *r, float3 p)
{
    float3 rel = p - f3(r->center), t = f3(r->tangent), b = f3(r->bitangent);
    SurfacePoint sp;
    sp.uv = (float2)(dot3(rel, t) / (2.0f * r->half_x) + 0.5f, dot3(rel, b) / (2.0f * r->half_y) + 0.5f);
    sp.dpdu = t * (2.0f * r->half_x);
    sp.dpdv = b * (2.0f * r->half_y);
    sp.n = f3(r->normal);
    sp.tangent = t;
    return sp;
}

/* uv interpolated from the vertices' with the barycentrics of the hit; dp/du, dp/dv precomputed. */
inline SurfacePoint surface_triangle(__global const Triangle *tri, __global const TriangleUV *tuv, float b1,
                                     float b2)
{
    __global const float *uv = tuv->uv;
    float b0 = 1.0f - b1 - b2;
    SurfacePoint sp;
    sp.uv = (float2)(b0 * uv[0] + b1 * uv[2] + b2 * uv[4], b0 * uv[1] + b1 * uv[3] + b2 * uv[5]);
    sp.dpdu = f3(tuv->dpdu);
    sp.dpdv = f3(tuv->dpdv);
    sp.n = f3(tri->normal);
    sp.tangent = f3(tuv->tangent);
    return sp;
}

/* Spherical coordinates of the unit-sphere point q = M^-1 (p - c): u = theta / 2 pi + 1/2 with
 * theta = atan2(q.y, q.x) (the README's model, texture coordinates), v = 1 - phi / pi with phi the angle
 * from the north pole, so v runs up the image as it does on the other shapes (pbrt-v4's sphere). q is
 * renormalised first: the hit point is off the surface by its rounding error. The angles come from atan2
 * alone, accurate at the poles where acos(q.z) is not; theta's wrap at the seam moves u by exactly 1,
 * which repeat wrapping ignores, and the derivatives are analytic, so the seam has no footprint of its own. */
inline SurfacePoint surface_ellipsoid(__global const Ellipsoid *e, float3 p)
{
    float3 q = normalize3(mat3_mul(e->world_to_unit, p - f3(e->center)));
    float sin_phi = length_of(q.xy);
    float cos_theta = sin_phi > 0.0f ? q.x / sin_phi : 1.0f, sin_theta = sin_phi > 0.0f ? q.y / sin_phi : 0.0f;
    const float pi = M_PI_F;
    SurfacePoint sp;
    sp.uv = (float2)(atan2(q.y, q.x) / (2.0f * pi) + 0.5f, 1.0f - atan2(sin_phi, q.z) / pi);
    sp.dpdu = mat3_mul(e->unit_to_world, (float3)(-q.y, q.x, 0.0f) * (2.0f * pi));
    sp.dpdv = mat3_mul(e->unit_to_world, (float3)(q.z * cos_theta, q.z * sin_theta, -sin_phi) * -pi);
    sp.n = normalize3(mat3_mul_transposed(e->world_to_unit, q)); /* the inverse-transpose, as ellipsoid.cl */
    sp.tangent = normalize3(mat3_mul(e->unit_to_world, (float3)(-sin_theta, cos_theta, 0.0f)));
    return sp;
}

/* Some unit vector orthogonal to the unit vector n (Duff et al., JCGT 2017). */
inline float3 any_perpendicular(float3 n)
{
    float sign = copysign(1.0f, n.z), a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    return (float3)(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
}

/* The orthonormal, right-handed tangent frame (t, b, n) of the uv parameterisation: t along dp/du,
 * b on dp/dv's side, n the shape's normal turned to dp/du x dp/dv's side. */
inline Frame shading_frame(SurfacePoint sp)
{
    Frame f;
    float3 t = sp.tangent - sp.n * dot3(sp.n, sp.tangent);
    float len2 = dot3(t, t);
    f.t = len2 > 0.0f ? t * rsqrt1(len2) : any_perpendicular(sp.n);
    f.n = dot3(sp.n, cross3(sp.dpdu, sp.dpdv)) < 0.0f ? -sp.n : sp.n;
    f.b = cross3(f.n, f.t);
    return f;
}

/* (du/dx, dv/dx, du/dy, dv/dy) from the offsets dpdx, dpdy of the point on the tangent plane: the
 * least-squares solution of dpdx = du/dx dp/du + dv/dx dp/dv (pbrt-v4 section 10.1.1). Where the
 * parameterisation degenerates (a pole) the system is singular: the result is 0, not NaN. */
inline float4 uv_derivatives(SurfacePoint sp, float3 dpdx, float3 dpdy)
{
    float a00 = dot3(sp.dpdu, sp.dpdu), a01 = dot3(sp.dpdu, sp.dpdv), a11 = dot3(sp.dpdv, sp.dpdv);
    float inv_det = 1.0f / (a00 * a11 - a01 * a01);
    inv_det = finite1(inv_det) ? inv_det : 0.0f;
    float bx0 = dot3(sp.dpdu, dpdx), bx1 = dot3(sp.dpdv, dpdx), by0 = dot3(sp.dpdu, dpdy), by1 = dot3(sp.dpdv, dpdy);
    float4 d = (float4)(a11 * bx0 - a01 * bx1, a00 * bx1 - a01 * bx0, a11 * by0 - a01 * by1, a00 * by1 - a01 * by0)
               * inv_det;
    return select(clamp(d, -1e8f, 1e8f), (float4)(0.0f), isnan(d));
}

#endif
