/* The local geometry of a hit for texturing: texture coordinates (u, v), the derivatives dp/du and dp/dv of
 * the shape's uv parameterisation, the shading frame they define, and the (u, v) footprint of a pixel
 * sample from ray differentials (pbrt-v4 sections 6.1-6.5 and 10.1).
 *
 * A hit's surface point is scalar code, run once per lane (material.cl): the shapes that lanes hit differ.
 * The frame and the footprint then run on lanes. */
#ifndef SURFACE_CL
#define SURFACE_CL

#include "affine.h"
#include "types.h"
#include "vmath.h"

typedef struct {
    float2 uv;
    float3 dpdu, dpdv;
    float3 n;       /* the shape's own unit normal, not turned toward the ray */
    float3 tangent; /* unit direction of dpdu, defined where dpdu vanishes (an ellipsoid's poles) too */
} SurfacePoint;

/* u along the tangent, v along the bitangent, both in [0, 1] over the rectangle (docs/model.md,
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
 * theta = atan2(q.y, q.x) (docs/model.md, texture coordinates), v = 1 - phi / pi with phi the angle
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
    sp.n = normalize3(mat3_mul_transposed(e->world_to_unit, q)) * e->normal_sign; /* as ellipsoid.cl's */
    sp.tangent = normalize3(mat3_mul(e->unit_to_world, (float3)(-sin_theta, cos_theta, 0.0f)));
    return sp;
}

/* Mitsuba's disk: polar coordinates of the local point q = to_local (p - c), u = r = |q.xy| and v = phi / 2 pi
 * in [0, 1), dp/du = to_world (cos phi, sin phi, 0), dp/dv = to_world (-sin phi, cos phi, 0) 2 pi r (its
 * compute_surface_interaction); at the centre, where dp/du vanishes, the tangent is to_world's x axis. */
inline SurfacePoint surface_disk(__global const Disk *k, float3 p)
{
    float3 q = mat3_mul(k->to_local, p - f3(k->center));
    float r = length_of(q.xy);
    float cos_phi = r > 0.0f ? q.x / r : 0.0f, sin_phi = r > 0.0f ? q.y / r : 0.0f;
    float v = atan2(q.y, q.x) / (2.0f * M_PI_F);
    SurfacePoint sp;
    sp.uv = (float2)(r, v < 0.0f ? v + 1.0f : v);
    sp.dpdu = mat3_mul(k->to_world, (float3)(cos_phi, sin_phi, 0.0f));
    sp.dpdv = mat3_mul(k->to_world, (float3)(-sin_phi, cos_phi, 0.0f) * (2.0f * M_PI_F * r));
    sp.n = normalize3((float3)(k->to_local[6], k->to_local[7], k->to_local[8])) * k->normal_sign;
    sp.tangent = normalize3(r > 0.0f ? sp.dpdu : mat3_mul(k->to_world, (float3)(1.0f, 0.0f, 0.0f)));
    return sp;
}

/* Mitsuba's cylinder: u = phi / 2 pi in [0, 1) around the axis from the local x axis, v = z along it,
 * dp/du = to_world 2 pi (-y, x, 0), dp/dv = to_world (0, 0, 1) (its compute_surface_interaction), with the
 * local point put back on the tube. */
inline SurfacePoint surface_cylinder(__global const Cylinder *k, float3 p)
{
    float3 q = mat3_mul(k->to_local, p - f3(k->center));
    float2 xy = q.xy / length_of(q.xy);
    float u = atan2(xy.y, xy.x) / (2.0f * M_PI_F);
    SurfacePoint sp;
    sp.uv = (float2)(u < 0.0f ? u + 1.0f : u, q.z);
    sp.dpdu = mat3_mul(k->to_world, (float3)(-xy.y, xy.x, 0.0f) * (2.0f * M_PI_F));
    sp.dpdv = mat3_mul(k->to_world, (float3)(0.0f, 0.0f, 1.0f));
    sp.n = normalize3(mat3_mul_transposed(k->to_local, (float3)(xy.x, xy.y, 0.0f))) * k->normal_sign;
    sp.tangent = normalize3(sp.dpdu);
    return sp;
}

typedef struct { vec2 uv; vec3 dpdu, dpdv, n, tangent; } Surface; /* SurfacePoint on lanes */

