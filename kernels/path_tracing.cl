/* Global illumination, the third shading model (`shading = "path"`; docs/global-illumination.md):
 * unidirectional path tracing from the camera (pbrt-v4's PathIntegrator, Mitsuba 3's `path`). A material's
 * BSDF is its `type`, with Mitsuba's names: `diffuse`, Lambertian, f = albedo / pi, both sides reflecting, as
 * in the direct model; `conductor`, a smooth mirror with the Fresnel reflectance of eta + i k
 * (HAS_CONDUCTORS); `dielectric`, smooth glass that reflects or refracts by its Fresnel reflectance
 * (HAS_DIELECTRICS); `roughconductor`, GGX microfacets of roughness alpha with the conductor's Fresnel term
 * (HAS_ROUGH_CONDUCTORS, microfacet.cl). The rectangular lights emit their radiance from the front face and
 * reflect by their material where they have one; an environment (HAS_ENVIRONMENT, environment.cl), constant
 * or an image, emits along every direction in which a ray leaves the scene.
 *
 * At every vertex the lights are sampled by area (next-event estimation, light_sampling.cl) and the BSDF by
 * its own sample (the cosine-weighted hemisphere for diffuse, the visible normals for rough conductors); the
 * two estimates of light reached both ways are combined by multiple importance sampling with the power
 * heuristic (Veach, "Robust Monte Carlo Methods for Light Transport Simulation", 1997, section 9.2), and so
 * are the environment's, sampled by its map or, constant, by the cosine about the normal. Each light's n
 * samples form one technique and the BSDF's single sample the other: w_light = (n p_light)^2 / ((n p_light)^2
 * + p_bsdf^2), both densities per solid angle, p_light = r^2 / (A cos(theta_l)), p_bsdf the density of the
 * BSDF's sample (cos(theta_s) / pi for diffuse). The weights are formed from the ratio p_bsdf / (n p_light),
 * which stays finite where either density does not (a light seen edge-on). The smooth conductor and the
 * dielectric are delta BSDFs, one direction each, which no light sample can meet: their vertices sample
 * that direction alone (sample_specular), and light it reaches counts whole.
 *
 * Depth follows Mitsuba's convention: max_depth 1 shows the emitters seen directly, 2 adds direct light, -1
 * is unbounded. From vertex rr_depth on (Mitsuba's default 5), after the vertex's light samples, Russian
 * roulette continues a path with probability q = min(max(throughput), 0.95) and divides its throughput by q
 * (pbrt-v4 section 13.1.1). */
#ifndef PATH_TRACING_CL
#define PATH_TRACING_CL

#include "vmath.h"
#include "material.cl"
#if HAS_ROUGH_CONDUCTORS
#include "microfacet.cl"
#endif
/* The light samples' weights are colours where a BSDF's value varies by channel with the direction (a rough
 * conductor's Fresnel term): light_sampling.cl then sums them as such. */
#define LIGHT_VALUE_VEC3 HAS_ROUGH_CONDUCTORS
#ifndef LIGHT_SOLID_ANGLE
/* Lights are sampled by area. A build with 1 samples them by the solid angle they subtend where that is
 * accurate (spherical_rectangle.cl): its images are less noisy at the same samples, but each sample costs
 * more, and to the same error it took longer (measured in docs/global-illumination.md, from the records in
 * benchmarks/results/solid-angle/), so the renderer leaves it off; the tests keep it correct. */
#define LIGHT_SOLID_ANGLE 0
#endif

#ifndef RR_DEPTH
#define RR_DEPTH 5     /* the first vertex at which Russian roulette may end a path (Mitsuba's rr_depth) */
#endif
#ifndef PATH_SAMPLING
/* How light reaching a vertex is sampled: 0, both ways combined by MIS (the renderer's only choice); tests
 * (tests/test_path_integrator.py and the BSDFs' own) build 1, the lights alone, and 2, the BSDF alone, which
 * must agree with it. */
#define PATH_SAMPLING 0
#endif
#define RR_MAX_Q 0.95f /* a path always has a chance to end there, however bright its throughput */

/* A light sample counts where it lies above the surface (ng and the shading normal n) and in front of the
 * light (direct_lighting.cl's rule). */
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f) & (v3_dot(light_normal, l) < 0.0f);
}

