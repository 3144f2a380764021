/* Closest hit over every shape and light, and the any-hit test of shadow rays: over a BVH (bvh.cl) when the
 * host built one, else a loop over every shape. Either way a primitive is tested by all lanes at once (every
 * lane tests the same shape); the lanes' own results are merged with SELECT(). */
#ifndef INTERSECT_CL
#define INTERSECT_CL

#include "scene.h"
#include "rectangle.cl" /* lights are rectangles: always needed */
#if HAS_TRIANGLES
#include "triangle.cl"
#endif
#if HAS_ELLIPSOIDS
#include "ellipsoid.cl"
#endif

typedef struct {
    vfloat t;      /* +inf: nothing hit */
    vec3 p;        /* the hit point, computed from the shape's own parameters (not o + t d) */
    vfloat err;    /* a bound on p's distance from the surface along n (ray.h) */
    vec3 n;        /* unit geometric normal, facing the incoming ray */
    vint material; /* -1: nothing or a light */
    vec3 emitted;  /* colour of the light hit first, else 0 */
#if HAS_SURFACE_DATA /* what texturing and smooth normals need: the shape and where on it */
    vint kind, index; /* SHAPE_* and the shape's index in its table */
    vfloat b1, b2;    /* barycentrics of a triangle hit */
#endif
} Hit;

/* Keep the nearer of the current hit and a candidate at t_new, point p within err of the surface, with normal
 * n (any orientation): shape `index` of `kind`, with barycentrics (b1, b2) for a triangle. */