/* surface_rectangle on lanes, for lanes that all hit rectangle r: the same operations in the same order. */
inline Surface surface_rectangle_lanes(__global const Rectangle *r, vec3 p)
{
    vfloat rx = p.x - r->center.x, ry = p.y - r->center.y, rz = p.z - r->center.z;
    float3 t = f3(r->tangent), b = f3(r->bitangent), dpdu = t * (2.0f * r->half_x), dpdv = b * (2.0f * r->half_y);
    Surface s;
    s.uv.x = (rx * t.x + ry * t.y + rz * t.z) / (2.0f * r->half_x) + 0.5f;
    s.uv.y = (rx * b.x + ry * b.y + rz * b.z) / (2.0f * r->half_y) + 0.5f;
    s.dpdu = v3_splat(dpdu.x, dpdu.y, dpdu.z);
    s.dpdv = v3_splat(dpdv.x, dpdv.y, dpdv.z);
    s.n = v3_uniform(r->normal);
    s.tangent = v3_splat(t.x, t.y, t.z);
    return s;
}

/* The surface points of the lanes' hits, found one lane at a time (the shapes that lanes hit differ) and
 * moved into lanes for the rest of texturing. */
typedef struct { float u[LANES], v[LANES]; Lanes3 dpdu, dpdv, n, tangent; } SurfaceLanes;

inline void set_surface_lane(SurfaceLanes *a, int i, SurfacePoint sp)
{
    a->u[i] = sp.uv.x;
    a->v[i] = sp.uv.y;
    set_lane3(&a->dpdu, i, sp.dpdu);
    set_lane3(&a->dpdv, i, sp.dpdv);
    set_lane3(&a->n, i, sp.n);
    set_lane3(&a->tangent, i, sp.tangent);
}

inline Surface surface_fill(const SurfaceLanes *a)
{
    Surface s = {{VLOAD(a->u), VLOAD(a->v)}, v3_fill(&a->dpdu), v3_fill(&a->dpdv), v3_fill(&a->n),
                 v3_fill(&a->tangent)};
    return s;
}

typedef struct { vec3 t, b, n; } Frame;

/* Some unit vector orthogonal to the unit vector n (Duff et al., JCGT 2017). */
inline vec3 any_perpendicular(vec3 n)
{
    vfloat sign = vcopysign(1.0f, n.z), a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    return v3(MAD(sign * n.x * n.x, a, 1.0f), sign * b, -sign * n.x);
}

/* The orthonormal, right-handed tangent frame (t, b, n) of the uv parameterisation: t along dp/du,
 * b on dp/dv's side, n the shape's normal turned to dp/du x dp/dv's side. */
inline Frame shading_frame(Surface sp)
{
    Frame f;
    vec3 t = v3_sub(sp.tangent, v3_scale(sp.n, v3_dot(sp.n, sp.tangent)));
    f.t = v3_unit_or(t, any_perpendicular(sp.n));
    f.n = v3_select(sp.n, v3_scale(sp.n, -1.0f), v3_dot(sp.n, v3_cross(sp.dpdu, sp.dpdv)) < 0.0f);
    f.b = v3_cross(f.n, f.t);
    return f;
}

typedef struct { vfloat u_x, v_x, u_y, v_y; } UVDerivatives; /* du/dx, dv/dx, du/dy, dv/dy */

/* A derivative clamped to +-1e8, and 0 for NaN. */
inline vfloat finite_derivative(vfloat d)
{
    d = vmin(vmax(d, -1e8f), 1e8f);
    return SELECT((vfloat)(0.0f), d, d == d);
}

/* (du/dx, dv/dx, du/dy, dv/dy) from the offsets dpdx, dpdy of the point on the tangent plane: the
 * least-squares solution of dpdx = du/dx dp/du + dv/dx dp/dv (pbrt-v4 section 10.1.1). Where the
 * parameterisation degenerates (a pole) the system is singular: the result is 0, not NaN. */
inline UVDerivatives uv_derivatives(Surface sp, vec3 dpdx, vec3 dpdy)
{
    vfloat a00 = v3_dot(sp.dpdu, sp.dpdu), a01 = v3_dot(sp.dpdu, sp.dpdv), a11 = v3_dot(sp.dpdv, sp.dpdv);
    vfloat inv_det = 1.0f / (a00 * a11 - a01 * a01);
    inv_det = SELECT((vfloat)(0.0f), inv_det, vabs(inv_det) < INFINITY);
    vfloat bx0 = v3_dot(sp.dpdu, dpdx), bx1 = v3_dot(sp.dpdv, dpdx);
    vfloat by0 = v3_dot(sp.dpdu, dpdy), by1 = v3_dot(sp.dpdv, dpdy);
    UVDerivatives d = {finite_derivative((a11 * bx0 - a01 * bx1) * inv_det),
                       finite_derivative((a00 * bx1 - a01 * bx0) * inv_det),
                       finite_derivative((a11 * by0 - a01 * by1) * inv_det),
                       finite_derivative((a00 * by1 - a01 * by0) * inv_det)};
    return d;
}

#endif