/* 1 / (1 + x^2): the power heuristic's weight of a technique whose density is 1 / x times the other's. */
inline vfloat power_weight(vfloat x) { return 1.0f / MAD(x, x, 1.0f); }

#if HAS_BSDF_PARAMETERS
/* wo mirrored about the unit normal n. */
inline vec3 reflected(vec3 wo, vec3 n) { return v3_sub(v3_scale(n, 2.0f * v3_dot(wo, n)), wo); }

/* The Fresnel reflectance of a conductor of complex index of refraction eta + i k (relative to the outside)
 * at cos(theta_i) in [0, 1], unpolarised: the exact formula in real arithmetic (pbrt-v3's FrConductor, after
 * Born and Wolf). eta = k = 0 gives 1: a perfect mirror, Mitsuba's conductor of material "none".
 *
 * Its largest term, t0^2 + 4 eta^2 k^2, is at most (m^2 + 1)^2 + 4 m^4 for m = max(eta, k): below float32's
 * 2^128 while m <= 2^31. Beyond, the formula runs on cos(theta_i), eta and k times the power of two s that
 * takes m into [2^30, 2^31), and on sin^2 and cos^2 times s^2. rs is a ratio of terms of degree 2 in (cos,
 * eta, k), sin^2 counting as of degree 2, so the scaling leaves it unchanged, and a power of two rounds
 * nothing; what underflows there (cos s, cos^2 s^2, sin^2 s^2) makes terms below 2^-60 of a2b2 >= 2^60,
 * which they are added to or taken from.
 * rp / rs is a ratio of terms of degree 4, t3 and t4, whose scaled products would underflow: they are taken
 * over s^2 a2b2 instead, t3 = cos^2 + sin^4 s^2 / a2b2 and t4 = 2 cos sin^2 s a / a2b2, normal numbers for
 * cos(theta_i) >= 2^-62 (nearer grazing the reflectance stays in [0, 1]). The reflectance tends to 1 as the
 * index grows. Up to m = 2^31, s = 1: the bits of the unscaled formula. */
inline vfloat fresnel_conductor(vfloat cos_i, vfloat eta, vfloat k)
{
    const vfloat cos2 = cos_i * cos_i, sin2 = 1.0f - cos2, m = vmax(eta, k);
    const vint scaled = m > 0x1p31f;
    const vfloat s = SELECT((vfloat)(1.0f), ldexp((vfloat)(1.0f), 30 - ilogb(vmax(m, (vfloat)(1.0f)))), scaled);
    const vfloat s2 = s * s, c = cos_i * s, e = eta * s, kk = k * s, c2 = cos2 * s2, n2 = sin2 * s2;
    vfloat t0 = e * e - kk * kk - n2;
    vfloat a2b2 = sqrt(vmax(MAD(t0, t0, 4.0f * e * e * kk * kk), (vfloat)(0.0f)));
    vfloat t1 = a2b2 + c2, a = sqrt(vmax(0.5f * (a2b2 + t0), (vfloat)(0.0f))), t2 = 2.0f * c * a;
    vfloat rs = (t1 - t2) / (t1 + t2);
    vfloat t3 = MAD(c2, a2b2, n2 * n2), t4 = t2 * n2;
    t3 = SELECT(t3, MAD(sin2 * sin2, s2 / a2b2, cos2), scaled);
    t4 = SELECT(t4, 2.0f * cos_i * sin2 * (s * a / a2b2), scaled);
    vfloat rp = SELECT(rs * (t3 - t4) / (t3 + t4), rs, t3 + t4 == 0.0f); /* 0 / 0: the mirror head-on */
    return 0.5f * (rp + rs);
}

/* The conductor's reflectance per channel. */
inline vec3 fresnel_conductor3(vfloat cos_i, vec3 eta, vec3 k)
{
    return v3(fresnel_conductor(cos_i, eta.x, k.x), fresnel_conductor(cos_i, eta.y, k.y),
              fresnel_conductor(cos_i, eta.z, k.z));
}
#endif

