"""Mitsuba 3's BSDF wrappers as kernels/wrappers.cl resolves them at each hit (wrapped_materials, and
shading_point's material): blendbsdf's choice of its second material with probability weight, a textured weight,
mask as a blend of null and the masked material, nested blends, back sides (two_sided = false, back = NAME); the
null BSDF itself (kernels/bsdfs/null.cl); and whole renders: a mask over a diffuse panel in a constant
environment against its float64 expectation, and a scene of every wrapper finite at every lane width.

The choices are made by a hash of the hit (wrappers.cl's blend_number): over distinct hit points (random camera
rays) they must follow the blend's probabilities as independent draws would. The counts are tested by exact
binomial tests and Pearson's chi-square; each fails with probability SIGNIFICANCE (devtools/chi_square.py's, 1e-4)
for an ideal hash, and the module runs 3 weights + 2 opacities + 1 nested case at each of the machine's lane widths
(the same hits at every width draw the same numbers: the counts were identical at 1, 4, 8 and 16 lanes), so
about 6 independent tests: a false failure about once in 1700 runs at most.

Mutations tried (each in a copy of the checkout; every one failed the tests named, and the copy was discarded):
- wrappers.cl: `blend[second[i] != 0]` -> `== 0` (the wrong child): the blend, mask, nested, textured-weight,
  back-side and rendered-mask tests, at every lane width;
- wrappers.cl: the back-side rule skipped (`m[i] = m[i]`): test_back_sides, at every width;
- wrappers.cl: the second child chosen with probability 1 - weight: the same tests as the wrong child;
- wrappers.cl, mapped_weights: a textured weight written to every mapped lane, not only its own blend's:
  test_textured_weight_chooses_per_region at 4, 8 and 16 lanes (one lane has no neighbour to spoil);
- packing.py: a mask's children swapped ((masked, null)): the mask, nested and rendered-mask tests;
- null.cl: wi = wo (reflecting) instead of -wo: test_null_bsdf_passes_straight_on and the rendered mask.
"""
import numpy as np
import OpenImageIO as oiio
import pytest
from scipy import stats

import raytrace
import bsdf_support
import lookup_support as mts
import reference_textures
from devtools.chi_square import SIGNIFICANCE
from helpers import at_lane_ends, lane_id, runnable_lane_widths
from raytrace import structs
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

KERNEL = """
#include "camera.cl"
#include "material.cl"
__kernel void wrapped(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const float *xy,
                      __global float *material, __global float *bsdf, __global float *k, __global float *pos)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    Ray r = generate_camera_ray(camera, IN(xy), IN(xy + n), lens, &tmax);
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
#if HAS_WRAPPERS
    OUT(material, CONVERT_VFLOAT(wrapped_materials(&s, ts, r, hit)));
#else
    OUT(material, CONVERT_VFLOAT(hit.material));
#endif
    ShadingPoint sp = shading_point(&s, ts, r, hit);
#if HAS_BSDF_PARAMETERS
    OUT(bsdf, CONVERT_VFLOAT(sp.bsdf));
#else
    OUT(bsdf, (vfloat)(0.0f));
#endif
    OUT3(k, sp.k);
    OUT3(pos, hit.p);
}
"""
N = 4000  # hits per case
COLOURS = {"a": [0.9, 0.1, 0.1], "b": [0.1, 0.8, 0.2], "c": [0.2, 0.3, 0.9]}


def diffuse(name, **keys):
    return {"type": "diffuse", "reflectance": COLOURS[name], **keys}


def resolve(harness, table, seed=0):
    """The scene of `table` (mts.path_scene's) at N random camera positions over its 32 x 32 image: {material: the
    wrapped material's index (-1: none), bsdf: the shading point's BSDF, k: its colour, p: the hit}, and the
    scene. Every ray hits (the tests' panels fill the view)."""
    scene = raytrace.load_dict(table)
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    rng = np.random.default_rng(seed)
    xy = np.concatenate([rng.uniform(0, scene.width, N), rng.uniform(0, scene.height, N)])
    args = {**scene_tables(scene, scene.width, scene.height, 1, 1, "bilinear", features=features),
            **texture_tables(scene), "xy": xy.astype(np.float32)}
    out = harness.run(KERNEL, "wrapped", N, args, {"material": 1, "bsdf": 1, "k": 3, "pos": 3}, **defines)
    out = {"material": np.rint(out["material"]).astype(int), "bsdf": np.rint(out["bsdf"]).astype(int),
           "k": out["k"].T, "p": out["pos"].T}
    return out, scene


