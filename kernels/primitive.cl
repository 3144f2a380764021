/* One primitive, tested by all lanes at once (every lane tests the same shape; the lanes' own results are
 * merged with SELECT()): the closest-hit test and the any-hit test of shadow rays, for each kind of shape,
 * and the one dispatch on a primitive's kind that the BVH's leaves (bvh.cl) and the loop over every shape
 * (intersect.cl) both use.
 *
 * See-through surfaces (HAS_NULLS: a `mask`, or Mitsuba's `null`): a shadow segment that crosses one passes
 * where the wrappers at that crossing resolve to `null` (material.cl's passes_through: resolved as for a ray
 * meeting the surface, with the blends' probabilities and the mask's opacity there, drawn by a hash of the
 * crossing and the segment, a draw of the shadow ray's own), and is blocked elsewhere. That is pbrt-v4's stochastic alpha test of shadow rays (section 7.1.1's alpha, HashFloat over
 * the ray): the expected visibility is the product of the crossings' transparencies. Mitsuba 3's `path`
 * stops shadow rays at every surface, and light behind a leaf reaches a point only through its BSDF's
 * samples passing the `null` bounce; here the light samples reach it too, and the two are weighted by MIS
 * (path_tracing.cl keeps the MIS state of the vertex before the passes). As Mitsuba counts a pass as a
 * vertex of the path, a shadow segment may pass at most `passes` such surfaces (max_depth's vertices left). */
#ifndef PRIMITIVE_CL
#define PRIMITIVE_CL

#include "scene.h"
#include "rectangle.cl" /* lights are rectangles: always needed */
#if HAS_TRIANGLES
#include "triangle.cl"
#endif
#if HAS_ELLIPSOIDS
#include "ellipsoid.cl"
#endif
#if HAS_DISKS
#include "disk.cl"
#endif
#if HAS_CYLINDERS
#include "cylinder.cl"
#endif

typedef struct {
    vfloat t;      /* +inf: nothing hit */
    vec3 p;        /* the hit point, computed from the shape's own parameters (not o + t d) */
    vfloat err;    /* a bound on p's distance from the surface along n (ray.h) */
    vec3 n;        /* unit geometric normal, facing the incoming ray */
    vint material; /* -1: nothing or a light */
    vec3 emitted;  /* colour of the light hit first, else 0 */
#if HAS_BACKFACES
    vint backface; /* the ray met the side the shape's normal points away from: it leaves a closed shape */
#endif
#if HAS_SURFACE_DATA /* what texturing and smooth normals need: the shape and where on it */
    vint kind, index; /* SHAPE_* and the shape's index in its table */
    vfloat b1, b2;    /* barycentrics of a triangle hit */
#endif
#if HAS_SHAPE_EMITTERS
    vint emitter;     /* the Emitter of the shape hit (intersect.cl's hit_emission), -1 for none */
#endif
#if HAS_INSTANCES
    vint instance;    /* the Instance whose group the triangle hit is of (its p, n and err are the world's; the
                       * surface's own values, kind and index, its group's: material.cl maps them), -1 for none */
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
#if HAS_BACKFACES
    hit->backface = SELECT(hit->backface, facing < 0.0f, nearer);
#endif
#if HAS_SURFACE_DATA
    hit->kind = SELECT(hit->kind, (vint)(kind), nearer);
    hit->index = SELECT(hit->index, (vint)(index), nearer);
    hit->b1 = SELECT(hit->b1, b1, nearer);
    hit->b2 = SELECT(hit->b2, b2, nearer);
#endif
#if HAS_INSTANCES /* a shape of the world's (bvh.cl's leave_instance notes a group's) */
    hit->instance = SELECT(hit->instance, (vint)(-1), nearer);
#endif
}

/* The closest-hit test of one primitive of each kind, merged into *hit for the lanes it is nearer for; tmax
 * bounds t. Hit points and their error bounds are formed only where some lane's hit is nearer (ray.h). */
