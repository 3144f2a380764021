"""Mitsuba 3's normalmap and bumpmap (issue 58): kernels/lookups.cl's lookup_gradient (bitmap.cpp's eval_1_grad),
kernels/material.cl's perturb_normal (normalmap.cpp's and bumpmap.cpp's frame), kernels/bsdf.cl's perturbed_factor
(the wrappers' side rule and Estevez et al.'s shadowing term) in bsdf_eval_pdf and bsdf_sample, a rendered image
of a map that tilts nothing, and the scene format's and the XML loader's refusals. The references are float64
transcriptions of Mitsuba 3.9.1's code (src/bsdfs/normalmap.cpp, bumpmap.cpp, its normalmap helpers,
src/textures/bitmap.cpp) on tests/lookup_support.py's bitmap reference; nothing of raytrace's is called to form
them. U below is float32's unit roundoff, 2^-24.

Mutations tried (in a copy of the checkout, one kernel line changed at a time, the test run, the line restored
exactly); each fails the test named, at every lane width it runs:
- lookups.cl, lookup_gradient: ds and dt swapped in g (s and t confused): test_gradient_matches_mitsuba;
- lookups.cl: to_uv dropped, g = (ds, dt): test_gradient_matches_mitsuba;
- lookups.cl: the resolution applied after to_uv's transpose, as Mitsuba's eval_1_grad:
  test_gradient_matches_mitsuba, on the non-square image under rotation (the square cases pass, as they must);
- lookups.cl: ds's weights taken from wx instead of wy: test_gradient_matches_mitsuba;
- lookups.cl: a nearest lookup given the bilinear gradient: test_nearest_and_checkerboard_have_no_gradient;
- material.cl, perturb_normal: flip_invalid_normals' mirror removed: test_perturbed_normal_matches_mitsuba
  (worst error / bound ~3000);
- material.cl: the normal map's t = s x n0 (the frame's handedness flipped): test_perturbed_normal_matches_mitsuba;
- material.cl: the normal map's s and t swapped: test_perturbed_normal_matches_mitsuba;
- material.cl: the bump normal not turned to the outside: test_perturbed_normal_matches_mitsuba (the
  negated-axes ellipsoid) and test_flat_maps_render_the_unmapped_image;
- material.cl: n0 not turned to the outside (side = 1): test_perturbed_normal_matches_mitsuba (the wall's back);
- material.cl: dp/du tilted by dh/dv: test_perturbed_normal_matches_mitsuba;
- bsdf.cl, perturbed_factor: the shadowing term dropped (g = 1): test_eval_pdf_and_sample_under_a_normal_map (and,
  as it must, not test_flat_maps_render_the_unmapped_image: a flat map's alpha^2 is ~0);
- bsdf.cl: alpha^2 not clamped to 1: test_eval_pdf_and_sample_under_a_normal_map;
- bsdf.cl: the side rule dropped: test_eval_pdf_and_sample_under_a_normal_map;
- bsdf.cl: the factor applied on unperturbed lanes too: test_eval_pdf_and_sample_under_a_normal_map;
- bsdf.cl: bsdf_eval_pdf's pdf not zeroed where the factor is 0: test_eval_pdf_and_sample_under_a_normal_map;
- bsdf.cl: bsdf_sample's weight without the factor: test_eval_pdf_and_sample_under_a_normal_map.
"""
import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
import lookup_support as mts
import reference_textures as ref
from helpers import at_lane_ends
from raytrace import structs
from raytrace.errors import InputError
from raytrace.renderer import packing
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

U = 2.0 ** -24


def write(path, pixels, fmt):
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
    assert out.open(str(path), spec) and out.write_image(pixels) and out.close(), oiio.geterror()
    return str(path)


def waves(rng, channels, lo, hi, height, width):
    """height x width x channels of a few periodic low-frequency waves in [lo, hi]: small steps between texels."""
    y, x = np.mgrid[0:height, 0:width]
    out = []
    for _ in range(channels):
        a, b = rng.integers(1, 3, 2)
        wave = np.sin(2 * np.pi * a * x / width + rng.uniform(0, 6)) * np.cos(2 * np.pi * b * y / height
                                                                            + rng.uniform(0, 6))
        out.append(lo + (hi - lo) * (wave + 1) / 2)
    return np.stack(out, axis=2)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    """{name: (file, pixels)}: heights for the gradient, one channel float 8 x 8 (square), 8-bit sRGB RGB 6 x 6
    (its luminance is the height), float 8 wide by 5 high; for the shading points a smooth float normal map
    16 x 16 tilted up to ~70 degrees (z in [0.35, 1]), a smooth float height map 16 x 16, and the flat normal
    map (0.5, 0.5, 1)."""
    rng, folder = np.random.default_rng(58), tmp_path_factory.mktemp("perturbed")
    normals = waves(rng, 3, 0.0, 1.0, 16, 16)
    normals[..., 2] = 0.675 + 0.325 * normals[..., 2]  # rgb = (n + 1) / 2: z in [0.35, 1]
    made = {"grey": (rng.uniform(0, 1, (8, 8, 1)).astype(np.float32), "float", "exr"),
            "rgb8": (rng.integers(0, 256, (6, 6, 3), dtype=np.uint8), "uint8", "png"),
            "wide": (rng.uniform(0, 1, (5, 8, 1)).astype(np.float32), "float", "exr"),
            "normals": (normals.astype(np.float32), "float", "exr"),
            "bumps": (waves(rng, 1, 0.0, 1.0, 16, 16).astype(np.float32), "float", "exr"),
            "flat": (np.broadcast_to(np.float32([0.5, 0.5, 1.0]), (4, 4, 3)).copy(), "float", "exr")}
    return {name: (write(folder / f"{name}.{ext}", pixels, fmt), pixels) for name, (pixels, fmt, ext) in made.items()}


# --- (1) lookup_gradient ------------------------------------------------------------------------------------

GRADIENT = """
#include "lookups.cl"
__kernel void gradient(int n, TEXTURE_PARAMETERS, int l, __global const float *uv, __global float *out)
{
    TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 p = {IN(uv), IN(uv + n)};
    vec2 g = lookup_gradient(ts, l, p);
    OUT(out, g.x);
    OUT(out + n, g.y);
}
"""


def heights_of(pixels, raw):
    """H x W: the height Mitsuba's eval_1 reads, a one-channel image's value or an RGB one's luminance."""
    texels = mts.linear_texels(pixels, raw)
    return texels[..., 0] if np.asarray(pixels).ndim == 3 and pixels.shape[2] == 1 else texels @ mts.LUMINANCE


