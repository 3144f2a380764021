"""Watertight ray-triangle intersection (kernels/triangle.cl) against the float64 reference."""
import numpy as np
import pytest

import reference
from helpers import planar
from raytrace.renderer.packing import triangle_structs
from raytrace.scene import Triangle
from raytrace.numerics import U

SOURCE = """
#include "triangle.cl"
__kernel void hit(int n, __global const Triangle *tri, __global const float *o, __global const float *d,
                  float tmin, float tmax, __global float *t, __global float *b1, __global float *b2)
{
    Ray r = {IN3(o), IN3(d)};
    vfloat dt, w, u, v;
    vfloat th = intersect_triangle(tri, r, ray_shear(r), &dt, &w, &u, &v);
    OUT(t, select((vfloat)(INFINITY), th, hit_in_range(th, dt, (vfloat)(tmax)) & (th >= tmin)));
    OUT(b1, u);
    OUT(b2, v);
}
"""

TRIS = [np.array([[-1, 0.2, 0.2], [-0.5, -0.65, 0.2], [0, 0.2, 0.2]]),      # a tetrahedron face
        np.array([[0.3, 0.1, -0.4], [1.2, 0.6, 0.3], [-0.2, 1.4, 0.9]]),     # oblique
        np.array([[0, 0, 0], [1e-3, 0, 0], [0, 1e-3, 5e-4]]) + 10.0]        # tiny and far from the origin


def trace(harness, vertices, o, d, tmin=0.0, tmax=np.inf):
    args = [triangle_structs([Triangle(np.asarray(vertices, float))]), planar(o), planar(d),
            np.float32(tmin), np.float32(tmax)]
    return harness.run(SOURCE, "hit", len(o), args, {"t": 1, "b1": 1, "b2": 1})


def rays_to(points, rng, distance=2.0):
    d = rng.normal(size=points.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return points - distance * np.linalg.norm(np.ptp(points, axis=0) + 1e-3) * d, d


@pytest.mark.parametrize("k", range(len(TRIS)), ids=["face", "oblique", "tiny"])
def test_matches_reference(harness, k):
    """Inside and outside away from the edges; t and barycentrics to float32 accuracy.

    Both sides get the same float32-rounded rays; the kernel also rounds the vertices and works in float32,
    so each sheared coordinate is off by a few 2^-24 of the magnitudes involved, |o| + |v|. Along a ray
    meeting the plane at cos(incidence) >= 0.1 that moves the hit by at most delta = 8 * 2^-24 *
    (|o| + |v|) / 0.1; barycentrics move by delta over the triangle's smallest altitude."""
    v = TRIS[k]
    rng = np.random.default_rng(3 + k)
    n = 256
    b = rng.uniform(-0.3, 1.1, (n, 2))
    points = (1 - b.sum(1))[:, None] * v[0] + b[:, :1] * v[1] + b[:, 1:] * v[2]
    o, d = (a.astype(np.float32).astype(float) for a in rays_to(points, rng))
    out = trace(harness, v, o, d)
    t, b1, b2 = reference.intersect_triangle(v, o, d, 0.0, np.inf)
    normal = np.cross(v[1] - v[0], v[2] - v[0])
    area2 = np.linalg.norm(normal)
    cos_incidence = np.abs(d @ normal) / area2
    delta = 8 * U * (np.abs(o).max(1) + np.abs(v).max()) / 0.1
    altitude = area2 / max(np.linalg.norm(v[1] - v[0]), np.linalg.norm(v[2] - v[1]), np.linalg.norm(v[0] - v[2]))
    weights = np.stack([1 - b.sum(1), b[:, 0], b[:, 1]], axis=1)
    sel = np.all(np.abs(weights) > 1e-3, axis=1) & (cos_incidence > 0.1)
    assert np.count_nonzero(sel & np.isfinite(t)) > 40 and np.count_nonzero(sel & ~np.isfinite(t)) > 40
    np.testing.assert_array_equal(np.isfinite(out["t"][sel]), np.isfinite(t[sel]))
    hit = sel & np.isfinite(t)
    assert np.all(np.abs(out["t"][hit] - t[hit]) <= delta[hit])
    assert np.all(np.abs(out["b1"][hit] - b1[hit]) <= delta[hit] / altitude)
    assert np.all(np.abs(out["b2"][hit] - b2[hit]) <= delta[hit] / altitude)


def test_edges_vertices_parallel_and_range(harness):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    targets = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0, 0.5, 0], [0.5, 0.5, 0],
                        [0.2, 0.2, 0], [0.2, 0.2, 0]])
    o = targets + [0, 0, 1.0]
    d = np.tile([0, 0, -1.0], (8, 1))
    o[7], d[7] = [-1, 0.2, 0.0], [1, 0, 0]  # in the plane, parallel to it
    out = trace(harness, v, o, d, tmax=2.0)
    assert np.all(out["t"][:7] == 1.0), "vertices and edges are inside"
    assert not np.isfinite(out["t"][7]), "a ray in the triangle's plane misses"
    np.testing.assert_allclose(out["b1"][:3], [0, 1, 0], atol=1e-7)
    np.testing.assert_allclose(out["b2"][:3], [0, 0, 1], atol=1e-7)
    short = trace(harness, v, o, d, tmax=0.999)["t"]
    assert not np.any(np.isfinite(short)), "t = 1 beyond tmax"
    late = trace(harness, v, o, d, tmin=1.001)["t"]
    assert not np.any(np.isfinite(late)), "t = 1 before tmin"


def test_watertight_shared_edge(harness):
    """Rays aimed exactly at the shared edge of two triangles (from many directions) hit at least one of
    them: a crack would let them through. Moller-Trumbore with independent edge tests fails this."""
    a, b = np.array([0.1, -0.7, 0.3]), np.array([0.4, 0.9, 0.35])
    c1, c2 = np.array([-0.8, 0.1, 0.1]), np.array([1.1, 0.2, 0.6])
    rng = np.random.default_rng(5)
    n = 2048
    s = rng.uniform(0, 1, (n, 1))
    points = (a + s * (b - a)).astype(np.float32).astype(float)
    o = points + rng.normal(0, 1, (n, 3)) * [1, 1, 0.2] + [0, 0, 2]
    d = points - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t1 = trace(harness, [a, b, c1], o, d)["t"]
    t2 = trace(harness, [b, a, c2], o, d)["t"]
    assert np.all(np.isfinite(t1) | np.isfinite(t2))
