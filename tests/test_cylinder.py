"""Mitsuba's cylinder (kernels/cylinder.cl, surface.cl's surface_cylinder) at every lane width against float64
on the stored float32 values (raytrace/commands/stability/affine_shapes.py's cylinder_truth): skewed,
non-uniformly scaled maps at scales 1e-4, 1 and 1e4, p0, p1 and radius, flip_normals, rays from inside, and
Mitsuba's (u, v), dp/du, dp/dv with its coordinate_system frame.

Mutations tried: the normal without normal_sign (flip_normals ignored): the flipped cases fail; u from
atan2 without the + 1 below 0: the uv test fails."""
import numpy as np
import pytest

from helpers import planar
from raytrace.commands.stability.affine_shapes import (cylinder_clear, cylinder_distance, cylinder_rays,
                                                       cylinder_t_error, cylinder_truth, placed, skewed)
from raytrace.numerics import f32
from raytrace.renderer.packing import affine_shape_structs
from raytrace.scene import Cylinder

SOURCE = """
#include "cylinder.cl"
#include "surface.cl"
__kernel void hit(int n, __global const Cylinder *k, __global const float *o, __global const float *d,
                  __global float *t, __global float *p, __global float *err, __global float *nrm)
{
    Ray r = {IN3(o), IN3(d)};
    vec3 q;
    vfloat e;
    vfloat th = intersect_cylinder(k, r, &q);
    vec3 nn = cylinder_normal(k, q);
    OUT(t, th);
    OUT3(p, cylinder_point(k, q, nn, &e));
    OUT(err, e);
    OUT3(nrm, nn);
}

__kernel void surface(int n, __global const Cylinder *k, __global const float *p, __global float *out)
{
    for (int j = 0, i = I * LANES; j < LANES; ++j, ++i) {
        SurfacePoint sp = surface_cylinder(k, (float3)(p[i], p[i + n], p[i + 2 * n]));
        float v[11] = {sp.uv.x, sp.uv.y, sp.dpdu.x, sp.dpdu.y, sp.dpdu.z, sp.dpdv.x, sp.dpdv.y, sp.dpdv.z,
                       sp.n.x, sp.n.y, sp.n.z};
        for (int c = 0; c < 11; ++c)
            out[i + c * n] = v[c];
    }
}
"""


def cylinder(scale, flip=False, seed=0):
    rng = np.random.default_rng(seed)
    return Cylinder(placed(skewed(rng, scale, 4.0), scale * np.array([0.3, -0.2, 0.1])),
                    np.array([0.1, 0.0, -0.2]), np.array([-0.3, 0.4, 1.1]), 0.6, flip)


def trace(harness, k, o, d):
    out = harness.run(SOURCE, "hit", len(o), [affine_shape_structs([k]), planar(o), planar(d)],
                      {"t": 1, "p": 3, "err": 1, "nrm": 3})
    return {"t": out["t"], "p": out["p"].T, "err": out["err"], "n": out["nrm"].T}


@pytest.mark.parametrize("flip", [False, True], ids=["outwards", "flipped"])
@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e4])
def test_matches_float64(harness, scale, flip):
    """Lines passing the axis at local distances up to 1.2 (a sixth miss), some through the open ends: hit or
    miss as float64 where clear (cylinder_clear: silhouette and ends beyond twice their rounding); t within
    17u kt (the stability suite's grazing argument); Hit.p within its Hit.err of the stored tube; the normal
    the inverse transpose's L^T (x, y, 0), outwards from the axis unless flipped (to first order in float32:
    checked by its sign against float64's, which only a wrong orientation changes)."""
    k = cylinder(scale, flip)
    rng = np.random.default_rng(1)
    o, d = cylinder_rays(rng, k, 512, 1.2 * np.sqrt(rng.uniform(size=512)), 3, z=(-0.1, 1.1))
    s = affine_shape_structs([k])[0]
    out, truth = trace(harness, k, o, d), cylinder_truth(s, o, d)
    clear = cylinder_clear(truth)
    np.testing.assert_array_equal(np.isfinite(out["t"][clear]), np.isfinite(truth["t"][clear]))
    hit = clear & np.isfinite(out["t"]) & np.isfinite(truth["t"])
    assert hit.sum() > 250
    assert np.all(cylinder_t_error(out["t"], truth)[hit] <= 17)
    assert np.all(cylinder_distance(s, out["p"][hit]) <= out["err"][hit])
    q = truth["o_l"][hit] + truth["t"][hit, None] * truth["d_l"][hit]
    q[:, 2] = 0
    outwards = q @ truth["L"]  # L^T q: the gradient of |L_xy (x - c)|^2
    assert np.all(np.sign(np.sum(out["n"][hit] * outwards, 1)) == (-1 if flip else 1))


