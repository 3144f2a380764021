"""Textured BSDF parameters (kernels/lookups.cl's lookup_value, raytrace/scene/texture_lookups.py, packing.py's
lookup_structs): Mitsuba 3's bitmap and checkerboard textures from a scene's tables through the host's packing to
the kernel, against the float64 reference of Mitsuba's semantics in tests/lookup_support.py, at every lane width;
the texture's mean the host keeps; and the scene format's refusals.

Mutations tried (each in a copy of the checkout; every one failed the tests named, at every lane width, and the
copy was discarded):
- lookups.cl, checkerboard: colour0 and colour1 swapped: test_checkerboard_matches_mitsuba;
- lookups.cl: the luminance block removed (a float slot reads red): test_bitmap_matches_mitsuba (all 6 wrap and
  filter cases: their RGB images' float slots; the grey ones and the grey checkerboards pass, as they must);
- lookups.cl: eval_1's swap (`same = !same`) removed: test_checkerboard_matches_mitsuba;
- lookups.cl: to_uv's translation m[2] dropped from s: the bitmap, huge-coordinate, render-filter and checkerboard
  tests;
- packing.py: t' = 1 - t not composed (to_uv's second row packed as given): the same four, and
  test_wrappers.py's textured weight;
- lookups.cl: filter -1 read as FILTER_BILINEAR, not the render's: test_render_filter for nearest, trilinear
  and anisotropic;
- lookups.cl: the footprint's t components from the s row (m[0], m[1]): test_render_filter for trilinear and
  anisotropic;
- texture_lookups.py: texture_mean without the sRGB decode: test_texture_mean.
"""
import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
import reference_textures
import lookup_support as mts
from helpers import stored_levels
from raytrace.renderer import packing
from raytrace.scene import mipmap, texture_lookups
from raytrace.scene.model import Material, TextureLookup
from raytrace.scene.textures import make_texture
from raytrace import structs

KERNEL = """
#include "lookups.cl"
__kernel void lookup(int n, TEXTURE_PARAMETERS, int l, int render_filter, __global const float *uv,
                     __global const float *duv, __global float *out)
{
    TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 p = {IN(uv), IN(uv + n)};
    UVDerivatives d = {IN(duv), IN(duv + n), IN(duv + 2 * n), IN(duv + 3 * n)};
    OUT3(out, lookup_value(ts, l, p, d, render_filter));
}
"""
U = 2.0 ** -24  # float32's unit roundoff


def kernel_values(harness, tables, lookup, uv, duv=None, render_filter="bilinear"):
    """N x 3: lookup_value of lookup `lookup` in the packed `tables` at the points uv (N x 2), footprints duv (4 x
    N: du/dx, dv/dx, du/dy, dv/dy; default 0)."""
    n = len(uv)
    args = {**tables, "l": np.int32(lookup), "render_filter": np.int32(structs.FILTERS[render_filter]),
            "uv": np.ascontiguousarray(np.asarray(uv, np.float64).T), "duv": np.zeros((4, n)) if duv is None else duv}
    return harness.run(KERNEL, "lookup", n, args, {"out": 3})["out"].T


def write(path, pixels, fmt):
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
    assert out.open(str(path), spec) and out.write_image(pixels) and out.close(), oiio.geterror()


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    """{name: (file, pixels)}: no side a power of two, no two alike: an 8-bit RGB PNG (9 x 6), a 16-bit one (5 x
    7), a one-channel 8-bit one (7 x 5) and a float RGB EXR (6 x 4), values in [0, 1] (the parameters' ranges)."""
    rng, folder = np.random.default_rng(58), tmp_path_factory.mktemp("lookups")
    images = {"rgb8": (rng.integers(0, 256, (6, 9, 3), dtype=np.uint8), "uint8", "png"),
              "rgb16": (rng.integers(0, 65536, (7, 5, 3), dtype=np.uint16), "uint16", "png"),
              "grey8": (rng.integers(0, 256, (5, 7, 1), dtype=np.uint8), "uint8", "png"),
              "float": (rng.uniform(0, 1, (4, 6, 3)).astype(np.float32), "float", "exr")}
    out = {}
    for name, (pixels, fmt, ext) in images.items():
        write(folder / f"{name}.{ext}", pixels, fmt)
        out[name] = (str(folder / f"{name}.{ext}"), pixels)
    return out


