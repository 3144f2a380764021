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

from test_direct_lighting import without_ambient

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
/* Lane i's estimate of the radiance leaving p (normal nrm, albedo 1 there) towards a viewer above it: the mean of
 * trace_path over pixel samples 0 .. samples-1, as render.cl traces a camera ray's hit. */
__kernel void trace(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const uint2 *light_samples,
                    __global const float *p, __global const float *nrm, int samples, __global float *out)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec3 at = IN3(p), normal = IN3(nrm);
    Hit hit = no_hit();
    hit.t = (vfloat)(1.0f);
    hit.p = at;
    hit.n = normal;
    hit.material = (vint)(0);
    ShadingPoint sp = {at, (vfloat)(0.0f), normal, normal, v3_splat(1.0f, 1.0f, 1.0f), (vfloat)(1.0f)};
    Ray r = {v3_add(at, normal), v3_scale(normal, -1.0f)};
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


def traced(harness, scene, p, n, sampling, lanes=1024, samples=16):
    """(cases, lanes) estimates of the red channel leaving points p, light reaching them sampled as
    `sampling` says (path_tracing.cl's PATH_SAMPLING: 0 MIS, 1 the lights alone, 2 the BSDF alone)."""
    pattern = samplers.pattern("sobol", 1)
    features = dataclasses.replace(Features.of(scene, harness.lanes), direct_lighting=False, path_tracing=True)
    defines = dict(option[2:].split("=") for option in features.options() if not option.startswith("-DLANES"))
    args = {**scene_args(scene, light_samples=1, light_pattern=pattern, features=features),
            **texture_tables(scene), "light_samples": pattern.table(), "p": planar(np.repeat(p, lanes, axis=0)),
            "nrm": planar(np.repeat(n, lanes, axis=0)), "samples": np.int32(samples)}
    out = harness.run(TRACE, "trace", len(p) * lanes, args, {"out": 3}, **defines, PATH_SAMPLING=sampling)["out"]
    return out[0].reshape(len(p), lanes)


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
    p = np.array([[-0.3, -0.5, 0.0], [0.45, 0.4, 0.0], [0.999, 0.2, 1.0], [-0.95, 0.95, 1.95], [0.0, 0.05, 1.85],
                  [0.32, 0.0, 1.9]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [-1.0, 0, 0], [0.6, -0.6, -0.53], [0, 0, 1.0], [-0.6, 0, 1.0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    est = {k: traced(harness, scene, p, n, k) for k in (0, 1, 2)}
    mean = {k: e.mean(axis=1) for k, e in est.items()}
    se = {k: e.std(axis=1, ddof=1) / np.sqrt(e.shape[1]) for k, e in est.items()}
    for a, b in ((0, 1), (0, 2), (1, 2)):
        bound = 5 * np.hypot(se[a], se[b]) + 1e-5 * np.abs(mean[a])
        assert np.all(np.abs(mean[a] - mean[b]) <= bound), (a, b, mean, se)
    assert np.all(mean[0] > 0) and se[0][4] < min(se[1][4], se[2][4])
