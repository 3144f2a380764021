"""The `envmap` emitter (kernels/environment.cl): its lookup and its sampling against float64 references
written here from the layout the manual states (Mitsuba 3's: u = atan2(x, -z) / 2 pi, v = acos(y) / pi in
the map's frame, texels at u = (i + 1/2) / w and v = j / (h - 1), bilinear between them), a chi-square
test of the sampled
directions, the path tracer with a map (a furnace, three techniques agreeing), the shipped sky, and bad
input.

Tolerances are argued where they are used; every test runs at every lane width the machine has."""
import re

import numpy as np
import OpenImageIO as oiio
import pytest
from scipy import stats

import raytrace
from raytrace.errors import InputError
from raytrace.scene.model import EnvironmentMap
from raytrace.scene.scene_file import parse_scene
from raytrace.commands.stability.probe import planar, scene_args

from helpers import ROOT, at_lane_ends
from path_support import assert_mean, assert_techniques_agree, environment_scene, traced

ENVIRONMENT = """
#include "environment.cl"
/* Per lane: the map's radiance along d (times its scale), the density environment_pdf gives d, and a
 * direction drawn by the point xi with the density the sample reports; with skip > 0, for the lanes whose
 * index is not skip - 1 mod skip only. */
__kernel void probe(int n, SCENE_PARAMETERS, __global const float *d, __global const float *xi, int skip,
                    __global float *radiance, __global float *pdf, __global float *sampled,
                    __global float *sampled_pdf)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const vint ALL_LANES = skip > 0 ? (I * LANES + LANE_IDS) % skip != skip - 1 : (vint)(-1) != 0;
    vec3 dir = IN3(d);
    OUT3(radiance, environment_radiance(&s, dir, ALL_LANES));
    OUT(pdf, environment_pdf(&s, dir, ALL_LANES));
    vec2 u = {IN(xi), IN(xi + n)};
    vfloat p;
    OUT3(sampled, sample_environment(&s, u, ALL_LANES, &p));
    OUT(sampled_pdf, p);
}
"""
DEFINES = dict(HAS_PATH_TRACING=1, HAS_ENVIRONMENT=1, HAS_ENVIRONMENT_MAP=1, HAS_RECTANGLES=1)
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def small_map(h=16, w=32):
    """A small map with structure at every scale: random texels, a bright blob, and its lowest three rows
    black, whose texels (beyond the neighbours of lit ones) get no samples at all."""
    rng = np.random.default_rng(5)
    texels = rng.uniform(0.0, 1.0, (h, w, 3))
    texels[3:5, 20:23] += 40.0
    texels[h - 4:] = 0.0
    return texels.astype(np.float32)


def map_scene(texels, up=(0.0, 0.0, 1.0), forward=(0.3, -1.0, 0.2), scale=1.0, material=None):
    """environment_scene's sphere under an envmap of `texels`, the map turned off the world's axes."""
    scene = environment_scene(material or {"colour": [0.5, 0.5, 0.5]})
    return scene.__class__(**{**vars(scene), "environment": None, "environment_map": EnvironmentMap(
        "<test map>", texels, scale, np.array(up), np.array(forward))})


def frame(up, forward):
    """The map's local axes in world coordinates, derived here: y = up, z = forward made orthogonal to it,
    x = y cross z."""
    y = np.asarray(up, float) / np.linalg.norm(up)
    z = np.asarray(forward, float) - np.dot(forward, y) * y
    z /= np.linalg.norm(z)
    return np.cross(y, z), y, z


def uv_of(d, axes):
    x, y, z = (d @ a for a in axes)
    return np.mod(np.arctan2(x, -z) / (2 * np.pi), 1.0), np.arccos(np.clip(y, -1, 1)) / np.pi


def bilinear(texels, u, v):
    """The radiance at (u, v): bilinear between texels at u = (i + 1/2) / w, wrapping, and v = j / (h - 1)
    (float64)."""
    h, w = texels.shape[:2]
    x, y = u * w - 0.5, v * (h - 1)
    i, j = np.floor(x).astype(int), np.minimum(np.floor(y).astype(int), h - 2)
    a, b = (x - i)[..., None], (y - j)[..., None]
    t = lambda ii, jj: texels[np.clip(jj, 0, h - 1), np.mod(ii, w)].astype(np.float64)  # noqa: E731
    return (1 - b) * ((1 - a) * t(i, j) + a * t(i + 1, j)) + b * ((1 - a) * t(i, j + 1) + a * t(i + 1, j + 1))


