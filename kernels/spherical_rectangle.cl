/* Sampling a rectangular light by the solid angle it subtends: Ureña, Fajardo and King, "An Area-Preserving
 * Parametrization for Spherical Rectangles" (EGSR 2013), as pbrt-v4's SampleSphericalRectangle (section 6.5.4
 * of the book). Seen from o, the rectangle is a spherical rectangle of solid angle S; the parametrization maps
 * [0, 1)^2 onto it with constant density 1 / S per steradian, so that a light sample's weight no longer carries
 * the factor cos(theta_l) / r^2, which varies over a light seen up close.
 *
 * In the rectangle's frame (tangent, bitangent, normal; the normal's sign flipped to point away from o) the
 * corners relative to o are (x0 or x1, y0 or y1, z0), z0 <= 0. Three quantities are computed so as to keep
 * their float32 accuracy where the paper's direct formulas lose it:
 * - the interior angles g_i of the spherical rectangle, each the angle between two planes through o and an
 *   edge, as atan2(|z0| |v|, +-x y) of the corner v the edges share (the paper's acos(-n_i . n_j), whose
 *   argument approaches +-1 where o nears the plane of an edge, there losing half its digits);
 * - the solid angle S as the sum of the two spherical triangles' angles by Van Oosterom and Strackee's
 *   formula (IEEE Trans. Biomed. Eng. 1983), tan(Omega / 2) = |a . (b x c)| / (|a||b||c| + (a . b)|c| + (a .
 *   c)|b| + (b . c)|a|), whose triple product is z0 (x1 - x0)(y1 - y0) exactly in this frame: no cancellation,
 *   where g0 + g1 + g2 + g3 - 2 pi cancels all but the last digits for a small or distant light;
 * - the paper's b0 = n0.z, b1 = n2.z and k = 2 pi - g2 - g3.
 * Two limits of float32 remain, and where either binds, light_sampling.cl samples the light by area instead
 * (spherical_rectangle_used):
 * - The sample's first coordinate, an angle au = u S + k in (0, 2 pi), has a float32 spacing of at most
 *   2^-21; over a light of S >= SOLID_ANGLE_MIN = 2^-10 sr that leaves more than 2000 steps, below it fewer.
 *   Such a light spans less than 2 degrees, over which the density of area sampling, proportional to
 *   cos(theta_l) / r^2, varies by a few percent at most.
 * - The sample's coordinates come from 1 - cu^2 and 1 - hv^2, whose true values are h^2 / (h^2 + x^2) and
 *   at least h^2 / (h^2 + y^2) for a point (x, y) of the light at height h = -z0 below o; computed from cu
 *   and hv, each difference carries an absolute error of a few 2^-24, so a light reaching further than
 *   GRAZING_MAX = 32 heights from o in x or y (o within 2 degrees of its plane, as seen from its far end)
 *   would get relative errors beyond 2^-12 there: a chi-square test of 2^18 samples detects them (seen at a
 *   ratio of 800). */
#ifndef SPHERICAL_RECTANGLE_CL
#define SPHERICAL_RECTANGLE_CL

#include "scene.h"
#include "vmath.h"

#define SOLID_ANGLE_MIN 0x1p-10f
#define GRAZING_MAX 32.0f

typedef struct {
    vfloat x0, y0, x1, y1, z0; /* the corners relative to o in the rectangle's frame, z0 <= 0 */
    vfloat b0, b1, k;          /* the paper's b0 = n0.z, b1 = n2.z and k = 2 pi - g2 - g3 */
    vfloat solid_angle;        /* S */
} SphericalRectangle;

/* Van Oosterom and Strackee's denominator for the spherical triangle o, a, b, c (relative positions a, b, c of
 * lengths la, lb, lc): its solid angle is 2 atan2(|a . (b x c)|, this). */
inline vfloat spherical_triangle_denominator(vec3 a, vec3 b, vec3 c, vfloat la, vfloat lb, vfloat lc)
{
    return la * lb * lc + v3_dot(a, b) * lc + v3_dot(a, c) * lb + v3_dot(b, c) * la;
}

/* atan2(y1, x1) + atan2(y2, x2) for two angles in [0, pi] (y1, y2 >= 0), by one atan2: the argument of the
 * product (x1 + i y1)(x2 + i y2), taken in [0, 2 pi). */
inline vfloat angle_sum(vfloat y1, vfloat x1, vfloat y2, vfloat x2)
{
    vfloat a = atan2(MAD(x1, y2, y1 * x2), MAD(x1, x2, -y1 * y2));
    return SELECT(a, a + 2.0f * M_PI_F, a < 0.0f);
}

