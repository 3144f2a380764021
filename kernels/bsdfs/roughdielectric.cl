/* `roughdielectric`: rough glass, an interface of microfacets each a smooth dielectric (dielectric.cl), their
 * normals m spread by GGX's or Beckmann's distribution, isotropic or anisotropic (microfacet.cl), reflecting
 * and refracting after Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007, as
 * Mitsuba 3's `roughdielectric` (v3.9.1, src/bsdfs/roughdielectric.cpp) writes it; pbrt-v4's DielectricBxDF,
 * section 9.7, is the same model (GGX only).
 * With eta the index of wi's side over wo's, F = F(wo.m) the microfacet's Fresnel reflectance and the separable
 * G = G1(wo, m) G1(wi, m), Mitsuba's, the value with its cosine (bsdf.cl's convention) is
 *   reflection (wi on wo's side):   F D(m) G / (4 cos_o),                      m = normalize(wo + wi),
 *   refraction (wi across):         (1 - F) D(m) G |wo.m| |wi.m| / (cos_o (wo.m + eta wi.m)^2),
 *                                                                              m = normalize(wo + eta wi),
 * m flipped onto wo's side of the normal in both (Walter's generalised half vector: the microfacet that
 * refracts wo into wi). The refraction is Walter's eq. 21 times 1 / eta^2, the radiance's compression into
 * the denser medium's smaller solid angle, which Mitsuba applies in radiance mode ("missing term in the
 * original paper"): raytrace traces radiance from the camera, as Mitsuba's `path` does. So the transmission
 * is not reciprocal; eval eta_wi^2 / cos_i is.
 * G1(v, m) is 0 where v sees the microfacet from behind, dot(v, m) cos(v) <= 0 (Mitsuba's smith_g1): a
 * direction pair whose half vector no microfacet facing both could have has no value and no density. Those
 * checks are the lanes' `valid` here, and G1 itself microfacet_g1_front.
 *
 * Sampling: a normal m visible from wo (microfacet_sample_visible: Heitz 2018 for GGX, Jakob 2014 for
 * Beckmann), then reflection about m with probability F(wo.m), refraction through it otherwise (Walter's
 * section 5.3: the choice by the sampled microfacet's own reflectance, so that F cancels from the weight). The
 * density of wi is D_wo(m) times the choice's probability times the Jacobian of the half vector,
 * 1 / (4 |wi.m|) for reflection and eta^2 |wi.m| / (wo.m + eta wi.m)^2 for refraction (Walter's eqs. 14 and
 * 17), so f cos / p = k G1(wi, m), and 1 / eta^2 that on refraction (dielectric.cl's factor). A sample whose wi
 * lies on the wrong side for its lobe (reflected below the surface, refracted above it: G1(wi, m) = 0) has
 * pdf 0, as does wo at the horizon.
 *
 * Sides. Mitsuba's shading frame keeps the surface's normal: cos(theta_o) < 0 means the viewer is inside and
 * eta inverts, and m is sampled from the visible normals of -wo. raytrace's shading normal sp.n faces the
 * viewer's side of the geometric normal and sp.backface says the hit is from inside. Mitsuba's BSDF is
 * unchanged by turning its normal over together with eta into 1 / eta (every quantity is a dot product with the
 * normal or m, m turning with it, and F(-cos, eta) = F(cos, 1 / eta); D and G1 are even in the tangential
 * coordinates, so the frame's x and y may turn too), so this works in the frame of n, the side of the surface
 * wo is on: sp.n, or -sp.n where a shading normal leaves wo below it; the index inverts where wo is inside
 * Mitsuba's normal, backface xor that flip (dielectric.cl's rule where n = sp.n).
 *
 * Frames. An isotropic distribution needs only cosines to n, and a build without anisotropy (HAS_ANISOTROPIC
 * 0) passes microfacet.cl just those, (0, 0, cos), so that isotropic GGX renders to the bit as the GGX-only
 * version of this file did. An anisotropic build works in the local frame of n whose x axis is the shading
 * tangent sp.t (material.cl: dp/du made orthogonal to the normal, Mitsuba's shading frame), alpha_u's axis,
 * as roughconductor.cl does; there D takes m's x and y, which also spares it the cancellation of
 * cos^2 (alpha^2 - 1) + 1 near the normal that the cosine-only GGX D has (float32 cannot resolve alpha 1e-3's
 * peak from the cosine alone). Mitsuba's two factors specular_reflectance and specular_transmittance are
 * raytrace's one colour k (raytrace/scene/bsdfs.py). */
#ifndef BSDFS_ROUGHDIELECTRIC_CL
#define BSDFS_ROUGHDIELECTRIC_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../microfacet.cl"

/* The normal of wo's side (above), cos(theta_o) >= 0 to it, and the index of refraction across it relative
 * to wo's side: sp.eta.x = int_ior / ext_ior from outside, its inverse from inside. */
inline vec3 roughdielectric_side(ShadingPoint sp, vec3 wo, vfloat *cos_o, vfloat *eta)
{
    vfloat c = v3_dot(sp.n, wo);
    vint below = c < 0.0f;
    *cos_o = vabs(c);
    *eta = SELECT(sp.eta.x, 1.0f / sp.eta.x, (sp.backface != 0) ^ below);
    return v3_select(sp.n, v3_scale(sp.n, -1.0f), below);
}

