"""The path model (kernels/path_tracing.cl) against closed forms: a furnace whose walls all emit and reflect,
the MIS weights of the two techniques, and direct light alone (max_depth 2) against the direct model.

Estimates are compared with their expected values through their standard errors: each pixel is an
independent estimate (its own randomisation of the sequence, kernels/samplers.cl), so the mean over n pixels
has a standard error of sd / sqrt(n), sd the pixels' spread. The tests allow 5 standard errors: a chance of
about 6e-7 per comparison for a normal mean (the central limit holds well over thousands of pixels of these
bounded-variance cases), plus 1e-5 relative for float32 rounding, far below that."""
import dataclasses
import re

import numpy as np
import pytest

import raytrace
from raytrace import samplers
from raytrace.errors import InputError
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.program import Features
from raytrace.commands.stability.probe import planar, scene_args

from devtools.chi_square import SIGNIFICANCE, chi_square
from helpers import ROOT, SURFACE_POINT, without_ambient

FACES = [([1, 0, 0], [0, 1, 0]), ([-1, 0, 0], [0, 1, 0]), ([0, 1, 0], [0, 0, 1]), ([0, -1, 0], [0, 0, 1]),
         ([0, 0, 1], [1, 0, 0]), ([0, 0, -1], [1, 0, 0])]


def furnace(albedo, radiance=1.0, max_depth=-1):
    """A closed cube of six lights of `radiance` facing in, each reflecting with a diffuse albedo, the camera
    at its centre: every path from the camera meets a wall at every vertex."""
    return raytrace.load_dict({
        "camera": {"position": [0.1, -0.2, 0.05], "look_at": [0.3, 1.0, 0.2], "up": [0, 0, 1], "fov": 100.0},
        "image": {"width": 48, "height": 48},
        "render": {"shading": "path", "max_depth": max_depth},
        "materials": {"grey": {"colour": [albedo] * 3}},
        "lights": [{"center": c, "size": [2.0, 2.0], "normal": [-x for x in c], "tangent": t, "radiance": radiance,
                    "material": "grey"} for c, t in FACES]})


def assert_mean(image, expected):
    pixels = np.asarray(image).reshape(-1, 3)
    mean, se = pixels.mean(axis=0), pixels.std(axis=0, ddof=1) / np.sqrt(len(pixels))
    assert np.all(np.abs(mean - expected) <= 5 * se + 1e-5 * expected), (mean, se, expected)
    return mean, se


@pytest.mark.parametrize("albedo, max_depth", [(0.5, -1), (0.8, -1), (0.5, 1), (0.5, 2), (0.5, 3), (0.8, 6)])
def test_furnace(albedo, max_depth):
    """Every vertex of every path is on a wall that emits L_e and reflects with albedo rho, so the radiance
    is the geometric series L_e (1 + rho + ... + rho^(D-1)) over the D vertices max_depth allows, L_e / (1 -
    rho) unbounded (where Russian roulette ends the paths from vertex 5 on: it must not bias the sum). At
    max_depth 1 the camera sees the walls' emission alone, exactly. Each vertex's light arrives both by
    sampling the lights and by the BSDF's ray hitting a wall, weighted by MIS: the weights must add to one."""
    image, stats = raytrace.render(furnace(albedo, max_depth=max_depth), spp=16, light_samples=1)
    depth = max_depth if max_depth >= 0 else np.inf
    expected = (1 - albedo**depth) / (1 - albedo)
    if max_depth == 1:
        np.testing.assert_array_equal(image, 1.0)
        return
    mean, se = assert_mean(image, expected)
    assert np.all(se < 0.01 * expected)  # the test can resolve a 5% bias
    assert "-DHAS_PATH_TRACING=1" in stats.build_options and stats.extra["nonfinite_values"] == 0


def test_furnace_bias_is_seen():
    """The furnace test's power: at max_depth 3 the expected 1.75 lies 0.25 from max_depth 2's 1.5, many
    standard errors away, so a vertex lost or counted twice fails it."""
    image, _ = raytrace.render(furnace(0.5, max_depth=2), spp=16, light_samples=1)
    with pytest.raises(AssertionError):
        assert_mean(image, 1.75)


