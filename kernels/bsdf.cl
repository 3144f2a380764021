/* The BSDF interface: the only way the integrators (path_tracing.cl) reach a material's scattering, as
 * pbrt-v4's BSDF and Mitsuba 3's BSDF plugins have it. Directions are world unit vectors: wo towards the
 * viewer (where the path came from), wi towards the light or the next vertex; the shading point sp (material.cl)
 * holds the shading normal n, on the side of the geometric normal that faces wo, and the material's values.
 *
 *   bsdf_eval(sp, wo, wi, active)        f(wo, wi) |cos(theta_i)|, theta_i to the shading normal (Mitsuba's
 *                                        eval: the cosine included); 0 for delta lobes
 *   bsdf_pdf(sp, wo, wi, active)         the density per solid angle with which bsdf_sample picks wi
 *   bsdf_eval_pdf(sp, wo, wi, active, &pdf)  both at once (Mitsuba's eval_pdf: what a light sample needs)
 *   bsdf_sample(sp, wo, u1, u2, active)  a direction wi from uniform u1 (the choice of a lobe) and u2 (the
 *                                        direction within it): BSDFSample below
 *   bsdf_is_delta(sp)                    the lanes whose BSDF has delta lobes only: light samples cannot meet it
 *
 * Each BSDF is a file of kernels/bsdfs/ named after it (Mitsuba's plugin name), defining NAME_eval (value and
 * density, as bsdf_eval_pdf) and NAME_sample; the host declares it once (raytrace/scene/bsdfs.py) and numbers
 * it BSDF_* (types.h); a scene compiles the BSDFs its materials use (HAS_* from raytrace/renderer/program.py's
 * Features), diffuse always. Each function below runs every compiled BSDF on the lanes of `active` that have
 * it; a build of diffuse alone runs it on every lane, with no BSDF number to read (HAS_BSDF_PARAMETERS 0).
 * docs/design.md's "Adding a BSDF" says what a new one touches. */
#ifndef BSDF_CL
#define BSDF_CL

#include "material.cl"

typedef struct {
    vec3 wi;       /* the sampled direction */
    vec3 weight;   /* f |cos(theta_i)| / pdf: the path throughput's factor */
    vfloat pdf;    /* wi's density per solid angle; of a delta lobe, the probability it was chosen with;
                    * 0 where there is no sample (wo below the surface, wi below it after reflection) */
    vint delta;    /* wi is a delta lobe's: no light sample could have reached it (its light counts whole) */
    vint transmit; /* wi crosses the surface */
} BSDFSample;

/* NAME_eval of a BSDF of delta lobes only (bsdf_is_delta): no value or density towards a given direction. */
#define DELTA_BSDF_EVAL(name)                                                                               \
    inline vec3 name##_eval(ShadingPoint sp, vec3 wo, vec3 wi, vfloat *pdf)                                 \
    {                                                                                                       \
        *pdf = 0.0f;                                                                                        \
        return v3_splat(0.0f, 0.0f, 0.0f);                                                                  \
    }

#include "bsdfs/diffuse.cl"
#if HAS_CONDUCTORS
#include "bsdfs/conductor.cl"
#endif
#if HAS_DIELECTRICS
#include "bsdfs/dielectric.cl"
#endif
#if HAS_ROUGH_CONDUCTORS
#include "bsdfs/roughconductor.cl"
#endif
#if HAS_THIN_DIELECTRICS
#include "bsdfs/thindielectric.cl"
#endif
#if HAS_ROUGH_DIELECTRICS
#include "bsdfs/roughdielectric.cl"
#endif
#if HAS_PLASTICS
#include "bsdfs/plastic.cl"
#endif
#if HAS_ROUGH_PLASTICS
#include "bsdfs/roughplastic.cl"
#endif
#if HAS_NULLS
#include "bsdfs/null.cl"
#endif
#if HAS_PRINCIPLED
#include "bsdfs/principled.cl"
#endif
#if HAS_PRINCIPLEDTHIN
#include "bsdfs/principledthin.cl"
#endif

