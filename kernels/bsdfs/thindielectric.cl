/* `thindielectric`: a dielectric slab so thin that its two interfaces coincide, such as a window pane modelled
 * as one sheet (Mitsuba 3's `thindielectric`; pbrt-v4's ThinDielectricBxDF, section 14.1.1). Light entering
 * the slab bounces between its parallel faces, each reflecting R = F(|cos_o|, eta) (fresnel.cl, eta =
 * int_ior / ext_ior in sp.eta.x; both faces see the same angles, so the side the ray comes from does not
 * matter), and the slab reflects the sum of the series R' = R + T^2 R + T^2 R^3 + ... = R + T^2 R / (1 - R^2)
 * = 2 R / (1 + R), T = 1 - R, and transmits the rest, 1 - R'. The transmitted light leaves parallel to the
 * incident (the two refractions cancel), into the medium it came from: wi = -wo, with no 1 / eta^2, which
 * the two crossings cancel too. The choice is made by u1 with probability R' (Mitsuba's u1 <= R'), so that
 * f cos / p is the colour k either way, the material's colour being the specular reflectance and the
 * transmittance alike (the host declares them equal). Both lobes are delta: bsdf_is_delta holds it, and a
 * transmitted sample's next ray leaves from the far side of ng (transmit). Beyond the critical angle (eta < 1)
 * R = 1 and everything is reflected. Shadow rays stop at the pane, as Mitsuba's `path` has them. */
#ifndef BSDFS_THINDIELECTRIC_CL
#define BSDFS_THINDIELECTRIC_CL

#include "../fresnel.cl"
#include "../local_frame.cl"

DELTA_BSDF_EVAL(thindielectric)

/* The slab's reflectance R' = 2 R / (1 + R) at the cosine cos_o of wo to the normal, either side. */
inline vfloat thindielectric_reflectance(vfloat cos_o, vfloat eta)
{
    vfloat cos_t, r = fresnel_dielectric(vabs(cos_o), eta, &cos_t);
    return r * (2.0f / (1.0f + r));
}

inline BSDFSample thindielectric_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2)
{
    BSDFSample bs;
    vfloat r = thindielectric_reflectance(v3_dot(wo, sp.n), sp.eta.x);
    vint reflect = u1 <= r;
    bs.wi = v3_select(v3_scale(wo, -1.0f), reflected(wo, sp.n), reflect);
    bs.weight = sp.k;
    bs.pdf = SELECT(1.0f - r, r, reflect);
    bs.delta = (vint)(-1) != 0; /* a mask, whatever the lane width */
    bs.transmit = !reflect;
    return bs;
}

#endif