def index(scene, name):
    return [m.name for m in scene.materials].index(name)


def two_sided_binomial(count, n, p):
    """The exact binomial test's p-value of `count` successes in n draws of probability p."""
    return stats.binomtest(count, n, p).pvalue


@pytest.mark.parametrize("weight", [0.0, 0.2, 0.5, 0.85, 1.0])
def test_blend_chooses_second_with_weight(harness, weight):
    """A blendbsdf of two diffuse materials of different colours: the second with probability weight over N
    distinct hits (exact binomial test at SIGNIFICANCE), never at weight 0 and always at 1 (the number is in [0,
    1) and compared by <); the shading point's colour and BSDF are the chosen material's, exactly."""
    out, scene = resolve(harness, mts.path_scene(
        {"a": diffuse("a"), "b": diffuse("b"), "mix": {"type": "blendbsdf", "bsdfs": ["a", "b"], "weight": weight}},
        [mts.panel("mix")]), seed=int(weight * 100))
    a, b = index(scene, "a"), index(scene, "b")
    assert set(out["material"]) <= {a, b}
    second = out["material"] == b
    np.testing.assert_array_equal(out["k"], np.where(second[:, None], COLOURS["b"], COLOURS["a"]).astype(np.float32))
    if weight in (0.0, 1.0):
        assert np.all(second == (weight == 1.0))
    else:
        p = two_sided_binomial(int(second.sum()), N, weight)
        print(f"weight {weight}: {second.mean():.4f} chose the second, p = {p:.3g}")
        assert p >= SIGNIFICANCE, (second.mean(), p)


@pytest.mark.parametrize("opacity", [0.0, 0.35, 0.8, 1.0])
def test_mask_is_null_with_one_minus_opacity(harness, opacity):
    """A mask of a diffuse material: the null material (the host's last, packing.material_table) with
    probability 1 - opacity, its shading point's BSDF BSDF_NULL and colour 0; else the masked material, diffuse,
    its colour. Exact at 0 and 1, an exact binomial test at SIGNIFICANCE between."""
    out, scene = resolve(harness, mts.path_scene(
        {"a": diffuse("a"), "cut": {"type": "mask", "bsdf": "a", "opacity": opacity}}, [mts.panel("cut")]),
        seed=7 + int(opacity * 100))
    null = len(scene.materials)
    masked = out["material"] == index(scene, "a")
    assert np.all(masked | (out["material"] == null))
    np.testing.assert_array_equal(out["bsdf"], np.where(masked, structs.BSDFS["diffuse"], structs.BSDFS["null"]))
    np.testing.assert_array_equal(out["k"], np.where(masked[:, None], COLOURS["a"], 0.0).astype(np.float32))
    if opacity in (0.0, 1.0):
        assert np.all(masked == (opacity == 1.0))
    else:
        p = two_sided_binomial(int(masked.sum()), N, opacity)
        print(f"opacity {opacity}: {masked.mean():.4f} masked, p = {p:.3g}")
        assert p >= SIGNIFICANCE, (masked.mean(), p)


def test_nested_wrappers_multiply(harness):
    """A mask (opacity 0.8) of a blend (0.7) of a and a blend (0.4) of b and c: null 0.2, a 0.8 x 0.3, b 0.8 x 0.7
    x 0.6, c 0.8 x 0.7 x 0.4 (each level draws its own number: the hash takes the node). Pearson's chi-square
    over the four outcomes at SIGNIFICANCE (expected counts >= 800)."""
    out, scene = resolve(harness, mts.path_scene(
        {"a": diffuse("a"), "b": diffuse("b"), "c": diffuse("c"),
         "inner": {"type": "blendbsdf", "bsdfs": ["b", "c"], "weight": 0.4},
         "outer": {"type": "blendbsdf", "bsdfs": ["a", "inner"], "weight": 0.7},
         "cut": {"type": "mask", "bsdf": "outer", "opacity": 0.8}}, [mts.panel("cut")]), seed=11)
    outcomes = [len(scene.materials), index(scene, "a"), index(scene, "b"), index(scene, "c")]
    observed = np.array([np.sum(out["material"] == m) for m in outcomes])
    assert observed.sum() == N
    expected = N * np.array([0.2, 0.8 * 0.3, 0.8 * 0.7 * 0.6, 0.8 * 0.7 * 0.4])
    p = stats.chisquare(observed, expected).pvalue
    print(f"nested: observed {observed}, expected {expected}, p = {p:.3g}")
    assert p >= SIGNIFICANCE, (observed, expected, p)


