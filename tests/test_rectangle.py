"""Ray-rectangle intersection (kernels/rectangle.cl) against the float64 reference."""
import numpy as np
import pytest

import reference
from helpers import planar
from raytrace.renderer.packing import rectangle_structs
from raytrace.scene import Rectangle

SOURCE = """
#include "rectangle.cl"
__kernel void hit(int n, __global const Rectangle *rect, __global const float *o, __global const float *d,
                  float tmin, float tmax, __global float *t)
{
    Ray r = {IN3(o), IN3(d)};
    vfloat dt, u, v;
    vfloat th = intersect_rectangle(rect, r, (vfloat)(tmax), &dt, &u, &v);
    OUT(t, select((vfloat)(INFINITY), th, hit_in_range(th, dt, (vfloat)(tmax)) & (th >= tmin)));
}
"""

RECTS = [
    Rectangle(np.array([0.0, 0, 0]), np.array([2.0, 2.0]), np.array([0.0, 0, 1]), np.array([1.0, 0, 0])),
    Rectangle(np.array([1.0, 0, 1]), np.array([2.0, 0.5]), np.array([-1.0, 0, 0]), np.array([0.0, 0, -1])),
    Rectangle(np.array([0.3, -0.2, 0.5]), np.array([0.7, 1.9]),
              np.array([1.0, 2, 2]) / 3, np.array([2.0, -2, 1]) / 3),
]


def trace(harness, rect, o, d, tmin=0.0, tmax=np.inf):
    args = [rectangle_structs([rect]), planar(o), planar(d), np.float32(tmin), np.float32(tmax)]
    return harness.run(SOURCE, "hit", len(o), args, {"t": 1})["t"]


def rays_at(rect, uv, rng, n):
    """Rays from random points in front of the plane to points rect.center + u t + v b."""
    target = rect.center + uv[:, :1] * rect.tangent + uv[:, 1:] * rect.bitangent
    origin = target + rect.normal * rng.uniform(0.5, 3, (n, 1)) + rng.normal(0, 0.5, (n, 3))
    d = target - origin
    return origin, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("rect", RECTS, ids=["floor", "wall", "oblique"])
def test_matches_reference(harness, rect):
    """Hits and misses agree away from the border; t to float32 accuracy (relative 1e-5: t is a ratio
    of two float32 dot products of O(1) terms, each good to a few 2^-24)."""
    rng = np.random.default_rng(2)
    n = 256
    uv = rng.uniform(-1, 1, (n, 2)) * rect.size / 2 * 1.5
    o, d = rays_at(rect, uv, rng, n)
    t = trace(harness, rect, o, d)
    ref = reference.intersect_rectangle(rect, o, d, 0.0, np.inf)
    # points within 1e-4 of the border may fall either way in float32: the test skips only those
    clear = np.all(np.abs(np.abs(uv) - rect.size / 2) > 1e-4, axis=1)
    assert np.count_nonzero(clear & np.isfinite(ref)) > 50 and np.count_nonzero(clear & ~np.isfinite(ref)) > 50
    np.testing.assert_array_equal(np.isfinite(t[clear]), np.isfinite(ref[clear]))
    hit = clear & np.isfinite(ref)
    np.testing.assert_allclose(t[hit], ref[hit], rtol=1e-5)


def test_parallel_ray_and_t_range(harness):
    rect = RECTS[0]
    o = np.array([[0, 0, 1.0], [0, 0, 0.0], [0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0], [0.5, 0.5, 2]] + [[0, 0, 1]] * 2)
    d = np.array([[1, 0, 0.0], [1, 0, 0.0], [0, 0, -1.0], [0, 0, -1.0], [0, 0, 1.0], [0, 0, -1]] + [[0, 0, 1]] * 2)
    t = trace(harness, rect, o, d, tmin=0.0, tmax=1.5)
    assert not np.isfinite(t[0]) and not np.isfinite(t[1])   # parallel: above and in the plane
    assert t[2] == 1.0 and t[3] == 1.0                         # straight down
    assert t[4] == 1.0                                         # from behind: rectangles are two-sided
    assert not np.isfinite(t[5])                               # t = 2 beyond tmax
    assert not np.isfinite(t[6])                               # pointing away: t < tmin
