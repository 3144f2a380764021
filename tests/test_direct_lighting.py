"""The direct-lighting model (kernels/direct_lighting.cl) against closed forms: the irradiance from a
rectangular light of uniform radiance by Lambert's polygon formula, a white furnace, a light's black back
and a point behind a light.

The renderer's estimate at a point is unbiased (area sampling, p_A = 1 / A): each lane here is an independent
estimate (its own key, random light samples), so the mean over lanes differs from the expected value by
about its standard error, SE = sd / sqrt(lanes). The tests allow 5 SE (a chance of about 6e-7 per case for a
normal mean; with 512 lanes the central limit holds well for these bounded-variance cases), plus the float32
rounding of each sample's geometry term, a few ulp relative, far below that: 1e-5 relative."""
import dataclasses
import re
import tomllib

import numpy as np
import pytest

import raytrace
from raytrace import samplers
from helpers import SURFACE_POINT, run, without_ambient
from raytrace.errors import InputError
from raytrace.renderer.program import Features
from raytrace.scene import Camera, Light, Material, Scene, parse_scene
from raytrace.commands.stability.probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, planar, scene_args

RADIANCE = """
#include "direct_lighting.cl"
""" + SURFACE_POINT + """__kernel void radiance(int n, SCENE_PARAMETERS, __global const uint2 *light_samples, __global const float *p,
                       __global const float *nrm, __global float *out)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 at = IN3(p), normal = IN3(nrm);
    Ray r; /* a viewer above the point: Lambertian, any */
    Hit hit = surface_hit(at, normal, &r);
    ShadingPoint sp = white(at, normal);
    vfloat rays = 0.0f;
    PixelSample ps = start_pixel_sample(pixel_key(AS_VUINT(I * LANES + LANE_IDS), s.params->seed), (vint)(0));
    OUT3(out, shade(&s, r, hit, sp, light_samples, &ps, &rays));
}
"""
LANES_PER_CASE = 512
LIGHT_SAMPLES = 64
DIRECT = dict(HAS_RECTANGLES=0, HAS_TRIANGLES=0, HAS_ELLIPSOIDS=0, HAS_DIRECT_LIGHTING=1)


def light(center, size, normal, tangent, radiance=1.0):
    return Light(center=np.asarray(center, float), size=np.asarray(size, float), normal=np.asarray(normal, float),
                 tangent=np.asarray(tangent, float), colour=np.full(3, radiance))


def scene_of(lights):
    """The lights alone, with a white material for the probe's point."""
    camera = Camera(np.array([0.0, -3, 1]), np.zeros(3), np.array([0.0, 0, 1]), 45.0)
    return Scene("<test>", camera, 1, 1, np.zeros(3), lights, [Material("white", np.ones(3))], shading="direct")


