/* The volume swept by a packet's shadow segments towards one light, traversed once per packet and light: the
 * BVH's leaves it meets are then the only ones each of the light's samples needs to test (Benthin and Wald,
 * "Efficient Ray Traced Soft Shadows using Multi-Frusta Tracing", HPG 2009, trace a frustum per packet and
 * light the same way). Every segment runs from a lane's origin o, in the box O of the packet's origins, to a
 * point near the light, in a box L around it; at t in [0, 1] it is at (1 - t) o + t e, within the box
 * (1 - t) O + t L. That moving box sweeps a volume holding every segment of every sample, and a node the
 * volume misses holds nothing that can block one. Where the volume meets a handful of leaves (most packets:
 * the floor seen by a light with nothing in between), a sample tests only their boxes and shapes, or
 * nothing at all; where it meets more than SWEEP_LEAVES (a packet on a finely meshed surface: its segments
 * start among the mesh's leaves), each sample traverses the tree as before (bvh.cl). The blocked lanes are
 * the same either way: the primitive tests decide, the sweep only leaves out leaves no segment reaches. */
#ifndef SHADOW_SWEEP_CL
#define SHADOW_SWEEP_CL

#include "bvh.cl"
#include "lights.cl"

/* More leaves than this, and each sample traverses the tree. Against 16, the 10^3-triangle torus of
 * `bench --scaling` takes less time (a sweep that overflows stops sooner), scene 0 and mesh_cornell the same;
 * 6 leaves cost mesh_cornell time (measured in commit 2c05cce). */
#define SWEEP_LEAVES 8

/* Nor may a sweep open more interior nodes than this: one that must (a packet whose segments start among a
 * fine mesh's leaves) mostly ends with too many leaves anyway, and gives up sooner. Against no limit, the tori
 * of `bench --scaling` take less time at 10^3, 10^5 and 10^6 triangles, scene 0, textured_cornell and
 * mesh_cornell the same within the noise; 6, 16 and 24 were no better (measured in commit 4db479c). */
#define SWEEP_OPENED 12

/* The box (1 - t) O + t L: on each axis its low side moves from O's low to L's, its high side from O's high to
 * L's. A node's box [b0, b1] overlaps it where lo(t) <= b1 and hi(t) >= b0: each a bound on t, above or below
 * by the sign of the side's motion. */
typedef struct {
    float3 o_lo, o_hi;          /* O */
    float3 inv_lo, inv_hi;      /* 1 / (L_lo - O_lo), 1 / (L_hi - O_hi): +inf where a side does not move */
    int3 lo_rises, hi_rises;    /* where L_lo >= O_lo, L_hi >= O_hi (masks: where the reciprocals are > 0) */
    int negative[3];            /* the signs of the way from the origins to the light: children go far first */
} Sweep;

/* The lanes' minimum and maximum of x over `lanes` (at least one). */
inline float lanes_min(vfloat x, vint lanes) { return min_lane(SELECT((vfloat)(INFINITY), x, lanes)); }
inline float lanes_max(vfloat x, vint lanes) { return max_lane(SELECT((vfloat)(-INFINITY), x, lanes)); }

/* The sweep from the origins of `lanes` to light, whose points lie within q_err of its plane
 * (light_point_error): L is the light's box widened by where a shadow segment can
 * end (lights.cl). A sample point q is within gamma(4) (|c| + ext) of c + du t + dv b, its ideal point in the
 * box c +- ext (light_point_error); shadow_segment pushes it off the light by err <= q_err + gamma(2) |n|.|q - o|
 * along the unit normal n (offset_ray_origin: err n_i, plus the sum's rounding and one float step, within
 * 3u (|q_i| + err |n_i|)), and the segment's end o + fl(q' - o) is within u |q' - o|_i of that point q'. With
 * reach_i >= |q - o|_i over both boxes, L = c +- (ext + m), m_i = err |n_i| + gamma(8) (|c_i| + ext_i + err +
 * reach_i), holds every end with room for the roundings of m itself. */
