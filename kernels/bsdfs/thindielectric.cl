/* `thindielectric`: a thin dielectric slab (Mitsuba 3's `thindielectric`). NOT WRITTEN YET: a placeholder that scatters nothing (issue 57). */
#ifndef BSDFS_THINDIELECTRIC_CL
#define BSDFS_THINDIELECTRIC_CL

inline vec3 thindielectric_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)
{
    *pdf = 0.0f;
    return v3_splat(0.0f, 0.0f, 0.0f);
}

inline BSDFSample thindielectric_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs = {sp.n, v3_splat(0.0f, 0.0f, 0.0f), (vfloat)(0.0f), (vint)(0), (vint)(0)};
    return bs;
}

#endif
