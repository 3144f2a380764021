/* `principledthin`: Disney's principled BSDF for thin, translucent sheets (leaves, paper, cloth, a pane of
 * frosted glass) as Mitsuba 3 writes it (its `principledthin` plugin, v3.9.1: src/bsdfs/principledthin.cpp and
 * principledhelpers.h), after Burley, "Extending the Disney BRDF to a BSDF with Integrated Subsurface
 * Scattering", SIGGRAPH 2015 course notes (section 4, thin surfaces). A sheet of no thickness: the same on both
 * sides (the frame's z is turned to the viewer's side), with no refraction (a transmitted ray goes on in the
 * direction it would have, mirrored through the sheet). With k the colour (base_color), st = spec_trans, dt =
 * diff_trans / 2, cos_o and cos_i the cosines of wo (the viewer: Mitsuba's si.wi) and wi (the light: Mitsuba's
 * wo) on the viewer's side, wi' = wi mirrored to that side (its z made positive) and h the half vector of wo and
 * wi', the value with its cosine (bsdf.cl's convention) is the sum of
 *   reflection        st F_t(wo . h) D(h) G(wo, wi, h) / (4 cos_o)           GGX, alpha_u and alpha_v (anisotropic)
 *   transmission      st k (1 - F) D'(h) G'(wo, wi, h) / (4 cos_o)           GGX of (0.65 eta - 0.35) roughness
 *   diffuse           (1 - st)(1 - dt) k / pi lerp(Burley's, f_ss, flatness) |cos_i|       (reflecting)
 *   sheen             sheen (1 - st)(1 - dt) (1 + sheen_tint (k / lum(k) - 1)) Fw(wi . h) |cos_i| (reflecting)
 *   diffuse through   (1 - st) dt k / pi |cos_i|                                           (across)
 * with F the dielectric Fresnel reflectance of eta (fresnel.cl: 0 at eta 1; beyond the critical angle 1 where
 * eta < 1), F_t = lerp(F, F_s(k / lum R0(eta)), spec_tint) with Schlick's F_s (principled.cl's), Burley's
 * diffuse with retro-reflection and the sheen principled.cl's (principled_diffuse, Rr = 2 roughness (wi . h)^2,
 * Fw the Schlick weight), and Mitsuba's flatness (Hanrahan-Krueger's fake subsurface, principled.cl's
 * principled_flatten): f_ss = 1.25 (Fss (1 / (|cos_o| + |cos_i|) - 0.5) + 0.5), Fss = lerp(1, Rr / 2, Fo)
 * lerp(1, Rr / 2, Fi). The specular lobes are 0 where wo and wi do not see h's front and back as Mitsuba's
 * mac_mic_compatibility asks (the reflection: wo . h and wi . h > 0; the transmission: wo . h > 0, wi . h < 0),
 * which with wi' in h leaves part of the transmission's directions without value. The sheen's lack of a 1 / pi
 * and the transmission's k (not sqrt(k) as principled's) are Mitsuba's, kept. Nothing crosses from one medium
 * to another: no 1 / eta^2.
 *
 * Sampling (Mitsuba's): a lobe by u1 with probabilities proportional to st specular_reflectance_sampling_rate /
 * 2 (the reflection: GGX's visible normals from wo, mirrored), st specular_transmittance_sampling_rate / 2 (the
 * transmission's distribution's visible normals, mirrored and then turned through the sheet), (1 - st)(1 - dt)
 * diffuse_reflectance_sampling_rate and (1 - st) dt diffuse_transmittance_sampling_rate (cosine-weighted on
 * either side, warp.cl). The density is that mixture's; a specular sample that lands on the wrong side or
 * against mac_mic_compatibility is refused (weight 0, pdf 0), as Mitsuba's, and the density of the others
 * counts no such direction, so that the directions kept are distributed as the density. The weight is eval /
 * pdf at the sampled direction. */
#ifndef BSDFS_PRINCIPLEDTHIN_CL
#define BSDFS_PRINCIPLEDTHIN_CL

#include "principled.cl"

