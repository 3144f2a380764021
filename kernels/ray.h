/* Rays, and where secondary rays leave a surface: error-bounded offsets (pbrt-v4 sections 6.8.4-6.8.6).
 *
 * float32 hit points are off the true surface by their rounding error. Every intersection routine returns
 * the hit point with a conservative bound `err` on its distance from the surface along the normal, and a
 * secondary ray leaves from the point pushed along the normal by that bound, rounded away from the surface,
 * so that it starts strictly on the side it leaves to. Intersection routines in turn reject a hit whose t is
 * not conservatively away from the ray's ends (its own rounding bound `dt`), so a ray never meets the surface
 * it leaves. No constant epsilon: every bound scales with the magnitudes involved, so a scene renders the
 * same when it is scaled or moved (tests/test_offsets.py, tests/stability/). */
#ifndef RAY_H
#define RAY_H

#include "lanes.h"

typedef struct { vec3 o, d; } Ray;

/* gamma(n) = n u / (1 - n u), u = 2^-24: the relative error bound of n float32 roundings (Higham; pbrt-v4
 * section 6.8.1). OpenCL C allows 2.5 ulp for division and 2 ulp for rsqrt (OpenCL 1.2, section 7.4): they
 * count as 5 and 4 roundings below. MAD() may round once or twice: it counts as two. */
#define GAMMA(n) ((float)(n) * 0x1p-24f / (1.0f - (float)(n) * 0x1p-24f))

/* The far end of a parameter interval [near, far] whose two ends are each within gamma(n - 1) of their exact
 * values, widened for both errors and for the product's own rounding: near <= WIDENED(far, n) holds whenever
 * the exact interval is not empty, so a box test that uses it never misses (pbrt-v4 section 6.8.2 widens by
 * 2 gamma(3) this way). */
#define WIDENED(far, n) ((far) * (1.0f + 2.0f * GAMMA(n)))

inline vec3 v3_abs(vec3 a) { return v3(vabs(a.x), vabs(a.y), vabs(a.z)); }

/* The next float beyond x in the direction of `towards` where `away` is set (nextafter, written on the bits:
 * the builtin is an out-of-line call on PoCL, lanes.h). For finite x, stepping the bit pattern by one moves
 * away from zero, or towards it when the directions differ; from +-0 the next float is the smallest
 * subnormal of towards' sign. Infinite x stays. */
inline vfloat round_away(vfloat x, vfloat towards, vint away)
{
    vuint bits = AS_VUINT(x), sign = AS_VUINT(towards) & 0x80000000U;
    vuint next = SELECT(bits - 1U, bits + 1U, (bits & 0x80000000U) == sign);
    next = SELECT(next, sign | 1U, (bits << 1) == 0U);
    return SELECT(x, AS_VFLOAT(next), away & (vabs(x) < INFINITY));
}

/* Where a ray leaves a point p that is within err of a surface with unit normal n, to n's side: p + err n,
 * each coordinate rounded one float further, so that the sum's own rounding cannot bring it back. */
inline vec3 offset_ray_origin(vec3 p, vfloat err, vec3 n)
{
    vec3 o = v3_madd(p, err, n);
    vint moved = err > 0.0f;
    return v3(round_away(o.x, n.x, moved & (n.x != 0.0f)), round_away(o.y, n.y, moved & (n.y != 0.0f)),
              round_away(o.z, n.z, moved & (n.z != 0.0f)));
}

/* The distance along the unit normal n that a box of per-coordinate errors `box` can reach: |n|.box. */
inline vfloat error_along(vec3 n, vec3 box) { return v3_dot(v3_abs(n), box); }

/* Whether a hit at t with error bound dt is one for a ray leaving a surface at t = 0: conservatively past
 * the start (not the surface it leaves) and not beyond tmax. */
inline vint hit_in_range(vfloat t, vfloat dt, vfloat tmax) { return (t > dt) & (t <= tmax); }

/* The same for a shadow segment o + t d, t in (0, 1): conservatively short of its end too, where it meets
 * the light (an occluder flush with the light does not shadow it). */
inline vint hit_on_segment(vfloat t, vfloat dt) { return (t > dt) & (t < 1.0f - dt); }

#endif
