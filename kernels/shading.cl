/* The course's Phong model, docs/model.md, shading:
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

/* A light sample counts where it lies above both the surface (ng: else the surface itself would block it) and
 * the shading normal (n: the lobes of a bumped surface); it weighs its Phong lobes, and the light 1 / N. */
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f);
}

inline vfloat sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                            vint active)
{
    return phong_lobes(sp.n, l, v, sp.shininess);
}

inline float light_scale(__global const Light *light) { return 1.0f; }

#include "light_sampling.cl"

/* Colour seen along r at its hit, shaded at sp; *rays counts the shadow rays traced per lane. */
inline vec3 shade(const Scene *s, Ray r, Hit hit, ShadingPoint sp, __global const uint2 *light_samples,
                  PixelSample *ps, vfloat *rays)
{
    vint surface = (hit.t < INFINITY) & (hit.material >= 0);
    vec3 direct = lights_sum(s, sp, v3_scale(r.d, -1.0f), surface, light_samples, ps, rays);
    vec3 colour = v3_mul(sp.k, v3_add(v3_uniform(s->params->ambient), direct));
    return v3_select(hit.emitted, colour, surface);
}

#endif