def corners(l):
    """The light's corners in order (float64), as light_point's (u, v) runs round the square."""
    b = np.cross(l.normal, l.tangent)
    hx, hy = l.size / 2
    return np.array([l.center + su * hx * l.tangent + sv * hy * b for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def clip_above(poly, p, n):
    """The part of polygon `poly` with n.(x - p) >= 0 (Sutherland-Hodgman against one plane)."""
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        da, db = np.dot(n, a - p), np.dot(n, b - p)
        if da >= 0:
            out.append(a)
        if (da >= 0) != (db >= 0):
            out.append(a + (b - a) * (da / (da - db)))
    return np.array(out)


def lambert_irradiance(l, p, n):
    """E at p (unit normal n) from light l of radiance L emitting from its front face: Lambert's polygon
    formula E = L/2 |sum_i theta_i n.u_i| (Arvo, "Irradiance Tensors", 1995), over the light clipped to the
    hemisphere above p, in float64; 0 behind the light."""
    if np.dot(l.normal, p - l.center) <= 0:
        return 0.0
    poly = clip_above(corners(l), p, n)
    if len(poly) < 3:
        return 0.0
    v = poly - p
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    w = np.roll(v, -1, axis=0)
    theta = np.arccos(np.clip(np.sum(v * w, axis=1), -1, 1))
    u = np.cross(v, w)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return l.colour[0] / 2 * abs(np.sum(theta * (u @ n)))


def estimates(harness, scene, p, n, seed=0):
    """LANES_PER_CASE independent estimates of the radiance leaving p (albedo 1) per case: (cases, lanes)."""
    cases = len(p)
    p, n = np.repeat(p, LANES_PER_CASE, axis=0), np.repeat(n, LANES_PER_CASE, axis=0)
    pattern = samplers.pattern("random", LIGHT_SAMPLES)
    args = {**scene_args(scene, light_samples=LIGHT_SAMPLES, light_pattern=pattern, seed=seed,
                         features=Features(direct_lighting=True)),
            "light_samples": pattern.table(), "p": planar(p), "nrm": planar(n)}
    out = harness.run(RADIANCE, "radiance", len(p), args, {"out": 3}, **DIRECT)["out"]
    assert np.array_equal(out[0], out[1]) and np.array_equal(out[0], out[2])  # grey light, white surface
    return out[0].reshape(cases, LANES_PER_CASE)


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def assert_unbiased(est, expected):
    mean, se = est.mean(axis=1), est.std(axis=1, ddof=1) / np.sqrt(est.shape[1])
    tolerance = 5 * se + 1e-5 * np.abs(expected)
    bad = np.abs(mean - expected) > tolerance
    assert not bad.any(), list(zip(mean[bad], expected[bad], se[bad]))


def test_irradiance_matches_lamberts_formula(harness):
    """A 0.5 x 0.3 light of radiance 2 facing down at z = 1: points at random places and orientations below
    it, points nearly in its plane (1e-3 in front, beside it and under its edge), 0.05 under its middle, and
    far away (1e3), some with the light crossing their horizon; the radiance leaving them is E / pi. Not
    closer under the light's inside: area sampling's cos cos / r^2 then has a peak of 1 / h^2 over an area
    of about h^2, which 32768 samples miss (1e-3 under it, the mean of 512 lanes was 0.77 against 2.0): a
    heavy tail the standard error does not see, and what sampling by solid angle would remove."""
    rng = np.random.default_rng(41)
    lamp = light([0.0, 0.0, 1.0], [0.5, 0.3], [0, 0, -1], [1, 0, 0], radiance=2.0)
    p = np.concatenate([rng.uniform([-1, -1, -0.5], [1, 1, 0.9], (24, 3)),
                        [[0.6, 0.0, 0.999], [0.2, 0.1, 0.95], [0.25, 0.0, 0.999], [0.0, 0.0, -1e3], [300, 0, -1e3]]])
    n = unit(np.concatenate([rng.normal(size=(24, 3)) + [0, 0, 1.5],
                             [[-1, 0, 0.2], [0, 0, 1], [0, 0.3, 1], [0, 0, 1], [-0.3, 0, 1]]]))
    expected = np.array([lambert_irradiance(lamp, a, b) for a, b in zip(p, n)]) / np.pi
    assert (expected > 0).sum() >= 25 and (expected == 0).sum() >= 1  # some lit, some turned away
    assert any(0 < np.dot(b, c - a) for a, b in zip(p, n) for c in corners(lamp)) and \
        any(0 < lambert_irradiance(lamp, a, b) < lambert_irradiance(lamp, a, np.array([0, 0, 1.0]))
            for a, b in zip(p[:24], n[:24]) if np.dot(b, [0, 0, 1]) > 0)  # a horizon crosses the light
    assert_unbiased(estimates(harness, scene_of([lamp]), p, n), expected)


def test_white_furnace(harness):
    """Albedo 1 at the centre of a cube whose six faces are lights of radiance 1 facing in: whatever the
    normal, the hemisphere above is all light, E = pi, and the radiance leaving is exactly 1."""
    faces = [light(c, [2, 2], -np.array(c), t) for c, t in
             (([1, 0, 0], [0, 1, 0]), ([-1, 0, 0], [0, 1, 0]), ([0, 1, 0], [0, 0, 1]), ([0, -1, 0], [0, 0, 1]),
              ([0, 0, 1], [1, 0, 0]), ([0, 0, -1], [1, 0, 0]))]
    rng = np.random.default_rng(43)
    n = unit(rng.normal(size=(6, 3)))
    p = rng.uniform(-0.3, 0.3, (6, 3))
    assert np.allclose([sum(lambert_irradiance(f, a, b) for f in faces) for a, b in zip(p, n)], np.pi)
    assert_unbiased(estimates(harness, scene_of(faces), p, n), np.ones(6))


def test_behind_a_light_nothing(harness):
    """Points behind the light's plane (and in it) get exactly 0 from it, whatever their orientation."""
    lamp = light([0.0, 0.0, 1.0], [0.5, 0.3], [0, 0, -1], [1, 0, 0])
    rng = np.random.default_rng(47)
    p = rng.uniform([-1, -1, 1.0], [1, 1, 2.0], (8, 3))
    p[0] = [0.1, 0.0, 1.0]
    est = estimates(harness, scene_of([lamp]), p, unit(rng.normal(size=(8, 3))))
    assert np.all(est == 0)


def test_a_lights_back_is_black(harness):
    """A camera ray meeting a light's front face sees its radiance; its back face is black in the direct
    model (and still hides what is behind it), where the Phong model shows the light's colour both ways."""
    lamp = light([0.0, 0.0, 1.0], [0.5, 0.3], [0, 0, -1], [1, 0, 0], radiance=3.0)
    scene = scene_of([lamp])
    o = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    for direct, back in ((1, 0.0), (0, 3.0)):
        hit = harness.run(CLOSEST_HIT, "closest", 2, {**scene_args(scene), "o": planar(o), "d": planar(d)},
                          CLOSEST_HIT_OUTPUTS, **dict(DIRECT, HAS_DIRECT_LIGHTING=direct))
        np.testing.assert_array_equal(hit["emitted"], [3.0, back])
        np.testing.assert_array_equal(hit["t"], [1.0, 1.0])


def test_cornell_direct_renders(cornell):
    """scenes/cornell_direct.toml: scene 0's geometry and colours in the direct model; finite, the ceiling
    (behind the light's plane) black, the light's face at its radiance."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    assert scene.shading == "direct" and np.all(scene.lights[0].colour == 60) and not np.any(scene.ambient)
    assert [m.colour.tolist() for m in scene.materials] == [m.colour.tolist() for m in cornell.materials]
    assert (len(scene.rectangles), len(scene.triangles), len(scene.ellipsoids)) == \
        (len(cornell.rectangles), len(cornell.triangles), len(cornell.ellipsoids))
    image, stats = raytrace.render(scene, width=64, height=64, spp=4, light_samples=4, sampler="grid")
    assert np.isfinite(image).all() and stats.extra["nonfinite_values"] == 0
    assert "-DHAS_DIRECT_LIGHTING=1" in stats.build_options
    assert image[1, 32].max() == 0 and np.all(image[6, 32] == 60)  # the ceiling; the light's face


@pytest.mark.parametrize("change, message", [
    (lambda t: "ambient = [0.1, 0.1, 0.1]\n" + t, "ambient = [0.1, 0.1, 0.1]: is the Phong model's"),
    (lambda t: t.replace("radiance = 60.0", "colour = [1.0, 1.0, 1.0]"), "lights[0].colour"),
    (lambda t: t.replace("radiance = 60.0", "radiance = -1.0"), "lights[0].radiance = -1.0"),
    (lambda t: t.replace("radiance = 60.0", "radiance = [1.0, 2.0]"), "lights[0].radiance = [1.0, 2.0]"),
    (lambda t: t.replace('shading = "direct"', 'shading = "pbr"'), "render.shading = 'pbr': must be one of"),
    (lambda t: t.replace('shading = "direct"', ''), "lights[0].radiance"),  # Phong lights have a colour
])
def test_bad_direct_scenes_are_one_line(cornell, change, message):
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    with pytest.raises(InputError, match=re.escape(message)):
        parse_scene(tomllib.loads(change(text)), "cornell_direct.toml")


def test_radiance_as_three_numbers(cornell):
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    scene = parse_scene(tomllib.loads(text.replace("radiance = 60.0", "radiance = [1.0, 2.0, 3.0]")))
    assert scene.lights[0].colour.tolist() == [1.0, 2.0, 3.0]


def test_shading_from_the_command_line(cornell):
    """--shading (render's shading=) overrides the scene's: scene 0's white light then is a radiance of 1."""
    scene = without_ambient(cornell.path)
    direct, stats = raytrace.render(scene, width=16, height=16, spp=1, light_samples=4, shading="direct")
    phong, _ = raytrace.render(scene, width=16, height=16, spp=1, light_samples=4)
    assert "-DHAS_DIRECT_LIGHTING=1" in stats.build_options and not np.array_equal(direct, phong)
    with pytest.raises(InputError, match="shading = 'pbr'"):
        raytrace.render(scene, width=16, height=16, shading="pbr")


def test_textures_in_the_direct_model(cornell):
    """textured_cornell.toml (colour, normal and height maps, a BVH) shaded by direct lighting: the maps
    are compiled in beside it, the image is finite, and its colour maps show (a textured scene differs from
    the same scene with every map removed)."""
    scene = without_ambient(cornell.path.replace("cornell.toml", "textured_cornell.toml"))
    options = dict(width=48, height=48, spp=4, light_samples=4, shading="direct")
    image, stats = raytrace.render(scene, **options)
    assert {"-DHAS_DIRECT_LIGHTING=1", "-DHAS_COLOUR_MAPS=1", "-DHAS_NORMAL_MAPS=1", "-DHAS_HEIGHT_MAPS=1"} <= \
        set(stats.build_options)
    assert np.isfinite(image).all() and stats.extra["nonfinite_values"] == 0 and image.mean() > 0
    plain = [dataclasses.replace(m, colour_map=-1, normal_map=-1, height_map=-1) for m in scene.materials]
    untextured, _ = raytrace.render(dataclasses.replace(scene, materials=plain), **options)
    assert np.abs(image - untextured).mean() > 0.1 * image.mean()  # the light of colour 1 is a dim radiance


CONVERGENCE = """
#include "direct_lighting.cl"
""" + SURFACE_POINT + """/* Lane i's estimate of the radiance leaving p (albedo 1): the mean of shade() over pixel samples 0 .. N-1, each
 * with the scene's light samples, written for N = 4, 16, 64 and 256 (out plane k: N = 4^(k+1)). */
__kernel void convergence(int n, SCENE_PARAMETERS, __global const uint2 *light_samples, __global const float *p,
                          __global const float *nrm, __global float *out)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 at = IN3(p), normal = IN3(nrm);
    Ray r;
    Hit hit = surface_hit(at, normal, &r);
    ShadingPoint sp = white(at, normal);
    vfloat rays = 0.0f, sum = 0.0f;
    vuint key = pixel_key(AS_VUINT(I * LANES + LANE_IDS), s.params->seed);
    for (int i = 0, k = 0; i < 256; ++i) {
        PixelSample ps = start_pixel_sample(key, (vint)(i));
        ps.dimension = 1; /* after the pixel offset, as in render.cl */
        sum += shade(&s, r, hit, sp, light_samples, &ps, &rays).x;
        if (i + 1 == 4 << (2 * k))
            OUT(out + (k++) * n, sum / (float)(i + 1));
    }
}
"""
SAMPLE_COUNTS = np.array([4, 16, 64, 256])


def convergence_slope(harness, pattern_name, p, n, expected):
    """The slope of log RMSE against log N, RMSE over LANES_PER_CASE independent randomisations of the light
    pattern with one light sample per pixel sample, relative to the expected value; one per case."""
    pattern = samplers.pattern(pattern_name, 1)
    lamp = light([0.0, 0.0, 1.0], [0.5, 0.3], [0, 0, -1], [1, 0, 0])
    cases = len(p)
    args = {**scene_args(scene_of([lamp]), light_samples=1, light_pattern=pattern, seed=17,
                         features=Features(direct_lighting=True)), "light_samples": pattern.table(),
            "p": planar(np.repeat(p, LANES_PER_CASE, axis=0)), "nrm": planar(np.repeat(n, LANES_PER_CASE, axis=0))}
    out = harness.run(CONVERGENCE, "convergence", cases * LANES_PER_CASE, args, {"out": 4}, **DIRECT)["out"]
    errors = out.reshape(4, cases, LANES_PER_CASE) - expected[None, :, None]
    rmse = np.sqrt(np.mean(np.square(errors), axis=2)) / expected[None, :]
    return np.polyfit(np.log(SAMPLE_COUNTS), np.log(rmse), 1)[0]


def test_one_light_sample_per_pixel_sample_converges_at_the_sequences_rate(harness):
    """With one light sample per pixel sample, the light points of a pixel's samples come from one
    Owen-scrambled Sobol sequence (kernels/samplers.cl), whose error for a smooth integrand falls like
    N^-3/2 (Owen, "Scrambled net variance for integrals of smooth functions", 1997), against N^-1/2 for
    independent points: the irradiance from a light wholly above the horizon (no visibility edge, Lambert's
    closed form the expected value) at three points. The RMSE at each N comes from 512 independent
    randomisations, so its relative standard deviation is about sqrt((kurtosis - 1) / (4 * 512)): 3% for
    normal errors, 7% for a kurtosis of 10; over N = 4 .. 256 (log N spread 5.5) a least-squares slope then
    has a standard deviation of at most 0.03. The bounds, slope < -1.1 for sobol (measured -1.5) and
    -0.5 +- 0.12 for random, are more than 10 of those from the expected slopes: a false failure does not
    happen. The old light sampling (point 0 of the pattern, re-keyed for every pixel sample) converges like
    random, and fails the sobol bound."""
    p = np.array([[0.1, 0.05, 0.2], [0.5, -0.3, 0.0], [-0.2, 0.3, 0.6]])
    n = unit(np.array([[0.0, 0.0, 1.0], [-0.4, 0.2, 1.0], [0.1, -0.1, 1.0]]))
    lamp = light([0.0, 0.0, 1.0], [0.5, 0.3], [0, 0, -1], [1, 0, 0])
    assert all(np.all((corners(lamp) - a) @ b > 0) for a, b in zip(p, n))  # the whole light above the horizon
    expected = np.array([lambert_irradiance(lamp, a, b) for a, b in zip(p, n)]) / np.pi
    sobol = convergence_slope(harness, "sobol", p, n, expected)
    random = convergence_slope(harness, "random", p, n, expected)
    assert np.all(sobol < -1.1), sobol
    assert np.all(np.abs(random + 0.5) < 0.12), random


def test_the_radiometric_default_pattern_is_sobol(cornell):
    """A direct scene that names no pattern gets sobol for pixels and lights (the sequence that converges
    fastest, docs/sampling.md); a Phong one keeps the course's grid."""
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    assert "sampler" not in text
    scene = parse_scene(tomllib.loads(text), "cornell_direct.toml")
    assert (scene.sampler, scene.light_sampler) == ("sobol", "sobol")
    phong = parse_scene(tomllib.loads(open(cornell.path).read().replace('sampler = "grid"', "")), "cornell.toml")
    assert (phong.sampler, phong.light_sampler) == ("grid", "grid")


@pytest.mark.parametrize("pattern", ["grid", "center", "rotated-grid-cw"])
def test_one_light_sample_at_one_point_is_refused(cornell, tmp_path, pattern):
    """In the direct model a course's pattern of one light sample is the light's centre: a point light, biased
    however many pixel samples. Refused in one line wherever it could come from: the scene file, render()'s
    options, a parameter edit, the command line (exit 2, no file); 4 grid points, and the Phong model's point
    light (its center sampler), are accepted."""
    path = cornell.path.replace("cornell.toml", "cornell_direct.toml")
    text = open(path).read()
    with pytest.raises(InputError, match=re.escape(f"render.light_sampler = '{pattern}': with 1 light sample")):
        parse_scene(tomllib.loads(text.replace("light_samples = 16", f'light_samples = 1\nlight_sampler = '
                                                                     f'"{pattern}"')), "x.toml")
    scene = raytrace.load_file(path)
    with pytest.raises(InputError, match=re.escape(f"{path}: render.light_sampler = '{pattern}': with 1 light")):
        raytrace.render(scene, width=8, height=8, light_samples=1, light_sampler=pattern)
    params = raytrace.parameters(scene)
    params["render.light_samples"], params["render.light_sampler"] = 1, pattern
    with pytest.raises(InputError, match="light_sampler"):
        params.update()
    assert scene.light_samples == 16  # left as it was
    out = tmp_path / "x.png"
    r = run("render", path, "-o", out, "--width", 8, "--height", 8, "--light-samples", 1, "--light-sampler", pattern)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and pattern in r.stderr, r.stderr
    assert "light sample" in r.stderr and not out.exists()
    raytrace.render(scene, width=8, height=8, light_samples=4, light_sampler="grid")
    raytrace.render(without_ambient(cornell.path), width=8, height=8, light_samples=1, light_sampler="center")
