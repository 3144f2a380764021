/* Radiometric direct lighting, the second shading model (`shading = "direct"`; docs/model.md's "Direct
 * lighting"): Lambertian surfaces, f = albedo / pi, both sides reflecting (the hit's normals already face the
 * incoming ray, so a back-facing hit is shaded with its normal flipped, as Mitsuba's `twosided`), under
 * rectangular area lights of uniform radiance L_e that emit from their front face (the side the normal
 * points to). The lights are sampled by area, p_A = 1 / A (pbrt-v4 section 12.2.3), with the scene's light
 * sample pattern:
 *   L = f sum over lights (A / N) sum_j V_j L_e cos(theta_s) cos(theta_l) / r_j^2,
 * theta_s between the shading normal and the sample, theta_l between the light's normal and the way back, r
 * the distance. A sample below the surface or behind the light adds nothing and casts no shadow ray. There is
 * no ambient term. */
#ifndef DIRECT_LIGHTING_CL
#define DIRECT_LIGHTING_CL

#include "vmath.h"
#include "material.cl"

/* A light sample counts where it lies above the surface (ng and the shading normal n) and in front of the
 * light; it weighs cos(theta_s) cos(theta_l) / r^2, and the light A / pi over its N samples. */
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f) & (v3_dot(light_normal, l) < 0.0f);
}

inline vfloat sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                            vint active)
{
    return v3_dot(sp.n, l) * -v3_dot(light_normal, l) / v3_dot(w, w);
}

inline float light_scale(__global const Light *light)
{
    return 4.0f * light->shape.half_x * light->shape.half_y * M_1_PI_F;
}

/* An emitting shape's sample (emitters.cl), of density pdf per solid angle: cos(theta_s) / (pi pdf). */
inline vfloat emitter_weight(ShadingPoint sp, vec3 l, vec3 v, vfloat pdf, int n, vint active)
{
    return v3_dot(sp.n, l) * M_1_PI_F / pdf;
}

#include "light_sampling.cl"

/* Radiance along r from its hit, shaded at sp (albedo k times E / pi); *rays counts the shadow rays traced
 * per lane. */
inline vec3 shade(const Scene *s, Ray r, Hit hit, ShadingPoint sp, __global const uint2 *light_samples,
                  PixelSample *ps, vfloat *rays)
{
    vint surface = (hit.t < INFINITY) & (hit.material >= 0);
    vec3 irradiance = lights_sum(s, sp, v3_scale(r.d, -1.0f), surface, light_samples, ps, rays);
    return v3_select(hit.emitted, v3_mul(sp.k, irradiance), surface);
}

#endif
