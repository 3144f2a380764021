"""What tests/test_lookups.py and tests/test_wrappers.py share: a float64 numpy reference of Mitsuba 3's texture
plugins as v3.9.1 evaluates them (src/textures/bitmap.cpp, checkerboard.cpp, and underneath them Dr.Jit's
Texture class and its tex_wrap), the composition of a scene's to_uv with the image's rows, and the scene
tables both modules build on.

Nothing here is imported from raytrace: the reference transcribes Mitsuba's code, so a slip in the kernel or in the
host's packing cannot hide in both. It was checked against Mitsuba 3.9.1's own plugins (scalar_rgb, eval and
eval_1): bitmaps of the four kinds tests/test_lookups.py writes, raw or not, both filters, the three wrap modes,
under a rotated and scaled to_uv, 200 points each: worst difference 2.4e-4 (Mitsuba's float32 at |s| ~ 12);
checkerboards of RGB colours at 2000 points: equal.

Mitsuba's conventions, as the reference keeps them:
- a bitmap's (s, t) = to_uv (u, v); texel (i, j) (column i, row j, row 0 the image's top) has its centre at
  ((i + 1/2) / W, (j + 1/2) / H); `nearest` reads texel floor(s W), floor(t H); `bilinear` interpolates the four
  centres around (s W - 1/2, t H - 1/2) (bitmap.cpp's bilinear_weights);
- out of range texel indices wrap by Dr.Jit's tex_wrap: repeat, a Euclidean modulo; mirror, that modulo reflected
  on odd periods (counted from a truncated division of i + 1 for negative i); clamp;
- an 8-bit image's codes decode by the sRGB curve unless raw; a float image's values are taken as they are; one
  channel gives grey;
- a float parameter (eval_1) of an RGB image is its interpolated colour's luminance (Rec. 709 weights);
- the checkerboard gives color0 where the fractions of s and t lie on the same side of 1/2 (eval); eval_1, a float
  parameter's, gives color1 there (its masks are swapped in checkerboard.cpp), as that colour's eval_1: the mean
  of an RGB colour's channels.

raytrace's scene format writes to_uv with t up the image (the surface's v); Mitsuba's t runs down the rows:
t_mitsuba = 1 - t_scene (texture_lookups.py's docstring), which `mitsuba_st` applies."""
import numpy as np

# Mitsuba's luminance() of linear sRGB (its core spectrum header)
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])


def srgb_decode(c):
    """Linear values of sRGB-encoded values c in [0, 1] (the IEC 61966-2-1 curve), float64."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_texels(pixels, raw=False):
    """H x W x 3 float64 linear texels of an image as Mitsuba reads it: 8- and 16-bit codes over their largest
    code, sRGB-decoded unless raw; floats as they are; one channel replicated to three."""
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    assert pixels.ndim == 3 and 1 <= pixels.shape[2] <= 4, pixels.shape
    if pixels.dtype in (np.uint8, np.uint16):
        code = pixels / float(np.iinfo(pixels.dtype).max)
        x = code if raw else srgb_decode(code)
    else:
        x = pixels.astype(np.float64)
    return np.repeat(x[..., :1], 3, axis=2) if x.shape[2] == 1 else x[..., :3]


def tex_wrap(i, n, mode):
    """Dr.Jit's tex_wrap of integer texel indices i along a side of n texels, transcribed (C's division
    truncates towards 0)."""
    assert mode in ("repeat", "mirror", "clamp"), mode
    i = np.asarray(i, np.int64)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    shifted = np.where(i < 0, i + 1, i)
    div = np.trunc(shifted / n).astype(np.int64)
    mod = i - div * n
    mod = np.where(mod < 0, mod + n, mod)
    if mode == "mirror":
        mod = np.where(((div & 1) == 0) ^ (i < 0), mod, n - 1 - mod)
    return mod


def bitmap(texels, s, t, filter_type, wrap):
    """N x 3: Mitsuba's bitmap of linear `texels` (H x W x 3, row 0 the top) at its texture coordinates (s, t)."""
    assert filter_type in ("nearest", "bilinear") and texels.ndim == 3 and texels.shape[2] == 3, filter_type
    h, w = texels.shape[:2]
    s, t = np.asarray(s, np.float64), np.asarray(t, np.float64)
    if filter_type == "nearest":
        return texels[tex_wrap(np.floor(t * h), h, wrap), tex_wrap(np.floor(s * w), w, wrap)]
    x, y = s * w - 0.5, t * h - 0.5
    i, j = np.floor(x), np.floor(y)
    fx, fy = (x - i)[:, None], (y - j)[:, None]
    i0, i1, j0, j1 = tex_wrap(i, w, wrap), tex_wrap(i + 1, w, wrap), tex_wrap(j, h, wrap), tex_wrap(j + 1, h, wrap)
    return ((1 - fy) * ((1 - fx) * texels[j0, i0] + fx * texels[j0, i1])
            + fy * ((1 - fx) * texels[j1, i0] + fx * texels[j1, i1]))