/* The BSDF towards l seen along v relative to a Lambertian one of the same colour k, pi f / k (1 for the
 * diffuse lanes; a rough conductor's pi F D G2 / (4 cos(theta_o) cos(theta_l)), G2 = G1(v) G1(l) the separable
 * form, Mitsuba's: microfacet.cl), and *pdf, the density of the BSDF's own sample of l: cos(theta_l) / pi, or
 * GGX's G1 D / (4 cos(theta_o)). The GGX terms need only cosines to the normal: they are isotropic. */
inline vec3 bsdf_value(ShadingPoint sp, vec3 v, vec3 l, vfloat *pdf)
{
    vfloat cos_s = v3_dot(sp.n, l);
    vec3 value = v3_splat(1.0f, 1.0f, 1.0f);
    *pdf = cos_s * M_1_PI_F;
#if HAS_ROUGH_CONDUCTORS
    vint rough = sp.bsdf == BSDF_ROUGHCONDUCTOR;
    if (ANY(rough)) {
        vec3 h = v3_direction(v3_add(v, l));
        vfloat cos_o = v3_dot(sp.n, v), zero = 0.0f;
        vec3 zo = v3(zero, zero, cos_o), zi = v3(zero, zero, cos_s), zh = v3(zero, zero, v3_dot(sp.n, h));
        vfloat d = ggx_d(zh, sp.alpha);
        vfloat common = M_PI_F * d * ggx_g2(zo, zi, sp.alpha) / (4.0f * cos_o * cos_s);
        common = SELECT(common, zero, cos_o <= 0.0f);
        value = v3_select(value, v3_scale(fresnel_conductor3(v3_dot(v, h), sp.eta, sp.k_imag), common), rough);
        *pdf = SELECT(*pdf, ggx_g1(zo, sp.alpha) * d / (4.0f * cos_o), rough);
    }
#endif
    return value;
}

/* The model's sample_weight takes the solid angle light_sampling.cl sampled the light by (0: by area). */
#if LIGHT_SOLID_ANGLE
#define SOLID_ANGLE_PARAMETER , vfloat solid_angle
#define SOLID_ANGLE_BY_AREA
#else
#define SOLID_ANGLE_PARAMETER
#define SOLID_ANGLE_BY_AREA const vfloat solid_angle = 0.0f;
#endif

/* 1 / (A p_light), A the light's area and p_light the density per steradian of a light's sample towards l:
 * cos(theta_l) / r^2 by area, the solid angle over A where the light was sampled by it (solid_angle > 0). */
inline vfloat light_area_weight(vfloat cos_l, vfloat r2, float area, vfloat solid_angle)
{
#if LIGHT_SOLID_ANGLE
    return SELECT(cos_l / r2, solid_angle / area, solid_angle > 0.0f);
#else
    return cos_l / r2;
#endif
}

#if LIGHT_VALUE_VEC3
/* The light sample's pi f cos(theta_s) / (k A p_light) (bsdf_value), times its MIS weight against the BSDF's
 * own sample of the direction: x = p_bsdf / (n p_light). */
inline vec3 sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area,
                          int n SOLID_ANGLE_PARAMETER)
{
    SOLID_ANGLE_BY_AREA
    vfloat cos_s = v3_dot(sp.n, l), pdf;
    vfloat g = light_area_weight(-v3_dot(light_normal, l), v3_dot(w, w), area, solid_angle);
    vec3 value = v3_scale(bsdf_value(sp, v, l, &pdf), cos_s * g);
#if PATH_SAMPLING == 1
    return value;
#else
    return v3_scale(value, power_weight(pdf * g * (area / (float)n)));
#endif
}
#else
/* The light sample's cos(theta_s) / (A p_light), times its MIS weight against a cosine-weighted BSDF sample of
 * the same direction: x = p_bsdf / (n p_light) = cos(theta_s) / (pi n p_light). */
inline vfloat sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area,
                            int n SOLID_ANGLE_PARAMETER)
{
    SOLID_ANGLE_BY_AREA
    vfloat g = v3_dot(sp.n, l) * light_area_weight(-v3_dot(light_normal, l), v3_dot(w, w), area, solid_angle);
#if PATH_SAMPLING == 1
    return g;
#else
    return g * power_weight(g * (area * M_1_PI_F / (float)n));
#endif
}
#endif

inline float light_scale(__global const Light *light)
{
    return 4.0f * light->shape.half_x * light->shape.half_y * M_1_PI_F;
}

