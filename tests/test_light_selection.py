"""Choosing the emitter of each light sample (render.light_selection; kernels/light_selection.cl,
raytrace/renderer/packing.py's selection): the probabilities against the emitters' power, the kernel's choices
against those probabilities by chi-square, and the light of many emitters on a floor against its closed form.

Probabilities: by power, each emitter's pi A Y(L) (its area times pi times its radiance's luminance, pbrt-v4's
PowerLightSampler) over their sum; uniform 1 / n; uniform too where no emitter has power. The kernel chooses by
the float32 cumulative values, each within 2^-24 of the float64 one (rounded once, below 1), and the stored
probability is the width they give the emitter (rounded once more to float32): within 2^-23 + 2^-24 p of the
float64 probability, the tolerance here.

Choices, at every lane width: N draws of u through choose_emitters; the counts of each emitter, and of each
emitter with its rescaled u.x in one of BINS equal bins (uniform within its share: the rescaled number must stay
a uniform number for the emitter's own sampling), by Pearson's chi-square against N p_e and N p_e / BINS (every
cell expects >= 250). Each test fails by chance with SIGNIFICANCE (1e-4): 2 tests per lane width, about 1e-3 per
run on a machine of 4 widths. u.y passes unchanged (exactly), and with one emitter u.x does too (bit for bit, so
that a scene of one emitting shape renders the same image whatever the selection).

Light, judged per pixel by devtools/judge.py's Z-test (CHUNKS renders; each scale at ALPHA = 1e-4: about 4e-4
per image): a diffuse floor under three sphere lights of
different sizes and radiances, each wholly above the floor's horizon, whose irradiance is the sum of pi L (r /
d)^2 cos(beta) (Lambert), radiance rho E / pi averaged over each pixel's footprint (a 6 x 6 grid), in the
direct model (light samples alone: a choice's probability left out of the density shows as a ratio per
emitter), the direct model with 2 BSDF samples, and the path model at max_depth 2 (the last two weigh light
and BSDF samples by MIS, whose density for a hit emitter must include its choice's probability,
light_selection.cl's hit_emitter_pdf), by power and uniformly: 12 images, 5e-3 per run.

Mutations tried (each in a copy of the kernels or host; every one failed the tests named, then was undone):
- light_selection.cl choose_emitters: u.x not rescaled within the chosen share: the rescaled-u chi-square;
- light_selection.cl choose_emitters: the search's comparison `>` made `>=`: exact for no draw; not caught by the
  chi-square (u.x equal to a cumulative value has probability 2^-24), recorded here as the one survivor;
- light_selection.cl sample_chosen: the density not multiplied by the choice's probability: the direct and
  path floors;
- light_selection.cl hit_emitter_pdf: the choice's probability left out of the hit's density: the path and
  direct+bsdf floors (the MIS weights then do not sum to 1);
- packing.py selection: the power without the radiance's luminance (area alone): the probabilities test.
"""
import math

import numpy as np
import pytest
from scipy import stats

import raytrace
from devtools.chi_square import SIGNIFICANCE
from devtools.judge import judge
from helpers import at_lane_ends
from reference import floor_footprint, pixel_means
from render_judging import CHUNKS, assert_judged, chunked
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

KERNEL = """
#include "light_selection.cl"
__kernel void choose(int n, SCENE_PARAMETERS, __global const float *u, __global float *chosen, __global float *v)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vfloat ux = IN(u), uy = IN(u + n);
    vint c = choose_emitters(&s, &ux, (vfloat)(0.0f) == 0.0f);
    OUT(chosen, CONVERT_VFLOAT(c));
    OUT(v, ux);
    OUT(v + n, uy);
}
"""
N = 40000
BINS = 8
ALPHA = 1e-4
RHO = np.array([0.8, 0.6, 0.4])
# three sphere lights over the floor z = 0: centre, radius, radiance
SPHERES = [(np.array([0.7, 0.5, 1.0]), 0.3, np.array([3.0, 2.0, 1.0])),
           (np.array([-0.8, 0.6, 0.9]), 0.12, np.array([8.0, 9.0, 12.0])),
           (np.array([0.0, -0.9, 1.1]), 0.2, np.array([0.5, 0.4, 0.6]))]


def sphere(centre, radius, radiance):
    return {"type": "ellipsoid", "center": centre.tolist(), "axes": (np.eye(3) * radius).tolist(),
            "radiance": radiance.tolist()}


def floor_scene(shading, selection, max_depth=2, spheres=SPHERES):
    """A 20 x 20 diffuse floor at z = 0 under the sphere lights, seen from below them (the camera sees the floor
    alone: no silhouette, whose pixels' coverage a Z-test cannot judge)."""
    render = {"shading": shading, "light_selection": selection, **({"max_depth": max_depth} if shading == "path"
                                                                    else {})}
    if shading == "direct+bsdf":  # the direct model with BSDF samples too, weighed against the lights' by MIS
        render.update(shading="direct", bsdf_samples=2)
    return {"camera": {"position": [0.0, -0.3, 0.7], "look_at": [0.0, 0.1, 0.0], "up": [0.0, 0.0, 1.0], "fov": 60.0},
            "image": {"width": 24, "height": 24}, "render": render,
            "materials": {"floor": {"colour": RHO.tolist()}},
            "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [20.0, 20.0],
                        "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0], "material": "floor"},
                       *(sphere(*s) for s in spheres)]}


