"""Sample patterns: the host's tables (raytrace/samplers.py) against scipy.stats.qmc and their definitions,
and the kernel's per-pixel randomisation (kernels/samplers.cl) against an exact numpy reference of the
same integer arithmetic, plus the properties the randomisations must keep (strata, nets, discrepancy)."""
import math

import numpy as np
import pytest
from scipy.stats import qmc

from raytrace import samplers

M32 = np.uint64(0xFFFFFFFF)

SAMPLE = """
#include "samplers.cl"
/* Work-item I draws points 0..count-1 for the pixels p = I*LANES .. I*LANES+LANES-1, pixel p its point
 * (i + stagger p) mod count at step i: with stagger 0 the lanes share each index, with 1 each lane has its own.
 * out: count x-planes, then count y-planes, of n pixels each, by step. */
__kernel void samples(int n, __global const uint2 *table, __global const Sampler *sampler, uint seed,
                      uint stream, int count, int stagger, __global float *out)
{
    vint pixel = I * LANES + LANE_IDS;
    vuint key = pixel_key(AS_VUINT(pixel), seed);
    if (stream)
        key = stream_key(key, (vuint)(stream - 1));
    for (int i = 0; i < count; ++i) {
        vec2 u = sample_2d(table, (i + stagger * pixel) % count, *sampler, key);
        OUT(out + i * n, u.x);
        OUT(out + (count + i) * n, u.y);
    }
}
"""


# --- an exact reference of kernels/samplers.cl in numpy uint64 arithmetic, reduced mod 2^32 ---------

def _hash(x):
    x = np.asarray(x, np.uint64) & M32
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & M32
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & M32
    return x ^ (x >> np.uint64(16))


def _reverse(v):
    bits = (v[..., None] >> np.arange(32, dtype=np.uint64)) & np.uint64(1)
    return (bits << np.arange(31, -1, -1, dtype=np.uint64)).sum(-1, dtype=np.uint64)


def _owen(v, seed):
    mul = lambda a, c: (a * np.uint64(c)) & M32  # noqa: E731
    v = _reverse(v)
    v ^= mul(v, 0x3D20ADEA)
    v = (v + seed) & M32
    v = (v * ((seed >> np.uint64(16)) | np.uint64(1))) & M32
    v ^= mul(v, 0x05526C56)
    v ^= mul(v, 0x53A22864)
    return _reverse(v)


def reference_samples(pattern, pixels, seed, count, stream=None):
    """(count, pixels, 2) points, as the kernel must produce them."""
    key = _hash(np.asarray(pixels, np.uint64) ^ _hash((seed + 0x9E3779B9) & 0xFFFFFFFF))[None, :]
    if stream is not None:
        key = _hash(key ^ _hash(stream))
    table = pattern.table().astype(np.uint64)[:count, None, :]
    i = np.arange(count, dtype=np.uint64)[:, None]
    x, y = np.broadcast_to(table[..., 0], (count, key.size)), np.broadcast_to(table[..., 1], (count, key.size))
    draw = lambda d: _hash(key ^ _hash(2 * i + d))  # noqa: E731
    if pattern.randomize == "independent":
        x, y = draw(0), draw(1)
    elif pattern.randomize == "jitter":
        s = pattern.sampler_struct()
        x = x + (((draw(0) * np.uint64(s["cell_x"])) >> np.uint64(32)) << np.uint64(8))
        y = y + (((draw(1) * np.uint64(s["cell_y"])) >> np.uint64(32)) << np.uint64(8))
    elif pattern.randomize == "shift":
        x, y = (x + _hash(key ^ np.uint64(0x68E31DA4))) & M32, (y + _hash(key ^ np.uint64(0xB5297A4D))) & M32
    elif pattern.randomize == "owen":
        x, y = _owen(x, _hash(key ^ np.uint64(0x68E31DA4))), _owen(y, _hash(key ^ np.uint64(0xB5297A4D)))
    return np.stack([(x >> np.uint64(8)) * 2.0**-24, (y >> np.uint64(8)) * 2.0**-24], axis=-1)


