"""Ray-ellipsoid intersection and normals (kernels/ellipsoid.cl) against the float64 reference,
including stiff cases: far origins, thin and long ellipsoids."""
import numpy as np
import pytest

import reference
from helpers import planar
from raytrace.renderer.packing import ellipsoid_structs
from raytrace.scene import Ellipsoid
from raytrace.numerics import U

SOURCE = """
#include "ellipsoid.cl"
__kernel void hit(int n, __global const Ellipsoid *e, __global const float *o, __global const float *d,
                  __global float *t, __global float *nrm)
{
    Ray r = {IN3(o), IN3(d)};
    vec3 q;
    vfloat th = intersect_ellipsoid(e, r, &q);
    OUT(t, th);
    OUT3(nrm, ellipsoid_normal(e, q));
}
"""


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


CASES = {
    "course": Ellipsoid(np.array([0.5, 0.4, 0.4]), np.array([[0.3, 0.1, 0], [-0.1, 0.3, 0], [0, 0, 0.4]])),
    "sphere": Ellipsoid(np.zeros(3), np.eye(3)),
    "rotated": Ellipsoid(np.array([1.0, -2, 0.5]), (rotation([1, 2, 3], 0.7) @ np.diag([1.5, 0.4, 0.9])).T),
    "thin 1:100": Ellipsoid(np.array([0, 0, 1.0]), (rotation([0, 1, 1], 0.3) @ np.diag([1, 1, 0.01])).T),
    "long 100:1": Ellipsoid(np.zeros(3), (rotation([1, 0, 1], 1.1) @ np.diag([100, 1, 1])).T),
    "sheared": Ellipsoid(np.array([0.2, 0, 0]), np.array([[1, 0.9, 0], [0, 1, 0.9], [0.2, 0, 1.0]])),
}


def trace(harness, e, o, d):
    args = [ellipsoid_structs([e]), planar(o), planar(d)]
    return harness.run(SOURCE, "hit", len(o), args, {"t": 1, "nrm": 3})


def rays(e, rng, n, distance):
    """Rays from `distance` (in ellipsoid radii) towards points around the ellipsoid."""
    radius = np.linalg.norm(e.axes, axis=1).max()
    target = e.center + (rng.uniform(-1.3, 1.3, (n, 3)) @ e.axes)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return target - distance * radius * direction, direction


@pytest.mark.parametrize("distance", [3.0, 1000.0], ids=["near", "far"])
@pytest.mark.parametrize("name", CASES)
def test_matches_reference(harness, name, distance):
    """Hit/miss agree except where the ray grazes the surface; t and the normal within first-order
    float32 error bounds.

    Both sides get the same float32 rays. The kernel maps the origin into unit-sphere space with a float32
    matrix: the hit point there is off by ~2^-24 |o - c| / r_min. t moves by that over cos(incidence);
    the normal (the inverse-transpose of that point) turns by it times the condition number kappa of the
    axes. The tolerances are 4x these bounds (measured worst: 1.7x), so a wrong root, a plain instead of
    an inverse-transposed normal, or an unstable quadratic (errors of 1e-3 and more here) fails."""
    e = CASES[name]
    rng = np.random.default_rng(7)
    n = 512
    o, d = (a.astype(np.float32).astype(float) for a in rays(e, rng, n, distance))
    out = trace(harness, e, o, d)
    t, normal = reference.intersect_ellipsoid(e, o, d, 0.0, np.inf)
    inv = np.linalg.inv(e.matrix)
    ou, du = (o - e.center) @ inv.T, d @ inv.T
    h = np.sum(ou * du, 1) / np.sum(du * du, 1)
    closest = np.linalg.norm(ou - h[:, None] * du, axis=1)  # closest approach, unit-sphere space
    clear = np.abs(closest - 1) > 1e-3 * max(1.0, distance / 10)
    assert np.count_nonzero(clear & np.isfinite(t)) > 50
    np.testing.assert_array_equal(np.isfinite(out["t"][clear]), np.isfinite(t[clear]))
    hit = clear & np.isfinite(t)
    sv = np.linalg.svd(e.axes, compute_uv=False)
    cos_incidence = np.maximum(np.abs(np.sum(normal * d, 1)), 1e-3)
    point_error = U * np.linalg.norm(o - e.center, axis=1) / sv[-1]
    assert np.all(np.abs(out["t"][hit] - t[hit]) <= 4 * point_error[hit] * sv[0] / cos_incidence[hit])
    normal_error = np.linalg.norm(out["nrm"].T - normal, axis=1)
    assert np.all(normal_error[hit] <= 4 * point_error[hit] * sv[0] / sv[-1] / cos_incidence[hit])


def test_inside_and_behind(harness):
    """From the centre the far root is taken; a sphere behind the origin is missed."""
    e = CASES["course"]
    o = np.tile(e.center, (8, 1))
    d = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 0], [-1, 0, 0], [0, -1, 0], [1, 1, 1.0]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = trace(harness, e, o, d)
    t, _ = reference.intersect_ellipsoid(e, o, d, 0.0, np.inf)
    np.testing.assert_allclose(out["t"], t, rtol=1e-5)
    away = trace(harness, e, o + [0, 0, 5], np.tile([0, 0, 1.0], (8, 1)))["t"]
    assert not np.any(np.isfinite(away))


def test_normals_are_inverse_transpose(harness):
    """On a sheared ellipsoid the normal is not the scaled point: it is M^-T q (checked against the
    implicit function's gradient, independently of the reference's formula)."""
    e = CASES["sheared"]
    rng = np.random.default_rng(9)
    o, d = rays(e, rng, 256, 4.0)
    out = trace(harness, e, o, d)
    hit = np.isfinite(out["t"])
    p = o[hit] + out["t"][hit, None] * d[hit]
    inv = np.linalg.inv(e.matrix)
    grad = 2 * ((p - e.center) @ inv.T) @ inv   # gradient of |inv (p - c)|^2
    grad /= np.linalg.norm(grad, axis=1, keepdims=True)
    np.testing.assert_allclose(out["nrm"].T[hit], grad, atol=1e-4)
