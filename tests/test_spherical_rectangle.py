"""Sampling a rectangular light by solid angle (kernels/spherical_rectangle.cl; Ureña et al. 2013) against
float64 references written here: the solid angle by the closed form over the rectangle's corners, and the
distribution of the sampled points over the light by a chi-square test against their density, at every lane
width, from points near and far, above the centre, beside an edge, close to the light's plane and at a
corner."""
import numpy as np
import pytest
from scipy import stats

import raytrace
from raytrace.commands.stability.probe import planar, scene_args

from devtools.chi_square import SIGNIFICANCE

PROBE = """
#include "spherical_rectangle.cl"
/* Per lane: light 0 as seen from o: its solid angle, whether it is sampled so, and the (s, t) on it that xi
 * maps to. */
__kernel void probe(int n, SCENE_PARAMETERS, __global const float *o, __global const float *xi,
                    __global float *solid_angle, __global float *used, __global float *st)
{
    SphericalRectangle q = spherical_rectangle(&lights[0].shape, IN3(o));
    vec2 u = {IN(xi), IN(xi + n)};
    vec2 p = spherical_rectangle_point(q, u);
    OUT(solid_angle, q.solid_angle);
    OUT(used, SELECT((vfloat)(0.0f), (vfloat)(1.0f), spherical_rectangle_used(q)));
    OUT(st, p.x);
    OUT(st + n, p.y);
}
"""
DEFINES = dict(HAS_PATH_TRACING=1, HAS_RECTANGLES=1)
CENTER, HALF = np.array([0.1, -0.2, 1.0]), np.array([0.4, 0.25])  # the light: normal -z, tangent +x