def checkerboard(s, t, colour0, colour1, float_slot):
    """N x 3: Mitsuba's checkerboard at (s, t): eval, a colour; or, float_slot, eval_1 (thrice), which takes the
    other colour and that colour's own eval_1: an RGB constant's (Mitsuba's srgb spectrum, RGB variants) is the
    mean of its channels, not its luminance (src/spectra/srgb.cpp: eval_1 returns mean())."""
    a = (s - np.floor(s)) > 0.5
    b = (t - np.floor(t)) > 0.5
    first = (a == b) if not float_slot else (a != b)
    c = np.where(first[:, None], np.asarray(colour0, np.float64), np.asarray(colour1, np.float64))
    return np.repeat(c.mean(axis=1, keepdims=True), 3, axis=1) if float_slot else c


def luminance(rgb):
    """N x 3: the luminance of each row, thrice (what the kernel returns for a float parameter)."""
    return np.repeat((np.asarray(rgb, np.float64) @ LUMINANCE)[:, None], 3, axis=1)


def mitsuba_st(to_uv, u, v):
    """Mitsuba's texture coordinates (s, t) of surface points (u, v) under a scene's to_uv rows ((a, b, c), (d, e,
    f)), whose t runs up the image: s = a u + b v + c, t = 1 - (d u + e v + f); and the extent |a u| + |b v| + |c|
    (and its t's) of the sums, which bound their float32 rounding."""
    (a, b, c), (d, e, f) = np.asarray(to_uv, np.float64)
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    extent = np.maximum(np.abs(a * u) + np.abs(b * v) + abs(c), np.abs(d * u) + np.abs(e * v) + abs(f) + 1)
    return a * u + b * v + c, 1.0 - (d * u + e * v + f), extent


def near_border(x, cells, margin):
    """Where x (in units of whole periods) lies within `margin` cells of a border of `cells` equal cells."""
    y = np.asarray(x, np.float64) * cells
    return np.abs(y - np.round(y)) < margin


def path_scene(materials, shapes, camera=None, width=32, height=32, environment=1.0, **render):
    """A path-model scene table: `materials` and `shapes` under a constant environment of radiance `environment`
    and no light, seen by `camera` (default: from (0, -3, 0) towards the origin, z up, 40 degrees)."""
    return {"camera": camera or {"position": [0.0, -3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                                 "fov": 40.0},
            "image": {"width": width, "height": height}, "render": {"shading": "path", **render},
            "environment": {"type": "constant", "radiance": environment}, "lights": [],
            "materials": materials, "shapes": shapes}


def panel(material, center=(0.0, 0.0, 0.0), size=(4.0, 4.0), normal=(0.0, -1.0, 0.0), tangent=(1.0, 0.0, 0.0)):
    """A rectangle's table: by default 4 x 4 in the plane y = 0 facing the default camera (its normal towards
    -y), u along +x and v along normal x tangent = +z."""
    return {"type": "rectangle", "material": material, "center": list(center), "size": list(size),
            "normal": list(normal), "tangent": list(tangent)}


XML_SCENE = """<scene version="3.0.0">
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, -4, 1" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"/>
    <shape type="rectangle">
        BSDF
    </shape>
</scene>
"""


def xml_file(tmp_path, bsdf):
    """A Mitsuba XML file of one rectangle of BSDF `bsdf` (XML text) under a constant sky, written in tmp_path."""
    path = tmp_path / "scene.xml"
    path.write_text(XML_SCENE.replace("BSDF", bsdf))
    return path
