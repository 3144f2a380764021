"""A pixel's sums over its lanes (kernels/render.cl's pixel_sums): the lanes' compensated sums added pairwise
with every rounding error kept, against the exact sum (math.fsum of the same float32 terms), at every lane
width and every group of lanes a launch can have."""
import math

import numpy as np
import pyopencl as cl
import pytest

from raytrace.renderer.program import build

KERNEL = """
#include "render.cl"
/* pixel_sums of the lanes (sum[i], carry[i]) of work-item i, every lane's result. */
__kernel void sums(__global const float *sum, __global const float *carry, int group, __global float *out)
{
    int i = (int)get_global_id(0) * LANES;
    vfloat total = pixel_sums(VLOAD(sum + i), VLOAD(carry + i), group);
    VSTORE(total, out + i);
}
"""
U = 2.0**-24
ITEMS = 512


def gamma(n):
    return n * U / (1 - n * U)


def terms(rng, lanes, cancelling):
    """ITEMS x lanes float32 partial sums and carries. Cancelling terms (both signs, magnitudes from 2^-20 to
    2^20, the last lane of each item chosen so that the item's sum is small) make an uncompensated pairwise sum
    err by about u times the terms' magnitude, far above the bound on their small sum; the carries are then 0,
    so that sum - carry is exact. Otherwise the lanes are positive sums with carries of a few of their ulps, as
    a render's are."""
    if cancelling:
        s = (rng.choice([-1, 1], (ITEMS, lanes)) * 2.0 ** rng.uniform(-20, 20, (ITEMS, lanes))).astype(np.float32)
        s[:, -1] = -s[:, :-1].astype(np.float64).sum(axis=1).astype(np.float32) + np.float32(1e-3)
        return s, np.zeros_like(s)
    s = rng.uniform(0.0, 4.0, (ITEMS, lanes)).astype(np.float32)
    return s, (s * rng.uniform(-4.0, 4.0, s.shape) * U).astype(np.float32)


@pytest.mark.parametrize("cancelling", [False, True], ids=["render-like", "cancelling"])
def test_pixel_sums_are_within_sum2s_bound(cl_env, lanes, cancelling):
    """Every lane of a group holds the group's sum S of its lanes' v = fl(sum - carry), within Sum2's bound
    (Ogita, Rump and Oishi 2005, their Proposition 4.5): u |S| + gamma(g - 1)^2 sum |v|. A sum that dropped its
    error terms, summed a group's lanes wrongly, or left a lane out of its group fails it."""
    context, queue = cl_env
    program, _ = build(context, KERNEL, [f"-DLANES={lanes}"])
    rng = np.random.default_rng(lanes + 10 * cancelling)
    s, c = terms(rng, lanes, cancelling)
    v = (s - c).astype(np.float32)  # float32 subtraction, rounded as the kernel's
    group = 1
    while group <= lanes:
        mf = cl.mem_flags
        bufs = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (s, c)]
        out = np.empty_like(s)
        out_buf = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
        cl.Kernel(program, "sums")(queue, (ITEMS,), None, *bufs, np.int32(group), out_buf)
        cl.enqueue_copy(queue, out, out_buf)
        groups = v.reshape(ITEMS, lanes // group, group).astype(np.float64)
        exact = np.array([[math.fsum(g) for g in item] for item in groups])
        bound = U * np.abs(exact) + gamma(group - 1) ** 2 * np.abs(groups).sum(axis=2)
        error = np.abs(out.reshape(ITEMS, lanes // group, group) - exact[..., None])
        assert np.all(error <= bound[..., None]), (group, float(np.max(error - bound[..., None])))
        group *= 2