def test_depth_two_is_the_direct_model(cornell):
    """max_depth 2 is direct light only: its expected image is the direct model's, block by block of 16 x 16
    pixels (each block's mean difference within 5 of its standard errors, from the two renders' pixel
    spreads; 16 blocks: a false failure once in 1e5 runs)."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    options = dict(width=64, height=64, spp=64, light_samples=1)
    direct, _ = raytrace.render(scene, **options)
    path, _ = raytrace.render(scene, shading="path", max_depth=2, seed=1, **options)
    d = np.clip(np.asarray(path) - np.asarray(direct), -100, 100).reshape(4, 16, 4, 16, 3)
    mean = d.mean(axis=(1, 3))
    se = d.std(axis=(1, 3), ddof=1) / 16
    assert np.all(np.abs(mean) <= 5 * se + 1e-5), np.max(np.abs(mean) / (se + 1e-12))
    unbounded, _ = raytrace.render(scene, shading="path", **options)  # indirect light is no small change
    assert np.asarray(unbounded).mean() > 1.1 * np.asarray(direct).mean()


@pytest.mark.parametrize("change, message", [
    (dict(max_depth=-2), "render(): max_depth = -2: must be an integer in [-1, 1024]"),
    (dict(max_depth=1.5), "render(): max_depth = 1.5"),
    (dict(max_depth=3, shading="direct"), 'render(): max_depth = 3: is the path model\'s, and this render\'s '
                                          'shading is "direct"'),
])
def test_bad_render_options_are_one_line(cornell, change, message):
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    with pytest.raises(InputError) as e:
        raytrace.render(scene, **{"shading": "path", "width": 8, "height": 8, **change})
    assert str(e.value).startswith(message) and "\n" not in str(e.value)


def test_bad_scene_keys_are_one_line():
    table = lambda **render: {  # noqa: E731
        "camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
        "image": {"width": 8, "height": 8}, "render": render, "materials": {"grey": {"colour": [0.5] * 3}},
        "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                    "radiance": 1.0, "material": "grey"}]}
    cases = [(dict(shading="path", max_depth=-3), "render.max_depth = -3: must be"),
             (dict(shading="path", max_depth=2000), "render.max_depth = 2000: must be"),
             (dict(shading="direct"), "lights[0].material = 'grey': a light reflects only in the path model"),
             (dict(shading="direct", max_depth=3), "render.max_depth = 3: is the path model's")]
    for render, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict(table(**render))
    bad = table(shading="path")
    bad["lights"][0]["material"] = "gold"
    with pytest.raises(InputError, match=re.escape("lights[0].material = 'gold': no such material")):
        raytrace.load_dict(bad)
    scene = raytrace.load_dict(table(shading="path", max_depth=4))
    assert scene.max_depth == 4 and scene.lights[0].material == 0


def test_a_phong_scene_in_the_path_model(cornell):
    """--shading path takes a Phong scene's light colours as radiances, as --shading direct does; the image
    is finite and brighter than direct light alone (light bounces)."""
    scene = without_ambient(cornell.path)
    path, stats = raytrace.render(scene, width=32, height=32, spp=4, light_samples=1, light_sampler="sobol",
                                  shading="path")
    direct, _ = raytrace.render(scene, width=32, height=32, spp=4, light_samples=1, light_sampler="sobol",
                                shading="direct")
    assert stats.extra["nonfinite_values"] == 0 and np.asarray(path).mean() > np.asarray(direct).mean()


TRACE = """
#include "path_tracing.cl"
""" + SURFACE_POINT + """/* Lane i's estimate of the radiance leaving p (normal nrm, albedo 1 there) towards a viewer above it: the mean of
 * trace_path over pixel samples 0 .. samples-1, as render.cl traces a camera ray's hit. */
__kernel void trace(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const uint2 *light_samples,
                    __global const float *p, __global const float *nrm, int samples, __global float *out)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec3 at = IN3(p), normal = IN3(nrm);
    Ray r;
    Hit hit = surface_hit(at, normal, &r);
#if SHADED /* material 0's BSDF */
    ShadingPoint sp = shading_point(&s, ts, r, hit);
#else /* a white Lambertian surface */
    ShadingPoint sp = white(at, normal);
