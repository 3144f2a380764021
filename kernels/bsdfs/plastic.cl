/* `plastic`: a diffuse base under a smooth dielectric coat of relative index eta = int_ior / ext_ior
 * (sp.eta.x), such as plastic or varnish (Mitsuba 3's `plastic`; the layered model of Weidlich and Wilkie,
 * "Arbitrarily Layered Micro-Facet Surfaces", GRAPHITE 2007, with a smooth coat; pbrt-v4 section 14.3 builds
 * its layered BxDFs by random walks instead). Two lobes, as Mitsuba has them:
 *   - the coat's mirror reflection, a delta lobe of coefficient F(cos_o) specular (sp.specular, the coat's
 *     specular_reflectance), F the Fresnel reflectance (fresnel.cl);
 *   - the base's light, which crosses the coat twice, f cos = d' (1 - F(cos_o)) (1 - F(cos_i)) cos_i /
 *     (pi eta^2): entering, the coat passes 1 - F(cos_i) of the light's power (irradiance, which has no
 *     factor of eta), which the base scatters diffusely; leaving, 1 - F(cos_o) of the radiance inside
 *     crosses into the larger solid angles outside, divided by eta^2 (radiance, not importance, is carried,
 *     as in Mitsuba's radiance mode). The base d (the material's colour k) scatters again and again
 *     under the coat, which reflects back inside the share R_int of its diffuse light, the diffuse Fresnel
 *     reflectance at 1 / eta (d'Eon and Irving's fit, SIGGRAPH 2011; the host's plastic_terms.py). With
 *     nonlinear the round trips' geometric series is d' = d / (1 - d R_int): each return to the base scatters
 *     d again, darkening and saturating the colour as a real varnish does; by default Mitsuba takes d' = d /
 *     (1 - R_int), which keeps the given colour's hue. For a white base the two agree.
 * The lobe is chosen by u1 with Mitsuba's probability p_s = F w / (F w + (1 - F)(1 - w)), F at cos_o and w
 * the host's specular_weight (the coat's share of the mean reflectances), so that each lobe gets samples as
 * it reflects; the diffuse lobe is sampled by the cosine about the shading normal with density (1 - p_s)
 * cos_i / pi, which bsdf_eval's pdf and MIS use. The diffuse lobe's f is symmetric in (wo, wi), reciprocal;
 * its sampling density is not (p_s depends on cos_o alone).
 * bsdf_is_delta stays false: light samples meet the diffuse lobe. A sample of the coat's reflection is
 * delta, so that light it reaches counts whole. One-sided as in Mitsuba, both directions above the shading
 * normal (which faces the viewer: raytrace's BSDFs scatter on both sides of a surface). */
#ifndef BSDFS_PLASTIC_CL
#define BSDFS_PLASTIC_CL

#include "../fresnel.cl"
#include "../local_frame.cl"
#include "../warp.cl"

/* The base's albedo seen through the coat, d' = d / (1 - R_int), or d / (1 - d R_int) where nonlinear: the
 * light the base scatters, summed over its round trips under the coat. */
inline vec3 plastic_base(ShadingPoint sp)
{
    vint nonlinear = sp.nonlinear != 0;
    vfloat r = sp.internal_reflectance;
    vec3 d = sp.k;
    return v3(d.x / (1.0f - SELECT(r, d.x * r, nonlinear)), d.y / (1.0f - SELECT(r, d.y * r, nonlinear)),
              d.z / (1.0f - SELECT(r, d.z * r, nonlinear)));
}

/* The probability of sampling the coat's reflection, F its Fresnel reflectance at cos_o and w the coat's
 * specular_weight. Where no lobe reflects anything (F = 1 with w = 0: total internal reflection under a coat
 * of eta < 1 that reflects nothing; F = 0 with w = 1: eta = 1 over a black base) Mitsuba's 0 / 0 is a NaN;
 * here the diffuse lobe is chosen, and its weight is 0 there as its value. */
inline vfloat plastic_specular_probability(vfloat f, vfloat w)
{
    vfloat ps = f * w, pd = (1.0f - f) * (1.0f - w);
    return SELECT((vfloat)(0.0f), ps / (ps + pd), ps + pd > 0.0f);
}

inline vec3 plastic_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vfloat cos_o = v3_dot(sp.n, wo), cos_i = v3_dot(sp.n, wi), eta = sp.eta.x, zero = 0.0f, cos_t;
    vint above = (cos_o > 0.0f) & (cos_i > 0.0f);
    vfloat f_o = fresnel_dielectric(vmax(cos_o, zero), eta, &cos_t);
    vfloat f_i = fresnel_dielectric(vmax(cos_i, zero), eta, &cos_t);
    vfloat hemisphere = cos_i * M_1_PI_F;
    *pdf = SELECT(zero, hemisphere * (1.0f - plastic_specular_probability(f_o, sp.specular_weight)), above);
    vfloat s = SELECT(zero, hemisphere * (1.0f - f_o) * (1.0f - f_i) / (eta * eta), above);
    return v3_scale(plastic_base(sp), s);
}

inline BSDFSample plastic_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat cos_o = v3_dot(sp.n, wo), eta = sp.eta.x, zero = 0.0f, cos_t;
    vfloat f_o = fresnel_dielectric(vmax(cos_o, zero), eta, &cos_t);
    vfloat ps = plastic_specular_probability(f_o, sp.specular_weight);
    vint specular = u1 < ps;
    /* both lobes' directions and weights, the chosen one kept (the other's may divide by a probability 0) */
    vec3 wd = cosine_direction(sp.n, u2);
    vfloat cos_d = v3_dot(sp.n, wd);
    vfloat f_d = fresnel_dielectric(vmax(cos_d, zero), eta, &cos_t);
    vec3 diffuse = v3_scale(plastic_base(sp), (1.0f - f_o) * (1.0f - f_d) / (eta * eta * (1.0f - ps)));
    bs.wi = v3_select(wd, reflected(wo, sp.n), specular);
    bs.weight = v3_select(diffuse, v3_scale(sp.specular, f_o / ps), specular);
    bs.pdf = SELECT(zero, SELECT((1.0f - ps) * cos_d * M_1_PI_F, ps, specular),
                    (cos_o > 0.0f) & (specular | (cos_d > 0.0f)));
    bs.delta = specular;
    bs.transmit = (vint)(0);
    return bs;
}

#endif
