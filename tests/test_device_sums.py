"""A render's sums kept on the device (kernels/accumulate.cl, raytrace/renderer/device_sums.py): the double-float
addition against the exact sum, and whole renders whose passes add up on the device against the same renders
added up on the host in float64 (progressive.py's Accumulator), image, variance, ray count and error estimate.

The accumulation kernels are scalar, one work-item per pixel on every device (no LANES): there is no lane width
to vary. The renders run at the session's lane width, on its device."""
import math

import numpy as np
import pyopencl as cl
import pytest

from raytrace import load_file
from raytrace.errors import InputError
from raytrace.options import RenderOptions
from raytrace.render import render_progressive, resolve_all
from raytrace.renderer.device_render import OUTPUT_PLANES, RAYS_PLANE
from raytrace.renderer.device_render import FIRST_HALF_PLANE
from raytrace.renderer.device_sums import DeviceSums, estimate_chunks
from raytrace.renderer.progressive import CHANNELS, Accumulator
from raytrace.renderer.program import Features, build

from helpers import CORNELL, ROOT, SESSION_KIND

U = 2.0**-24  # float32's unit roundoff

def half_difference_error(total, n_prefix, n_total):
    """A bound on the device's error in the half difference where only the total T (float64) is known:
    1.01 u T (5 wp + 4 |wt|) (test_device_sums_match_the_host argues it)."""
    n_rest = n_total - n_prefix
    w = math.sqrt(n_prefix * n_rest) / n_total
    return 1.01 * U * total * (5 * (w / n_prefix + w / n_rest) + 4 * w / n_rest)


ADD_ALL = """
#include "accumulate.cl"
/* hi[i] + lo[i] += every term of row i, in order. */
__kernel void add_all(__global const float *terms, int n, __global float *hi, __global float *lo)
{
    const int i = get_global_id(0);
    for (int k = 0; k < n; ++k)
        double_float_add(hi + i, lo + i, terms[i * n + k]);
}
"""


def test_double_float_sum_is_within_its_bound(cl_env):
    """ITEMS rows of N non-negative float32 terms spread over 2^-12 .. 2^12 (a render's fireflies beside its dark
    pixels) and N equal ones (where a plain float32 running sum drifts most), added by double_float_add. Each
    addition's only rounding is that of lo + e, at most u |lo + e| <= u (u |hi| + u |s|) <= 2 u^2 S for a
    running sum S of non-negative terms (TwoSum's e and FastTwoSum's renormalisation are exact): the pair is
    within 2 N u^2 S of the exact sum (math.fsum), 2^-33 S here. A plain float32 sum misses that by about
    N u / 2, a Kahan sum left unrenormalised by about u: both fail it. And hi is the pair rounded to float32,
    the invariant that lets the other kernels read hi alone."""
    context, queue = cl_env
    program, _ = build(context, ADD_ALL)
    items, n = 128, 1 << 14
    rng = np.random.default_rng(5)
    terms = (rng.uniform(0, 1, (items, n)) * 2.0 ** rng.uniform(-12, 12, (items, n))).astype(np.float32)
    terms[-8:] = np.float32(0.1)  # equal terms
    mf = cl.mem_flags
    hi, lo = np.zeros(items, np.float32), np.zeros(items, np.float32)
    t_buf = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=terms)
    hi_buf, lo_buf = (cl.Buffer(context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=a) for a in (hi, lo))
    cl.Kernel(program, "add_all")(queue, (items,), None, t_buf, np.int32(n), hi_buf, lo_buf)
    cl.enqueue_copy(queue, hi, hi_buf)
    cl.enqueue_copy(queue, lo, lo_buf)
    exact = np.array([math.fsum(row.astype(np.float64)) for row in terms])
    error = np.abs(hi.astype(np.float64) + lo - exact)
    assert np.all(error <= 2 * n * U * U * exact), (error / exact).max()
    assert np.array_equal((hi.astype(np.float64) + lo).astype(np.float32), hi)