/* The lobes' sampling probabilities, normalised (all 0 where every rate with a lobe is 0: no density). */
inline void principledthin_probabilities(ShadingPoint sp, vfloat *ps, vfloat *pt, vfloat *pdr, vfloat *pdt)
{
    vfloat st = PRINCIPLED(sp, SPEC_TRANS), dt = PRINCIPLED(sp, DIFF_TRANS), zero = 0.0f;
    *ps = 0.5f * st * PRINCIPLED(sp, SPECULAR_RATE);
    *pt = 0.5f * st * PRINCIPLED(sp, SPEC_TRANS_RATE);
    *pdr = PRINCIPLED(sp, DIFFUSE_RATE) * (1.0f - st) * (1.0f - dt);
    *pdt = PRINCIPLED(sp, DIFF_TRANS_RATE) * (1.0f - st) * dt;
    vfloat total = *ps + *pt + *pdr + *pdt;
    vfloat inv = SELECT(zero, 1.0f / total, total > 0.0f);
    *ps *= inv;
    *pt *= inv;
    *pdr *= inv;
    *pdt *= inv;
}

inline vec3 principledthin_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    const vint ggx = (vint)(MICROFACET_GGX);
    vfloat zero = 0.0f, st = PRINCIPLED(sp, SPEC_TRANS), dt = PRINCIPLED(sp, DIFF_TRANS), eta = sp.eta.x, cos_t;
    vfloat au = sp.alpha, av = sp.alpha_v, tu = PRINCIPLED(sp, TRANS_ALPHA_U), tv = PRINCIPLED(sp, TRANS_ALPHA_V);
    LocalFrame frame = principled_frame(sp); /* sp.n: no inside (TRANSMITS is 0) */
    vec3 lo = to_local(frame, wo), li = to_local(frame, wi);
    vint active = lo.z != 0.0f;
    vfloat side = SELECT((vfloat)(-1.0f), (vfloat)(1.0f), lo.z >= 0.0f); /* Mitsuba's mulsign: the viewer's side */
    lo = v3_scale(lo, side);
    li = v3_scale(li, side);
    vfloat co = lo.z, ci = li.z;
    vint reflect = ci > 0.0f, refract = ci < 0.0f;
    vec3 mirrored = v3(li.x, li.y, vabs(ci));
    vec3 h = v3_unit_or(v3_add(lo, mirrored), v3_splat(0.0f, 0.0f, 1.0f));
    vfloat oh = v3_dot(lo, h), ih = v3_dot(li, h);
    vint compatible_r = active & reflect & (oh > 0.0f) & (ih > 0.0f);
    vint compatible_t = active & refract & (oh > 0.0f) & (ih < 0.0f);
    vfloat f = principled_fresnel(oh, eta, &cos_t);
    vec3 k = sp.k, tint = principled_tint(k), white = v3_splat(1.0f, 1.0f, 1.0f);

    /* the reflection: the dielectric's F, a share spec_tint of it Schlick's of the tinted R0(eta) */
    vfloat spec_tint = PRINCIPLED(sp, SPEC_TINT), r0 = (eta - 1.0f) / (eta + 1.0f), w = principled_schlick(oh, eta);
    vec3 r0_tint = v3_scale(tint, r0 * r0);
    vec3 f_tint = v3_add(r0_tint, v3_scale(v3_sub(white, r0_tint), w));
    vfloat f_plain = f - f * spec_tint;
    vec3 f_thin = v3_add(v3_scale(f_tint, spec_tint), v3(f_plain, f_plain, f_plain));
    vfloat d = microfacet_d(ggx, au, av, h), g = microfacet_g(ggx, au, av, lo, li, h);
    vfloat specular = SELECT(zero, st * d * g / (4.0f * co), compatible_r & (st > 0.0f));
    vec3 value = v3_scale(f_thin, specular);

    /* the transmission, of its own roughness */
    vfloat d_t = microfacet_d(ggx, tu, tv, h), g_t = microfacet_g(ggx, tu, tv, lo, li, h);
    vfloat through = SELECT(zero, st * (1.0f - f) * d_t * g_t / (4.0f * co), compatible_t & (st > 0.0f));
    value = v3_add(value, v3_scale(k, through));

    /* the diffuse (Burley's, flattened towards the fake subsurface) and the sheen, reflecting; the diffuse
     * transmission */
    vfloat base = (1.0f - st) * (1.0f - dt), aci = vabs(ci);
    vint diffuse_on = active & reflect & (st < 1.0f) & (dt < 1.0f);
    vfloat fo = principled_schlick_weight(aci), fi = principled_schlick_weight(co);
    vfloat rr = 2.0f * PRINCIPLED(sp, ROUGHNESS) * ih * ih, flatness = PRINCIPLED(sp, FLATNESS);
    vfloat lambert = principled_flatten(principled_diffuse(fo, fi, rr), fo, fi, rr, aci + co, flatness);
    vfloat diffuse = SELECT(zero, base * aci * M_1_PI_F * lambert, diffuse_on);
    vfloat sheen = PRINCIPLED(sp, SHEEN), sheen_tint = PRINCIPLED(sp, SHEEN_TINT);
    vfloat sheen_w = SELECT(zero, sheen * base * principled_schlick_weight(vabs(ih)) * aci, diffuse_on & (sheen > 0.0f));
    vec3 c_sheen = v3_add(white, v3_scale(v3_sub(tint, white), sheen_tint));
    vfloat across = SELECT(zero, (1.0f - st) * dt * M_1_PI_F * aci, active & refract & (st < 1.0f) & (dt > 0.0f));
    value = v3_add(value, v3_add(v3_scale(k, diffuse + across), v3_scale(c_sheen, sheen_w)));

    /* the density: the lobes' mixture, the specular ones' normal densities times the Jacobian 1 / (4 wi' . h) */
    vfloat ps, pt, pdr, pdt;
    principledthin_probabilities(sp, &ps, &pt, &pdr, &pdt);
    vfloat jacobian = 1.0f / (4.0f * vabs(v3_dot(mirrored, h)));
    vfloat p = SELECT(zero, ps * microfacet_pdf(ggx, au, av, lo, h) * jacobian, compatible_r & (st > 0.0f));
    p += SELECT(zero, pt * microfacet_pdf(ggx, tu, tv, lo, h) * jacobian, compatible_t & (st > 0.0f));
    p += SELECT(zero, SELECT(pdt, pdr, reflect) * aci * M_1_PI_F, active);
    *pdf = p;
    return v3_select(v3_splat(0.0f, 0.0f, 0.0f), value, active);
}

