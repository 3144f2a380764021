"""Phong terms, light sample points and shadow rays (kernels/shading.cl, lights.cl, intersect.cl)."""
import dataclasses

import numpy as np
import pytest

import reference
from helpers import planar
import raytrace
from raytrace import samplers
from raytrace.renderer import culling, packing
from raytrace.renderer.scene_tables import scene_tables
from raytrace.renderer.program import Features
from raytrace.scene import Light, Rectangle
from raytrace.renderer.culling import light_sides
from raytrace.renderer.packing import light_structs, rectangle_structs
from raytrace.scene.textures import make_texture
from raytrace.commands.stability.probe import scene_args

PHONG = """
#include "shading.cl"
__kernel void lobes(int n, __global const float *nrm, __global const float *l, __global const float *v,
                    float shininess, __global float *out)
{
    OUT(out, phong_lobes(IN3(nrm), IN3(l), IN3(v), (vfloat)(shininess)));
}

__kernel void points(int n, __global const Light *light, __global const float *uv, __global float *p)
{
    vec2 u = {IN(uv), IN(uv + n)};
    OUT3(p, light_point(light, u));
}
"""

SHADOW = """
#include "shading.cl"
__kernel void shadow(int n, SCENE_PARAMETERS, __global const float *p, __global const float *q,
                     __global float *blocked)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 from = IN3(p);
    Ray r = {from, v3_sub(IN3(q), from)};
    OUT(blocked, MASK_TO_ONE(occluded(&s, r, 0u, (vfloat)(0.0f) == 0.0f)));
}

/* The renderer's own way off a surface: the camera ray's hit, its offset origin, the segment to q. */
__kernel void leave(int n, SCENE_PARAMETERS, __global const float *o, __global const float *d,
                    __global const float *q, __global float *blocked)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    Ray r = {IN3(o), IN3(d)};
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    vec3 origin = offset_ray_origin(hit.p, hit.err, hit.n);
    OUT(blocked, MASK_TO_ONE(occluded(&s, shadow_segment(origin, IN3(q), light_point_error(lights),
                                                         v3_uniform(lights->shape.normal)), 0u,
                                                (vfloat)(0.0f) == 0.0f)));
}
"""


def unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_phong_lobes(harness):
    """max(0, n.l) + max(0, r.v)^s with r = 2(n.l)n - l, against float64; exp2(s log2 x) in float32 is good
    to about s * 2^-22 relative, so 1e-5 absolute for terms <= 2 and s <= 64."""
    rng = np.random.default_rng(13)
    n = 512
    nrm, l, v = (unit(rng.normal(size=(n, 3))) for _ in range(3))
    l[:64] = nrm[:64]  # mirror cases: r = n, r.v = n.v
    for s in (1.0, 16.0, 64.0):
        out = harness.run(PHONG, "lobes", n, [planar(nrm), planar(l), planar(v), np.float32(s)], {"out": 1})
        ndl = np.sum(nrm * l, 1)
        r = 2 * ndl[:, None] * nrm - l
        ref = np.maximum(ndl, 0) + np.maximum(np.sum(r * v, 1), 0) ** s
        np.testing.assert_allclose(out["out"], ref, atol=1e-5)


def test_light_points(harness, cornell):
    light = cornell.lights[0]
    uv = samplers.grid(16)
    out = harness.run(PHONG, "points", 16, [light_structs([light]), planar(uv)], {"p": 3})
    np.testing.assert_allclose(out["p"].T, reference.light_points(light, uv), atol=1e-7)
    assert np.allclose(out["p"][2], 1.95) and out["p"][0].min() > -0.25 and out["p"][1].max() < 0.15