@pytest.mark.parametrize("passes", [1, 3, 7, 1000])
def test_a_constant_sample_gives_itself_back(cl_env, passes):
    """Every pixel's own constant (random float32s over 2^-20 .. 2^20) added as `passes` passes of one sample:
    the image is each constant to the bit, as the host's float64 sums give it (kernels/accumulate.cl's mean_of
    argues why), the ray count is exact, and the variance of a constant is within the rounding of its half
    difference. A mean taken as hi / n or as hi times 1 / n misses some pixels by an ulp at 3 and 7 passes."""
    context, queue = cl_env
    width, height = 64, 16
    rng = np.random.default_rng(passes)
    c = (2.0 ** rng.uniform(-20, 20, (CHANNELS, height, width))).astype(np.float32)
    out = np.zeros((OUTPUT_PLANES, height, width), np.float32)
    out[:CHANNELS], out[RAYS_PLANE] = c, 3.0
    out_buf = cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=out)
    sums = DeviceSums(context, queue, width, height)
    for k in range(passes):
        sums.add_band(out_buf, 0, height, has_first=False)  # a pass of one sample has no halves
        sums.end_pass(1)
    assert sums.rays_traced() == 3.0 * width * height * passes
    image, variance = sums.images()
    assert np.array_equal(image, np.moveaxis(c, 0, -1))
    assert (variance is None) == (passes == 1)
    if variance is not None:  # d is 0 but for its roundings: half_difference_error
        n_prefix = 1 << (passes - 1).bit_length() - 1
        scale = math.sqrt(n_prefix * (passes - n_prefix)) / passes
        e = half_difference_error(passes * c.astype(np.float64), n_prefix, passes)
        assert np.all(variance <= np.moveaxis(e, 0, -1) ** 2)


def _add_pass(context, host, device, sums, first, rays, bands):
    """One pass of sums (CHANNELS x H x W float32), first-half sums or None and ray counts (H x W) added into
    the host's Accumulator and into DeviceSums, band by band ((first row, rows) each), as a render adds them."""
    for row0, rows in bands:
        band = slice(row0, row0 + rows)
        out = np.zeros((OUTPUT_PLANES, rows, sums.shape[2]), np.float32)
        out[:CHANNELS], out[RAYS_PLANE] = sums[:, band], rays[band]
        if first is not None:
            out[FIRST_HALF_PLANE:FIRST_HALF_PLANE + CHANNELS] = first[:, band]
        buffer = cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=out)
        device.add_band(buffer, row0, rows, first is not None)
        host.add_rows(row0, sums[:, band], None if first is None else first[:, band],
                      float(rays[band].sum(dtype=np.float64)))


# Passes as (samples, samples summed apart): a render's first pass sums half apart (progressive.first_half),
# except a pass of one sample; then passes of any size, unequal ones included (a render's last).
SCHEDULES = {"halves-then-unequal": [(4, 2), (2, 0), (2, 0), (4, 0), (8, 0), (3, 0), (7, 0)],
             "ones": [(1, 0), (1, 0), (2, 0), (1, 0), (3, 0), (8, 0), (1, 0)],
             "big-first": [(16, 8), (16, 0), (5, 0), (27, 0), (64, 0)]}


