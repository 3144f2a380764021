/* `roughplastic`: a diffuse base under a rough dielectric coat (Mitsuba 3's `roughplastic`, v3.9.1; the layered
 * model of Weidlich and Wilkie, "Arbitrarily Layered Micro-Facet Surfaces", GRAPHITE 2007, with the coat's
 * reflection a microfacet one: Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR
 * 2007; pbrt-v4 section 9.6 for the GGX terms). With cos_o, cos_i the cosines of wo and wi to the normal and h
 * their half vector:
 *   f cos_i = F(wo . h) D(h) G1(wo, h) G1(wi, h) / (4 cos_o) specular  (the coat's glossy reflection)
 *           + k / (1 - R_int) t(cos_o) t(cos_i) cos_i / (pi eta^2)      (the base, seen through the coat)
 * k the base's diffuse reflectance (the material's colour), `specular` the coat's specular_reflectance, eta =
 * int_ior / ext_ior. t(mu) is the coat's transmittance (the share of light at cos(theta) = mu that crosses
 * the rough interface, lost neither to Fresnel reflection nor to masking) on each way through, and 1 / eta^2
 * the compression of radiance entering the denser coat, spread again by the diffuse base. The base's light
 * that the coat reflects back down is reflected by the base again, a geometric series: 1 / (1 - R_int), R_int
 * the coat's reflectance averaged over the base's cosine-weighted light; with `nonlinear` the base's colour
 * enters each bounce, 1 / (1 - k R_int), which darkens and saturates it (Mitsuba's plastic plugins; the
 * series is d'Eon and Irving's Fresnel diffuse reflectance argument, "A Quantized-Diffusion Model for
 * Rendering Translucent Materials", SIGGRAPH 2011, with the rough coat's R_int in place of Fdr).
 *
 * t and R_int have no closed form: the host integrates them as Mitsuba does when it builds the plugin
 * (raytrace/scene/rough_transmittance.py), t as ROUGH_TRANSMITTANCE_RES values at cos(theta) = i / (RES -
 * 1) in the material's table (types.h's Material.transmittance), looked up here by Mitsuba's lerp_gather,
 * and R_int as the material's internal_reflectance. So the BSDF is Mitsuba's to float32's rounding, not only
 * its model.
 *
 * Sampling (Mitsuba's): the coat with probability p = (1 - t(cos_o)) w / ((1 - t(cos_o)) w + t(cos_o) (1 - w)),
 * w the material's specular_weight (the specular reflectance's mean over the sum of both reflectances' means),
 * by the microfacet normals visible from wo (Heitz and d'Eon 2014; microfacet.cl) reflected, else the cosine
 * about the normal (warp.cl); the density is the mixture's, p D(h) G1(wo, h) / (4 cos_o) + (1 - p) cos_i / pi,
 * so a light sample and a BSDF sample weigh each other with one density. Both directions must lie above the
 * shading normal (a one-sided BSDF, as Mitsuba's; `twosided` is the scene's business).
 *
 * The microfacet terms are microfacet.cl's general ones, GGX's or Beckmann's per lane (sp.distribution; the
 * tables are the same distribution's), isotropic (Mitsuba's roughplastic has one alpha: alpha_v is alpha
 * here whatever the material holds), the roughness clamped to Mitsuba's 1e-4. They take the directions in a
 * local frame about the normal: an isotropic build reads only their cosines, an anisotropic one (a scene
 * that also has an anisotropic conductor) their x and y too, which any frame about n gives alike. */
#ifndef BSDFS_ROUGHPLASTIC_CL
#define BSDFS_ROUGHPLASTIC_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../microfacet.cl"
#include "../warp.cl"

/* The coat's transmittance at cos_a and cos_b (both in [0, 1]) on the lanes of `on`, from each lane's
 * material's table: Mitsuba's lerp_gather, linear between the entries about x = cos (RES - 1), the last
 * interval closed at 1. A gather, lane by lane; lanes mostly share a material (one object fills neighbouring
 * pixels), and then they read one table, its address found once. Lanes off `on` read nothing (their material
 * may be none: -1) and get 0. */