/* value and *pdf of NAME_eval where the lanes `on` (of `active`, BSDF `id`) hold that BSDF */
#define BSDF_EVAL(name, id)                                                                                 \
    {                                                                                                       \
        vint on = active & (sp.bsdf == (id));                                                               \
        if (ANY(on)) {                                                                                      \
            vfloat p;                                                                                       \
            vec3 v = name##_eval(sp, wo, wi, &p);                                                           \
            f = v3_select(f, v, on);                                                                        \
            *pdf = SELECT(*pdf, p, on);                                                                     \
        }                                                                                                   \
    }

#if HAS_PERTURBED_NORMALS
/* What Mitsuba 3's normalmap and bumpmap wrappers add to the BSDF of their perturbed normal sp.n (material.cl's
 * perturb_normal), at the light's direction wi: nothing where wi lies on different sides of the shading normal
 * sp.n0 and of sp.n, and the microfacet shadowing term of Estevez et al. (Ray Tracing Gems, 2019, chapter 12),
 * which darkens the light past the tilted normal's terminator smoothly: G = 2 / (1 + sqrt(1 + alpha^2 tan^2
 * theta_i)), alpha^2 = min(tan^2 theta_n / 8, 1), both angles from sp.n0. 1 on unperturbed lanes. */
inline vfloat perturbed_factor(ShadingPoint sp, vec3 wi)
{
    vfloat cos_n = v3_dot(sp.n, sp.n0), cos_i = v3_dot(wi, sp.n0);
    vfloat cos_n2 = cos_n * cos_n, cos_i2 = cos_i * cos_i;
    vfloat alpha2 = vmin(0.125f * vmax(1.0f - cos_n2, 0.0f) / cos_n2, 1.0f);
    vfloat g = 2.0f / (1.0f + sqrt(1.0f + alpha2 * vmax(1.0f - cos_i2, 0.0f) / cos_i2));
    g = SELECT((vfloat)(0.0f), g, cos_i * v3_dot(wi, sp.n) > 0.0f);
    return SELECT((vfloat)(1.0f), g, sp.perturbed);
}
#endif

/* the value and density of the BSDF's lobes: bsdf_eval_pdf but for a perturbed normal's factor */
inline vec3 lobes_eval_pdf(ShadingPoint sp, vec3 wo, vec3 wi, vint active, vfloat *pdf)
{
#if !HAS_BSDF_PARAMETERS
    return diffuse_eval(sp, wo, wi, pdf);
#else
    vec3 f = v3_splat(0.0f, 0.0f, 0.0f);
    *pdf = 0.0f;
    BSDF_EVAL(diffuse, BSDF_DIFFUSE)
#if HAS_ROUGH_CONDUCTORS
    BSDF_EVAL(roughconductor, BSDF_ROUGHCONDUCTOR)
#endif
#if HAS_ROUGH_DIELECTRICS
    BSDF_EVAL(roughdielectric, BSDF_ROUGHDIELECTRIC)
#endif
#if HAS_PLASTICS
    BSDF_EVAL(plastic, BSDF_PLASTIC)
#endif
#if HAS_ROUGH_PLASTICS
    BSDF_EVAL(roughplastic, BSDF_ROUGHPLASTIC)
#endif
#if HAS_PRINCIPLED
    BSDF_EVAL(principled, BSDF_PRINCIPLED)
#endif
#if HAS_PRINCIPLEDTHIN
    BSDF_EVAL(principledthin, BSDF_PRINCIPLEDTHIN)
#endif
    /* the delta BSDFs' (bsdf_is_delta) eval is 0: conductor_eval, dielectric_eval, thindielectric_eval */
    return f;
#endif
}

inline vec3 bsdf_eval_pdf(ShadingPoint sp, vec3 wo, vec3 wi, vint active, vfloat *pdf)
{
    vec3 f = lobes_eval_pdf(sp, wo, wi, active, pdf);
#if HAS_PERTURBED_NORMALS
    vfloat g = perturbed_factor(sp, wi);
    *pdf = SELECT(*pdf, (vfloat)(0.0f), g == 0.0f);
    f = v3_scale(f, g);
#endif
    return f;
}

inline vec3 bsdf_eval(ShadingPoint sp, vec3 wo, vec3 wi, vint active)
{
    vfloat pdf;
    return bsdf_eval_pdf(sp, wo, wi, active, &pdf);
}