#include "light_sampling.cl"
#if HAS_ENVIRONMENT
#include "environment.cl"
#endif

/* Unit vectors *t and *b completing the unit n to a right-handed orthonormal frame, without a branch or a
 * cancellation (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017). */
inline void orthonormal_frame(vec3 n, vec3 *t, vec3 *b)
{
    vfloat sign = vcopysign((vfloat)(1.0f), n.z), a = -1.0f / (sign + n.z), c = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = v3(c, sign + n.y * n.y * a, -n.y);
}

/* A direction about the unit normal n with density cos(theta) / pi, from u in [0, 1)^2: Malley's method, a
 * uniform point on the disk (Shirley and Chiu's concentric map, pbrt-v4 section A.5.1) lifted to the
 * hemisphere. */
inline vec3 cosine_direction(vec3 n, vec2 u)
{
    vfloat a = MAD(2.0f, u.x, -1.0f), b = MAD(2.0f, u.y, -1.0f);
    vint first = vabs(a) > vabs(b);
    vfloat r = SELECT(b, a, first);
    /* phi = x (first) or pi/2 - x, |x| <= pi/4: cos and sin of x, exchanged for pi/2 - x, inline (vmath.h) */
    vfloat x = SELECT((M_PI_4_F * a) / b, (M_PI_4_F * b) / a, first), sin_x, cos_x;
    x = SELECT(x, (vfloat)(0.0f), (a == 0.0f) & (b == 0.0f));
    vsincos_quarter(x, &sin_x, &cos_x);
    vfloat dx = r * SELECT(sin_x, cos_x, first), dy = r * SELECT(cos_x, sin_x, first);
    vfloat dz = sqrt(vmax((vfloat)(0.0f), 1.0f - dx * dx - dy * dy));
    vec3 t, bt;
    orthonormal_frame(n, &t, &bt);
    return v3_add(v3_add(v3_scale(t, dx), v3_scale(bt, dy)), v3_scale(n, dz));
}

#if HAS_SPECULAR
/* The Fresnel reflectance of a dielectric interface at cos(theta_i) in [0, 1] on the incident side, eta the
 * index of refraction beyond over the one before it; *cos_t the cosine of the refracted direction, and 1 with
 * *cos_t = 0 beyond the critical angle (total internal reflection): pbrt-v4's FrDielectric. */
inline vfloat fresnel_dielectric(vfloat cos_i, vfloat eta, vfloat *cos_t)
{
    vfloat sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    vint total = sin2_t >= 1.0f;
    vfloat ct = sqrt(vmax(1.0f - sin2_t, (vfloat)(0.0f)));
    vfloat r_parl = (eta * cos_i - ct) / (eta * cos_i + ct), r_perp = (cos_i - eta * ct) / (cos_i + eta * ct);
    *cos_t = SELECT(ct, (vfloat)(0.0f), total);
    return SELECT(0.5f * (r_parl * r_parl + r_perp * r_perp), (vfloat)(1.0f), total);
}

/* The smooth BSDFs' sample for the lanes of `lanes`, seen along wo (towards the viewer), the shading normal
 * sp.n facing wo: the direction *wi and the throughput's factor f cos / p (*weight); *transmit where the
 * direction crosses the surface. A conductor reflects with weight k F; a dielectric reflects with
 * probability F (weight k) and refracts otherwise, its radiance divided by eta^2 (pbrt-v4 section 9.5: the
 * solid angle compresses by eta^2 entering a denser medium), the choice made by u. */
