/* `principled`: Disney's principled BSDF as Mitsuba 3 writes it (its `principled` plugin, v3.9.1:
 * src/bsdfs/principled.cpp and principledhelpers.h), after Burley, "Physically Based Shading at Disney", SIGGRAPH
 * 2012 course notes, and "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering", SIGGRAPH
 * 2015 course notes. One colour k (Mitsuba's base_color) and a handful of weights in [0, 1] (the material's
 * principled values, types.h's PRINCIPLED_*) blend five lobes. With brdf = (1 - metallic)(1 - spec_trans) and
 * bsdf = (1 - metallic) spec_trans, cos_o and cos_i the cosines of wo (the viewer: Mitsuba's si.wi) and wi (the
 * light: Mitsuba's wo) and h their half vector, the value with its cosine (bsdf.cl's convention) is the sum of
 *   main reflection   F_p(wo . h) D(h) G(wo, wi, h) / (4 |cos_o|)           GGX, alpha_u and alpha_v (anisotropic)
 *   transmission      sqrt(k) bsdf (1 - F) D G |(wo . h)(wi . h)| / (|cos_o| (wo . h + eta' wi . h)^2)  (across)
 *   clearcoat         clearcoat / 4 F_s(0.04) D_GTR1(h) G1(wo) G1(wi) |cos_i|  (Smith GGX of alpha 0.25)
 *   diffuse           brdf k / pi lerp((1 - Fo/2)(1 - Fi/2) + Rr (Fo + Fi + Fo Fi (Rr - 1)), f_ss, flatness) |cos_i|
 *   sheen             sheen (1 - metallic) (1 + sheen_tint (k / lum(k) - 1)) Fw(wi . h) |cos_i|
 * with F the dielectric Fresnel reflectance of eta = sp.eta.x (fresnel.cl; eta' = eta seen from the front,
 * 1 / eta from inside), F_p = (1 - metallic)(1 - spec_tint) F + metallic F_s(k) + (1 - metallic) spec_tint
 * F_s(k / lum R0(eta)) on the front and bsdf F inside, F_s(R0) = R0 + (1 - R0) Fw Schlick's approximation
 * (Fw(c) = (1 - c)^5 of the cosine outside the denser side, else of the refracted one), Fo = Fw(|cos_i|),
 * Fi = Fw(|cos_o|), Rr = 2 roughness (wi . h)^2 (Burley's retro-reflection), f_ss = 1.25 (Fss (1 / (|cos_o| +
 * |cos_i|) - 0.5) + 0.5) with Fss = lerp(1, Rr / 2, Fo) lerp(1, Rr / 2, Fi) (Mitsuba's `flatness`: Hanrahan and
 * Krueger's fake subsurface, principled_flatten, which principledthin.cl shares) and lum the luminance. The
 * refraction's half vector is wo + eta' wi. Mitsuba's transmission has a factor 1 / eta'^2 (radiance mode) and
 * one eta'^2 that cancel: neither is here; its albedo still carries the radiance's 1 / eta'^2 (by the
 * Jacobian of refraction), as roughdielectric.cl's does. The clearcoat's form (no 1 / (cos_o cos_i), cos_i in their place)
 * and the sheen's lack of a 1 / pi are Mitsuba's, kept: raytrace renders Mitsuba's scenes as Mitsuba does. The
 * diffuse, sheen and clearcoat lobes reflect on the front only; the lobes are each 0 where their side or
 * their half vector's side is wrong (Mitsuba's mac_mic_compatibility: wo and wi each see h's front for
 * reflection, wo sees it and wi its back for refraction), the main reflection where F = 0, the transmission
 * where F = 1. flatness changes the diffuse lobe's value only: its samples stay cosine-weighted (Mitsuba's
 * sample), their weight eval / pdf.
 *
 * Sides. The frame is Mitsuba's: z the outward normal, which is sp.n unless the hit is on the back of a
 * material that transmits (Mitsuba's has_spec_trans, PRINCIPLED_TRANSMITS: the viewer is inside; eta inverts,
 * only the main reflection, weighted bsdf F, and the transmission remain, both 0 where bsdf is, as with metallic
 * 1). An opaque principled (no spec_trans) is the same on both sides, as raytrace's other opaque BSDFs are
 * (Mitsuba's `twosided` around it): its back hits take sp.n, towards the viewer. The weights may vary per lane
 * (textured parameters: material.cl's principled_lookups), the sides not.
 *
 * Sampling (Mitsuba's): a lobe by u1 with probabilities proportional to, on the front, brdf
 * diffuse_reflectance_sampling_rate (cosine-weighted, warp.cl), clearcoat / 4 clearcoat_sampling_rate
 * (GTR1's normals, not the visible ones), and main_specular_sampling_rate for the main lobes, split by the
 * sampled normal's F into reflection (1 - bsdf (1 - F)) and transmission (bsdf (1 - F)); inside, reflection
 * F and transmission 1 - F. The main lobes' normal is one visible from wo (turned to the front) by GGX's
 * sampler (microfacet.cl), the same for both. The density is that mixture's, the choice's shares taken at the
 * half vector of the direction evaluated: the front's reflection and transmission share the specular rate
 * whatever F, so the mixture is exactly the sampler's. The weight is eval / pdf at the sampled direction, 0 (with
 * pdf 0) where it lands on the wrong side. */
