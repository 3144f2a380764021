"""Pearson's chi-square goodness-of-fit test of sampled directions against a density on the sphere, as Mitsuba
3's `chi2` tests and pbrt-v4's bsdfs_test.cpp run them: the directions are histogrammed over cells of
(cos(theta), phi), equal in solid angle; each cell's expected count is the density integrated over the
cell by Gauss-Legendre quadrature in float64; cells expecting fewer than MIN_EXPECTED samples are pooled
into one, so the statistic's chi-square distribution holds; the p-value is scipy's.

For independent samples drawn exactly from the density, the p-value is uniform on [0, 1]: a test that fails
below a significance level fails by chance with exactly that probability. The tests use SIGNIFICANCE per
case, with the cases they run stated beside it."""
import numpy as np
from scipy import stats

MIN_EXPECTED = 5.0
SIGNIFICANCE = 1e-4
QUADRATURE = np.polynomial.legendre.leggauss(8)
SUBCELLS = 6  # per side of a cell: Gauss-Legendre on each, so that a jump of the density (GGX's D at the
              # horizon of h) costs little accuracy: the total of a density integrates to 1 within 1e-3


def cell_integrals(density, cos_edges, phi_edges):
    """The integral of density(cos_theta, phi) (vectorised, per steradian) over each cell [c0, c1] x [p0,
    p1] (d(omega) = d(cos_theta) d(phi)), by Gauss-Legendre quadrature on SUBCELLS x SUBCELLS parts of it."""
    x, w = QUADRATURE
    k = SUBCELLS
    fine_cos = np.linspace(cos_edges[0], cos_edges[-1], (len(cos_edges) - 1) * k + 1)
    fine_phi = np.linspace(phi_edges[0], phi_edges[-1], (len(phi_edges) - 1) * k + 1)
    c = (0.5 * np.diff(fine_cos)[:, None] * x + 0.5 * (fine_cos[1:] + fine_cos[:-1])[:, None]).ravel()
    p = (0.5 * np.diff(fine_phi)[:, None] * x + 0.5 * (fine_phi[1:] + fine_phi[:-1])[:, None]).ravel()
    cc, pp = np.meshgrid(c, p, indexing="ij")
    weights = np.outer(np.tile(w, len(fine_cos) - 1) * np.repeat(0.5 * np.diff(fine_cos), len(x)),
                       np.tile(w, len(fine_phi) - 1) * np.repeat(0.5 * np.diff(fine_phi), len(x)))
    values = density(cc, pp) * weights
    n = len(x) * k
    return values.reshape(len(cos_edges) - 1, n, len(phi_edges) - 1, n).sum(axis=(1, 3))


def chi_square(directions, density, cos_cells=16, phi_cells=32):
    """(p-value, statistic, expected total) of unit `directions` (n x 3, in the density's frame: z up)
    against `density` over the whole sphere; the expected total is the density's integral (1 for a
    density of directions; less where the sampler may also return nothing)."""
    cos_edges = np.linspace(-1.0, 1.0, cos_cells + 1)
    phi_edges = np.linspace(0.0, 2 * np.pi, phi_cells + 1)
    phi = np.mod(np.arctan2(directions[:, 1], directions[:, 0]), 2 * np.pi)
    observed, _, _ = np.histogram2d(np.clip(directions[:, 2], -1, 1), phi, bins=[cos_edges, phi_edges])
    integrals = cell_integrals(density, cos_edges, phi_edges)
    expected = integrals * len(directions)
    small = expected < MIN_EXPECTED
    obs = np.append(observed[~small], observed[small].sum())
    exp = np.append(expected[~small], expected[small].sum())
    keep = exp > 0
    statistic = float(np.sum((obs[keep] - exp[keep]) ** 2 / exp[keep]))
    if np.any(obs[~keep] > 0):  # samples where the density says none can be
        return 0.0, np.inf, float(integrals.sum())
    dof = int(keep.sum()) - 1
    return float(stats.chi2.sf(statistic, dof)), statistic, float(integrals.sum())
