"""The film's reconstruction filters (kernels/film_filter.cl, raytrace/renderer/film_filter.py): the offsets drawn
against the tables' density by a chi-square test, and the weighted samples against each filter's formula
(Mitsuba's, in float64), inside the crop window and at its edge.

Statistics: each chi-square test fails by chance with probability SIGNIFICANCE = 1e-4 (devtools/chi_square.py's),
and each weighted comparison is a z-test at |z| < Z = 5 (two-sided 5.7e-7 for a normal mean; the means are of
2^20 samples of bounded weights, so the central limit holds closely): 5 filters x (1 chi-square + 17 z-tests)
in the window, 5 x 2 at its edge and 3 x 2 with a sample border, at 4 lane widths: 20 chi-square tests and 404
z-tests, which fail by chance with probability below 2.3e-3 in all.

Mutations tried, each failing this file: the bin's root as a / p0 (a constant density inside each bin: the
chi-square); the weight without the density (f / integral: the weights' mean); the window's share read one node
off (the edge's mean); Mitchell's far piece with +12B for -12B (its weighted bins); the gaussian's bias
not passed to the kernel (its weighted bins); the border's whole integral ignored (the border's test)."""
import math

import numpy as np
import pytest
from scipy import stats

from devtools.chi_square import MIN_EXPECTED, SIGNIFICANCE
from raytrace.renderer.film_filter import formula, rfilter_tables
from raytrace.renderer.packing import camera_struct
from raytrace.scene.model import Camera

SOURCE = """
#include "film_filter.cl"
__kernel void offsets(int n, __constant const Camera *cam, __global const float *u, int pixel, int window,
                      __global float *offset, __global float *weight)
{
    vfloat w;
    OUT(offset, rfilter_offsets(cam, IN(u), (vint)(pixel), window, &w) - 0.5f);
    OUT(weight, w);
}
"""
FILTERS = [("tent", {"radius": 1.0}), ("tent", {"radius": 2.3}), ("gaussian", {"stddev": 0.5}),
           ("mitchell", {"B": 1 / 3, "C": 1 / 3}), ("lanczos", {"lobes": 3})]
N = 1 << 20
Z = 5.0


def run(harness, name, p, pixel, window, seed=1, border=False):
    camera = Camera(np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]), 45.0)
    cam = camera_struct(camera, 16, 16, rfilter=(name, p), border=border)
    u = np.random.default_rng(seed).random(N).astype(np.float32)
    out = harness.run(SOURCE, "offsets", N, [cam, u, np.int32(pixel), np.int32(window)], {"offset": 1, "weight": 1})
    return out["offset"], out["weight"]


def table_density_integrals(t, edges):
    """The tables' piecewise-linear density integrated over each cell of `edges` (each cell inside one bin)."""
    nodes = -t.reach + t.step * np.arange(t.bins + 1)
    mid = (edges[:-1] + edges[1:]) / 2
    return np.interp(mid, nodes, t.pdf) * np.diff(edges)  # linear in the cell: its midpoint value, exactly


@pytest.mark.parametrize("name, p", FILTERS, ids=[f"{n}{list(p.values())[0]:g}" for n, p in FILTERS])
def test_offsets_follow_the_tables_density(harness, name, p):
    """The offsets of uniform u against the piecewise-linear density through |f| (4 cells per bin)."""
    t = rfilter_tables(name, p)
    x, _ = run(harness, name, p, 1000, 4000)
    edges = -t.reach + t.step / 4 * np.arange(4 * t.bins + 1)
    observed, _ = np.histogram(x, edges)
    expected = table_density_integrals(t, edges) * N
    assert observed.sum() == N and expected.sum() == pytest.approx(N, rel=1e-6)
    small = expected < MIN_EXPECTED
    obs, exp = np.append(observed[~small], observed[small].sum()), np.append(expected[~small], expected[small].sum())
    assert not np.any((exp == 0) & (obs > 0))
    keep = exp > 0
    statistic = np.sum((obs[keep] - exp[keep]) ** 2 / exp[keep])
    p_value = stats.chi2.sf(statistic, keep.sum() - 1)
    assert p_value > SIGNIFICANCE, (p_value, statistic)