#ifndef BSDFS_PRINCIPLED_CL
#define BSDFS_PRINCIPLED_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../microfacet.cl"
#include "../warp.cl"

#define PRINCIPLED(sp, name) ((sp).principled[PRINCIPLED_##name])

/* The local frame of Mitsuba's shading frame: z the outward normal (above), x the shading tangent in an
 * anisotropic build (alpha_u's axis; D and G1 are even in y, which turns over with z). The inside is the
 * material's (Mitsuba's has_spec_trans, PRINCIPLED_TRANSMITS), not the hit's weights: a textured spec_trans of 0
 * at a hit from inside leaves no lobe there (black), as in Mitsuba, rather than the front's. */
inline LocalFrame principled_frame(ShadingPoint sp)
{
    vec3 n = v3_select(sp.n, v3_scale(sp.n, -1.0f), (sp.backface != 0) & (PRINCIPLED(sp, TRANSMITS) != 0.0f));
#if HAS_ANISOTROPIC
    LocalFrame f = {sp.t, v3_cross(n, sp.t), n};
    return f;
#else
    return local_frame(n);
#endif
}

/* Schlick's weight (1 - c)^5, c clamped to [0, 1]. */
inline vfloat principled_schlick_weight(vfloat c)
{
    vfloat m = vmin(vmax(1.0f - c, (vfloat)(0.0f)), (vfloat)(1.0f)), m2 = m * m;
    return m2 * m2 * m;
}

/* The weight of Mitsuba's calc_schlick at cos_h (to the microfacet, signed: inside where negative): Fw of |cos_h|
 * where the incident side is the less dense (eta_it > 1), else of the refracted direction's cosine (1 beyond the
 * critical angle); F_s(R0) = R0 + (1 - R0) that. */
inline vfloat principled_schlick(vfloat cos_h, vfloat eta)
{
    vfloat eta_it = SELECT(1.0f / eta, eta, cos_h >= 0.0f), eta_ti = 1.0f / eta_it;
    vfloat cos_t = sqrt(vmax(1.0f - (1.0f - cos_h * cos_h) * (eta_ti * eta_ti), (vfloat)(0.0f)));
    return principled_schlick_weight(SELECT(cos_t, vabs(cos_h), eta_it > 1.0f));
}

/* The dielectric Fresnel reflectance at cos_h (signed, as Mitsuba's fresnel: eta inverts where negative) and
 * the refracted cosine's magnitude; 0 at eta 1 exactly (Mitsuba's index-matched case: no reflection at all,
 * where float32's amplitudes leave some 1e-15). */
