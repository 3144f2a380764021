"""Texture images and lookups inside one level (raytrace/scene/textures.py, kernels/textures.cl): real files of
every kind written and read back, the decoding of stored texels, wrap modes, nearest and bilinear filtering
against the float64 reference (tests/reference_textures.py) and against OpenImageIO's TextureSystem."""
import numpy as np
import OpenImageIO as oiio
import pytest

import reference_textures as ref
from helpers import kernel_lookup, openimageio_lookup, stored_levels
from raytrace.renderer import packing
from raytrace.scene import mipmap
from raytrace import structs
from raytrace.errors import InputError
from raytrace.scene.textures import load_texture, make_texture

def random_uv(rng, n, lo=-1.5, hi=2.5):
    """Points covering several periods, so every wrap mode folds some of them."""
    return rng.uniform(lo, hi, n), rng.uniform(lo, hi, n)


# --- files ----------------------------------------------------------------------------------------------

def write(path, pixels, fmt):
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
    spec.attribute("oiio:UnassociatedAlpha", 1)  # write the colours as given, not divided by alpha
    assert out.open(str(path), spec) and out.write_image(pixels) and out.close(), oiio.geterror()


FORMATS = [  # (file, OpenImageIO format, numpy type, code scale)
    ("png8.png", "uint8", np.uint8, 255), ("png16.png", "uint16", np.uint16, 65535),
    ("tif16.tif", "uint16", np.uint16, 65535), ("jpeg.jpg", "uint8", np.uint8, 255),
    ("half.exr", "half", np.float16, None), ("float.exr", "float", np.float32, None),
    ("float.tif", "float", np.float32, None)]


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("name, fmt, dtype, scale", FORMATS, ids=[f[0] for f in FORMATS])
def test_every_format_reads_back_as_linear(tmp_path, name, fmt, dtype, scale, channels):
    """A 13 x 7 image (no power of two) in each format and channel count: level 0 decodes to the reference's
    linear values. Bounds: exact formats 1e-6 (float32 rounding of the decode); JPEG is lossy, so it only
    has to agree in the mean within 2 codes (JPEG of a smooth ramp)."""
    if name.startswith("jpeg") and channels in (2, 4):
        pytest.skip("JPEG has no alpha channel")
    yy, xx = np.mgrid[0:7, 0:13]
    base = np.stack([(xx + 2 * yy) / 30, xx / 12, yy / 6, np.full_like(xx, 0.5, dtype=float)], axis=2)[..., :channels]
    pixels = (np.round(base * scale) if scale else base).astype(dtype)
    write(tmp_path / name, pixels, fmt)
    for role in ("colour", "height"):
        texture = load_texture(tmp_path / name, role, "scene.toml", "materials.m.texture")
        assert texture.size == (13, 7) and len(texture.levels) == 4  # 13x7, 6x3, 3x1, 1x1
        got = stored_levels(texture)[0]
        want = ref.image_to_linear(pixels, srgb=role == "colour")
        if role == "height":  # the height is the first channel
            got, want = got[..., 0], want[..., 0]
        if name.startswith("jpeg"):
            assert abs(got.mean() - want.mean()) < 2 / 255
        else:
            np.testing.assert_allclose(got, want, atol=1e-6)


def test_eight_bit_stays_eight_bit(tmp_path):
    """8-bit files take one 32-bit word per texel on the device, with the file's codes unchanged."""
    codes = np.random.default_rng(1).integers(0, 256, (16, 16, 3), dtype=np.uint8)
    write(tmp_path / "c.png", codes, "uint8")
    colour = load_texture(tmp_path / "c.png", "colour", "s", "k")
    data = load_texture(tmp_path / "c.png", "normal", "s", "k")
    assert colour.encoding == structs.TEXELS_SRGB8 and data.encoding == structs.TEXELS_UNORM8
    np.testing.assert_array_equal(colour.levels[0][..., :3], codes)
    texels, _, _ = packing.pack_textures([colour])
    assert texels.nbytes == 4 * sum(level.shape[0] * level.shape[1] for level in colour.levels)


@pytest.mark.parametrize("kind, encoding", [("8-bit", structs.TEXELS_QUAD8), ("16-bit", structs.TEXELS_QUAD16),
                                           ("float", structs.TEXELS_QUADF)])