inline vfloat bsdf_pdf(ShadingPoint sp, vec3 wo, vec3 wi, vint active)
{
    vfloat pdf;
    bsdf_eval_pdf(sp, wo, wi, active, &pdf);
    return pdf;
}

/* NAME_sample's sample where the lanes `on` (of `active`, BSDF `id`) hold that BSDF */
#define BSDF_SAMPLE(name, id)                                                                               \
    {                                                                                                       \
        vint on = active & (sp.bsdf == (id));                                                               \
        if (ANY(on)) {                                                                                      \
            BSDFSample b = name##_sample(sp, wo, u1, u2);                                                   \
            bs.wi = v3_select(bs.wi, b.wi, on);                                                             \
            bs.weight = v3_select(bs.weight, b.weight, on);                                                 \
            bs.pdf = SELECT(bs.pdf, b.pdf, on);                                                             \
            bs.delta = SELECT(bs.delta, b.delta, on);                                                       \
            bs.transmit = SELECT(bs.transmit, b.transmit, on);                                              \
        }                                                                                                   \
    }

/* a sample of the BSDF's lobes: bsdf_sample but for a perturbed normal's factor */
inline BSDFSample lobes_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2, vint active)
{
#if !HAS_BSDF_PARAMETERS
    return diffuse_sample(sp, wo, u1, u2);
#else
    BSDFSample bs = {sp.n, v3_splat(0.0f, 0.0f, 0.0f), (vfloat)(0.0f), (vint)(0), (vint)(0)};
    BSDF_SAMPLE(diffuse, BSDF_DIFFUSE)
#if HAS_CONDUCTORS
    BSDF_SAMPLE(conductor, BSDF_CONDUCTOR)
#endif
#if HAS_DIELECTRICS
    BSDF_SAMPLE(dielectric, BSDF_DIELECTRIC)
#endif
#if HAS_ROUGH_CONDUCTORS
    BSDF_SAMPLE(roughconductor, BSDF_ROUGHCONDUCTOR)
#endif
#if HAS_THIN_DIELECTRICS
    BSDF_SAMPLE(thindielectric, BSDF_THINDIELECTRIC)
#endif
#if HAS_ROUGH_DIELECTRICS
    BSDF_SAMPLE(roughdielectric, BSDF_ROUGHDIELECTRIC)
#endif
#if HAS_PLASTICS
    BSDF_SAMPLE(plastic, BSDF_PLASTIC)
#endif
#if HAS_ROUGH_PLASTICS
    BSDF_SAMPLE(roughplastic, BSDF_ROUGHPLASTIC)
#endif
#if HAS_NULLS
    BSDF_SAMPLE(null, BSDF_NULL)
#endif
#if HAS_PRINCIPLED
    BSDF_SAMPLE(principled, BSDF_PRINCIPLED)
#endif
#if HAS_PRINCIPLEDTHIN
    BSDF_SAMPLE(principledthin, BSDF_PRINCIPLEDTHIN)
#endif
    return bs;
#endif
}

inline BSDFSample bsdf_sample(ShadingPoint sp, vec3 wo, vfloat u1, vec2 u2, vint active)
{
    BSDFSample bs = lobes_sample(sp, wo, u1, u2, active);
#if HAS_PERTURBED_NORMALS
    vfloat g = perturbed_factor(sp, bs.wi);
    bs.weight = v3_scale(bs.weight, g);
    bs.pdf = SELECT(bs.pdf, (vfloat)(0.0f), g == 0.0f);
#endif
    return bs;
}

inline vint bsdf_is_delta(ShadingPoint sp)
{
    vint delta = (vint)(0);
#if HAS_CONDUCTORS
    delta |= sp.bsdf == BSDF_CONDUCTOR;
#endif
#if HAS_DIELECTRICS
    delta |= sp.bsdf == BSDF_DIELECTRIC;
#endif
#if HAS_THIN_DIELECTRICS
    delta |= sp.bsdf == BSDF_THINDIELECTRIC;
#endif
#if HAS_NULLS
    delta |= sp.bsdf == BSDF_NULL;
#endif
    return delta;
}

#endif
