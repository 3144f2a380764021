"""The traversal counters (raytrace/commands/visits.py; COUNT_VISITS in kernels/scene.h, bvh.cl, primitive.cl and
render.cl): a measuring build of the render kernel that counts the BVH boxes and the primitives its traversals
test, per work-item, and the figures `bench` prints from them. The counts are checked exactly where the tree's shape fixes them, at every lane width
this machine runs."""
import dataclasses
import math

import numpy as np
import pytest

from raytrace.render import render
from raytrace.renderer.program import Features
from raytrace.scene import Camera, Triangle, load_file
from raytrace.renderer.device_render import FIRST_HALF_PLANE, OUTPUT_PLANES, RAYS_PLANE, VISIT_KINDS
from raytrace.renderer.progressive import pass_size
from raytrace.structs import samples_at_once, tile_shape
from raytrace.commands.visits import node_visits, pixels_with_half
from helpers import ROOT, planar, run_int_kernel, values_kernel
from path_support import furnace
from raytrace.commands.stability.probe import scene_args

# 11 x 7 pixels: the tiles of 4 x 2, 2 x 2 and 2 x 1 pixels (kernels/tile.h, with 16, 8 and 4 lanes holding 2
# samples of each pixel) reach past the image's edges, so a work-item's count is shared among fewer pixels
# than its tile holds.
SIZE = dict(width=11, height=7, spp=4, light_samples=4, progress=False)
PASS = pass_size(SIZE["spp"], 1)  # the render's pixel samples per launch
FAR = 100.0  # a triangle this far along x meets no ray of the scene below


def tile_and_group(lanes):
    """(columns, rows) of a work-item's tile of pixels and the samples of each pixel its lanes hold at once."""
    return tile_shape(lanes, PASS), samples_at_once(lanes, PASS)


def steps_and_pixels(lanes):
    """The work-items' steps per pixel sample of the SIZE image, and its pixels. Its launches are grids of
    tiles (the tiles at its edges reach past it), and a work-item takes one step per `group` samples of its
    pixels: one closest-hit traversal, one sweep per light and one shadow test per light sample, whatever
    its lanes."""
    (columns, rows), group = tile_and_group(lanes)
    work_items = math.ceil(SIZE["width"] / columns) * math.ceil(SIZE["height"] / rows)
    return work_items / group, SIZE["width"] * SIZE["height"]


