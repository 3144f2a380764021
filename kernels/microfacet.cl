/* The microfacet distributions of rough surfaces, in the local frame of the surface (z along the shading
 * normal, x along the tangent: the direction of u, alpha_u's axis): the distribution of normals D, Smith's
 * masking G1 and masking-shadowing G (Mitsuba 3's separable form), and sampling of the normals visible from a
 * direction. Two distributions, with Mitsuba 3's names and parameters (its MicrofacetDistribution): GGX
 * (Trowbridge-Reitz; Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007), and
 * Beckmann's, of a Gaussian random surface (Beckmann and Spizzichino 1963; Walter et al. 2007), compiled only
 * where a scene uses it (HAS_BECKMANN). alpha is the roughness, the
 * distribution's slope scale (GGX's, and Beckmann's RMS slope over sqrt 2): 0 a mirror, 1 very rough;
 * anisotropic surfaces (HAS_ANISOTROPIC) have alpha_u along x and alpha_v along y (Mitsuba's stretched forms,
 * Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 2014, section 5).
 *
 * The ggx_* functions are GGX's isotropic forms, of cosines alone. The microfacet_* functions take the
 * distribution (MICROFACET_*, per lane) and both alphas; in a build without anisotropy they read alpha_u
 * alone and only the cosines of their directions (and the sign of dot(v, m)), and are the ggx_* forms where
 * the distribution is GGX: an isotropic GGX scene renders as it did before the general forms existed. */
#ifndef MICROFACET_CL
#define MICROFACET_CL

#include "types.h"
#include "vmath.h"

/* D(h) = 1 / (pi alpha^2 cos^4(theta_h) (1 + tan^2(theta_h) / alpha^2)^2), written without the tangent so
 * that it holds at theta_h = 0: with c = cos^2, D = alpha^2 / (pi (c alpha^2 + (1 - c))^2). Zero below the
 * horizon. The denominator is summed so, not as c (alpha^2 - 1) + 1, and c is clamped to 1: below alpha =
 * 1.7e-4 (alpha^2 < 2^-25; roughplastic's clamp is Mitsuba's 1e-4) alpha^2 - 1 rounds to -1, and at the peak
 * (c = 1) D was alpha^2 / 0 = inf, a sample's weight inf / inf; and a normalised h may have h.z one ulp above
 * 1 (c - 1 = 2^-22), which cancels alpha^2 near 2^-22 (alpha 2^-11) to nothing. So the denominator is at
 * least c alpha^2 and D at most 1 / (pi alpha^2 c), 3.2e7 at alpha 1e-4 (found by the fuzz suite). */
inline vfloat ggx_d(vec3 h, vfloat alpha)
{
    vfloat a2 = alpha * alpha, c = vmin(h.z * h.z, (vfloat)(1.0f)), d = MAD(c, a2, 1.0f - c);
    return SELECT(a2 / (M_PI_F * d * d), (vfloat)(0.0f), h.z <= 0.0f);
}

/* Smith's Lambda(w) = (sqrt(1 + alpha^2 tan^2(theta)) - 1) / 2, from cos(theta) (tan^2 = (1 - c^2) / c^2),
 * in a form without the cancellation of sqrt(1 + x) - 1 at small x: x / (sqrt(1 + x) + 1) / 2. */
inline vfloat ggx_lambda(vec3 w, vfloat alpha)
{
    vfloat c2 = w.z * w.z, x = alpha * alpha * vmax(1.0f - c2, (vfloat)(0.0f)) / c2;
    return 0.5f * x / (sqrt(1.0f + x) + 1.0f);
}

