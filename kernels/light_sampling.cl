/* The light sampling both shading models share (shading.cl, direct_lighting.cl): for every light, its samples
 * from the light sample pattern (randomised under the pixel's key and the light's index), the ones that count
 * (sample_counts), their shadow segments (tested among what the packet's segments towards the light can meet:
 * intersect.cl's shadow_candidates, once per light), and the weights (sample_weight) of those nothing blocks,
 * summed and scaled (light_scale) by the light's colour. The including model defines those three before
 * including this file; a sample that does not count casts no shadow ray. */
#ifndef LIGHT_SAMPLING_CL
#define LIGHT_SAMPLING_CL

#include "lights.cl"
#include "material.cl"

/* sum over lights of colour (light_scale / N) sum_j V_j sample_weight_j, for the lanes of `surface`, seen
 * along -v; *rays counts the shadow rays traced per lane. The models see each sample as w = q - p and its unit
 * direction l, formed once here. */
inline vec3 lights_sum(const Scene *s, ShadingPoint sp, vec3 v, vint surface, __global const uint2 *light_samples,
                       vuint key, vfloat *rays)
{
    vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng); /* every sample that counts is on ng's side */
    vec3 total = v3_splat(0.0f, 0.0f, 0.0f);
    int n_samples = s->params->light_samples;
    for (int li = 0; li < s->params->n_lights && ANY(surface); ++li) {
        __global const Light *light = &s->lights[li];
        vuint light_key = stream_key(key, (vuint)(li));
        vec3 light_normal = v3_uniform(light->shape.normal);
        vfloat q_err = light_point_error(light);
        uint skip = rectangles_out_of_reach(s, light, origin, surface);
        SweptLeaves candidates = {0};
        int swept = 0; /* found at the first sample that counts: a packet facing away needs none */
        vfloat sum = 0.0f;
        for (int j = 0; j < n_samples; ++j) {
            vec3 q = light_point(light, sample_2d(light_samples, (vint)(j), s->params->light_sampler, light_key));
            vec3 w = v3_sub(q, sp.p), l = v3_direction(w); /* towards the sample, and its unit direction */
            vint lit = surface & sample_counts(sp, l, light_normal);
            if (!ANY(lit))
                continue;
            if (!swept) {
                candidates = shadow_candidates(s, light, FIRST_LANE(q_err), origin, surface, skip, n_samples);
                swept = 1;
            }
            *rays += MASK_TO_ONE(lit);
            if (candidates.n != 0) /* else nothing can block the light */
                lit &= !occluded_among(s, &candidates, shadow_segment(origin, q, q_err, light_normal), skip, lit);
            sum += SELECT((vfloat)(0.0f), sample_weight(sp, w, l, light_normal, v), lit);
        }
        total = v3_madd(total, sum * (light_scale(light) / n_samples), v3_uniform(light->colour));
    }
    return total;
}

#endif
