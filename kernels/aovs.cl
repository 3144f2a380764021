/* Arbitrary output variables (Mitsuba 3's `aov` integrator, src/integrators/aov.cpp): what the camera ray of
 * each pixel sample meets first, summed per pixel beside the beauty and averaged by the host like it. HAS_AOVS
 * (set by raytrace/renderer/program.py from the render's `aov` option or the scene's `aovs`) is the bitmask of
 * the types below that the render stores; 0 compiles none of this (render.cl). Each type's value at a hit, as
 * aov.cpp defines it, and 0 in every plane where the ray meets nothing (its zeroed interaction):
 *   albedo      the BSDF's diffuse reflectance (aov_albedo: Mitsuba's eval_diffuse_reflectance, per BSDF)
 *   sh_normal   the shading normal (after normal, bump and height maps; smooth meshes' interpolated normal),
 *               world space, as the shape orients it: not turned towards the viewer (Mitsuba's sh_frame.n)
 *   geo_normal  the shape's own geometric normal, not turned either (Mitsuba's si.n)
 *   depth       the distance along the unit-length camera ray from its origin, on the near clip plane
 *               (camera.cl, as Mitsuba's sensors start it), to the hit: Mitsuba's si.t
 *   position    the world-space hit point
 *   uv          the surface's texture coordinates there (surface.cl; a mesh without uvs: barycentrics)
 *   shape_index 1 + the shape's place in the scene's order (raytrace/aovs.py's SHAPE_ORDER), as a float; a
 *               pixel's mean over samples on two shapes lies between their numbers (Mitsuba's does too)
 * The first hit is the camera ray's after hide_emitters' pass_emitters: the surface the beauty shows, where
 * Mitsuba's aov (which knows nothing of its nested integrator's hide_emitters) would show the emitter. Planes
 * follow the types' order below, each type's components in order. */
#ifndef AOVS_CL
#define AOVS_CL

#include "material.cl"
#if HAS_PATH_TRACING
#include "bsdf.cl"
#endif
#if HAS_AOVS & AOV_UV
#include "surface.cl"
#endif

/* AOV_* bits and AOV_PLANES: types.h (the host reads them from there too). */

/* The diffuse reflectance of the lanes' shading points seen along d: Mitsuba's eval_diffuse_reflectance.
 * - Phong and direct models, diffuse: the material's colour at the hit (textured), Mitsuba's diffuse's
 *   reflectance;
 * - plastic, roughplastic: the base's diffuse_reflectance (sp.k), as Mitsuba's overrides return;
 * - principled, principledthin: base_color (sp.k), as Mitsuba's overrides return;
 * - conductor, dielectric, thindielectric, null: 0, Mitsuba's default pi f(wi, n) cos, which a delta BSDF's
 *   eval makes 0;
 * - roughconductor, roughdielectric: that default, pi f(-d, n) towards the shading normal (on the viewer's
 *   side: Mitsuba's +z, which differs only for a rough dielectric seen from inside);
 * - wrappers: the material they resolve to at this sample (wrappers.cl), so a blend's average over a pixel's
 *   samples is Mitsuba's weighted sum; a mask's is the masked material's times its opacity (Mitsuba's ignores
 *   the opacity); a one-sided material seen from behind is 0 (Mitsuba's diffuse gives its reflectance);
 * - no material (a light without one, an emitter that does not reflect, nothing hit): 0. */
inline vec3 aov_albedo(ShadingPoint sp, vec3 d)
{
    vec3 a = sp.k;
#if HAS_BSDF_PARAMETERS
    vint zero = (sp.bsdf == BSDF_CONDUCTOR) | (sp.bsdf == BSDF_DIELECTRIC) | (sp.bsdf == BSDF_THINDIELECTRIC)
              | (sp.bsdf == BSDF_NULL);
#if HAS_ROUGH_CONDUCTORS || HAS_ROUGH_DIELECTRICS
    vint rough = (sp.bsdf == BSDF_ROUGHCONDUCTOR) | (sp.bsdf == BSDF_ROUGHDIELECTRIC);
    if (ANY(rough)) {
        vfloat pdf;
        vec3 f = lobes_eval_pdf(sp, v3_scale(d, -1.0f), sp.n, rough, &pdf);
        a = v3_select(a, v3_scale(f, M_PI_F), rough);
    }
#endif
    a = v3_select(a, v3_splat(0.0f, 0.0f, 0.0f), zero);
#endif
    return a;
}

#if HAS_AOVS & AOV_UV
/* The texture coordinates of the lanes' hits (`on`), one lane at a time: a shape's (material.cl's
 * surface_point, a group's triangle as its own), a rectangular light's as a rectangle's. */