def floor_scene(cornell, far_triangle):
    """A large floor triangle under scene 0's light, seen from straight above by a camera between the two:
    every camera ray meets the floor and every floor point in view sees the whole light, so every lane casts
    every shadow ray. With far_triangle, a second triangle that no ray meets, far off along x."""
    white = cornell.rectangles[0].material
    floor = Triangle(np.array([[-10.0, -10.0, 0.0], [10.0, -10.0, 0.0], [0.0, 10.0, 0.0]]), white)
    far = Triangle(np.array([[FAR, 0.0, 0.0], [FAR + 1, 0.0, 0.0], [FAR, 1.0, 0.0]]), white)
    camera = Camera(np.array([0.0, 0.0, 1.5]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 45.0, 1.0)
    return dataclasses.replace(cornell, camera=camera, rectangles=[], ellipsoids=[],
                               triangles=[floor, far] if far_triangle else [floor])



@pytest.mark.parametrize("light_samples", [1, 2, 3, 5, 6, 7, 9])
def test_every_light_sample_casts_one_shadow_ray(cornell, lanes, light_samples):
    """lights_sum (kernels/light_sampling.cl) forms light samples in groups of four before tracing them: over
    the floor, where every lane casts every shadow ray, a render traces exactly light_samples shadow rays per
    pixel sample, whether or not the count fills its last group. It fails if a group's samples past the last
    are traced or the last ones dropped."""
    scene = floor_scene(cornell, False)
    size = dict(SIZE, light_samples=light_samples)
    _, stats = render(scene, features=Features.of(scene, lanes), light_sampler="random", **size)
    camera_rays = size["width"] * size["height"] * size["spp"]
    assert stats.rays == camera_rays * (1 + light_samples)

@pytest.mark.parametrize("far_triangle,bvh,boxes,swept,primitives", [(False, True, 1, 1, 1), (True, True, 3, 3, 1),
                                                                       (True, False, 0, 0, 2)])
def test_visits_are_the_boxes_and_primitives_tested(cornell, lanes, far_triangle, bvh, boxes, swept, primitives):
    """One triangle: the BVH is one leaf, and every closest-hit traversal tests 1 box and 1 triangle. Two
    triangles: a root and two leaves, and every closest-hit traversal tests all 3 boxes (the far leaf's box is
    tested and missed) but only the floor's triangle; without a BVH, both triangles and no box. Shadow rays
    first sweep the tree once per packet and light (kernels/shadow_sweep.cl), testing `swept` boxes (the root
    alone, or the root and both leaves), and find the floor's leaf (the segments start in its plane, so the
    sweep touches it); each light sample then tests that leaf's box and triangle: 1 box and 1 primitive. A
    work-item's step traces one closest-hit traversal, one sweep per light and one shadow test per light
    sample (every lane lit), so the counts per ray are boxes (or primitives) x steps per pixel sample / pixels
    exactly: with lanes, the packets' saving. (The per-pixel shares are float32 quotients,
    summed in float64: rel 1e-6.) It fails if the counter counts lanes rather than work-items, only the nodes
    entered (2 instead of 3), the primitives of leaves missed, misses a traversal kind or the sweep, or if a
    work-item's count is divided among its lanes rather than among its pixels in the image."""
    scene = floor_scene(cornell, far_triangle)
    features = dataclasses.replace(Features.of(scene, lanes), bvh=bvh)
    visits = node_visits(scene, features, **SIZE)
    (columns, rows), group = tile_and_group(lanes)
    steps, pixels = steps_and_pixels(lanes)
    samples = SIZE["light_samples"]
    shadow_boxes = swept / samples + (1 if bvh else 0)  # per shadow ray of a work-item
    assert visits["camera_rays"] == pixels * SIZE["spp"]
    assert visits["shadow_rays"] == visits["camera_rays"] * samples  # every lane lit
    assert visits["visits_per_camera_ray"] == pytest.approx(boxes * steps / pixels, rel=1e-6)
    assert visits["visits_per_shadow_ray"] == pytest.approx(shadow_boxes * steps / pixels, rel=1e-6)
    assert visits["primitives_per_camera_ray"] == pytest.approx(primitives * steps / pixels, rel=1e-6)
    assert visits["primitives_per_shadow_ray"] == pytest.approx(primitives * steps / pixels, rel=1e-6)
    # Each pixel holds its work-item's count over the pixels it shares it with: boxes x steps (samples / group)
    # / pixels of its tile inside the image.
    y, x = np.mgrid[:SIZE["height"], :SIZE["width"]]
    tile_pixels = (np.minimum(columns, SIZE["width"] - x // columns * columns)
                   * np.minimum(rows, SIZE["height"] - y // rows * rows))
    np.testing.assert_allclose(visits["closest_hit_map"], boxes * SIZE["spp"] / group / tile_pixels, rtol=1e-6)
    np.testing.assert_allclose(visits["shadow_map"], shadow_boxes * SIZE["spp"] / group * samples / tile_pixels,
                               rtol=1e-6)


def test_closest_hits_test_a_pushed_node_again(cornell, lanes):
    """Closest-hit traversals test both children of a node they open and push the farther when both are met
    (kernels/bvh.cl); popped, it is tested again against the closer hit found since. The scene: the floor
    under a small triangle at z = 1.4 that covers the whole view of the camera above it (z = 1.5). The root
    splits them along z (SAH: 1 + (800 + 32) / 912 < 2, a leaf of both), and every camera ray meets both
    leaves' boxes: the traversal tests the root's box and both leaves', enters the near one (the cover), hits
    it at t = 0.1 and tests the floor's box again, now beyond the hit: 4 boxes, 1 primitive (per work-item). It
    fails if the pushed node is not tested again (3 boxes and the floor's triangle: 2 primitives), or if the
    children are tested one at a time, when popped (3 boxes, 1 primitive)."""
    white = cornell.rectangles[0].material
    cover = Triangle(np.array([[-2.0, -2.0, 1.4], [2.0, -2.0, 1.4], [0.0, 2.0, 1.4]]), white)
    scene = floor_scene(cornell, False)
    scene = dataclasses.replace(scene, triangles=scene.triangles + [cover])
    visits = node_visits(scene, dataclasses.replace(Features.of(scene, lanes), bvh=True), **SIZE)
    steps, pixels = steps_and_pixels(lanes)
    assert visits["visits_per_camera_ray"] == pytest.approx(4 * steps / pixels, rel=1e-6)
    assert visits["primitives_per_camera_ray"] == pytest.approx(steps / pixels, rel=1e-6)


@pytest.mark.parametrize("visit_map,fraction", [([[3, 1], [0, 0]], 1 / 4), ([[1, 1], [1, 1]], 2 / 4),
                                                ([[1, 2], [3, 2]], 2 / 4), ([[0, 0]], 0.0)])
def test_pixels_with_half_the_visits(visit_map, fraction):
    """The fewest pixels whose visits reach half of the total: 3 of 4 alone; two of four equal; 3 + 2 of 8
    (3 alone is less than half); none without visits."""
    assert pixels_with_half(np.array(visit_map, float)) == fraction


SHADOW_VISITS = """
#include "intersect.cl"
/* The boxes and primitives one shadow traversal of the whole tree (bvh.cl) tests, per work-item. */
__kernel void shadow_visits(int n, SCENE_PARAMETERS, __global const float *o, __global const float *d,
                            __global float *boxes, __global float *primitives)
{
    int visits[VISIT_KINDS] = {0};
    Scene s = SCENE_FROM_PARAMETERS;
    s.visits = visits;
    Ray r = {IN3(o), IN3(d)};
    occluded(&s, r, 0u, (vfloat)(0.0f) == 0.0f);
    OUT(boxes, (vfloat)(visits[VISITS_SHADOW_NODES]));
    OUT(primitives, (vfloat)(visits[VISITS_SHADOW_PRIMITIVES]));
}
"""


def blocked_floor(cornell):
    """A floor of 800 small triangles, seen from above, and one large triangle above the camera, below the
    light, that blocks every shadow ray. The root's split puts the floor and the blocker apart along z."""
    white = cornell.rectangles[0].material
    grid = np.linspace(-2.0, 2.0, 21)
    floor = [Triangle(np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0]]), white) for x0, x1 in zip(grid, grid[1:])
             for y0, y1 in zip(grid, grid[1:])]
    floor += [Triangle(np.array([[x0, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]), white) for x0, x1 in zip(grid, grid[1:])
              for y0, y1 in zip(grid, grid[1:])]
    blocker = Triangle(np.array([[-10.0, -10.0, 1.7], [0.0, 10.0, 1.7], [10.0, -10.0, 1.7]]), white)
    return dataclasses.replace(floor_scene(cornell, False), triangles=floor + [blocker])


def test_shadow_traversals_open_the_far_end_first(harness, cornell):
    """A shadow traversal of the tree visits a node's children far first (from the light's end, kernels/bvh.cl):
    packets of segments from tiles of the floor up to the light test the root's box and both its children's
    (the blocker's leaf and the floor's subtree), enter the blocker's leaf first and stop with every lane
    blocked: 3 boxes and 1 primitive per work-item. It fails if they go near first (they would open the floor's
    subtree around their origins first: about a dozen boxes more) or if a blocked packet does not stop."""
    rng = np.random.default_rng(3)
    tiles = rng.uniform(-1.5, 1.5, (256, 1, 2))
    xy = (tiles + rng.uniform(0, 0.02, (256, harness.lanes, 2))).reshape(-1, 2)
    o = np.column_stack([xy, np.full(len(xy), 1e-3)])
    d = np.array([0.1, 0.0, 1.9]) - o
    args = {**scene_args(blocked_floor(cornell), features=Features(bvh=True)), "o": planar(o), "d": planar(d)}
    out = harness.run(SHADOW_VISITS, "shadow_visits", len(o), args, {"boxes": 1, "primitives": 1},
                      HAS_TRIANGLES=1, HAS_BVH=1, COUNT_VISITS=1)
    np.testing.assert_array_equal(out["boxes"], 3)
    np.testing.assert_array_equal(out["primitives"], 1)


def test_swept_leaves_go_far_first(cornell, lanes):
    """The leaves a packet's sweep meets (kernels/shadow_sweep.cl) are listed far first too, so that every light
    sample of a render over the blocked floor tests the blocker's leaf and its one triangle first and stops:
    1 primitive per work-item and shadow ray. It fails if the list goes near first (the floor's leaves under
    the tile, with their triangles, come first) or if a blocked sample goes on."""
    scene = blocked_floor(cornell)
    visits = node_visits(scene, Features.of(scene, lanes), **SIZE)
    steps, pixels = steps_and_pixels(lanes)
    assert visits["shadow_rays"] == pixels * SIZE["spp"] * SIZE["light_samples"]  # every lane lit
    assert visits["primitives_per_shadow_ray"] == pytest.approx(steps / pixels, rel=1e-6)


def test_counting_build_renders_the_same_image(cornell, lanes):
    """The counter must not change what it measures: scene 0 (BVH, culled walls, shadow rays stopping when a
    packet is blocked) renders the same bits with and without it, with the same ray count. It fails if
    counting perturbs a traversal (a visit counted by evaluating the box test differently) or the output's
    first four planes."""
    features = dataclasses.replace(Features.of(cornell, lanes), bvh=True)
    options = dict(SIZE, width=33, height=21)
    plain, plain_stats = render(cornell, features=features, **options)
    counted, counted_stats = render(cornell, features=dataclasses.replace(features, count_visits=True), **options)
    np.testing.assert_array_equal(counted, plain)
    assert counted_stats.rays == plain_stats.rays
    assert "visits" in counted_stats.extra and "visits" not in plain_stats.extra


def test_banded_counts_add_up_within_the_budget(cornell, lanes):
    """A budget of 8 rows of the counting build's eleven planes cuts 21 rows into bands of 8, 8 and 5; 8 is a
    multiple of every tile's height, so the work-items, and with them every pixel's count, are those of one
    band. It fails if a band's visit planes land on the wrong rows of the map, if the budget ignores the four
    planes more (the buffer would hold 8 rows of seven planes: 12 rows), or if bands are counted twice."""
    features = dataclasses.replace(Features.of(cornell, lanes), bvh=True)
    options = dict(SIZE, width=33, height=21)
    whole = node_visits(cornell, features, **options)
    row_bytes = (OUTPUT_PLANES + len(VISIT_KINDS)) * 4 * options["width"]
    _, stats = render(cornell, features=dataclasses.replace(features, count_visits=True),
                      max_band_bytes=8 * row_bytes, **options)
    assert stats.extra["band_rows"] == 8 and stats.extra["device_output_bytes"] == 8 * row_bytes
    closest, shadow = stats.extra["visit_maps"][:2]
    np.testing.assert_array_equal(closest, whole["closest_hit_map"])
    np.testing.assert_array_equal(shadow, whole["shadow_map"])


def test_output_planes_match_the_kernel(cl_env):
    """The host's reading of the kernel's output (device_render's plane indices) against render.cl's."""
    names = ["RAYS_PLANE", "FIRST_HALF_PLANE", "OUTPUT_PLANES"]
    source = f'#include "render.cl"\n{values_kernel(names)}'
    assert run_int_kernel(cl_env, source, 3, ["-DLANES=1"]) == [RAYS_PLANE, FIRST_HALF_PLANE, OUTPUT_PLANES]


def test_visit_kinds_match_the_kernel(cl_env):
    """The host's names of the counting build's planes (device_render.VISIT_KINDS) against scene.h's VISITS_*
    indices, in order: the host reads plane OUTPUT_PLANES + k as kind k."""
    names = ["VISIT_KINDS", "VISITS_CLOSEST_NODES", "VISITS_SHADOW_NODES", "VISITS_CLOSEST_PRIMITIVES",
             "VISITS_SHADOW_PRIMITIVES", "VISITS_PATH_LANES", "VISITS_PATH_LANE_STEPS"]
    source = f'#include "scene.h"\n{values_kernel(names)}'
    n, *indices = run_int_kernel(cl_env, source, 7, ["-DLANES=1"])
    assert n == len(VISIT_KINDS) and indices == [VISIT_KINDS.index(k) for k in (
        "closest_hit_nodes", "shadow_nodes", "closest_hit_primitives", "shadow_primitives", "path_lanes",
        "path_lane_steps")]


def test_path_lanes_busy():
    """How busy the path model's bounce loop keeps its lanes (visits.path_lanes_busy): in a closed furnace
    below the depth where Russian roulette starts every path bounces to max_depth, so every lane of every
    iteration is busy (exactly 1); in mi.cornell_box(), open at the front and with roulette, paths end at
    different depths and a packet bounces as often as its longest one (measured 0.4 to 0.6 at 16 lanes); the
    other models have no bounce loop (None)."""
    closed = node_visits(furnace(0.5, max_depth=4), width=16, height=16, spp=4, light_samples=1)
    assert closed["path_lanes_busy"] == 1.0
    box = node_visits(load_file(ROOT / "scenes" / "cornell_box.toml"), width=32, height=32, spp=4, light_samples=1)
    assert 0.2 < box["path_lanes_busy"] < 0.9
    phong = node_visits(load_file(ROOT / "scenes" / "cornell.toml"), width=16, height=16, spp=1, light_samples=1)
    assert phong["path_lanes_busy"] is None