/* The share of the microfacets facing w that w sees, G1(w) = 1 / (1 + Lambda(w)), and of both directions,
 * G2(wo, wi). Heitz ("Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 2014)
 * gives two Smith forms for reflection: the separable G1(wo) G1(wi) (eq. 98), masking and shadowing
 * independent, and the height-correlated 1 / (1 + Lambda(wo) + Lambda(wi)) (eq. 99, pbrt-v4 9.6.3), which
 * counts a microfacet high enough to be seen from wo as likelier seen from wi too, and is at least the
 * separable one (by 5% of a rough mirror's albedo at alpha 0.6 seen 69 degrees off the normal). raytrace
 * takes the separable form: Mitsuba 3's roughconductor does (MicrofacetDistribution::G), and raytrace
 * renders Mitsuba's scenes as Mitsuba does (the height-correlated form left the rim of a rough gold sphere
 * 1.5 to 2.5% brighter than Mitsuba's: scenes/mitsuba/roughconductor_rim.xml). */
inline vfloat ggx_g1(vec3 w, vfloat alpha) { return 1.0f / (1.0f + ggx_lambda(w, alpha)); }
inline vfloat ggx_g2(vec3 wo, vec3 wi, vfloat alpha)
{
    return ggx_g1(wo, alpha) * ggx_g1(wi, alpha); /* symmetric to the bit: a product of two roundings */
}

/* A microfacet normal visible from wo (wo.z > 0), with density D_wo(h) = G1(wo) max(0, dot(wo, h)) D(h) / wo.z,
 * from u in [0, 1)^2 (Heitz 2018, listing 1): wo stretched to the unit-roughness configuration, a point on
 * the projected disk of the hemisphere it sees, lifted onto the hemisphere and unstretched. Anisotropic GGX
 * stretches x by alpha_u and y by alpha_v (Heitz's listing takes both); with alpha_u = alpha_v = alpha this is
 * the isotropic sampler's arithmetic, operation for operation. Mitsuba 3 samples the same density through
 * slopes (Heitz, "A Simpler and Exact Sampling Routine for the GGX Distribution of Visible Normals", 2017): the
 * same normals, from other u. */
inline vec3 ggx_sample_visible_normal_uv(vec3 wo, vfloat alpha_u, vfloat alpha_v, vec2 u)
{
    vec3 v = v3_direction(v3(alpha_u * wo.x, alpha_v * wo.y, wo.z));
    vfloat len2 = v.x * v.x + v.y * v.y, inv = vrsqrt(len2);
    vint flat = len2 <= 0.0f;
    vec3 t1 = v3(SELECT(-v.y * inv, (vfloat)(1.0f), flat), SELECT(v.x * inv, (vfloat)(0.0f), flat), (vfloat)(0.0f));
    vec3 t2 = v3_cross(v, t1);
    vfloat r = sqrt(u.x), phi = 2.0f * M_PI_F * u.y;
    vfloat p1 = r * cos(phi), p2 = r * sin(phi), s = 0.5f * (1.0f + v.z);
    p2 = MAD(1.0f - s, sqrt(vmax(1.0f - p1 * p1, (vfloat)(0.0f))), s * p2);
    vfloat p3 = sqrt(vmax(1.0f - p1 * p1 - p2 * p2, (vfloat)(0.0f)));
    vec3 n = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)), v3_scale(v, p3));
    return v3_direction(v3(alpha_u * n.x, alpha_v * n.y, vmax(n.z, (vfloat)(0.0f))));
}

inline vec3 ggx_sample_visible_normal(vec3 wo, vfloat alpha, vec2 u)
{
    return ggx_sample_visible_normal_uv(wo, alpha, alpha, u);
}

/* The density of wi sampled by reflecting wo (wo.z > 0) about a visible normal: D_wo(h) / (4 dot(wo, h)) with h the
 * half vector, = G1(wo) D(h) / (4 wo.z) (the Jacobian of reflection, pbrt-v4 9.6.5); 0 where dot(wo, h) <= 0. */
inline vfloat ggx_reflection_pdf(vec3 wo, vec3 wi, vfloat alpha)
{
    vec3 h = v3_direction(v3_add(wo, wi));
    vfloat pdf = ggx_g1(wo, alpha) * ggx_d(h, alpha) / (4.0f * wo.z);
    return SELECT(pdf, (vfloat)(0.0f), v3_dot(wo, h) <= 0.0f);
}