inline void sample_specular(ShadingPoint sp, vec3 wo, vfloat u, vint lanes, vec3 *wi, vec3 *weight, vint *transmit)
{
    vfloat cos_i = v3_dot(wo, sp.n);
    vec3 mirror = reflected(wo, sp.n);
#if HAS_CONDUCTORS
    vint conductor = lanes & (sp.bsdf == BSDF_CONDUCTOR);
    if (ANY(conductor)) {
        vec3 f = fresnel_conductor3(cos_i, sp.eta, sp.k_imag);
        *wi = v3_select(*wi, mirror, conductor);
        *weight = v3_select(*weight, v3_mul(sp.k, f), conductor);
    }
#endif
#if HAS_DIELECTRICS
    vint dielectric = lanes & (sp.bsdf == BSDF_DIELECTRIC);
    if (ANY(dielectric)) {
        vfloat eta = SELECT(sp.eta.x, 1.0f / sp.eta.x, sp.backface), cos_t; /* inside: out through the surface */
        vfloat f = fresnel_dielectric(cos_i, eta, &cos_t);
        vint refract = dielectric & (u >= f);
        vec3 t = v3_sub(v3_scale(sp.n, cos_i / eta - cos_t), v3_scale(wo, 1.0f / eta));
        *wi = v3_select(*wi, v3_select(mirror, t, refract), dielectric);
        *weight = v3_select(*weight, v3_select(sp.k, v3_scale(sp.k, 1.0f / (eta * eta)), refract), dielectric);
        *transmit |= refract;
    }
#endif
}
#endif

/* The area of the light each lane's hit is on (HAS_SURFACE_DATA: kind SHAPE_NONE and the light's index, for a
 * hit; a miss has kind SHAPE_NONE too), 0 elsewhere. */
