/* `roughconductor`: a rough metal, microfacets of GGX's or Beckmann's distribution (microfacet.cl), isotropic
 * or anisotropic, with the conductor's Fresnel reflectance (Mitsuba 3's `roughconductor`; Walter et al.,
 * "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007; pbrt-v4's ConductorBxDF, section 9.6):
 *   f = k F(wo . h) D(h) G(wo, wi, h) / (4 cos(theta_o) cos(theta_i)),  h = (wo + wi) / |wo + wi|,
 * G = G1(wo, h) G1(wi, h), Mitsuba's separable form. It samples the normals visible from wo (Heitz and d'Eon
 * 2014; Heitz 2018 for GGX, Jakob 2014 for Beckmann) and reflects wo about them: p = G1(wo, h) D(h) /
 * (4 cos(theta_o)), f cos / p = k F G1(wi, h). Like Mitsuba's it is one-sided: 0 where wo or wi is below the
 * shading normal (which raytrace turns towards the viewer).
 *
 * An isotropic distribution needs only cosines to the shading normal, and a build without anisotropy
 * (HAS_ANISOTROPIC 0) passes microfacet.cl just those, (0, 0, cos), as before the general forms. G1's check
 * that v sees the facet's front (Mitsuba's smith_g1) is left out (microfacet_g1_front): where wo and wi are
 * both above the surface, dot(wo, h) = dot(wi, h) = |wo + wi| / 2 > 0, and a visible normal faces wo; the
 * other lanes have value and density 0 anyway. An anisotropic one works
 * in the local frame whose x axis is the shading tangent sp.t (material.cl: dp/du made orthogonal to n, as
 * Mitsuba's shading frame), alpha_u's axis. */
#ifndef BSDFS_ROUGHCONDUCTOR_CL
#define BSDFS_ROUGHCONDUCTOR_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../microfacet.cl"

#if HAS_ANISOTROPIC
/* The shading frame of an anisotropic surface: x along the tangent, z the shading normal. Seen from the back
 * (raytrace turns n to the viewer), y turns over with n; D, G1 and the sampled density are even in y. */
inline LocalFrame roughconductor_frame(ShadingPoint sp)
{
    LocalFrame f = {sp.t, v3_cross(sp.n, sp.t), sp.n};
    return f;
}
#endif

inline vec3 roughconductor_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vec3 h = v3_direction(v3_add(wo, wi));
    vfloat zero = 0.0f;
#if HAS_ANISOTROPIC
    LocalFrame frame = roughconductor_frame(sp);
    vec3 lo = to_local(frame, wo), li = to_local(frame, wi), lh = to_local(frame, h);
#else
    vec3 lo = v3(zero, zero, v3_dot(sp.n, wo)), li = v3(zero, zero, v3_dot(sp.n, wi));
    vec3 lh = v3(zero, zero, v3_dot(sp.n, h));
#endif
    vint distribution = sp.distribution;
    vfloat au = sp.alpha, av = sp.alpha_v;
    vfloat d = microfacet_d(distribution, au, av, lh);
    vfloat g1_o = microfacet_g1_front(distribution, au, av, lo), g1_i = microfacet_g1_front(distribution, au, av, li);
    vint above = (lo.z > 0.0f) & (li.z > 0.0f);
    vfloat common = SELECT(zero, d * (g1_o * g1_i) / (4.0f * lo.z), above);
    *pdf = SELECT(zero, g1_o * d / (4.0f * lo.z), above);
    return v3_scale(v3_mul(sp.k, fresnel_conductor3(v3_dot(wo, h), sp.eta, sp.k_imag)), common);
}

inline BSDFSample roughconductor_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    (void)u1;
    BSDFSample bs;
    vint distribution = sp.distribution;
    vfloat au = sp.alpha, av = sp.alpha_v, zero = 0.0f;
#if HAS_ANISOTROPIC
    LocalFrame frame = roughconductor_frame(sp);
#else
    LocalFrame frame = local_frame(sp.n);
#endif
    vec3 lo = to_local(frame, wo);
    vec3 hl = microfacet_sample_visible(distribution, au, av, lo, u2), h = from_local(frame, hl);
    bs.wi = reflected(wo, h);
    vfloat cos_i = v3_dot(sp.n, bs.wi);
#if HAS_ANISOTROPIC
    vec3 li = to_local(frame, bs.wi), vo = lo;
#else
    vec3 li = v3(zero, zero, cos_i), vo = v3(zero, zero, lo.z);
#endif
    vfloat g1 = microfacet_g1_front(distribution, au, av, vo);
    bs.weight = v3_scale(v3_mul(sp.k, fresnel_conductor3(v3_dot(wo, h), sp.eta, sp.k_imag)),
                         microfacet_g1_front(distribution, au, av, li));
    bs.pdf = SELECT(zero, g1 * microfacet_d(distribution, au, av, hl) / (4.0f * lo.z), (lo.z > 0.0f) & (cos_i > 0.0f));
    bs.delta = bs.transmit = (vint)(0);
    return bs;
}

#endif