/* f cos(theta_i) / p of wi sampled so (as above), without the Fresnel factor: with f = F D G2 / (4 wo.z wi.z),
 * G2 = G1(wo) G1(wi), and p = G1(wo) D / (4 wo.z), all but G1(wi) cancels: wo drops out (the
 * height-correlated G2 would leave G2 / G1(wo)). Mitsuba's sample() weight, smith_g1(bs.wo, m) (its bs.wo the
 * sampled direction, wi here). For wi.z > 0: the caller drops the samples below the horizon. */
inline vfloat ggx_reflection_weight(vec3 wo, vec3 wi, vfloat alpha)
{
    (void)wo;
    return ggx_g1(wi, alpha);
}

/* ---------------------------------------------------------------------------------------------------------
 * The general distribution: GGX or Beckmann per lane, isotropic or anisotropic, as Mitsuba 3's
 * MicrofacetDistribution (eval, smith_g1, G, sample, pdf). Directions are unit vectors of the local frame. */

#if HAS_BECKMANN
/* erf x on lanes, inline (PoCL leaves its erf an out-of-line call: vmath.h): Dr.Jit's single-precision fit
 * (Dr.Jit's erf; Remez fits, 2 ulp on [0, 1] in x^2, 2.6 ulp on [1, 4] as 1 - 2^(c(|x|) |x|)), which
 * Mitsuba's scalar variants evaluate; |x| past 6, where erf is 1 in float32, is taken as 6. vexp2 adds its 2u. */
inline vfloat verf(vfloat x)
{
    vfloat xa = vmin(vabs(x), (vfloat)(6.0f)), x2 = x * x;
    vfloat c0 = MAD(x2, MAD(x2, MAD(x2, MAD(x2, MAD(x2, -0x1.273facp-11f, 0x1.4246b4p-8f), -0x1.b5a334p-6f),
                                     0x1.ce0934p-4f), -0x1.812672p-2f), 0x1.20dd74p+0f);
    vfloat c1 = MAD(xa, MAD(xa, MAD(xa, MAD(xa, MAD(xa, MAD(xa, -0x1.8ca9f6p-16f, 0x1.180f1ep-11f), -0x1.6856bep-8f),
                                               0x1.1c395cp-5f), -0x1.3a904cp-3f), -0x1.d51e3ap-1f), -0x1.a0d71ap+0f);
    vfloat tail = vcopysign(1.0f - vexp2(c1 * xa), x);
    return SELECT(tail, x * c0, xa < 1.0f);
}

/* erf^-1 x for |x| < 1: Giles's single-precision polynomials ("Approximating the erfinv function", GPU Computing
 * Gems Jade Edition, 2011), as Dr.Jit's erfinv, in w = -ln(1 - x^2) (vlog2: 11u relative to the logarithm). */
inline vfloat verfinv(vfloat x)
{
    vfloat w = -0.69314718f * vlog2((1.0f - x) * (1.0f + x)), w1 = w - 2.5f, w2 = sqrt(w) - 3.0f;
    vfloat p1 = 2.81022636e-08f;
    p1 = MAD(p1, w1, 3.43273939e-07f);
    p1 = MAD(p1, w1, -3.5233877e-06f);
    p1 = MAD(p1, w1, -4.39150654e-06f);
    p1 = MAD(p1, w1, 0.00021858087f);
    p1 = MAD(p1, w1, -0.00125372503f);
    p1 = MAD(p1, w1, -0.00417768164f);
    p1 = MAD(p1, w1, 0.246640727f);
    p1 = MAD(p1, w1, 1.50140941f);
    vfloat p2 = -0.000200214257f;
    p2 = MAD(p2, w2, 0.000100950558f);
    p2 = MAD(p2, w2, 0.00134934322f);
    p2 = MAD(p2, w2, -0.00367342844f);
    p2 = MAD(p2, w2, 0.00573950773f);
    p2 = MAD(p2, w2, -0.0076224613f);
    p2 = MAD(p2, w2, 0.00943887047f);
    p2 = MAD(p2, w2, 1.00167406f);
    p2 = MAD(p2, w2, 2.83297682f);
    return SELECT(p2, p1, w < 5.0f) * x;
}