inline vec2 aov_uv(const Scene *s, Hit hit, vint on)
{
    int kind[LANES], index[LANES], hit_on[LANES];
    float b1[LANES], b2[LANES], u[LANES], v[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(hit.b1, b1);
    VSTORE(hit.b2, b2);
    VSTORE(on, hit_on);
    Lanes3 p = v3_spill(hit.p);
    for (int i = 0; i < LANES; ++i) {
        float2 uv = (float2)(0.0f);
        if (hit_on[i])
            uv = kind[i] == SHAPE_NONE ? surface_rectangle(&s->lights[index[i]].shape, lane3(&p, i)).uv
                                       : surface_point(s, kind[i], index[i], lane3(&p, i), b1[i], b2[i]).uv;
        u[i] = uv.x;
        v[i] = uv.y;
    }
    vec2 uv = {VLOAD(u), VLOAD(v)};
    return uv;
}
#endif

#if HAS_AOVS & AOV_SHAPE_INDEX
/* The shape_index of the lanes' hits (`on`), one lane at a time, from the host's table of every primitive's
 * number (raytrace/renderer/packing.py's shape_index_table): the rectangles', ellipsoids', disks',
 * cylinders', lights' (SHAPE_NONE) and instances' in that order, then the triangles' in the Triangle table's
 * order. A hit in an instance's group is the instance's. */
inline vfloat aov_shape_index(const Scene *s, Hit hit, vint on)
{
    int kind[LANES], index[LANES], hit_on[LANES];
    float number[LANES];
    VSTORE(hit.kind, kind);
    VSTORE(hit.index, index);
    VSTORE(on, hit_on);
#if HAS_INSTANCES
    int instance[LANES];
    VSTORE(hit.instance, instance);
#endif
    __constant const RenderParams *p = s->params;
    const int ellipsoids = p->n_rectangles, disks = ellipsoids + p->n_ellipsoids, cylinders = disks + p->n_disks;
    const int lights = cylinders + p->n_cylinders, instances = lights + p->n_lights;
    const int triangles = instances + p->n_instances;
    for (int i = 0; i < LANES; ++i) {
        int k = kind[i], at = index[i];
        at += k == SHAPE_RECTANGLE ? 0 : k == SHAPE_ELLIPSOID ? ellipsoids : k == SHAPE_DISK ? disks
            : k == SHAPE_CYLINDER ? cylinders : k == SHAPE_TRIANGLE ? triangles : lights;
#if HAS_INSTANCES
        if (instance[i] >= 0)
            at = instances + instance[i];
#endif
        number[i] = hit_on[i] ? (float)s->shape_indices[at] : 0.0f;
    }
    return VLOAD(number);
}
#endif

/* value[*k ...] = v's components, *k past them. */
inline void put_vec3(vfloat *value, int *k, vec3 v)
{
    value[(*k)++] = v.x;
    value[(*k)++] = v.y;
    value[(*k)++] = v.z;
}

/* The AOV_PLANES values of the lanes' camera rays: r the ray that met `hit` (its origin past the emitters it
 * passed), o the camera ray's own origin, sp the hit's shading point. */
inline void aov_values(const Scene *s, Ray r, vec3 o, Hit hit, ShadingPoint sp, vfloat *value)
{
    const vint on = hit.t < INFINITY;
    const vec3 zero = v3_splat(0.0f, 0.0f, 0.0f);
    int k = 0;
#if HAS_AOVS & (AOV_SH_NORMAL | AOV_GEO_NORMAL)
    /* hit.n and sp.n face the viewer; the shape's own side is the other where the ray met its back */
    const vfloat side = SELECT(SELECT((vfloat)(1.0f), (vfloat)(-1.0f), hit.backface != 0), (vfloat)(0.0f), !on);
#endif
#if HAS_AOVS & AOV_ALBEDO
    vec3 albedo = v3_select(zero, aov_albedo(sp, r.d), on);
    put_vec3(value, &k, albedo);
#endif
#if HAS_AOVS & AOV_SH_NORMAL
    vec3 n = v3_scale(sp.n, side);
    put_vec3(value, &k, n);
#endif
#if HAS_AOVS & AOV_GEO_NORMAL
    vec3 ng = v3_scale(hit.n, side);
    put_vec3(value, &k, ng);
#endif
#if HAS_AOVS & AOV_DEPTH
    /* hit.t runs from r's origin; a ray that passed emitters left from beyond them along the same direction; a
     * near plane the loader dropped (it cuts nothing) is still where the depth starts: depth_from / cos */
    const float depth_from = s->camera->depth_from;
    vfloat depth = hit.t + v3_dot(v3_sub(r.o, o), r.d);
    if (depth_from > 0.0f)
        depth -= depth_from / v3_dot(r.d, v3_uniform(s->camera->forward));
    value[k++] = SELECT((vfloat)(0.0f), depth, on);
#endif
#if HAS_AOVS & AOV_POSITION
    vec3 p = v3_select(zero, hit.p, on);
    put_vec3(value, &k, p);
#endif
#if HAS_AOVS & AOV_UV
    vec2 uv = aov_uv(s, hit, on);
    value[k++] = uv.x;
    value[k++] = uv.y;
#endif
#if HAS_AOVS & AOV_SHAPE_INDEX
    value[k++] = aov_shape_index(s, hit, on);
#endif
}

#endif
