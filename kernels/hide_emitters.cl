/* Mitsuba's hide_emitters (its `path` and `direct` integrators; Integrator::skip_area_emitters in
 * src/render/integrator.cpp): the camera does not see the emitters. A camera ray that meets an emitter, a
 * rectangular light or an emitting shape, from either side, passes it as if it were not there and goes on to
 * what lies beyond, which it sees as it would without the emitter in front; the emitters still light the
 * scene (their samples' shadow rays and the path model's later vertices meet them as always). What else the
 * camera does not see, the environment and emitters seen through see-through surfaces, is the path model's
 * (path_tracing.cl's path_hit). */
#ifndef HIDE_EMITTERS_CL
#define HIDE_EMITTERS_CL

#include "intersect.cl"

/* Emitters a camera ray passes at most: each pass moves its origin past one surface, so only a ray through
 * more emitters than this (a stack of lights, a mesh light folded on itself) stops at the next, which it
 * shows black. */
#define MAX_EMITTERS_PASSED 64

/* The lanes whose hit is on an emitter: a light (kind SHAPE_NONE), or a shape with an Emitter. The direct
 * model's lights and emitting shapes reflect nothing (scene/rules.py): there, they alone have no material. */
inline vint hits_emitter(Hit hit)
{
#if HAS_PATH_TRACING
    vint on = (hit.kind == SHAPE_NONE) & (hit.t < INFINITY);
#if HAS_SHAPE_EMITTERS
    on |= hit.emitter >= 0;
#endif
    return on;
#else
    return (hit.t < INFINITY) & (hit.material < 0);
#endif
}

/* The hit of each lane of `camera` past the emitters along its ray *r, whose origin moves to just beyond the
 * last emitter passed (so that the hit's t and the shading point's ray stay each other's); `tmax`, how far
 * each lane's ray was traced (negative: not at all, and it keeps its miss; a camera ray's far clip plane). The
 * lanes to pass are traced again, and the others with them (to the same hit, their rays unchanged): one
 * traversal a step, where the renderer's packets would otherwise merge per-lane hits of every kind field by
 * field. A ray that passed an emitter goes on without its far clip plane, as Mitsuba's spawn_ray drops the
 * ray's maxt; the others keep theirs. */
inline Hit pass_emitters(const Scene *s, Ray *r, Hit hit, vfloat tmax, vint camera)
{
    vint passing = camera & hits_emitter(hit), passed = passing;
    for (int k = 0; k < MAX_EMITTERS_PASSED && ANY(passing); ++k) {
        /* beyond the surface: hit.n faces the incoming ray */
        r->o = v3_select(r->o, offset_ray_origin(hit.p, hit.err, v3_scale(hit.n, -1.0f)), passing);
        hit = closest_hit(s, *r, SELECT(tmax, (vfloat)(INFINITY), passed));
        passing &= hits_emitter(hit);
        passed |= passing;
    }
    hit.emitted = v3_select(hit.emitted, v3_splat(0.0f, 0.0f, 0.0f), passing); /* past the cap: black */
    return hit;
}

#endif