/* The density of wi (given m, a = wo.m > 0, b = wi.m, the lobe's probability `lobe` and d = D(m)): D_wo(m)
 * lobe |dm/dwi|, D_wo(m) = G1(wo) a D / cos_o. */
inline vfloat roughdielectric_density(vfloat d, vfloat g1o, vfloat a, vfloat b, vfloat cos_o, vfloat eta,
                                      vfloat lobe, vint reflect)
{
    vfloat s = MAD(eta, b, a);
    vfloat jacobian = SELECT(eta * eta * vabs(b) / (s * s), 1.0f / (4.0f * b), reflect);
    return lobe * d * g1o * a / cos_o * jacobian;
}

#if HAS_ANISOTROPIC
/* The shading frame of an anisotropic surface on wo's side n = +-sp.n: x along the tangent (orthogonal to n
 * either way), y completing it right-handed (turned over with n, which D and G1 do not see). */
inline LocalFrame roughdielectric_frame(ShadingPoint sp, vec3 n)
{
    LocalFrame f = {sp.t, v3_cross(n, sp.t), n};
    return f;
}
#endif

inline vec3 roughdielectric_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vfloat cos_o, eta, zero = 0.0f, cos_t;
    vec3 n = roughdielectric_side(sp, wo, &cos_o, &eta);
    vfloat cos_i = v3_dot(n, wi);
    vint reflect = cos_i > 0.0f;
    vec3 m = v3_direction(v3_add(wo, v3_scale(wi, SELECT(eta, (vfloat)(1.0f), reflect))));
    vfloat cos_m = v3_dot(n, m);
    m = v3_select(m, v3_scale(m, -1.0f), cos_m < 0.0f); /* onto wo's side */
    vfloat a = v3_dot(wo, m), b = v3_dot(wi, m);
    /* G1's sides: wo and wi each see m from the front (cos_o > 0: Mitsuba ignores the horizon) */
    vint valid = (cos_o > 0.0f) & (a > 0.0f) & (b * cos_i > 0.0f);
    vfloat f = fresnel_dielectric(vmin(vabs(a), (vfloat)(1.0f)), eta, &cos_t);
    vint distribution = sp.distribution;
    vfloat au = sp.alpha, av = sp.alpha_v;
#if HAS_ANISOTROPIC
    LocalFrame frame = roughdielectric_frame(sp, n);
    vec3 lm = to_local(frame, m), lo = to_local(frame, wo), li = to_local(frame, wi);
#else
    vec3 lm = v3(zero, zero, vabs(cos_m)), lo = v3(zero, zero, cos_o), li = v3(zero, zero, cos_i);
#endif
    vfloat d = microfacet_d(distribution, au, av, lm);
    vfloat g1o = microfacet_g1_front(distribution, au, av, lo);
    vfloat g = g1o * microfacet_g1_front(distribution, au, av, li);
    vfloat lobe = SELECT(1.0f - f, f, reflect), s = MAD(eta, b, a);
    vfloat value = lobe * d * g / cos_o * SELECT(vabs(a * b) / (s * s), (vfloat)(0.25f), reflect);
    *pdf = SELECT(zero, roughdielectric_density(d, g1o, a, b, cos_o, eta, lobe, reflect), valid);
    return v3_scale(sp.k, SELECT(zero, value, valid));
}

inline BSDFSample roughdielectric_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat cos_o, eta, zero = 0.0f, cos_t;
    vec3 n = roughdielectric_side(sp, wo, &cos_o, &eta);
    vint distribution = sp.distribution;
    vfloat au = sp.alpha, av = sp.alpha_v;
#if HAS_ANISOTROPIC
    LocalFrame frame = roughdielectric_frame(sp, n);
#else
    LocalFrame frame = local_frame(n);
#endif
    vec3 lo = to_local(frame, wo);
    vec3 hl = microfacet_sample_visible(distribution, au, av, lo, u2), m = from_local(frame, hl);
    vfloat a = v3_dot(wo, m);
    vfloat f = fresnel_dielectric(vmin(vabs(a), (vfloat)(1.0f)), eta, &cos_t);
    vint refract = u1 > f; /* Mitsuba: reflection where u1 <= F; all of it past the critical angle (F = 1) */
    vec3 t = v3_sub(v3_scale(m, a / eta - cos_t), v3_scale(wo, 1.0f / eta)); /* Snell's law about m */
    bs.wi = v3_select(reflected(wo, m), t, refract);
    vfloat b = v3_dot(bs.wi, m), cos_i = v3_dot(n, bs.wi);
    vint valid = (cos_o > 0.0f) & (a > 0.0f) & (b * cos_i > 0.0f);
#if HAS_ANISOTROPIC
    vec3 li = to_local(frame, bs.wi), vo = lo;
#else
    vec3 li = v3(zero, zero, cos_i), vo = v3(zero, zero, cos_o);
#endif
    vfloat g1o = microfacet_g1_front(distribution, au, av, vo), g1i = microfacet_g1_front(distribution, au, av, li);
    vfloat p = roughdielectric_density(microfacet_d(distribution, au, av, hl), g1o, a, b, cos_o, eta,
                                       SELECT(f, 1.0f - f, refract), !refract);
    bs.pdf = SELECT(zero, p, valid);
    bs.weight = v3_scale(sp.k, SELECT(zero, g1i * SELECT((vfloat)(1.0f), 1.0f / (eta * eta), refract), valid));
    bs.delta = (vint)(0);
    bs.transmit = refract;
    return bs;
}

#endif