#endif
    vfloat rays = 0.0f;
    vuint key = pixel_key(AS_VUINT(I * LANES + LANE_IDS), s.params->seed);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < samples; ++i) {
        PixelSample ps = start_pixel_sample(key, (vint)(i));
        ps.dimension = 1;
        sum = v3_add(sum, trace_path(&s, ts, r, hit, sp, light_samples, &ps, &rays));
    }
    OUT3(out, v3_scale(sum, 1.0f / (float)samples));
}
"""


def traced(harness, scene, p, n, sampling, lanes=1024, samples=16, shaded=False, solid_angle=False, **defines_too):
    """(cases, lanes) estimates of the red channel leaving points p, light reaching them sampled as
    `sampling` says (path_tracing.cl's PATH_SAMPLING: 0 MIS, 1 the lights alone, 2 the BSDF alone); with
    `shaded`, the points have material 0's BSDF, else a white Lambertian one; with `solid_angle`, the lights
    sampled by solid angle (LIGHT_SOLID_ANGLE); defines_too, more build options (RR_DEPTH)."""
    pattern = samplers.pattern("sobol", 1)
    features = dataclasses.replace(Features.of(scene, harness.lanes), direct_lighting=False, path_tracing=True)
    defines = dict(option[2:].split("=") for option in features.options() if not option.startswith("-DLANES"))
    args = {**scene_args(scene, light_samples=1, light_pattern=pattern, features=features),
            **texture_tables(scene), "light_samples": pattern.table(), "p": planar(np.repeat(p, lanes, axis=0)),
            "nrm": planar(np.repeat(n, lanes, axis=0)), "samples": np.int32(samples)}
    out = harness.run(TRACE, "trace", len(p) * lanes, args, {"out": 3}, **defines, PATH_SAMPLING=sampling,
                      SHADED=int(shaded), LIGHT_SOLID_ANGLE=int(solid_angle), **defines_too)["out"]
    return out[0].reshape(len(p), lanes)


def assert_techniques_agree(est):
    """The three estimators' means (PATH_SAMPLING 0, 1, 2: {k: (cases, lanes)}) agree pairwise within 5
    standard errors of each difference, plus float32 rounding; returns (means, standard errors)."""
    mean = {k: e.mean(axis=1) for k, e in est.items()}
    se = {k: e.std(axis=1, ddof=1) / np.sqrt(e.shape[1]) for k, e in est.items()}
    for a, b in ((0, 1), (0, 2), (1, 2)):
        bound = 5 * np.hypot(se[a], se[b]) + 1e-5 * np.abs(mean[a])
        assert np.all(np.abs(mean[a] - mean[b]) <= bound), (a, b, mean, se)
    return mean, se


LIGHT_POINTS = np.array([[-0.3, -0.5, 0.0], [0.45, 0.4, 0.0], [0.999, 0.2, 1.0], [-0.95, 0.95, 1.95],
                         [0.0, 0.05, 1.85], [0.32, 0.0, 1.9]])
LIGHT_NORMALS = np.array([[0, 0, 1.0], [0, 0, 1.0], [-1.0, 0, 0], [0.6, -0.6, -0.53], [0, 0, 1.0], [-0.6, 0, 1.0]])
LIGHT_NORMALS /= np.linalg.norm(LIGHT_NORMALS, axis=1, keepdims=True)


def test_light_sampling_bsdf_sampling_and_mis_agree(harness, cornell):
    """Sampling the lights alone, the BSDF alone, and both combined by MIS are three unbiased estimators of the
    same radiance: at points of scene 0's direct variant (a lit floor point, one in the ellipsoid's penumbra,
    one on the wall, one in the ceiling's corner that only indirect light reaches, and two 5 to 10 cm below
    the light, where both techniques carry weight) their means over 1024 lanes agree within 5 standard
    errors of each difference. Far from the small light its samples take nearly all the weight (MIS and the
    lights alone agree to 4 digits there); close to it both count. A BSDF hit counted with weight 1 beside
    the lights' MIS-weighted samples fails this at every point (seen). MIS is less noisy than either alone
    under the light (standard errors measured 0.078 against 0.175 and 0.108)."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    est = {k: traced(harness, scene, LIGHT_POINTS, LIGHT_NORMALS, k) for k in (0, 1, 2)}
    mean, se = assert_techniques_agree(est)
    assert np.all(mean[0] > 0) and se[0][4] < min(se[1][4], se[2][4])


def test_roulette_comes_after_the_light_samples(harness, cornell):
    """Russian roulette decides after a vertex's light samples and BSDF sample, before its ray is traced, as
    in Mitsuba 3 and pbrt-v4 (path_tracing.cl). With the lights alone sampled (PATH_SAMPLING 1: light that a
    BSDF ray meets weighs 0) and max_depth = RR_DEPTH + 1, the last vertex shaded is the first where roulette
    plays, and it can only cut the ray along which no light is counted: every lane's estimate equals, to the
    bit, that of a build whose roulette never plays (RR_DEPTH 100; the numbers drawn are the same). One
    vertex deeper, roulette cuts paths before a vertex's light samples, and the two builds differ: the
    comparison sees roulette where it acts. Roulette played right after a vertex's hit, before its light
    samples (the placement before commit 07d2363), fails the first part."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    for depth, same in ((6, True), (7, False)):
        at = dataclasses.replace(scene, max_depth=depth)
        with_roulette = traced(harness, at, LIGHT_POINTS, LIGHT_NORMALS, 1, lanes=64)
        without = traced(harness, at, LIGHT_POINTS, LIGHT_NORMALS, 1, lanes=64, RR_DEPTH=100)
        assert np.array_equal(with_roulette, without) == same, depth
        assert np.all(np.isfinite(with_roulette)) and np.all(with_roulette >= 0)


def test_lights_sampled_by_solid_angle(harness, cornell):
    """The same three estimators with the lights sampled by solid angle (kernels/spherical_rectangle.cl, a
    build option the renderer leaves off: docs/global-illumination.md measures it) agree with each other and
    with the estimates by area (means within 5 standard errors of each difference); just under the light
    the light's samples alone are far less noisy than by area (standard errors measured 0.020 against 0.175)
    and less noisy than MIS (0.035): the power heuristic then gives the BSDF's samples weight where the
    light's are nearly exact. A sample weighed by area where it was drawn by solid angle fails it (seen)."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    est = {k: traced(harness, scene, LIGHT_POINTS, LIGHT_NORMALS, k, solid_angle=True) for k in (0, 1, 2)}
    mean, se = assert_techniques_agree(est)
    by_area = traced(harness, scene, LIGHT_POINTS, LIGHT_NORMALS, 1)
    assert_techniques_agree({0: est[0], 1: by_area, 2: est[1]})
    se_area = by_area.std(axis=1, ddof=1) / np.sqrt(by_area.shape[1])
    assert se[1][4] < 0.5 * se_area[4] and se[1][4] < se[0][4] and np.all(se[0] < se[2])


