"""BVH traversal (kernels/bvh.cl) against the plain loop over every shape (intersect.cl without HAS_BVH):
the same closest hit, ray by ray, and the same shadow answers, at both lane widths.

The two paths call the very same per-primitive tests, so their results must agree exactly: the BVH only
decides which primitives are tested. A traversal that skips a subtree it should enter (a box test that is
too tight, a wrong child order with a stale tmax, a stack slip) loses hits; one that culls with the wrong
t loses the nearest hit. Rays are random (origins inside and around the mesh, all directions), so packets of
8 are incoherent: the worst case for masked packet traversal."""
import dataclasses

import numpy as np
import pytest

from helpers import planar
from raytrace import structs
from raytrace.renderer import bvh
from raytrace.scene import meshgen
from raytrace.scene import Triangle
from raytrace.renderer.geometry import bvh_structs, triangle_soup
from raytrace.renderer.scene_tables import scene_tables
from raytrace.renderer.program import Features
from raytrace.commands.stability.probe import scene_args

SOURCE = """
#include "intersect.cl"
__kernel void trace(int n, SCENE_PARAMETERS, uint skip, __global const float *o, __global const float *d,
                    __global const float *active, __global float *t, __global float *nrm, __global float *material,
                    __global float *blocked, __global float *blocked_skipping, __global float *blocked_active)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    Ray r = {IN3(o), IN3(d)};
    vint every = (vfloat)(0.0f) == 0.0f;
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    OUT(t, hit.t);
    OUT3(nrm, hit.n);
    OUT(material, CONVERT_VFLOAT(hit.material));
    OUT(blocked, MASK_TO_ONE(occluded(&s, r, 0u, every))); /* the segment from o to o + d */
    OUT(blocked_skipping, MASK_TO_ONE(occluded(&s, r, skip, every))); /* the same without the skipped rectangles */
    OUT(blocked_active, MASK_TO_ONE(occluded(&s, r, skip, IN(active) > 0.0f))); /* and only where active */
}
"""


@pytest.fixture(scope="module")
def mesh_scene(cornell):
    """Scene 0 with a displaced torus of 10^4 triangles in the room: all three shape kinds."""
    torus = meshgen.torus(10_000)
    vertices = torus.vertices * 0.4 + [0.0, 0.2, 1.0]
    triangles = [Triangle(vertices[f], material=1) for f in torus.faces]
    return dataclasses.replace(cornell, triangles=cornell.triangles + triangles)


GRID_LINES = np.arange(9, dtype=np.float64) * 0.25 - 1.0  # x and y of flat_grid's vertices, before the offset


def flat_grid(cornell, offset=0.0):
    """Scene 0's camera and light over nothing but 128 flat triangles at z = 0.5: two per cell of the grid
    GRID_LINES x GRID_LINES, moved by `offset` in x and y. Their boxes have lo == hi in z and share faces."""
    corners = np.stack(np.meshgrid(GRID_LINES, GRID_LINES, indexing="ij"), -1)
    quads = np.stack([corners[:-1, :-1], corners[1:, :-1], corners[1:, 1:], corners[:-1, 1:]], 2).reshape(-1, 4, 2)
    flat = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) + offset
    vertices = np.concatenate([flat, np.full((len(flat), 3, 1), 0.5)], -1)
    return dataclasses.replace(cornell, rectangles=[], ellipsoids=[], triangles=[Triangle(v) for v in vertices])


def trace(harness, scene, o, d, use_bvh, skip=0, active=None):
    active = np.ones(len(o)) if active is None else active
    args = {**scene_args(scene, features=Features(bvh=use_bvh)), "skip": np.uint32(skip), "o": planar(o),
            "d": planar(d), "active": active.astype(np.float32)}
    return harness.run(SOURCE, "trace", len(o), args,
                       {"t": 1, "nrm": 3, "material": 1, "blocked": 1, "blocked_skipping": 1, "blocked_active": 1},
                       HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1, HAS_BVH=int(use_bvh))


@pytest.mark.parametrize("skip", [0b11111, 0b10110])
def test_bvh_agrees_with_the_loop(harness, mesh_scene, skip):
    """Also with rectangles skipped (scene 0's five walls are rectangles 0-4): all of them, so that the
    subtrees holding only walls are not opened, and some, so that a subtree holding a wall still tested
    must be. The shadow test traces only its active lanes: the others answer 0 (unblocked), the rest as
    when every lane is traced."""
    rng = np.random.default_rng(31)
    n = 4096
    o = rng.uniform([-0.95, -0.95, 0.05], [0.95, 0.95, 1.9], (n, 3))
    d = rng.normal(size=(n, 3)) * rng.uniform(0.05, 2.0, (n, 1))  # segment lengths for the shadow test
    o, d = (a.astype(np.float32).astype(np.float64) for a in (o, d))
    active = rng.uniform(size=n) < 0.6
    loop = trace(harness, mesh_scene, o, d, False, skip, active)
    tree = trace(harness, mesh_scene, o, d, True, skip, active)
    hits_mesh = np.count_nonzero(loop["material"] == 1)
    assert hits_mesh > n // 10 and 0.1 < loop["blocked"].mean() < 0.9
    assert loop["blocked_skipping"].mean() < loop["blocked"].mean() - 0.05, "skipped walls block no segment"
    for key in ("t", "nrm", "material", "blocked", "blocked_skipping", "blocked_active"):
        np.testing.assert_array_equal(tree[key], loop[key], err_msg=key)
    np.testing.assert_array_equal(tree["blocked_active"], tree["blocked_skipping"] * active)


