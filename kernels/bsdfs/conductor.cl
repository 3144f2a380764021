/* `conductor`: a smooth metal, a perfect mirror whose reflectance is the Fresnel reflectance of its complex
 * index of refraction eta + i k per channel (fresnel.cl) times specular_reflectance, the material's colour k
 * (Mitsuba 3's `conductor`; pbrt-v4's ConductorBxDF where its distribution is smooth). eta = k = 0 is a
 * perfect mirror, Mitsuba's material "none". A delta BSDF: one direction, which no light sample meets. */
#ifndef BSDFS_CONDUCTOR_CL
#define BSDFS_CONDUCTOR_CL

#include "../fresnel.cl"
#include "../local_frame.cl"

DELTA_BSDF_EVAL(conductor)

inline BSDFSample conductor_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat cos_o = v3_dot(wo, sp.n);
    bs.wi = reflected(wo, sp.n);
    bs.weight = v3_mul(sp.k, fresnel_conductor3(cos_o, sp.eta, sp.k_imag));
    bs.pdf = SELECT((vfloat)(0.0f), (vfloat)(1.0f), cos_o > 0.0f);
    bs.delta = (vint)(-1) != 0; /* a mask, whatever the lane width */
    bs.transmit = (vint)(0);
    return bs;
}

#endif