# --- the smooth BSDFs: Fresnel, Snell, and energy ------------------------------------------------------------

FRESNEL = """
#include "path_tracing.cl"
/* Per lane: the conductor's and the dielectric's Fresnel reflectance at cos_i, and the dielectric's cos_t. */
__kernel void fresnel(int n, __global const float *cos_i, __global const float *eta, __global const float *k,
                      __global float *conductor, __global float *dielectric, __global float *cos_t)
{
    vfloat c = IN(cos_i), t;
    OUT(conductor, fresnel_conductor(c, IN(eta), IN(k)));
    OUT(dielectric, fresnel_dielectric(c, IN(eta), &t));
    OUT(cos_t, t);
}
"""
SPECULAR = dict(HAS_PATH_TRACING=1, HAS_CONDUCTORS=1, HAS_DIELECTRICS=1, HAS_RECTANGLES=1)


def fresnel_reference(cos_i, eta, k):
    """Unpolarised Fresnel reflectance of the interface to a medium of complex index eta + i k (relative), in
    complex float64 (Born and Wolf): the conductor's, and with k = 0 the dielectric's (1 beyond the critical
    angle, where the complex cos_t is imaginary and |r| = 1 exactly)."""
    n = eta + 1j * k
    sin2_t = (1 - cos_i**2) / n**2
    cos_t = np.sqrt(1 - sin2_t + 0j)
    cos_t = np.where(cos_t.imag < 0, -cos_t, cos_t)  # the decaying wave: Im(n cos_t) >= 0
    r_s = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


def test_fresnel_against_float64(harness):
    """The conductor's reflectance (pbrt-v3's real-arithmetic form) and the dielectric's against complex
    float64, over cos_i in (0, 1] and indices of gold, silver, aluminium, glass, water and their inverses (the
    ray leaving the denser medium), at every lane width. The float32 forms take some tens of roundings
    (square roots, a division of near-equal sums at grazing angles): 2e-5 absolute, where the values are
    in [0, 1] and a sign or a swapped polarisation is off by 1e-2 or more. Beyond the critical angle the
    dielectric reflects 1 exactly and cos_t is 0; elsewhere cos_t is Snell's, sqrt(1 - sin_i^2 / eta^2)."""
    cos_i = np.concatenate([np.linspace(1e-3, 1.0, 200), [1.0, 0.5, 1e-2]])
    media = [(0.143, 3.98), (0.155, 4.83), (1.66, 8.06), (0.05, 3.1), (0.0, 0.0)]  # Au, Ag, Al red; Ag blue; mirror
    glass = [1.5046, 1.333, 2.4, 1 / 1.5046, 1 / 1.333]
    c, e, kk = (np.repeat(cos_i[None], len(media) + len(glass), 0).ravel(),
                np.repeat([m[0] for m in media] + glass, len(cos_i)), np.repeat([m[1] for m in media] + [0] * 5,
                                                                                len(cos_i)))
    out = harness.run(FRESNEL, "fresnel", len(c), [c, e, kk], {"conductor": 1, "dielectric": 1, "cos_t": 1},
                      **SPECULAR)
    conductor = kk > 0
    np.testing.assert_allclose(out["conductor"][conductor], fresnel_reference(c, e, kk)[conductor], atol=2e-5)
    mirror = (e == 0) & (kk == 0)
    np.testing.assert_allclose(out["conductor"][mirror], 1.0, atol=1e-6)
    dielectric = np.isin(e, glass)
    np.testing.assert_allclose(out["dielectric"][dielectric], fresnel_reference(c, e, 0 * e)[dielectric], atol=2e-5)
    sin2_t = (1 - c**2) / e**2
    total = dielectric & (sin2_t >= 1)
    assert total.sum() > 50 and np.all(out["dielectric"][total] == 1) and np.all(out["cos_t"][total] == 0)
    inside = dielectric & (sin2_t < 1 - 1e-4)
    np.testing.assert_allclose(out["cos_t"][inside], np.sqrt(1 - sin2_t[inside]), atol=2e-6)