def z_scores(values, truth):
    """(mean - truth) / its standard error, per column of values (samples x cases). A weight is float32 work of
    about 10 roundings (the filter's value 3, the density 4, the quotient and products 3): within 1e-6 of
    its value relative, which bounds the mean's bias where the weights hardly vary (a tent of radius 1 is
    sampled exactly: every weight is 1 but for rounding), so that is added to the standard error."""
    error = values.std(axis=0, ddof=1) / math.sqrt(len(values)) + 1e-6 * np.abs(values).mean(axis=0)
    return (values.mean(axis=0) - truth) / np.maximum(error, 1e-12)


@pytest.mark.parametrize("name, p", FILTERS, ids=[f"{n}{list(p.values())[0]:g}" for n, p in FILTERS])
def test_weighted_samples_are_the_normalised_filter(harness, name, p):
    """Inside the window: the weights' mean is 1, and the weighted share of each of 16 cells of [-radius,
    radius] is the filter's integral over it over its whole (float64 quadrature of Mitsuba's formula): the
    estimator's expectation is the normalised convolution, whatever the table's density."""
    radius, f, _, _ = formula(name, p)
    x, w = run(harness, name, p, 1000, 4000, seed=2)
    edges = np.linspace(-radius, radius, 17)
    total = quad(f, -radius, radius)
    truth = np.array([quad(f, a, b) for a, b in zip(edges[:-1], edges[1:])]) / total
    cells = np.stack([w * ((x >= a) & (x < b)) for a, b in zip(edges[:-1], edges[1:])], axis=1)
    z = z_scores(np.concatenate([w[:, None], cells], axis=1), np.concatenate([[1.0], truth]))
    assert np.abs(z).max() < Z, z


@pytest.mark.parametrize("name, p", FILTERS, ids=[f"{n}{list(p.values())[0]:g}" for n, p in FILTERS])
def test_the_window_edge_takes_the_filter_inside(harness, name, p):
    """Pixel 0 of a window of 3 (its centre at 0.5): no weight outside [-0.5, 2.5), the weights' mean still 1
    (over the filter's integral inside), and the weighted share of [-0.5, 0] as the formula's."""
    radius, f, _, _ = formula(name, p)
    x, w = run(harness, name, p, 0, 3, seed=3)
    assert np.all(w[(x < -0.5) | (x >= 2.5)] == 0)
    inside = quad(f, -0.5, min(2.5, radius))
    z = z_scores(np.stack([w, w * (x < 0)], axis=1), [1.0, quad(f, -0.5, 0.0) / inside])
    assert np.abs(z).max() < Z, z


@pytest.mark.parametrize("name, p", FILTERS[2:], ids=[f"{n}{list(p.values())[0]:g}" for n, p in FILTERS[2:]])
def test_a_sample_border_takes_the_whole_filter(harness, name, p):
    """With rfilter_border (Mitsuba's sample_border), pixel 0 of a window of 3 weighs samples outside the window
    too: its weights' mean is 1 and the weighted share of [-radius, -0.5] is the formula's over its whole."""
    radius, f, _, _ = formula(name, p)
    x, w = run(harness, name, p, 0, 3, seed=4, border=True)
    z = z_scores(np.stack([w, w * (x < -0.5)], axis=1), [1.0, quad(f, -radius, -0.5) / quad(f, -radius, radius)])
    assert np.abs(z).max() < Z, z


def quad(f, a, b):
    """f's integral over [a, b] by 64-point Gauss-Legendre on pieces split at the integers and half-integers
    (the formulas' kinks lie there but the gaussian's cut-off, where f is 0 to 3e-4 with a kink: error below
    1e-9 of the whole)."""
    x, wts = np.polynomial.legendre.leggauss(64)
    cuts = np.unique(np.concatenate([[a, b], np.arange(math.ceil(2 * a), math.floor(2 * b) + 1) / 2]))
    return sum(float(np.sum(wts * f((lo + hi) / 2 + (hi - lo) / 2 * x)) * (hi - lo) / 2)
               for lo, hi in zip(cuts[:-1], cuts[1:]))