def test_shadow_rays(harness, cornell):
    """Segments from visible surface points to light samples: blocked exactly when the float64
    reference is, except segments passing within 1e-3 of an occluder's silhouette."""
    rng = np.random.default_rng(17)
    n = 2048
    o = np.tile(cornell.camera.position, (n, 1))
    d = unit(rng.normal([0, 1, -0.2], [0.35, 0.1, 0.3], (n, 3)))
    hit = reference.closest_hit(cornell, o, d, tmin=0.0)
    ok = (hit["material"] >= 0)
    p = o + np.where(ok, hit["t"], 0)[:, None] * d  # rays that see nothing or the light: any finite point
    p_off = p + hit["normal"] * 2.44140625e-4 * (1 + np.abs(p).max(1, keepdims=True))
    q = reference.light_points(cornell.lights[0], rng.uniform(0, 1, (n, 2)))
    ref = reference.occluded(cornell, p_off, q)
    out = harness.run(SHADOW, "shadow", n, {**scene_args(cornell), "p": planar(p_off), "q": planar(q)}, {"blocked": 1},
                      HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)["blocked"] > 0
    # silhouette: nudging the light point by 1e-3 changes the reference's answer
    nudged = [reference.occluded(cornell, p_off, q + dq) for dq in np.eye(3) * 1e-3]
    clear = ok & np.all([x == ref for x in nudged], axis=0)
    assert np.count_nonzero(clear & ref) > 100 and np.count_nonzero(clear & ~ref) > 100
    np.testing.assert_array_equal(out[clear], ref[clear])


def test_no_acne(harness, cornell):
    """Shadow segments from camera-ray hits on every surface to the light's centre, leaving as the renderer
    does (the hit point's error-bounded offset, the segment's end pushed off the light), are never blocked
    where the float64 reference says the point is lit: no surface shadows itself. Also with the light moved
    up into the ceiling's plane (flush, the segment ends on the ceiling): the ceiling does not block it."""
    rng = np.random.default_rng(19)
    n = 2048
    o = np.tile(cornell.camera.position, (n, 1)).astype(np.float32).astype(float)
    d = unit(rng.normal([0, 1, -0.1], [0.4, 0.1, 0.4], (n, 3))).astype(np.float32).astype(float)
    for light in (cornell.lights[0], dataclasses.replace(cornell.lights[0], center=np.array([0.0, 0.0, 2.0]))):
        scene = dataclasses.replace(cornell, lights=[light])
        hit = reference.closest_hit(scene, o, d, tmin=0.0)
        on_surface = hit["material"] >= 0
        p = o + np.where(on_surface, hit["t"], 0)[:, None] * d
        q = np.tile(light.center, (n, 1))
        lit = on_surface & (np.sum(hit["normal"] * (q - p), 1) > 0) & ~reference.occluded(scene, p, q)
        out = harness.run(SHADOW, "leave", n, {**scene_args(scene), "o": planar(o), "d": planar(d), "q": planar(q)},
                          {"blocked": 1}, HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)["blocked"] > 0
        assert np.count_nonzero(lit) > 500
        assert not np.any(out[lit])


def test_light_sides_of_planes():
    """light_sides (raytrace/structs.py) for scene 0's light, 0.5 x 0.3 at z = 1.95 facing down, in a scene
    whose coordinates stay below 2: a floor (z = 0) and a plane 1e-3 under the light have it in front, a
    ceiling-high plane has it behind, and the same from the other side with the normals turned. A vertical
    plane through it and a plane 1e-6 under it (closer than the margin for where shadow rays end,
    sqrt(3) gamma(32) (2 + 0.4) = 7.93e-6) have it on neither side. The margin itself is pinned by planes
    7.7e-6 and 8.2e-6 under it (float32 stores z = 1.95 to 1.2e-7): the first within, the second beyond."""
    light = light_structs([Light(np.array([0.0, 0, 1.95]), np.array([0.5, 0.3]), np.array([0.0, 0, -1]),
                                 np.array([1.0, 0, 0]), 0, np.ones(3))])[0]["shape"]
    up, x = np.array([0.0, 0, 1]), np.array([1.0, 0, 0])
    planes = [Rectangle(np.array([0, 0, z]), np.array([2.0, 2.0]), up, x) for z in (0.0, 1.949, 2.0, 1.949999)]
    planes += [Rectangle(np.array([0, 0, 1.0]), np.array([2.0, 2.0]), x, np.array([0.0, 1, 0]))]
    planes += [Rectangle(np.array([0, 0, z]), np.array([2.0, 2.0]), -up, x) for z in (0.0, 2.0)]
    planes += [Rectangle(np.array([0, 0, 1.95 - dz]), np.array([2.0, 2.0]), up, x) for dz in (7.7e-6, 8.2e-6)]
    front, behind = light_sides(light, rectangle_structs(planes), 2.0)
    assert (front, behind) == (0b100000011 | 0b1000000, 0b0100100)


