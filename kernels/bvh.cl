/* Traversal of the bounding volume hierarchy built on the host (raytrace/renderer/bvh.py; pbrt-v4 section 7.3.5).
 *
 * Packets: the LANES rays of a work-item (its tile of pixels, or their shadow rays towards one light sample)
 * walk the tree together. A node is entered when any lane that is still looking meets its box; lanes that
 * miss it are masked by the primitive tests' own t ranges. Closest-hit traversals visit children near first,
 * by the first lane's direction along the split axis (the packet's rays are nearly parallel), so that the
 * closest hit found early culls the far subtrees. Shadow rays visit them far first, from the light's end of
 * the segment: a segment starts on a surface, and the subtrees around its origin (a mesh's neighbouring
 * triangles, which it leaves) rarely block it, so a blocker is found sooner and a packet whose lanes are all
 * blocked stops before it opens them. Measured with the counting build (raytrace/commands/visits.py, 512 x 512, 16 x 16
 * samples, 16 lanes): mesh_cornell's shadow rays open 18% fewer nodes and test 33% fewer primitives, scene
 * 0's 3% more nodes; an unblocked ray visits the same nodes in either order. Both kinds test an opened node's
 * two children together and push the second only when both are met (each function says how). With LANES=1
 * (GPUs) this is ordinary single-ray traversal. Shadow packets traverse the whole tree only when their sweep
 * towards the light meets more leaves than it keeps (shadow_sweep.cl). */
#ifndef BVH_CL
#define BVH_CL

#include "primitive.cl"
#if HAS_INSTANCES
#include "instances.cl"
#endif

/* Per ray: the reciprocal direction for the slab test, the signs that order the children, and whether any
 * lane's reciprocal direction has an infinite component (a zero or subnormal one in the direction: the slab
 * test's special case, below). */
typedef struct { vec3 inv_d; int negative[3], any_zero; } BoxRay;

inline BoxRay box_ray(Ray r)
{
    BoxRay b;
    b.inv_d = v3(1.0f / r.d.x, 1.0f / r.d.y, 1.0f / r.d.z);
    b.negative[0] = FIRST_LANE(r.d.x) < 0.0f;
    b.negative[1] = FIRST_LANE(r.d.y) < 0.0f;
    b.negative[2] = FIRST_LANE(r.d.z) < 0.0f;
    b.any_zero = ANY((vabs(b.inv_d.x) == INFINITY) | (vabs(b.inv_d.y) == INFINITY) | (vabs(b.inv_d.z) == INFINITY));
    return b;
}

/* The ray's parameter interval within the slab [lo, hi] of one axis, (*near, *far). A ray parallel to the
 * slab gets infinite distances: both of one sign outside it, -inf and +inf inside. With its origin exactly in
 * a face (or in a flat box's plane) one of them is 0 * inf = NaN, and a min or max would keep the other
 * infinity (or the NaN) and miss the box (every axis-parallel ray through a grid's vertex lines did): the ray
 * runs in the closed slab, which then does not limit it at all. t0 + t1 is NaN exactly in those cases and inside. */
inline void slab(float lo, float hi, vfloat o, vfloat inv_d, int any_zero, vfloat *near, vfloat *far)
{
    vfloat t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
    *near = vmin(t0, t1);
    *far = vmax(t0, t1);
    if (any_zero) { /* uniform over the packet: the common case pays nothing */
        vint unlimited = (t0 + t1) != (t0 + t1); /* NaN */
        *near = SELECT(*near, (vfloat)(-INFINITY), unlimited);
        *far = SELECT(*far, (vfloat)(INFINITY), unlimited);
    }
}