def kernel_samples(harness, pattern, n_pixels, seed=0, count=None, stream=None, stagger=0):
    """(count, n_pixels, 2) points drawn by the kernel for pixels 0 .. n_pixels-1, pixel p's point
    (i + stagger p) mod count at step i."""
    count = count or len(pattern.points)
    out = harness.run(SAMPLE, "samples", n_pixels,
                      [pattern.table(), pattern.sampler_struct().reshape(1), np.uint32(seed),
                       np.uint32(0 if stream is None else stream + 1), np.int32(count), np.int32(stagger)],
                      {"out": 2 * count})["out"]
    return np.stack([out[:count], out[count:]], axis=-1)


VALID = [(name, n) for name in samplers.SAMPLERS for n in (1, 4, 9, 16, 12, 64, 256)
         if samplers.count_problem(name, n) is None]


# --- host tables --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name,n", VALID)
def test_tables_lie_in_the_unit_square(name, n):
    p = samplers.pattern(name, n)
    assert p.points.shape == (n, 2) and np.all((p.points >= 0) & (p.points < 1))
    as_read = (p.table() >> np.uint32(8)) * 2.0**-24  # what the kernel makes of an unrandomised entry
    assert np.all((as_read >= 0) & (as_read < 1))


def test_counts_each_pattern_allows():
    assert samplers.count_problem("center", 2) and samplers.count_problem("grid", 8)
    assert samplers.count_problem("rotated-grid-cw", 12) and samplers.count_problem("nope", 4)
    for name in ("random", "jittered", "halton", "sobol"):
        assert all(samplers.count_problem(name, n) is None for n in (1, 2, 3, 7, 12, 1000))
    assert samplers.jitter_strata(12) == (4, 3) and samplers.jitter_strata(7) == (7, 1)
    with pytest.raises(ValueError):
        samplers.pattern("grid", 5)


def test_grid_is_cell_centres_in_progressive_order():
    g = samplers.pattern("grid", 16).points
    np.testing.assert_array_equal(np.sort(g, axis=0), np.sort(samplers.grid(16), axis=0))
    assert len({tuple(p) for p in g}) == 16
    # every prefix of 4^k points has one point in each of the 4^k dyadic cells
    for k in (1, 2):
        cells = {tuple(c) for c in np.floor(g[: 4**k] * 2**k).astype(int)}
        assert len(cells) == 4**k


@pytest.mark.parametrize("n", [4, 9, 16, 64])
def test_rotated_grids_are_the_grid_rotated_about_the_pixel_centre(n):
    """+-atan(1/2) about (1/2, 1/2), wrapped into [0, 1)^2; clockwise on screen (y down) is a positive angle."""
    for name, sign in (("rotated-grid-cw", 1), ("rotated-grid-ccw", -1)):
        a = sign * math.atan(0.5)
        g = samplers.grid(n) - 0.5
        expected = np.mod(g @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]) + 0.5, 1)
        got = samplers.pattern(name, n).points
        np.testing.assert_allclose(np.sort(got, axis=0), np.sort(expected, axis=0), atol=1e-12)
    # The course's 4-sample rotated grid: every row and every column of the pixel holds one sample.
    p = samplers.pattern("rotated-grid-cw", 4).points
    assert len(set(np.floor(p[:, 0] * 4))) == 4 and len(set(np.floor(p[:, 1] * 4))) == 4


def test_halton_matches_scipy():
    np.testing.assert_allclose(samplers.pattern("halton", 300).points,
                               qmc.Halton(d=2, scramble=False).random(300), atol=1e-15)


def test_sobol_matches_scipy():
    np.testing.assert_array_equal(samplers.pattern("sobol", 1024).points, qmc.Sobol(d=2, scramble=False).random(1024))


def is_net(points, m):
    """Every elementary interval [a 2^-j, (a+1) 2^-j) x [b 2^-(m-j), (b+1) 2^-(m-j)) holds one point."""
    for j in range(m + 1):
        cells = np.floor(points[:, 0] * 2**j).astype(np.int64) * 2 ** (m - j) + np.floor(
            points[:, 1] * 2 ** (m - j)).astype(np.int64)
        if len(np.unique(cells)) != 2**m:
            return False
    return True


