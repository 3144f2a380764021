/* exp2, log2, 1/sqrt, and sine and cosine of a quarter turn on lanes, written out for the shading loop and
 * the path model's sampling; floor, unit vectors and lengths for texturing.
 *
 * PoCL leaves its builtins as out-of-line calls (lanes.h), and the loop over light samples would make three
 * of them per sample, each spilling every live vector register. These run inline on any target, with error
 * bounds of their own (below, measured in tests/test_vmath.py); u = 2^-24, a float32 rounding. The
 * intersection routines keep the builtins: their error bounds count OpenCL's own ulp limits. */
#ifndef VMATH_H
#define VMATH_H

#include "lanes.h"

/* log2 x for finite x >= 0 (subnormal x counts as 0, and 0 gives -inf). x = 2^e m with m in [1/sqrt2,
 * sqrt2), and log2 m = (2 / ln 2) atanh s, s = (m - 1) / (m + 1), |s| <= 0.172: atanh s = s (1 + s^2/3 + ...
 * + s^8/9), the next term below 2e-9 (0.04u). m - 1 is exact (Sterbenz); m + 1 rounds once and the
 * division counts as 5 roundings (OpenCL's 2.5 ulp, ray.h); the polynomial and the two products 3 more, the
 * constant 2 / ln 2 one: log2 m within 10u relative, and e + log2 m within 10u |log2 m| + u |log2 x| <=
 * 11u |log2 x| (|log2 m| <= 1/2 <= |log2 x| when e != 0). Near x = 1, e = 0 and the error stays relative
 * to the small log2 x. (PoCL's division rounds correctly: 2.8u measured.) */
inline vfloat vlog2(vfloat x)
{
    vint bits = AS_VINT(x);
    vfloat m = AS_VFLOAT((bits & 0x007fffff) | 0x3f800000); /* [1, 2) */
    vint e = (bits >> 23) - 127, high = m > 1.41421356f;
    m = SELECT(m, 0.5f * m, high);
    e = SELECT(e, e + 1, high);
    vfloat s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
    vfloat series = MAD(s2, MAD(s2, MAD(s2, MAD(s2, 1.0f / 9.0f, 1.0f / 7.0f), 1.0f / 5.0f), 1.0f / 3.0f), 1.0f);
    vfloat l = CONVERT_VFLOAT(e) + (2.0f * 1.44269504f) * s * series;
    return SELECT(l, (vfloat)(-INFINITY), x < 0x1p-126f);
}

/* 2^z for z <= 0 (-inf gives 0; z > 0 is taken as 0). z = i + f with i an integer and f in (-1/2, 1/2],
 * exact; 2^f = e^(f ln 2) by Taylor to degree 7 (the remainder below 7e-9 relative, 0.12u), in Horner's
 * form: the last step 1 + f q rounds once and carries q's error scaled by |f q| <= 0.42, so the polynomial
 * is within 2u (3u without fused multiply-adds); 2^i is exact. Below 2^-126 the result is 0 or subnormal:
 * only its size is kept. */
inline vfloat vexp2(vfloat z)
{
    z = vmin(vmax(z, -127.0f), 0.0f);
    vint i = CONVERT_VINT(z - 0.5f); /* rounds toward 0: i = ceil(z - 1/2) for z <= 0 */
    vfloat f = z - CONVERT_VFLOAT(i);
    vfloat p = MAD(f, 1.5252734e-05f, 1.5403530e-04f); /* (ln 2)^k / k!, k = 7, 6, ... */
    p = MAD(f, p, 1.3333558e-03f);
    p = MAD(f, p, 9.6181291e-03f);
    p = MAD(f, p, 5.5504109e-02f);
    p = MAD(f, p, 2.4022651e-01f);
    p = MAD(f, p, 6.9314718e-01f);
    p = MAD(f, p, 1.0f);
    return p * AS_VFLOAT((i + 127) << 23); /* i = -127 scales by 0 */
}

/* sin x and cos x for |x| <= pi/4 (the concentric disk mapping's angles, path_tracing.cl): the minimax
 * polynomials of Cephes' sinf and cosf on that range (S. L. Moshier, Cephes Math Library, 1992), whose own
 * error is below 0.5u relative; Horner's 3 steps and the products add about 4 roundings of terms below
 * |x|^3/6 <= 0.081 |x| (sine) and of 1 - x^2/2 >= 0.69 (cosine): within 2u |sin x| and 2u of 1 for the
 * cosine, measured in tests/test_vmath.py. */