/* Lanes whose ray meets the node's box within [0, tmax]: the slabs' intervals intersected, the far distance
 * widened by the bound on the rounding of both slab distances, so that a box is never missed by a ray that
 * meets it (pbrt-v4 section 6.8.2). Each distance (b - o) * (1 / d) rounds 7 times (the difference, the
 * reciprocal as 5 (ray.h), the product): within gamma(7) of itself; the widening's product rounds once
 * more. pbrt-v4's 2 gamma(3) counts a correctly rounded reciprocal, which OpenCL C does not promise. */
inline vint meets_box(__global const BVHNode *node, Ray r, BoxRay b, vfloat tmax)
{
    vfloat nx, fx, ny, fy, nz, fz;
    slab(node->lo[0], node->hi[0], r.o.x, b.inv_d.x, b.any_zero, &nx, &fx);
    slab(node->lo[1], node->hi[1], r.o.y, b.inv_d.y, b.any_zero, &ny, &fy);
    slab(node->lo[2], node->hi[2], r.o.z, b.inv_d.z, b.any_zero, &nz, &fz);
    vfloat near = vmax(vmax(nx, ny), vmax(nz, 0.0f)), far = vmin(vmin(fx, fy), vmin(fz, tmax));
    return near <= WIDENED(far, 8);
}

/* The children of interior node `i` in the order to visit them: *first, then the returned second. Near first
 * along a direction whose signs per axis are `negative` (a packet's first lane's: BoxRay) on the node's split
 * axis, or far first with `far_first`. */
inline int order_children(__global const BVHNode *nodes, int i, const int *negative, int far_first, int *first)
{
    int right = nodes[i].offset, right_first = negative[-nodes[i].count] != far_first;
    *first = right_first ? right : i + 1;
    return right_first ? i + 1 : right;
}

/* The nodes a traversal has yet to visit: second children of nodes whose two children it entered. */
typedef struct { int node[BVH_STACK], top; } NodeStack;

/* After testing an opened node's two children: whether either is entered, and *i, the one to visit next, the
 * first if it is entered, else the second; the second is pushed when both are (stored always, counted only
 * then: no branch to mispredict). Every traversal here, shadow_sweep.cl's too, steps this way. Written as one
 * node index or -1, or with popping likewise, the traversals ran slower (measured in commit ae18e79). */
inline int enter_children(NodeStack *todo, int *i, int first, int second, int in_first, int in_second)
{
    todo->node[todo->top] = second;
    todo->top += in_first & in_second;
    *i = in_first ? first : second;
    return in_first | in_second;
}

/* Whether a closest-hit packet meets node j's box within [0, t]. */
inline int meets_node(const Scene *s, int j, Ray r, BoxRay b, vfloat t)
{
    COUNT_VISIT(s, VISITS_CLOSEST_NODES);
    return ANY(meets_box(&s->nodes[j], r, b, t));
}

/* The closest hit along r within tmax over the hierarchy. As in shadow traversals (below), an opened node's
 * two children are tested together, near first, and the second is pushed only when both are met; it is tested
 * again when popped, against the closer hit found since (no entry distances are pushed: a stack of 16-lane
 * distances measured slower). Against testing each child when it is popped, this saves time on the
 * 10^6-triangle torus of `bench --scaling` and changes nothing beyond the noise on smaller scenes (measured in
 * commit 2effa75). Inline (lanes.h): the path model calls it from its loop, where a call spills the paths'
 * state. */
#if HAS_INSTANCES
/* The lanes of `hit` that a traversal of instance `inside`'s group made nearer than t_before: their point,
 * normal and bound brought to the world (instances.cl), and the instance noted. */
inline void leave_instance(const Scene *s, Hit *hit, int inside, vfloat t_before)
{
    vint found = hit->t < t_before;
    if (!ANY(found))
        return;
    vec3 n;
    vfloat err;
    vec3 p = instance_point(&s->instances[inside], hit->p, hit->n, hit->err, &n, &err);
    hit->p = v3_select(hit->p, p, found);
    hit->n = v3_select(hit->n, n, found);
    hit->err = SELECT(hit->err, err, found);
    hit->instance = SELECT(hit->instance, (vint)(inside), found);
}
/* A node index that is a popped marker: the group of the instance being traversed is done (bvh_closest_hit). */
#define LEAVES(i) ((i) < 0)
#else
#define LEAVES(i) 0
#endif