inline vfloat hit_light_area(const Scene *s, Hit hit)
{
    int kind[LANES], index[LANES];
    float t[LANES], area[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(hit.t, t);
    for (int i = 0; i < LANES; ++i) {
        __global const Rectangle *shape = &s->lights[index[i]].shape;
        area[i] = kind[i] == SHAPE_NONE && t[i] < INFINITY ? 4.0f * shape->half_x * shape->half_y : 0.0f;
    }
    return VLOAD(area);
}

#if LIGHT_SOLID_ANGLE
/* The solid angle, seen from each lane's o, of the light each lane's hit is on where light_sampling.cl samples
 * that light by solid angle from o, 0 elsewhere (by area, or no light hit). */
inline vfloat hit_light_solid_angle(const Scene *s, Hit hit, vec3 o)
{
    vfloat solid_angle = 0.0f;
    vint on_light = (hit.kind == SHAPE_NONE) & (hit.t < INFINITY);
    for (int li = 0; li < s->params->n_lights; ++li) {
        vint here = on_light & (hit.index == li);
        if (ANY(here)) {
            SphericalRectangle q = spherical_rectangle(&s->lights[li].shape, o);
            solid_angle = SELECT(solid_angle, q.solid_angle, here & spherical_rectangle_used(q));
        }
    }
    return solid_angle;
}
#endif

#if HAS_ENVIRONMENT
/* The lanes of `active` whose ray from o along the unit d leaves the scene: no shape and no light meets it
 * before it is beyond every coordinate the scene has (the segment to o + 4 extent d, |o| being within
 * sqrt(3) extent of the origin). */
inline vint escapes(const Scene *s, vec3 o, vec3 d, vint active)
{
    Ray r = {o, v3_scale(d, 4.0f * s->params->scene_extent)};
    vint blocked = occluded(s, r, 0u, active);
    vfloat dt, u, v;
    for (int i = 0; i < s->params->n_lights; ++i) {
        vfloat t = intersect_rectangle(&s->lights[i].shape, r, (vfloat)(1.0f), &dt, &u, &v);
        blocked |= hit_on_segment(t, dt);
    }
    return active & !blocked;
}
#endif

/* A path in each lane (pbrt-v4's PathIntegrator::Li, cut at its closest-hit call so that the lanes of a packet
 * may stand at different vertices: render.cl starts a lane's next pixel sample where its path ends): the ray
 * it follows next, from the camera (depth 0) or from its vertex `depth`, the throughput beta, the radiance
 * gathered so far, and what the MIS weight of light the ray reaches needs of the vertex it left: its BSDF
 * sample's density, whether that was a delta BSDF's or the camera's (weight 1), and for a constant
 * environment the sample's cosine (p_env = cos / pi), for solid-angle light sampling the vertex. */
typedef struct {
    Ray r;
    vec3 beta, radiance;
    vint depth, specular;
    vfloat pdf;
#if HAS_ENVIRONMENT
    vfloat cos_s;
#endif
#if LIGHT_SOLID_ANGLE
    vec3 p;
#endif
} PathState;

/* The paths of `lanes` start anew along the camera rays r. */
inline void start_paths(PathState *path, Ray r, vint lanes)
{
    path->r.o = v3_select(path->r.o, r.o, lanes);
    path->r.d = v3_select(path->r.d, r.d, lanes);
    path->beta = v3_select(path->beta, v3_splat(1.0f, 1.0f, 1.0f), lanes);
    path->radiance = v3_select(path->radiance, v3_splat(0.0f, 0.0f, 0.0f), lanes);
    path->depth = SELECT(path->depth, (vint)(0), lanes);
    path->specular = SELECT(path->specular, (vint)(-1), lanes) != 0; /* a mask, whatever the lane width */
    path->pdf = SELECT(path->pdf, (vfloat)(1.0f), lanes);
}

/* The BSDF's and roulette's numbers: sobol's sequence, else independent points (a table pattern is a light's,
 * or the course's). */
inline Sampler bounce_sampler(const Scene *s)
{
    Sampler bounce = s->params->light_sampler;
    if (bounce.randomize != RANDOMIZE_SOBOL)
        bounce.randomize = RANDOMIZE_INDEPENDENT;
    return bounce;
}

/* The paths of `lanes` meet `hit` along their rays: the light and environment they reach, weighted against the
 * lights' samples of the same direction at the vertex they left (a camera ray's counts whole, max_depth 0
 * excepted). Returns the lanes whose hit is a vertex to shade: a surface, below max_depth. */
inline vint path_hit(const Scene *s, PathState *path, Hit hit, vint lanes)
{
    const int max_depth = s->params->max_depth, n_light = s->params->light_samples;
    const vec3 wi = path->r.d;
    const vint specular = path->specular;
    const vfloat pdf = path->pdf;
    /* light reached by the BSDF's sample, weighted against the lights' samples of the same direction: x = n
     * p_light / p_bsdf = n r^2 / (A cos(theta_l) p_bsdf) (0 where no light was hit: weight 1) */
    vfloat area = hit_light_area(s, hit), cos_l = vabs(v3_dot(hit.n, wi));
    vfloat x = (float)n_light * hit.t * hit.t / (area * cos_l * pdf);
#if LIGHT_SOLID_ANGLE
    vfloat solid_angle = hit_light_solid_angle(s, hit, path->p); /* p_light = 1 / solid_angle there */
    x = SELECT(x, (float)n_light / (solid_angle * pdf), solid_angle > 0.0f);
#endif
    vfloat w = SELECT(power_weight(x), (vfloat)(1.0f), (area == 0.0f) | specular);
#if PATH_SAMPLING == 1
    w = SELECT((vfloat)(0.0f), (vfloat)(1.0f), (area == 0.0f) | specular);
#elif PATH_SAMPLING == 2
    w = (vfloat)(1.0f);
#endif
    const vint seen = max_depth != 0 ? lanes : (vint)(0); /* max_depth 0: nothing, not even the emitters */
#if HAS_ENVIRONMENT
    vint escaped = seen & (hit.t == INFINITY);
    if (ANY(escaped)) { /* the environment reached by the BSDF's sample: x = p_env / p_bsdf, weight 1 after the
                         * camera or a specular vertex */
#if HAS_ENVIRONMENT_MAP
        vfloat pdf_e = environment_pdf(s, wi, escaped & !specular); /* (a camera ray's needs none) */
#else
        vfloat pdf_e = path->cos_s * M_1_PI_F;
#endif
        vfloat w_env = SELECT(power_weight(pdf_e / pdf), (vfloat)(1.0f), specular);
#if PATH_SAMPLING == 1
        w_env = SELECT((vfloat)(0.0f), (vfloat)(1.0f), specular);
#elif PATH_SAMPLING == 2
        w_env = (vfloat)(1.0f);
#endif
        vec3 e = v3_scale(v3_mul(path->beta, environment_radiance(s, wi, escaped)), w_env);
        path->radiance = v3_add(path->radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), e, escaped));
    }
#endif
    vint lit = seen & (hit.t < INFINITY);
    path->radiance = v3_add(path->radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f),
                                                      v3_scale(v3_mul(path->beta, hit.emitted), w), lit));
    vint alive = lanes & (hit.t < INFINITY) & (hit.material >= 0);

    path->depth += 1; /* (a lane without a path is reset when it starts one) */
    return alive & (((vint)(max_depth < 0) != 0) | (path->depth < max_depth));
}