def to_uv(k):
    """The k-th lookup's to_uv: a rotation, an unequal scale with a reflection, a translation (each its own)."""
    angle, (sx, sy) = 0.6 + 0.37 * k, (2.1 - 0.1 * k, -1.6 + 0.05 * k)
    c, s = np.cos(angle), np.sin(angle)
    return [[sx * c, -sy * s, 0.3 + 0.11 * k], [sx * s, sy * c, -0.7 + 0.05 * k]]


# (image, raw, parameter): a colour slot (diffuse's reflectance), or a float one: a blend's weight, a rough
# conductor's alpha (a float slot of an RGB image is its luminance)
CASES = [("rgb8", False, "colour"), ("rgb8", True, "colour"), ("rgb16", False, "colour"), ("rgb16", True, "colour"),
         ("grey8", False, "colour"), ("grey8", True, "colour"), ("float", False, "colour"),
         ("rgb8", False, "weight"), ("rgb8", True, "alpha"), ("rgb16", True, "weight"), ("grey8", False, "weight"),
         ("float", False, "alpha")]


def bitmap_scene(images, filter_type, wrap):
    """A scene whose material k holds CASES[k]'s texture (a bitmap with to_uv(k)); its packed tables and each
    case's lookup."""
    materials = {}
    for k, (image, raw, slot) in enumerate(CASES):
        texture = {"type": "bitmap", "filename": images[image][0], "raw": raw, "filter_type": filter_type,
                   "wrap_mode": wrap, "to_uv": to_uv(k)}
        materials[f"m{k}"] = ({"type": "diffuse", "reflectance": texture} if slot == "colour" else
                              {"type": "blendbsdf", "bsdfs": ["m0", "m0"], "weight": texture} if slot == "weight"
                              else {"type": "roughconductor", "alpha": texture})
    scene = raytrace.load_dict(mts.path_scene(materials, [mts.panel("m0")]))
    tables = packing.texture_tables(scene)
    _, maps = packing.lookup_structs(packing.material_table(scene.materials))
    return tables, [int(maps[k][structs.MAP_SLOTS[slot]]) for k, (_, _, slot) in enumerate(CASES)]


@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp"])
@pytest.mark.parametrize("filter_type", ["nearest", "bilinear"])
def test_bitmap_matches_mitsuba(harness, images, filter_type, wrap):
    """Every case of CASES at 512 random (u, v) in [-3, 4]^2, so (s, t) spans several periods each way (|s|, |t|
    up to ~12), in each wrap mode and Mitsuba filter, the render's own filter anisotropic with footprints of a
    few texels (filter_type wins). Bound: the kernel forms (s, t) in float32 from to_uv's float32 rounding
    (<= u per term) and two multiply-adds (<= 4 u of the terms' sum E = |a u| + |b v| + |c|), then s W - 1/2 and
    the period's reduction (<= 4 u of E W: tests/test_textures.py's reduce bound): within 16 u E max(W, H) texels
    of Mitsuba's position, which moves a bilinear value by at most that times the largest step D between
    neighbouring texels (<= 1 here); the weights' products and sums, the sRGB table's float32 and the luminance's
    dot product add < 2e-6. Nearest: the same texel except within that distance of a texel border; the points
    within 1e-3 texel of one (> 10 times the bound) are skipped, at most 2% of them, the rest exact to 2e-6."""
    tables, lookups = bitmap_scene(images, filter_type, wrap)
    rng = np.random.default_rng(("nearest", "bilinear").index(filter_type) * 3
                                + ("repeat", "mirror", "clamp").index(wrap))
    uv = rng.uniform(-3, 4, (512, 2)).astype(np.float32).astype(np.float64)
    duv = rng.uniform(-0.15, 0.15, (4, 512))
    worst = 0.0
    for k, (image, raw, slot) in enumerate(CASES):
        pixels = images[image][1]
        texels = mts.linear_texels(pixels, raw)
        h, w = texels.shape[:2]
        s, t, extent = mts.mitsuba_st(to_uv(k), uv[:, 0], uv[:, 1])
        want = mts.bitmap(texels, s, t, filter_type, wrap)
        if slot != "colour":
            want = mts.luminance(want)
        got = kernel_values(harness, tables, lookups[k], uv, duv, "anisotropic")
        if filter_type == "nearest":
            clear = ~(mts.near_border(s, w, 1e-3) | mts.near_border(t, h, 1e-3))
            assert clear.mean() > 0.98
            np.testing.assert_allclose(got[clear], want[clear], rtol=0, atol=2e-6, err_msg=str(CASES[k]))
        else:
            step = max(np.abs(np.diff(texels, axis=a)).max() for a in (0, 1))
            bound = 2e-6 + 16 * U * extent * max(w, h) * step
            error = np.abs(got - want).max(axis=1)
            assert np.all(error <= bound), (CASES[k], error.max(), bound[np.argmax(error - bound)])
            worst = max(worst, float((error / bound).max()))
    print(f"{filter_type} {wrap}: worst error / bound {worst:.3g}")