/* The closest hit along r within tmax over the hierarchy. As in shadow traversals (below), an opened node's
 * two children are tested together, near first, and the second is pushed only when both are met; it is tested
 * again when popped, against the closer hit found since (no entry distances are pushed: a stack of 16-lane
 * distances measured slower). Against testing each child when it is popped, this saves time on the
 * 10^6-triangle torus of `bench --scaling` and changes nothing beyond the noise on smaller scenes (measured in
 * commit 2effa75). Inline (lanes.h): the path model calls it from its loop, where a call spills the paths'
 * state. With HAS_INSTANCES a leaf that holds an instance is entered as a subtree: the packet's rays go into
 * the group's space, a marker is pushed below the group's nodes, and when it is popped the hits found there come
 * back to the world (leave_instance) and the world's rays are taken up again. */
ALWAYS_INLINE void bvh_closest_hit(const Scene *s, Hit *hit, Ray r, vfloat tmax)
{
    BoxRay b = box_ray(r);
    PrimitiveRay p = primitive_ray(r);
    NodeStack todo = {.top = 0};
    int i = 0;
#if HAS_INSTANCES
    const Ray world = r;
    const BoxRay world_box = b;
    PrimitiveRay world_p = p;
    int inside = -1;
    vfloat t_before = INFINITY;
#endif
    if (!meets_node(s, 0, r, b, vmin(tmax, hit->t)))
        return;
    for (;;) {
        __global const BVHNode *node = &s->nodes[i];
        if (node->count <= 0) {
            int first, second = order_children(s->nodes, i, b.negative, 0, &first);
            vfloat t = vmin(tmax, hit->t);
            int in_first = meets_node(s, first, r, b, t), in_second = meets_node(s, second, r, b, t);
            if (enter_children(&todo, &i, first, second, in_first, in_second))
                continue;
        } else {
#if HAS_INSTANCES
            if (PRIM_KIND(s->prims[node->offset]) == SHAPE_INSTANCE) { /* alone in its leaf (geometry.py) */
                inside = PRIM_INDEX(s->prims[node->offset]);
                t_before = hit->t;
                world_p = p;
                r = instance_ray(&s->instances[inside], world);
                b = box_ray(r);
                p = primitive_ray(r);
                todo.node[todo.top++] = -1;
                i = s->instances[inside].root;
                continue;
            }
#endif
            for (int k = node->offset; k < node->offset + node->count; ++k)
                hit_primitive(s, hit, &p, PRIM_KIND(s->prims[k]), PRIM_INDEX(s->prims[k]), tmax);
        }
        do { /* a node pushed before a closer hit was found is tested again */
            if (todo.top == 0)
                return;
            i = todo.node[--todo.top];
#if HAS_INSTANCES
            if (LEAVES(i)) {
                leave_instance(s, hit, inside, t_before);
                r = world;
                b = world_box;
                p = world_p;
                inside = -1;
            }
#endif
        } while (LEAVES(i) || !meets_node(s, i, r, b, vmin(tmax, hit->t)));
    }
}

/* Whether every shape under node i is a `skip`ped rectangle: then the node is not even opened. Without
 * skipped rectangles (scenes without rectangles, lights among them) the table is not read. */
inline int skipped_subtree(const Scene *s, int i, uint skip)
{
    if (skip == 0u)
        return 0;
    uint only = s->culled_subtrees[i];
    return only != 0u && (only & ~skip) == 0u;
}

