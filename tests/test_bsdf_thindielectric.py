"""The thin dielectric BSDF (kernels/bsdfs/thindielectric.cl behind kernels/bsdf.cl), a pane whose two
interfaces coincide, against Mitsuba 3's `thindielectric` as tests/bsdf_reference.py reproduces it in float64:
its two delta lobes (reflection with the slab's R' = 2 R / (1 + R), straight transmission with 1 - R'), their
choice frequencies, their symmetry, and a furnace through which a pane is invisible. It has no lobe that a
density describes: bsdf_eval and bsdf_pdf are 0 everywhere, and its samples' weights are the colour."""
import math

import bsdf_reference as ref
import bsdf_support
from bsdf_support import facing, unit
import numpy as np
import pytest
from path_support import FACES, assert_mean
from scipy import stats

import raytrace
from devtools.chi_square import SIGNIFICANCE

BUILD = {"HAS_PATH_TRACING": 1, "HAS_THIN_DIELECTRICS": 1, "HAS_RECTANGLES": 1}
OUTPUTS = ("f", "pdf", "delta_bsdf", "s_wi", "s_weight", "s_pdf", "s_delta", "s_transmit")

COLOUR = (0.9, 0.5, 0.2)
# Relative indices: glass, its inverse (a pane less dense than its surroundings: R' = 1 past the critical
# angle, 42 degrees), an index near 1 (R' small everywhere), a very dense one.
ETAS = (1.5046 / 1.000277, 1.000277 / 1.5046, 1.01, 3.0)


def run(harness, eta, wo, normal, u, wi=None, colour=COLOUR):
    """bsdf_eval_pdf at (wo, wi), bsdf_is_delta, and bsdf_sample at (wo, u1) of a thin dielectric of colour k and
    index eta about the per-lane normal (u2 = 0.5: its lobes are chosen by u1 alone)."""
    table = bsdf_support.material_table(bsdf="thindielectric", colour=colour, eta=(eta, 0.0, 0.0))
    u = np.column_stack([u, np.full((len(wo), 2), 0.5)])
    return bsdf_support.run(harness, table, normal, wo, wi, u, OUTPUTS, **BUILD)


def reference(eta):
    return ref.ThinDielectric(int_ior=eta, ext_ior=1.0, specular_reflectance=list(COLOUR),
                              specular_transmittance=list(COLOUR))


@pytest.mark.parametrize("eta", ETAS)
def test_lobes_against_the_reference(harness, eta):
    """(1) At 4000 random (wo, normal), wo on either side of the normal (Mitsuba's slab sees |cos theta_o|;
    the shading normal may lean past the viewer), u1 uniform: bsdf_sample matches Mitsuba's sample with the
    same u1, the lobe (transmit where the light passes), the direction (the mirror about the normal, or -wo
    exactly: no refraction, no shift), its probability R' or 1 - R', and the weight, the colour k either way
    (f cos / p with f cos the lobe's coefficient R' k or (1 - R') k: no 1 / eta^2, the pane's two crossings
    cancel it). Every sample is delta, bsdf_is_delta holds for it, and bsdf_eval and bsdf_pdf are 0 at random
    (wo, wi).

    Tolerances: directions 1e-5 (a reflection is two roundings of 2 (wo . n) n - wo; -wo is exact, checked
    so); weights exact (the colour itself); probabilities 1e-6 plus what an error of 3e-7 in |cos theta_o|
    moves R' by in float64 (the kernel's cosine is a float32 dot product of float32-rounded vectors, off by
    a few units of 6e-8: its effect is bounded by R''s change over that interval, which near the critical
    angle of eta < 1, where F rises as a square root, reaches 3e-6; elsewhere R' in float32, a dozen
    roundings of values below 2, is within 1e-6). Lanes whose u1 lies within 1e-5 plus that share of R' are
    left out (none at these seeds). Measured, the same at every lane width: directions 2.2e-7; probabilities
    6.2e-6 at most (eta 2/3, near its critical angle), 1.1e-7 beyond the cosine's share. Mutations seen to fail it: R for R', the choice u1 < 1 - R', wi =
    wo for -wo, a weight divided by eta^2 on transmission."""
    m = 4000
    rng = np.random.default_rng(int(eta * 1000))
    normal, wo = unit(rng.normal(size=(m, 3))), unit(rng.normal(size=(m, 3)))
    u = rng.uniform(0, 1, m)
    out = run(harness, eta, wo, normal, u, wi=unit(rng.normal(size=(m, 3))))
    assert np.all(out["f"] == 0) and np.all(out["pdf"] == 0) and np.all(out["delta_bsdf"] == 1)
    assert np.all(out["s_delta"] == 1)

    cos_o = np.sum(wo * normal, axis=1)
    b = reference(eta)
    r = b.slab_reflectance(cos_o)
    critical = math.sqrt(1 - eta * eta) if eta < 1 else -1.0
    c = np.abs(cos_o)
    moved = np.maximum(np.abs(b.slab_reflectance(np.minimum(c + 3e-7, 1)) - r),
                       np.abs(b.slab_reflectance(np.maximum(c - 3e-7, 0)) - r))
    keep = np.abs(u - r) > 1e-5 + moved
    assert keep.sum() > 0.99 * m
    reflect = u <= r
    assert np.array_equal(out["s_transmit"][keep] == 0, reflect[keep])
    mirror = 2 * cos_o[:, None] * normal - wo
    np.testing.assert_allclose(out["s_wi"][keep & reflect], mirror[keep & reflect], atol=1e-5)
    through = keep & ~reflect
    assert np.array_equal(out["s_wi"][through], -wo.astype(np.float32).astype(np.float64)[through])
    error = np.abs(out["s_pdf"] - np.where(reflect, r, 1 - r))
    assert np.all(error[keep] <= 1e-6 + moved[keep]), np.max(error[keep] - moved[keep])
    assert np.array_equal(out["s_weight"], np.tile(np.float32(COLOUR).astype(np.float64), (m, 1)))
    if eta < 1:  # past the critical angle everything reflects
        beyond = np.abs(cos_o) < critical - 1e-3
        assert beyond.sum() > 100 and np.all(out["s_transmit"][beyond] == 0)
        assert np.all(out["s_pdf"][beyond] == 1)