def expected_probabilities(spheres, selection):
    luminance = np.array([0.212671, 0.715160, 0.072169])  # linear sRGB's Y row (Mitsuba's luminance)
    power = np.array([math.pi * 4 * math.pi * r * r * radiance @ luminance for _, r, radiance in spheres])
    return power / power.sum() if selection == "power" and power.sum() > 0 else np.full(len(spheres), 1 / len(spheres))


@pytest.mark.parametrize("selection", ["power", "uniform"])
def test_probabilities_follow_power(selection):
    """The Emitter table's selection_pdf is pi A Y(L) over the sum (power) or 1 / n (uniform), and exactly the
    width its float32 cumulative selection_cdf gives it (ending at 1 exactly); a scene whose emitters have no
    power chooses uniformly."""
    for spheres in (SPHERES, [(c, r, 0 * radiance) for c, r, radiance in SPHERES]):
        scene = raytrace.load_dict(floor_scene("direct", selection, spheres=spheres))
        emitters = scene_tables(scene)["emitters"]
        expected = expected_probabilities(spheres, selection)
        np.testing.assert_allclose(emitters["selection_pdf"], expected, rtol=2**-24, atol=2**-23)
        np.testing.assert_allclose(emitters["selection_cdf"], np.cumsum(expected), rtol=0, atol=2**-24)
        widths = np.diff(emitters["selection_cdf"].astype(np.float64), prepend=0.0)
        np.testing.assert_allclose(emitters["selection_pdf"], widths, rtol=2**-24, atol=0)
        assert emitters["selection_cdf"][-1] == 1.0


def choose(harness, table, seed):
    scene = raytrace.load_dict(table)
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    u = np.random.default_rng(seed).random((2, N)).astype(np.float32)
    args = {**scene_tables(scene, 8, 8, 1, 1, "bilinear", features=features), "u": u}
    out = harness.run(KERNEL, "choose", N, args, {"chosen": 1, "v": 2}, **defines)
    return out["chosen"].astype(int), out["v"], u.astype(np.float64)


def test_emitters_are_chosen_by_their_probabilities(harness):
    """Each emitter is chosen in proportion to its probability, and its rescaled u.x is uniform within its
    share (chi-square over emitters x BINS); u.y passes unchanged."""
    chosen, v, u = choose(harness, floor_scene("direct", "power"), seed=1)
    p = expected_probabilities(SPHERES, "power")
    observed = np.bincount(chosen, minlength=len(p))
    statistic = float(np.sum((observed - N * p) ** 2 / (N * p)))
    pvalue = stats.chi2.sf(statistic, len(p) - 1)
    print(f"choices: {observed} for {N * p}, chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    assert np.all((v[0] >= 0) & (v[0] < 1))
    cells = np.bincount(chosen * BINS + np.minimum((v[0] * BINS).astype(int), BINS - 1), minlength=len(p) * BINS)
    expected = np.repeat(N * p / BINS, BINS)
    assert expected.min() > 250
    statistic = float(np.sum((cells - expected) ** 2 / expected))
    pvalue = stats.chi2.sf(statistic, len(expected) - 1)
    print(f"rescaled u: chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    assert np.array_equal(v[1], u[1])


def test_one_emitter_takes_u_as_it_is(harness):
    """With one emitting shape every lane chooses it and its u is the sample's, bit for bit."""
    chosen, v, u = choose(harness, floor_scene("direct", "power", spheres=SPHERES[:1]), seed=2)
    assert np.all(chosen == 0)
    assert np.array_equal(v, u)


def floor_radiance(table):
    """rho E / pi over each pixel's footprint by a 6 x 6 grid, E the sum over the spheres of pi L (r / d)^2
    cos(beta) (each wholly above the floor's horizon, no camera ray meets one, and no sphere hides part of
    another from the floor: their cones of directions are apart)."""
    scene = raytrace.load_dict(table)
    o, d, t, p = floor_footprint(scene)
    value = np.zeros_like(p)
    for i, (a, ra, _) in enumerate(SPHERES):
        for b, rb, _ in SPHERES[i + 1:]:
            da, db = np.linalg.norm(a - p, axis=1), np.linalg.norm(b - p, axis=1)
            apart = np.arccos(np.sum((a - p) * (b - p), 1) / (da * db))
            assert np.all(apart > np.arcsin(ra / da) + np.arcsin(rb / db))
    for centre, radius, radiance in SPHERES:
        assert centre[2] > radius
        to_centre = centre - p
        d2 = np.sum(to_centre ** 2, 1)
        oc = o - centre
        h = np.sum(oc * d, 1)  # (d is unit) the rays' roots -h +- sqrt(disc), none within (0, t)
        disc = np.maximum(h * h - (np.sum(oc * oc, 1) - radius ** 2), 0)
        assert not np.any((disc > 0) & (-h + np.sqrt(disc) > 0) & (-h - np.sqrt(disc) < t))
        value += RHO * radiance * (radius ** 2 * to_centre[:, 2] / d2 ** 1.5)[:, None]
    return pixel_means(scene, value)


@at_lane_ends
@pytest.mark.parametrize("shading", ["direct", "direct+bsdf", "path"])
@pytest.mark.parametrize("selection", ["power", "uniform"])
def test_many_sphere_lights_on_a_floor(lanes, shading, selection):
    """The floor under three sphere lights, one light sample per vertex shared among them, against the sum of
    their closed forms, per pixel."""
    table = floor_scene(shading, selection)
    mean, variance = chunked(table, lanes, spp=64)
    verdict = judge(mean, variance, floor_radiance(table), np.zeros_like(variance), alpha=ALPHA, dof=CHUNKS - 1,
                    tile_alpha=ALPHA)
    assert_judged(verdict, f"{selection} {shading} at {lanes} lanes")
