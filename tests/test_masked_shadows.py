"""Shadow rays through see-through surfaces (kernels/primitive.cl's crossing_blocks, material.cl's
passes_through): a shadow segment passes a crossing of a `mask` where the wrappers there resolve to `null` (as for
a ray meeting the surface, with the mask's opacity there, drawn by a hash of the crossing and the segment), at
most `passes` times; and the path model's
use of it (kernels/path_tracing.cl): light samples through masks, MIS against the BSDF's samples that pass the
`null` bounce as from the vertex before, and max_depth counting each pass as Mitsuba does.

Statistics: over N distinct segments a crossing of opacity o must pass with probability 1 - o as an independent
draw would: exact binomial tests at SIGNIFICANCE (devtools/chi_square.py's, 1e-4) for an ideal hash; the module
runs 5 of them at each of the machine's lane widths (the same segments draw the same numbers at every width),
about 5 independent tests: a false failure about once in 2000 runs. What is exact is tested exactly: opacity 0 and
1, a `null`, a budget of 0 passes, a checkerboard of opacities 0 and 1.

The renders compare expectations: a floor inside a masked sphere under a constant sky, against its closed form
rho (1 - o) L, and a floor lit by a rectangle light through a masked plane, against (1 - o) times the same floor
without the mask; every light-carrying path crosses the mask once, so the relation is exact in expectation, and
both MIS techniques (light samples passing the mask, BSDF samples passing its null bounce) contribute to it.
Each is judged by devtools/judge.py's per-pixel Z-test (and its tiles of 4 and 16 pixels and the whole image),
the variances from 16 independent renders of 8 spp, each scale at a false-failure rate of ALPHA = 1e-4: about
4e-4 per judged image, 4 images at the two lane-width ends, 1.6e-3 per run.

Mutations tried (each in a copy of the kernels; every one failed the tests named, and the copy was discarded):
- primitive.cl, crossing_blocks: every crossing blocks (Mitsuba's shadow rays): every test;
- primitive.cl, crossing_blocks: one pass fewer allowed (`passed > passes` then, now `passed < passes - 1`): the
  pass fractions, the null, the budgets, the sphere's crossings, the checkerboard;
- primitive.cl, crossing_blocks: one pass more allowed (`passed <= passes`): the pass fractions (a budget of 0),
  the budgets, the floor inside the sphere at max_depth 2;
- primitive.cl, blocks_ellipsoid: the far root not tested (one crossing per ellipsoid): the sphere's crossings;
- path_tracing.cl: the MIS state not kept at a pass (`passing` never set): both renders (light counted twice);
- path_tracing.cl: `travelled` not added to the light's distance: the light through the plane;
- path_tracing.cl: sp.passes one more than max_depth leaves: the floor inside the sphere (max_depth 2).
"""
import numpy as np
import pytest
from scipy import stats

import raytrace
import lookup_support as mts
from devtools.chi_square import SIGNIFICANCE
from devtools.judge import judge
from helpers import at_lane_ends
from render_judging import CHUNKS, assert_judged, chunked
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

KERNEL = """
#include "material.cl"
__kernel void shadows(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const float *o,
                      __global const float *q, int passes, __global float *blocked)
{
    Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    s.textures = ts;
    vec3 from = IN3(o);
    Ray r = {from, v3_sub(IN3(q), from)};
    OUT(blocked, MASK_TO_ONE(occluded(&s, r, 0u, (vfloat)(0.0f) == 0.0f PASSES((vint)(passes)))));
}
"""
N = 4000  # segments per case
ALPHA = 1e-4  # devtools/judge.py's false-failure rate per scale (pixels, tiles of 4 and 16, the whole image)
BLACK = {"type": "diffuse", "reflectance": 0.0}


def mask(opacity, bsdf="black"):
    return {"type": "mask", "bsdf": bsdf, "opacity": opacity}


def blocked(harness, materials, shapes, o, q, passes, bvh=False):
    """Which of the segments o -> q (N x 3 each) the scene of `materials` and `shapes` blocks when they may pass
    `passes` see-through surfaces (bvh: the scene is large enough for a BVH at every lane width)."""
    scene = raytrace.load_dict(mts.path_scene({"black": BLACK, **materials}, shapes))
    features = Features.of(scene, harness.lanes)
    defines = {o_[2:].split("=")[0]: int(o_.split("=")[1]) for o_ in features.options()[1:]}
    assert defines["HAS_NULLS"] == 1 and (defines["HAS_BVH"] == 1 or not bvh)
    args = {**scene_tables(scene, scene.width, scene.height, 1, 1, "bilinear", features=features),
            **texture_tables(scene), "o": o.T.astype(np.float32), "q": q.T.astype(np.float32),
            "passes": np.int32(passes)}
    out = harness.run(KERNEL, "shadows", len(o), args, {"blocked": 1}, **defines)
    return out["blocked"] > 0.5