def bilinear_gradient(heights, rows, u, v, wrap):
    """Mitsuba's bilinear interpolation of `heights` at (u, v) under a scene's to_uv `rows` (t up the image) and
    its derivatives, float64: {value, grad: the chain rule's (dh/du, dh/dv), mitsuba: eval_1_grad's (the
    resolution applied after the transpose), border: the distance in texels of the position to the nearest
    cell border (where the derivative jumps), extent: to_uv's sums' extent (lookup_support.mitsuba_st)}."""
    h, w = heights.shape
    s, t, extent = mts.mitsuba_st(rows, u, v)
    x, y = s * w - 0.5, t * h - 0.5
    i, j = np.floor(x), np.floor(y)
    wx, wy = x - i, y - j
    i0, i1, j0, j1 = mts.tex_wrap(i, w, wrap), mts.tex_wrap(i + 1, w, wrap), mts.tex_wrap(j, h, wrap), \
        mts.tex_wrap(j + 1, h, wrap)
    f00, f10, f01, f11 = heights[j0, i0], heights[j0, i1], heights[j1, i0], heights[j1, i1]
    value = (1 - wy) * ((1 - wx) * f00 + wx * f10) + wy * ((1 - wx) * f01 + wx * f11)
    dfx = (1 - wy) * (f10 - f00) + wy * (f11 - f01)  # per unit of x = s w - 1/2
    dfy = (1 - wx) * (f01 - f00) + wx * (f11 - f10)  # per unit of y = t h - 1/2, t = 1 - (d u + e v + f)
    (a, b, _), (d, e, _) = np.asarray(rows, np.float64)
    grad = np.stack([w * a * dfx - h * d * dfy, w * b * dfx - h * e * dfy], axis=1)
    mitsuba = np.stack([w * (a * dfx - d * dfy), h * (b * dfx - e * dfy)], axis=1)  # bitmap.cpp: res * df_uv
    border = np.minimum(np.minimum(wx, 1 - wx), np.minimum(wy, 1 - wy))
    return {"value": value, "grad": grad, "mitsuba": mitsuba, "border": border, "extent": extent}


def rotated(angle, su, sv, offset):
    """to_uv rows: a rotation by `angle` of the scales (su, sv) (negative: a reflection), translated."""
    c, s = np.cos(angle), np.sin(angle)
    return [[su * c, -sv * s, offset[0]], [su * s, sv * c, offset[1]]]


# (image, raw, to_uv): square images under a rotation with unequal scales and a reflection, the non-square one
# under a rotation and under scales alone (where Mitsuba's order of operations agrees)
GRADIENT_CASES = [("grey", True, rotated(0.7, 1.7, -1.3, (0.3, -0.2))),
                  ("rgb8", False, rotated(-1.1, 1.2, 2.1, (-0.4, 0.6))),
                  ("rgb8", True, rotated(2.5, -0.9, 1.4, (0.1, 0.1))),
                  ("wide", True, rotated(0.9, 1.5, 1.1, (0.2, 0.35))),
                  ("wide", True, [[1.6, 0.0, 0.2], [0.0, -1.3, 0.1]])]


def gradient_scene(images, filter_type, wrap, cases=GRADIENT_CASES):
    """Packed tables of a scene whose material k has case k's bump map, and each case's lookup index."""
    materials = {f"m{k}": {"type": "diffuse", "colour": [0.5, 0.5, 0.5],
                           "bumpmap": {"type": "bitmap", "filename": images[name][0], "raw": raw,
                                       "filter_type": filter_type, "wrap_mode": wrap, "to_uv": rows}}
                 for k, (name, raw, rows) in enumerate(cases)}
    scene = raytrace.load_dict(mts.path_scene(materials, [mts.panel("m0")]))
    _, maps = packing.lookup_structs(packing.material_table(scene.materials))
    return packing.texture_tables(scene), [int(maps[k][structs.MAP_SLOTS["bump"]]) for k in range(len(cases))]


def kernel_gradient(harness, tables, lookup, uv):
    args = {**tables, "l": np.int32(lookup), "uv": np.ascontiguousarray(uv.T)}
    return harness.run(GRADIENT, "gradient", len(uv), args, {"out": 2})["out"].T


@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp"])
def test_gradient_matches_mitsuba(harness, images, wrap):
    """lookup_gradient of each case at 512 random (u, v) in [-2, 3]^2 against the float64 derivative of Mitsuba's
    bilinear interpolation, which central differences (step 1e-6 in u and v) of the float64 interpolation
    confirm: the interpolation is quadratic along a line within a cell, so a central difference is exact but
    for rounding (1e-16 / 1e-6: bound 1e-8 (1 + |g|)). Mitsuba's own formula scales (dh/ds, dh/dt) by (W, H)
    after to_uv's transpose: the same on the square images and without rotation (asserted to 1e-9), and on
    the non-square image with rotation off by up to ~30% of the gradient (asserted > 10%): the kernel takes the
    chain rule, docs/mitsuba.md's difference.

    Bound: the kernel's texel position lies within delta = 16 U E max(W, H) texels of the float64 one
    (tests/test_lookups.py's argument: to_uv's float32 terms and multiply-adds, the period's reduction), E the
    extent of to_uv's sums. The derivative jumps at cell borders: the points within 1e-3 texel of one (> 10
    delta here) are skipped, under 1% of them. Inside a cell dh/dx moves with y by f11 - f01 - f10 + f00, at
    most 2 D (D the heights' range), so the position costs (|a| W + |d| H) 2 D delta along u; the texels'
    decoding (the sRGB table, the luminance) and the differences, weights, products and sums of the kernel add
    16 U of (|a| W + |d| H) max|f| along u ((|b| W + |e| H) along v). Nearest filtering and a checkerboard:
    exactly 0, Mitsuba's 'zero almost everywhere'."""
    tables, lookups = gradient_scene(images, "bilinear", wrap)
    rng = np.random.default_rng(["repeat", "mirror", "clamp"].index(wrap))
    uv = rng.uniform(-2, 3, (512, 2)).astype(np.float32).astype(np.float64)
    worst, step = 0.0, 1e-6
    for k, (name, raw, rows) in enumerate(GRADIENT_CASES):
        heights = heights_of(images[name][1], raw)
        h, w = heights.shape
        want = bilinear_gradient(heights, rows, uv[:, 0], uv[:, 1], wrap)
        plus_u = bilinear_gradient(heights, rows, uv[:, 0] + step, uv[:, 1], wrap)["value"]
        minus_u = bilinear_gradient(heights, rows, uv[:, 0] - step, uv[:, 1], wrap)["value"]
        plus_v = bilinear_gradient(heights, rows, uv[:, 0], uv[:, 1] + step, wrap)["value"]
        minus_v = bilinear_gradient(heights, rows, uv[:, 0], uv[:, 1] - step, wrap)["value"]
        central = np.stack([plus_u - minus_u, plus_v - minus_v], axis=1) / (2 * step)
        clear = want["border"] > 1e-3
        assert clear.mean() > 0.99
        np.testing.assert_allclose(central[clear], want["grad"][clear], rtol=0,
                                   atol=1e-8 * (1 + np.abs(want["grad"]).max()), err_msg=f"{name} finite differences")
        gap = np.abs(want["mitsuba"] - want["grad"]).max()
        if h == w or rows[0][1] == rows[1][0] == 0:
            assert gap <= 1e-9 * np.abs(want["grad"]).max(), (name, rows)
        else:  # docs: Mitsuba scales after the transpose
            assert gap > 0.1 * np.abs(want["grad"]).max(), (name, gap)
        got = kernel_gradient(harness, tables, lookups[k], uv)
        (a, b, _), (d, e, _) = np.abs(np.asarray(rows))
        delta = 16 * U * want["extent"] * max(w, h)
        span, top = np.ptp(heights), np.abs(heights).max()
        reach = np.stack([np.full(len(uv), a * w + d * h), np.full(len(uv), b * w + e * h)], axis=1)
        bound = reach * (2 * span * delta + 16 * U * top)[:, None]
        error = np.abs(got - want["grad"])
        assert np.all(error[clear] <= bound[clear]), (name, error[clear].max(), (error / bound)[clear].max())
        worst = max(worst, float((error / bound)[clear].max()))
    print(f"{wrap}: worst gradient error / bound {worst:.3g}")