/* Beckmann's D(m) = exp(-tan^2(theta_m) / alpha^2) / (pi alpha^2 cos^4(theta_m)) (Walter et al. 2007, eq. 33),
 * anisotropic: tan^2 / alpha^2 = ((m.x / alpha_u)^2 + (m.y / alpha_v)^2) / cos^2. Isotropic builds have only
 * the cosine: tan^2 = (1 - cos^2) / cos^2. 0 where D cos(theta_m) <= 1e-20 (Mitsuba's guard; it also takes the
 * horizon's 0 / 0 and the lanes below it). */
inline vfloat beckmann_d(vfloat alpha_u, vfloat alpha_v, vec3 m)
{
    vfloat c2 = m.z * m.z;
#if HAS_ANISOTROPIC
    vfloat x = m.x / alpha_u, y = m.y / alpha_v, e = (x * x + y * y) / c2;
#else
    vfloat e = vmax(1.0f - c2, (vfloat)(0.0f)) / (c2 * alpha_u * alpha_u);
    alpha_v = alpha_u;
#endif
    vfloat d = vexp2(-1.44269504f * e) / (M_PI_F * alpha_u * alpha_v * c2 * c2);
    return SELECT((vfloat)(0.0f), d, d * m.z > 1e-20f);
}

/* Smith's G1 of Beckmann's distribution, 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi))) with a = 1 / (alpha
 * tan(theta_v)) (Walter et al. 2007, eq. 27), by Walter et al.'s rational fit (eq. 27's, below 0.35% off; 1 from
 * a = 1.6), as Mitsuba 3 evaluates it (smith_g1): Mitsuba's images are the target. xy_alpha2 is
 * (alpha_u v.x)^2 + (alpha_v v.y)^2; at normal incidence a is inf, and G1 1. */
inline vfloat beckmann_g1(vfloat xy_alpha2, vfloat cos_v)
{
    vfloat a = sqrt(cos_v * cos_v / xy_alpha2), a2 = a * a;
    vfloat g = MAD(2.181f, a2, 3.535f * a) / MAD(2.577f, a2, MAD(2.276f, a, 1.0f));
    return SELECT(g, (vfloat)(1.0f), a >= 1.6f);
}

/* The slopes of a normal of the unit-roughness Beckmann distribution visible from a direction cos_i off the
 * normal (and azimuth 0), from u: Mitsuba 3's sample_visible_11 (Jakob, "An Improved Visible Normal Sampling
 * Routine for the Beckmann Distribution", 2014): the slope along the plane of incidence by three Newton steps
 * on its CDF, parameterised in the erf domain, from the closed form at grazing incidence; the slope across it
 * is a Gaussian's, erfinv(2 u.y - 1). Mitsuba clamps u to [1e-6, 1 - 1e-6]. */