inline void vsincos_quarter(vfloat x, vfloat *s, vfloat *c)
{
    vfloat z = x * x;
    *s = MAD(x * z, MAD(MAD(-1.9515295891e-4f, z, 8.3321608736e-3f), z, -1.6666654611e-1f), x);
    *c = MAD(z * z, MAD(MAD(2.443315711809948e-5f, z, -1.388731625493765e-3f), z, 4.166664568298827e-2f),
             MAD(-0.5f, z, 1.0f));
}

/* 1 / sqrt(x) for normal, finite x > 0 (not for 0, subnormals or inf): the classic bit-level first guess
 * (relative error below 3.5e-2), then three Newton steps y (3/2 - x y^2 / 2), each taking the error e to
 * about 3/2 e^2 (1.8e-3, 4.6e-6, 3.2e-11); the last step rounds at most 3 times: within 4u. For directions whose length only scales what they are
 * compared with (shading), never for error-bounded points. */
inline vfloat vrsqrt(vfloat x)
{
    vfloat y = AS_VFLOAT(0x5f375a86 - (AS_VINT(x) >> 1)), half_x = 0.5f * x;
    y = y * (1.5f - half_x * y * y);
    y = y * (1.5f - half_x * y * y);
    return y * (1.5f - half_x * y * y);
}

inline vec3 v3_direction(vec3 a) { return v3_scale(a, vrsqrt(v3_dot(a, a))); }

/* a / |a| for finite a whose largest |coordinate| m is at least 2^-127 (below, 1 / m overflows): divided
 * by m first (exact to a rounding), |a|^2 lies in [1, 3], inside vrsqrt's domain, whatever a's size (a
 * normal map's float texels, a flat bump). Where a is smaller, 0 or not finite, the fallback: vmax may
 * drop a NaN coordinate from m, so |b|^2 < 4 (false for NaN) is checked as well. */
inline vec3 v3_unit_or(vec3 a, vec3 fallback)
{
    vfloat m = v3_max_abs(a);
    vint ok = m > 0.0f & m < INFINITY;
    vec3 b = v3_scale(a, 1.0f / SELECT((vfloat)(1.0f), m, ok));
    vfloat d = v3_dot(b, b);
    ok = ok & (d < 4.0f);
    return v3_select(fallback, v3_scale(b, vrsqrt(SELECT((vfloat)(1.0f), d, ok))), ok);
}

/* The length of (x, y) (texture footprints); where |(x, y)|^2 is below the normal range (a footprint far
 * under a texel), 0, and where it overflows (a huge uv_scale), 2^63: either way far past every level. */
inline vfloat v2_length(vfloat x, vfloat y)
{
    vfloat d = vmin(x * x + y * y, 0x1p126f);
    vint normal = d >= 0x1p-126f;
    return SELECT((vfloat)(0.0f), d * vrsqrt(SELECT((vfloat)(1.0f), d, normal)), normal);
}

/* Beyond 2^23 every float is an integer (and NaN stays NaN); below, truncation corrected downwards. */
inline vfloat vfloor(vfloat x)
{
    vfloat t = CONVERT_VFLOAT(CONVERT_VINT(x));
    return SELECT(x, SELECT(t, t - 1.0f, t > x), vabs(x) < 0x1p23f);
}

/* The same for scalar code: a textured hit's surface point, found once per lane (surface.cl), smooth
 * normals (material.cl) and the lights' constants (lights.cl). The builtins would each be a call there
 * too. The formulas are OpenCL's own. */
inline float dot3(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline float abs1(float x) { return as_float(as_uint(x) & 0x7fffffffU); }
inline float3 abs3(float3 v) { return (float3)(abs1(v.x), abs1(v.y), abs1(v.z)); }
/* One lane of the lane versions above: the same cost as a scalar version, without a second copy. */
inline float rsqrt1(float x) { return FIRST_LANE(vrsqrt((vfloat)(x))); }
/* Outside rsqrt1's domain (|v|^2 zero, subnormal or overflowing) the builtins, which rescale. */
inline int normal_square(float d) { return d >= 0x1p-126f && d < INFINITY; }
inline float3 normalize3(float3 v) { float d = dot3(v, v); return normal_square(d) ? v * rsqrt1(d) : normalize(v); }
inline float length_of(float2 v) { float d = v.x * v.x + v.y * v.y; return normal_square(d) ? d * rsqrt1(d) : length(v); }

/* Luminance of linear sRGB (Rec. 709 primaries, as Mitsuba's `luminance`): a float parameter's value of an RGB
 * texture (lookups.cl, Mitsuba's eval_1), the principled BSDFs' tint. Grey stays grey: the weights sum to 1. */
inline vfloat luminance(vec3 c) { return MAD(c.x, 0.212671f, MAD(c.y, 0.715160f, c.z * 0.072169f)); }

#endif