def test_huge_coordinates_wrap_as_mitsuba(harness, images):
    """Texel centres 1000 periods out along s (to_uv's translation 1000.5/W ... ): Mitsuba's wrap of texel index
    i + 1000 W (repeat: the same texel; mirror: the same, as 1000 periods is even; clamp: the last column), and
    one period further (mirror reflects). A centre interpolates nothing, so only the position's rounding counts:
    at |s W| ~ 9000 float32 resolves 1e-3 texel, far inside the half texel that would change the texel: exact
    to 2e-6."""
    pixels = images["rgb8"][1]
    texels = mts.linear_texels(pixels)
    h, w = texels.shape[:2]
    i = np.arange(w)
    for wrap in ("repeat", "mirror", "clamp"):
        for periods in (1000, 1001, -1001):
            rows = [[1.0 / w, 0.0, periods + 0.5 / w], [0.0, 0.0, 1 - 2.5 / h]]  # t = 2.5 / h: row 2
            scene = raytrace.load_dict(mts.path_scene(
                {"m": {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": images["rgb8"][0],
                                                          "wrap_mode": wrap, "to_uv": rows}}}, [mts.panel("m")]))
            uv = np.stack([i.astype(np.float64), np.zeros(w)], axis=1)
            got = kernel_values(harness, packing.texture_tables(scene), 0, uv)
            column = mts.tex_wrap(i + periods * w, w, wrap)
            np.testing.assert_allclose(got, texels[2, column], atol=2e-6, err_msg=f"{wrap} {periods}")