inline vec2 beckmann_visible_slopes(vfloat cos_i, vec2 u)
{
    const float inv_sqrt_pi = 0.56418958f;
    vfloat tan_i = sqrt(vmax(1.0f - cos_i * cos_i, (vfloat)(0.0f))) / cos_i, cot_i = 1.0f / tan_i;
    vfloat maxval = verf(cot_i);
    vfloat ux = vmin(vmax(u.x, (vfloat)(1e-6f)), (vfloat)(1.0f - 1e-6f));
    vfloat uy = vmin(vmax(u.y, (vfloat)(1e-6f)), (vfloat)(1.0f - 1e-6f));
    vfloat x = maxval - (maxval + 1.0f) * verf(sqrt(-0.69314718f * vlog2(ux)));
    vfloat target = ux * (1.0f + maxval + inv_sqrt_pi * tan_i * vexp2(-1.44269504f * cot_i * cot_i));
    for (int k = 0; k < 3; ++k) {
        vfloat slope = verfinv(x);
        vfloat value = 1.0f + x + inv_sqrt_pi * tan_i * vexp2(-1.44269504f * slope * slope) - target;
        x -= value / (1.0f - slope * tan_i);
    }
    vec2 r = {verfinv(x), verfinv(MAD(2.0f, uy, -1.0f))};
    return r;
}

/* A normal visible from wi (wi.z > 0) of the anisotropic Beckmann distribution (Mitsuba 3's sample(), visible
 * normals): wi stretched to the unit-roughness configuration, its azimuth's sine and cosine (Frame3f::sincos_phi:
 * 1, 0 within 4 epsilon of the pole), the slopes sampled there, rotated to that azimuth and unstretched; the
 * normal of slopes (s_x, s_y) is (-s_x, -s_y, 1) normalised (Heitz and d'Eon, "Importance Sampling
 * Microfacet-Based BSDFs using the Distribution of Visible Normals", EGSR 2014). */
inline vec3 beckmann_sample_visible_normal(vec3 wi, vfloat alpha_u, vfloat alpha_v, vec2 u)
{
    vec3 w = v3_direction(v3(alpha_u * wi.x, alpha_v * wi.y, wi.z));
    vfloat s2 = w.x * w.x + w.y * w.y, inv = vrsqrt(SELECT(s2, (vfloat)(1.0f), s2 <= 0.0f));
    vint pole = s2 <= 4.0f * 0x1p-24f;
    vfloat cos_phi = SELECT(vmin(vmax(w.x * inv, (vfloat)(-1.0f)), (vfloat)(1.0f)), (vfloat)(1.0f), pole);
    vfloat sin_phi = SELECT(vmin(vmax(w.y * inv, (vfloat)(-1.0f)), (vfloat)(1.0f)), (vfloat)(0.0f), pole);
    vec2 slope = beckmann_visible_slopes(w.z, u);
    vfloat sx = (cos_phi * slope.x - sin_phi * slope.y) * alpha_u;
    vfloat sy = (sin_phi * slope.x + cos_phi * slope.y) * alpha_v;
    return v3_direction(v3(-sx, -sy, (vfloat)(1.0f)));
}
#endif

/* D(m) of the lanes' distributions. GGX's anisotropic form is 1 / (pi alpha_u alpha_v ((m.x / alpha_u)^2 +
 * (m.y / alpha_v)^2 + m.z^2)^2), 0 where D cos(theta_m) <= 1e-20 (Mitsuba's eval); isotropic builds take
 * ggx_d. */
inline vfloat microfacet_d(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 m)
{
#if HAS_ANISOTROPIC
    vfloat x = m.x / alpha_u, y = m.y / alpha_v, s = MAD(x, x, MAD(y, y, m.z * m.z));
    vfloat d = 1.0f / (M_PI_F * alpha_u * alpha_v * s * s);
    d = SELECT((vfloat)(0.0f), d, d * m.z > 1e-20f);
#else
    vfloat d = ggx_d(m, alpha_u);
#endif
#if HAS_BECKMANN
    vint beckmann = distribution == MICROFACET_BECKMANN;
    if (ANY(beckmann))
        d = SELECT(d, beckmann_d(alpha_u, alpha_v, m), beckmann);
#else
    (void)distribution;
#endif
    (void)alpha_v;
    return d;
}

