/* Closest hit over every shape and light, and the any-hit test of shadow rays: over a BVH (bvh.cl) when the
 * host built one, else a loop over every shape. Either way each primitive goes through primitive.cl's one
 * dispatch on its kind, tested by all lanes at once. With a BVH, a packet's shadow rays towards one light
 * test only the leaves their sweep meets (shadow_sweep.cl) when it meets few. */
#ifndef INTERSECT_CL
#define INTERSECT_CL

#include "primitive.cl"
#if HAS_BVH
#include "shadow_sweep.cl"
#else
typedef struct { int n; } SweptLeaves; /* without a BVH: every shape (n = -1) */
#endif

#if HAS_SHAPE_EMITTERS
/* The lanes whose hit is on an emitting shape (its material's emitter, types.h): the radiance it emits towards
 * the ray from its front side (the back is black), and the emitter, which the path model's MIS weight needs;
 * where the emitter has no BSDF the hit gets no material, and ends a path as a light does. */
inline void hit_emission(const Scene *s, Hit *hit)
{
    int material[LANES], back[LANES], emitter[LANES];
    Lanes3 emitted = v3_spill(hit->emitted);
    VSTORE(hit->material, material);
    VSTORE(hit->backface, back);
    for (int i = 0; i < LANES; ++i) {
        emitter[i] = material[i] >= 0 ? s->materials[material[i]].emitter : -1;
        if (emitter[i] < 0)
            continue;
        __global const Emitter *e = &s->emitters[emitter[i]];
        set_lane3(&emitted, i, back[i] ? (float3)(0.0f) : f3(e->radiance));
        if (!e->reflects)
            material[i] = -1;
    }
    hit->emitted = v3_fill(&emitted);
    hit->material = VLOADT(vint, material);
    hit->emitter = VLOADT(vint, emitter);
}
#endif

#if !HAS_BVH
/* The last kind the loop over every shape tests: the kinds a variant leaves out have no shapes. */
#if HAS_CYLINDERS
#define LAST_SHAPE SHAPE_CYLINDER
#elif HAS_DISKS
#define LAST_SHAPE SHAPE_DISK
#else
#define LAST_SHAPE SHAPE_ELLIPSOID
#endif

/* How many shapes of `kind` the scene has: the loop over every shape, for scenes too small for a BVH. */
inline int shape_count(const Scene *s, int kind)
{
    return kind == SHAPE_RECTANGLE ? s->params->n_rectangles
         : kind == SHAPE_TRIANGLE  ? s->params->n_triangles
         : kind == SHAPE_ELLIPSOID ? s->params->n_ellipsoids
         : kind == SHAPE_DISK      ? s->params->n_disks
                                   : s->params->n_cylinders;
}
#endif

/* The nearest hit along r in (0, tmax]; a ray leaving a surface never hits that surface (ray.h). */
ALWAYS_INLINE Hit closest_hit(const Scene *s, Ray r, vfloat tmax)
{
    Hit hit = no_hit();
#if HAS_BVH
    bvh_closest_hit(s, &hit, r, tmax);
#else
    PrimitiveRay p = primitive_ray(r);
    for (int kind = SHAPE_RECTANGLE; kind <= LAST_SHAPE; ++kind)
        for (int i = 0; i < shape_count(s, kind); ++i)
            hit_primitive(s, &hit, &p, kind, i, tmax);
#endif
    vfloat dt, u, v;
    for (int i = 0; i < s->params->n_lights; ++i) {
        __global const Light *light = &s->lights[i];
        vfloat t = intersect_rectangle(&light->shape, r, vmin(tmax, hit.t), &dt, &u, &v);
        t = SELECT((vfloat)(INFINITY), t, hit_in_range(t, dt, tmax));
#if RADIOMETRIC /* a light with a material reflects (the path model's), and camera rays pass a light they do
                * not see (hide_emitters.cl): those hits get a point, to shade or to leave, as a rectangle's do */
        vfloat err = 0.0f;
        vec3 p = hit.p;
#if HAS_AOVS /* and the AOVs' position of any light (aovs.cl) */
        if (ANY(t < hit.t))
#else
        if ((light->shape.material >= 0 || s->params->hide_emitters) && ANY(t < hit.t))
#endif
            p = rectangle_point(&light->shape, u, v, &err);
        hit_update(&hit, r, t, p, err, v3_uniform(light->shape.normal), light->shape.material, light->colour,
                   SHAPE_NONE, i, (vfloat)(0.0f), (vfloat)(0.0f));
#else
#if HAS_AOVS /* the AOVs' position of a light (aovs.cl) */
        vfloat err;
        vec3 p = ANY(t < hit.t) ? rectangle_point(&light->shape, u, v, &err) : hit.p;
        hit_update(&hit, r, t, p, 0.0f, v3_uniform(light->shape.normal), -1, light->colour, SHAPE_NONE, i,
                   (vfloat)(0.0f), (vfloat)(0.0f));
#else
        hit_update(&hit, r, t, hit.p, 0.0f, v3_uniform(light->shape.normal), -1, light->colour, SHAPE_NONE, i,
                   (vfloat)(0.0f), (vfloat)(0.0f));
#endif
#endif
#if RADIOMETRIC /* radiance leaves the front face only: a light's back is black, and hides what is behind */
        vint back = (t == hit.t) & (v3_dot(r.d, v3_uniform(light->shape.normal)) >= 0.0f);
        hit.emitted = v3_select(hit.emitted, v3_splat(0.0f, 0.0f, 0.0f), back);
#endif
    }
#if HAS_SHAPE_EMITTERS
    if (ANY(hit.material >= 0))
        hit_emission(s, &hit);
#endif
    return hit;
}