/* The lanes that a shape of leaf `node` blocks (primitive.cl's any-hit tests). */
ALWAYS_INLINE vint leaf_blocks(const Scene *s, PrimitiveRay *p, __global const BVHNode *node, uint skip)
{
    vint blocked = (vint)(0);
    for (int k = node->offset; k < node->offset + node->count; ++k)
        blocked |= primitive_blocks(s, p, PRIM_KIND(s->prims[k]), PRIM_INDEX(s->prims[k]), skip);
    return blocked;
}

/* Whether a lane of a shadow packet that is still unsettled meets node j's box. */
inline int unsettled_meets(const Scene *s, int j, Ray r, BoxRay b, vint settled)
{
    COUNT_VISIT(s, VISITS_SHADOW_NODES);
    return ANY(meets_box(&s->nodes[j], r, b, (vfloat)(1.0f)) & !settled);
}

/* Whether a shadow packet enters node j: the node is not skipped and a lane still unsettled meets its box. */
inline int enters(const Scene *s, int j, Ray r, BoxRay b, uint skip, vint settled)
{
    return !skipped_subtree(s, j, skip) && unsettled_meets(s, j, r, b, settled);
}

/* intersect.cl's occluded() over the subtree of node i (the root, or where a sweep says every blocker must lie:
 * shadow_sweep.cl): the `skip`ped rectangles are not tested, nor the subtrees that hold nothing else (a room's
 * walls). Lanes outside `active` count as settled from the start, so they open no node: a packet's traversal is the
 * union of its active rays' only. An opened node's two children are tested together, and only those the packet
 * enters are visited (the second pushed, without the lanes that met it: a shadow ray needs no distance to cull by):
 * the two box tests are independent, so they overlap in the CPU's pipeline, and a missed child costs no trip
 * through the stack. Against testing each child when it is popped, this saves time on mesh_cornell and the
 * 10^6-triangle torus of `bench --scaling`, and changes nothing beyond the noise on scene 0 (measured in commit
 * 3377fc4). */
inline vint bvh_occluded(const Scene *s, int i, Ray r, uint skip, vint active PASSES_PARAMETER OWN_PARAMETER)
{
    BoxRay b = box_ray(r);
    PrimitiveRay p = shadow_primitive_ray(r PASSES(SELECT((vint)(0), passes, active)) OWN(own));
    vint settled = !active;
    NodeStack todo = {.top = 0};
#if HAS_INSTANCES /* instances are entered as bvh_closest_hit enters them; a segment keeps t in (0, 1) there */
    const Ray world = r;
    const BoxRay world_box = b;
#endif
    if (!enters(s, i, r, b, skip, settled))
        return settled & active;
    for (;;) {
        __global const BVHNode *node = &s->nodes[i];
        if (node->count <= 0) {
            int first, second = order_children(s->nodes, i, b.negative, 1, &first);
            int in_first = enters(s, first, r, b, skip, settled), in_second = enters(s, second, r, b, skip, settled);
            if (enter_children(&todo, &i, first, second, in_first, in_second))
                continue;
        } else {
#if HAS_INSTANCES
            if (PRIM_KIND(s->prims[node->offset]) == SHAPE_INSTANCE) {
                __global const Instance *in = &s->instances[PRIM_INDEX(s->prims[node->offset])];
                r = instance_ray(in, world);
                b = box_ray(r);
                p.r = r; /* the passes counted so far go on */
#if HAS_TRIANGLES
                p.sheared = 0;
#endif
                todo.node[todo.top++] = -1;
                i = in->root;
                continue;
            }
#endif
            settled |= leaf_blocks(s, &p, node, skip);
            if (ALL(settled))
                break;
        }
        do {
            if (todo.top == 0)
                return settled & active;
            i = todo.node[--todo.top];
#if HAS_INSTANCES
            if (LEAVES(i)) {
                r = world;
                b = world_box;
                p.r = r;
#if HAS_TRIANGLES
                p.sheared = 0;
#endif
            }
#endif
        } while (LEAVES(i));
    }
    return settled & active;
}

#endif
