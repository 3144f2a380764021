"""The sweep of a packet's shadow segments towards a light (kernels/shadow_sweep.cl), at every lane width.

Its promise is containment: every point of every segment that lights_sum traces from the packet's origins to
the light lies in the volume, so that no leaf it misses can hold a blocker. The tests check that promise
point by point, check that the volume is not simply everything (boxes clearly outside it, by a float64
reference of the same volume, are missed), and check the renderer's use of it against the plain traversal:
the same blocked lanes, segment by segment."""
import dataclasses

import numpy as np
import pytest

from helpers import planar, run_int_kernel, values_kernel
from raytrace import structs
from raytrace.renderer.packing import light_structs
from raytrace.renderer.program import Features
from raytrace.scene import Light, Triangle, meshgen
from raytrace.commands.stability.probe import scene_args

SOURCE = """
#include "intersect.cl"
/* The segments lights_sum traces from each work-item's origins to its light's points uv. */
__kernel void segments(int n, __global const Light *lights, __global const float *o, __global const float *uv,
                       __global float *ro, __global float *rd)
{
    __global const Light *light = &lights[get_global_id(0)];
    vec2 u = {IN(uv), IN(uv + n)};
    Ray r = shadow_segment(IN3(o), light_point(light, u), light_point_error(light), v3_uniform(light->shape.normal));
    OUT3(ro, r.o);
    OUT3(rd, r.d);
}

/* Whether the sweep from each work-item's origins to its light meets the box of each of its lanes. */
__kernel void meets(int n, __global const Light *lights, __global const BVHNode *nodes, __global const float *o,
                    __global float *met)
{
    Scene s = {.nodes = nodes};
    __global const Light *light = &lights[get_global_id(0)];
    Sweep w = shadow_sweep(light, light_point_error(light), IN3(o), (vfloat)(0.0f) == 0.0f);
    for (int k = 0; k < LANES; ++k) {
        int j = get_global_id(0) * LANES + k;
        met[j] = sweep_meets(&s, &w, j);
    }
}

/* How many leaves swept_leaves lists for the sweep from each work-item's origins to its light over the tree
 * `nodes` (-1: too many, or too deep to reach), and the node it says every blocker lies under. */
__kernel void swept(int n, __global const Light *lights, __global const BVHNode *nodes, __global const float *o,
                    __global float *leaves, __global float *start)
{
    Scene s = {.nodes = nodes};
    __global const Light *light = &lights[get_global_id(0)];
    Sweep w = shadow_sweep(light, light_point_error(light), IN3(o), (vfloat)(0.0f) == 0.0f);
    SweptLeaves met = swept_leaves(&s, &w, 0u);
    OUT(leaves, (vfloat)(met.n));
    OUT(start, (vfloat)(met.start));
}

/* A sample's blocked lanes as lights_sum finds them for one of `samples` light samples (among the sweep's
 * leaves), and by the plain traversal, from the origins of the active lanes to light 0's points uv; the
 * number of leaves the sweep met. */
__kernel void shadows(int n, SCENE_PARAMETERS, int samples, __global const float *o, __global const float *uv,
                      __global const float *active, __global float *swept, __global float *traversed,
                      __global float *leaves)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 origin = IN3(o);
    vint lanes = IN(active) > 0.0f;
    uint skip = rectangles_out_of_reach(&s, lights, origin, lanes);
    SweptLeaves candidates = shadow_candidates(&s, lights, light_point_error(lights), origin, lanes, skip, samples);
    vec2 u = {IN(uv), IN(uv + n)};
    Ray r = shadow_segment(origin, light_point(lights, u), light_point_error(lights), v3_uniform(lights->shape.normal));
    vint blocked = (vint)(0);
    if (candidates.n != 0)
        blocked = occluded_among(&s, &candidates, r, skip, lanes);
    OUT(swept, MASK_TO_ONE(blocked));
    OUT(traversed, MASK_TO_ONE(occluded(&s, r, skip, lanes)));
    OUT(leaves, (vfloat)(candidates.n));
}
"""

LARGEST_BELOW_ONE = np.nextafter(np.float32(1), np.float32(0))


def random_lights(rng, count, scale, axis_aligned=False):
    """Lights of random orientation (or facing +-z, edges along x and y) and size, `scale` away from the
    origin at most."""
    lights = []
    for _ in range(count):
        normal = np.array([0.0, 0.0, rng.choice([-1.0, 1.0])]) if axis_aligned else rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        tangent = np.array([1.0, 0.0, 0.0]) if axis_aligned else np.cross(normal, rng.normal(size=3))
        tangent /= np.linalg.norm(tangent)
        lights.append(Light(center=rng.uniform(-scale, scale, 3), size=rng.uniform(0.05, 1.0, 2) * scale / 4,
                            normal=normal, tangent=tangent))
    return light_structs(lights)