@pytest.mark.parametrize("schedule", SCHEDULES.values(), ids=SCHEDULES)
def test_device_sums_follow_the_accumulator_pass_by_pass(cl_env, schedule):
    """Synthetic passes (per-pixel scales over 2^-6 .. 2^6, cubed uniform samples) added in two bands into
    DeviceSums and the host's Accumulator, the estimate compared after every pass, as the time limit and the
    target error read it:
    - the same halves (n_prefix) and None before the second half exists;
    - the RMSE within its rounding: with p and T the host's prefix and total and wp, wt the weights, the device's
      half difference errs by at most e = 3 u |p| wp + 4 u |T| |wt| (a rounding each of the weights, of the pair
      to hi, of the products and of their sum, each within u of the term it rounds or of the sum, which the
      terms bound) plus one ulp of p times wp (its prefix, the pair rounded, may neighbour the host's float64
      total rounded), times 1.01 for the second-order terms (2^-24 of these); the sum of squares S then errs by
      at most 2 sqrt(S sum e^2) + sum e^2 (Cauchy-Schwarz) plus the float32 partial sums' n u S, n the terms of
      one, and the squares' own roundings;
    - the mean behind the relative estimate within (n + 2) u: the partial sums of hi, each within u/2 of its pair;
    - the ray count exactly: odd counts below 2^23 a pixel a pass, past 2^24 within a few passes, so that the
      pairs' lo parts hold part of it.
    Skipping a prefix copy, a wrong weight, a band at the wrong row, or leaving lo out of the rays fails it."""
    context, queue = cl_env
    width, height = 48, 20
    bands = [(0, 7), (7, 13)]
    rng = np.random.default_rng(len(schedule))
    host, device = Accumulator((CHANNELS, height, width)), DeviceSums(context, queue, width, height)
    scale = 2.0 ** rng.uniform(-6, 6, (CHANNELS, height, width))
    terms = CHANNELS * -(-height // device.chunks)
    for n, n_first in schedule:
        samples = (rng.uniform(0, 1, (n, CHANNELS, height, width)) ** 3 * scale).astype(np.float32)
        sums = samples.astype(np.float64).sum(axis=0).astype(np.float32)
        first = samples[:n_first].astype(np.float64).sum(axis=0).astype(np.float32) if n_first else None
        rays = (2 * rng.integers(1 << 21, 1 << 22, (height, width)) + 1).astype(np.float32)
        _add_pass(context, host, device, sums, first, rays, bands)
        host.end_pass(n, n_first)
        device.end_pass(n, n_first)
        (rmse, relative), (d_rmse, d_relative) = host.estimated_rmse(), device.estimated_rmse()
        assert (d_rmse is None) == (rmse is None) and device.n_prefix == host.n_prefix
        if rmse is None:
            continue
        n_prefix, n_rest = host.n_prefix, host.n_total - host.n_prefix
        w = math.sqrt(n_prefix * n_rest) / host.n_total
        wp, wt = w / n_prefix + w / n_rest, w / n_rest
        prefix = host.prefix.astype(np.float64)
        e = 1.01 * (U * (3 * prefix * wp + 4 * host.total * wt) + np.spacing(host.prefix) * wp)
        s = float(np.sum(np.square(host._half_difference(slice(None)))))
        bound = 2 * math.sqrt(s * np.sum(e * e)) + np.sum(e * e) + (terms + 4) * U * s
        assert abs(d_rmse**2 - rmse**2) * host.total.size <= bound  # (+ 4 u S: the squares' roundings)
        assert abs(d_rmse / d_relative - rmse / relative) <= (terms + 2) * U * rmse / relative
    assert device.rays_traced() == host.rays_traced()


@pytest.mark.parametrize("bad", [np.inf, np.nan], ids=["inf", "nan"])
def test_a_nonfinite_sum_meets_no_target(cl_env, bad):
    """A NaN or Inf sample (a kernel bug: the image zeroes and counts it) leaves an estimate that says nothing:
    its relative error is infinite on both sides, so no target error stops the render on it. Before, the
    device's NaN sums made it 0, a target met."""
    context, queue = cl_env
    width, height = 16, 4
    host, device = Accumulator((CHANNELS, height, width)), DeviceSums(context, queue, width, height)
    for k in range(4):
        sums = np.full((CHANNELS, height, width), 0.5, np.float32)
        sums[1, 2, 3] = bad if k == 2 else 0.5
        _add_pass(context, host, device, sums, None, np.ones((height, width), np.float32), [(0, height)])
        host.end_pass(1)
        device.end_pass(1)
    assert host.estimated_rmse()[1] == device.estimated_rmse()[1] == math.inf


SIZE = dict(width=40, height=30, sampler="sobol", progress=False)


def _scene(name):
    return load_file(CORNELL if name == "cornell" else ROOT / "scenes" / f"{name}.toml")


def _render(scene, spp, accumulate):
    """A render of spp samples in passes of at most 4 (so that the estimate's prefix is copied at 4, 8 and 16)
    and bands of 7 rows (5 bands a pass), its sums added as `accumulate` says."""
    r = resolve_all(scene, RenderOptions(spp=spp, **SIZE))
    options = dict(spp=spp, max_pass_work=4 * r.width * r.height * r.work,
                   max_band_bytes=OUTPUT_PLANES * 4 * r.width * 7, accumulate=accumulate, **SIZE)
    return render_progressive(scene, **options)


@pytest.mark.parametrize("spp", [4, 24], ids=["one-pass", "six-passes"])
@pytest.mark.parametrize("name", ["cornell", "cornell_box"])
def test_device_sums_match_the_host(name, spp):
    """The same render with its sums on the device and on the host. The course's Cornell box (Phong) and
    cornell_box (path tracing); one pass (the estimate's halves from the kernel's first-half planes) and six
    passes of 4 (the prefix copied from the total at 4, 8 and 16; the last estimate 16 against 8 samples).
    - Rays: equal; each pixel's count is an integer, added exactly by both.
    - Image: within 1 float32 ulp of the host's: the host rounds its float64 mean once; the device's mean_of is
      within little more than half an ulp of the pair's quotient, the pair within 2^-33 of the sum.
    - Variance: the half difference d = p wp + T wt (prefix p and total T, weights wp and wt rounded once from
      float64) errs on the device by at most e = u (3 |p| wp + 4 |T| |wt|) plus one ulp of p times wp, as in
      test_device_sums_follow_the_accumulator_pass_by_pass; with p <= T (the samples are >= 0) and one ulp at
      most 2 u |p|, e <= 1.01 u T (5 wp + 4 |wt|) (half_difference_error), T from the image. Then |d'^2 - d^2|
      <= e (2 |d| + e), and each side's square rounds once more (2 u d^2).
    - The last pass's estimated RMSE: its sum of squares S errs by sum e (2 |d| + e) <= 2 sqrt(S sum e^2) + sum
      e^2 (Cauchy-Schwarz), plus the device's float32 partial sums of n terms each (n u S) and the squares' own
      roundings.
    A prefix taken at the wrong pass, a weight swapped, or a band added twice misses these by far more."""
    scene = _scene(name)
    image, variance, stats = _render(scene, spp, "host")
    d_image, d_variance, d_stats = _render(scene, spp, "device")
    assert stats.extra["sums"] == "host" and d_stats.extra["sums"] == "device"
    assert d_stats.rays == stats.rays
    assert d_stats.spp == stats.spp == spp and d_stats.passes == stats.passes

    ulp = np.spacing(image)
    assert np.all(np.abs(d_image.astype(np.float64) - image) <= ulp)

    e = half_difference_error(image.astype(np.float64) * spp, 2 if spp == 4 else 16, spp)
    d = np.sqrt(variance.astype(np.float64))
    bound = e * (2 * d + e) + 2 * U * variance
    assert np.all(np.abs(d_variance.astype(np.float64) - variance) <= bound)

    count = variance.size
    s = float(np.sum(variance, dtype=np.float64))
    terms = CHANNELS * -(-SIZE["height"] // estimate_chunks(SIZE["width"], SIZE["height"]))
    s_bound = 2 * math.sqrt(s * np.sum(e * e)) + np.sum(e * e) + (terms + 4) * U * s
    rmse, d_rmse = stats.history[-1]["estimated_rmse"], d_stats.history[-1]["estimated_rmse"]
    assert abs(d_rmse**2 - rmse**2) * count <= s_bound
    assert [h["estimated_rmse"] is None for h in d_stats.history] == [h["estimated_rmse"] is None
                                                                         for h in stats.history]


def test_sums_stay_on_the_host_on_a_cpu():
    """Without the option, a CPU device's render adds its passes on the host, a GPU's on the device."""
    _, _, stats = render_progressive(_scene("cornell"), spp=1, **SIZE)
    assert stats.extra["sums"] == ("host" if SESSION_KIND == "cpu" else "device")


@pytest.mark.parametrize("options, words", [
    (dict(accumulate="gpu"), "accumulate = 'gpu'"),
    (dict(accumulate="device", scheduler="local:1"), "a Dask render adds its bands on the client"),
    (dict(accumulate="device", features=Features(count_visits=True)), "counting build"),
])
def test_accumulate_is_checked(options, words):
    """A value of accumulate the render cannot use is one line naming it, before any device work."""
    with pytest.raises(InputError, match=words) as caught:
        render_progressive(_scene("cornell"), spp=1, **SIZE, **options)
    assert "accumulate" in str(caught.value) and "\n" not in str(caught.value)