inline BSDFSample principledthin_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    const vint ggx = (vint)(MICROFACET_GGX);
    vfloat zero = 0.0f;
    LocalFrame frame = principled_frame(sp); /* sp.n: no inside (TRANSMITS is 0) */
    vec3 lo = to_local(frame, wo);
    vint active = lo.z != 0.0f;
    vfloat side = SELECT((vfloat)(-1.0f), (vfloat)(1.0f), lo.z >= 0.0f);
    lo = v3_scale(lo, side);
    vfloat ps, pt, pdr, pdt;
    principledthin_probabilities(sp, &ps, &pt, &pdr, &pdt);
    vint reflect_s = u1 < ps, transmit_s = (u1 >= ps) & (u1 < ps + pt);
    vint diffuse_t = (u1 >= ps + pt + pdr) & (pdt > 0.0f), specular = reflect_s | transmit_s;
    /* the specular lobes: a visible normal of the lobe's distribution, wo mirrored about it (and through the
     * sheet for the transmission) */
    vfloat au = SELECT(sp.alpha, PRINCIPLED(sp, TRANS_ALPHA_U), transmit_s);
    vfloat av = SELECT(sp.alpha_v, PRINCIPLED(sp, TRANS_ALPHA_V), transmit_s);
    vec3 m = microfacet_sample_visible(ggx, au, av, lo, u2);
    vec3 li = reflected(lo, m);
    li.z = SELECT(li.z, -li.z, transmit_s);
    vfloat mi = v3_dot(li, m); /* Mitsuba's mac_mic_compatibility: wi on m's front (reflection) or back */
    vint kept = SELECT((li.z > 0.0f) & (mi > 0.0f), (li.z < 0.0f) & (mi < 0.0f), transmit_s) & (v3_dot(lo, m) > 0.0f);
    vec3 n = v3_scale(frame.n, side), wd = cosine_direction(n, u2); /* else the diffuse lobes, either side */
    bs.wi = v3_select(v3_select(wd, v3_scale(wd, -1.0f), diffuse_t), from_local(frame, v3_scale(li, side)), specular);
    active &= SELECT((vint)(-1), kept, specular);
    vfloat pdf;
    vec3 value = principledthin_eval(sp, wo, bs.wi, &pdf);
    return principled_weighted(bs, value, pdf, active, transmit_s | diffuse_t);
}

#endif