def packets(rng, count, lanes, scale):
    """Origins of `count` packets: each around its own centre, spread by 1e-4 to 0.3 of the scale (a tile of
    pixels on one surface, or rays that have little in common)."""
    centres = rng.uniform(-scale, scale, (count, 1, 3))
    spread = scale * 10.0 ** rng.uniform(-4, np.log10(0.3), (count, 1, 1))
    return (centres + spread * rng.uniform(-1, 1, (count, lanes, 3))).reshape(-1, 3)


def light_box(light):
    """The light's own box, c +- (|t| hx + |b| hy), in float64."""
    shape = light["shape"]
    c, t, b = (np.array(shape[k].tolist(), np.float64) for k in ("center", "tangent", "bitangent"))
    ext = np.abs(t) * shape["half_x"] + np.abs(b) * shape["half_y"]
    return c - ext, c + ext


def point_boxes(p):
    """float32 boxes around the float64 points p, rounded outwards as the BVH's are (renderer/bvh.py)."""
    lo, hi = p.astype(np.float32), p.astype(np.float32)
    lo = np.where(lo > p, np.nextafter(lo, np.float32(-np.inf)), lo)
    hi = np.where(hi < p, np.nextafter(hi, np.float32(np.inf)), hi)
    nodes = np.zeros(len(p), structs.BVH_NODE)
    nodes["lo"], nodes["hi"] = lo, hi
    return nodes


def sweep_meets_reference(o_lo, o_hi, l_lo, l_hi, b_lo, b_hi):
    """float64: whether the box (1 - t) O + t L overlaps B for some t in [0, 1]. On each axis, lo(t) <= b_hi
    and hi(t) >= b_lo are linear in t: each keeps t on one side of a root, or holds everywhere or nowhere."""
    lower, upper = np.zeros(len(b_lo)), np.ones(len(b_lo))
    for start, end, bound, sign in ((o_lo, l_lo, b_hi, 1.0), (o_hi, l_hi, b_lo, -1.0)):
        # sign * (start + t (end - start) - bound) <= 0
        slope, value = sign * (end - start), sign * (start - bound)
        with np.errstate(divide="ignore", invalid="ignore"):
            root = -value / slope
        upper = np.minimum(upper, np.where(slope > 0, root, np.inf).min(1))
        lower = np.maximum(lower, np.where(slope < 0, root, -np.inf).max(1))
        lower = np.where(((slope == 0) & (value > 0)).any(1), np.inf, lower)
    return lower <= upper


@pytest.mark.parametrize("scale,near_plane", [(1.0, False), (1e3, False), (1e4, True)])
def test_segments_lie_in_their_sweep(harness, lanes, scale, near_plane):
    """Points of the very segments lights_sum traces (shadow_segment towards light_point, with the light's
    corners among the samples: uv 0 and the float below 1), at t = 0, 1/2 and 1: each inside the sweep of its
    packet, as a box no larger than its float32 rounding. The segment's end lies off the light by the offset
    that keeps it from the light's own surface, and its direction rounds: the sweep's light box is widened by
    bounds on both (shadow_sweep.cl). Far from the origin (scale 1e3) the roundings are larger; hardest where
    packets lie within 1e-6 to 1e-3 of the scale from the plane of a light 1e4 away, facing +-z (the
    segments run almost in the plane, and the sweep's sides along z barely move)."""
    rng = np.random.default_rng(5)
    count = 2048 // lanes
    lights = random_lights(rng, count, scale, axis_aligned=near_plane)
    o = packets(rng, count, lanes, scale)
    if near_plane:  # each packet beside its light, just off its plane on either side
        centre = lights["shape"]["center"].astype(np.float64)
        off = rng.uniform(-scale / 2, scale / 2, (count, 3))
        off[:, 2] = rng.choice([-1.0, 1.0], count) * scale * 10.0 ** rng.uniform(-6, -3, count)
        o = (np.repeat(centre + off, lanes, 0) + rng.uniform(-1e-4, 1e-4, (len(o), 3)) * scale * [1, 1, 0])
    uv = rng.uniform(0, 1, (len(o), 2))
    uv[::3] = rng.choice([0.0, LARGEST_BELOW_ONE], (len(uv[::3]), 2))
    segment = harness.run(SOURCE, "segments", len(o), [lights, planar(o), planar(uv).ravel()], {"ro": 3, "rd": 3},
                          HAS_BVH=1)
    ro, rd = segment["ro"].T, segment["rd"].T
    for t in (0.0, 0.5, 1.0):
        met = harness.run(SOURCE, "meets", len(o), [lights, point_boxes(ro + t * rd), planar(o)], {"met": 1},
                          HAS_BVH=1)["met"]
        assert met.all(), f"t = {t}: {np.count_nonzero(met == 0)} of {len(met)} points outside their sweep"