def test_height_maps_hold_quads(kind, encoding):
    """A height map's texel (i, j) holds its own height and those of (i + 1, j), (i, j + 1) and (i + 1, j + 1),
    0 beyond the edges, at every level (kernels/types.h); the words per texel stay 1 (8-bit), 2 (16-bit: level
    0 the file's codes, as OpenImageIO gives them, code / 65535 in float32) and 4."""
    rng = np.random.default_rng(3)
    codes = rng.integers(1, 65536 if kind == "16-bit" else 256, (5, 7, 1))
    heights = {"8-bit": codes.astype(np.uint8), "16-bit": (codes / 65535).astype(np.float32),
               "float": (codes / 255).astype(np.float32)}[kind]
    texture = make_texture(heights, kind, "height")
    assert texture.encoding == encoding and len(texture.levels) == 3  # 7 x 5, 3 x 2, 1 x 1
    for level in texture.levels:
        h = np.pad(level[..., 0], ((0, 1), (0, 1)))
        np.testing.assert_array_equal(level, np.stack([h[:-1, :-1], h[:-1, 1:], h[1:, :-1], h[1:, 1:]], axis=2))
    np.testing.assert_array_equal(texture.levels[0][..., 0], codes[..., 0] if kind == "16-bit" else heights[..., 0])
    texels, _, _ = packing.pack_textures([texture])
    assert texels.size == structs.TEXEL_WORDS[encoding] * sum(level[..., 0].size for level in texture.levels)


@pytest.mark.parametrize("content, problem", [
    (None, "cannot read the image"), (b"not an image", "cannot read the image"),
    ("grey", "a normal map needs 3 channels")])
def test_bad_texture_files(tmp_path, content, problem):
    path = tmp_path / "t.png"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content == "grey":
        write(path, np.zeros((4, 4, 1), np.uint8), "uint8")
    with pytest.raises(InputError) as e:
        load_texture(path, "normal", "scene.toml", "materials.m.normal_map")
    assert e.value.source == "scene.toml" and e.value.key == "materials.m.normal_map"
    assert e.value.value == str(path) and problem in str(e.value)


@pytest.mark.parametrize("value, problem", [(-0.5, ("heights must be >= 0", "its lowest is -0.5")),
                                            (np.nan, ("NaN or infinite",)), (np.inf, ("NaN or infinite",))])
def test_bad_float_height_maps(tmp_path, value, problem):
    """A float height map with a negative height (the surface would be displaced behind itself and shadow
    every point of it) or a non-finite one: one error naming the scene, the key and the file."""
    pixels = np.full((4, 4, 1), 0.25, np.float32)
    pixels[1, 2] = value
    path = tmp_path / "h.exr"
    write(path, pixels, "float")
    with pytest.raises(InputError) as e:
        load_texture(path, "height", "scene.toml", "materials.m.height_map")
    assert (e.value.source, e.value.key, e.value.value) == ("scene.toml", "materials.m.height_map", str(path))
    assert all(part in str(e.value) for part in problem)


@pytest.mark.parametrize("fmt, value, problem", [
    ("float", -0.5, ("a colour map's values must be >= 0", "its lowest is -0.5")),
    ("float", np.nan, ("NaN or infinite", "texel (x=2, y=1)")), ("float", np.inf, ("NaN or infinite",)),
    ("double", 1e39, ("beyond float32's range", "1e+39")),
    ("int16", -1000, ("a colour map's values must be >= 0",))])
def test_bad_colour_maps(tmp_path, fmt, value, problem):
    """A colour map with a negative value (it would reflect negative light: float files, and signed integer
    ones, which OpenImageIO reads as [-1, 1]), a NaN or infinite one, or one beyond float32 (a float64 TIFF,
    which reading as float32 would turn into inf): one error naming the scene, the key and the file."""
    dtype = {"float": np.float32, "double": np.float64, "int16": np.int16}[fmt]
    pixels = np.full((4, 4, 3), 0.25 if fmt != "int16" else 1000, dtype)
    pixels[1, 2, 1] = value
    path = tmp_path / "c.tif"
    write(path, pixels, fmt)
    with pytest.raises(InputError) as e:
        load_texture(path, "colour", "scene.toml", "materials.m.texture")
    assert (e.value.source, e.value.key, e.value.value) == ("scene.toml", "materials.m.texture", str(path))
    assert all(part in str(e.value) for part in problem), str(e.value)


def broken_png(path):
    write(path, np.zeros((16, 16, 3), np.uint8), "uint8")
    path.write_bytes(path.read_bytes()[:-30])


def broken_exr(path):
    """An EXR whose header turns into bytes that are not UTF-8 after its first attribute: OpenImageIO's
    error message quotes them, and its Python binding raised UnicodeDecodeError reading that message."""
    write(path, np.zeros((4, 4, 3), np.float32), "float")
    path.write_bytes(path.read_bytes()[:48] + np.random.default_rng(0).bytes(400))


