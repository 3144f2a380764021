/* Radiometric direct lighting, the second shading model (`shading = "direct"`; the README's "Direct
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

#include "lights.cl"
#include "material.cl"
#include "vmath.h"

/* cos(theta_s) cos(theta_l) / r^2 of one light sample q seen from the shading point, on the lanes where q
 * lies above the surface (ng and the shading normal n) and in front of the light; *lit says which. */
inline vfloat geometry_term(ShadingPoint sp, vec3 q, vec3 light_normal, vint *lit)
{
    vec3 w = v3_sub(q, sp.p);
    vfloat r2 = v3_dot(w, w);
    vec3 l = v3_direction(w);
    vfloat cos_s = v3_dot(sp.n, l), cos_l = -v3_dot(light_normal, l);
    *lit &= (v3_dot(sp.ng, l) > 0.0f) & (cos_s > 0.0f) & (cos_l > 0.0f);
    return cos_s * cos_l / r2;
}

/* Radiance along r from its hit, shaded at sp; *rays counts the shadow rays traced per lane. The light
 * samples come from the light sample pattern, randomised under `key` and the light's index, as in the Phong
 * model (shading.cl). */
inline vec3 shade(const Scene *s, Ray r, Hit hit, ShadingPoint sp, __global const uint2 *light_samples,
                  vuint key, vfloat *rays)
{
    vint surface = (hit.t < INFINITY) & (hit.material >= 0);
    vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng); /* every lit sample is on ng's side */
    vec3 irradiance = v3_splat(0.0f, 0.0f, 0.0f);         /* E / pi: the radiance reflected at albedo 1 */
    int n_samples = s->params->light_samples;
    for (int li = 0; li < s->params->n_lights && ANY(surface); ++li) {
        __global const Light *light = &s->lights[li];
        vuint light_key = stream_key(key, li);
        vec3 light_normal = v3_uniform(light->shape.normal);
        vfloat q_err = light_point_error(light);
        uint skip = rectangles_out_of_reach(s, light, origin, surface);
        vfloat sum = 0.0f;
        for (int j = 0; j < n_samples; ++j) {
            vec3 q = light_point(light, sample_2d(light_samples, j, s->params->light_sampler, light_key));
            vint lit = surface;
            vfloat g = geometry_term(sp, q, light_normal, &lit);
            if (!ANY(lit))
                continue;
            *rays += MASK_TO_ONE(lit);
            lit &= !occluded(s, shadow_segment(origin, q, q_err, light_normal), skip, lit);
            sum += SELECT((vfloat)(0.0f), g, lit);
        }
        float area_over_pi = 4.0f * light->shape.half_x * light->shape.half_y * M_1_PI_F;
        irradiance = v3_madd(irradiance, sum * (area_over_pi / n_samples), v3_uniform(light->colour));
    }
    return v3_select(hit.emitted, v3_mul(sp.k, irradiance), surface);
}

#endif