def test_from_inside_every_ray_meets_the_wall(harness):
    """From points on the axis within the tube's height, rays across it: each meets the wall ahead at
    float64's positive root within 17u kt, but for those that leave through an open end (as float64 says,
    where clear)."""
    k = cylinder(1.0, seed=2)
    rng = np.random.default_rng(3)
    m = k.matrix
    o = f32(np.stack([np.zeros(256), np.zeros(256), rng.uniform(0.3, 0.7, 256)], 1) @ m[:3, :3].T + m[:3, 3])
    d_l = np.stack([rng.normal(size=256), rng.normal(size=256), 0.2 * rng.normal(size=256)], 1)
    d = f32(d_l @ m[:3, :3].T / np.linalg.norm(d_l @ m[:3, :3].T, axis=1, keepdims=True))
    out, truth = trace(harness, k, o, d), cylinder_truth(affine_shape_structs([k])[0], o, d)
    clear = cylinder_clear(truth)
    np.testing.assert_array_equal(np.isfinite(out["t"][clear]), np.isfinite(truth["t"][clear]))
    ok = clear & np.isfinite(truth["t"])
    assert ok.sum() > 150
    assert np.all(cylinder_t_error(out["t"], truth)[ok] <= 17)


def test_uv_and_derivatives_are_mitsubas(harness):
    """u = phi / 2 pi in [0, 1) about the axis from the local x axis of Mitsuba's to_frame(coordinate_system(
    (p1 - p0) / |p1 - p0|)), v = the local height in [0, 1]; dp/du = M 2 pi (-sin, cos, 0), dp/dv = M (0, 0, 1),
    M the composed map (model.Cylinder.matrix, built as cylinder.cpp's constructor). At points M (cos, sin, z)
    rounded to float32 the local point maps back within about 6u of |L| |p - c|: u and v within 1e-5 (u around
    the circle), the derivatives within 1e-5 of their size."""
    k = cylinder(1.0, seed=4)
    rng = np.random.default_rng(5)
    phi, z = rng.uniform(0, 2 * np.pi, 512), rng.uniform(0, 1, 512)
    m = k.matrix
    p = f32(np.stack([np.cos(phi), np.sin(phi), z], 1) @ m[:3, :3].T + m[:3, 3])
    out = harness.run(SOURCE, "surface", 512, [affine_shape_structs([k]), planar(p)], {"out": 11})["out"]
    u, v, dpdu, dpdv = out[0], out[1], out[2:5].T, out[5:8].T
    assert np.all(np.abs((u - phi / (2 * np.pi) + 0.5) % 1 - 0.5) <= 1e-5) and np.all((u >= 0) & (u < 1))
    np.testing.assert_allclose(v, z, atol=1e-5)
    want_u = (np.stack([-np.sin(phi), np.cos(phi), np.zeros(512)], 1) @ m[:3, :3].T) * 2 * np.pi
    assert np.all(np.linalg.norm(dpdu - want_u, axis=1) <= 1e-5 * np.linalg.norm(want_u, axis=1))
    np.testing.assert_allclose(dpdv, np.broadcast_to(m[:3, 2], dpdv.shape), rtol=1e-5, atol=1e-6)


def test_map_is_mitsubas():
    """Cylinder.matrix against Mitsuba 3.9.1's own composition for these parameters (to_world * translate(p0)
    * to_frame(Frame3f(axis)) * scale(r, r, length)), computed by it and written here: the frame's s, t from
    coordinate_system fix where u = 0 lies, so textures map as Mitsuba's."""
    k = Cylinder(np.eye(4), np.array([0.1, 0.0, -0.2]), np.array([-0.3, 0.4, 1.1]), 0.6)
    axis = np.array([-0.4, 0.4, 1.3]) / np.linalg.norm([-0.4, 0.4, 1.3])
    s, t = k.matrix[:3, 0] / 0.6, k.matrix[:3, 1] / 0.6
    np.testing.assert_allclose(np.cross(s, t), axis, atol=1e-12)  # right-handed (s, t, n)
    sign = 1.0
    a = -1 / (sign + axis[2])
    b = axis[0] * axis[1] * a
    np.testing.assert_allclose(s, [axis[0] ** 2 * a + 1, b, -axis[0]], atol=1e-12)