inline vfloat principled_fresnel(vfloat cos_h, vfloat eta, vfloat *cos_t)
{
    vfloat f = fresnel_dielectric(vmin(vabs(cos_h), (vfloat)(1.0f)), SELECT(1.0f / eta, eta, cos_h >= 0.0f), cos_t);
    return SELECT(f, (vfloat)(0.0f), eta == 1.0f);
}

/* The lobes' sampling probabilities at the dielectric reflectance f (front, or inside), normalised. Inside, the
 * transmission only where the material transmits (Mitsuba's has_spec_trans: a viewer below the shading normal of
 * an opaque principled samples the main reflection alone, and nothing where F is 0, at eta 1: Mitsuba's 0 / 0,
 * here no density). */
inline void principled_probabilities(ShadingPoint sp, vint front, vfloat f, vfloat brdf, vfloat bsdf, vfloat *ps,
                                     vfloat *pt, vfloat *pc, vfloat *pd)
{
    vfloat rate = PRINCIPLED(sp, SPECULAR_RATE), zero = 0.0f;
    *ps = SELECT(f, rate * (1.0f - bsdf * (1.0f - f)), front);
    *pt = SELECT(SELECT(zero, 1.0f - f, PRINCIPLED(sp, TRANSMITS) != 0.0f), rate * bsdf * (1.0f - f), front);
    *pc = SELECT(zero, 0.25f * PRINCIPLED(sp, CLEARCOAT) * PRINCIPLED(sp, CLEARCOAT_RATE), front);
    *pd = SELECT(zero, brdf * PRINCIPLED(sp, DIFFUSE_RATE), front);
    vfloat total = *ps + *pt + *pc + *pd; /* 0 inside an opaque principled of eta 1 (F = 0): no lobe at all */
    vfloat inv = SELECT(zero, 1.0f / total, total > 0.0f);
    *ps *= inv;
    *pt *= inv;
    *pc *= inv;
    *pd *= inv;
}

/* GTR1's D(h) of roughness a, (a^2 - 1) / (pi ln(a^2) (1 + (a^2 - 1) cos^2)), 0 where D cos <= 1e-20. */
inline vfloat principled_gtr1(vfloat a, vfloat cos_h)
{
    vfloat a2 = a * a;
    vfloat d = (a2 - 1.0f) / (M_PI_F * (0.69314718f * vlog2(a2)) * MAD(a2 - 1.0f, cos_h * cos_h, 1.0f));
    return SELECT((vfloat)(0.0f), d, d * cos_h > 1e-20f);
}

/* The lobes principledthin.cl shares. The tint: the colour over its luminance (white where that is 0, as
 * Mitsuba's, and where it is below float32's smallest normal number: 1 / lum would overflow to inf, and k inf
 * to inf or NaN, where each k / lum is at most 1 / 0.072169; the fuzz suite found such a colour texture). */
inline vec3 principled_tint(vec3 k)
{
    vfloat lum = luminance(k);
    return v3_select(v3_splat(1.0f, 1.0f, 1.0f), v3_scale(k, 1.0f / lum), lum >= 0x1p-126f);
}

/* Burley's diffuse with retro-reflection, (1 - Fi/2)(1 - Fo/2) + Rr (Fo + Fi + Fo Fi (Rr - 1)), of the Schlick
 * weights fo, fi of the two cosines and Rr = 2 roughness cos_d^2. */
inline vfloat principled_diffuse(vfloat fo, vfloat fi, vfloat rr)
{
    return (1.0f - 0.5f * fi) * (1.0f - 0.5f * fo) + rr * (fo + fi + fo * fi * (rr - 1.0f));
}

/* Burley's diffuse `lambert` (principled_diffuse's) flattened towards Hanrahan and Krueger's fake subsurface
 * f_ss = 1.25 (Fss (1 / (|cos_o| + |cos_i|) - 0.5) + 0.5), Fss = lerp(1, Rr / 2, Fo) lerp(1, Rr / 2, Fi), by
 * flatness: lerp(lambert, f_ss, flatness). Mitsuba computes it only where flatness is given (its m_has_flatness:
 * a texture, or a number not 0); its lerp at flatness 0 is lambert exactly, and so is this one ((f_ss - lambert)
 * 0 + lambert, fused or not) wherever f_ss is finite (cos_sum > 0: the lobe's lanes), so a material without
 * flatness needs no flag to keep its bits. */