inline void roughplastic_transmittance(ShadingPoint sp, vfloat cos_a, vfloat cos_b, vint on, vfloat *t_a,
                                       vfloat *t_b)
{
    const float last = (float)(ROUGH_TRANSMITTANCE_RES - 1);
    vfloat xa = vmax((vfloat)(0.0f), vmin((vfloat)(last), cos_a * last)); /* NaN-free: vmin keeps its first */
    vfloat xb = vmax((vfloat)(0.0f), vmin((vfloat)(last), cos_b * last));
    vint ia = CONVERT_VINT(xa), ib = CONVERT_VINT(xb);
    ia = SELECT(ia, (vint)(ROUGH_TRANSMITTANCE_RES - 2), ia > ROUGH_TRANSMITTANCE_RES - 2);
    ib = SELECT(ib, (vint)(ROUGH_TRANSMITTANCE_RES - 2), ib > ROUGH_TRANSMITTANCE_RES - 2);
    int a[LANES], b[LANES], m[LANES], act[LANES];
    float a0[LANES], a1[LANES], b0[LANES], b1[LANES];
    VSTORE(ia, a);
    VSTORE(ib, b);
    VSTORE(sp.material, m);
    VSTORE(on, act);
    int shared = -1, same = 1; /* the material of every lane of `on`, if they have one */
    for (int i = 0; i < LANES; ++i) {
        if (!act[i])
            continue;
        same &= shared < 0 || m[i] == shared;
        shared = m[i];
    }
    __global const float *one = same && shared >= 0 ? sp.materials[shared].transmittance : 0;
    for (int i = 0; i < LANES; ++i) {
        a0[i] = a1[i] = b0[i] = b1[i] = 0.0f;
        if (!act[i])
            continue;
        __global const float *t = one ? one : sp.materials[m[i]].transmittance;
        a0[i] = t[a[i]];
        a1[i] = t[a[i] + 1];
        b0[i] = t[b[i]];
        b1[i] = t[b[i] + 1];
    }
    vfloat va0 = VLOAD(a0), va1 = VLOAD(a1), vb0 = VLOAD(b0), vb1 = VLOAD(b1);
    *t_a = MAD(va1 - va0, xa - CONVERT_VFLOAT(ia), va0);
    *t_b = MAD(vb1 - vb0, xb - CONVERT_VFLOAT(ib), vb0);
}

/* The probability of sampling the coat, from t(cos_o): Mitsuba's, where the coat reflects more (small t) and
 * the specular reflectance outweighs the diffuse one. */
inline vfloat roughplastic_prob_specular(ShadingPoint sp, vfloat t_o)
{
    vfloat ps = (1.0f - t_o) * sp.specular_weight, pd = t_o * (1.0f - sp.specular_weight);
    return SELECT(ps / (ps + pd), sp.specular_weight, ps + pd <= 0.0f);
}

inline vec3 roughplastic_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vfloat zero = 0.0f, alpha = vmax(sp.alpha, (vfloat)(1e-4f)), t_o, t_i, cos_t;
    vint distribution = sp.distribution;
    LocalFrame frame = local_frame(sp.n);
    vec3 h = v3_direction(v3_add(wo, wi));
    vec3 lo = to_local(frame, wo), li = to_local(frame, wi), lh = to_local(frame, h);
    vint above = (lo.z > 0.0f) & (li.z > 0.0f);
    vfloat d = microfacet_d(distribution, alpha, alpha, lh);
    vfloat g1_o = microfacet_g1(distribution, alpha, alpha, lo, lh);
    vfloat g1_i = microfacet_g1(distribution, alpha, alpha, li, lh);
    vfloat f = fresnel_dielectric(vmax(v3_dot(wo, h), zero), sp.eta.x, &cos_t);
    vfloat glossy = f * d * (g1_o * g1_i) / (4.0f * lo.z);
    roughplastic_transmittance(sp, lo.z, li.z, above, &t_o, &t_i);
    /* the base's albedo under the coat: k / (1 - R_int), or k / (1 - k R_int) with `nonlinear` */
    vec3 r = v3(sp.internal_reflectance, sp.internal_reflectance, sp.internal_reflectance);
    r = v3_select(r, v3_scale(sp.k, sp.internal_reflectance), sp.nonlinear != 0);
    vec3 base = v3(sp.k.x / (1.0f - r.x), sp.k.y / (1.0f - r.y), sp.k.z / (1.0f - r.z));
    vfloat diffuse = t_o * t_i * li.z * M_1_PI_F / (sp.eta.x * sp.eta.x);
    vfloat ps = roughplastic_prob_specular(sp, t_o);
    *pdf = SELECT(zero, MAD(ps, d * g1_o / (4.0f * lo.z), (1.0f - ps) * li.z * M_1_PI_F), above);
    vec3 value = v3_add(v3_scale(sp.specular, glossy), v3_scale(base, diffuse));
    return v3_select(v3_splat(0.0f, 0.0f, 0.0f), value, above);
}

inline BSDFSample roughplastic_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat zero = 0.0f, alpha = vmax(sp.alpha, (vfloat)(1e-4f)), t_o, unused;
    LocalFrame frame = local_frame(sp.n);
    vec3 lo = to_local(frame, wo);
    vint above = lo.z > 0.0f;
    roughplastic_transmittance(sp, lo.z, lo.z, above, &t_o, &unused);
    vint glossy = u1 < roughplastic_prob_specular(sp, t_o);
    vec3 wd = cosine_direction(sp.n, u2);
    /* the visible normals only where a lane reflects off the coat: Beckmann's sampler is some hundred
     * operations (erf, erfinv, three Newton steps) */
    if (ANY(glossy & above)) {
        vec3 h = from_local(frame, microfacet_sample_visible(sp.distribution, alpha, alpha, lo, u2));
        wd = v3_select(wd, reflected(wo, h), glossy);
    }
    bs.wi = wd;
    vfloat pdf;
    vec3 f = roughplastic_eval(sp, wo, bs.wi, &pdf);
    vint valid = above & (pdf > 0.0f);
    bs.pdf = SELECT(zero, pdf, valid);
    bs.weight = v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_scale(f, 1.0f / pdf), valid);
    bs.delta = bs.transmit = (vint)(0);
    return bs;
}

#endif