def test_textured_weight_chooses_per_region(harness):
    """Three strips side by side, so that neighbouring lanes mix them: blends whose weight is a checkerboard of 0
    and 1 (a float slot: Mitsuba's eval_1, colour1 where the fractions of s and t lie on the same side of 1/2),
    each with its own to_uv, around a blend of constant weight 0.5. On the checkerboards the choice is the
    second material exactly where the weight is 1 (u, v of the hit from the reference's rectangle, Mitsuba's t
    = 1 - the scene's); points within 1e-4 of a square's or a strip's border (the float32 hit's rounding is
    ~1e-7) are skipped, < 1% of them. The middle strip takes both materials (its weight is its own): its share of
the second within 0.5 +- 0.1, 7 standard deviations of ~1300 draws (a false failure ~1e-12)."""
    rows = {"left": [[3.0, 0.0, 0.0], [0.0, 2.0, 0.0]], "right": [[2.0, 1.0, 0.25], [-1.0, 2.0, 0.5]]}
    checker = lambda side: {"type": "checkerboard", "color0": 0.0, "color1": 1.0, "to_uv": rows[side]}  # noqa
    strips = {"left": (-0.8, "ab"), "middle": (0.0, "bc"), "right": (0.8, "ca")}
    materials = {"a": diffuse("a"), "b": diffuse("b"), "c": diffuse("c")}
    for side, (_, pair) in strips.items():
        materials[side] = {"type": "blendbsdf", "bsdfs": list(pair),
                           "weight": 0.5 if side == "middle" else checker(side)}
    shapes = [mts.panel(side, center=(x, 0.0, 0.0), size=(0.8, 4.0)) for side, (x, _) in strips.items()]
    out, scene = resolve(harness, mts.path_scene(materials, shapes), seed=13)
    x = out["p"][:, 0]
    for side, (centre, pair) in strips.items():
        on = (np.abs(x - centre) < 0.4 - 1e-4)
        first, second = index(scene, pair[0]), index(scene, pair[1])
        got = out["material"][on]
        assert on.sum() > N / 4 and set(got) <= {first, second}, side
        if side == "middle":
            assert 0.4 < np.mean(got == second) < 0.6
            continue
        surface = reference_textures.rectangle_surface((centre, 0.0, 0.0), (0.8, 4.0), (0.0, -1.0, 0.0),
                                                       (1.0, 0.0, 0.0), out["p"][on])
        s, t, _ = mts.mitsuba_st(rows[side], surface["u"], surface["v"])
        weight = mts.checkerboard(s, t, [0.0] * 3, [1.0] * 3, float_slot=True)[:, 0]
        clear = ~(mts.near_border(s, 2, 2e-4) | mts.near_border(t, 2, 2e-4))
        assert clear.mean() > 0.99 and 0.3 < weight[clear].mean() < 0.7, side
        np.testing.assert_array_equal(got[clear], np.where(weight[clear] == 1.0, second, first), err_msg=side)