def test_sobol_table_is_a_0_2_sequence():
    p = samplers.pattern("sobol", 4096).points
    for m in (2, 5, 8, 12):
        assert all(is_net(p[k: k + 2**m], m) for k in range(0, 4096, 2**m))
    assert not is_net(samplers.pattern("halton", 256).points, 8)  # the check can fail


# --- the kernel's randomisation -------------------------------------------------------------------------

@pytest.mark.parametrize("name,n", [("center", 1), ("grid", 16), ("rotated-grid-ccw", 9), ("random", 16),
                                    ("jittered", 12), ("halton", 16), ("sobol", 64)])
def test_kernel_matches_reference(harness, name, n):
    """Exact: the randomisations are integer arithmetic, and (v >> 8) 2^-24 is exact in float32. Both ways of
    reading the table: the lanes sharing an index (a light sample), or each lane its own (several samples of
    a pixel at once, kernels/tile.h)."""
    pattern = samplers.pattern(name, n)
    pixels = np.arange(64)
    for seed, stream in ((0, None), (7, None), (7, 3)):
        want = reference_samples(pattern, pixels, seed, n, stream)
        got = kernel_samples(harness, pattern, 64, seed=seed, stream=stream)
        np.testing.assert_array_equal(got, want)
        assert np.all((got >= 0) & (got < 1))
        staggered = kernel_samples(harness, pattern, 64, seed=seed, stream=stream, stagger=1)
        np.testing.assert_array_equal(staggered, want[(np.arange(n)[:, None] + pixels) % n, pixels])


def test_fixed_patterns_are_the_table_in_every_pixel(harness):
    pattern = samplers.pattern("grid", 16)
    got = kernel_samples(harness, pattern, 16, seed=5)
    expected = (pattern.table() >> np.uint32(8)) * 2.0**-24
    np.testing.assert_array_equal(got, np.broadcast_to(expected[:, None, :], got.shape))


def test_jittered_has_one_point_per_stratum(harness):
    pattern = samplers.pattern("jittered", 12)
    got = kernel_samples(harness, pattern, 64, seed=3)
    nx, ny = pattern.strata
    strata = np.floor(got[..., 0] * nx) + nx * np.floor(got[..., 1] * ny)  # float64: exact for float32 input
    assert all(sorted(strata[:, p]) == list(range(12)) for p in range(64))
    assert len(np.unique(got[..., 0])) > 12 * 60  # not the strata centres: jittered per pixel


def test_owen_scrambled_sobol_stays_a_0_2_sequence(harness):
    got = kernel_samples(harness, samplers.pattern("sobol", 1024), 16, seed=11)
    for pixel in range(16):
        points = got[:, pixel]
        for m in (4, 8, 10):
            assert all(is_net(points[k: k + 2**m], m) for k in range(0, 1024, 2**m))


def test_pixels_and_seeds_get_different_randomisations(harness):
    for name in ("random", "jittered", "halton", "sobol"):
        pattern = samplers.pattern(name, 16)
        a = kernel_samples(harness, pattern, 64, seed=1)
        b = kernel_samples(harness, pattern, 64, seed=2)
        first = a[:, 0]
        assert not any(np.array_equal(first, a[:, p]) for p in range(1, 64)), name
        assert not np.any(np.all(a == b, axis=(0, 2))), name  # a new seed changes every pixel
        light = kernel_samples(harness, pattern, 64, seed=1, stream=0)  # a light stream of the same pixel
        assert not np.any(np.all(a == light, axis=(0, 2))), name


def test_discrepancy_ordering(harness):
    """Mean L2-star discrepancy over pixels of the kernel's randomised 64-point sets: low-discrepancy
    patterns beat jittered, which beats random (expected values differ by factors of about 2 here, and 32
    pixels average the spread away)."""
    d = {name: np.mean([qmc.discrepancy(s.T, method="L2-star") for s in
                        kernel_samples(harness, samplers.pattern(name, 64), 32, seed=9).transpose(1, 2, 0)])
         for name in ("random", "jittered", "halton", "sobol")}
    assert max(d["sobol"], d["halton"]) < d["jittered"] < d["random"], d
