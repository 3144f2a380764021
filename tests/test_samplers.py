"""Host-built sample tables, checked against scipy.stats.qmc where it has the same construction."""
import numpy as np
import pytest
from scipy.stats import qmc

from raytrace import samplers


def test_grid_is_cell_centres():
    g = samplers.grid(16)
    assert g.shape == (16, 2)
    np.testing.assert_allclose(np.unique(g[:, 0]), [0.125, 0.375, 0.625, 0.875])
    assert len({tuple(p) for p in g}) == 16
    with pytest.raises(ValueError):
        samplers.pixel_samples("nope", 4)


def test_radical_inverse_matches_scipy_halton():
    i = np.arange(257)
    halton = qmc.Halton(d=2, scramble=False).random(257)
    np.testing.assert_allclose(samplers.radical_inverse(i, 2), halton[:, 0], atol=1e-15)
    np.testing.assert_allclose(samplers.radical_inverse(i, 3), halton[:, 1], atol=1e-15)


def test_light_samples_square_and_not():
    np.testing.assert_array_equal(samplers.light_samples(9), samplers.grid(9))
    h = samplers.light_samples(10)
    assert h.shape == (10, 2) and np.all((h >= 0) & (h < 1))
    # a low-discrepancy set: far below random points of the same size
    assert qmc.discrepancy(samplers.hammersley(64)) < 0.5 * qmc.discrepancy(np.random.default_rng(0).random((64, 2)))