SCATTER = """
#include "path_tracing.cl"
/* The smooth BSDFs' sample at a surface of normal nrm seen along wo, u choosing reflection or refraction. */
__kernel void scatter(int n, __global const float *wo_, __global const float *nrm, __global const float *eta,
                      __global const float *u, __global const int *bsdf, __global const int *backface,
                      __global float *wi, __global float *weight, __global float *transmit)
{
    vec3 normal = IN3(nrm);
    ShadingPoint sp = {v3_splat(0.0f, 0.0f, 0.0f), (vfloat)(0.0f), normal, normal, v3_splat(1.0f, 1.0f, 1.0f),
                       (vfloat)(1.0f), VLOAD_INT(bsdf + I * LANES), v3((vfloat)(IN(eta)), (vfloat)(0.0f), (vfloat)(0.0f)),
                       v3_splat(0.0f, 0.0f, 0.0f), (vfloat)(0.0f), VLOAD_INT(backface + I * LANES)};
    vec3 w = normal, f = v3_splat(0.0f, 0.0f, 0.0f);
    vint t = (vint)(0);
    sample_specular(sp, IN3(wo_), IN(u), sp.bsdf != BSDF_DIFFUSE, &w, &f, &t);
    OUT3(wi, w);
    OUT3(weight, f);
    OUT(transmit, SELECT((vfloat)(0.0f), (vfloat)(1.0f), t != 0));
}
"""