def cell_probabilities(texels):
    """The probability of each of the w x (h - 1) cells (u in [i, i + 1] / w, v in [j, j + 1] / (h - 1)): the
    mean luminance of the bilinear radiance over the cell (exactly the mean of its values at the centres of
    the cell's two halves in u, each within one bilinear patch), times sin(theta) at the cell's centre,
    normalised."""
    h, w = texels.shape[:2]
    jj, ii = np.meshgrid(np.arange(h - 1), np.arange(w), indexing="ij")
    mean = sum(bilinear(texels, (ii + a) / w, (jj + 0.5) / (h - 1)) for a in (0.25, 0.75)) / 2
    weight = (mean @ LUMINANCE) * np.sin(np.pi * (np.arange(h - 1) + 0.5) / (h - 1))[:, None]
    return weight / weight.sum()


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def probe(harness, scene, d, xi, skip=0):
    args = {**scene_args(scene), "d": planar(d), "xi": planar(xi), "skip": np.int32(skip)}
    return harness.run(ENVIRONMENT, "probe", len(d), args, {"radiance": 3, "pdf": 1, "sampled": 3,
                                                          "sampled_pdf": 1}, **DEFINES)


def random_directions(rng, m):
    """m directions uniform on the sphere."""
    return unit(rng.normal(size=(m, 3)))


def test_lookup_against_float64(harness):
    """The radiance along 4096 random directions, the map turned off every axis and scaled by 2, equals the
    bilinear reference within 0.02 absolute. Why that bound: the kernel's u and v come from float32 dot
    products, atan2 and acos, each a few ulps, so a direction's position on the map is off by about 1e-6 /
    sin(theta) radians; the test keeps sin(theta) >= 0.045 (|y| <= 0.999), giving at most 3e-4 texel at
    32 texels around, and the texels (up to 41) change by at most 41 per texel: 0.0123. A mirrored u
    (atan2(x, z)), an unwrapped seam, columns at i / w or rows at (j + 1/2) / h are off by whole texels'
    differences."""
    texels = small_map()
    up, forward = (0.0, 0.0, 1.0), (0.3, -1.0, 0.2)
    scene = map_scene(texels, up, forward, scale=2.0)
    axes = frame(up, forward)
    rng = np.random.default_rng(1)
    d = random_directions(rng, 4096)
    d = d[np.abs(d @ axes[1]) <= 0.999]
    out = probe(harness, scene, d, rng.uniform(size=(len(d), 2)))
    expected = 2.0 * bilinear(texels, *uv_of(d, axes))
    np.testing.assert_allclose(out["radiance"].T, expected, rtol=0, atol=0.02)


def test_lanes_left_out_look_nothing_up(harness):
    """The lookups, densities and samples of a packet's lanes (environment.cl takes a mask: the path model asks
    for few lanes at a time) are those of the full packet in the lanes asked for, and 0 in the others."""
    scene = map_scene(small_map(), (0.0, 0.0, 1.0), (0.3, -1.0, 0.2))
    rng = np.random.default_rng(4)
    d, xi = random_directions(rng, 512), rng.uniform(size=(512, 2))
    full, masked = probe(harness, scene, d, xi), probe(harness, scene, d, xi, skip=3)
    off = np.arange(512) % 3 == 2
    for key in full:
        np.testing.assert_array_equal(masked[key][..., ~off], full[key][..., ~off])
        assert np.all(masked[key][..., off] == 0) and np.mean(full[key][..., off] != 0) > 0.5, key


def test_density_matches_the_luminance(harness):
    """environment_pdf's density of random directions equals p_cell w (h - 1) / (2 pi^2 sin(theta)), the
    probability of the cell it falls in from its luminance (cell_probabilities). The kernel reads each probability as a difference
    of float32 cumulative entries, each within 2^-25 of the float64 sum, so the relative error is at most
    2^-24 / p_row + 2^-24 / p_column (the column's conditional probability); float32 sin adds 1e-6. Cells of
    probability 0 get density 0."""
    texels = small_map()
    up, forward = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    scene = map_scene(texels, up, forward)
    h, w = texels.shape[:2]
    rng = np.random.default_rng(2)
    d = random_directions(rng, 4096)
    u, v = uv_of(d, frame(up, forward))
    rows = h - 1  # of cells
    inside = (np.abs(u * w - np.round(u * w)) > 1e-3) & (np.abs(v * rows - np.round(v * rows)) > 1e-3)  # off edges
    d, u, v = d[inside], u[inside], v[inside]
    out = probe(harness, scene, d, rng.uniform(size=(len(d), 2)))
    p = cell_probabilities(texels)
    i, j = (u * w).astype(int), (v * rows).astype(int)
    expected = p[j, i] * w * rows / (2 * np.pi**2 * np.sin(np.pi * v))
    row = p.sum(axis=1)[j]
    column = np.where(row > 0, p[j, i] / np.where(row > 0, row, 1), 1)
    bound = (2.0**-24 / np.maximum(row, 1e-300) + 2.0**-24 / np.maximum(column, 1e-300) + 1e-5) * expected
    assert np.all(np.abs(out["pdf"] - expected) <= bound)
    assert np.any(expected == 0) and np.all(out["pdf"][expected == 0] == 0)