def test_scene_extent_counts_displaced_points(cornell):
    """The extent that sets light_sides' margins bounds displaced shading points too: height_scale times
    the largest |height| a lookup can return, 1 for an 8-bit map, any value for a float map (here -40 at
    one texel, which every coarser level averages down: level 0 decides)."""
    none = {k: np.zeros((0, 3), np.float32) for k in ("v0", "v1", "v2")}
    base = culling.scene_extent(cornell, none)
    assert base == pytest.approx(2.0, rel=1e-6), "scene 0's coordinates reach 2 (ceiling, walls)"
    heights = np.zeros((4, 4, 1), np.float32)
    heights[1, 2] = -40.0
    for pixels, kind, reach in ((heights, "float", 40.0), (np.full((4, 4, 1), 255, np.uint8), "8-bit", 1.0)):
        bumpy = dataclasses.replace(cornell.materials[0], height_map=0, height_scale=0.1)
        scene = dataclasses.replace(cornell, textures=[make_texture(pixels, kind, "height")],
                                    materials=[bumpy, *cornell.materials[1:]])
        assert culling.scene_extent(scene, none) == pytest.approx(base + 0.1 * reach, rel=1e-6), kind


REACH = """
#include "shading.cl"
__kernel void reach(int n, SCENE_PARAMETERS, __global const float *o, __global const float *q,
                    int index, __global float *skipped, __global float *blocked)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 origin = IN3(o);
    uint skip = rectangles_out_of_reach(&s, lights, origin, (vint)(-1));
    OUT(skipped, (vfloat)(((skip >> index) & 1u) ? 1.0f : 0.0f));
    Ray r = shadow_segment(origin, IN3(q), light_point_error(lights), v3_uniform(lights->shape.normal));
    PrimitiveRay p = primitive_ray(r);
    OUT(blocked, MASK_TO_ONE(blocks_rectangle(&s, &p, index)));
}
"""