/* The rectangles (of the first CULLED_RECTANGLES) that no shadow segment from o to the light can block, in every lane of
 * `lanes`. The host's bits (types.h) say that the light lies wholly on one side of the plane, with margins
 * for how shadow rays sample the light and end. Then a lane's segment cannot cross the plane when o is
 * certainly on that side too, beyond num's rounding e (rectangle.cl's plane_num and plane_num_error, the
 * very values its test computes); and where |num| <= e, rectangle.cl itself never reports a hit (dt >=
 * |t|). So the rectangle test could only answer "not blocked": skipping it changes no result. Once per hit
 * and light, for every shadow ray towards that light: the walls of a room are not tested again. */
inline uint rectangles_out_of_reach(const Scene *s, __global const Light *light, vec3 o, vint lanes)
{
    uint front = light->planes_in_front, behind = light->planes_behind, out = 0u;
    for (int i = 0; i < s->params->n_rectangles && i < CULLED_RECTANGLES; ++i) {
        uint bit = 1u << i;
        if (!((front | behind) & bit))
            continue;
        __global const Rectangle *rect = &s->rectangles[i];
        vec3 co = v3_sub(v3_uniform(rect->center), o);
        vfloat num = plane_num(rect, co), e = plane_num_error(rect, co);
        vint beyond_reach = (front & bit) ? num <= e : num >= -e; /* (o - c).n = -num */
        if (ALL(beyond_reach | (lanes == 0)))
            out |= bit;
    }
    return out;
}

/* Mask of the lanes whose segment o + t d, t in (0, 1), is blocked by a shape other than the `skip`ped
 * rectangles: for planes and triangles conservatively inside, so neither the surface it leaves nor one it
 * ends on counts (ray.h); an ellipsoid blocks for 0 < t < 1, the segment's end being already pushed off the
 * light (shading.cl). Lights do not block. Only the `active` lanes are traced (the others answer 0), and the
 * test stops as soon as every one of them is blocked. With HAS_NULLS a segment may pass `passes` see-through
 * surfaces (primitive.cl). */
inline vint occluded(const Scene *s, Ray r, uint skip, vint active PASSES_PARAMETER OWN_PARAMETER)
{
#if HAS_BVH
    return bvh_occluded(s, 0, r, skip, active PASSES(passes) OWN(own));
#else
    PrimitiveRay p = shadow_primitive_ray(r PASSES(SELECT((vint)(0), passes, active)) OWN(own));
    vint settled = !active;
    for (int kind = SHAPE_RECTANGLE; kind <= LAST_SHAPE; ++kind)
        for (int i = 0; i < shape_count(s, kind) && !ALL(settled); ++i)
            settled |= primitive_blocks(s, &p, kind, i, skip);
    return settled & active;
#endif
}

/* What the segments of `samples` light samples from the origins of `lanes` towards `light` (its points within
 * q_err of its plane) may meet, for
 * occluded_among(): the leaves of their sweep (shadow_sweep.cl), none at all (n = 0) where it meets nothing
 * the samples could be blocked by, or everything (n = -1). A single sample's segments are all the sweep would
 * bound, and traversing them costs less than the sweep (scene 0 with one light sample took more time with it,
 * measured in commit 67aa6ba): everything, then. */
inline SweptLeaves shadow_candidates(const Scene *s, __global const Light *light, float q_err, vec3 origin,
                                     vint lanes, uint skip, int samples)
{
#if HAS_BVH
    if (samples > 1) {
        Sweep w = shadow_sweep(light, q_err, origin, lanes);
        return swept_leaves(s, &w, skip);
    }
#endif
    SweptLeaves every = {-1}; /* every shape; with a tree, each sample traverses it from the root (start 0) */
    return every;
}

/* occluded() of a segment among the shadow candidates of its packet and light. */
inline vint occluded_among(const Scene *s, const SweptLeaves *candidates, Ray r, uint skip, vint active
                           PASSES_PARAMETER)
{
#if HAS_BVH
    return swept_occluded(s, candidates, r, skip, active PASSES(passes));
#else
    return occluded(s, r, skip, active PASSES(passes) OWN(-1));
#endif
}

#endif