@pytest.mark.parametrize("render_filter", ["nearest", "bilinear", "trilinear", "anisotropic"])
def test_render_filter(harness, images, render_filter):
    """A model TextureLookup with filter None (packed as -1) filters by the render's texture filter: nearest and
    bilinear as Mitsuba's on the finest level (the reference of tests/lookup_support.py), trilinear and anisotropic
    as the course's MIP-mapped filters (tests/reference_textures.py on the levels as the device stores them), with
    the footprint carried through to_uv's linear part (t flipped). Footprints of 0.3 to 3 texels. Bounds: the
    positions' as in test_bitmap_matches_mitsuba (16 u E max(W, H) texels, on steps <= 1 per texel: 5e-5 here),
    the level's rounding (log2 of a float32 footprint length: ~1e-6) on differences between levels <= 1, and the
    blend of levels and probes: 1e-4 in all; nearest as there."""
    pixels = images["rgb8"][1]
    texture = make_texture(pixels, "8-bit", "colour")
    rows = to_uv(3)
    lookup = TextureLookup("bitmap", 0, "mirror", None, tuple(np.ravel(rows)))
    lookups, maps = packing.lookup_structs([Material("m", np.zeros(3), maps=(("colour", lookup),))])
    assert lookups["filter"][maps[0][structs.MAP_SLOTS["colour"]]] == -1
    texels, levels, table = packing.pack_textures([texture])
    tables = {"textures": table, "mip_levels": levels, "texels": texels, "lookups": lookups,
              "srgb_to_linear": mipmap.SRGB8_TO_LINEAR.astype(np.float32)}
    rng = np.random.default_rng(3)
    n = 512
    uv = rng.uniform(-1, 2, (n, 2)).astype(np.float32).astype(np.float64)
    h, w = pixels.shape[:2]
    duv = (rng.uniform(-1, 1, (4, n)) * np.exp(rng.uniform(np.log(0.3), np.log(3), n)) / w).astype(np.float32)
    got = kernel_values(harness, tables, 0, uv, duv.astype(np.float64), render_filter)
    s, t, extent = mts.mitsuba_st(rows, uv[:, 0], uv[:, 1])
    (a, b, _), (d, e, _) = np.asarray(rows)
    du_x, dv_x, du_y, dv_y = duv.astype(np.float64)
    derivs = (a * du_x + b * dv_x, -(d * du_x + e * dv_x), a * du_y + b * dv_y, -(d * du_y + e * dv_y))
    if render_filter in ("nearest", "bilinear"):
        want = mts.bitmap(mts.linear_texels(pixels), s, t, render_filter, "mirror")
    else:
        want = reference_textures.lookup(stored_levels(texture), render_filter, s, t, derivs, "mirror")
    if render_filter == "nearest":
        clear = ~(mts.near_border(s, w, 1e-3) | mts.near_border(t, h, 1e-3))
        got, want = got[clear], want[clear]
    error = np.abs(got - want).max()
    assert error <= (2e-6 if render_filter == "nearest" else 1e-4), error
    print(f"{render_filter}: worst error {error:.3g}")


def checkerboard_case(harness, colours, seed):
    """(kernel, Mitsuba's reference, points clear of the squares' borders) for three checkerboards, each with its
    general to_uv and its colour pair of `colours`: on a colour slot (a diffuse's reflectance) and on two float
    slots (a blend's weight, a rough dielectric's alpha), at 1024 points over many squares."""
    materials = {"d": {"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": colours[0][0],
                                                          "color1": colours[0][1], "to_uv": to_uv(0)}},
                 "b": {"type": "blendbsdf", "bsdfs": ["d", "d"],
                       "weight": {"type": "checkerboard", "color0": colours[1][0], "color1": colours[1][1],
                                  "to_uv": to_uv(1)}},
                 "r": {"type": "roughdielectric", "alpha": {"type": "checkerboard", "color0": colours[2][0],
                                                             "color1": colours[2][1], "to_uv": to_uv(2)}}}
    scene = raytrace.load_dict(mts.path_scene(materials, [mts.panel("d")]))
    tables = packing.texture_tables(scene)
    _, maps = packing.lookup_structs(packing.material_table(scene.materials))
    uv = np.random.default_rng(seed).uniform(-3, 4, (1024, 2)).astype(np.float32).astype(np.float64)
    out = []
    for k, slot in enumerate(("colour", "weight", "alpha")):
        got = kernel_values(harness, tables, int(maps[k][structs.MAP_SLOTS[slot]]), uv)
        s, t, _ = mts.mitsuba_st(to_uv(k), uv[:, 0], uv[:, 1])
        want = mts.checkerboard(s, t, *colours[k], float_slot=slot != "colour")
        clear = ~(mts.near_border(s, 2, 2e-4) | mts.near_border(t, 2, 2e-4))
        assert clear.mean() > 0.99
        out.append((slot, got[clear], want[clear]))
    return out