def test_back_sides(harness):
    """Strips seen from the front and, their normals turned away, from behind: a one-sided diffuse (two_sided =
    false) is itself in front and nothing (-1, colour 0: Mitsuba's one-sided BSDFs are black from behind)
    behind; a material with back = "rear" is itself in front and rear behind (Mitsuba's twosided of two); a
    dielectric is itself from both sides; a blend of weight 0 of the one-sided one and rear is the one-sided one
    in front and nothing behind (its child's side is resolved after the choice). Exact."""
    materials = {"one": diffuse("a", two_sided=False), "rear": diffuse("c"), "front": diffuse("b", back="rear"),
                 "glass": {"type": "dielectric"}, "mix": {"type": "blendbsdf", "bsdfs": ["one", "rear"], "weight": 0.0}}
    names = ["one", "front", "glass", "mix"]
    centres = [-0.9, -0.3, 0.3, 0.9]
    for behind in (False, True):
        shapes = [mts.panel(name, center=(x, 0.0, 0.0), size=(0.6, 4.0), normal=(0.0, 1.0 if behind else -1.0, 0.0))
                  for name, x in zip(names, centres)]
        out, scene = resolve(harness, mts.path_scene(materials, shapes), seed=17)
        want = {"one": ("one", COLOURS["a"]), "front": ("front", COLOURS["b"]), "glass": ("glass", [1.0] * 3),
                "mix": ("one", COLOURS["a"])}
        if behind:
            want.update(one=(None, [0.0] * 3), front=("rear", COLOURS["c"]), mix=(None, [0.0] * 3))
        x = out["p"][:, 0]
        for name, centre in zip(names, centres):
            on = np.abs(x - centre) < 0.3 - 1e-4
            material, colour = want[name]
            assert on.sum() > N / 8
            np.testing.assert_array_equal(out["material"][on], -1 if material is None else index(scene, material),
                                          err_msg=f"{name} behind={behind}")
            np.testing.assert_array_equal(out["k"][on], np.broadcast_to(np.float32(colour), (on.sum(), 3)),
                                          err_msg=f"{name} behind={behind}")


def test_null_bsdf_passes_straight_on(harness):
    """null.cl: every sample is wi = -wo (exact: a negation), weight 1, pdf 1, a delta transmission; its value
    and density towards any direction, and at its own sample, are 0 (a delta lobe has none to evaluate)."""
    rng = np.random.default_rng(19)
    m = 256
    normal, wo = bsdf_support.facing(rng, m)
    wi = bsdf_support.unit(rng.normal(size=(m, 3)))
    u = rng.uniform(0, 1, (m, 3))
    out = bsdf_support.run(harness, bsdf_support.material_table(bsdf="null"), normal, wo, wi, u,
                           HAS_PATH_TRACING=1, HAS_NULLS=1, HAS_RECTANGLES=1)
    np.testing.assert_array_equal(out["s_wi"], -wo.astype(np.float32))
    for name, value in (("s_weight", 1.0), ("s_pdf", 1.0), ("s_delta", 1.0), ("s_transmit", 1.0),
                        ("delta_bsdf", 1.0), ("f", 0.0), ("pdf", 0.0), ("f_swapped", 0.0), ("s_f", 0.0),
                        ("s_eval_pdf", 0.0)):
        assert np.all(out[name] == value), name


@at_lane_ends
def test_rendered_mask_over_a_panel(lanes):
    """A mask of opacity 0.3 over a diffuse panel (albedo rho) filling the view, in a constant environment L and
    nothing else: a camera ray meets the diffuse panel with probability 0.3, which then reflects rho L (the panel
    is flat: it sees the whole environment above it), else passes straight on to L. Expected pixel: 0.3 rho L +
    0.7 L, per channel. 32 x 32 pixels of 16 samples; each pixel an independent estimate (path_support.py), its
    mean within 5 standard errors of the expectation (about 6e-7 per channel to fail by chance), plus 1e-5
    relative for float32."""
    rho, radiance, opacity = np.array([0.8, 0.5, 0.2]), np.array([0.5, 0.8, 1.2]), 0.3
    scene = raytrace.load_dict(mts.path_scene(
        {"panel": {"type": "diffuse", "reflectance": rho.tolist()},
         "cut": {"type": "mask", "bsdf": "panel", "opacity": opacity}}, [mts.panel("cut")],
        environment=radiance.tolist()))
    image, stats_ = raytrace.render(scene, spp=16, lanes=lanes)
    assert "-DHAS_NULLS=1" in stats_.build_options and stats_.extra["nonfinite_values"] == 0
    pixels = np.asarray(image, np.float64).reshape(-1, 3)
    expected = opacity * rho * radiance + (1 - opacity) * radiance
    mean, se = pixels.mean(axis=0), pixels.std(axis=0, ddof=1) / np.sqrt(len(pixels))
    print(f"lanes {lanes}: mean {mean}, expected {expected}, (mean - expected) / se {(mean - expected) / se}")
    assert np.all(np.abs(mean - expected) <= 5 * se + 1e-5 * expected), (mean, se, expected)