inline Sweep shadow_sweep(__global const Light *light, float q_err, vec3 origin, vint lanes)
{
    Sweep w;
    w.o_lo = (float3)(lanes_min(origin.x, lanes), lanes_min(origin.y, lanes), lanes_min(origin.z, lanes));
    w.o_hi = (float3)(lanes_max(origin.x, lanes), lanes_max(origin.y, lanes), lanes_max(origin.z, lanes));
    __global const Rectangle *r = &light->shape;
    float3 c = f3(r->center), n = abs3(f3(r->normal));
    float3 ext = abs3(f3(r->tangent)) * r->half_x + abs3(f3(r->bitangent)) * r->half_y;
    float3 reach_lo = abs3(c + ext - w.o_lo), reach_hi = abs3(w.o_hi - (c - ext));
    float3 reach = (1.0f + GAMMA(8)) * LANE_MAX(reach_lo, reach_hi);
    float err = (q_err + GAMMA(2) * dot3(n, reach)) * (1.0f + GAMMA(8));
    float3 m = err * n + GAMMA(8) * (abs3(c) + ext + err + reach);
    /* + 0: a side that does not move gets +0, and 1 / +0 = +inf: its bound is then O's own, on any node */
    float3 d_lo = (c - ext - m) - w.o_lo + 0.0f, d_hi = (c + ext + m) - w.o_hi + 0.0f;
    w.inv_lo = 1.0f / d_lo;
    w.inv_hi = 1.0f / d_hi;
    w.lo_rises = w.inv_lo > 0.0f; /* from the reciprocal, so that a flushed subnormal motion agrees with it */
    w.hi_rises = w.inv_hi > 0.0f;
    w.negative[0] = c.x < 0.5f * (w.o_lo.x + w.o_hi.x);
    w.negative[1] = c.y < 0.5f * (w.o_lo.y + w.o_hi.y);
    w.negative[2] = c.z < 0.5f * (w.o_lo.z + w.o_hi.z);
    return w;
}

/* The smallest (largest) of start and the components of v that are numbers: a NaN bound is ignored. */
inline float min_bound(float start, float3 v)
{
    start = LANE_MIN(start, v.x);
    start = LANE_MIN(start, v.y);
    return LANE_MIN(start, v.z);
}
inline float max_bound(float start, float3 v)
{
    start = LANE_MAX(start, v.x);
    start = LANE_MAX(start, v.y);
    return LANE_MAX(start, v.z);
}

/* Whether the sweep meets node j's box for some t in [0, 1]. Each bound rounds 8 times (the side's motion,
 * the reciprocal as 5 (ray.h), the distance and the product): within gamma(8) of itself, so widening the
 * upper end by 2 gamma(9) (and its own rounding) never misses a node the exact sweep meets (as pbrt-v4's
 * slab test, section 6.8.2). A side that does not move bounds t by +-inf (met or not at all), or by NaN where
 * it touches the node (0 * inf): a NaN bound is dropped, and so may be the other bound of its axis and kind
 * when the two are merged, which can only let more nodes in. The two bounds of an axis are merged lane-wise
 * first, so that only two minima run across the axes. */
inline int sweep_meets(const Scene *s, const Sweep *w, int j)
{
    COUNT_VISIT(s, VISITS_SHADOW_NODES);
    __global const BVHNode *node = &s->nodes[j];
    float3 lo = (float3)(node->lo[0], node->lo[1], node->lo[2]), hi = (float3)(node->hi[0], node->hi[1], node->hi[2]);
    float3 t_lo = (hi - w->o_lo) * w->inv_lo; /* where the low side passes the node's high side */
    float3 t_hi = (lo - w->o_hi) * w->inv_hi; /* where the high side passes the node's low side */
    const float3 inf = (float3)(INFINITY);
    float3 up_lo = w->lo_rises ? t_lo : inf, up_hi = w->hi_rises ? inf : t_hi;
    float3 down_lo = w->lo_rises ? -inf : t_lo, down_hi = w->hi_rises ? t_hi : -inf;
    float upper = min_bound(1.0f, LANE_MIN(up_lo, up_hi));
    float lower = max_bound(0.0f, LANE_MAX(down_lo, down_hi));
    return lower <= WIDENED(upper, 9);
}