def test_sampling_chi_square(harness):
    """2^19 directions drawn from independent uniform points fall on the cells as their probabilities say:
    Pearson's chi-square over the 480 cells (those expecting fewer than 5 pooled) at significance 1e-4, a
    false failure once in 10^4 runs per lane width; none on a cell of probability 0. Each sample's
    reported density is the one environment_pdf gives its direction: the same table entries, sin(theta)
    recomputed, 1e-5 relative at the median; 1 in 10^4 differ by more than 1e-3 (measured 67 of 2^19), those
    on a cell's edge, whose recomputed u or v rounds into the neighbour, or near a pole, where acos of a
    float32 y near 1 loses digits: the MIS weights of such a direction sum to 1 within that. Weighting each
    cell by its own column's luminance alone, without its neighbours' share, fails (seen)."""
    texels = small_map()
    up, forward = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)
    scene = map_scene(texels, up, forward)
    h, w = texels.shape[:2]
    rng = np.random.default_rng(3)
    n = 2**19
    xi = rng.uniform(size=(n, 2)).astype(np.float32)
    d = np.tile([[0.0, 0.6, 0.8]], (n, 1))
    out = probe(harness, scene, d, xi)
    sampled = out["sampled"].T
    np.testing.assert_allclose(np.linalg.norm(sampled, axis=1), 1.0, atol=1e-5)
    u, v = uv_of(unit(sampled), frame(up, forward))
    observed = np.zeros((h - 1, w))
    np.add.at(observed, (np.minimum((v * (h - 1)).astype(int), h - 2), np.minimum((u * w).astype(int), w - 1)), 1)
    expected = cell_probabilities(texels) * n
    assert observed[expected == 0].sum() == 0
    small = expected < 5
    obs = np.append(observed[~small & (expected > 0)], observed[small].sum())
    exp = np.append(expected[~small & (expected > 0)], expected[small].sum())
    keep = exp > 0
    statistic = np.sum((obs[keep] - exp[keep]) ** 2 / exp[keep])
    p_value = stats.chi2.sf(statistic, keep.sum() - 1)
    assert p_value > 1e-4, (statistic, keep.sum())
    again = probe(harness, scene, sampled, xi)["pdf"]
    ok = out["sampled_pdf"] > 0
    relative = np.abs(out["sampled_pdf"][ok] - again[ok]) / out["sampled_pdf"][ok]
    assert np.median(relative) < 1e-5 and np.mean(relative > 1e-3) < 1e-3


def test_a_uniform_map_is_the_constant_environment():
    """A map of one value L everywhere (any size, any orientation) lights the furnace sphere as the constant
    environment of L does: rho L from a diffuse sphere of albedo rho, L off a mirror; the background is L
    exactly. The map's own sampling (uniform in (u, v), so denser towards the poles) and its MIS weights
    against the BSDF must still add up."""
    for material, expected in (({"colour": [0.5, 0.5, 0.5]}, 0.5), ({"type": "conductor"}, 1.0)):
        scene = map_scene(np.full((8, 16, 3), 2.0, np.float32), material=material)
        image, stats = raytrace.render(scene, spp=64, light_samples=1)
        assert "-DHAS_ENVIRONMENT_MAP=1" in stats.build_options and stats.extra["nonfinite_values"] == 0
        np.testing.assert_allclose(np.asarray(image)[:3, :3], 2.0, rtol=1e-6)
        assert_mean(np.asarray(image)[20:44, 20:44], 2.0 * expected)


@at_lane_ends
def test_techniques_agree_under_the_sky(harness):
    """The materials scene under its sky with a sun: sampling the lights and the map alone, the BSDF alone,
    and both by MIS agree (5 standard errors of each difference) at a floor point in the open, one in the
    gold sphere's shadow, and on a rough gold surface (material 0 is the textured floor: the points take the
    scene's first material, and a white Lambertian one for the first two)."""
    scene = raytrace.load_file(ROOT / "scenes" / "materials.toml")
    p = np.array([[1.0, -1.5, 0.0], [-0.5, 0.9, 0.0]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0]])
    est = {k: traced(harness, scene, p, n, k) for k in (0, 1, 2)}
    mean, se = assert_techniques_agree(est)
    assert np.all(mean[0] > 0) and np.all(se[0] < se[2])
    gold = raytrace.load_file(ROOT / "scenes" / "materials.toml")
    materials = [m for m in gold.materials if m.name == "gold"] + [m for m in gold.materials if m.name != "gold"]
    gold = gold.__class__(**{**vars(gold), "materials": materials})
    est = {k: traced(harness, gold, np.array([[0.0, -3.0, 0.0]]), np.array([[0, -1.0, 0.3]]) / np.hypot(1, 0.3),
                     k, shaded=True) for k in (0, 1, 2)}
    assert_techniques_agree(est)


