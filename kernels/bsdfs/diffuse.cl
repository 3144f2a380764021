/* `diffuse`: Lambertian reflection, f = reflectance / pi (Mitsuba 3's `diffuse`; pbrt-v4's DiffuseBxDF,
 * section 9.2), sampled by the cosine about the shading normal, so that f cos / p = reflectance. Like every
 * BSDF here it reflects only where both directions lie above the shading normal (Mitsuba's rule; a shading
 * normal bent past the viewer makes the surface black there rather than light it from behind). The
 * reflectance is the material's colour k. */
#ifndef BSDFS_DIFFUSE_CL
#define BSDFS_DIFFUSE_CL

#include "../warp.cl"

inline vec3 diffuse_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    vfloat cos_i = v3_dot(sp.n, wi);
    vint above = (cos_i > 0.0f) & (v3_dot(sp.n, wo) > 0.0f);
    *pdf = SELECT((vfloat)(0.0f), cos_i * M_1_PI_F, above);
    return v3_scale(sp.k, *pdf);
}

inline BSDFSample diffuse_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    bs.wi = cosine_direction(sp.n, u2);
    vfloat cos_i = v3_dot(sp.n, bs.wi);
    bs.pdf = SELECT((vfloat)(0.0f), cos_i * M_1_PI_F, (cos_i > 0.0f) & (v3_dot(sp.n, wo) > 0.0f));
    bs.weight = sp.k;
    bs.delta = bs.transmit = (vint)(0);
    return bs;
}

#endif