/* The paths of `alive` at their vertex, shaded at sp: the light sampled there (the lights, and the
 * environment), then the BSDF's sample of the direction onwards, which becomes the path's ray; *rays counts the
 * rays traced per lane. Returns the lanes whose path goes on: the BSDF's sample leaves the surface on its side. */
inline vint path_vertex(const Scene *s, TextureStore ts, PathState *path, ShadingPoint sp, vint alive,
                        __global const uint2 *light_samples, PixelSample *ps, vfloat *rays)
{
    const Sampler bounce = bounce_sampler(s);
    const Ray r = path->r;
    vec3 beta = path->beta, radiance = path->radiance;
    COUNT_VISITS_ADD(s, VISITS_PATH_LANES, count_lanes(alive));
    COUNT_VISITS_ADD(s, VISITS_PATH_LANE_STEPS, LANES);
    /* light reached by sampling the lights: k / pi sum over lights (A / n) sum_j V L_e G w */
#if HAS_SPECULAR
    const vint specular = sp.bsdf != BSDF_DIFFUSE; /* a delta BSDF: no light sample can meet its one direction */
#else
    const vint specular = (vint)(0);
#endif
    vec3 direct = lights_sum(s, sp, v3_scale(r.d, -1.0f), PATH_SAMPLING == 2 ? (vint)(0) : alive & !specular,
                             light_samples, ps, rays);
    radiance = v3_add(radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_mul(v3_mul(beta, sp.k), direct), alive));
#if HAS_ENVIRONMENT
    { /* the environment, sampled by its map (environment.cl) or, constant, by the cosine about the normal;
       * the sample's f cos / p_env = k bsdf_value cos / (pi p_env), weighted against the BSDF's sample of
       * the same direction: x = p_bsdf / p_env */
        vec2 ue = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0)); /* drawn or not */
        const vint candidates = PATH_SAMPLING == 2 ? (vint)(0) : alive & !specular;
        if (ANY(candidates)) { /* the map's sampling and lookups are per lane: none for a packet without use */
            vec3 wo_ = v3_scale(r.d, -1.0f);
#if HAS_ENVIRONMENT_MAP
            vfloat pdf_e;
            vec3 we = sample_environment(s, ue, candidates, &pdf_e);
#else
            vec3 we = cosine_direction(sp.n, ue);
            vfloat pdf_e = v3_dot(sp.n, we) * M_1_PI_F;
#endif
            vfloat cos_e = v3_dot(sp.n, we), pdf_b;
            vint sampled = candidates & (v3_dot(sp.ng, we) > 0.0f) & (cos_e > 0.0f) & (pdf_e > 0.0f);
            vec3 f = bsdf_value(sp, wo_, we, &pdf_b);
            vfloat w = PATH_SAMPLING == 1 ? (vfloat)(1.0f) : power_weight(pdf_b / pdf_e);
            vint open = escapes(s, offset_ray_origin(sp.p, sp.err, sp.ng), we, sampled);
            *rays += MASK_TO_ONE(sampled);
            if (ANY(open)) {
                vec3 e = v3_mul(v3_mul(v3_mul(beta, sp.k), f), environment_radiance(s, we, open));
                e = v3_scale(e, w * cos_e * M_1_PI_F / pdf_e);
                radiance = v3_add(radiance, v3_select(v3_splat(0.0f, 0.0f, 0.0f), e, open));
            }
        }
    }
#endif

    /* the next direction by sampling the BSDF: f cos / p = k for the diffuse surfaces */
    vec2 u = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
    vec3 wi = cosine_direction(sp.n, u), weight = sp.k;
    vint transmit = (vint)(0);
#if HAS_SPECULAR
    vec3 wo = v3_scale(r.d, -1.0f);
    sample_specular(sp, wo, u.x, alive & specular, &wi, &weight, &transmit);
    alive &= !specular | (v3_dot(wo, sp.n) > 0.0f);
#endif
    vint rough = (vint)(0);
    vfloat rough_pdf = 0.0f;