/* The leaves a sweep meets, far first from the light's side as shadow traversals go (bvh.cl); n = -1 when
 * there are more than SWEEP_LEAVES, or it would open more than SWEEP_OPENED interior nodes to find them. Then
 * each sample traverses the tree from `start`, the deepest node the sweep reached whose subtree holds every
 * node it met (it met no other leaf and had none pushed): the nodes above it and their other children lie
 * outside the sweep, so no segment meets them. A packet on a mesh skips the levels above the mesh's subtree.
 * Against traversals from the root, shadow boxes a ray fall on the bench --scaling tori (0.68 -> 0.55 at 10^3
 * triangles, 3.11 -> 2.96 at 10^6) and on mesh_cornell (0.272 -> 0.259), and so does their time; scene 0's
 * sweeps seldom give up (measured in commit 46cdd4c). */
typedef struct { int n, start, leaf[SWEEP_LEAVES]; } SweptLeaves;

inline int sweep_enters(const Scene *s, const Sweep *w, int j, uint skip)
{
    return !skipped_subtree(s, j, skip) && sweep_meets(s, w, j);
}

inline SweptLeaves swept_leaves(const Scene *s, const Sweep *w, uint skip)
{
    SweptLeaves out = {0};
    NodeStack todo = {.top = 0};
    int i = 0, opened = 0;
    if (!sweep_enters(s, w, 0, skip))
        return out;
    for (;;) {
        if (todo.top == 0 && out.n == 0)
            out.start = i;
        __global const BVHNode *node = &s->nodes[i];
        if (node->count <= 0) {
            if (opened++ == SWEEP_OPENED) {
                out.n = -1;
                return out;
            }
            int first, second = order_children(s->nodes, i, w->negative, 1, &first);
            int in_first = sweep_enters(s, w, first, skip), in_second = sweep_enters(s, w, second, skip);
            if (enter_children(&todo, &i, first, second, in_first, in_second))
                continue;
        } else {
            if (out.n == SWEEP_LEAVES) {
                out.n = -1;
                return out;
            }
            out.leaf[out.n++] = i;
        }
        if (todo.top == 0)
            return out;
        i = todo.node[--todo.top];
    }
}

/* occluded() of one sample's segment r, given the leaves its packet's sweep met: their boxes and shapes only,
 * or the whole tree when there were too many. */
inline vint swept_occluded(const Scene *s, const SweptLeaves *leaves, Ray r, uint skip, vint active
                           PASSES_PARAMETER)
{
    if (leaves->n < 0)
        return bvh_occluded(s, leaves->start, r, skip, active PASSES(passes) OWN(-1));
    BoxRay b = box_ray(r);
    PrimitiveRay p = shadow_primitive_ray(r PASSES(SELECT((vint)(0), passes, active)) OWN(-1));
    vint settled = !active;
    for (int l = 0; l < leaves->n; ++l) {
        int i = leaves->leaf[l];
        if (!unsettled_meets(s, i, r, b, settled)) /* not skipped: the sweep entered it with the same skip */
            continue;
#if HAS_INSTANCES
        int first = s->prims[s->nodes[i].offset];
        if (PRIM_KIND(first) == SHAPE_INSTANCE) { /* its group's tree, in its space (bvh.cl) */
            __global const Instance *in = &s->instances[PRIM_INDEX(first)];
            settled |= bvh_occluded(s, in->root, instance_ray(in, r), 0u, !settled
                                    PASSES(SELECT((vint)(0), p.passes - p.passed, active)) OWN(-1));
            if (ALL(settled))
                break;
            continue;
        }
#endif
        settled |= leaf_blocks(s, &p, &s->nodes[i], skip);
        if (ALL(settled))
            break;
    }
    return settled & active;
}

#endif