inline vfloat principled_flatten(vfloat lambert, vfloat fo, vfloat fi, vfloat rr, vfloat cos_sum, vfloat flatness)
{
    vfloat fss90 = 0.5f * rr, fss = MAD(fss90 - 1.0f, fo, 1.0f) * MAD(fss90 - 1.0f, fi, 1.0f);
    vfloat f_ss = 1.25f * (fss * (1.0f / cos_sum - 0.5f) + 0.5f);
    return MAD(f_ss - lambert, flatness, lambert);
}

/* A sample of direction bs.wi, of value (eval's) and density pdf there: its weight eval / pdf where it is
 * valid (`active`, pdf > 0), else weight and pdf 0; transmit where it is valid and crosses the surface. */
inline BSDFSample principled_weighted(BSDFSample bs, vec3 value, vfloat pdf, vint active, vint transmit)
{
    vint valid = active & (pdf > 0.0f);
    bs.pdf = SELECT((vfloat)(0.0f), pdf, valid);
    bs.weight = v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_scale(value, 1.0f / pdf), valid);
    bs.delta = (vint)(0);
    bs.transmit = transmit & valid;
    return bs;
}

inline vec3 principled_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    const vint ggx = (vint)(MICROFACET_GGX);
    vfloat zero = 0.0f, metallic = PRINCIPLED(sp, METALLIC), spec_trans = PRINCIPLED(sp, SPEC_TRANS);
    vfloat brdf = (1.0f - metallic) * (1.0f - spec_trans), bsdf = (1.0f - metallic) * spec_trans;
    vfloat eta = sp.eta.x, au = sp.alpha, av = sp.alpha_v, cos_t;
    LocalFrame frame = principled_frame(sp);
    vec3 lo = to_local(frame, wo), li = to_local(frame, wi);
    vfloat co = lo.z, ci = li.z;
    vint front = co > 0.0f, reflect = co * ci > 0.0f, refract = co * ci < 0.0f, active = co != 0.0f;
    vfloat eta_path = SELECT(1.0f / eta, eta, front);
    vec3 h = v3_add(lo, v3_scale(li, SELECT(eta_path, (vfloat)(1.0f), reflect)));
    h = v3_unit_or(h, v3_splat(0.0f, 0.0f, 1.0f)); /* 0 where wi refracts straight back: (0, 0, 1), no lobe's */
    h = v3_select(h, v3_scale(h, -1.0f), h.z < 0.0f); /* onto the outward side */
    vfloat oh = v3_dot(lo, h), ih = v3_dot(li, h), side = SELECT((vfloat)(-1.0f), (vfloat)(1.0f), front);
    vint sees = active & (oh * side > 0.0f);
    vint compatible_r = sees & reflect & (ih * side > 0.0f), compatible_t = sees & refract & (ih * side < 0.0f);
    vfloat f = principled_fresnel(oh, eta, &cos_t);
    vfloat d = microfacet_d(ggx, au, av, h), g = microfacet_g(ggx, au, av, lo, li, h);
    vec3 k = sp.k, value = v3_splat(0.0f, 0.0f, 0.0f);
    vec3 tint = principled_tint(k);

    /* the main reflection: F_p, Schlick's metal and tinted dielectric beside the true dielectric's F */
    vfloat w = principled_schlick(oh, eta), spec_tint = PRINCIPLED(sp, SPEC_TINT);
    vfloat eta_it = SELECT(1.0f / eta, eta, oh >= 0.0f), r0 = (eta_it - 1.0f) / (eta_it + 1.0f);
    vec3 r0_tint = v3_scale(tint, r0 * r0);
    vec3 f_metal = v3_add(k, v3_scale(v3_sub(v3_splat(1.0f, 1.0f, 1.0f), k), w));
    vec3 f_tint = v3_add(r0_tint, v3_scale(v3_sub(v3_splat(1.0f, 1.0f, 1.0f), r0_tint), w));
    vfloat f_plain = (1.0f - metallic) * (1.0f - spec_tint) * f;
    vec3 f_front = v3_add(v3_scale(f_metal, metallic), v3_scale(f_tint, (1.0f - metallic) * spec_tint));
    f_front = v3_add(f_front, v3(f_plain, f_plain, f_plain));
    vec3 f_p = v3_select(v3(bsdf * f, bsdf * f, bsdf * f), f_front, front);
    vfloat specular = SELECT(zero, d * g / (4.0f * vabs(co)), compatible_r & (f > 0.0f));
    value = v3_add(value, v3_scale(f_p, specular));

    /* the transmission */
    vfloat s = MAD(eta_path, ih, oh);
    vfloat through = bsdf * vabs((1.0f - f) * d * g * oh * ih / (co * s * s));
    through = SELECT(zero, through, compatible_t & (bsdf > 0.0f) & (f < 1.0f));
    value = v3_add(value, v3_scale(v3(sqrt(k.x), sqrt(k.y), sqrt(k.z)), through));

    /* the clearcoat */
    vfloat clearcoat = PRINCIPLED(sp, CLEARCOAT), cc_alpha = PRINCIPLED(sp, CLEARCOAT_ALPHA);
    vfloat d_cc = principled_gtr1(cc_alpha, h.z);
    vfloat g_cc = microfacet_g(ggx, (vfloat)(0.25f), (vfloat)(0.25f), lo, li, h);
    vfloat coat = 0.25f * clearcoat * MAD(0.96f, w, 0.04f) * d_cc * g_cc * vabs(ci); /* (w: the main lobe's) */
    coat = SELECT(zero, coat, compatible_r & front & (clearcoat > 0.0f));

    /* the diffuse base (Burley's retro-reflection, flattened towards the fake subsurface) and the sheen, on the
     * front */
    vint diffuse_on = active & reflect & front & (brdf > 0.0f);
    vfloat fo = principled_schlick_weight(vabs(ci)), fi = principled_schlick_weight(vabs(co));
    vfloat rr = 2.0f * PRINCIPLED(sp, ROUGHNESS) * ih * ih;
    vfloat lambert = principled_flatten(principled_diffuse(fo, fi, rr), fo, fi, rr, vabs(ci) + vabs(co),
                                        PRINCIPLED(sp, FLATNESS));
    vfloat diffuse = SELECT(zero, brdf * vabs(ci) * M_1_PI_F * lambert, diffuse_on);
    vfloat sheen = PRINCIPLED(sp, SHEEN), sheen_tint = PRINCIPLED(sp, SHEEN_TINT);
    vfloat sheen_w = SELECT(zero, sheen * (1.0f - metallic) * principled_schlick_weight(vabs(ih)) * vabs(ci),
                            diffuse_on & (sheen > 0.0f) & (1.0f - metallic > 0.0f));
    vec3 c_sheen = v3_add(v3_splat(1.0f, 1.0f, 1.0f), v3_scale(v3_sub(tint, v3_splat(1.0f, 1.0f, 1.0f)), sheen_tint));
    value = v3_add(value, v3_add(v3_scale(k, diffuse), v3_scale(c_sheen, sheen_w)));
    value = v3_add(value, v3(coat, coat, coat));

    /* the density: the lobes' mixture, each lobe's normal density times the Jacobian of its half vector */
    vfloat ps, pt, pc, pd;
    principled_probabilities(sp, front, f, brdf, bsdf, &ps, &pt, &pc, &pd);
    vfloat jacobian = vabs(SELECT(eta_path * eta_path * ih / (s * s), 1.0f / (4.0f * ih), reflect));
    vec3 up = v3_scale(lo, side);
    vfloat visible = microfacet_pdf(ggx, au, av, up, h) * jacobian;
    vfloat p = SELECT(zero, ps * visible, compatible_r);
    p += SELECT(zero, pt * visible, compatible_t);
    p += SELECT(zero, pc * SELECT(h.z * d_cc, zero, h.z < 0.0f) * jacobian, compatible_r);
    p += SELECT(zero, pd * ci * M_1_PI_F, active & reflect & front);
    *pdf = p;
    return v3_select(v3_splat(0.0f, 0.0f, 0.0f), value, active);
}