def through_panel(seed, y0=-1.0, y1=1.0, extent=1.5):
    """N segments from y = y0 to y = y1 between random points of |x|, |z| < extent: each crosses the 4 x 4 panels
    of mts.panel (at y between y0 and y1) once."""
    rng = np.random.default_rng(seed)
    o = np.column_stack([rng.uniform(-extent, extent, N), np.full(N, y0), rng.uniform(-extent, extent, N)])
    q = np.column_stack([rng.uniform(-extent, extent, N), np.full(N, y1), rng.uniform(-extent, extent, N)])
    return o, q


def assert_passes(passed, p, label):
    if p in (0.0, 1.0):
        assert np.all(passed == (p == 1.0)), label
        return
    pvalue = stats.binomtest(int(passed.sum()), len(passed), p).pvalue
    print(f"{label}: {passed.mean():.4f} passed, expected {p}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE, (label, passed.mean(), p, pvalue)


@pytest.mark.parametrize("opacity", [0.0, 0.3, 0.75, 1.0])
def test_a_mask_passes_with_one_minus_opacity(harness, opacity):
    """A masked panel crossed once by each segment: passed with probability 1 - opacity when one pass is
    allowed, never when none is; exact at opacities 0 and 1."""
    o, q = through_panel(seed=int(opacity * 100))
    materials, shapes = {"cut": mask(opacity)}, [mts.panel("cut")]
    assert_passes(~blocked(harness, materials, shapes, o, q, 1), 1.0 - opacity, f"opacity {opacity}")
    assert np.all(blocked(harness, materials, shapes, o, q, 0))


def test_null_passes_and_opaque_blocks(harness):
    """A `null` panel is always passed (one pass allowed); a diffuse panel behind it always blocks; a segment
    that ends before the opaque panel passes the null alone."""
    o, q = through_panel(seed=3)
    materials = {"nothing": {"type": "null"}, "grey": {"type": "diffuse", "reflectance": 0.5}}
    shapes = [mts.panel("nothing"), mts.panel("grey", center=(0.0, 0.5, 0.0))]
    assert not np.any(blocked(harness, materials, shapes, o, q * [1, 0.25, 1], 1))
    assert np.all(blocked(harness, materials, shapes, o, q, 1))


def test_budget_counts_crossings(harness):
    """Two masked panels (opacities 0.3 and 0.6) crossed by every segment: passed with probability 0.7 x 0.4 =
    0.28 when two passes are allowed, never with one (the second crossing would exceed it)."""
    o, q = through_panel(seed=5)
    materials = {"near": mask(0.3), "far": mask(0.6)}
    shapes = [mts.panel("near"), mts.panel("far", center=(0.0, 0.5, 0.0))]
    assert_passes(~blocked(harness, materials, shapes, o, q, 2), 0.7 * 0.4, "two masks")
    assert np.all(blocked(harness, materials, shapes, o, q, 1))


def test_a_masked_sphere_is_crossed_twice(harness):
    """A sphere of radius 1 masked with opacity 0.4: a segment through it crosses it twice, passing with
    probability 0.6^2 = 0.36 (two passes allowed); one ending inside it crosses once, 0.6."""
    rng = np.random.default_rng(9)
    o = np.column_stack([rng.uniform(-0.5, 0.5, N), np.full(N, -2.0), rng.uniform(-0.5, 0.5, N)])
    q = np.column_stack([rng.uniform(-0.5, 0.5, N), np.full(N, 2.0), rng.uniform(-0.5, 0.5, N)])
    materials = {"cut": mask(0.4)}
    shapes = [{"type": "ellipsoid", "material": "cut", "center": [0.0, 0.0, 0.0],
               "axes": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}]
    assert_passes(~blocked(harness, materials, shapes, o, q, 2), 0.36, "through the sphere")
    assert_passes(~blocked(harness, materials, shapes, o, q * [1, 0.1, 1], 2), 0.6, "into the sphere")


def test_textured_opacity_passes_per_cell(harness, tmp_path):
    """A mesh sheet (a 16 x 16 grid of quads: a BVH) masked by a checkerboard of opacities 0 and 1: a segment
    passes exactly where its crossing lies on a cell of opacity 0 (Mitsuba's float checkerboard through the
    sheet's texture coordinates, points within 1e-4 of a border skipped)."""
    n = 16
    grid = np.linspace(-2.0, 2.0, n + 1)
    lines = [f"v {x} 0 {z}\nvt {(x + 2) / 4} {(z + 2) / 4}" for z in grid for x in grid]
    faces = []
    for j in range(n):
        for i in range(n):
            a, d = j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1
            b, c = a + 1, d + 1
            faces.append(f"f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}")
    (tmp_path / "sheet.obj").write_text("\n".join(lines + faces) + "\n")
    rows = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]
    materials = {"cut": mask({"type": "checkerboard", "color0": 0.0, "color1": 1.0, "to_uv": rows})}
    shapes = [{"type": "mesh", "file": str(tmp_path / "sheet.obj"), "material": "cut", "flip_tex_coords": False}]
    o, q = through_panel(seed=11)
    passed = ~blocked(harness, materials, shapes, o, q, 1, bvh=True)
    crossing = o + (q - o) * (-o[:, 1:2] / (q[:, 1:2] - o[:, 1:2]))
    u, v = (crossing[:, 0] + 2) / 4, (crossing[:, 2] + 2) / 4
    s, t, _ = mts.mitsuba_st(rows, u, v)
    opacity = mts.checkerboard(s, t, [0.0] * 3, [1.0] * 3, float_slot=True)[:, 0]
    clear = ~(mts.near_border(s, 2, 2e-4) | mts.near_border(t, 2, 2e-4))
    assert clear.mean() > 0.99 and 0.3 < opacity[clear].mean() < 0.7
    np.testing.assert_array_equal(passed[clear], opacity[clear] == 0.0)


