/* Radiometric direct lighting, the second shading model (`shading = "direct"`; docs/model.md's "Direct
 * lighting"): Lambertian surfaces, f = albedo / pi, both sides reflecting (the hit's normals already face the
 * incoming ray, so a back-facing hit is shaded with its normal flipped, as Mitsuba's `twosided`), under
 * rectangular area lights of uniform radiance L_e that emit from their front face (the side the normal
 * points to). The lights are sampled by area, p_A = 1 / A (pbrt-v4 section 12.2.3), with the scene's light
 * sample pattern:
 *   L = f sum over lights (A / N) sum_j V_j L_e cos(theta_s) cos(theta_l) / r_j^2,
 * theta_s between the shading normal and the sample, theta_l between the light's normal and the way back, r
 * the distance. A sample below the surface or behind the light adds nothing and casts no shadow ray. There is
 * no ambient term.
 *
 * With M = render.bsdf_samples > 0 (HAS_BSDF_SAMPLING; Mitsuba's `direct` with its emitter_samples and
 * bsdf_samples), the BSDF is sampled too: M directions by the cosine about the normal (p_b = cos(theta_s) /
 * pi), each counting the light it reaches on a light or an emitting shape, f L_e cos(theta_s) / p_b = albedo
 * L_e. Each light's N samples form one technique and the M BSDF samples the other, combined by the power
 * heuristic weighted by the counts (Veach 1997, section 9.2.4; Mitsuba's direct.cpp):
 *   w_light = (N p_l)^2 / ((N p_l)^2 + (M p_b)^2),  w_bsdf = (M p_b)^2 / ((N p_l)^2 + (M p_b)^2),
 * p_l the density per solid angle of one of the light's samples towards the direction (r^2 / (A cos(theta_l))
 * for a light, light_selection.cl's hit_emitter_pdf for an emitting shape: its choice among the emitting shapes
 * included, as they share the N samples), each sample's value divided by its own
 * technique's count. The expectation is the light-only model's; where a large light is close, the BSDF's
 * samples take the weight that the light's (whose density grows with r^2 / cos(theta_l)) cannot carry.
 *
 * An environment (HAS_ENVIRONMENT: constant or envmap, as Mitsuba's direct integrator sees it) lights the
 * surfaces through directions sampled by the cosine (its own technique: a BSDF sample that leaves the scene
 * counts nothing), and is seen where a ray leaves the scene. */
#ifndef DIRECT_LIGHTING_CL
#define DIRECT_LIGHTING_CL

#include "vmath.h"
#include "material.cl"
#if HAS_BSDF_SAMPLING
#include "warp.cl"
#include "mis.cl"

/* The Lambertian model needs no view direction: shade hands lights_sum, as `v`, a vector whose length is the
 * BSDF sample count M, which the light samples' weights need and light_sampling.cl passes on untouched. */
inline vfloat bsdf_count(vec3 v) { return sqrt(v3_dot(v, v)); }
#endif

/* A light sample counts where it lies above the surface (ng and the shading normal n) and in front of the
 * light; it weighs cos(theta_s) cos(theta_l) / r^2, and the light A / pi over its N samples. */
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f) & (v3_dot(light_normal, l) < 0.0f);
}

inline vfloat sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                            vint active)
{
    vfloat g = v3_dot(sp.n, l) * -v3_dot(light_normal, l) / v3_dot(w, w);
#if HAS_BSDF_SAMPLING /* times w_light: x = M p_b / (N p_l) = M A g / (pi N) */
    g *= power_weight(g * (bsdf_count(v) * area * M_1_PI_F / (float)n));
#endif
    return g;
}

inline float light_scale(__global const Light *light)
{
    return 4.0f * light->shape.half_x * light->shape.half_y * M_1_PI_F;
}

/* An emitter's sample (emitters.cl), of density pdf per solid angle: cos(theta_s) / (pi pdf) (a delta light's
 * alike: pdf = r^2, or 1 for a directional one). */
inline vfloat emitter_weight(ShadingPoint sp, vec3 l, vec3 v, vfloat pdf, int n, vint active, vint delta)
{
    vfloat weight = v3_dot(sp.n, l) * M_1_PI_F / pdf;
#if HAS_BSDF_SAMPLING /* times w_light: x = M p_b / (N p_l), p_b = cos(theta_s) / pi; 1 for a delta light */
    weight *= SELECT(power_weight(weight * (bsdf_count(v) / (float)n)), (vfloat)(1.0f), delta);
#endif
    return weight;
}

#include "light_sampling.cl"
#if HAS_ENVIRONMENT
#include "environment.cl"
#include "warp.cl"

/* The environment's share of E / pi at sp (Mitsuba's direct integrator sees it too): n directions about the
 * shading normal by the cosine (p = cos / pi, so that each counts L, and E / pi = (1 / n) sum V L), a constant's
 * and a map's alike, from the light sampler's stream after the lights'; *rays counts the shadow rays. */
