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
/* Work-item I draws points 0..count-1 of dimension pair `dimension` for the pixels p = I*LANES .. I*LANES+LANES-1,
 * pixel p its point (i + stagger p) mod count at step i: with stagger 0 the lanes share each index, with 1 each
 * lane has its own. Point i is point i mod per_sample (of per_sample per pixel sample) of pixel sample
 * first + i / per_sample; pair 0 (the pixel offsets) has one point per pixel sample. Pixel p draws pair
 * dimension + p mod spread: with spread > 1 a packet's lanes stand at different pairs, as the path model's do
 * (render.cl). out: count x-planes, then count y-planes, of n pixels each, by step. */
__kernel void samples(int n, __global const uint2 *table, __global const Sampler *sampler, uint seed,
                      int dimension, int first, int per_sample, int count, int stagger, int spread,
                      __global float *out)
{
    vint pixel = I * LANES + LANE_IDS;
    vuint key = pixel_key(AS_VUINT(pixel), seed);
    for (int i = 0; i < count; ++i) {
        vint at = (i + stagger * pixel) % count;
        PixelSample ps = start_pixel_sample(key, first + at / per_sample);
        ps.dimension = dimension + pixel % spread;
        SampleStream stream = next_stream(&ps, *sampler, per_sample);
        vec2 u = stream_2d(table, *sampler, stream, at % per_sample);
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


def stream_key(key, stream):
    return _hash(key ^ _hash(stream))


def sobol_owen(index, key):
    """Owen-scrambled Sobol point gray(index) as (x, y) uint64 fixed point: the table's point, scrambled."""
    g = index ^ (index >> np.uint64(1))
    table = samplers.sobol_points(g).astype(np.uint64)
    return _owen(table[..., 0], _hash(key ^ np.uint64(0x68E31DA4))), _owen(table[..., 1], _hash(key ^ np.uint64(0xB5297A4D)))


def reference_samples(pattern, pixels, seed, count, dimension=0, first=0, per_sample=None):
    """(count, pixels, 2) points of dimension pair `dimension`, as the kernel must produce them: point i is
    point i mod per_sample of pixel sample first + i / per_sample (per_sample: 1 for the pixel offsets, pair 0;
    by default count for a light's pair)."""
    per_sample = per_sample or (1 if dimension == 0 else count)
    key = _hash(np.asarray(pixels, np.uint64) ^ _hash((seed + 0x9E3779B9) & 0xFFFFFFFF))[None, :]
    i = np.arange(count, dtype=np.uint64)[:, None]
    sample, j = np.uint64(first) + i // np.uint64(per_sample), i % np.uint64(per_sample)
    if pattern.randomize == "sobol":
        index = np.broadcast_to(sample * np.uint64(per_sample) + j, (count, len(pixels)))
        if dimension > 0:
            key = stream_key(key, np.uint64(dimension))
            index = _owen(index, _hash(key ^ np.uint64(0x2C1B3C6D)))
        x, y = sobol_owen(index, key)
        return np.stack([(x >> np.uint64(8)) * 2.0**-24, (y >> np.uint64(8)) * 2.0**-24], axis=-1)
    if dimension > 0:
        key = stream_key(stream_key(key, sample), np.uint64(dimension - 1))
        i = j
    else:
        i = sample
    table = pattern.table().astype(np.uint64)[i[:, 0]][:, None, :]
    shape = (count, len(pixels))
    x, y = np.broadcast_to(table[..., 0], shape), np.broadcast_to(table[..., 1], shape)
    draw = lambda d: _hash(key ^ _hash(2 * i + d))  # noqa: E731
    if pattern.randomize == "independent":
        x, y = draw(0), draw(1)
    elif pattern.randomize == "jitter":
        s = pattern.sampler_struct()
        x = x + (((draw(0) * np.uint64(s["cell_x"])) >> np.uint64(32)) << np.uint64(8))
        y = y + (((draw(1) * np.uint64(s["cell_y"])) >> np.uint64(32)) << np.uint64(8))
    elif pattern.randomize == "shift":
        x, y = (x + _hash(key ^ np.uint64(0x68E31DA4))) & M32, (y + _hash(key ^ np.uint64(0xB5297A4D))) & M32
    return np.stack([(x >> np.uint64(8)) * 2.0**-24, (y >> np.uint64(8)) * 2.0**-24], axis=-1)


def kernel_samples(harness, pattern, n_pixels, seed=0, count=None, dimension=0, first=0, per_sample=None,
                   stagger=0, spread=1):
    """(count, n_pixels, 2) points of dimension pair `dimension` (pixel p's: dimension + p mod spread) drawn by
    the kernel for pixels 0 .. n_pixels-1, pixel p's point (i + stagger p) mod count at step i
    (reference_samples says which)."""
    count = count or len(pattern.points)
    per_sample = per_sample or (1 if dimension == 0 else count)
    out = harness.run(SAMPLE, "samples", n_pixels,
                      [pattern.table(), pattern.sampler_struct().reshape(1), np.uint32(seed), np.int32(dimension),
                       np.int32(first), np.int32(per_sample), np.int32(count), np.int32(stagger), np.int32(spread)],
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
    if p.randomize == "jitter":  # a corner as read stays in its own stratum (rounded up, not down)
        np.testing.assert_array_equal(np.floor(as_read * p.strata), np.round(p.points * p.strata))


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


@pytest.mark.parametrize("name, n", [("jittered", 6), ("jittered", 12), ("jittered", 15), ("jittered", 20),
                                     ("jittered", 24), ("grid", 9), ("grid", 25), ("grid", 49)])
def test_cells_of_no_power_of_two_start_in_the_four_quadrants(name, n):
    """Cells nx x ny, not both powers of two, in bit-reversed Morton order (samplers.progressive): the first
    four points lie in the pixel's four quadrants (a cell in the half its centre is in; a centre at 1/2 in
    the upper one), so that a render stopped at 4 samples, and each half of the error estimate's passes,
    covers the pixel. Reversing all 16 bits of the cells' fixed-point positions put jittered 12's and
    20's first four in one row or one column."""
    p = samplers.pattern(name, n)
    nx, ny = p.strata if name == "jittered" else (round(n**0.5),) * 2
    assert nx & (nx - 1) or ny & (ny - 1)
    cells = np.floor(p.points[:4] * [nx, ny] + 1e-9).astype(int)
    assert len({tuple(2 * c + 1 >= [nx, ny]) for c in cells}) == 4, cells.tolist()


@pytest.mark.parametrize("n", [4, 9, 16, 64])
def test_rotated_grids_are_the_grid_rotated_about_the_pixel_centre(n):
    """+-atan(1/2) about (1/2, 1/2), wrapped into [0, 1)^2; clockwise on screen (y down) is a positive angle."""
    for name, sign in (("rotated-grid-cw", 1), ("rotated-grid-ccw", -1)):
        a = sign * math.atan(0.5)
        g = samplers.grid(n) - 0.5
        expected = np.mod(g @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]) + 0.5, 1)
        got = samplers.pattern(name, n).points
        np.testing.assert_allclose(np.sort(got, axis=0), np.sort(expected, axis=0), atol=1e-12)
        gap = np.linalg.norm(got[:, None, :] - expected[None, :, :], axis=-1)  # as points, not columns
        assert gap.min(axis=0).max() < 1e-12 and gap.min(axis=1).max() < 1e-12, name
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
    for seed, dimension, first, per_sample in ((0, 0, 0, 1), (7, 0, 0, 1), (7, 1, 3, n), (7, 4, 5, n), (3, 2, 9, 1)):
        want = reference_samples(pattern, pixels, seed, n, dimension, first, per_sample)
        got = kernel_samples(harness, pattern, 64, seed, n, dimension, first, per_sample)
        np.testing.assert_array_equal(got, want)
        assert np.all((got >= 0) & (got < 1))
        staggered = kernel_samples(harness, pattern, 64, seed, n, dimension, first, per_sample, stagger=1)
        np.testing.assert_array_equal(staggered, want[(np.arange(n)[:, None] + pixels) % n, pixels])


@pytest.mark.parametrize("name", ["random", "halton", "sobol"])
def test_each_lane_draws_its_own_dimension_pair(harness, name):
    """The lanes of a packet at different dimension pairs (kernels/samplers.cl's per-lane counter; the path
    model's lanes start new paths as theirs end): pixel p draws pair p mod 3, the pixel offsets (pair 0,
    unshuffled, under the pixel's key) beside pairs 1 and 2 (shuffled, under their own keys), each exactly as
    a packet all at that pair draws it."""
    n = 16
    pattern = samplers.pattern(name, n)
    pixels = np.arange(64)
    got = kernel_samples(harness, pattern, 64, 5, n, 0, 0, per_sample=1, spread=3)
    for d in range(3):
        want = reference_samples(pattern, pixels, 5, n, d, 0, 1)
        np.testing.assert_array_equal(got[:, d::3], want[:, d::3])
    assert not np.array_equal(got[:, 0::3], reference_samples(pattern, pixels, 5, n, 1, 0, 1)[:, 0::3])


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
        light = kernel_samples(harness, pattern, 64, seed=1, dimension=1)  # a light's points in the same pixel
        assert not np.any(np.all(a == light, axis=(0, 2))), name


def test_discrepancy_ordering(harness):
    """Mean L2-star discrepancy over pixels of the kernel's randomised 64-point sets: low-discrepancy
    patterns beat jittered, which beats random (expected values differ by factors of about 2 here, and 32
    pixels average the spread away)."""
    d = {name: np.mean([qmc.discrepancy(s.T, method="L2-star") for s in
                        kernel_samples(harness, samplers.pattern(name, 64), 32, seed=9).transpose(1, 2, 0)])
         for name in ("random", "jittered", "halton", "sobol")}
    assert max(d["sobol"], d["halton"]) < d["jittered"] < d["random"], d


# --- the sequence over a pixel's samples (sobol: every dimension pair of one Owen-scrambled Sobol sequence) ---

SOBOL = """
#include "samplers.cl"
/* Unscrambled Sobol point gray(first + i), i the lane's global index, each coordinate in 16-bit halves (the
 * harness returns floats: halves are exact, a whole uint32's bits could be a NaN). */
__kernel void sobol(int n, uint first, __global float *out)
{
    vuint i = (vuint)(first) + AS_VUINT(I * LANES + LANE_IDS), g = i ^ (i >> 1);
    vuint x = reverse_bits(g), y = reverse_bits(sobol_pascal(g));
    OUT(out, CONVERT_VFLOAT(x >> 16));
    OUT(out + n, CONVERT_VFLOAT(x & 0xffffU));
    OUT(out + 2 * n, CONVERT_VFLOAT(y >> 16));
    OUT(out + 3 * n, CONVERT_VFLOAT(y & 0xffffU));
}
"""


@pytest.mark.parametrize("first", [0, 2**20, 2**31 - 512, 2**32 - 1024])
def test_kernel_sobol_matches_scipy(harness, first):
    """The kernel's Sobol generator (sobol_pascal: the Pascal matrix by a transform over bit supersets) exactly,
    over 1024 points at the start, in the middle and at the end of the 2^32 indices a pixel can use: against
    scipy's unscrambled two-dimensional Sobol sequence with 32-bit direction numbers (Joe and Kuo's) where
    scipy gets there quickly (its fast_forward takes 13 s to 2^32), and beyond against samplers.sobol_points,
    the generator matrices' plain product, whose direction numbers are scipy's (test_sobol_matches_scipy)."""
    out = harness.run(SOBOL, "sobol", 1024, [np.uint32(first)], {"out": 4})["out"].astype(np.uint64)
    got = np.stack([out[0] << np.uint64(16) | out[1], out[2] << np.uint64(16) | out[3]], axis=1)
    if first < 2**24:
        engine = qmc.Sobol(d=2, scramble=False, bits=32)
        if first:  # scipy's fast_forward(0) raises
            engine.fast_forward(first)
        np.testing.assert_array_equal(got.astype(np.float64), engine.random(1024) * 2.0**32)
    else:
        i = np.arange(first, first + 1024, dtype=np.uint64)
        np.testing.assert_array_equal(got, samplers.sobol_points(i ^ (i >> np.uint64(1))))


def sequence(harness, n_pixels, samples, dimension, per_sample=1, seed=5):
    """(samples * per_sample, n_pixels, 2): dimension pair `dimension` of pixel samples 0 .. samples-1 of the
    sobol sequence, per_sample points each (a light's samples), in index order."""
    return kernel_samples(harness, samplers.pattern("sobol", 1), n_pixels, seed, samples * per_sample, dimension,
                          0, per_sample)


def test_every_pair_is_a_net_over_the_pixel_samples(harness):
    """Owen scrambling keeps (0, m, 2)-nets (Owen 1995), and the index's scramble maps aligned blocks of 2^m
    pixel samples onto aligned blocks: so in every pixel, for every pair the renderer draws (the pixel offset,
    pair 0; a light's points, pairs 1 and 5), every aligned block of 2^m pixel samples, prefixes included,
    is a net: with one light sample per pixel sample, and with 4 (then each pixel sample's 4 points are a net
    too, and the 4 x 256 points of 256 pixel samples). Exact property: it holds or the code is wrong."""
    for dimension, per_sample in ((0, 1), (1, 1), (5, 1), (1, 4), (3, 16)):
        got = sequence(harness, 8, 1024 // per_sample, dimension, per_sample)
        for pixel in range(8):
            points = got[:, pixel]
            for m in (2, 4, 7, 10):
                assert all(is_net(points[k: k + 2**m], m) for k in range(0, 1024, 2**m)), (dimension, per_sample, m)
    shuffled_halton = kernel_samples(harness, samplers.pattern("halton", 256), 4, 5, 256, 1, 0, 1)  # can fail
    assert not is_net(shuffled_halton[:, 0], 8)


def occupancy_chi2(a, b, cells=8):
    """Pearson's chi-square of the cells x cells histogram of the points (a, b) (one pixel's samples)
    against a uniform one."""
    counts, _, _ = np.histogram2d(a, b, bins=cells, range=[[0, 1], [0, 1]])
    expected = len(a) / cells**2
    return float(np.sum((counts - expected) ** 2 / expected))


def test_pairs_are_decorrelated(harness):
    """Two pairs of one pixel sample (the pixel offset and a light point, two lights' points) must be
    independent of each other, or the 4D points lie on a 2D surface and the error falls no faster than one
    pair's. Without the index's shuffle they are: both are Owen scrambles of the same Sobol point, which map
    each dyadic interval of x onto one of the other's, so with 64 samples each 1/8 column of (x_pixel,
    x_light) holds its 8 points in one cell (chi-square 448 per pixel against a uniform 8 x 8 histogram).
    Independent uniform points give a chi-square of mean 63 (the multinomial's); the sequence's stratified
    marginals give less (measured 55 for each pair below). The test allows a mean over 256 pixels of 90: the
    per-pixel statistic's standard deviation is about 19 (measured 17-19), so the mean's is 1.2 and the bound
    is 29 of them above the measured mean: a false failure never happens, and a missing shuffle fails it
    fivefold (seen). The same for the y coordinates, for x against y, and for two lights' pairs."""
    pixel = sequence(harness, 256, 64, 0)
    light, other = sequence(harness, 256, 64, 1), sequence(harness, 256, 64, 2)
    for a, b in ((pixel[..., 0], light[..., 0]), (pixel[..., 1], light[..., 1]), (light[..., 0], other[..., 0]),
                 (pixel[..., 0], light[..., 1])):
        chi2 = np.mean([occupancy_chi2(a[:, p], b[:, p]) for p in range(256)])
        assert chi2 < 90, chi2
    same = [occupancy_chi2(pixel[:, p, 0], pixel[:, p, 0]) for p in range(4)]  # a pair against itself: fails
    assert min(same) > 90
