/* `dielectric`: smooth glass, the interface between media of indices int_ior (inside, where the normal
 * points away from) and ext_ior (Mitsuba 3's `dielectric`; pbrt-v4's DielectricBxDF, section 9.5). It
 * reflects with the Fresnel reflectance F (fresnel.cl) and refracts by Snell's law otherwise, the choice made
 * by u1 with probability F, so that f cos / p is the colour k either way, the refracted radiance divided by
 * eta^2 (the solid angle compresses by eta^2 entering a denser medium: radiance, not importance, is carried).
 * sp.eta.x holds int_ior / ext_ior; a hit from inside (sp.backface) sees its inverse. A delta BSDF. */
#ifndef BSDFS_DIELECTRIC_CL
#define BSDFS_DIELECTRIC_CL

#include "../fresnel.cl"
#include "../local_frame.cl"

DELTA_BSDF_EVAL(dielectric)

inline BSDFSample dielectric_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat cos_o = v3_dot(wo, sp.n);
    vfloat eta = SELECT(sp.eta.x, 1.0f / sp.eta.x, sp.backface), cos_t; /* inside: out through the surface */
    vfloat f = fresnel_dielectric(cos_o, eta, &cos_t);
    vint refract = u1 >= f;
    vec3 t = v3_sub(v3_scale(sp.n, cos_o / eta - cos_t), v3_scale(wo, 1.0f / eta));
    bs.wi = v3_select(reflected(wo, sp.n), t, refract);
    bs.weight = v3_select(sp.k, v3_scale(sp.k, 1.0f / (eta * eta)), refract);
    bs.pdf = SELECT((vfloat)(0.0f), SELECT(f, 1.0f - f, refract), cos_o > 0.0f);
    bs.delta = (vint)(-1) != 0;
    bs.transmit = refract;
    return bs;
}

#endif