inline BSDFSample principled_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    const vint ggx = (vint)(MICROFACET_GGX);
    vfloat zero = 0.0f, metallic = PRINCIPLED(sp, METALLIC), spec_trans = PRINCIPLED(sp, SPEC_TRANS);
    vfloat brdf = (1.0f - metallic) * (1.0f - spec_trans), bsdf = (1.0f - metallic) * spec_trans;
    vfloat eta = sp.eta.x, au = sp.alpha, av = sp.alpha_v, cos_t;
    LocalFrame frame = principled_frame(sp);
    vec3 lo = to_local(frame, wo);
    vfloat co = lo.z, side = SELECT((vfloat)(-1.0f), (vfloat)(1.0f), co > 0.0f);
    vint front = co > 0.0f, active = (co != 0.0f) & (front | (bsdf > 0.0f));
    vec3 m = microfacet_sample_visible(ggx, au, av, v3_scale(lo, side), u2);
    vfloat om = v3_dot(lo, m), f = principled_fresnel(om, eta, &cos_t);
    vfloat ps, pt, pc, pd;
    principled_probabilities(sp, front, f, brdf, bsdf, &ps, &pt, &pc, &pd);
    vint diffuse = u1 < pd, clearcoat = (u1 >= pd) & (u1 < pd + pc);
    vint transmit = (u1 >= pd + pc) & (u1 < pd + pc + pt); /* else the main reflection */
    /* the main lobes about m: mirrored, or refracted (Mitsuba's refract: cos_t signed against wo's side of m) */
    vfloat eta_ti = SELECT(eta, 1.0f / eta, om >= 0.0f), ct = SELECT(cos_t, -cos_t, om >= 0.0f);
    vec3 li = v3_select(reflected(lo, m), v3_sub(v3_scale(m, MAD(om, eta_ti, ct)), v3_scale(lo, eta_ti)), transmit);
    if (ANY(clearcoat & active)) { /* GTR1's normals: cos^2 = (1 - a^2^(1 - u.y)) / (1 - a^2), phi = 2 pi u.x */
        vfloat a2 = PRINCIPLED(sp, CLEARCOAT_ALPHA) * PRINCIPLED(sp, CLEARCOAT_ALPHA);
        vfloat c2 = (1.0f - vexp2((1.0f - u2.y) * vlog2(a2))) / (1.0f - a2), phi = 2.0f * M_PI_F * u2.x;
        vfloat st = sqrt(vmax(1.0f - c2, zero)), c = sqrt(vmax(c2, zero));
        vec3 mc = v3(cos(phi) * st, sin(phi) * st, c);
        li = v3_select(li, reflected(lo, mc), clearcoat);
        m = v3_select(m, mc, clearcoat);
    }
    vec3 wd = cosine_direction(frame.n, u2);
    bs.wi = v3_select(from_local(frame, li), wd, diffuse);
    li = v3_select(li, to_local(frame, wd), diffuse);
    /* the sampled direction on its lobe's side, and wo and it on m's sides */
    vfloat mo = v3_dot(lo, m) * side, mi = v3_dot(li, m) * side;
    vint on_side = SELECT(co * li.z > 0.0f, co * li.z < 0.0f, transmit);
    vint facing = (mo > 0.0f) & SELECT(mi > 0.0f, mi < 0.0f, transmit);
    active &= on_side & (diffuse | facing);
    vfloat pdf;
    vec3 value = principled_eval(sp, wo, bs.wi, &pdf);
    return principled_weighted(bs, value, pdf, active, transmit);
}

#endif