#if HAS_ROUGH_CONDUCTORS
    rough = alive & (sp.bsdf == BSDF_ROUGHCONDUCTOR);
    if (ANY(rough)) { /* a visible normal h (microfacet.cl), wo reflected about it: f cos / p = k F G1(wi) */
        vec3 wo_ = v3_scale(r.d, -1.0f), t, b;
        orthonormal_frame(sp.n, &t, &b);
        vec3 lo = v3(v3_dot(wo_, t), v3_dot(wo_, b), v3_dot(wo_, sp.n));
        vec3 hl = ggx_sample_visible_normal(lo, sp.alpha, u);
        vec3 h = v3_add(v3_add(v3_scale(t, hl.x), v3_scale(b, hl.y)), v3_scale(sp.n, hl.z));
        vec3 wr = reflected(wo_, h);
        vfloat zero = 0.0f, g1 = ggx_g1(v3(zero, zero, lo.z), sp.alpha);
        vfloat g = ggx_reflection_weight(v3(zero, zero, lo.z), v3(zero, zero, v3_dot(sp.n, wr)), sp.alpha);
        vec3 f = v3_scale(v3_mul(sp.k, fresnel_conductor3(v3_dot(wo_, h), sp.eta, sp.k_imag)), g);
        rough_pdf = g1 * ggx_d(v3(zero, zero, hl.z), sp.alpha) / (4.0f * lo.z);
        wi = v3_select(wi, wr, rough);
        weight = v3_select(weight, f, rough);
        alive &= !rough | (lo.z > 0.0f);
    }
#endif
    vfloat cos_s = v3_dot(sp.n, wi), cos_g = v3_dot(sp.ng, wi);
    vfloat pdf = SELECT(cos_s * M_1_PI_F, rough_pdf, rough); /* the BSDF sample's density, for MIS */
    alive &= SELECT(cos_g > 0.0f, cos_g < 0.0f, transmit) & (specular | (cos_s > 0.0f));
    beta = v3_select(beta, v3_mul(beta, weight), alive);

    /* Russian roulette from vertex RR_DEPTH on, on the throughput onwards: here, after the vertex's light
     * samples and before its ray is traced, as in Mitsuba 3's `path` and pbrt-v4's PathIntegrator, so that a
     * path it ends keeps its vertex's sampled light (the estimate's low-variance part) and costs no ray */
    vec2 v = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
    vint roulette = alive & (path->depth >= RR_DEPTH);
    if (ANY(roulette)) {
        vfloat q = vmin(vmax(beta.x, vmax(beta.y, beta.z)), (vfloat)(RR_MAX_Q));
        alive &= !roulette | (v.x < q);
        beta = v3_select(beta, v3_scale(beta, 1.0f / vmax(q, (vfloat)(1e-30f))), roulette);
    }
    Ray next = {offset_ray_origin(sp.p, sp.err, v3_select(sp.ng, v3_scale(sp.ng, -1.0f), transmit)), wi};
    *rays += MASK_TO_ONE(alive);
    path->r = next;
    path->beta = beta;
    path->radiance = radiance;
    path->specular = specular;
    path->pdf = pdf;
#if HAS_ENVIRONMENT
    path->cos_s = cos_s;
#endif
#if LIGHT_SOLID_ANGLE
    path->p = sp.p;
#endif
    return alive;
}

/* Radiance along the camera ray r, whose first hit is `hit`, shaded at sp: one pixel sample's path in every
 * lane, vertex after vertex (render.cl's loop does the same, restarting each lane's path where it ends); *rays
 * counts the rays traced per lane after the camera ray. */
inline vec3 trace_path(const Scene *s, TextureStore ts, Ray r, Hit hit, ShadingPoint sp,
                       __global const uint2 *light_samples, PixelSample *ps, vfloat *rays)
{
    PathState path;
    start_paths(&path, r, (vint)(-1) != 0);
    vint alive = path_hit(s, &path, hit, (vint)(-1) != 0);
    while (ANY(alive)) {
        alive = path_vertex(s, ts, &path, sp, alive, light_samples, ps, rays);
        hit = closest_hit(s, path.r, (vfloat)(INFINITY));
        alive = path_hit(s, &path, hit, alive);
        sp = shading_point(s, ts, path.r, hit);
    }
    return path.radiance;
}

#endif