@pytest.mark.parametrize("make, name, problem", [
    (broken_png, "t.png", "libpng error: IDAT"),
    (broken_exr, "t.exr", "cannot read the image: EXR Error"),
    (lambda path: None, "missing.null", "OpenImageIO's null plugin"),
    (lambda path: path.mkdir(), "d.png", "is not a regular file")])
def test_unreadable_textures_are_one_line(tmp_path, capfd, make, name, problem):
    """libpng prints its error on fd 2 itself (a second line before ours): it is captured and becomes our
    line's reason. No error is left pending in OpenImageIO (it would print one when the process exits).
    OpenImageIO's "null" plugin makes up an image for any name ending in .null, existing or not: refused."""
    path = tmp_path / name
    make(path)
    with pytest.raises(InputError) as e:
        load_texture(path, "colour", "scene.toml", "materials.m.texture")
    assert e.value.value == str(path) and problem in str(e.value) and "\n" not in str(e.value), str(e.value)
    assert capfd.readouterr().err == "" and oiio.geterror() == ""


def test_srgb_table_is_the_standard_curve():
    """The kernel's decoding table against the reference's formula, at every code."""
    np.testing.assert_allclose(mipmap.SRGB8_TO_LINEAR, ref.srgb_to_linear(np.arange(256) / 255), rtol=1e-15)
    assert mipmap.SRGB8_TO_LINEAR[0] == 0 and mipmap.SRGB8_TO_LINEAR[255] == 1


# --- lookups in one level ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def textures():
    """An 8-bit sRGB colour map (11 x 6), an 8-bit data map (8 x 8), a float height map (5 x 9, in quads), a
    float colour map (7 x 4), an 8-bit height map (6 x 10, in quads) and a 16-bit one (7 x 5, in quads)."""
    rng = np.random.default_rng(7)
    return [make_texture(rng.integers(0, 256, (6, 11, 3), dtype=np.uint8), "8-bit", "colour"),
            make_texture(rng.integers(0, 256, (8, 8, 3), dtype=np.uint8), "8-bit", "normal"),
            make_texture(rng.uniform(-1, 4, (9, 5, 1)).astype(np.float32), "float", "height"),
            make_texture(rng.uniform(0, 4, (4, 7, 3)).astype(np.float32), "float", "colour"),
            make_texture(rng.integers(0, 256, (10, 6, 1), dtype=np.uint8), "8-bit", "height"),
            make_texture((rng.integers(0, 65536, (5, 7, 1)) / 65535).astype(np.float32), "16-bit", "height")]


@pytest.mark.parametrize("wrap", list(structs.WRAP_MODES))
@pytest.mark.parametrize("index", [0, 1, 2, 3, 4, 5], ids=["srgb8", "unorm8", "quadf", "float", "quad8", "quad16"])
def test_nearest_and_bilinear_match_reference(harness, textures, index, wrap):
    """Level-0 lookups at random points over several periods, in each wrap mode and storage. Bilinear: the
    weights are float32 products of coordinates up to 2.5 * 11 texels (error ~ 2^-24 * 30 per weight), on
    values up to 4: bound 1e-5. Nearest picks the same texel except within float32 rounding of a texel
    border, which the test skips (distance < 1e-4 texels)."""
    rng = np.random.default_rng(index)
    s, t = random_uv(rng, 512)
    levels = stored_levels(textures[index])
    h, w = levels[0].shape[:2]
    got = kernel_lookup(harness, textures, index, "bilinear", wrap, s, t)
    np.testing.assert_allclose(got, ref.bilinear(levels[0], s, t, wrap), atol=1e-5)
    fx, fy = s * w, t * h
    clear = (np.abs(fx - np.round(fx)) > 1e-4) & (np.abs(fy - np.round(fy)) > 1e-4)
    got = kernel_lookup(harness, textures, index, "nearest", wrap, s, t)
    np.testing.assert_allclose(got[clear], ref.nearest(levels[0], s, t, wrap)[clear], atol=1e-6)


