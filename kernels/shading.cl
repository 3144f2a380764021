/* The course's Phong model, the README's model, shading:
 *   colour = ambient k + sum over lights (1/N) sum_s V_s (k L max(0, n.l_s) + k L max(0, r_s.v)^shininess)
 * with ka = kd = ks = k. Samples below the surface (n.l_s <= 0) add nothing and cast no shadow ray: on a
 * closed object such a ray would be blocked by the object itself, so this is the course's value too. */
#ifndef SHADING_CL
#define SHADING_CL

#include "lights.cl"
#include "material.cl"
#include "vmath.h"

/* x^n for x in [0, 1], as exp2(n log2 x) (vmath.h): the builtin pow costs more than all the rest of the
 * shading. */
inline vfloat phong_power(vfloat x, vfloat n) { return vexp2(n * vlog2(x)); }

/* Diffuse + specular factor of one light sample, without colours: max(0, n.l) + max(0, r.v)^shininess. */
inline vfloat phong_lobes(vec3 n, vec3 l, vec3 v, vfloat shininess)
{
    vfloat ndotl = v3_dot(n, l);
    vec3 r = v3_sub(v3_scale(n, 2.0f * ndotl), l);
    /* r.v can round above 1 at a highlight's centre: x^n is taken on [0, 1] */
    return vmax(ndotl, 0.0f) + phong_power(vmin(vmax(v3_dot(r, v), 0.0f), 1.0f), shininess);
}

/* Colour seen along r at its hit, shaded at sp; *rays counts the shadow rays traced per lane. The light
 * samples come from the light sample pattern, randomised under `key` and the light's index. A light
 * sample counts where it lies above both the surface (ng: else the surface itself would block it) and the
 * shading normal (n: the lobes of a bumped surface). */
inline vec3 shade(const Scene *s, Ray r, Hit hit, ShadingPoint sp, __global const uint2 *light_samples,
                  vuint key, vfloat *rays)
{
    vint surface = (hit.t < INFINITY) & (hit.material >= 0);
    vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng); /* every lit sample is on ng's side */
    vec3 v = v3_scale(r.d, -1.0f);
    vec3 direct = v3_splat(0.0f, 0.0f, 0.0f);
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
            vec3 l = v3_direction(v3_sub(q, sp.p));
            vint lit = surface & (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f);
            if (!ANY(lit))
                continue;
            *rays += MASK_TO_ONE(lit);
            lit &= !occluded(s, shadow_segment(origin, q, q_err, light_normal), skip, lit);
            sum += SELECT((vfloat)(0.0f), phong_lobes(sp.n, l, v, sp.shininess), lit);
        }
        direct = v3_madd(direct, sum * (1.0f / n_samples), v3_uniform(light->colour));
    }
    vec3 ambient = v3_uniform(s->params->ambient);
    vec3 colour = v3_mul(sp.k, v3_add(ambient, direct));
    return v3_select(hit.emitted, colour, surface);
}

#endif
