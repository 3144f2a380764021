"""The path integrator (kernels/path_tracing.cl) against closed forms: a furnace whose walls all emit and
reflect, at several depths and unbounded (where Russian roulette must not bias the sum); direct light alone
(max_depth 2) against the direct model; the three estimators (the lights alone, the BSDF alone, MIS) agreeing,
the lights sampled by area and by solid angle; and the place in a vertex where Russian roulette plays.

Estimates are compared with their expected values, or with each other, within 5 standard errors
(tests/path_support.py argues the bound)."""
import dataclasses

import numpy as np
import pytest

import raytrace

from helpers import at_lane_ends, without_ambient
from path_support import assert_mean, assert_techniques_agree, furnace, traced


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


def test_a_phong_scene_in_the_path_model(cornell):
    """--shading path takes a Phong scene's light colours as radiances, as --shading direct does; the image
    is finite and brighter than direct light alone (light bounces)."""
    scene = without_ambient(cornell.path)
    path, stats = raytrace.render(scene, width=32, height=32, spp=4, light_samples=1, light_sampler="sobol",
                                  shading="path")
    direct, _ = raytrace.render(scene, width=32, height=32, spp=4, light_samples=1, light_sampler="sobol",
                                shading="direct")
    assert stats.extra["nonfinite_values"] == 0 and np.asarray(path).mean() > np.asarray(direct).mean()


LIGHT_POINTS = np.array([[-0.3, -0.5, 0.0], [0.45, 0.4, 0.0], [0.999, 0.2, 1.0], [-0.95, 0.95, 1.95],
                         [0.0, 0.05, 1.85], [0.32, 0.0, 1.9]])
LIGHT_NORMALS = np.array([[0, 0, 1.0], [0, 0, 1.0], [-1.0, 0, 0], [0.6, -0.6, -0.53], [0, 0, 1.0], [-0.6, 0, 1.0]])
LIGHT_NORMALS /= np.linalg.norm(LIGHT_NORMALS, axis=1, keepdims=True)


@at_lane_ends
def test_light_sampling_bsdf_sampling_and_mis_agree(harness, cornell):
    """Sampling the lights alone, the BSDF alone (path_support's own path tracers), and both combined by MIS
    (the renderer's) are three unbiased estimators of the same radiance: at points of scene 0's direct
    variant (a lit floor point, one in the ellipsoid's penumbra, one on the wall, one in the ceiling's corner
    that only indirect light reaches, and two 5 to 10 cm below the light, where both techniques carry
    weight) their means over 1024 lanes agree within 5 standard errors of each difference. Far from the
    small light its samples take nearly all the weight (MIS and the lights alone agree to 4 digits there);
    close to it both count. A BSDF hit counted with weight 1 beside the lights' MIS-weighted samples fails
    this at every point (seen). MIS is less noisy than either alone under the light (standard errors
    measured 0.078 against 0.175 and 0.108)."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    est = {k: traced(harness, scene, LIGHT_POINTS, LIGHT_NORMALS, k) for k in (0, 1, 2)}
    mean, se = assert_techniques_agree(est)
    assert np.all(mean[0] > 0) and se[0][4] < min(se[1][4], se[2][4])


def test_roulette_comes_after_the_light_samples(harness, cornell):
    """Russian roulette decides after a vertex's light samples and BSDF sample, before its ray is traced, as
    in Mitsuba 3 and pbrt-v4 (path_tracing.cl), from vertex render.rr_depth on. The renderer's path tracer
    stopped before the ray of the last vertex max_depth allows (path_support's `cut`: path_tracing.cl's own
    steps, that ray not traced) with max_depth = rr_depth + 1: the last vertex shaded is the first where
    roulette plays, and it can only cut the ray that is not traced, so every lane's estimate equals, to the
    bit, that of a scene whose roulette never plays (rr_depth 100; the numbers drawn are the same). One
    vertex deeper, roulette cuts paths before a vertex's light samples, and the two differ: the comparison
    sees roulette where it acts, at Mitsuba's default 5 and at 1 and 3 (a run-time value: RenderParams).
    Roulette played right after a vertex's hit, before its light samples (the placement before commit
    07d2363), fails the first part; so do roulette from vertex rr_depth + 1 (`>` for `>=`), from vertex
    rr_depth - 1, and the kernel's rr_depth fixed at 5 (each seen)."""
    scene = raytrace.load_file(cornell.path.replace("cornell.toml", "cornell_direct.toml"))
    for rr_depth in (5, 1, 3):
        for depth, same in ((rr_depth + 1, True), (rr_depth + 2, False)):
            at = dataclasses.replace(scene, max_depth=depth, rr_depth=rr_depth)
            with_roulette = traced(harness, at, LIGHT_POINTS, LIGHT_NORMALS, 0, lanes=64, cut=True)
            without = traced(harness, dataclasses.replace(at, rr_depth=100), LIGHT_POINTS, LIGHT_NORMALS, 0,
                             lanes=64, cut=True)
            assert np.array_equal(with_roulette, without) == same, (rr_depth, depth)
            assert np.all(np.isfinite(with_roulette)) and np.all(with_roulette >= 0)


@at_lane_ends
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