def test_nearest_and_checkerboard_have_no_gradient(harness, images):
    """Mitsuba's eval_1_grad is 0 for a nearest bitmap (bitmap.cpp: 'zero almost everywhere'); a checkerboard
    has none either (raytrace's lookup_gradient gives 0: constant almost everywhere). Exactly 0; the bilinear
    lookup of the same texture and points is not (so the 0 is the filter's)."""
    checker = [("grey", True, GRADIENT_CASES[0][2])]
    tables, (nearest,) = gradient_scene(images, "nearest", "repeat", checker)
    rng = np.random.default_rng(5)
    uv = rng.uniform(-2, 3, (256, 2))
    assert np.all(kernel_gradient(harness, tables, nearest, uv) == 0)
    tables, (bilinear,) = gradient_scene(images, "bilinear", "repeat", checker)
    assert np.abs(kernel_gradient(harness, tables, bilinear, uv)).max() > 1
    scene = raytrace.load_dict(mts.path_scene({"m": {"type": "diffuse", "colour": [0.5] * 3, "bumpmap": {
        "type": "checkerboard", "to_uv": GRADIENT_CASES[0][2]}}}, [mts.panel("m")]))
    _, maps = packing.lookup_structs(packing.material_table(scene.materials))
    got = kernel_gradient(harness, packing.texture_tables(scene), int(maps[0][structs.MAP_SLOTS["bump"]]), uv)
    assert np.all(got == 0)


# --- (2) the perturbed normal at shading points of whole scenes ---------------------------------------------

SHADING = """
#include "camera.cl"
#include "material.cl"
__kernel void shading(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const float *xy, __global float *nrm,
                      __global float *n0, __global float *perturbed, __global float *pos, __global float *dir,
                      __global float *t)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    Ray r = generate_camera_ray(camera, IN(xy), IN(xy + n), lens, &tmax);
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    ShadingPoint sp = shading_point(&s, ts, r, hit);
    OUT3(nrm, sp.n);
    OUT3(n0, sp.n0);
    OUT(perturbed, SELECT((vfloat)(0.0f), (vfloat)(1.0f), sp.perturbed != 0));
    OUT3(pos, hit.p);
    OUT3(dir, r.d);
    OUT(t, hit.t);
}
"""

NORMAL_ROWS = rotated(0.4, 2.0, 1.5, (0.1, 0.3))  # the normal map's to_uv: the frame ignores it (dp/du's)
BUMP_ROWS = rotated(-0.3, 1.5, 2.0, (0.25, -0.1))
BUMP_SCALE = 0.04