def test_checkerboard_matches_mitsuba(harness):
    """Checkerboards of RGB colours on a colour slot (Mitsuba's eval: colour0 where the fractions of s and t lie
    on the same side of 1/2) and of two greys on float slots (eval_1: its masks swapped, colour1 there), each with
    its general to_uv (the reference checked against Mitsuba 3.9.1's own plugin at 2000 points). Exact (the
    colours are stored as they are; a grey's luminance rounds thrice, < 2e-7), except within 2e-4 of a square's
    border, beyond the position's rounding (16 u E < 2e-5 at E < 20): skipped, < 1% of the points."""
    colours = [([0.9, 0.1, 0.3], [0.05, 0.7, 0.2]), (0.8, 0.15), (0.05, 0.6)]
    for slot, got, want in checkerboard_case(harness, colours, 5):
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-7, err_msg=slot)


def test_checkerboard_of_rgb_colours_on_float_slots(harness):
    """A float slot's checkerboard of RGB colours: Mitsuba's eval_1 of the colour (an srgb spectrum: the mean of
    its channels, src/spectra/srgb.cpp), colour1 where eval gives colour0. Bound as above."""
    colours = [([0.9, 0.1, 0.3], [0.05, 0.7, 0.2]), ([0.2, 0.3, 0.95], [1.0, 0.8, 0.0]),
               ([0.6, 0.6, 0.1], [0.0, 0.1, 0.9])]
    for slot, got, want in checkerboard_case(harness, colours, 6):
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-7, err_msg=slot)


def test_checkerboard_defaults_are_mitsubas():
    """Mitsuba's checkerboard defaults: color0 0.4, color1 0.2, grey."""
    scene = raytrace.load_dict(mts.path_scene({"d": {"type": "diffuse", "reflectance": {"type": "checkerboard"}}},
                                              [mts.panel("d")]))
    lookup = dict(scene.materials[0].maps)["colour"]
    assert (lookup.colour0, lookup.colour1) == ((0.4,) * 3, (0.2,) * 3)


def test_texture_mean(images):
    """texture_lookups.texture_mean against the numpy mean of the reference's decoding of the file's pixels, for
    each image as colour and raw; and a material's constant value, the mean (a colour slot) or its luminance (a
    float slot), as the host keeps it. Both sides are float64 means of the same decoded texels (the host's sRGB
    table is the curve in float64): 1e-12, but a 16-bit image's texels are stored decoded to float32, each
    within 2^-24 relative: 2^-23 there."""
    for image, (path, pixels) in images.items():
        for raw in (False, True):
            texture = {"type": "bitmap", "filename": path, "raw": raw}
            scene = raytrace.load_dict(mts.path_scene(
                {"d": {"type": "diffuse", "reflectance": texture},
                 "b": {"type": "blendbsdf", "bsdfs": ["d", "d"], "weight": texture}}, [mts.panel("d")]))
            want = mts.linear_texels(pixels, raw).reshape(-1, 3).mean(axis=0)
            got = texture_lookups.texture_mean(scene.textures[dict(scene.materials[0].maps)["colour"].texture])
            rtol = 2.0 ** -23 if image == "rgb16" else 1e-12
            np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-15, err_msg=f"{image} raw={raw}")
            np.testing.assert_allclose(scene.materials[0].colour, want, rtol=rtol, err_msg=image)
            np.testing.assert_allclose(scene.materials[1].weight, want @ mts.LUMINANCE, rtol=rtol, err_msg=image)


BITMAP = {"type": "bitmap", "filename": "FILE"}
CHECKER = {"type": "checkerboard", "color0": 0.1, "color1": 0.3}