inline vec3 environment_sum(const Scene *s, ShadingPoint sp, vint surface, __global const uint2 *light_samples,
                            PixelSample *ps, vfloat *rays)
{
    const int n = s->params->light_samples;
    SampleStream stream = next_stream(ps, s->params->light_sampler, n);
    vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng), sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int j = 0; j < n && ANY(surface); ++j) {
        vec2 u = stream_2d(light_samples, s->params->light_sampler, stream, (vint)(j));
        vec3 we = cosine_direction(sp.n, u);
        vint sampled = surface & (v3_dot(sp.ng, we) > 0.0f) & (v3_dot(sp.n, we) > 0.0f);
        if (!ANY(sampled))
            continue;
        *rays += MASK_TO_ONE(sampled);
        vint open = escapes(s, origin, we, sampled PASSES(sp.passes));
        if (ANY(open))
            sum = v3_add(sum, v3_select(v3_splat(0.0f, 0.0f, 0.0f), environment_radiance(s, we, open), open));
    }
    return v3_scale(sum, 1.0f / n);
}
#endif

#if HAS_BSDF_SAMPLING
/* The BSDF's M samples' share of E / pi at sp, for the lanes of `surface`: (1 / M) sum_j L_e w_bsdf over the
 * directions drawn by the cosine that reach a light's or an emitting shape's front (hit.emitted; anything
 * else emits nothing), w_bsdf against that light's N samples: x = N p_l / (M p_b). The directions come from
 * their own stream, after the lights' (the light pattern's Sobol points, else independent ones: a table
 * pattern is sized for the lights' N); *rays counts their rays. */
inline vec3 bsdf_samples_sum(const Scene *s, ShadingPoint sp, vint surface, __global const uint2 *light_samples,
                             PixelSample *ps, vfloat *rays)
{
    const int m = s->params->bsdf_samples;
    const float n = (float)s->params->light_samples;
    Sampler sampler = s->params->light_sampler;
    if (sampler.randomize != RANDOMIZE_SOBOL)
        sampler.randomize = RANDOMIZE_INDEPENDENT;
    SampleStream stream = next_stream(ps, sampler, m);
    const vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int j = 0; j < m; ++j) {
        vec3 wi = cosine_direction(sp.n, stream_2d(light_samples, sampler, stream, (vint)(j)));
        vfloat cos_s = v3_dot(sp.n, wi);
        vint sampled = surface & (v3_dot(sp.ng, wi) > 0.0f) & (cos_s > 0.0f);
        if (!ANY(sampled))
            continue;
        *rays += MASK_TO_ONE(sampled);
        Ray ray = {origin, wi};
        Hit hit = closest_hit(s, ray, SELECT((vfloat)(-1.0f), (vfloat)(INFINITY), sampled));
        vfloat cos_l = vabs(v3_dot(hit.n, wi)), p_b = cos_s * M_1_PI_F;
        /* N p_l: a light's by area, r^2 / (A cos(theta_l)), as lights_sum samples it */
        vint on_light = sampled & (hit.t < INFINITY) & (hit.kind == SHAPE_NONE); /* (the others have no ray) */
        vfloat x = n * hit.t * hit.t / (hit_light_area(s, hit) * cos_l * p_b * (float)m);
        vint weighed = on_light;
#if HAS_SHAPE_EMITTERS /* an emitting shape's: emitters.cl's density of its samples */
        vint on_emitter = sampled & (hit.t < INFINITY) & (hit.emitter >= 0);
        if (ANY(on_emitter)) /* the emitter's choice included (light_selection.cl) */
            x = SELECT(x, n * hit_emitter_pdf(s, hit, sp.p, hit.t, cos_l, on_emitter) / (p_b * (float)m), on_emitter);
        weighed |= on_emitter;
#endif
        sum = v3_add(sum, v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_scale(hit.emitted, power_weight(x)), weighed));
    }
    return v3_scale(sum, 1.0f / (float)m);
}
#endif

/* Radiance along r from its hit, shaded at sp (albedo k times E / pi); *rays counts the shadow rays traced
 * per lane. */
inline vec3 shade(const Scene *s, Ray r, Hit hit, ShadingPoint sp, __global const uint2 *light_samples,
                  PixelSample *ps, vfloat *rays)
{
    vint surface = (hit.t < INFINITY) & (hit.material >= 0);
#if HAS_BSDF_SAMPLING
    vec3 v = v3_scale(r.d, -(float)s->params->bsdf_samples); /* its length M (bsdf_count) */
#else
    vec3 v = v3_scale(r.d, -1.0f);
#endif
    vec3 irradiance = lights_sum(s, sp, v, surface, light_samples, ps, rays);
#if HAS_BSDF_SAMPLING
    irradiance = v3_add(irradiance, bsdf_samples_sum(s, sp, surface, light_samples, ps, rays));
#endif
#if HAS_ENVIRONMENT /* and seen where the ray leaves the scene (but with hide_emitters, as Mitsuba's) */
    irradiance = v3_add(irradiance, environment_sum(s, sp, surface, light_samples, ps, rays));
    vint escaped = hit.t == INFINITY;
    if (!s->params->hide_emitters && ANY(escaped))
        return v3_select(v3_select(hit.emitted, v3_mul(sp.k, irradiance), surface),
                         environment_radiance(s, r.d, escaped), escaped);
#endif
    return v3_select(hit.emitted, v3_mul(sp.k, irradiance), surface);
}

#endif