def shading_scene(images):
    """A floor (normalmap, seen at grazing angles so that many views fall behind its tilted normals), a wall
    facing away from the camera (bumpmap: its back side), and two ellipsoids with negated axes (as the XML loader
    makes Mitsuba's spheres: dp/du x dp/dv points in, where the rectangles' points out), one under the bump map,
    whose cross product must be turned out, one under the normal map, whose frame is n0's, not dp/dv's; and a panel
    under both (Mitsuba's bumpmap around a normalmap: the normal map in the bumped frame)."""
    normal = {"type": "bitmap", "filename": images["normals"][0], "raw": True, "wrap_mode": "repeat",
              "to_uv": NORMAL_ROWS}
    bump = {"type": "bitmap", "filename": images["bumps"][0], "raw": True, "wrap_mode": "mirror",
            "to_uv": BUMP_ROWS}
    materials = {"nm": {"type": "diffuse", "colour": [0.6] * 3, "normalmap": normal},
                 "bm": {"type": "diffuse", "colour": [0.6] * 3, "bumpmap": bump, "bump_scale": BUMP_SCALE},
                 "both": {"type": "diffuse", "colour": [0.6] * 3, "normalmap": normal, "bumpmap": bump,
                          "bump_scale": BUMP_SCALE}}
    shapes = [{"type": "rectangle", "material": "nm", "center": [0.0, 0.5, 0.0], "size": [5.0, 4.0],
               "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0]},
              {"type": "rectangle", "material": "bm", "center": [1.3, 1.2, 0.9], "size": [1.6, 1.8],
               "normal": [0.2, 0.98, 0.0], "tangent": [0.98, -0.2, 0.0]},
              {"type": "ellipsoid", "material": "bm", "center": [-0.9, 0.2, 0.55],
               "axes": [[-0.5, -0.1, 0.0], [0.0, -0.45, -0.1], [-0.05, 0.0, -0.5]]},
              {"type": "ellipsoid", "material": "nm", "center": [0.35, -0.3, 0.45],
               "axes": [[-0.4, 0.0, 0.0], [0.0, -0.4, 0.0], [0.0, 0.0, -0.4]]},
              {"type": "rectangle", "material": "both", "center": [-1.1, 1.3, 1.2], "size": [1.4, 1.2],
               "normal": [0.3, -0.95, 0.1], "tangent": [0.95, 0.3, 0.0]}]
    camera = {"position": [0.0, -3.0, 0.7], "look_at": [0.0, 0.3, 0.4], "up": [0.0, 0.0, 1.0], "fov": 55.0}
    table = mts.path_scene(materials, shapes, camera, width=48, height=40)
    return raytrace.load_dict(table)


def kernel_shading(harness, scene, x, y):
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    args = {**scene_tables(scene, scene.width, scene.height, 1, 1, "bilinear", features=features),
            **packing.texture_tables(scene), "xy": np.concatenate([x, y]).astype(np.float32)}
    out = harness.run(SHADING, "shading", len(x), args, {"nrm": 3, "n0": 3, "perturbed": 1, "pos": 3, "dir": 3,
                                                                "t": 1},
                      **defines)
    return {k: v.T if v.ndim == 2 else v for k, v in out.items()}


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def surfaces_at(scene, p):
    """Which shape each point p lies on (-1: none) and the float64 surface there (reference_textures.py: u, v,
    dp/du, dp/dv, the shape's outward normal), from the points alone."""
    which = np.full(len(p), -1)
    shapes = [(r, "rectangle") for r in scene.rectangles] + [(e, "ellipsoid") for e in scene.ellipsoids]
    for index, (shape, kind) in enumerate(shapes):
        if kind == "rectangle":
            rel = p - shape.center
            local = np.stack([rel @ shape.tangent, rel @ shape.bitangent], axis=1) / shape.size
            on = (np.abs(rel @ shape.normal) < 1e-4) & np.all(np.abs(local) <= 0.5 + 1e-4, axis=1)
        else:
            on = np.abs(np.linalg.norm((p - shape.center) @ np.linalg.inv(shape.matrix).T, axis=1) - 1) < 1e-4
        which[on & (which < 0)] = index
    surface = {key: np.zeros((len(p), 3)) for key in ("dpdu", "dpdv", "normal")}
    surface["u"], surface["v"] = np.zeros(len(p)), np.zeros(len(p))
    for index, (shape, kind) in enumerate(shapes):
        at = which == index
        if not at.any():
            continue
        got = (ref.rectangle_surface(shape.center, shape.size, shape.normal, shape.tangent, p[at])
               if kind == "rectangle" else ref.ellipsoid_surface(shape.center, shape.matrix, p[at]))
        for key in surface:
            surface[key][at] = got[key]
    return which, surface


def perturbed_reference(scene, images, p, d, hit):
    """Mitsuba's perturbed normal at the points p seen along d, float64, in raytrace's convention (turned to the
    viewer's side), with each lane's error bound and the quantity whose sign decides the mirror. normalmap.cpp:
    n = normalize(2 rgb - 1) in the frame (s, t, n0) of the outward shading normal n0, s = dp/du made orthogonal
    to n0, t = n0 x s; bumpmap.cpp: dp/du + n0 (scale dh/du - n0.dp/du), likewise dp/dv, n their normalised
    cross product turned to the outside; both: where (wo.n0) (wo.n) <= 0 (flip_invalid_normals), n's tangential
    part negated, (-x, -y, z) in the frame of n0."""
    which, surface = surfaces_at(scene, p)
    which[~hit] = -1
    owners = [-1] + [s.material for s in scene.rectangles] + [e.material for e in scene.ellipsoids]
    material = np.array(owners)[which + 1]
    names = [m.name for m in scene.materials]
    n0, dpdu, dpdv = surface["normal"], surface["dpdu"], surface["dpdv"]
    wo = -unit(d)
    n, bound = n0.copy(), np.full(len(p), np.inf)
    both = material == names.index("both")
    nm, bm = material == names.index("nm"), material == names.index("bm")
    # the normal map
    texels = mts.linear_texels(images["normals"][1], True)
    s, t, extent = mts.mitsuba_st(NORMAL_ROWS, surface["u"], surface["v"])
    rgb = mts.bitmap(texels, s, t, "bilinear", "repeat")
    m = 2 * rgb - 1
    frame_s = unit(dpdu - n0 * dot(n0, dpdu)[:, None])
    frame_t = np.cross(n0, frame_s)
    mapped = m[:, :1] * frame_s + m[:, 1:2] * frame_t + m[:, 2:] * n0
    n[nm] = unit(mapped[nm])
    # float32 texel positions (delta, as the gradient's test, plus u, v from the kernel's float32 p: atan2 and
    # the spherical terms within 64 U) move the colour by delta times the texels' largest step; the frame and the
    # normalisation round within 64 U
    step = max(np.abs(np.diff(np.concatenate([texels, texels[:1]], 0), axis=0)).max(),
               np.abs(np.diff(np.concatenate([texels, texels[:, :1]], 1), axis=1)).max())
    scale = np.abs(np.asarray(NORMAL_ROWS)[:, :2]).sum()
    delta = (16 * U * extent + 64 * U * scale) * 16
    colour_error = delta * step + 8 * U
    bound[nm] = (4 * np.sqrt(3) * colour_error / np.linalg.norm(m, axis=1) + 64 * U)[nm]
    # the bump map
    heights = mts.linear_texels(images["bumps"][1], True)[..., 0]
    g = bilinear_gradient(heights, BUMP_ROWS, surface["u"], surface["v"], "mirror")
    grad = BUMP_SCALE * g["grad"]
    du = dpdu + n0 * (grad[:, :1] - dot(n0, dpdu)[:, None])
    dv = dpdv + n0 * (grad[:, 1:] - dot(n0, dpdv)[:, None])
    cross = np.cross(du, dv)
    bumped = unit(cross) * np.where(dot(cross, n0) < 0, -1.0, 1.0)[:, None]
    n[bm] = bumped[bm]
    rows = np.abs(np.asarray(BUMP_ROWS)[:, :2])
    delta = (16 * U * g["extent"] + 64 * U * rows.sum()) * 16
    span = np.ptp(heights)
    grad_error = BUMP_SCALE * (rows.sum(axis=0) * 16)[None, :] * (2 * span * delta + 16 * U)[:, None]
    size = np.linalg.norm(cross, axis=1)
    tilt = (grad_error[:, 0] * np.linalg.norm(dv, axis=1) + grad_error[:, 1] * np.linalg.norm(du, axis=1)) / size
    bound[bm] = (2 * tilt + 64 * U * np.linalg.norm(du, axis=1) * np.linalg.norm(dv, axis=1) / size)[bm]
    bound[bm & (g["border"] <= 1e-3)] = np.inf  # the gradient jumps at cell borders: not compared
    # both: the normal map in the bumped frame (its normal, s along the bumped dp/du); the bump's tilt error turns
    # the frame, and the normal map's result with it, so the two bounds add
    both_s = unit(du - bumped * dot(bumped, du)[:, None])
    both_t = np.cross(bumped, both_s)
    n[both] = unit(m[:, :1] * both_s + m[:, 1:2] * both_t + m[:, 2:] * bumped)[both]
    bound[both] = (2 * tilt + 64 * U * np.linalg.norm(du, axis=1) * np.linalg.norm(dv, axis=1) / size)[both] + \
        (4 * np.sqrt(3) * colour_error / np.linalg.norm(m, axis=1) + 64 * U)[both]
    bound[both & (g["border"] <= 1e-3)] = np.inf
    # flip_invalid_normals, then the viewer's side
    decide = dot(wo, n0) * dot(wo, n)
    mirrored = (decide <= 0) & (nm | bm | both)
    n[mirrored] = (2 * dot(n, n0)[:, None] * n0 - n)[mirrored]
    side = np.where(dot(wo, n0) < 0, -1.0, 1.0)[:, None]
    return {"which": which, "nm": nm, "bm": bm, "both": both, "n": n * side, "n0": n0 * side, "bound": bound,
            "mirrored": mirrored, "decide": decide}


@at_lane_ends
def test_perturbed_normal_matches_mitsuba(cl_env, images, lanes):
    """shading_point's sp.n on 2048 random pixels of shading_scene against the float64 frame construction from
    the kernel's own hit points (so only the texturing is compared), sp.n0 the facing shading normal before the
    map, sp.perturbed on exactly the mapped lanes; the lanes mix the two maps and both, five shapes and misses.

    Bound per lane (perturbed_reference): the normal map's colour moves by the texel position's float32 error
    (delta: 16 U E + 64 U |to_uv| for u, v formed from the float32 hit, times the resolution) times the texels'
    largest step, plus 8 U; 2 rgb - 1 doubles it, and normalising a vector m divides by |m| (>= 0.35 here):
    4 sqrt(3) dc / |m| + 64 U. The bump's gradient errs as in test_gradient_matches_mitsuba (times bump_scale),
    which tilts du x dv by (dg_u |dv| + dg_v |du|) / |du x dv|, plus 64 U of |du| |dv| / |du x dv| for the cross
    product's rounding. The lanes within 1e-3 texel of a cell border (the gradient jumps) and those whose
    mirror decision (wo.n0) (wo.n) lies within 4 bounds of 0 are not compared (counted: a few %). Mitsuba's
    mirror must occur on enough lanes (> 5%) for the test to see it."""
    from raytrace.commands.stability.probe import Probe
    harness = Probe(lanes, env=cl_env)
    scene = shading_scene(images)
    rng = np.random.default_rng(21)
    x, y = rng.uniform(0, scene.width, 2048), rng.uniform(0, scene.height, 2048)
    got = kernel_shading(harness, scene, x, y)
    want = perturbed_reference(scene, images, got["pos"], got["dir"], np.isfinite(got["t"]))
    mapped = want["nm"] | want["bm"] | want["both"]
    assert np.array_equal(got["perturbed"] == 1, mapped)
    hit = want["which"] >= 0
    assert np.count_nonzero(want["nm"]) > 400 and np.count_nonzero(want["bm"]) > 300
    assert np.count_nonzero(want["both"]) > 60
    assert np.count_nonzero(want["mirrored"]) > 0.05 * np.count_nonzero(mapped)
    for shape in range(5):
        assert np.count_nonzero(want["which"] == shape) > 50, shape
    np.testing.assert_allclose(got["n0"][hit], want["n0"][hit], atol=64 * U)
    np.testing.assert_allclose(got["nrm"][~mapped & hit], got["n0"][~mapped & hit], atol=0)
    compared = mapped & np.isfinite(want["bound"]) & (np.abs(want["decide"]) > 4 * want["bound"])
    assert compared.sum() > 0.9 * mapped.sum()
    error = np.linalg.norm(got["nrm"] - want["n"], axis=1)
    ratio = error[compared] / want["bound"][compared]
    assert np.all(ratio <= 1), (ratio.max(), np.flatnonzero(compared)[np.argmax(ratio)])
    print(f"lanes {lanes}: {compared.sum()} of {mapped.sum()} mapped lanes compared, {want['mirrored'].sum()} "
          f"mirrored; worst error {error[compared].max():.3g}, worst error / bound {ratio.max():.3g}")


# --- (3) perturbed_factor in bsdf_eval_pdf and bsdf_sample ---------------------------------------------------

# A diffuse shading point per lane (HAS_BSDF_PARAMETERS 0: diffuse alone) with its shading normal before the map
# n0 (also ng), the perturbed normal n and the flag `perturbed`: bsdf_eval_pdf towards wi and a bsdf_sample with
# its bsdf_eval_pdf, and perturbed_factor itself.
FACTOR = """
#include "bsdf.cl"
__kernel void factor(int n, __global const float *n0, __global const float *nrm, __global const int *perturbed,
                     __global const float *k, __global const float *wo_, __global const float *wi_,
                     __global const float *u, __global float *f, __global float *pdf, __global float *g,
                     __global float *s_wi, __global float *s_weight, __global float *s_pdf, __global float *s_f,
                     __global float *s_eval_pdf)
{
    ShadingPoint sp;
    sp.p = v3_splat(0.0f, 0.0f, 0.0f);
    sp.err = 0.0f;
    sp.ng = sp.n0 = IN3(n0);
    sp.n = IN3(nrm);
    sp.k = IN3(k);
    sp.shininess = 1.0f;
    sp.perturbed = VLOAD_INT(perturbed + I * LANES);
    const vint all = (vint)(-1) != 0;
    vec3 wo = IN3(wo_), wi = IN3(wi_);
    vfloat p;
    OUT3(f, bsdf_eval_pdf(sp, wo, wi, all, &p));
    OUT(pdf, p);
    OUT(g, perturbed_factor(sp, wi));
    vec2 u2 = {IN(u + n), IN(u + 2 * n)};
    BSDFSample bs = bsdf_sample(sp, wo, IN(u), u2, all);
    OUT3(s_wi, bs.wi);
    OUT3(s_weight, bs.weight);
    OUT(s_pdf, bs.pdf);
    OUT3(s_f, bsdf_eval_pdf(sp, wo, bs.wi, all, &p));
    OUT(s_eval_pdf, p);
}
"""


def shadowing(n, n0, wi):
    """Estevez et al.'s term as Mitsuba's eval_shadow_terminator: alpha^2 = min(tan^2(n, n0) / 8, 1),
    G = 2 / (1 + sqrt(1 + alpha^2 tan^2(wi, n0))), the cosines as dot products of the vectors given."""
    cos_n, cos_i = dot(n, n0), dot(wi, n0)
    alpha2 = np.minimum(0.125 * np.maximum(1 - cos_n ** 2, 0) / cos_n ** 2, 1)
    tan2_i = np.maximum(1 - cos_i ** 2, 0) / cos_i ** 2
    return 2 / (1 + np.sqrt(1 + alpha2 * tan2_i)), alpha2, tan2_i


def diffuse_under_map(k, n, n0, wo, wi, perturbed):
    """Mitsuba's normalmap(diffuse) (or bumpmap's: the same wrapper) at (wo, wi), float64: f = k / pi cos(wi, n)
    G where wi lies on one side of n0 and of n, wo and wi above n (diffuse.cpp), else 0; pdf cos / pi there, else
    0. Unperturbed lanes: the plain diffuse."""
    cos_i = dot(wi, n)
    above = (cos_i > 0) & (dot(wo, n) > 0)
    g, _, _ = shadowing(n, n0, wi)
    agree = dot(wi, n0) * cos_i > 0
    factor = np.where(perturbed, np.where(agree, g, 0.0), 1.0)
    pdf = np.where(above & (agree | ~perturbed), cos_i / np.pi, 0.0)
    return k * (pdf * factor)[:, None], pdf, factor


def factor_lanes(rng, m):
    """m lanes: n0 uniform on the sphere; n tilted from it by an angle up to 80 degrees, or (every 8th lane)
    n = n0; every 4th lane unperturbed; wo on the side of both normals (as perturb_normal leaves it) and wi
    uniform over the sphere; random colours."""
    n0 = unit(rng.normal(size=(m, 3)))
    side = unit(np.cross(n0, rng.normal(size=(m, 3))))
    angle = rng.uniform(0, np.radians(80), m)
    angle[::8] = 0
    n = unit(np.cos(angle)[:, None] * n0 + np.sin(angle)[:, None] * side)
    n[::8] = n0[::8]
    wo = unit(rng.normal(size=(m, 3)))
    wo *= np.sign(dot(wo, n0))[:, None]
    bad = dot(wo, n) <= 0.05
    while bad.any():
        fresh = unit(rng.normal(size=(int(bad.sum()), 3)))
        wo[bad] = fresh * np.sign(dot(fresh, n0[bad]))[:, None]
        bad = dot(wo, n) <= 0.05
    perturbed = np.arange(m) % 4 != 3
    f32 = lambda a: a.astype(np.float32).astype(np.float64)  # noqa: E731 (both sides take the same inputs)
    return (f32(n0), f32(n), perturbed, f32(rng.uniform(0.2, 1, (m, 3))), f32(wo), f32(unit(rng.normal(size=(m, 3)))),
            f32(rng.uniform(0, 1, (m, 3))))


def run_factor(harness, n0, n, perturbed, k, wo, wi, u):
    args = [planar(n0), planar(n), np.where(perturbed, -1, 0).astype(np.int32), planar(k), planar(wo), planar(wi),
            planar(u)]
    outputs = {"f": 3, "pdf": 1, "g": 1, "s_wi": 3, "s_weight": 3, "s_pdf": 1, "s_f": 3, "s_eval_pdf": 1}
    out = harness.run(FACTOR, "factor", len(wo), args, outputs, HAS_PERTURBED_NORMALS=1)
    return {key: v.T if v.ndim == 2 else v for key, v in out.items()}


def planar(v):
    return np.ascontiguousarray(np.asarray(v, np.float64).T, dtype=np.float32)


def shadowing_bound(n, n0, wi):
    """A bound on the kernel's float32 error in G: its cosines are dot products of float32 unit vectors (within
    4 U), so 1 - cos^2 errs by 10 U absolutely and tan^2 = (1 - cos^2) / cos^2 by (10 U + 4 U tan^2) / cos^2 +
    2 U tan^2; alpha^2 by 1/8 of its tan^2's error where below 1; G's derivatives are |dG/d alpha^2| <= tan_i^2 /
    4 and |dG/d tan_i^2| <= alpha^2 / 4 (G = 2 / (1 + S), S = sqrt(1 + alpha^2 tan_i^2) >= 1), and its own
    sqrt, sum and division add 8 U."""
    g, alpha2, tan2_i = shadowing(n, n0, wi)
    cos_n2, cos_i2 = dot(n, n0) ** 2, dot(wi, n0) ** 2
    tan2_n = np.maximum(1 - cos_n2, 0) / cos_n2
    d_alpha2 = np.where(alpha2 < 1, 0.125 * ((10 * U + 4 * U * tan2_n) / cos_n2 + 2 * U * tan2_n), 0)
    d_tan2_i = (10 * U + 4 * U * tan2_i) / cos_i2 + 2 * U * tan2_i
    return tan2_i / 4 * d_alpha2 + alpha2 / 4 * d_tan2_i + 8 * U


def test_eval_pdf_and_sample_under_a_normal_map(harness):
    """bsdf_eval_pdf and bsdf_sample of a diffuse under a map (sp.perturbed) on 4096 random lanes against
    Mitsuba's wrapper of a diffuse (diffuse_under_map): f = k / pi cos(wi, n) G(wi) where wi lies on one side of
    n0 and of n, 0 elsewhere, pdf cos / pi there and 0 elsewhere; perturbed_factor is G or 0; 1 on the
    unperturbed lanes (the plain diffuse, a quarter of the lanes, mixed with the others). A sample's weight is
    k G(wi) where its pdf is not 0 (f / pdf), 0 where the side rule refuses it (wi below n0: its pdf 0 too), and
    bsdf_eval_pdf at the sampled direction gives the same pdf and f = weight pdf.

    Bounds: the factor within shadowing_bound (its float32 rounding through G's derivatives: at most ~3e-5 here,
    where cos(wi, n0) >= 0.02 for the lanes compared); f within k / pi (cos dG + 8 U) + its cosine's 4 U. The
    side rule and the diffuse's own are compared exactly where both cosines are >= 1e-5 (their float32 rounding
    is < 4 U), the values where cos(wi, n0) and cos(wi, n) are >= 0.02 (tan^2 <= 2500, so the bound stays small;
    the rest, ~4% of the lanes, is exercised but not compared)."""
    rng = np.random.default_rng(3)
    n0, n, perturbed, k, wo, wi, u = factor_lanes(rng, 4096)
    got = run_factor(harness, n0, n, perturbed, k, wo, wi, u)
    f, pdf, factor = diffuse_under_map(k, n, n0, wo, wi, perturbed)
    clear = (np.abs(dot(wi, n0)) > 1e-5) & (np.abs(dot(wi, n)) > 1e-5)
    assert clear.mean() > 0.99
    assert np.array_equal(got["pdf"][clear] > 0, pdf[clear] > 0)
    assert np.array_equal(got["g"][clear] > 0, factor[clear] > 0)
    refused = perturbed & (dot(wi, n) > 0) & (dot(wi, n0) < 0)
    assert refused.sum() > 200 and np.all(got["f"][refused & clear] == 0) and np.all(got["pdf"][refused & clear] == 0)
    far = (np.abs(dot(wi, n0)) >= 0.02) & (np.abs(dot(wi, n)) >= 0.02)
    dg = np.where(perturbed, shadowing_bound(n, n0, wi), 0)
    assert np.all(np.abs(got["g"] - factor)[far] <= dg[far]), np.abs(got["g"] - factor)[far].max()
    cos_i = np.maximum(dot(wi, n), 0)
    bound_f = k / np.pi * (cos_i * dg + 12 * U)[:, None]
    assert np.all(np.abs(got["f"] - f)[far] <= bound_f[far]), (np.abs(got["f"] - f) / bound_f)[far].max()
    np.testing.assert_allclose(got["pdf"][far], pdf[far], rtol=8 * U, atol=4 * U)
    assert (factor[far & perturbed & (pdf > 0)] < 0.99).mean() > 0.2  # the term darkens many lanes visibly
    # samples: cosine about n; accepted where wi is above n0 too
    s_wi, accepted = got["s_wi"], got["s_pdf"] > 0
    sample_g, _, _ = shadowing(n, n0, s_wi)
    sure = np.abs(dot(s_wi, n0)) > 1e-5
    assert np.array_equal(accepted[sure], (~perturbed | (dot(s_wi, n0) > 0))[sure] & (dot(s_wi, n) > 0)[sure])
    assert (~accepted & perturbed).sum() > 50
    assert np.all(got["s_weight"][~accepted] == 0)
    want_weight = k * np.where(perturbed, sample_g, 1.0)[:, None]
    sample_far = accepted & (np.abs(dot(s_wi, n0)) >= 0.02)
    weight_bound = k * (np.where(perturbed, shadowing_bound(n, n0, s_wi), 0) + 4 * U)[:, None]
    assert np.all(np.abs(got["s_weight"] - want_weight)[sample_far] <= weight_bound[sample_far])
    np.testing.assert_array_equal(got["s_eval_pdf"][accepted], got["s_pdf"][accepted])
    np.testing.assert_allclose(got["s_f"][accepted], (got["s_weight"] * got["s_pdf"][:, None])[accepted],
                               rtol=16 * U, atol=1e-30)
    print(f"f: worst error / bound {(np.abs(got['f'] - f) / bound_f)[far].max():.3g}; "
          f"{refused.sum()} lanes refused by the side rule")


# --- (4) rendered: maps that tilt nothing ---------------------------------------------------------------------

def render_scene(images, normalmap=None, bumpmap=None, bump_scale=1.0):
    """A floor and a ball (negated axes, as the XML loader's spheres) under a constant environment, path traced to
    depth 3: the floor may take a normal map, the ball a bump map (to_uv (4 u, 2 v))."""
    floor = {"type": "diffuse", "colour": [0.7, 0.6, 0.5]}
    ball = {"type": "diffuse", "colour": [0.3, 0.6, 0.8]}
    if normalmap:
        floor["normalmap"] = {"type": "bitmap", "filename": images[normalmap][0], "raw": True}
    if bumpmap:
        ball["bumpmap"] = {"type": "bitmap", "filename": images[bumpmap][0], "raw": True,
                           "to_uv": [[4.0, 0.0, 0.0], [0.0, 2.0, 0.0]]}
        ball["bump_scale"] = bump_scale
    shapes = [{"type": "rectangle", "material": "floor", "center": [0.0, 0.5, 0.0], "size": [4.0, 4.0],
               "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0]},
              {"type": "ellipsoid", "material": "ball", "center": [0.0, 0.3, 0.8],
               "axes": [[-0.6, 0.0, 0.0], [0.0, -0.6, 0.0], [0.0, 0.0, -0.6]]}]
    camera = {"position": [0.0, -3.0, 1.5], "look_at": [0.0, 0.3, 0.5], "up": [0.0, 0.0, 1.0], "fov": 50.0}
    return raytrace.load_dict(mts.path_scene({"floor": floor, "ball": ball}, shapes, camera, width=32, height=32,
                                             max_depth=3))


@at_lane_ends
def test_flat_maps_render_the_unmapped_image(images, lanes):
    """The flat normal map (0.5, 0.5, 1) is the unperturbed normal and a bump map's relief vanishes with its scale:
    with the same build (the mapped scene's features) and the same samples (16 random per pixel), the images of
    the flat map, and of a bump_scale of 1e-7, match the unmapped image within 1e-5 per pixel (values up to 1),
    their mean differences within 1e-7. Argument: the flat map's normal is n0 normalised again (within 4 U), the
    bump of scale 1e-7 tilts by 1e-7 |g| / |dp/du| <= 1e-7 * 64 / 1.8 = 4e-6 (|g| <= |to_uv| 16 texels per period
    times heights in [0, 1]); each of <= 3 bounces' directions and cosines move by that, 1e-5 relative at most
    on a path's throughput; the shadowing term of so small a tilt (alpha^2 <= 2e-12) darkens a sample by more
    than 1e-6 only within 1e-6 of grazing. A path would move further only by meeting another shape's edge within
    that angle: none does in this image (its samples are fixed), and finding one is what the bound would then
    report. Larger scales move the image, their mean difference about in proportion (1e-2, 1e-3, 1e-4: each
    at least 3 times the next), and the tilting normal map by far more (> 0.1): the comparison can fail."""
    features = Features.of(render_scene(images, "flat", "bumps"), lanes)

    def image(*args, **kw):
        picture, stats = raytrace.render(render_scene(images, *args, **kw), spp=16, lanes=lanes, features=features,
                                         sampler="random", seed=7)
        assert "-DHAS_PERTURBED_NORMALS=1" in stats.build_options
        return picture.astype(np.float64)

    plain = image()
    assert 0.2 < plain.mean() and plain.max() <= 1.5
    for kw in ({"normalmap": "flat"}, {"bumpmap": "bumps", "bump_scale": 1e-7},
               {"normalmap": "flat", "bumpmap": "bumps", "bump_scale": 1e-7}):
        difference = np.abs(image(**kw) - plain)
        assert difference.max() <= 1e-5 and difference.mean() <= 1e-7, (kw, difference.max(), difference.mean())
    means = [np.abs(image(bumpmap="bumps", bump_scale=scale) - plain).mean() for scale in (1e-2, 1e-3, 1e-4)]
    assert means[0] > 3 * means[1] > 9 * means[2] > 0, means
    assert np.abs(image(normalmap="normals") - plain).max() > 0.1


# --- (5) refusals -------------------------------------------------------------------------------------------

def refusal(images, material):
    with pytest.raises(InputError) as info:
        raytrace.load_dict(mts.path_scene({"m": material}, [mts.panel("m")]))
    return str(info.value)


def test_scene_format_refuses_conflicting_maps_and_bad_scales(images):
    """Mitsuba's maps or the course's, not a mix: normalmap or bumpmap with the course's normal_map or
    height_map is refused in one line naming the course's key and its value (a long one elided but for its ends:
    the file's name shows); normalmap with bumpmap is Mitsuba's bumpmap around a normalmap (accepted: both
    maps); bump_scale must be > 0 and finite."""
    normal = {"type": "bitmap", "filename": images["normals"][0], "raw": True}
    bump = {"type": "bitmap", "filename": images["bumps"][0], "raw": True}
    base = {"type": "diffuse", "colour": [0.5, 0.5, 0.5]}
    scene = raytrace.load_dict(mts.path_scene({"m": {**base, "normalmap": normal, "bumpmap": bump}},
                                              [mts.panel("m")]))
    assert sorted(slot for slot, _ in scene.materials[0].maps) == ["bump", "normal"]
    for extra, key, first in (({"normalmap": normal, "normal_map": images["normals"][0]}, "normal_map", "normalmap"),
                              ({"bumpmap": bump, "height_map": images["bumps"][0]}, "height_map", "bumpmap"),
                              ({"bumpmap": bump, "normal_map": images["normals"][0]}, "normal_map", "bumpmap")):
        line = refusal(images, {**base, **extra})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.{key} = "), line
        named = extra[key]["filename"] if isinstance(extra[key], dict) else extra[key]  # a long value is elided
        assert named.rsplit("/", 1)[1] in line and f"not with {first}" in line, line
    for scale, says in ((0, "must be > 0"), (-1, "must be > 0"), (float("nan"), "must be a finite number")):
        line = refusal(images, {**base, "bumpmap": bump, "bump_scale": scale})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.bump_scale = {scale}: {says}"), line
    # a map that is no texture's table, and a scale without a bump map, are refused rather than ignored
    for extra, key, says in (({"normalmap": [0.9, 0.5, 0.5]}, "normalmap", "must be a texture's table"),
                             ({"bumpmap": "height.png"}, "bumpmap", "must be a texture's table"),
                             ({"bump_scale": 0.5}, "bump_scale", "only with bumpmap")):
        line = refusal(images, {**base, **extra})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.{key} = ") and says in line, line


def test_xml_maps_and_refusals(tmp_path, images):
    """The XML loader: a normalmap around a diffuse gives a material with the normal map's lookup, a bumpmap its
    bump lookup and scale; a normalmap without its texture, and a bumpmap without one, are refused in one line at
    the wrapper's line; a normalmap inside a normalmap (or a bumpmap inside one) is unsupported, in one line. A map
    inside twosided gives its material mirrored_maps (its back sees the map's normal mirrored through the surface,
    as Mitsuba's twosided turns the directions over before the map: scenes/mitsuba/twosided_maps.xml judges it),
    a twosided inside the map does not."""
    texture = (f'<texture name="normalmap" type="bitmap"><string name="filename" value="{images["normals"][0]}"/>'
               '<boolean name="raw" value="true"/></texture>')
    height = texture.replace('"normalmap"', '"height"', 1).replace(images["normals"][0], images["bumps"][0])
    diffuse = '<bsdf type="diffuse"/>'
    scene = raytrace.load_file(mts.xml_file(tmp_path, f'<bsdf type="normalmap">{texture}{diffuse}</bsdf>'))
    assert [[slot for slot, _ in m.maps] for m in scene.materials] == [["normal"]]
    bumped = f'<bsdf type="bumpmap">{height}<float name="scale" value="0.25"/>{diffuse}</bsdf>'
    scene = raytrace.load_file(mts.xml_file(tmp_path, bumped))
    assert [([slot for slot, _ in m.maps], m.bump_scale) for m in scene.materials] == [(["bump"], 0.25)]
    inside = raytrace.load_file(mts.xml_file(tmp_path, f'<bsdf type="twosided"><bsdf type="normalmap">{texture}'
                                             f'{diffuse}</bsdf></bsdf>'))
    outside = raytrace.load_file(mts.xml_file(tmp_path, f'<bsdf type="normalmap">{texture}<bsdf type="twosided">'
                                              f'{diffuse}</bsdf></bsdf>'))
    assert [(m.mirrored_maps, m.two_sided) for m in inside.materials] == [(True, True)]
    assert [(m.mirrored_maps, m.two_sided) for m in outside.materials] == [(False, True)]
    line = lambda: str(info.value)  # noqa: E731
    at = f"{tmp_path / 'scene.xml'}:9: "
    for bsdf, says in ((f'<bsdf type="normalmap">{diffuse}</bsdf>', "normalmap takes one texture named normalmap"),
                       (f'<bsdf type="bumpmap">{diffuse}</bsdf>', "bumpmap takes one texture"),
                       (f'<bsdf type="normalmap">{texture}<bsdf type="normalmap">{texture}{diffuse}</bsdf></bsdf>',
                        "normalmap inside normalmap: one map tilts a material's normal"),
                       (f'<bsdf type="normalmap">{texture}<bsdf type="bumpmap">{height}{diffuse}</bsdf></bsdf>',
                        "bumpmap inside normalmap: one map tilts a material's normal")):
        with pytest.raises(InputError) as info:
            raytrace.load_file(mts.xml_file(tmp_path, bsdf))
        assert "\n" not in line() and line().startswith(at) and says in line(), line()