def test_a_skipped_rectangle_never_blocks(harness, cornell):
    """The property the culling rests on, tested where it is tight: origins within 1e-9 to 1e-4 of a
    tilted shelf's plane (the light behind it), on both sides, with shadow segments to light points built
    as the renderer builds them. Wherever rectangles_out_of_reach skips the shelf, the rectangle test
    itself finds no hit on that segment. The plane is tilted so that num's rounding bound e (about 1e-7
    here, from every coordinate of c - o) is not a tiny fraction of num: a bound 10 times looser skips
    origins 1e-7 to 1e-6 in front of the plane, whose segments the shelf blocks. Lanes are grouped by
    their signed distance, and each run of 16 shares its point in the plane (and so nearly its bound e), so
    that at every lane width whole groups lie within e (the skip holds for all lanes or none)."""
    normal = unit(np.array([[0.3, 0.2, -1.0]]))[0]
    tangent = unit(np.cross([[0.0, 1.0, 0.0]], normal))[0]
    shelf = Rectangle(np.array([0.1, 0.5, 1.4]), np.array([0.8, 0.6]), normal, tangent, 1)
    scene = dataclasses.replace(cornell, rectangles=[*cornell.rectangles, shelf])
    index = len(cornell.rectangles)
    lights = scene_tables(scene)["lights"]
    assert lights[0]["planes_behind"] >> index & 1, "the light is behind the shelf's plane"
    rng = np.random.default_rng(23)
    n = 4096
    stored = rectangle_structs([shelf])[0]
    c, t, b, nz = (stored[k].astype(np.float64) for k in ("center", "tangent", "bitangent", "normal"))
    ab = np.repeat(rng.uniform(-0.8, 0.8, (n // 16, 2)) * [0.4, 0.3], 16, axis=0)
    distance = np.sort(rng.choice([-1, 1], n) * 10 ** rng.uniform(-9, -4, n))  # > 0: away from the light
    o = (c + ab[:, :1] * t + ab[:, 1:] * b + distance[:, None] * nz).astype(np.float32).astype(np.float64)
    q = reference.light_points(cornell.lights[0], rng.uniform(0, 1, (n, 2)))
    out = harness.run(REACH, "reach", n, {**scene_args(scene), "o": planar(o), "q": planar(q), "index": np.int32(index)},
                      {"skipped": 1, "blocked": 1}, HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)
    skipped, blocked = out["skipped"] > 0, out["blocked"] > 0
    assert not np.any(skipped & blocked)
    front = distance > 0
    assert np.count_nonzero(skipped & front) > 8, "some origins in front lie within rounding of the plane"
    assert np.count_nonzero(blocked & (distance < 1e-6)) > 50, "and the shelf blocks ones just beyond it"


@pytest.mark.parametrize("bvh", [False, True])
@pytest.mark.parametrize("view", ["room", "under the shelf"])
def test_skipping_rectangles_out_of_reach_changes_nothing(cornell, lanes, bvh, view, monkeypatch):
    """Shadow rays skip the rectangles whose plane has the whole light on one side and their origin on the
    same side, or within rounding of the plane, where the rectangle test rejects the hit anyway
    (intersect.cl). Scene 0 with a panel under the light, facing up: it shadows the floor, whose shadow
    rays must still test it, while those from above it skip it; a vertical fin piercing the panel; and a
    shelf against the back wall, facing down, the light behind both. Seen close up, the wall right under
    the shelf starts its shadow rays a few 1e-3 from the shelf's plane, on the far side from the light: a
    rounding bound looser than the rectangle test's (1e-3 already) would skip the shelf that shadows them.
    The render is the same bit for bit as with no rectangle skipped (the lights' bits cleared), at both
    lane widths, with and without the BVH (two traversal loops), in both views."""
    material = cornell.rectangles[0].material
    extras = [Rectangle(np.array(c), np.array(size), np.array(n), np.array([1.0, 0, 0]), material)
              for c, size, n in (([0.3, 0.2, 1.5], [0.4, 0.4], [0.0, 0, 1]),     # panel
                                 ([0.3, 0.2, 1.4], [0.4, 0.4], [0.0, 1, 0]),     # fin
                                 ([0.0, 0.8, 1.6], [1.2, 0.4], [0.0, 0, -1]))]  # shelf
    camera = cornell.camera if view == "room" else dataclasses.replace(
        cornell.camera, look_at=np.array([0.0, 1.0, 1.59]), fov_deg=5.0)
    plain = dataclasses.replace(cornell, camera=camera)
    scene = dataclasses.replace(plain, rectangles=[*cornell.rectangles, *extras])
    of = Features.of.__func__
    monkeypatch.setattr(Features, "of", classmethod(lambda cls, *a: dataclasses.replace(of(cls, *a), bvh=bvh)))
    lights = scene_tables(scene)["lights"]
    assert lights[0]["planes_in_front"] == 0b111111, "the walls and the panel have the light in front"
    assert lights[0]["planes_behind"] == 0b11000000, "the fin and the shelf have the light behind"
    options = dict(width=64, height=64, spp=4, light_samples=4, lanes=lanes)
    skipping, stats = raytrace.render(scene, **options)
    assert f"-DHAS_BVH={int(bvh)}" in stats.build_options
    without_extras = raytrace.render(plain, **options)[0]
    monkeypatch.setattr(packing, "light_sides", lambda *args: (0, 0))
    testing_all = raytrace.render(scene, **options)[0]
    np.testing.assert_array_equal(skipping, testing_all)
    assert np.abs(skipping - without_extras).max() > 0.1, "the extras' shadows are in the image"