ALWAYS_INLINE void hit_rectangle(const Scene *s, Hit *hit, Ray r, int i, vfloat tmax)
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
ALWAYS_INLINE void hit_triangle(const Scene *s, Hit *hit, Ray r, RayShear shear, int i, vfloat tmax)
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

#if HAS_DISKS
inline void hit_disk(const Scene *s, Hit *hit, Ray r, int i, vfloat tmax)
{
    __global const Disk *k = &s->disks[i];
    vec3 q;
    vfloat dt, err;
    vfloat t = intersect_disk(k, r, vmin(tmax, hit->t), &dt, &q);
    t = SELECT((vfloat)(INFINITY), t, hit_in_range(t, dt, tmax));
    if (ANY(t < hit->t)) {
        vec3 n = disk_normal(k);
        vec3 p = disk_point(k, q.x, q.y, n, &err);
        hit_update(hit, r, t, p, err, n, k->material, (Vec3f){0.0f, 0.0f, 0.0f}, SHAPE_DISK, i, (vfloat)(0.0f),
                   (vfloat)(0.0f));
    }
}
#endif

#if HAS_CYLINDERS
inline void hit_cylinder(const Scene *s, Hit *hit, Ray r, int i, vfloat tmax)
{
    __global const Cylinder *k = &s->cylinders[i];
    vec3 q;
    vfloat err;
    vfloat t = intersect_cylinder(k, r, &q);
    t = SELECT((vfloat)(INFINITY), t, t <= tmax);
    if (ANY(t < hit->t)) {
        vec3 n = cylinder_normal(k, q);
        vec3 p = cylinder_point(k, q, n, &err);
        hit_update(hit, r, t, p, err, n, k->material, (Vec3f){0.0f, 0.0f, 0.0f}, SHAPE_CYLINDER, i,
                   (vfloat)(0.0f), (vfloat)(0.0f));
    }
}
#endif

/* Rectangle i is among the `skipped` ones (bit i of the first CULLED_RECTANGLES). */
inline int skipped(uint rectangles, int i) { return i < CULLED_RECTANGLES && ((rectangles >> i) & 1u); }

inline Hit no_hit(void)
{
    Hit hit;
    hit.t = (vfloat)(INFINITY);
    hit.p = hit.n = hit.emitted = v3_splat(0.0f, 0.0f, 0.0f);
    hit.err = 0.0f;
    hit.material = (vint)(-1);
#if HAS_BACKFACES
    hit.backface = (vint)(0);
#endif
#if HAS_SURFACE_DATA
    hit.kind = hit.index = (vint)(0);
    hit.b1 = hit.b2 = (vfloat)(0.0f);
#endif
#if HAS_SHAPE_EMITTERS
    hit.emitter = (vint)(-1);
#endif
#if HAS_INSTANCES
    hit.instance = (vint)(-1);
#endif
    return hit;
}

/* A ray with what the primitive tests derive from it once: the triangle test's shear, formed at the first
 * triangle the ray meets (most rays of a room never reach a mesh's leaves); and for a shadow segment, the
 * see-through surfaces it has passed so far and how many it may pass. */
typedef struct {
    Ray r;
#if HAS_TRIANGLES
    RayShear shear;
    int sheared;
#endif
#if HAS_NULLS
    vint passed, passes;
#endif
#if HAS_SHAPE_EMITTERS
    vint own; /* per lane, a shadow segment towards a point of an emitting shape: that shape,
               * SHAPE_REFERENCE(kind, index), where it cannot block the segment (emitters.cl), else -1 */
#endif
} PrimitiveRay;

inline PrimitiveRay primitive_ray(Ray r)
{
    PrimitiveRay p;
    p.r = r;
#if HAS_TRIANGLES
    p.sheared = 0;
#endif
#if HAS_NULLS
    p.passed = p.passes = (vint)(0);
#endif
#if HAS_SHAPE_EMITTERS
    p.own = -1;
#endif
    return p;
}

