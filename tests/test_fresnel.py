"""Fresnel reflectance (kernels/path_tracing.cl's fresnel_conductor and fresnel_dielectric) against complex
float64 (Born and Wolf), for conductors and dielectrics, from either side of the interface."""
import numpy as np

from path_support import SPECULAR, fresnel_reference


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


def test_conductor_fresnel_at_any_float32_index(harness):
    """A conductor's index may be any float32 (issue 55: eta = k = 1e15, or either at 1e20, gave NaN from
    eta^4, and 648 of 768 values zeroed). Beyond max(eta, k) = 2^31 the kernel scales cos, eta and k by a
    power of two, which rounds nothing, so the formula keeps its roundings: within 2e-5 of complex float64, as
    above, for cos_i in [2^-20, 1] and indices from 2^31 to float32's largest, alone or with the other part
    anywhere from 0 up (the reflectance tends to 1 as the index grows). Nearer grazing, where the p part dips
    at cos_i = 1 / |eta + i k| (the scaled formula's terms of degree 4 are taken over a2b2 s^2, normal down to
    cos_i = 2^-62), it stays finite and in [0, 1]."""
    rng = np.random.default_rng(55)
    n = 4096
    big = 2.0 ** rng.uniform(31, 127.99, n)
    other = np.where(rng.random(n) < 0.25, 0.0, 2.0 ** rng.uniform(-20, 127.99, n))
    swap = rng.random(n) < 0.5
    e, kk = np.where(swap, big, other), np.where(swap, other, big)
    e, kk = [np.asarray(x, np.float32).astype(np.float64) for x in (e, kk)]
    c = 2.0 ** rng.uniform(-20, 0, n)
    c = np.asarray(np.concatenate([c[:-2], [1.0, 2.0**-20]]), np.float32).astype(np.float64)
    out = harness.run(FRESNEL, "fresnel", n, [c, e, kk], {"conductor": 1, "dielectric": 1, "cos_t": 1}, **SPECULAR)
    np.testing.assert_allclose(out["conductor"], fresnel_reference(c, e, kk), atol=2e-5)
    grazing = np.asarray(2.0 ** rng.uniform(-149, -20, n), np.float32).astype(np.float64)
    out = harness.run(FRESNEL, "fresnel", n, [grazing, e, kk], {"conductor": 1, "dielectric": 1, "cos_t": 1},
                      **SPECULAR)
    assert np.all((out["conductor"] >= 0) & (out["conductor"] <= 1)), out["conductor"][~(out["conductor"] <= 1)]