def light_scene():
    return raytrace.load_dict({
        "camera": {"position": [0, -3, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40.0},
        "image": {"width": 8, "height": 8}, "render": {"shading": "path"},
        "materials": {"m": {"colour": [0.5] * 3}},
        "lights": [{"center": CENTER.tolist(), "size": (2 * HALF).tolist(), "normal": [0, 0, -1],
                    "tangent": [1, 0, 0], "radiance": 1.0}]})


def f32(x):
    """x as float32 holds it (the kernel's inputs), in float64."""
    return np.asarray(x, np.float32).astype(np.float64)


def corners(o):
    """The rectangle's corner coordinates relative to o in the frame (tangent, bitangent, normal) =
    (+x, normal x tangent = -y, -z): x0, x1, y0, y1 and z0 = -|distance to the plane|; the light and o as
    float32 holds them, so that the reference measures the kernel's arithmetic, not its inputs' rounding (o
    1e-3 from the light's plane moves by 6e-8 in float32: 6e-5 of that distance)."""
    d = f32(CENTER) - f32(o)
    HALF_ = f32(HALF)
    cx, cy, cz = d[..., 0], -d[..., 1], -d[..., 2]
    return cx - HALF_[0], cx + HALF_[0], cy - HALF_[1], cy + HALF_[1], -np.abs(cz)


def solid_angle_reference(o):
    """The solid angle of an axis-aligned rectangle [x0, x1] x [y0, y1] at height z: the sum over its corners
    of +-atan(x y / (z r)), in float64 (an independent closed form: the integral of z / r^3 over the
    rectangle)."""
    x0, x1, y0, y1, z0 = corners(o)
    z = -z0
    f = lambda x, y: np.arctan2(x * y, z * np.sqrt(x * x + y * y + z * z))  # noqa: E731
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


def probe(harness, o, xi):
    args = {**scene_args(light_scene()), "o": planar(o), "xi": planar(xi)}
    return harness.run(PROBE, "probe", len(o), args, {"solid_angle": 1, "used": 1, "st": 2}, **DEFINES)


# Points to see the light from: above its centre, far above, beside an edge, 0.03 below its plane by an edge,
# under a corner, very close under its centre, and far off to the side.
VIEWS = np.array([[0.1, -0.2, 0.5], [0.1, -0.2, -6.0], [0.7, -0.2, 0.6], [0.52, -0.2, 0.97], [0.5, -0.45, 0.8],
                  [0.1, -0.2, 0.98], [-5.0, 3.0, -1.0]])


def test_solid_angle_against_float64(harness):
    """The solid angle from 2000 random points below the light (distance 1e-3 to 10) and the VIEWS, within
    4e-6 relative of the closed form. Why: Van Oosterom and Strackee's formula adds only positive terms where
    the triangles subtend less than a hemisphere and its triple product is exact but for three roundings,
    so each triangle's angle carries a few roundings (1e-6 relative); the corners' coordinates relative to
    o are rounded to float32 too (2^-24 of their size, against distances no smaller than 1e-3 of it). The
    textbook sum of the four angles minus 2 pi is off by more than 1e-3 relative from the far points
    (seen)."""
    rng = np.random.default_rng(7)
    o = np.concatenate([VIEWS, np.column_stack([rng.uniform(-3, 3, (2000, 2)),
                                                1.0 - 10.0 ** rng.uniform(-3, 1, 2000)])])
    out = probe(harness, o, rng.uniform(size=(len(o), 2)))
    expected = solid_angle_reference(o)
    np.testing.assert_allclose(out["solid_angle"], expected, rtol=4e-6, atol=0)
    x0, x1, y0, y1, z0 = corners(o)
    reach = np.max(np.abs([x0, x1, y0, y1]), axis=0)
    assert np.all((out["used"] == 1) == ((expected >= 2.0**-10) & (reach <= -32 * z0)))
    assert 0 < out["used"].mean() < 1


def st_density(o):
    """The density over (s, t) in [0, 1]^2 of points sampled uniformly in solid angle: the Jacobian A cos /
    r^2 of the point (s, t), over the solid angle."""
    omega, o, center, half = solid_angle_reference(o), f32(o), f32(CENTER), f32(HALF)
    area = 4 * half[0] * half[1]

    def density(s, t):
        q = center + np.stack([(2 * s - 1) * half[0], -(2 * t - 1) * half[1], np.zeros_like(s)], axis=-1)
        w = q - o
        r2 = np.sum(w * w, axis=-1)
        return area * np.abs(w[..., 2]) / r2**1.5 / omega
    return density


@pytest.mark.parametrize("view", range(len(VIEWS)), ids=["above", "far", "beside", "grazing", "corner", "close",
                                                         "side"])
def test_sampled_points_chi_square(harness, view):
    """2^18 points from independent uniform numbers, histogrammed over 16 x 16 cells of (s, t), against the
    density of uniform solid-angle sampling integrated over each cell (Gauss-Legendre, 8 x 8 points per
    cell, in float64): Pearson's chi-square at significance 1e-4 per case (7 cases per lane width: a false
    failure about once in 1400 runs of all of them at one width). Points sampled uniformly by area fail it
    from up close (seen)."""
    o = VIEWS[view]
    n = 2**18
    rng = np.random.default_rng(11 + view)
    out = probe(harness, np.tile(o, (n, 1)), rng.uniform(size=(n, 2)).astype(np.float32))
    assert np.all(out["used"] == 1)
    s, t = out["st"]
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    cells = 16
    observed, _, _ = np.histogram2d(s, t, bins=cells, range=[[0, 1], [0, 1]])
    x, w = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0, 1, cells + 1)
    centres = (0.5 * (edges[:-1, None] + edges[1:, None]) + 0.5 / cells * x).ravel()
    weights = np.tile(w, cells) * 0.5 / cells
    ss, tt = np.meshgrid(centres, centres, indexing="ij")
    values = st_density(o)(ss, tt) * np.outer(weights, weights)
    expected = values.reshape(cells, 8, cells, 8).sum(axis=(1, 3)) * n
    assert abs(expected.sum() / n - 1) < 1e-5  # the quadrature, even of the peak below the grazing point
    statistic = np.sum((observed - expected) ** 2 / expected)
    assert stats.chi2.sf(statistic, cells * cells - 1) > SIGNIFICANCE, statistic
