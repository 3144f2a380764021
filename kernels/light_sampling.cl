/* The light sampling every shading model shares (shading.cl, direct_lighting.cl, path_tracing.cl): for every
 * light, its samples
 * from the light sample pattern (randomised under the pixel's key and the light's index), the ones that count
 * (sample_counts), their shadow segments (tested among what the packet's segments towards the light can meet:
 * intersect.cl's shadow_candidates, once per light), and the weights (sample_weight) of those nothing blocks,
 * summed and scaled (light_scale) by the light's colour. The including model defines those three before
 * including this file (sample_weight also gets the light's area and its sample count, which the path model's
 * MIS weights need); a sample that does not count casts no shadow ray. */
#ifndef LIGHT_SAMPLING_CL
#define LIGHT_SAMPLING_CL

#include "lights.cl"
#include "material.cl"
#if HAS_EMITTERS
#include "light_selection.cl"
#endif
#if LIGHT_SOLID_ANGLE
#include "spherical_rectangle.cl"
/* The model samples a light by the solid angle it subtends where that is accurate (spherical_rectangle.cl),
 * and its sample_weight takes that solid angle (0 where the light is sampled by area). */
#define SOLID_ANGLE_ARGUMENT , solid_angle
#else
#define SOLID_ANGLE_ARGUMENT
#endif

#if HAS_SURFACE_DATA
/* The area of the rectangular light each lane's hit is on (HAS_SURFACE_DATA: kind SHAPE_NONE and the light's
 * index, for a hit; a miss has kind SHAPE_NONE too), 0 elsewhere: the direct and path models' BSDF samples weigh
 * light they reach by it. */
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
#endif

/* How many light samples lights_sum forms at once: their points, directions and masks (sample_counts) are
 * independent work that the CPU overlaps, before their shadow rays are traced and their weights added in
 * order. Against one sample at a time, this saves time on scene 0, mesh_cornell, textured_cornell and
 * grid_floor, leaves the bench --scaling tori unchanged (most of their time in traversal) and costs a little
 * with 1 light sample; the same bits. A group of 2 was slower than 4 (measured in commit 9fec4db). */
#define LIGHT_SAMPLE_GROUP 4

#if HAS_EMITTERS
/* The emitters' share of lights_sum (emitters.cl): n samples from one stream, after the rectangular lights'
 * streams, each of an emitter chosen per lane (choose_emitters), weighted by the model's emitter_weight (the
 * sample's value over its density per solid angle, pdf, the choice's probability included; a delta light's,
 * which no BSDF sample meets, whole) and by the radiance it brings, from the origin `origin` off the surface. */
inline vec3 emitters_sum(const Scene *s, ShadingPoint sp, vec3 v, vint surface, vec3 origin,
                         __global const uint2 *light_samples, PixelSample *ps, vfloat *rays)
{
    vec3 total = v3_splat(0.0f, 0.0f, 0.0f);
    const int n_samples = s->params->light_samples;
    SampleStream stream = next_stream(ps, s->params->light_sampler, n_samples);
    for (int j = 0; j < n_samples && ANY(surface); ++j) {
        vec2 u = stream_2d(light_samples, s->params->light_sampler, stream, (vint)(j));
        vint own, chosen = choose_emitters(s, &u.x, surface);
        EmitterSample es = sample_chosen(s, chosen, sp.p, u, surface, &own);
        vec3 l = v3_direction(v3_sub(es.p, sp.p));
        vint lit = surface & (es.pdf > 0.0f) & sample_counts(sp, l, es.n);
        if (!ANY(lit))
            continue;
        *rays += MASK_TO_ONE(lit);
        lit &= !occluded(s, shadow_segment(origin, es.p, es.err, es.n), 0u, lit PASSES(sp.passes) OWN(own));
#if LIGHT_VALUE_VEC3
        vec3 weight = emitter_weight(sp, l, v, es.pdf, n_samples, lit, es.delta);
#else
        vfloat w = emitter_weight(sp, l, v, es.pdf, n_samples, lit, es.delta);
        vec3 weight = v3(w, w, w);
#endif
        total = v3_add(total, v3_select(v3_splat(0.0f, 0.0f, 0.0f), v3_mul(weight, es.radiance), lit));
    }
    return v3_scale(total, 1.0f / n_samples);
}
#endif

/* sum over lights of colour (light_scale / N) sum_j V_j sample_weight_j, for the lanes of `surface`, seen
 * along -v; *rays counts the shadow rays traced per lane. The models see each sample as w = q - p and its unit
 * direction l, formed once here. */