def test_flattened_tree_is_what_the_kernel_expects(mesh_scene):
    """The host's side of the contract bvh.cl relies on: every primitive reference once, in range; interior
    nodes' first child next, second child beyond; the depth within the kernel's stack (BVH_STACK = 64)."""
    nodes, prims, _, _ = bvh_structs(mesh_scene, True)
    counts = [len(mesh_scene.rectangles), len(mesh_scene.triangles), len(mesh_scene.ellipsoids)]
    kinds, index = prims & (structs.PRIM_KINDS - 1), prims >> structs.PRIM_KIND_BITS
    for kind, n in zip((1, 2, 3), counts):
        assert sorted(index[kinds == kind].tolist()) == list(range(n))
    depth, stack = 0, [(0, 1)]
    while stack:
        i, level = stack.pop()
        depth = max(depth, level)
        if nodes["count"][i] <= 0:
            assert nodes["offset"][i] > i + 1 and -nodes["count"][i] in (0, 1, 2)
            stack += [(i + 1, level + 1), (nodes["offset"][i], level + 1)]
    assert depth < 64
    assert bvh.sah_cost(nodes) > 0


def test_triangles_are_packed_in_leaf_order(mesh_scene):
    """The packed triangle table is in the order the leaves reference it (geometry.in_leaf_order): read leaf
    by leaf, the triangle references number the triangles 0, 1, 2, ..., and each packed triangle is the one
    the same reference named in the scene's order. Rectangles and ellipsoids keep their numbers. It fails if
    the table keeps the scene's order (the torus's faces are not in leaf order) or if the table and the
    references are renumbered differently (the traversal tests above would then disagree too)."""
    _, before, _, _ = bvh_structs(mesh_scene, True)
    tables = scene_tables(mesh_scene, features=Features(bvh=True))
    after, packed = tables["prims"], tables["triangles"]
    triangle = (after & (structs.PRIM_KINDS - 1)) == 2
    np.testing.assert_array_equal(after[~triangle], before[~triangle])
    np.testing.assert_array_equal(after[triangle] >> structs.PRIM_KIND_BITS, np.arange(np.count_nonzero(triangle)))
    scene_order = triangle_soup(mesh_scene).v[before[triangle] >> structs.PRIM_KIND_BITS].astype(np.float32)
    for k in range(3):
        np.testing.assert_array_equal(packed[f"v{k}"], scene_order[:, k])
    assert not np.array_equal(before[triangle] >> structs.PRIM_KIND_BITS, np.arange(np.count_nonzero(triangle)))


