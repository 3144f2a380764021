/* Fresnel reflectance: of a conductor of complex index of refraction eta + i k, and of a dielectric interface
 * (the BSDFs of kernels/bsdfs/ share them). */
#ifndef FRESNEL_CL
#define FRESNEL_CL

#include "vmath.h"

/* The Fresnel reflectance of a conductor of complex index of refraction eta + i k (relative to the outside)
 * at cos(theta_i) in [0, 1], unpolarised: the exact formula in real arithmetic (pbrt-v3's FrConductor, after
 * Born and Wolf). eta = k = 0 gives 1: a perfect mirror, Mitsuba's conductor of material "none".
 *
 * Its largest term, t0^2 + 4 eta^2 k^2, is at most (m^2 + 1)^2 + 4 m^4 for m = max(eta, k): below float32's
 * 2^128 while m <= 2^31. Beyond, the formula runs on cos(theta_i), eta and k times the power of two s that
 * takes m into [2^30, 2^31), and on sin^2 and cos^2 times s^2. rs is a ratio of terms of degree 2 in (cos,
 * eta, k), sin^2 counting as of degree 2, so the scaling leaves it unchanged, and a power of two rounds
 * nothing; what underflows there (cos s, cos^2 s^2, sin^2 s^2) makes terms below 2^-60 of a2b2 >= 2^60,
 * which they are added to or taken from.
 * rp / rs is a ratio of terms of degree 4, t3 and t4, whose scaled products would underflow: they are taken
 * over s^2 a2b2 instead, t3 = cos^2 + sin^4 s^2 / a2b2 and t4 = 2 cos sin^2 s a / a2b2, normal numbers for
 * cos(theta_i) >= 2^-62 (nearer grazing the reflectance stays in [0, 1]). The reflectance tends to 1 as the
 * index grows. Up to m = 2^31, s = 1: the bits of the unscaled formula. */
inline vfloat fresnel_conductor(vfloat cos_i, vfloat eta, vfloat k)
{
    const vfloat cos2 = cos_i * cos_i, sin2 = 1.0f - cos2, m = vmax(eta, k);
    const vint scaled = m > 0x1p31f;
    const vfloat s = SELECT((vfloat)(1.0f), ldexp((vfloat)(1.0f), 30 - ilogb(vmax(m, (vfloat)(1.0f)))), scaled);
    const vfloat s2 = s * s, c = cos_i * s, e = eta * s, kk = k * s, c2 = cos2 * s2, n2 = sin2 * s2;
    vfloat t0 = e * e - kk * kk - n2;
    vfloat a2b2 = sqrt(vmax(MAD(t0, t0, 4.0f * e * e * kk * kk), (vfloat)(0.0f)));
    vfloat t1 = a2b2 + c2, a = sqrt(vmax(0.5f * (a2b2 + t0), (vfloat)(0.0f))), t2 = 2.0f * c * a;
    vfloat rs = (t1 - t2) / (t1 + t2);
    vfloat t3 = MAD(c2, a2b2, n2 * n2), t4 = t2 * n2;
    t3 = SELECT(t3, MAD(sin2 * sin2, s2 / a2b2, cos2), scaled);
    t4 = SELECT(t4, 2.0f * cos_i * sin2 * (s * a / a2b2), scaled);
    vfloat rp = SELECT(rs * (t3 - t4) / (t3 + t4), rs, t3 + t4 == 0.0f); /* 0 / 0: the mirror head-on */
    return 0.5f * (rp + rs);
}

/* The conductor's reflectance per channel. */
inline vec3 fresnel_conductor3(vfloat cos_i, vec3 eta, vec3 k)
{
    return v3(fresnel_conductor(cos_i, eta.x, k.x), fresnel_conductor(cos_i, eta.y, k.y),
              fresnel_conductor(cos_i, eta.z, k.z));
}

/* The Fresnel reflectance of a dielectric interface at cos(theta_i) in [0, 1] on the incident side, eta the
 * index of refraction beyond over the one before it; *cos_t the cosine of the refracted direction, and 1 with
 * *cos_t = 0 beyond the critical angle (total internal reflection): pbrt-v4's FrDielectric. */
inline vfloat fresnel_dielectric(vfloat cos_i, vfloat eta, vfloat *cos_t)
{
    vfloat sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    vint total = sin2_t >= 1.0f;
    vfloat ct = sqrt(vmax(1.0f - sin2_t, (vfloat)(0.0f)));
    vfloat r_parl = (eta * cos_i - ct) / (eta * cos_i + ct), r_perp = (cos_i - eta * ct) / (cos_i + eta * ct);
    *cos_t = SELECT(ct, (vfloat)(0.0f), total);
    return SELECT(0.5f * (r_parl * r_parl + r_perp * r_perp), (vfloat)(1.0f), total);
}

#endif
