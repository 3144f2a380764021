"""raytrace's AOVs against Mitsuba 3.9.1's `aov` integrator (src/integrators/aov.cpp, the spec) on
scenes/mitsuba/aov.xml: a checkerboard diffuse floor, a backdrop, a plastic sphere, a smooth-shaded low-poly
roughconductor sphere (obj) and a checkerboard diffuse sphere, near_clip 0.5, a box rfilter, 64 x 48, the
AOVs albedo, depth, position, sh_normal, geo_normal, uv and shape_index. The reference,
scenes/mitsuba/references/channels/aov.npz (+ .json), is Mitsuba's mean of 16 renders of 16 samples (scalar_rgb,
seeds 0 to 15) made by devtools/peers/aov_reference.py; raytrace renders the file at the same 256 samples per
pixel (seed 0) and devtools/peers/aov_check.py compares them (`python -m devtools.peers.aov_check
scenes/mitsuba/aov.xml --out DIR` writes one PNG per AOV: raytrace | Mitsuba | |diff| / tolerance).

Where: the interior, the 2257 pixels (of 3072) whose 3 x 3 neighbourhood has one integral shape_index on both
sides: every sample of those 9 pixels met the same shape, so each value is a mean over one smooth surface.

The tolerance per value. With a box rfilter both renderers' pixel values are plain means of N = 256 samples
of the quantity at independent uniform points of the pixel (the independent sampler on both sides), so the
difference of two correct values has mean 0, and its terms are bounded: each sample lies within the
quantity's range R over the pixel. Hoeffding's inequality for the 2N independent terms (each of range R / N)
gives P(|diff| >= t) <= 2 exp(-N t^2 / R^2) whatever the quantity's distribution over the pixel; for a
false-failure rate ALPHA = 1e-4 over all M compared values (Bonferroni; M = 2257 pixels x 16 channels =
36112), t = R sqrt(ln(2 M / ALPHA) / N) = 0.28 R. R is taken as the range of the 3 x 3 neighbourhood's means
(both renderers'): for a quantity linear over the neighbourhood that is twice the pixel's own range, for a
smooth one with an extremum in the pixel (a sphere's normal facing the camera) four times its range; a
checkerboard's edge through the pixel has whole checks on either side (the floor's checks are 5 pixels and
more, the sphere's 4 and more), whose pure values bound it. Added, float32 rounding: each side's mean sums
N float32 values (Higham's bound, (N - 1) u of the largest, u = 2^-24) of values each computed within about
64 u of the AOV's largest magnitude m (a point or normal through two float32 transforms, an intersection):
2 (N + 64) u m, 3.8e-5 m. On shape_index (R = 0 on the interior) that leaves an exact comparison of the
mapped numbers, and on the plastic's and the backdrop's constant albedo and the planes' normals one to 4e-5.

shape_index is compared through the map between the numberings (raytrace's SHAPE_ORDER, Mitsuba's scalar
scene->shapes() order; its JIT variants write registry ids): over the interior each of raytrace's numbers
meets exactly one of Mitsuba's and the other way round; then the mapped image is compared as above.

albedo: both renderers define it alike on every BSDF here (kernels/aovs.cl): diffuse's reflectance (the
checkerboards), plastic's diffuse_reflectance, and roughconductor's pi f(wi, n) (Mitsuba's default
eval_diffuse_reflectance, eval towards the shading normal times pi). kernels/aovs.cl differs deliberately
where the scene does not go: a one-sided material seen from behind (0; Mitsuba's diffuse gives its
reflectance), a mask (the masked material times its opacity; Mitsuba's ignores it), a rough dielectric seen
from inside, and an emitter hidden by hide_emitters (raytrace's first hit is the surface beyond it).

depth: the scene's near plane (0.5) cuts nothing, so raytrace's loader drops it (raytrace/scene/mitsuba.py's
without_idle_clip_planes, so that a scene renders bit for bit as its TOML) and the rays start at the eye; the
depth AOV still runs from the plane, as Mitsuba's si.t does (perspective.cpp starts the ray at near_clip / d.z),
through the camera's dropped_near_clip (kernels/aovs.cl). Found by this test: without it raytrace's depth
exceeded Mitsuba's by near_clip / cos(the ray's angle to the view), 0.5 to 0.57 here, 3.5 times its tolerance
(0.01 on any file that keeps Mitsuba's default near_clip).

Measured (seed 0): worst |diff| per AOV, and its share of its tolerance: albedo 0.049 (0.36, a check edge on
the floor), position 0.017 (0.18), sh_normal 0.011 (0.15), geo_normal 0.033 (0.31, a facet edge of the
low-poly sphere), uv 0.0029 (0.18), shape_index 0 (exact), depth 0.018 (from the dropped near plane).

Mutations, each applied to raytrace's AOVs before judging (test_mutation_fails runs them; each fails):
normals negated (sh_normal, geo_normal: the shape's side not kept); sh_normal in geo_normal's place (the
low-poly sphere's facets); uv swapped; depth 1% long; position's y and z swapped; albedo 2% dark (the
constant plastic and backdrop catch it); two shapes given one number (the map breaks); depth 0.01 long (the
default near_clip: 76 of the 2257 values fail, the
backdrop's and the spheres' fronts, where depth spreads least over a pixel; the depth tolerance runs from
0.017 to 0.22). Not caught, by design: two shapes' numbers exchanged (labels)."""
import numpy as np
import pytest
from helpers import ROOT