SCENE = """
[camera]
position = [0.0, -3.5, 1.0]
look_at = [0.0, 0.0, 0.6]
up = [0.0, 0.0, 1.0]
fov = 50.0

[image]
width = 24
height = 16

[render]
shading = "path"
max_depth = 8

[environment]
type = "constant"
radiance = [0.3, 0.4, 0.6]

[materials.rear]
reflectance = [0.2, 0.2, 0.9]

[materials.front]
reflectance = {{ type = "bitmap", filename = "{image}", to_uv = [[2.0, 0.5, 0.1], [-0.5, 2.0, 0.3]] }}
back = "rear"

[materials.red]
reflectance = [0.8, 0.1, 0.1]
two_sided = false

[materials.rough]
type = "roughconductor"
alpha = {{ type = "bitmap", filename = "{image}", raw = true, filter_type = "nearest", wrap_mode = "mirror" }}

[materials.glass]
type = "dielectric"

[materials.mix]
type = "blendbsdf"
bsdfs = ["red", "rough"]
weight = {{ type = "checkerboard", color0 = 0.1, color1 = 0.9, to_uv = [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0]] }}

[materials.cut]
type = "mask"
bsdf = "mix"
opacity = {{ type = "bitmap", filename = "{image}", raw = true }}

[materials.half]
type = "mask"
bsdf = "glass"
opacity = 0.5

[[shapes]]
type = "rectangle"
material = "front"
center = [0.0, 0.0, 0.0]
size = [4.0, 4.0]
normal = [0.0, 0.0, 1.0]
tangent = [1.0, 0.0, 0.0]

[[shapes]]
type = "rectangle"
material = "cut"
center = [-0.6, 0.0, 0.8]
size = [1.0, 1.4]
normal = [0.3, -1.0, 0.0]
tangent = [1.0, 0.3, 0.0]

[[shapes]]
type = "ellipsoid"
material = "half"
center = [0.7, 0.2, 0.6]
axes = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.5]]

[[shapes]]
type = "rectangle"
material = "front"
center = [0.0, 1.5, 1.5]
size = [4.0, 3.0]
normal = [0.0, 1.0, 0.0]
tangent = [1.0, 0.0, 0.0]

[[lights]]
center = [0.0, -0.5, 2.4]
size = [0.8, 0.8]
normal = [0.0, 0.0, -1.0]
tangent = [1.0, 0.0, 0.0]
radiance = [6.0, 6.0, 6.0]
"""


@pytest.mark.parametrize("lanes", runnable_lane_widths(), ids=lane_id)
def test_every_wrapper_renders_finite(tmp_path, lanes):
    """A TOML scene of blendbsdf (textured weight), masks (textured and constant opacity, over a blend and over
    glass), a one-sided material, a back side (the far wall, seen from behind) and textured reflectance and
    roughness renders with every new switch on, at every lane width: no NaN or infinity, some light everywhere
    the environment reaches."""
    pixels = np.random.default_rng(23).integers(0, 256, (6, 9, 3), dtype=np.uint8)
    out = oiio.ImageOutput.create(str(tmp_path / "t.png"))
    assert out.open(str(tmp_path / "t.png"), oiio.ImageSpec(9, 6, 3, "uint8")) and out.write_image(pixels)
    out.close()
    scene = raytrace.load_string(SCENE.format(image=tmp_path / "t.png"))
    image, stats_ = raytrace.render(scene, spp=4, lanes=lanes)
    for switch in ("LOOKUPS", "WRAPPERS", "NULLS"):
        assert f"-DHAS_{switch}=1" in stats_.build_options, switch
    image = np.asarray(image)
    assert np.all(np.isfinite(image)) and stats_.extra["nonfinite_values"] == 0
    assert image.min() >= 0 and image.mean() > 0.05