@pytest.mark.parametrize("eta", ETAS[:2])
def test_choice_frequencies(harness, eta):
    """(2) The delta lobes' choice frequencies against their probabilities (Mitsuba's chi-square test has no
    density to bin for delta lobes: here the counts of each lobe): at 8 cosines of wo from 0.05 to 1, 2^13
    samples each with u1 uniform, the reflected counts against R'(cos) from the reference, a chi-square of 8
    degrees of freedom (2 cells per cosine, their counts summing to 2^13), significance 1e-4; 2 indices at
    every lane width, 8 tests: a correct sampler fails once in 1250 runs. Measured p-values 0.23 (eta 1.5, 8
    degrees of freedom) and 0.38 (eta 1 / 1.5: six of the cosines lie past the critical angle, where R' = 1
    and every sample must reflect, asserted exactly; the other two make 2 degrees of freedom). The bare R in
    place of R' (the first reflection alone) and the choice u1 < 1 - R' fail it (seen)."""
    per = 1 << 13
    cosines = np.linspace(0.05, 1.0, 8)
    wo = np.repeat(np.stack([np.sqrt(1 - cosines**2), 0 * cosines, cosines], axis=1), per, axis=0)
    normal = np.tile([0.0, 0.0, 1.0], (len(wo), 1))
    u = np.random.default_rng(3).uniform(0, 1, len(wo))
    out = run(harness, eta, wo, normal, u)
    reflected = (out["s_transmit"] == 0).reshape(8, per).sum(axis=1)
    r = reference(eta).slab_reflectance(cosines)
    statistic, dof = 0.0, 0
    for observed, p in zip(reflected, r):
        if p >= 1:
            assert observed == per
            continue
        expected = np.array([p, 1 - p]) * per
        statistic += np.sum((np.array([observed, per - observed]) - expected) ** 2 / expected)
        dof += 1
    assert stats.chi2.sf(statistic, dof) > SIGNIFICANCE, (statistic, dof, reflected, r * per)


def test_symmetric_from_either_side_and_both_ways(harness):
    """(4) The pane is symmetric: light from either side reflects R'(|cos|) (Mitsuba keeps eta, never 1 /
    eta, for both sides: the slab's faces are one of each kind, whichever side it is seen from), and the
    coefficients are reciprocal, R' at wo equal to R' at its mirror image wi, and the transmission from wo
    through to -wo equal to the one from -wo back to wo (seen from the other side: normal -n), bit for bit at
    4096 random directions of eta 1.5 (the same float32 operations on the same |cos|)."""
    m = 4096
    rng = np.random.default_rng(9)
    normal, wo = facing(rng, m)
    u = np.full(m, 0.999999)  # transmit where R' < 0.999999: s_pdf is then 1 - R'
    eta = ETAS[0]
    front = run(harness, eta, wo, normal, u)
    back = run(harness, eta, -wo, -normal, u)
    np.testing.assert_array_equal(front["s_pdf"], back["s_pdf"])
    mirrored = run(harness, eta, front["s_wi"], normal, np.zeros(m))  # u1 = 0: reflect, s_pdf = R'
    direct = run(harness, eta, wo, normal, np.zeros(m))
    np.testing.assert_allclose(mirrored["s_pdf"], direct["s_pdf"], rtol=0, atol=1e-6)


def test_furnace_with_a_pane_and_a_thin_shell():
    """(5) A thin dielectric is lossless: f cos / p is its colour, 1 here, on every sample (test (1)), and
    in the furnace's uniform radiance L_e / (1 - rho) a camera sees that radiance through and off a white
    pane and a thin shell too (2.0 at rho = 0.5, 5 standard errors, path_support.assert_mean): the light
    reaching a wall through the pane comes by the BSDF's rays alone, which leave on the far side of the
    geometric normal (transmit), with MIS weight 1 after the delta vertex. A weight 1 / eta^2 on the
    transmission (a refraction's) darkens it, as does a next ray started on the near side (it hits the
    pane again: a transmit flag of 0), seen. Measured: 1.9992 +- 0.0020 at 48 x 48 pixels and 32 samples."""
    table = {
        "camera": {"position": [0.0, -0.85, 0.0], "look_at": [0.0, 0.5, 0.0], "up": [0, 0, 1], "fov": 70.0},
        "image": {"width": 48, "height": 48},
        "render": {"shading": "path"},
        "materials": {"grey": {"colour": [0.5] * 3}, "pane": {"type": "thindielectric", "int_ior": 1.5}},
        "lights": [{"center": c, "size": [2.0, 2.0], "normal": [-x for x in c], "tangent": t, "radiance": 1.0,
                    "material": "grey"} for c, t in FACES],
        "shapes": [{"type": "rectangle", "material": "pane", "center": [0.0, -0.4, 0.0], "size": [1.2, 1.2],
                    "normal": [0.3, -0.9, 0.2], "tangent": [1.0, 0.0 + 1 / 3, 0.0]},
                   {"type": "ellipsoid", "material": "pane", "center": [0.2, 0.4, 0.1],
                    "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]}]}
    image, stats_ = raytrace.render(raytrace.load_dict(table), spp=32, light_samples=1)
    assert "-DHAS_THIN_DIELECTRICS=1" in stats_.build_options
    assert_mean(image, 2.0)
