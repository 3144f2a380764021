/* `null`: no surface at all for the light (Mitsuba 3's `null`), what a `mask` is where its opacity lets light
 * through (wrappers.cl chooses it there): every sample passes straight on, wi = -wo, with weight 1 and the whole
 * probability, a delta lobe that crosses the surface. As in Mitsuba 3's `path`, the pass counts as a vertex of
 * the path (max_depth); unlike there, shadow rays pass the surface too (primitive.cl), and light a ray reaches
 * after the pass is weighted by MIS as from the vertex before it (path_tracing.cl). */
#ifndef BSDFS_NULL_CL
#define BSDFS_NULL_CL

DELTA_BSDF_EVAL(null)

inline BSDFSample null_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    bs.wi = v3_scale(wo, -1.0f);
    bs.weight = v3_splat(1.0f, 1.0f, 1.0f);
    bs.pdf = (vfloat)(1.0f);
    bs.delta = (vint)(-1) != 0; /* a mask, whatever the lane width */
    bs.transmit = bs.delta;
    return bs;
}

#endif