def test_reflection_and_refraction_directions(harness):
    """Mirror reflection about the normal, and refraction by Snell's law: the refracted direction is a unit
    vector in the plane of wo and n, on the far side, with eta sin(theta_t) = sin(theta_i); inside a shape
    (backface) the index is inverted; past the critical angle every sample reflects. The radiance of a
    refracted sample is divided by eta^2 (pbrt-v4 9.5). Float32 to a few roundings: 1e-5."""
    rng = np.random.default_rng(5)
    m = 4096
    normal = rng.normal(size=(m, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    wo = rng.normal(size=(m, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo *= np.sign(np.sum(wo * normal, axis=1))[:, None]  # on the normal's side
    eta = rng.uniform(1.1, 2.5, m)
    u = rng.uniform(0, 1, m)
    bsdf = rng.choice([1, 2], m).astype(np.int32)
    backface = rng.choice([0, -1], m).astype(np.int32)
    out = harness.run(SCATTER, "scatter", m, [planar(wo), planar(normal), eta, u, bsdf, backface],
                      {"wi": 3, "weight": 3, "transmit": 1}, **SPECULAR)
    wi, weight, transmit = out["wi"].T, out["weight"].T, out["transmit"] > 0
    cos_i = np.sum(wo * normal, axis=1)
    mirror = 2 * cos_i[:, None] * normal - wo
    reflect = ~transmit
    np.testing.assert_allclose(wi[reflect], mirror[reflect], atol=1e-5)
    assert not np.any(transmit & (bsdf == 1))
    rel = np.where(backface != 0, 1 / eta, eta)
    t = transmit
    np.testing.assert_allclose(np.linalg.norm(wi[t], axis=1), 1, atol=1e-5)
    cos_t = -np.sum(wi[t] * normal[t], axis=1)
    assert np.all(cos_t > 0)
    sin_t = np.linalg.norm(np.cross(wi[t], normal[t]), axis=1)
    np.testing.assert_allclose(rel[t] * sin_t, np.sqrt(1 - cos_i[t] ** 2), atol=1e-5)
    np.testing.assert_allclose(np.sum(np.cross(wo[t], normal[t]) * wi[t], axis=1), 0, atol=1e-5)  # coplanar
    np.testing.assert_allclose(weight[t], 1 / rel[t, None] ** 2 * np.ones((1, 3)), rtol=1e-5)
    beyond = (bsdf == 2) & ((1 - cos_i**2) / rel**2 >= 1)
    assert beyond.sum() > 100 and not np.any(transmit[beyond])
    # the choice is Fresnel's: the share of samples refracted matches 1 - F to the binomial noise
    f = fresnel_reference(cos_i, rel, 0 * rel)
    glass = bsdf == 2
    assert abs(transmit[glass].mean() - (1 - f[glass]).mean()) < 5 * np.sqrt(0.25 / glass.sum())


@pytest.mark.parametrize("inside", [False, True])
def test_furnace_with_a_mirror_and_glass(inside):
    """A perfect mirror (conductor of material "none") and clear glass are lossless: in the furnace's uniform
    radiance L_e / (1 - rho) a camera sees that radiance through and off them too, in expectation (2.0 at
    rho = 0.5). Light reaching a wall through the glass comes only by the BSDF's rays (shadow rays stop at the
    glass), with MIS weight 1 after a specular vertex: a weight of the diffuse kind there fails it. A camera
    inside the glass (a large ellipsoid around it) sees eta^2 times that radiance, the radiance of a medium
    of index eta in the same field: the factor 1 / eta^2 of every refraction, which cancels for paths that go
    in and out again, decides it; leaving it out fails it."""
    table = {
        "camera": {"position": [0.0, -0.85 + 0.2 * inside, 0.0], "look_at": [0.0, 0.5, 0.0], "up": [0, 0, 1],
                   "fov": 70.0},
        "image": {"width": 48, "height": 48},
        "render": {"shading": "path"},
        "materials": {"grey": {"colour": [0.5] * 3}, "glass": {"type": "dielectric", "int_ior": 1.5},
                      "mirror": {"type": "conductor"}},
        "lights": [{"center": c, "size": [2.0, 2.0], "normal": [-x for x in c], "tangent": t, "radiance": 1.0,
                    "material": "grey"} for c, t in FACES],
        "shapes": [{"type": "ellipsoid", "material": "glass", "center": [-0.3, 0.3, 0.0],
                    "axes": [[0.35, 0, 0], [0, 0.3, 0], [0, 0, 0.4]]},
                   {"type": "ellipsoid", "material": "mirror", "center": [0.35, 0.4, 0.1],
                    "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]}]}
    if inside:
        table["shapes"] = [{"type": "ellipsoid", "material": "glass", "center": [0.0, -0.6, 0.0],
                            "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]}] + table["shapes"][1:]
    image, stats = raytrace.render(raytrace.load_dict(table), spp=64, light_samples=1)
    assert "-DHAS_DIELECTRICS=1" in stats.build_options and "-DHAS_CONDUCTORS=1" in stats.build_options
    assert_mean(image, 2.0 * (1.5 / 1.000277) ** 2 if inside else 2.0)


def test_bsdf_keys_are_checked():
    base = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "render": {"shading": "path"},
            "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                        "radiance": 1.0}]}
    cases = [({"type": "glass"}, "materials.m.type = 'glass': must be one of: diffuse, conductor, dielectric, "
                                 "roughconductor"),
             ({"type": "dielectric", "int_ior": 0.0}, "materials.m.int_ior = 0.0: must be > 0"),
             ({"type": "dielectric", "ext_ior": -1.0}, "materials.m.ext_ior = -1.0"),
             ({"type": "dielectric", "eta": 1.5}, "materials.m.eta = 1.5: is not a parameter of type = \"dielectric\""),
             ({"type": "conductor", "k": [1.0, -2.0, 1.0]}, "materials.m.k = [1.0, -2.0, 1.0]"),
             ({"colour": [1, 1, 1], "int_ior": 1.3}, "materials.m.int_ior = 1.3: is not a parameter"),
             ({"type": "roughconductor", "alpha": 0.0}, "materials.m.alpha = 0.0: must be > 0"),
             ({"type": "roughconductor", "alpha": 1.5}, "materials.m.alpha = 1.5"),
             ({"type": "conductor", "alpha": 0.3}, "materials.m.alpha = 0.3: is not a parameter of type = \"conductor\"")]
    for material, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict({**base, "materials": {"m": material}})
    direct = {**base, "render": {"shading": "direct"}, "materials": {"m": {"type": "conductor"}}}
    with pytest.raises(InputError, match=re.escape("materials.m.type = 'conductor': is the path model's")):
        raytrace.load_dict(direct)
    scene = raytrace.load_dict({**base, "materials": {"m": {"type": "conductor", "eta": 0.2, "k": [3.0, 3.5, 4.0]}}})
    assert scene.materials[0].eta == (0.2, 0.2, 0.2) and scene.materials[0].k == (3.0, 3.5, 4.0)


COSINE = """
#include "path_tracing.cl"
/* Each lane's cosine-weighted direction about nrm from u. */
__kernel void cosine(int n, __global const float *nrm, __global const float *u, __global float *wi)
{
    vec2 uu = {IN(u), IN(u + n)};
    OUT3(wi, cosine_direction(IN3(nrm), uu));
}
"""


@pytest.mark.parametrize("normal", [[0, 0, 1.0], [0, 0, -1.0], [0.48, -0.6, 0.64]])
def test_diffuse_sampling_chi_square(harness, normal):
    """The diffuse BSDF's directions (Malley's method on the concentric disk) are distributed as cos(theta) / pi
    about the normal, in the normal's frame (Duff et al.'s basis, also for a normal pointing down): a
    chi-square test over 16 x 32 cells of the sphere from 2^18 independent samples (devtools/chi_square.py),
    significance 1e-4 per case, 3 cases: a correct sampler fails once in 3000 runs. The same samples fail
    against the uniform hemisphere's density (p below 1e-10): the test sees a wrong density."""
    n = np.asarray(normal) / np.linalg.norm(normal)
    m = 1 << 18
    u = np.random.default_rng(11).uniform(0, 1, (2, m))
    wi = harness.run(COSINE, "cosine", m, [planar(np.tile(n, (m, 1))), np.ascontiguousarray(u.ravel())],
                     {"wi": 3}, **SPECULAR)["wi"].T
    t = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    t /= np.linalg.norm(t)
    local = wi @ np.stack([t, np.cross(n, t), n], axis=1)  # the directions in a frame of n (z along it)
    cosine = lambda c, phi: np.where(c > 0, c / np.pi, 0.0)  # noqa: E731
    p, statistic, total = chi_square(local, cosine)
    assert abs(total - 1) < 1e-9 and p > SIGNIFICANCE, (p, statistic)
    assert chi_square(local, lambda c, phi: np.where(c > 0, 1 / (2 * np.pi), 0.0))[0] < 1e-10
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1, atol=1e-5)


def test_rough_conductor_techniques_agree(harness, cornell):
    """A rough gold conductor (alpha 0.3, Fresnel per channel) on every white surface of scene 0's direct
    variant: the BSDF's value in the lights' samples (pi F D G2 / (4 cos_o) per channel, light_sampling.cl
    summing colours) and its visible-normal samples must estimate the same radiance, alone and combined by
    MIS, within 5 standard errors of each difference: on the lit floor, and under the light, where the
    viewer above sees the light's reflection and both techniques carry weight. A wrong D, G2, Fresnel or
    density in either technique moves it away from the other (a missing factor 4 fails it, seen)."""
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    text = text.replace('shading = "direct"', 'shading = "path"').replace(
        "white = { colour = [0.7, 0.7, 0.7] }", 'white = { type = "roughconductor", alpha = 0.3, colour = [1.0, 1.0, '
        "1.0], eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603] }")
    scene = raytrace.load_string(text)
    assert scene.materials[0].bsdf == "roughconductor"
    p = np.array([[-0.3, -0.5, 0.0], [0.05, 0.02, 1.6], [0.2, -0.1, 1.8]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0]])
    est = {k: traced(harness, scene, p, n, k, shaded=True) for k in (0, 1, 2)}
    mean, _ = assert_techniques_agree(est)
    assert np.all(mean[0] > 0)


# --- the environment ---------------------------------------------------------------------------------------

def environment_scene(material, radiance=1.0):
    """One sphere of `material` in a constant environment, filling the middle of the image (the light is a
    speck of radiance 0: a scene has one)."""
    return raytrace.load_dict({
        "camera": {"position": [0.0, -3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0, 0, 1], "fov": 40.0},
        "image": {"width": 64, "height": 64}, "render": {"shading": "path"},
        "environment": {"type": "constant", "radiance": radiance},
        "materials": {"m": material},
        "lights": [{"center": [0, 0, 50], "size": [0.01, 0.01], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                    "radiance": 0.0}],
        "shapes": [{"type": "ellipsoid", "material": "m", "center": [0, 0, 0],
                    "axes": [[0.8, 0, 0], [0, 0.8, 0], [0, 0, 0.8]]}]})


@pytest.mark.parametrize("material, expected", [
    ({"colour": [1.0, 1.0, 1.0]}, 1.0), ({"colour": [0.5, 0.5, 0.5]}, 0.5), ({"type": "conductor"}, 1.0),
    ({"type": "dielectric"}, 1.0), ({"type": "dielectric", "int_ior": 2.4}, 1.0)])
def test_environment_furnace(material, expected):
    """A convex object sees only the environment: in a constant radiance L it leaves rho L (a diffuse albedo
    rho, one bounce) and L through or off lossless glass and a perfect mirror: a white sphere vanishes. The
    environment is reached both by its own cosine-distributed samples and by the BSDF's rays that escape,
    weighted by MIS: a weight of 1 for either fails it (seen). The middle 24 x 24 pixels lie on the sphere;
    the background is L exactly."""
    image, stats = raytrace.render(environment_scene(material, 2.0), spp=64, light_samples=1)
    assert "-DHAS_ENVIRONMENT=1" in stats.build_options and stats.extra["nonfinite_values"] == 0
    assert np.all(np.asarray(image)[:3, :3] == 2.0)
    assert_mean(np.asarray(image)[20:44, 20:44], 2.0 * expected)


def test_environment_techniques_agree(harness, cornell):
    """The environment seen through the open front of scene 0's room: sampling lights and environment alone,
    the BSDF alone, and MIS agree at a floor point near the opening, one deep in the room, and one on a
    rough gold wall, within 5 standard errors of each difference."""
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    text = text.replace('shading = "direct"', 'shading = "path"').replace(
        "red = { colour = [0.8, 0.0, 0.0] }", 'red = { type = "roughconductor", alpha = 0.4, colour = [1.0, 1.0, '
        "1.0], eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603] }")
    text += '\n[environment]\ntype = "constant"\nradiance = [0.5, 0.8, 1.2]\n'
    scene = raytrace.load_string(text)
    p = np.array([[0.2, -0.9, 0.0], [-0.4, 0.6, 0.0], [-0.999, -0.5, 0.8]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [1.0, 0, 0]])
    est = {k: traced(harness, scene, p, n, k, shaded=True) for k in (0, 1, 2)}
    mean, _ = assert_techniques_agree(est)
    assert np.all(mean[0] > 0)


def test_environment_keys_are_checked():
    base = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "materials": {"m": {"colour": [0.5] * 3}},
            "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                        "radiance": 1.0}]}
    cases = [({"shading": "direct"}, {"type": "constant", "radiance": 1.0}, "environment = {'type': 'constant'"),
             ({"shading": "path"}, {"type": "sky", "radiance": 1.0}, "environment.type = 'sky': must be one of"),
             ({"shading": "path"}, {"type": "constant", "radiance": -1.0}, "environment.radiance = -1.0"),
             ({"shading": "path"}, {"type": "constant"}, "environment.radiance"),
             ({"shading": "path"}, {"type": "constant", "radiance": 1.0, "scale": 2}, "environment.scale")]
    for render, environment, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict({**base, "render": render, "environment": environment})
    scene = raytrace.load_dict({**base, "render": {"shading": "path"},
                                "environment": {"type": "constant", "radiance": [0.1, 0.2, 0.3]}})
    assert scene.environment.tolist() == [0.1, 0.2, 0.3]


@pytest.mark.parametrize("bsdf", ["roughconductor", "conductor", "dielectric"])
def test_normal_and_bump_maps_with_every_bsdf(cornell, tmp_path, bsdf):
    """textured_cornell.toml in the path model with its normal-mapped and bump-mapped walls turned to each of
    the new BSDFs: the maps' shading normals feed the BSDF's frame, so the walls differ from the same walls
    without the maps, rendered with the same samples (by more than 1% in more than a tenth of their pixels),
    and the image stays finite."""
    text = open(cornell.path.replace("cornell.toml", "textured_cornell.toml")).read()
    light = "tangent = [1.0, 0.0, 0.0]\ncolour = [1.0, 1.0, 1.0]"
    text = text.replace("../assets/", str(ROOT / "assets") + "/")
    for old, new in (("ambient =", "# ambient ="),
                     ("[render]", '[render]\nshading = "path"'),
                     (light, "tangent = [1.0, 0.0, 0.0]\nradiance = 40.0"),
                     ("[materials.red_bricks]", f'[materials.red_bricks]\ntype = "{bsdf}"'),
                     ("[materials.green_bricks]", f'[materials.green_bricks]\ntype = "{bsdf}"')):
        assert old in text, old
        text = text.replace(old, new, 1)
    mapped, flat = tmp_path / "mapped.toml", tmp_path / "flat.toml"
    mapped.write_text(text)
    flat.write_text("\n".join(line for line in text.splitlines()
                               if not line.startswith(("normal_map =", "height_map =", "height_scale ="))))
    options = dict(width=48, height=48, spp=16, light_samples=1, light_sampler="sobol")
    a, stats = raytrace.render(raytrace.load_file(mapped), **options)
    b, _ = raytrace.render(raytrace.load_file(flat), **options)
    assert stats.extra["nonfinite_values"] == 0 and "-DHAS_NORMAL_MAPS=1" in stats.build_options
    side = list(range(0, 8)) + list(range(40, 48))  # the red and green walls' columns
    a, b = np.asarray(a)[:, side].max(axis=-1), np.asarray(b)[:, side].max(axis=-1)
    assert np.mean(np.abs(a - b) > 0.01 * (a + b)) > 0.1  # the same samples: without a map's effect, equal