/* A shadow segment's PrimitiveRay. With HAS_NULLS the shadow tests take the number of see-through surfaces
 * their segments may pass, as one more parameter, PASSES_PARAMETER, and argument, PASSES(x); without, none. The
 * traversals give inactive lanes none: their crossings are not resolved (their answers are not kept). */
#if HAS_NULLS
#define PASSES(x) , x
#define PASSES_PARAMETER , vint passes
#else
#define PASSES(x)
#define PASSES_PARAMETER
#endif
/* With HAS_SHAPE_EMITTERS they take the emitting shape the segments end on likewise, OWN_PARAMETER and OWN(x),
 * where that shape cannot block them (emitters.cl): a sphere's sampled point is on the side of it the segment's
 * origin sees, and a cylinder's front (outwards) faces the origin, so that the convex solid lies beyond the
 * tangent plane there; then the shape's own roots near the segment's end are not tested against its
 * rounding. */
#if HAS_SHAPE_EMITTERS
#define OWN(x) , x
#define OWN_PARAMETER , vint own
#else
#define OWN(x)
#define OWN_PARAMETER
#endif
inline PrimitiveRay shadow_primitive_ray(Ray r PASSES_PARAMETER OWN_PARAMETER)
{
    PrimitiveRay p = primitive_ray(r);
#if HAS_NULLS
    p.passes = passes;
#endif
#if HAS_SHAPE_EMITTERS
    p.own = own;
#endif
    return p;
}

#if HAS_TRIANGLES
inline RayShear triangle_shear(PrimitiveRay *p)
{
    if (!p->sheared) {
        p->shear = ray_shear(p->r);
        p->sheared = 1;
    }
    return p->shear;
}
#endif

#if HAS_NULLS
/* The lanes of `hit` whose material lets a shadow ray pass (material.cl). */
vint passes_through(const Scene *s, Ray r, Hit hit);

/* Whether material m may resolve to `null` at a hit on either side: it, or its back, is a blend (a mask) or
 * `null`. Only then are its crossings resolved. */
inline int see_through(const Scene *s, int m)
{
    if (m < 0)
        return 0;
    int bsdf = s->materials[m].bsdf, back = s->materials[m].back;
    int back_bsdf = back >= 0 ? s->materials[back].bsdf : BSDF_DIFFUSE;
    return bsdf == BSDF_BLEND || bsdf == BSDF_NULL || back_bsdf == BSDF_BLEND || back_bsdf == BSDF_NULL;
}

/* The lanes of `crossed` that a crossing of a see-through surface at t (point p, normal n: shape `index` of
 * `kind`) blocks: those that have passed as many such surfaces as they may (their crossings are not resolved),
 * and those whose material there is not `null`; the others pass, and are counted. */
inline vint crossing_blocks(const Scene *s, PrimitiveRay *p, vint crossed, vfloat t, vec3 q, vec3 n,
                            int material, int kind, int index, vfloat b1, vfloat b2)
{
    vint spare = crossed & (p->passed < p->passes);
    if (!ANY(spare))
        return crossed;
    Hit hit = no_hit();
    hit_update(&hit, p->r, SELECT((vfloat)(INFINITY), t, spare), q, 0.0f, n, material,
               (Vec3f){0.0f, 0.0f, 0.0f}, kind, index, b1, b2);
    vint through = spare & passes_through(s, p->r, hit);
    p->passed = SELECT(p->passed, p->passed + 1, through);
    return crossed & !through;
}
#endif

/* The any-hit test of one primitive of each kind against a shadow segment (t in (0, 1), ray.h). */
inline vint blocks_rectangle(const Scene *s, PrimitiveRay *p, int i)
{
    __global const Rectangle *rect = &s->rectangles[i];
    vfloat dt, u, v;
    vfloat t = intersect_rectangle(rect, p->r, (vfloat)(1.0f), &dt, &u, &v);
    vint crossed = hit_on_segment(t, dt);
#if HAS_NULLS
    if (ANY(crossed) && see_through(s, rect->material)) {
        vfloat err;
        return crossing_blocks(s, p, crossed, t, rectangle_point(rect, u, v, &err), v3_uniform(rect->normal),
                               rect->material, SHAPE_RECTANGLE, i, (vfloat)(0.0f), (vfloat)(0.0f));
    }
#endif
    return crossed;
}