/* Smith's G1 of direction v, the share of the microfacets facing v that v sees: 1 / (1 + Lambda(v)) with
 * GGX's Lambda of the projected roughness, alpha^2 tan^2(theta_v) = ((alpha_u v.x)^2 + (alpha_v v.y)^2) /
 * v.z^2 (Heitz 2014, section 5.3), Beckmann's by its rational fit; without microfacet_g1's check of the side
 * of the facet, for callers that know v sees m's front (a reflection with wo and wi above the surface:
 * dot(wo, h) = dot(wi, h) = |wo + wi| / 2 > 0). */
inline vfloat microfacet_g1_front(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 v)
{
#if HAS_ANISOTROPIC
    vfloat ax = alpha_u * v.x, ay = alpha_v * v.y, xy_alpha2 = MAD(ax, ax, ay * ay), t2 = xy_alpha2 / (v.z * v.z);
    vfloat g = 1.0f / (1.0f + 0.5f * t2 / (sqrt(1.0f + t2) + 1.0f));
#else
    vfloat g = ggx_g1(v, alpha_u);
#endif
#if HAS_BECKMANN
    vint beckmann = distribution == MICROFACET_BECKMANN;
    if (ANY(beckmann)) {
#if !HAS_ANISOTROPIC
        vfloat xy_alpha2 = alpha_u * alpha_u * vmax(1.0f - v.z * v.z, (vfloat)(0.0f));
#endif
        g = SELECT(g, beckmann_g1(xy_alpha2, v.z), beckmann);
    }
#else
    (void)distribution;
#endif
    (void)alpha_v;
    return g;
}

/* Smith's G1(v, m), masking of the microfacets of normal m seen from v (Mitsuba's smith_g1):
 * microfacet_g1_front, and 0 where v sees m's back (dot(v, m) v.z <= 0: a facet cannot be seen from the other
 * side of the surface). */
inline vfloat microfacet_g1(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 v, vec3 m)
{
    return SELECT(microfacet_g1_front(distribution, alpha_u, alpha_v, v), (vfloat)(0.0f), v3_dot(v, m) * v.z <= 0.0f);
}

/* Smith's separable masking-shadowing G(wo, wi, m) = G1(wo, m) G1(wi, m) (MicrofacetDistribution::G). */
inline vfloat microfacet_g(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 wo, vec3 wi, vec3 m)
{
    return microfacet_g1(distribution, alpha_u, alpha_v, wo, m) * microfacet_g1(distribution, alpha_u, alpha_v, wi, m);
}

/* A microfacet normal visible from wi (wi.z > 0), of density microfacet_pdf: GGX's by Heitz 2018's mapping,
 * Beckmann's by Mitsuba's (Jakob 2014). Each is computed only where some lane has that distribution. */
inline vec3 microfacet_sample_visible(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 wi, vec2 u)
{
#if !HAS_ANISOTROPIC
    alpha_v = alpha_u;
#endif
#if HAS_BECKMANN
    vint beckmann = distribution == MICROFACET_BECKMANN;
    vec3 m = wi;
    if (ANY(distribution != MICROFACET_BECKMANN))
        m = ggx_sample_visible_normal_uv(wi, alpha_u, alpha_v, u);
    if (ANY(beckmann))
        m = v3_select(m, beckmann_sample_visible_normal(wi, alpha_u, alpha_v, u), beckmann);
    return m;
#else
    (void)distribution;
    return ggx_sample_visible_normal_uv(wi, alpha_u, alpha_v, u);
#endif
}

/* The density per steradian of m under microfacet_sample_visible(wi): the distribution of visible normals
 * D_wi(m) = G1(wi, m) |dot(wi, m)| D(m) / wi.z (Heitz and d'Eon 2014, eq. 2; Mitsuba's pdf()). */
inline vfloat microfacet_pdf(vint distribution, vfloat alpha_u, vfloat alpha_v, vec3 wi, vec3 m)
{
    return microfacet_d(distribution, alpha_u, alpha_v, m) * microfacet_g1(distribution, alpha_u, alpha_v, wi, m) *
           vabs(v3_dot(wi, m)) / wi.z;
}

#endif