def test_sweep_misses_what_lies_outside(harness, lanes):
    """Random boxes near the segments against the float64 volume between the packet's box and the light's:
    those it meets are met, those it misses even with the light's box widened by 1e-4 are missed (the kernel's
    own widening is a few float32 roundings). Both kinds are common, so a sweep that meets everything fails."""
    rng = np.random.default_rng(8)
    count = 4096 // lanes
    lights = random_lights(rng, count, 1.0)
    o = packets(rng, count, lanes, 1.0)
    per_packet = o.reshape(count, lanes, 3)
    o_lo, o_hi = (np.repeat(f(per_packet, 1), lanes, 0) for f in (np.min, np.max))
    l_lo, l_hi = (np.repeat(b, lanes, 0) for b in np.transpose([light_box(light) for light in lights], (1, 0, 2)))
    # boxes around points between the two boxes, moved by about 0.05 (the scene spans 2)
    t = rng.uniform(0, 1, (len(o), 1))
    centres = (1 - t) * rng.uniform(o_lo, o_hi) + t * rng.uniform(l_lo, l_hi) + rng.normal(0, 0.05, (len(o), 3))
    half = 10.0 ** rng.uniform(-4, -1, (len(o), 3))
    boxes = np.zeros(len(o), structs.BVH_NODE)
    boxes["lo"], boxes["hi"] = centres - half, centres + half
    met = harness.run(SOURCE, "meets", len(o), [lights, boxes, planar(o)], {"met": 1}, HAS_BVH=1)["met"]
    b_lo, b_hi = boxes["lo"].astype(np.float64), boxes["hi"].astype(np.float64)
    inside = sweep_meets_reference(o_lo, o_hi, l_lo, l_hi, b_lo, b_hi)
    outside = ~sweep_meets_reference(o_lo, o_hi, l_lo - 1e-4, l_hi + 1e-4, b_lo, b_hi)
    assert 0.1 < inside.mean() < 0.9 and outside.mean() > 0.1
    assert met[inside].all(), f"{np.count_nonzero(met[inside] == 0)} boxes inside the sweep missed"
    assert not met[outside].any(), f"{np.count_nonzero(met[outside])} boxes outside the sweep met"


def above_the_origins():
    """Origins of 4 packets of up to 16 lanes around the origin, and 4 copies of a light above them at z = 2."""
    rng = np.random.default_rng(5)
    return rng.uniform(-0.05, 0.05, (64, 3)), light_structs(
        [Light(center=[0.0, 0.0, 2.0], size=[0.4, 0.4], normal=[0.0, 0.0, -1.0], tangent=[1.0, 0.0, 0.0])] * 4)


def chain(depth):
    """A tree whose sweep (below) must open `depth` interior nodes to reach its one leaf on the way: interior
    node 2k holds everything, its first child 2k + 1 is a leaf far off the sweep, its second 2k + 2 the next
    interior node, and node 2 depth the leaf in the sweep's path."""
    nodes = np.zeros(2 * depth + 1, structs.BVH_NODE)
    nodes["lo"], nodes["hi"] = -10.0, 10.0
    nodes["offset"][:-1:2] = np.arange(2, 2 * depth + 1, 2)  # the second child; the first is the next node
    nodes["count"][1::2] = 1
    nodes["lo"][1::2], nodes["hi"][1::2] = 5.0, 6.0
    nodes["count"][-1] = 1
    nodes["lo"][-1], nodes["hi"][-1] = [-0.1, -0.1, 0.9], [0.1, 0.1, 1.1]
    return nodes


def test_a_sweep_gives_up_past_its_opened_nodes(harness, lanes, cl_env):
    """A sweep that must open more than SWEEP_OPENED interior nodes to find its leaves (a packet starting among
    a fine mesh's) gives up (-1: each sample traverses the tree, which tests the same leaves), one that opens
    SWEEP_OPENED lists its leaf. It fails if the limit is off by one or missing."""
    limit = run_int_kernel(cl_env, '#include "shadow_sweep.cl"\n' + values_kernel(["SWEEP_OPENED"]), 1)[0]
    o, lights = above_the_origins()
    o = o[:4 * lanes]
    for depth, expected in ((limit, 1), (limit + 1, -1)):
        leaves = harness.run(SOURCE, "swept", len(o), [lights, chain(depth), planar(o)], {"leaves": 1, "start": 1},
                             HAS_BVH=1)["leaves"]
        np.testing.assert_array_equal(leaves, expected, err_msg=f"{depth} interior nodes deep")