#if HAS_TRIANGLES
ALWAYS_INLINE vint blocks_triangle(const Scene *s, PrimitiveRay *p, RayShear shear, int i)
{
    __global const Triangle *tri = &s->triangles[i];
    vfloat dt, b0, b1, b2;
    vfloat t = intersect_triangle(tri, p->r, shear, &dt, &b0, &b1, &b2);
    vint crossed = hit_on_segment(t, dt);
#if HAS_NULLS
    if (ANY(crossed) && see_through(s, tri->material)) {
        vfloat err;
        return crossing_blocks(s, p, crossed, t, triangle_point(tri, b0, b1, b2, &err), v3_uniform(tri->normal),
                               tri->material, SHAPE_TRIANGLE, i, b1, b2);
    }
#endif
    return crossed;
}
#endif

#if HAS_ELLIPSOIDS
/* A see-through ellipsoid is crossed twice by a segment that passes it: at the hit, and at the far root. */
inline vint blocks_ellipsoid(const Scene *s, PrimitiveRay *p, int i)
{
    __global const Ellipsoid *e = &s->ellipsoids[i];
    vec3 q, q_beyond;
    vfloat t_beyond;
    vfloat t = ellipsoid_roots(e, p->r, &q, &t_beyond, &q_beyond);
    vint crossed = hit_on_segment(t, (vfloat)(0.0f));
#if HAS_NULLS
    if (ANY(crossed) && see_through(s, e->material)) {
        vfloat err;
        vec3 n = ellipsoid_normal(e, q);
        vint blocked = crossing_blocks(s, p, crossed, t, ellipsoid_point(e, q, n, &err), n, e->material,
                                       SHAPE_ELLIPSOID, i, (vfloat)(0.0f), (vfloat)(0.0f));
        vint again = crossed & !blocked & hit_on_segment(t_beyond, (vfloat)(0.0f));
        if (ANY(again)) {
            n = ellipsoid_normal(e, q_beyond);
            blocked |= crossing_blocks(s, p, again, t_beyond, ellipsoid_point(e, q_beyond, n, &err), n,
                                       e->material, SHAPE_ELLIPSOID, i, (vfloat)(0.0f), (vfloat)(0.0f));
        }
        return blocked;
    }
#endif
    return crossed;
}
#endif

#if HAS_DISKS
inline vint blocks_disk(const Scene *s, PrimitiveRay *p, int i)
{
    __global const Disk *k = &s->disks[i];
    vec3 q;
    vfloat dt;
    vfloat t = intersect_disk(k, p->r, (vfloat)(1.0f), &dt, &q);
    vint crossed = hit_on_segment(t, dt);
#if HAS_NULLS
    if (ANY(crossed) && see_through(s, k->material)) {
        vfloat err;
        vec3 n = disk_normal(k);
        return crossing_blocks(s, p, crossed, t, disk_point(k, q.x, q.y, n, &err), n, k->material, SHAPE_DISK, i,
                               (vfloat)(0.0f), (vfloat)(0.0f));
    }
#endif
    return crossed;
}
#endif

