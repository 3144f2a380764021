/* Choosing the emitter a light sample samples (render.light_selection): among the Emitter table's entries (the
 * emitting shapes and the delta lights, kernels/emitters.cl) one per sample and lane, with the probabilities the
 * host set (raytrace/renderer/packing.py's selection: in proportion to power, pbrt-v4 section 12.6.2's
 * PowerLightSampler, or uniform, Mitsuba 3's default), so that a scene of many emitters costs a light sample
 * per sample, not one per emitter. The rectangular lights (lights.cl) are not chosen among: each takes its own
 * samples (light_sampling.cl). */
#ifndef LIGHT_SELECTION_CL
#define LIGHT_SELECTION_CL

#include "emitters.cl"

/* The emitting shape that cannot block the segments to its own sampled points: a sphere (its point is on the
 * side of it the origin sees), a cylinder whose front faces out, a plane (primitive.cl's OWN); -1 for a mesh or
 * a cylinder whose front faces in, and for a delta light, which is no shape. */
inline int own_shape(const Scene *s, __global const Emitter *e)
{
    return e->kind == SHAPE_TRIANGLE || EMITTER_IS_DELTA(e->kind)
                   || (e->kind == SHAPE_CYLINDER && s->cylinders[e->index].normal_sign < 0.0f)
         ? -1 : SHAPE_REFERENCE(e->kind, e->index);
}

/* Each lane's emitter for a light sample, chosen by u->x with the selection's probabilities (types.h's
 * Emitter.selection_cdf: by power or uniformly): the first whose cumulative probability exceeds u->x (a binary
 * search), and u->x rescaled within that emitter's share, so that the emitter's own sampling gets a uniform
 * number again (sample_mesh's choice of a triangle, one level up). One emitter takes u as it is. */
inline vint choose_emitters(const Scene *s, vfloat *ux, vint active)
{
    float x[LANES];
    int use[LANES], chosen[LANES];
    VSTORE(*ux, x);
    VSTORE(active, use);
    const int n = s->params->n_emitters;
    for (int i = 0; i < LANES; ++i) {
        int lo = 0, hi = n - 1;
        while (use[i] && lo < hi) {
            int mid = (lo + hi) / 2;
            if (s->emitters[mid].selection_cdf > x[i])
                hi = mid;
            else
                lo = mid + 1;
        }
        chosen[i] = lo;
        float below = lo > 0 ? s->emitters[lo - 1].selection_cdf : 0.0f;
        float width = s->emitters[lo].selection_cdf - below; /* one emitter: 1, and x / 1 is x */
        x[i] = width > 0.0f ? fmin((x[i] - below) / width, 0x1.fffffep-1f) : 0.0f;
    }
    *ux = VLOAD(x);
    return VLOAD_INT(chosen);
}

/* The lanes' samples of the emitters they chose (choose_emitters), from ref with u, for the lanes of `active`:
 * each emitter the lanes chose sampled once, for the lanes that chose it (at most LANES emitters, however many
 * the scene has), its density times the probability of its choice; *own gets each lane's own_shape. */
inline EmitterSample sample_chosen(const Scene *s, vint chosen, vec3 ref, vec2 u, vint active, vint *own)
{
    EmitterSample es;
    es.p = es.n = es.radiance = v3_splat(0.0f, 0.0f, 0.0f);
    es.err = es.pdf = 0.0f;
    es.delta = (vint)(0);
    *own = -1;
    vint left = active;
    while (ANY(left)) {
        int index[LANES], use[LANES], first = 0;
        VSTORE(chosen, index);
        VSTORE(left, use);
        while (!use[first])
            ++first;
        const int ei = index[first];
        __global const Emitter *e = &s->emitters[ei];
        const vint here = left & (chosen == ei);
        EmitterSample one = sample_emitter(s, e, ref, u, here);
        es.p = v3_select(es.p, one.p, here);
        es.n = v3_select(es.n, one.n, here);
        es.radiance = v3_select(es.radiance, one.radiance, here);
        es.err = SELECT(es.err, one.err, here);
        es.pdf = SELECT(es.pdf, one.pdf * e->selection_pdf, here);
        es.delta = SELECT(es.delta, one.delta, here);
        *own = SELECT(*own, (vint)(own_shape(s, e)), here);
        left &= !here;
    }
    return es;
}

#if HAS_SHAPE_EMITTERS
/* The density per solid angle with which the light sampling at `ref` would have chosen each lane's hit on an
 * emitting shape (emitters.cl), met at `distance` from ref with |cos(theta_l)| = cos_l, the emitter's choice
 * (choose_emitters) included; 0 elsewhere. Each emitter the lanes hit is visited once. */
inline vfloat hit_emitter_pdf(const Scene *s, Hit hit, vec3 ref, vfloat distance, vfloat cos_l, vint lanes)
{
    vfloat pdf = 0.0f;
    vint left = lanes;
    while (ANY(left)) {
        int index[LANES], use[LANES], first = 0;
        VSTORE(hit.emitter, index);
        VSTORE(left, use);
        while (!use[first])
            ++first;
        __global const Emitter *e = &s->emitters[index[first]];
        const vint here = left & (hit.emitter == index[first]);
        pdf = SELECT(pdf, e->selection_pdf * emitter_pdf(s, e, ref, hit.p, distance, cos_l), here);
        left &= !here;
    }
    return pdf;
}
#endif

#endif
