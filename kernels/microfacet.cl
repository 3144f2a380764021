/* The GGX (Trowbridge-Reitz) microfacet distribution of rough surfaces, isotropic, in the local frame of the
 * surface (z along the normal): its distribution of normals D, Smith's masking G1 and masking-shadowing G2
 * (Mitsuba 3's separable form), and sampling of the normals visible from a direction (Heitz, "Sampling the
 * GGX Distribution of Visible Normals", JCGT 2018; pbrt-v4's TrowbridgeReitzDistribution, section 9.6).
 * alpha is the roughness (Mitsuba's `alpha`): the distribution's slope scale, 0 a mirror, 1 very rough. */
#ifndef MICROFACET_CL
#define MICROFACET_CL

#include "vmath.h"

/* D(h) = 1 / (pi alpha^2 cos^4(theta_h) (1 + tan^2(theta_h) / alpha^2)^2), written without the tangent so
 * that it holds at theta_h = 0: with c = cos^2, D = alpha^2 / (pi (c (alpha^2 - 1) + 1)^2). Zero below the
 * horizon. */
inline vfloat ggx_d(vec3 h, vfloat alpha)
{
    vfloat a2 = alpha * alpha, c = h.z * h.z, d = MAD(c, a2 - 1.0f, 1.0f);
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
 * the projected disk of the hemisphere it sees, lifted onto the hemisphere and unstretched. */
inline vec3 ggx_sample_visible_normal(vec3 wo, vfloat alpha, vec2 u)
{
    vec3 v = v3_direction(v3(alpha * wo.x, alpha * wo.y, wo.z));
    vfloat len2 = v.x * v.x + v.y * v.y, inv = vrsqrt(len2);
    vint flat = len2 <= 0.0f;
    vec3 t1 = v3(SELECT(-v.y * inv, (vfloat)(1.0f), flat), SELECT(v.x * inv, (vfloat)(0.0f), flat), (vfloat)(0.0f));
    vec3 t2 = v3_cross(v, t1);
    vfloat r = sqrt(u.x), phi = 2.0f * M_PI_F * u.y;
    vfloat p1 = r * cos(phi), p2 = r * sin(phi), s = 0.5f * (1.0f + v.z);
    p2 = MAD(1.0f - s, sqrt(vmax(1.0f - p1 * p1, (vfloat)(0.0f))), s * p2);
    vfloat p3 = sqrt(vmax(1.0f - p1 * p1 - p2 * p2, (vfloat)(0.0f)));
    vec3 n = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)), v3_scale(v, p3));
    return v3_direction(v3(alpha * n.x, alpha * n.y, vmax(n.z, (vfloat)(0.0f))));
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

#endif