def test_a_sweep_that_gives_up_says_where_blockers_lie(harness, lanes, cl_env):
    """Where a sweep gives up, each sample traverses from `start`, the deepest node whose subtree holds every
    node the sweep met. Down a chain of nodes that each enter one child, it is the node where the sweep gave
    up (2 SWEEP_OPENED: the nodes above it and their other children lie off the sweep); with a leaf met
    beside the chain, under a root split along z that lists that leaf first (far first, from the light), it
    stays the root. It fails if start moves past a listed leaf or is not set."""
    limit = run_int_kernel(cl_env, '#include "shadow_sweep.cl"\n' + values_kernel(["SWEEP_OPENED"]), 1)[0]
    o, lights = above_the_origins()
    o = o[:4 * lanes]
    out = harness.run(SOURCE, "swept", len(o), [lights, chain(limit + 1), planar(o)], {"leaves": 1, "start": 1},
                      HAS_BVH=1)
    np.testing.assert_array_equal(out["leaves"], -1)
    np.testing.assert_array_equal(out["start"], 2 * limit)
    beside = np.zeros(1, structs.BVH_NODE)
    beside["lo"], beside["hi"], beside["count"] = [-0.1, -0.1, 1.5], [0.1, 0.1, 1.6], 1
    inner = chain(limit + 1)
    inner["offset"][inner["count"] <= 0] += 1  # one node further down: the root comes first
    root = np.zeros(1, structs.BVH_NODE)
    root["lo"], root["hi"], root["count"], root["offset"] = -10.0, 10.0, -2, 1 + len(inner)
    tree = np.concatenate([root, inner, beside])
    out = harness.run(SOURCE, "swept", len(o), [lights, tree, planar(o)], {"leaves": 1, "start": 1}, HAS_BVH=1)
    np.testing.assert_array_equal(out["leaves"], -1)
    np.testing.assert_array_equal(out["start"], 0)


@pytest.fixture(scope="module")
def torus_room(cornell):
    """Scene 0 with a torus of 10^4 triangles under its light: packets whose sweeps meet no leaf, a few, or
    more than the kernel keeps."""
    torus = meshgen.torus(10_000)
    vertices = torus.vertices * 0.4 + [0.0, 0.2, 1.0]
    return dataclasses.replace(cornell, triangles=cornell.triangles + [Triangle(vertices[f]) for f in torus.faces])


def test_swept_shadows_agree_with_traversal(harness, lanes, torus_room):
    """lights_sum's shadow test through the sweep's leaves against the plain traversal of the same segments,
    lane by lane: the sweep only leaves out leaves, the primitive tests decide, so the answers must agree
    exactly. Packets of every spread, from anywhere in the room, some lanes inactive; the light's points at
    random and at its corners. With one light sample there is no sweep: every packet traverses the tree. (At
    one lane, 2% of the sweeps list leaves: one ray's sweep reaches the torus's leaves, a dozen levels down,
    only past SWEEP_OPENED interior nodes.)"""
    rng = np.random.default_rng(17)
    count = 4096 // lanes
    o = packets(rng, count, lanes, 0.95) + [0.0, 0.0, 0.95]
    o[: len(o) // 2] = packets(rng, count // 2, lanes, 0.5) + [0.0, 0.2, 1.0]  # half of them around the torus
    uv = rng.uniform(0, 1, (len(o), 2))
    uv[::4] = rng.choice([0.0, LARGEST_BELOW_ONE], (len(uv[::4]), 2))
    active = (rng.uniform(size=len(o)) < 0.8).astype(np.float32)
    args = {**scene_args(torus_room, features=Features(bvh=True)), "samples": np.int32(16), "o": planar(o),
            "uv": planar(uv).ravel(), "active": active}
    outputs = {"swept": 1, "traversed": 1, "leaves": 1}
    shapes = dict(HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1, HAS_BVH=1)
    out = harness.run(SOURCE, "shadows", len(o), args, outputs, **shapes)
    leaves = out["leaves"][::lanes]
    assert 0.1 < out["traversed"][active > 0].mean() < 0.9
    assert (leaves == -1).mean() > 0.05 and (leaves == 0).mean() > 0.05 and (leaves > 0).mean() > 0.01
    np.testing.assert_array_equal(out["swept"], out["traversed"])
    single = harness.run(SOURCE, "shadows", len(o), {**args, "samples": np.int32(1)}, outputs, **shapes)
    np.testing.assert_array_equal(single["leaves"], -1)  # one sample: no sweep, the whole tree
    np.testing.assert_array_equal(single["swept"], out["traversed"])
