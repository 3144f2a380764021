/* Mitsuba 3's BSDF wrappers, resolved at each hit into the one material whose BSDF scatters there
 * (material.cl gathers that material's values):
 * - a side: a hit on the back of a surface (hit.backface: the side its normal points away from) takes the
 *   material's `back`: itself where it is two-sided (raytrace's materials, and Mitsuba's `twosided`), another
 *   material (Mitsuba's `twosided` of two BSDFs), or none, -1: Mitsuba's one-sided BSDFs are black from behind;
 * - a blend (BSDF_BLEND: `blendbsdf`, and `mask` as a blend of `null` and the masked material) takes its second
 *   material with probability weight (clamped to [0, 1], as Mitsuba clamps it), else its first.
 * Choosing one material per hit at random with the blend's probabilities is pbrt-v4's MixMaterial: the expected
 * BSDF is the blend (1 - w) f_1 + w f_2, so every estimator built on the chosen one (light samples, BSDF samples,
 * MIS between them) stays unbiased, and each material keeps its own sampling. Mitsuba's blendbsdf evaluates both
 * and samples one: the same expectation, with less noise where the two differ. The random number is a hash of
 * the hit point, the ray's direction and the node, as pbrt-v4's HashFloat(p, wo, ...): it spends no dimension
 * of the sample patterns, so scenes without blends keep their samples. */
#ifndef WRAPPERS_CL
#define WRAPPERS_CL

#include "samplers.cl"
#if HAS_LOOKUPS
#include "lookups.cl"
#endif

/* A number in [0, 1) from the bits of p, d and the node: samplers.cl's hash folded over each word, 24 bits of
 * the result. */
inline vfloat blend_number(vec3 p, vec3 d, vint node)
{
    vuint h = AS_VUINT(node) * 0x9e3779b9U;
    h = hash(h ^ AS_VUINT(p.x));
    h = hash(h ^ AS_VUINT(p.y));
    h = hash(h ^ AS_VUINT(p.z));
    h = hash(h ^ AS_VUINT(d.x));
    h = hash(h ^ AS_VUINT(d.y));
    h = hash(h ^ AS_VUINT(d.z));
    return fixed_to_unit(h);
}

#if HAS_LOOKUPS
/* The weights of the blends at m[] whose weight is textured (mapped[]), in w's other lanes w: their hits'
 * surface points found for those lanes alone, each blend's lookup once. */
inline vfloat mapped_weights(const Scene *s, TextureStore ts, Ray r, Hit hit, const int *m, const int *mapped,
                             vfloat w)
{
    TexturedHits h = textured_hits(s, hit, textured_surface(s, hit, mapped), r.d, hit.p, hit.n);
    vint node = VLOAD_INT(m), on = VLOAD_INT(mapped) != 0;
    for (int i = 0; i < LANES; ++i) {
        int first = mapped[i]; /* each blend once, at its first lane */
        for (int j = 0; j < i; ++j)
            first &= !(mapped[j] && m[j] == m[i]);
        if (first) {
            vfloat v = lookup_at(s, ts, s->materials[m[i]].maps[MAP_WEIGHT], &h, s->params->texture_filter).x;
            w = SELECT(w, v, on & (node == m[i]));
        }
    }
    return w;
}
#endif

/* The material each lane's hit scatters by: hit.material through its wrappers (sides and blends), -1 where a
 * one-sided material is seen from behind (black) or nothing was hit. The host bounds the nesting below
 * WRAPPER_DEPTH and gives a material's back side a back of its own (raytrace/renderer/packing.py). */
inline vint wrapped_materials(const Scene *s, TextureStore ts, Ray r, Hit hit)
{
    int m[LANES], back[LANES], mapped[LANES];
    float weight[LANES];
    VSTORE(hit.material, m);
    VSTORE(hit.backface, back);
    for (int depth = 0; depth < WRAPPER_DEPTH; ++depth) {
        int blends = 0, any_mapped = 0;
        for (int i = 0; i < LANES; ++i) {
            if (m[i] >= 0 && back[i])
                m[i] = s->materials[m[i]].back;
            mapped[i] = 0;
            weight[i] = 0.0f;
            if (m[i] < 0 || s->materials[m[i]].bsdf != BSDF_BLEND)
                continue;
            blends = 1;
            weight[i] = s->materials[m[i]].weight;
#if HAS_LOOKUPS
            mapped[i] = s->materials[m[i]].maps[MAP_WEIGHT] >= 0;
            any_mapped |= mapped[i];
#endif
        }
        if (!blends)
            break;
        vfloat w = VLOAD(weight);
#if HAS_LOOKUPS
        if (any_mapped)
            w = mapped_weights(s, ts, r, hit, m, mapped, w);
#endif
        int second[LANES];
        VSTORE(blend_number(hit.p, r.d, VLOAD_INT(m)) < vmin(vmax(w, 0.0f), 1.0f), second);
        for (int i = 0; i < LANES; ++i)
            if (m[i] >= 0 && s->materials[m[i]].bsdf == BSDF_BLEND)
                m[i] = s->materials[m[i]].blend[second[i] != 0];
    }
    return VLOAD_INT(m);
}

#endif