inline void hit_update(Hit *hit, Ray r, vfloat t_new, vec3 p, vfloat err, vec3 n, int material, Vec3f emitted,
                       int kind, int index, vfloat b1, vfloat b2)
{
    vint nearer = t_new < hit->t;
    vfloat facing = SELECT((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(n, r.d) > 0.0f);
    hit->t = SELECT(hit->t, t_new, nearer);
    hit->p = v3_select(hit->p, p, nearer);
    hit->err = SELECT(hit->err, err, nearer);
    hit->n = v3_select(hit->n, v3_scale(n, facing), nearer);
    hit->material = SELECT(hit->material, (vint)(material), nearer);
    hit->emitted = v3_select(hit->emitted, v3_uniform(emitted), nearer);
#if HAS_SURFACE_DATA
    hit->kind = SELECT(hit->kind, (vint)(kind), nearer);
    hit->index = SELECT(hit->index, (vint)(index), nearer);
    hit->b1 = SELECT(hit->b1, b1, nearer);
    hit->b2 = SELECT(hit->b2, b2, nearer);
#endif
}

/* The closest-hit test of one primitive of each kind, merged into *hit for the lanes it is nearer for; tmax
 * bounds t. Hit points and their error bounds are formed only where some lane's hit is nearer (ray.h). */
inline void hit_rectangle(const Scene *s, Hit *hit, Ray r, int i, vfloat tmax)
{
    __global const Rectangle *rect = &s->rectangles[i];
    vfloat dt, u, v, err;
    vfloat t = intersect_rectangle(rect, r, vmin(tmax, hit->t), &dt, &u, &v);
    t = SELECT((vfloat)(INFINITY), t, hit_in_range(t, dt, tmax));
    if (ANY(t < hit->t)) {
        vec3 p = rectangle_point(rect, u, v, &err);
        hit_update(hit, r, t, p, err, v3_uniform(rect->normal), rect->material, (Vec3f){0.0f, 0.0f, 0.0f},
                   SHAPE_RECTANGLE, i, (vfloat)(0.0f), (vfloat)(0.0f));
    }
}

#if HAS_TRIANGLES
inline void hit_triangle(const Scene *s, Hit *hit, Ray r, RayShear shear, int i, vfloat tmax)
{
    __global const Triangle *tri = &s->triangles[i];
    vfloat dt, b0, b1, b2, err;
    vfloat t = intersect_triangle(tri, r, shear, &dt, &b0, &b1, &b2);
    t = SELECT((vfloat)(INFINITY), t, hit_in_range(t, dt, tmax));
    if (ANY(t < hit->t)) {
        vec3 p = triangle_point(tri, b0, b1, b2, &err);
        hit_update(hit, r, t, p, err, v3_uniform(tri->normal), tri->material, (Vec3f){0.0f, 0.0f, 0.0f},
                   SHAPE_TRIANGLE, i, b1, b2);
    }
}
#endif

#if HAS_ELLIPSOIDS
inline void hit_ellipsoid(const Scene *s, Hit *hit, Ray r, int i, vfloat tmax)
{
    __global const Ellipsoid *e = &s->ellipsoids[i];
    vec3 q;
    vfloat err;
    vfloat t = intersect_ellipsoid(e, r, &q);
    t = SELECT((vfloat)(INFINITY), t, t <= tmax);
    if (ANY(t < hit->t)) {
        vec3 n = ellipsoid_normal(e, q);
        vec3 p = ellipsoid_point(e, q, n, &err);
        hit_update(hit, r, t, p, err, n, e->material, (Vec3f){0.0f, 0.0f, 0.0f}, SHAPE_ELLIPSOID, i,
                   (vfloat)(0.0f), (vfloat)(0.0f));
    }
}
#endif

/* The any-hit test of one primitive of each kind against a shadow segment (t in (0, 1), ray.h). */
inline vint blocks_rectangle(const Scene *s, Ray r, int i)
{
    vfloat dt, u, v;
    return hit_on_segment(intersect_rectangle(&s->rectangles[i], r, (vfloat)(1.0f), &dt, &u, &v), dt);
}

#if HAS_TRIANGLES
inline vint blocks_triangle(const Scene *s, Ray r, RayShear shear, int i)
{
    vfloat dt, b0, b1, b2;
    return hit_on_segment(intersect_triangle(&s->triangles[i], r, shear, &dt, &b0, &b1, &b2), dt);
}
#endif

#if HAS_ELLIPSOIDS
inline vint blocks_ellipsoid(const Scene *s, Ray r, int i)
{
    vec3 q;
    return hit_on_segment(intersect_ellipsoid(&s->ellipsoids[i], r, &q), (vfloat)(0.0f));
}
#endif

/* Rectangle i is among the `skipped` ones (bit i of the first 32). */
inline int skipped(uint rectangles, int i) { return i < 32 && ((rectangles >> i) & 1u); }

#if HAS_BVH
#include "bvh.cl"
#endif

inline Hit no_hit(void)
{
    Hit hit;
    hit.t = (vfloat)(INFINITY);
    hit.p = hit.n = hit.emitted = v3_splat(0.0f, 0.0f, 0.0f);
    hit.err = 0.0f;
    hit.material = (vint)(-1);
#if HAS_SURFACE_DATA
    hit.kind = hit.index = (vint)(0);
    hit.b1 = hit.b2 = (vfloat)(0.0f);
#endif
    return hit;
}

/* The nearest hit along r in (0, tmax]; a ray leaving a surface never hits that surface (ray.h). */
inline Hit closest_hit(const Scene *s, Ray r, vfloat tmax)
{
    Hit hit = no_hit();
#if HAS_BVH
    bvh_closest_hit(s, &hit, r, tmax);
#else
#if HAS_RECTANGLES
    for (int i = 0; i < s->params->n_rectangles; ++i)
        hit_rectangle(s, &hit, r, i, tmax);
#endif
#if HAS_TRIANGLES
    RayShear shear = ray_shear(r);
    for (int i = 0; i < s->params->n_triangles; ++i)
        hit_triangle(s, &hit, r, shear, i, tmax);
#endif
#if HAS_ELLIPSOIDS
    for (int i = 0; i < s->params->n_ellipsoids; ++i)
        hit_ellipsoid(s, &hit, r, i, tmax);
#endif
#endif
    vfloat dt, u, v;
    for (int i = 0; i < s->params->n_lights; ++i) {
        __global const Light *light = &s->lights[i];
        vfloat t = intersect_rectangle(&light->shape, r, vmin(tmax, hit.t), &dt, &u, &v);
        t = SELECT((vfloat)(INFINITY), t, hit_in_range(t, dt, tmax));
        hit_update(&hit, r, t, hit.p, 0.0f, v3_uniform(light->shape.normal), -1, light->colour, SHAPE_NONE, i,
                   (vfloat)(0.0f), (vfloat)(0.0f));
    }
    return hit;
}

/* The rectangles (of the first 32) that no shadow segment from o to the light can block, in every lane of
 * `lanes`. The host's bits (types.h) say that the light lies wholly on one side of the plane, with margins
 * for how shadow rays sample the light and end. Then a lane's segment cannot cross the plane when o is
 * certainly on that side too, beyond num's rounding e (rectangle.cl's plane_num and plane_num_error, the
 * very values its test computes); and where |num| <= e, rectangle.cl itself never reports a hit (dt >=
 * |t|). So the rectangle test could only answer "not blocked": skipping it changes no result. Once per hit
 * and light, for every shadow ray towards that light: the walls of a room are not tested again. */
inline uint rectangles_out_of_reach(const Scene *s, __global const Light *light, vec3 o, vint lanes)
{
    uint front = light->planes_in_front, behind = light->planes_behind, out = 0u;
    for (int i = 0; i < s->params->n_rectangles && i < 32; ++i) {
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
 * light (shading.cl). Lights do not block. Stops as soon as every lane is blocked. */
inline vint occluded(const Scene *s, Ray r, uint skip)
{
#if HAS_BVH
    return bvh_occluded(s, r, skip);
#else
    vint blocked = (vint)(0);
#if HAS_RECTANGLES
    for (int i = 0; i < s->params->n_rectangles && !ALL(blocked); ++i)
        if (!skipped(skip, i))
            blocked |= blocks_rectangle(s, r, i);
#endif
#if HAS_TRIANGLES
    RayShear shear = ray_shear(r);
    for (int i = 0; i < s->params->n_triangles && !ALL(blocked); ++i)
        blocked |= blocks_triangle(s, r, shear, i);
#endif
#if HAS_ELLIPSOIDS
    for (int i = 0; i < s->params->n_ellipsoids && !ALL(blocked); ++i)
        blocked |= blocks_ellipsoid(s, r, i);
#endif
    return blocked;
#endif
}

#endif