@pytest.mark.parametrize("material, key, value, problem", [
    ({"type": "roughplastic", "alpha": CHECKER}, "materials.b.alpha", CHECKER,
     'takes a value, not a texture, in type = "roughplastic"'),
    ({"type": "plastic", "int_ior": CHECKER}, "materials.b.int_ior", CHECKER,
     'takes a value, not a texture, in type = "plastic"'),
    ({"type": "diffuse", "reflectance": {"type": "bitmap"}}, "materials.b.reflectance.filename", None,
     'missing (type = "bitmap" reads an image)'),
    ({"type": "diffuse", "reflectance": {**CHECKER, "raw": True}}, "materials.b.reflectance.raw", True,
     'is not a parameter of type = "checkerboard"'),
    ({"type": "diffuse", "reflectance": {**BITMAP, "color1": 0.3}}, "materials.b.reflectance.color1", 0.3,
     'is not a parameter of type = "bitmap"'),
    ({"type": "diffuse", "reflectance": {**BITMAP, "offset": 2.0}}, "materials.b.reflectance.offset", 2.0,
     "unknown key (expected one of: color0, color1, filename, filter_type, name, raw, scale, to_uv, type, "
     "wrap_mode)"),
    ({"type": "mask", "bsdf": "d", "opacity": {**BITMAP, "wrap_mode": "periodic"}},
     "materials.b.opacity.wrap_mode", "periodic", "must be one of: repeat, mirror, clamp"),
    ({"type": "dielectric", "colour": CHECKER, "texture": "FILE"}, "materials.b.texture", "FILE",
     "not with a textured colour: one texture gives a material's colour"),
    ({"type": "principled", "base_color": CHECKER, "texture": "FILE"}, "materials.b.texture", "FILE",
     "not with a textured base_color: one texture gives a material's colour"),
], ids=["roughplastic-alpha", "plastic-ior", "no-filename", "checker-raw", "bitmap-color1", "unknown", "wrap",
        "colour-map-and-colour", "colour-map-and-base_color"])
def test_refusals(images, material, key, value, problem):
    """A texture where the parameter takes a value only (a roughplastic's alpha, whose transmittance table is
    found for one number, as in Mitsuba; an index of refraction), a bitmap without its image, another kind's key,
    an unknown key, an unknown wrap mode, a colour map (the course's `texture`) beside a textured colour (the
    kernel read the one and the range checks the other: the fuzz suite found a colour of 2^31 rendering inf):
    one line naming the key's path and its value."""
    material = {k: {**v, "filename": images["rgb8"][0]} if isinstance(v, dict) and v.get("filename") == "FILE"
                else images["rgb8"][0] if v == "FILE" else v for k, v in material.items()}
    value = images["rgb8"][0] if value == "FILE" else value
    with pytest.raises(raytrace.InputError) as e:
        raytrace.load_dict(mts.path_scene({"d": {"colour": [0.5] * 3}, "b": material}, [mts.panel("d")]))
    assert (e.value.source, e.value.key, e.value.value) == ("load_dict()", key, value)
    assert str(e.value).endswith(problem) and "\n" not in str(e.value), str(e.value)


@pytest.mark.parametrize("texture", ["bitmap", "checkerboard"])
def test_the_brightest_value_of_a_colour_texture_bounds_the_albedo(tmp_path, texture):
    """Rule 5 (ranges.py) bounds a path's throughput by the largest albedo: of a textured colour, the texture's
    brightest value (an image's brightest texel, a checkerboard's brighter colour), not the mean the material
    keeps as its colour. An image of 2 x 2 texels, three of 0.01 and one of 50 (mean 12.5): refused with
    max_depth = -1, naming the key that holds the texture; accepted with max_depth = 4; and a texture of values
    up to 1 accepted either way. Mutation: ranges.base_albedo taking the mean (the lookup ignored): both cases
    accept the bright texture and fail."""
    pixels = np.full((2, 2, 3), 0.01, np.float32)
    pixels[0, 0] = 50.0
    oiio.ImageBuf(pixels).write(str(tmp_path / "hot.exr"))
    hot = ({"type": "bitmap", "filename": str(tmp_path / "hot.exr")} if texture == "bitmap" else
           {"type": "checkerboard", "color0": 0.01, "color1": 50.0})
    cool = {"type": "checkerboard", "color0": 0.2, "color1": 1.0}
    for material, max_depth, refused in ((hot, -1, True), (hot, 4, False), (cool, -1, False)):
        table = mts.path_scene({"m": {"type": "diffuse", "reflectance": material}}, [mts.panel("m")],
                               max_depth=max_depth)
        if not refused:
            raytrace.load_dict(table)
            continue
        with pytest.raises(raytrace.InputError) as e:
            raytrace.load_dict(table)
        assert e.value.key == "materials.m.reflectance" and "an albedo of 50" in str(e.value), str(e.value)