from devtools.peers import aov_check

SCENE = ROOT / "scenes" / "mitsuba" / "aov.xml"


@pytest.fixture(scope="module")
def rendered():
    """raytrace's AOVs of the scene at the reference's samples per pixel, seed 0, and the reference."""
    reference = aov_check.load_reference(aov_check.reference_path(SCENE))
    return aov_check.render_ours(SCENE, reference["spp"], seed=0), reference


def _names():
    reference = aov_check.load_reference(aov_check.reference_path(SCENE))
    return [n for n, _ in reference["aovs"]]


def test_shape_map_is_one_to_one(rendered):
    """Over the interior each of raytrace's shape numbers meets one of Mitsuba's and each of Mitsuba's one of
    raytrace's; the scene's five visible shapes are all there."""
    result = aov_check.judge(SCENE, ours=rendered[0])
    assert result["shape_map"]["breaks"] == ([], []), result["shape_map"]
    assert len(result["shape_map"]["map"]) == 5, result["shape_map"]
    assert result["interior_pixels"] > 2000


@pytest.mark.parametrize("name", _names())
def test_aov_matches_mitsuba(rendered, name):
    """Every interior value of the AOV within its tolerance of Mitsuba's (the module's docstring)."""
    result = aov_check.judge(SCENE, ours=rendered[0])
    verdict = result[name]
    assert verdict["failing"] == 0, verdict


def _negate(*names):
    return lambda a: {**a, **{n: -a[n] for n in names}}


MUTATIONS = {
    "normals negated": (_negate("nn", "gn"), ("nn", "gn")),
    "sh_normal as geo_normal": (lambda a: {**a, "gn": a["nn"]}, ("gn",)),
    "uv swapped": (lambda a: {**a, "uv": a["uv"][..., ::-1]}, ("uv",)),
    "depth 1% long": (lambda a: {**a, "dd": a["dd"] * 1.01}, ("dd",)),
    "depth 0.01 long": (lambda a: {**a, "dd": a["dd"] + 0.01}, ("dd",)),
    "position y and z swapped": (lambda a: {**a, "pos": a["pos"][..., [0, 2, 1]]}, ("pos",)),
    "albedo 2% dark": (lambda a: {**a, "albedo": a["albedo"] * 0.98}, ("albedo",)),
}


@pytest.mark.parametrize("mutation", [*MUTATIONS, "two shapes as one"])
def test_mutation_fails(rendered, mutation):
    """Each mutation of raytrace's AOVs (the module's docstring) fails the comparison of the AOVs it touches."""
    ours = rendered[0]
    if mutation == "two shapes as one":  # the largest two numbers merged: the map is no longer one-to-one
        si = ours["si"].copy()
        top = np.max(si)
        si[si == top] = top - 1
        result = aov_check.judge(SCENE, ours={**ours, "si": si})
        assert result["shape_map"]["breaks"] != ([], []), result["shape_map"]
        return
    mutate, names = MUTATIONS[mutation]
    result = aov_check.judge(SCENE, ours=mutate(ours))
    for name in names:
        assert result[name]["failing"] > 0, (mutation, result[name])