/* The rectangle r as seen from each lane's point o. */
inline SphericalRectangle spherical_rectangle(__global const Rectangle *r, vec3 o)
{
    vec3 d = v3_sub(v3_uniform(r->center), o);
    vfloat cx = v3_dot(d, v3_uniform(r->tangent)), cy = v3_dot(d, v3_uniform(r->bitangent));
    SphericalRectangle q;
    q.x0 = cx - r->half_x;
    q.x1 = cx + r->half_x;
    q.y0 = cy - r->half_y;
    q.y1 = cy + r->half_y;
    q.z0 = -vabs(v3_dot(d, v3_uniform(r->normal)));
    vfloat z = -q.z0, z2 = z * z;
    vfloat r00 = sqrt(MAD(q.x0, q.x0, MAD(q.y0, q.y0, z2))), r01 = sqrt(MAD(q.x0, q.x0, MAD(q.y1, q.y1, z2)));
    vfloat r10 = sqrt(MAD(q.x1, q.x1, MAD(q.y0, q.y0, z2))), r11 = sqrt(MAD(q.x1, q.x1, MAD(q.y1, q.y1, z2)));
    q.k = 2.0f * M_PI_F - angle_sum(z * r01, q.x0 * q.y1, z * r00, -q.x0 * q.y0); /* 2 pi - g2 - g3 */
    q.b0 = -q.y0 * rsqrt(MAD(q.y0, q.y0, z2)); /* n0 = (0, z0, -y0) / |.| */
    q.b1 = q.y1 * rsqrt(MAD(q.y1, q.y1, z2));  /* n2 = (0, -z0, y1) / |.| */
    vec3 v00 = v3(q.x0, q.y0, q.z0), v10 = v3(q.x1, q.y0, q.z0), v11 = v3(q.x1, q.y1, q.z0), v01 = v3(q.x0, q.y1, q.z0);
    vfloat volume = z * (4.0f * r->half_x * r->half_y); /* |v00 . (v10 x v11)| = |z0| (x1 - x0)(y1 - y0) */
    q.solid_angle = 2.0f * angle_sum(volume, spherical_triangle_denominator(v00, v10, v11, r00, r10, r11),
                                     volume, spherical_triangle_denominator(v00, v11, v01, r00, r11, r01));
    return q;
}

/* Whether each lane samples the light by solid angle (spherical_rectangle_point) rather than by area. */
inline vint spherical_rectangle_used(SphericalRectangle q)
{
    vfloat reach = vmax(vmax(vabs(q.x0), vabs(q.x1)), vmax(vabs(q.y0), vabs(q.y1)));
    return (q.solid_angle >= SOLID_ANGLE_MIN) & (reach <= -GRAZING_MAX * q.z0);
}

/* The point of the rectangle, as (s, t) in [0, 1]^2 along its tangent and bitangent (light_point's
 * coordinates), that the uniform point u maps to with constant density 1 / S over the solid angle. */
inline vec2 spherical_rectangle_point(SphericalRectangle q, vec2 u)
{
    vfloat au = MAD(u.x, q.solid_angle, q.k);
    vfloat fu = (cos(au) * q.b0 - q.b1) / sin(au);
    vfloat cu = vcopysign(rsqrt(MAD(fu, fu, q.b0 * q.b0)), fu);
    cu = vmin(vmax(cu, (vfloat)(-1.0f)), (vfloat)(1.0f));
    vfloat xu = -(cu * q.z0) * rsqrt(vmax(1.0f - cu * cu, (vfloat)(FLT_MIN)));
    xu = vmin(vmax(xu, q.x0), q.x1);
    vfloat dd = sqrt(MAD(xu, xu, q.z0 * q.z0));
    vfloat h0 = q.y0 * rsqrt(MAD(dd, dd, q.y0 * q.y0)), h1 = q.y1 * rsqrt(MAD(dd, dd, q.y1 * q.y1));
    vfloat hv = MAD(u.y, h1 - h0, h0), hv2 = hv * hv;
    vfloat yv = SELECT(q.y1, hv * dd * rsqrt(1.0f - hv2), hv2 < 1.0f);
    yv = vmin(vmax(yv, q.y0), q.y1);
    vec2 st = {(xu - q.x0) / (q.x1 - q.x0), (yv - q.y0) / (q.y1 - q.y0)};
    return st;
}

#endif