#if HAS_CYLINDERS
/* A see-through cylinder may be crossed twice by a segment that passes it, as an ellipsoid. */
inline vint blocks_cylinder(const Scene *s, PrimitiveRay *p, int i)
{
    __global const Cylinder *k = &s->cylinders[i];
    vec3 q, q_beyond;
    vfloat t_beyond;
    vfloat t = cylinder_roots(k, p->r, &q, &t_beyond, &q_beyond);
    vint crossed = hit_on_segment(t, (vfloat)(0.0f));
#if HAS_NULLS
    if (ANY(crossed) && see_through(s, k->material)) {
        vfloat err;
        vec3 n = cylinder_normal(k, q);
        vint blocked = crossing_blocks(s, p, crossed, t, cylinder_point(k, q, n, &err), n, k->material,
                                       SHAPE_CYLINDER, i, (vfloat)(0.0f), (vfloat)(0.0f));
        vint again = crossed & !blocked & hit_on_segment(t_beyond, (vfloat)(0.0f));
        if (ANY(again)) {
            n = cylinder_normal(k, q_beyond);
            blocked |= crossing_blocks(s, p, again, t_beyond, cylinder_point(k, q_beyond, n, &err), n,
                                       k->material, SHAPE_CYLINDER, i, (vfloat)(0.0f), (vfloat)(0.0f));
        }
        return blocked;
    }
#endif
    return crossed;
}
#endif

/* The closest-hit test of primitive `index` of `kind` (SHAPE_*), merged into *hit; tmax bounds t. */
ALWAYS_INLINE void hit_primitive(const Scene *s, Hit *hit, PrimitiveRay *p, int kind, int index, vfloat tmax)
{
    COUNT_VISIT(s, VISITS_CLOSEST_PRIMITIVES);
#if HAS_TRIANGLES
    if (kind == SHAPE_TRIANGLE)
        hit_triangle(s, hit, p->r, triangle_shear(p), index, tmax);
#endif
#if HAS_RECTANGLES
    if (kind == SHAPE_RECTANGLE)
        hit_rectangle(s, hit, p->r, index, tmax);
#endif
#if HAS_ELLIPSOIDS
    if (kind == SHAPE_ELLIPSOID)
        hit_ellipsoid(s, hit, p->r, index, tmax);
#endif
#if HAS_DISKS
    if (kind == SHAPE_DISK)
        hit_disk(s, hit, p->r, index, tmax);
#endif
#if HAS_CYLINDERS
    if (kind == SHAPE_CYLINDER)
        hit_cylinder(s, hit, p->r, index, tmax);
#endif
}

/* The lanes whose shadow segment primitive `index` of `kind` blocks; a `skip`ped rectangle blocks none (and is
 * not counted as tested). */
ALWAYS_INLINE vint primitive_blocks(const Scene *s, PrimitiveRay *p, int kind, int index, uint skip)
{
#if HAS_TRIANGLES
    if (kind == SHAPE_TRIANGLE)
        return (COUNT_VISIT(s, VISITS_SHADOW_PRIMITIVES), blocks_triangle(s, p, triangle_shear(p), index));
#endif
#if HAS_RECTANGLES
    if (kind == SHAPE_RECTANGLE && !skipped(skip, index))
        return (COUNT_VISIT(s, VISITS_SHADOW_PRIMITIVES), blocks_rectangle(s, p, index));
#endif
#if HAS_SHAPE_EMITTERS
    const vint mine = p->own == SHAPE_REFERENCE(kind, index); /* the lanes whose segment ends on this shape */
    if (ALL(mine))
        return (vint)(0);
#else
    const vint mine = (vint)(0);
#endif
#if HAS_ELLIPSOIDS
    if (kind == SHAPE_ELLIPSOID)
        return (COUNT_VISIT(s, VISITS_SHADOW_PRIMITIVES), blocks_ellipsoid(s, p, index) & !mine);
#endif
#if HAS_DISKS
    if (kind == SHAPE_DISK)
        return (COUNT_VISIT(s, VISITS_SHADOW_PRIMITIVES), blocks_disk(s, p, index) & !mine);
#endif
#if HAS_CYLINDERS
    if (kind == SHAPE_CYLINDER)
        return (COUNT_VISIT(s, VISITS_SHADOW_PRIMITIVES), blocks_cylinder(s, p, index) & !mine);
#endif
    return (vint)(0);
}

#endif