def test_wrap_modes_fold_as_specified(harness, textures):
    """Texel centres one, two and three periods away: repeat returns the same texel, mirror the reflected
    one on odd periods, clamp the border texel. Exact (a texel centre interpolates nothing)."""
    level = stored_levels(textures[2])[0]  # 5 x 9 floats
    h, w = level.shape[:2]
    i = np.arange(-3 * w, 4 * w)
    s, t = (i + 0.5) / w, np.full(i.shape, 2.5 / h)
    expect = {"repeat": i % w, "clamp": np.clip(i, 0, w - 1),
              "mirror": np.where((i // w) % 2 == 0, i % w, w - 1 - i % w)}
    for wrap, column in expect.items():
        got = kernel_lookup(harness, textures, 2, "bilinear", wrap, s, t)
        np.testing.assert_allclose(got, level[2, column], atol=1e-6, err_msg=wrap)


def test_huge_and_nonfinite_coordinates_stay_in_the_texture(harness, textures):
    """uv of 1e9 (a grazing floor with a large uv_scale) or NaN must read a texel of the texture, never
    memory beyond it: every value returned lies in the texture's range."""
    s = np.array([1e9, -1e9, 3e7, np.nan, np.inf, -np.inf, 0.5, 1e30])
    for wrap in structs.WRAP_MODES:
        for f in structs.FILTERS:
            got = kernel_lookup(harness, textures, 2, f, wrap, s, s[::-1], np.full((4, 8), 1e-3))
            level = stored_levels(textures[2])[0]
            assert np.all(np.isfinite(got)) and np.all(got >= level.min() - 1e-6) and np.all(got <= level.max() + 1e-6)


def test_bilinear_matches_openimageio(harness, tmp_path):
    """OpenImageIO's TextureSystem as an independent oracle: its bilinear mode without MIP-mapping
    interpolates the same texel centres (documented to agree with a plain bilinear to 5e-7). Float
    texture, so no decoding differs; bound 2e-6."""
    rng = np.random.default_rng(3)
    image = rng.random((12, 20, 3)).astype(np.float32)
    s, t = random_uv(rng, 64, 0.0, 1.0)
    want = openimageio_lookup(tmp_path, image, oiio.MipMode.NoMIP, s, t)
    got = kernel_lookup(harness, [make_texture(image, "float", "colour")], 0, "bilinear", "repeat", s, t)
    np.testing.assert_allclose(got, want, atol=2e-6)


REDUCE = """
#include "textures.cl"
__kernel void reduce(int n, __global const float *x, int size, int mode, __global float *out)
{
    OUT(out, reduce_coordinate(IN(x), (vint)(size), mode));
}
"""


def test_reduced_coordinates_stay_within_two_periods(harness):
    """reduce_coordinate for |x| from 1 to 1.2e38 and periods that are not powers of 2 (x / period rounds):
    the result lies within two periods of 0 (so its floor fits an int and wrap_index's cheap path applies)
    and, while x resolves a period (|x| < 2^20 here), equals x modulo the period up to rounding (the
    quotient's rounding is absorbed by floor, the product and difference round once each: 2 ulp of
    the larger of |x| and the results, below 2 periods)."""
    x = np.float32(10.0) ** np.linspace(0, 38, 600).astype(np.float32) * np.float32(1.2345)
    x = np.concatenate([x, -x, np.zeros((-2 * len(x)) % 8, np.float32)])
    for size in (7, 9, 300):
        for mode in ("repeat", "mirror"):
            period = size * (2 if mode == "mirror" else 1)
            r = harness.run(REDUCE, "reduce", len(x), [x, np.int32(size), np.int32(structs.WRAP_MODES[mode])],
                            {"out": 1})["out"].astype(np.float64)
            assert np.all(np.abs(r) < 2 * period), (size, mode)
            fine = np.abs(x) < 2 ** 20
            turns = (x[fine].astype(np.float64) - r[fine]) / period
            ulp = np.spacing(np.maximum(np.abs(x[fine]), 2 * period).astype(np.float32))
            assert np.all(np.abs(turns - np.round(turns)) * period <= 2 * ulp), (size, mode)
            assert np.all(r[fine] > -1e-3) and np.all(r[fine] < period + 1e-3), (size, mode)


WRAP = """
#include "textures.cl"
__kernel void wrap(int n, __global const float *i, int size, int mode, __global float *out)
{
    OUT(out, CONVERT_VFLOAT(wrap_index(CONVERT_VINT(IN(i)), (vint)(size), mode)));
}
"""


def test_wrap_index_over_many_periods(harness):
    """wrap_index against numpy's modulo for indices within a period of [0, n) (the cheap path) and far
    beyond (integer division), negative ones included: exact."""
    size = 7
    i = np.concatenate([np.arange(-3 * size, 4 * size), [-10**6 - 3, -1000, 1000, 10**6 + 5]])
    i = np.concatenate([i, np.zeros((-len(i)) % 8)])
    for mode, expect in [("repeat", i % size), ("clamp", np.clip(i, 0, size - 1)),
                         ("mirror", np.where((i // size) % 2 == 0, i % size, size - 1 - i % size))]:
        out = harness.run(WRAP, "wrap", len(i), [i.astype(np.float32), np.int32(size),
                                                 np.int32(structs.WRAP_MODES[mode])], {"out": 1})["out"]
        np.testing.assert_array_equal(out, expect, err_msg=mode)
