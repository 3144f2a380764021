/* `roughconductor`: a rough metal, GGX microfacets of roughness alpha (microfacet.cl) with the conductor's
 * Fresnel reflectance (Mitsuba 3's `roughconductor`; Walter et al., "Microfacet Models for Refraction through
 * Rough Surfaces", EGSR 2007; pbrt-v4's ConductorBxDF, section 9.6):
 *   f = k F(wo.h) D(h) G2(wo, wi) / (4 cos(theta_o) cos(theta_i)),  h = (wo + wi) / |wo + wi|,
 * G2 = G1(wo) G1(wi), Mitsuba's separable form. It samples the normals visible from wo (Heitz 2018) and
 * reflects wo about them: p = G1(wo) D(h) / (4 cos(theta_o)), f cos / p = k F G1(wi). The terms need only
 * cosines to the shading normal: the distribution is isotropic. */
#ifndef BSDFS_ROUGHCONDUCTOR_CL
#define BSDFS_ROUGHCONDUCTOR_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../microfacet.cl"

inline vec3 roughconductor_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vec3 h = v3_direction(v3_add(wo, wi));
    vfloat cos_o = v3_dot(sp.n, wo), cos_i = v3_dot(sp.n, wi), zero = 0.0f;
    vec3 zo = v3(zero, zero, cos_o), zi = v3(zero, zero, cos_i), zh = v3(zero, zero, v3_dot(sp.n, h));
    vfloat d = ggx_d(zh, sp.alpha);
    vint above = (cos_o > 0.0f) & (cos_i > 0.0f);
    vfloat common = SELECT(zero, d * ggx_g2(zo, zi, sp.alpha) / (4.0f * cos_o), above);
    *pdf = SELECT(zero, ggx_g1(zo, sp.alpha) * d / (4.0f * cos_o), above);
    return v3_scale(v3_mul(sp.k, fresnel_conductor3(v3_dot(wo, h), sp.eta, sp.k_imag)), common);
}

inline BSDFSample roughconductor_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    LocalFrame frame = local_frame(sp.n);
    vec3 lo = to_local(frame, wo);
    vec3 hl = ggx_sample_visible_normal(lo, sp.alpha, u2), h = from_local(frame, hl);
    bs.wi = reflected(wo, h);
    vfloat zero = 0.0f, cos_i = v3_dot(sp.n, bs.wi);
    vfloat g1 = ggx_g1(v3(zero, zero, lo.z), sp.alpha);
    bs.weight = v3_scale(v3_mul(sp.k, fresnel_conductor3(v3_dot(wo, h), sp.eta, sp.k_imag)),
                         ggx_reflection_weight(v3(zero, zero, lo.z), v3(zero, zero, cos_i), sp.alpha));
    bs.pdf = SELECT(zero, g1 * ggx_d(v3(zero, zero, hl.z), sp.alpha) / (4.0f * lo.z),
                    (lo.z > 0.0f) & (cos_i > 0.0f));
    bs.delta = bs.transmit = (vint)(0);
    return bs;
}

#endif