def test_the_shipped_sky_is_the_generated_one():
    """assets/textures/sky.exr reads back as the `assets` command's sky in half precision (2^-11 relative),
    linear, 256 x 128, its sun the brightest texel above the horizon."""
    from raytrace.commands import assets
    from raytrace.scene.environment_map import load
    texels = load(ROOT / "assets" / "textures" / "sky.exr", "test", "filename")
    np.testing.assert_allclose(texels, assets.sky(), rtol=2.0**-11, atol=1e-6)
    assert texels.shape == (128, 256, 3)
    j, i = np.unravel_index(np.argmax(texels @ LUMINANCE), texels.shape[:2])
    assert j < 64 and abs(i / 256 - assets.SUN_U) < 2 / 256


def write_exr(path, pixels):
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.FLOAT)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(pixels, np.float32)) and out.close()


def test_bad_maps_and_keys(tmp_path):
    """Each bad value is one InputError naming the file, the key and the value: an unreadable or missing
    file, NaN, infinite or negative radiance, a key of the other type, up parallel to forward, a negative
    scale; and the same from the Python API (an EnvironmentMap of the wrong shape, NaN texels, a map beside
    a constant radiance, a map in the direct model)."""
    good = np.ones((4, 8, 3), np.float32)
    write_exr(tmp_path / "good.exr", good)
    for name, value in (("nan.exr", np.nan), ("inf.exr", np.inf), ("negative.exr", -1.0)):
        bad = good.copy()
        bad[1, 2, 0] = value
        write_exr(tmp_path / name, bad)
    (tmp_path / "junk.exr").write_bytes(b"not an image at all")
    base = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "materials": {"m": {"colour": [0.5] * 3}},
            "render": {"shading": "path"},
            "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                        "radiance": 1.0}]}
    scene_file = tmp_path / "s.toml"
    envmap = {"type": "envmap", "filename": "good.exr"}
    cases = [({"filename": "missing.exr"}, "environment.filename = '" + str(tmp_path / "missing.exr")),
             ({"filename": "junk.exr"}, "cannot read the image"),
             ({"filename": "nan.exr"}, "texel (x=2, y=1) channel 0 is nan"),
             ({"filename": "inf.exr"}, "texel (x=2, y=1) channel 0 is inf"),
             ({"filename": "negative.exr"}, "an environment map's values must be >= 0, its lowest is -1"),
             ({"filename": "."}, "is not a regular file"),
             ({"radiance": 1.0}, "environment.radiance = 1.0: is not a parameter of type = \"envmap\""),
             ({"up": [0, 0, 1], "forward": [0, 0, -2]}, "environment.forward = [0.0, 0.0, -2.0]: must not be "
                                                         "parallel to up"),
             ({"scale": -1.0}, "environment.scale = -1.0"), ({"up": [0, 0, 0]}, "environment.up = [0, 0, 0]")]
    for change, message in cases:
        with pytest.raises(InputError, match=re.escape(message)) as e:
            parse_scene({**base, "environment": {**envmap, **change}}, str(scene_file))
        assert str(scene_file) in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(InputError, match=re.escape('environment.filename: missing')):
        parse_scene({**base, "environment": {"type": "envmap"}}, str(scene_file))
    with pytest.raises(InputError, match="is not a parameter of type = \"constant\""):
        parse_scene({**base, "environment": {"type": "constant", "radiance": 1, "filename": "good.exr"}},
                    str(scene_file))
    scene = parse_scene({**base, "environment": envmap}, str(scene_file))
    assert scene.environment is None and scene.environment_map.texels.shape == (4, 8, 3)

    def edited(**change):
        m = scene.environment_map
        fields = {"path": m.path, "texels": m.texels, "scale": m.scale, "up": m.up, "forward": m.forward}
        return scene.__class__(**{**vars(scene), "environment_map": EnvironmentMap(**{**fields, **change})})
    nan = good.copy()
    nan[0, 0, 1] = np.nan
    for bad, message in ((edited(texels=np.ones((4, 8))), "environment.texels = '(4, 8)'"),
                         (edited(texels=nan), "channel 1 is nan"), (edited(scale=np.inf), "environment.scale"),
                         (scene.__class__(**{**vars(scene), "environment": np.ones(3)}), "cannot both be set"),
                         (scene.__class__(**{**vars(scene), "shading": "phong"}), "is the radiometric models'")):
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.render(bad, spp=1)