inline vec3 lights_sum(const Scene *s, ShadingPoint sp, vec3 v, vint surface, __global const uint2 *light_samples,
                       PixelSample *ps, vfloat *rays)
{
    vec3 origin = offset_ray_origin(sp.p, sp.err, sp.ng); /* every sample that counts is on ng's side */
    vec3 total = v3_splat(0.0f, 0.0f, 0.0f);
    int n_samples = s->params->light_samples;
    const vint dimension = ps->dimension; /* light l's pair is dimension + l, whether or not it is drawn */
    for (int li = 0; li < s->params->n_lights && ANY(surface); ++li) {
        __global const Light *light = &s->lights[li];
        SampleStream stream = next_stream(ps, s->params->light_sampler, n_samples);
        vec3 light_normal = v3_uniform(light->shape.normal);
        vfloat q_err = light_point_error(light);
        float area = 4.0f * light->shape.half_x * light->shape.half_y;
        uint skip = rectangles_out_of_reach(s, light, origin, surface);
#if LIGHT_SOLID_ANGLE
        SphericalRectangle spherical = spherical_rectangle(&light->shape, sp.p);
        vint by_solid_angle = spherical_rectangle_used(spherical);
        vfloat solid_angle = SELECT((vfloat)(0.0f), spherical.solid_angle, by_solid_angle);
#endif
        SweptLeaves candidates = {0};
        int swept = 0; /* found at the first sample that counts: a packet facing away needs none */
#if LIGHT_VALUE_VEC3 /* the model's sample weights are colours (path_tracing.cl's BSDF values) */
        vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
#else
        vfloat sum = 0.0f;
#endif
        for (int j0 = 0; j0 < n_samples; j0 += LIGHT_SAMPLE_GROUP) {
            vec3 q[LIGHT_SAMPLE_GROUP], w[LIGHT_SAMPLE_GROUP], l[LIGHT_SAMPLE_GROUP];
            vint lit[LIGHT_SAMPLE_GROUP] = {0}, any_lit = (vint)(0); /* samples past the last count nowhere */
            for (int g = 0; g < LIGHT_SAMPLE_GROUP && j0 + g < n_samples; ++g) {
                vec2 u = stream_2d(light_samples, s->params->light_sampler, stream, (vint)(j0 + g));
#if LIGHT_SOLID_ANGLE
                if (ANY(by_solid_angle)) { /* the point of the light u maps to by solid angle */
                    vec2 st = spherical_rectangle_point(spherical, u);
                    u.x = SELECT(u.x, st.x, by_solid_angle);
                    u.y = SELECT(u.y, st.y, by_solid_angle);
                }
#endif
                q[g] = light_point(light, u);
                w[g] = v3_sub(q[g], sp.p); /* towards the sample, and its unit direction */
                l[g] = v3_direction(w[g]);
                lit[g] = surface & sample_counts(sp, l[g], light_normal);
                any_lit |= lit[g];
            }
            if (!ANY(any_lit))
                continue;
            if (!swept) {
                candidates = shadow_candidates(s, light, FIRST_LANE(q_err), origin, surface, skip, n_samples);
                swept = 1;
            }
            for (int g = 0; g < LIGHT_SAMPLE_GROUP; ++g) {
                if (!ANY(lit[g]))
                    continue;
                *rays += MASK_TO_ONE(lit[g]);
                if (candidates.n != 0) /* else nothing can block the light */
                    lit[g] &= !occluded_among(s, &candidates, shadow_segment(origin, q[g], q_err, light_normal), skip,
                                              lit[g] PASSES(sp.passes));
#if LIGHT_VALUE_VEC3
                vec3 weight = sample_weight(sp, w[g], l[g], light_normal, v, area, n_samples,
                                            lit[g] SOLID_ANGLE_ARGUMENT);
                sum = v3_add(sum, v3_select(v3_splat(0.0f, 0.0f, 0.0f), weight, lit[g]));
#else
                vfloat weight = sample_weight(sp, w[g], l[g], light_normal, v, area, n_samples,
                                              lit[g] SOLID_ANGLE_ARGUMENT);
                sum += SELECT((vfloat)(0.0f), weight, lit[g]);
#endif
            }
        }
#if LIGHT_VALUE_VEC3
        total = v3_add(total, v3_mul(v3_scale(sum, light_scale(light) / n_samples), v3_uniform(light->colour)));
#else
        total = v3_madd(total, sum * (light_scale(light) / n_samples), v3_uniform(light->colour));
#endif
    }
#if HAS_EMITTERS
    total = v3_add(total, emitters_sum(s, sp, v, surface, origin, light_samples, ps, rays));
#endif
    ps->dimension = dimension + s->params->n_lights + (s->params->n_emitters > 0); /* the emitters' one stream */
    return total;
}

#endif