def sphere_scene(opacity, rho, radiance, max_depth):
    """A floor (albedo rho) inside a sphere of radius 3 masked with `opacity` over black, under a constant sky
    L; the camera inside, looking down at the floor, which fills its view."""
    return mts.path_scene(
        {"floor": {"type": "diffuse", "reflectance": rho}, "black": BLACK, "cut": mask(opacity)},
        [mts.panel("floor", center=(0.0, 0.0, -1.0), size=(6.0, 6.0), normal=(0.0, 0.0, 1.0)),
         {"type": "ellipsoid", "material": "cut", "center": [0.0, 0.0, 0.0],
          "axes": [[3.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 3.0]]}],
        camera={"position": [0.0, 0.0, 0.5], "look_at": [0.0, 0.0, -1.0], "up": [0.0, 1.0, 0.0], "fov": 40.0},
        environment=radiance, max_depth=max_depth)


@at_lane_ends
def test_floor_inside_a_masked_sphere(lanes):
    """Every direction from the floor to the sky crosses the sphere once: the floor's radiance is rho (1 - o) L,
    reached by light samples that pass the mask and BSDF samples that pass its null bounce, weighted by MIS
    (a double count shows as 1.4x). At max_depth 2 the pass would be a third vertex: the floor is black, exactly
    (Mitsuba's depth counting)."""
    rho, radiance, opacity = np.array([0.8, 0.5, 0.2]), np.array([0.5, 0.8, 1.2]), 0.4
    mean, var = chunked(sphere_scene(opacity, rho.tolist(), radiance.tolist(), -1), lanes, 8)
    expected = np.broadcast_to(rho * (1 - opacity) * radiance, mean.shape)
    assert_judged(judge(mean, var, expected, np.zeros_like(var), alpha=ALPHA, dof=CHUNKS - 1, tile_alpha=ALPHA),
                  f"sphere, lanes {lanes}")
    dark, _ = raytrace.render(raytrace.load_dict(sphere_scene(opacity, rho.tolist(), radiance.tolist(), 2)),
                              spp=4, lanes=lanes)
    assert np.all(np.asarray(dark) == 0.0)


def lit_floor_scene(opacity):
    """A floor lit only by a 1 x 1 rectangle light 2 above it, through a 6 x 6 plane at height 1 masked with
    `opacity` over black (None: no plane); the camera below the plane. Every light-carrying path crosses the
    plane once: the image is (1 - o) times the image without it, in expectation."""
    shapes = [mts.panel("floor", center=(0.0, 0.0, 0.0), size=(6.0, 6.0), normal=(0.0, 0.0, 1.0))]
    if opacity is not None:
        shapes.append(mts.panel("cut", center=(0.0, 0.0, 1.0), size=(6.0, 6.0), normal=(0.0, 0.0, -1.0)))
    table = mts.path_scene(
        {"floor": {"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]}, "black": BLACK, "cut": mask(opacity or 0.0)},
        shapes, camera={"position": [0.0, -2.5, 0.6], "look_at": [0.0, 0.0, -0.6], "up": [0.0, 0.0, 1.0],
                        "fov": 40.0}, environment=0.0, max_depth=-1)
    table["lights"] = [{"center": [0.3, 0.2, 2.0], "size": [1.0, 1.0], "normal": [0.0, 0.0, -1.0],
                        "tangent": [1.0, 0.0, 0.0], "radiance": [4.0, 4.0, 4.0]}]
    return table


@at_lane_ends
def test_light_through_a_masked_plane(lanes):
    """The floor lit through a plane of opacity 0.5 against 0.5 times the floor without it, judged per pixel and
    per tile at ALPHA. The BSDF samples that pass the plane's null bounce reach the light at the distance
    from the floor (`travelled`), which their MIS weight against the light samples needs."""
    opacity = 0.5
    masked, masked_var = chunked(lit_floor_scene(opacity), lanes, 8)
    clear, clear_var = chunked(lit_floor_scene(None), lanes, 8, seed=CHUNKS)
    assert clear.mean() > 0.05
    assert_judged(judge(masked, masked_var, (1 - opacity) * clear, (1 - opacity) ** 2 * clear_var, alpha=ALPHA,
                        dof=CHUNKS - 1, ref_dof=CHUNKS - 1, tile_alpha=ALPHA), f"plane, lanes {lanes}")