def test_rays_in_box_faces(harness, cornell):
    """Rays parallel to an axis with their origin exactly in the planes of the boxes' faces: flat triangles
    on a grid (their boxes have lo == hi in z, and share x and y faces), rays straight down through the
    grid's lines and vertices, and rays along x in the grid's plane. A zero direction component makes the
    slab distances 0 * inf = NaN there: a box test that lets the NaN pick the other infinity misses every one
    of these (measured: all 64 downward rays lost)."""
    k = GRID_LINES
    scene = flat_grid(cornell)
    rng = np.random.default_rng(37)
    n = 128
    down = np.stack([rng.choice(k, n // 2), rng.uniform(-1, 1, n // 2), np.full(n // 2, 1.0)], 1)
    down[::2, 1] = rng.choice(k, n // 4)  # through vertices too
    along = np.stack([np.full(n // 2, -2.0), rng.choice(k, n // 2), np.full(n // 2, 0.5)], 1)
    o = np.concatenate([down, along])
    d = np.concatenate([np.tile([0.0, 0.0, -2.0], (n // 2, 1)), np.tile([4.0, 0.0, 0.0], (n // 2, 1))])
    loop = trace(harness, scene, o, d, False)
    tree = trace(harness, scene, o, d, True)
    assert np.isfinite(loop["t"][: n // 2]).all()
    for key in ("t", "blocked"):
        np.testing.assert_array_equal(tree[key], loop[key], err_msg=key)


def test_rays_far_from_the_origin(harness, cornell):
    """Slanted rays close by the vertices of a grid of flat triangles 1000 units from the origin (through
    them, but for the origin's rounding to float32, 6e-5 there): most hits lie within 1e-4 of their
    triangle box's edges, and o / d, up to 1e5 for direction components of 0.01, dwarfs the hit distances
    (about 1). The slab distances of the box test must not round by more than the test widens them: the
    subtract-then-multiply form rounds each by a few ulps of itself, a multiply-add form (o / d rounded
    once per ray, then subtracted: one operation less a slab) by an ulp of o / d, 1e-3 here. Measured: that
    form widened by 2 gamma(3) of the distance (this one by 2 gamma(8)) loses 101 to 128 of the 256 hits (by
    lane width). The widening itself is not what this checks: here the kernel's form finds every hit without
    it."""
    k = GRID_LINES
    scene = flat_grid(cornell, offset=1000.0)
    rng = np.random.default_rng(41)
    n = 256
    through = np.stack([rng.choice(k[1:-1], n) + 1000.0, rng.choice(k[1:-1], n) + 1000.0, np.full(n, 0.5)], 1)
    across = rng.choice([-1, 1], (n, 2)) * rng.uniform(0.01, 0.2, (n, 2))
    d = np.column_stack([across, -np.ones(n)])
    o = through - d
    loop = trace(harness, scene, o, d, False)
    tree = trace(harness, scene, o, d, True)
    assert np.isfinite(loop["t"]).mean() > 0.95
    for key in ("t", "blocked"):
        np.testing.assert_array_equal(tree[key], loop[key], err_msg=key)


def test_the_widening_keeps_rays_through_shared_box_faces(harness, cornell):
    """Slanted rays through the vertices and edges of a height field (the grid GRID_LINES, two triangles a
    cell, each vertex at a random height in [0.3, 0.7]): its triangles' boxes are not flat, and neighbours
    share their x and y faces, so a ray through a vertex or edge meets the boxes there in a single point,
    where the slab distances' rounding can put near a few ulps past far. The box test widens far by
    2 gamma(8) (WIDENED, ray.h; pbrt-v4 section 6.8.2 does so too) to keep that box; the loop over all
    triangles needs no box, so the two must agree on every ray. Measured without the widening: 5 to 31 of
    4096 such rays disagreed per scene, so at least one of these 16384 all but certainly does."""
    k = GRID_LINES
    rng = np.random.default_rng(43)
    z = rng.uniform(0.3, 0.7, (len(k), len(k)))
    corners = np.concatenate([np.stack(np.meshgrid(k, k, indexing="ij"), -1), z[..., None]], -1)
    quads = np.stack([corners[:-1, :-1], corners[1:, :-1], corners[1:, 1:], corners[:-1, 1:]], 2).reshape(-1, 4, 3)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    scene = dataclasses.replace(cornell, rectangles=[], ellipsoids=[], triangles=[Triangle(v) for v in triangles])
    n = 16384
    i, j = rng.integers(1, len(k) - 1, n), rng.integers(1, len(k) - 1, n)
    along = rng.uniform(0, 1, (n, 1))
    through = np.where((np.arange(n) % 2 == 0)[:, None], corners[i, j],  # a vertex, or a point on an edge
                       corners[i, j] * (1 - along) + corners[i + 1, j] * along)
    d = rng.normal(size=(n, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 0.05
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = through - d * rng.uniform(0.5, 3, (n, 1))
    loop = trace(harness, scene, o, d, False)
    tree = trace(harness, scene, o, d, True)
    assert np.isfinite(loop["t"]).mean() > 0.5
    for key in ("t", "blocked"):
        np.testing.assert_array_equal(tree[key], loop[key], err_msg=key)


def test_culled_subtrees_against_a_walk_of_the_tree(cornell):
    """culling.culled_subtrees against a recursive walk that collects every primitive under each node: the
    rectangles' bits where all of them are rectangles among the first 32, else 0. The scene mixes 40 small
    rectangles (8 beyond the first 32), triangles and an ellipsoid, so that leaves and subtrees of every
    kind occur."""
    rng = np.random.default_rng(5)
    rects = [dataclasses.replace(cornell.rectangles[0], center=c, size=np.array([0.05, 0.05]))
             for c in rng.uniform(-1, 1, (40, 3))]
    triangles = [Triangle(r.center + rng.normal(scale=0.05, size=(3, 3))) for r in rects[::2]]  # beside them
    scene = dataclasses.replace(cornell, rectangles=rects, triangles=triangles)
    nodes, prims, culled, _ = bvh_structs(scene, True)

    def under(i):
        first, count = nodes["offset"][i], nodes["count"][i]
        return [int(r) for r in prims[first:first + count]] if count > 0 else under(i + 1) + under(first)

    kinds = set()
    for i in range(len(nodes)):
        refs = under(i)
        ok = all(ref % structs.PRIM_KINDS == 1 and ref // structs.PRIM_KINDS < 32 for ref in refs)
        assert culled[i] == (sum(1 << (ref // structs.PRIM_KINDS) for ref in set(refs)) if ok else 0), i
        kinds.add((ok, nodes["count"][i] > 0, any(ref % structs.PRIM_KINDS == 1 and ref // structs.PRIM_KINDS < 32 for ref in refs)))
    assert kinds >= {(True, True, True), (True, False, True), (False, True, True), (False, False, True)}, \
        "cullable-only and mixed leaves and subtrees"
