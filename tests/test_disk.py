"""Mitsuba's disk (kernels/disk.cl, surface.cl's surface_disk) at every lane width against float64 on the
stored float32 values (raytrace/commands/stability/affine_shapes.py's disk_truth): random rays and skewed,
non-uniformly scaled maps at scales 1e-4, 1 and 1e4, flip_normals, rays leaving the disk from both sides, and
Mitsuba's (u, v), dp/du, dp/dv.

Mutations tried: the normal from to_world's third column instead of to_local's third row (the inverse
transpose): 36 tests fail; v without the + 1 below 0: 4 fail. dt = 0 in intersect_disk survives: rays leaving
from origins offset by Hit.err are clear of the plane by more than o.z's rounding here (the bound still holds
where origins are not offset; the stability suite checks t against it)."""
import numpy as np
import pytest

from helpers import planar
from raytrace.commands.stability.affine_shapes import disk_distance, disk_rays, disk_truth, leaving, placed, skewed
from raytrace.numerics import U, f32
from raytrace.renderer.packing import affine_shape_structs
from raytrace.scene import Disk

SOURCE = """
#include "disk.cl"
#include "surface.cl"
__kernel void hit(int n, __global const Disk *k, __global const float *o, __global const float *d,
                  __global float *t, __global float *p, __global float *err, __global float *nrm)
{
    Ray r = {IN3(o), IN3(d)};
    vec3 q;
    vfloat dt, e;
    vfloat th = intersect_disk(k, r, (vfloat)(INFINITY), &dt, &q);
    vec3 nn = disk_normal(k);
    OUT(t, SELECT((vfloat)(INFINITY), th, hit_in_range(th, dt, (vfloat)(INFINITY))));
    OUT3(p, disk_point(k, q.x, q.y, nn, &e));
    OUT(err, e);
    OUT3(nrm, nn);
}

/* Lane k of work-item I is element i = I LANES + k: (u, v), dp/du, dp/dv, n of each point, scalar code. */
__kernel void surface(int n, __global const Disk *k, __global const float *p, __global float *out)
{
    for (int j = 0, i = I * LANES; j < LANES; ++j, ++i) {
        SurfacePoint sp = surface_disk(k, (float3)(p[i], p[i + n], p[i + 2 * n]));
        float v[11] = {sp.uv.x, sp.uv.y, sp.dpdu.x, sp.dpdu.y, sp.dpdu.z, sp.dpdv.x, sp.dpdv.y, sp.dpdv.z,
                       sp.n.x, sp.n.y, sp.n.z};
        for (int c = 0; c < 11; ++c)
            out[i + c * n] = v[c];
    }
}
"""

SCALES = (1e-4, 1.0, 1e4)


def disk(scale, flip=False, seed=0):
    rng = np.random.default_rng(seed)
    return Disk(placed(skewed(rng, scale, 8.0), scale * np.array([0.3, -0.2, 0.1])), flip)


def trace(harness, k, o, d):
    out = harness.run(SOURCE, "hit", len(o), [affine_shape_structs([k]), planar(o), planar(d)],
                      {"t": 1, "p": 3, "err": 1, "nrm": 3})
    return {"t": out["t"], "p": out["p"].T, "err": out["err"], "n": out["nrm"].T}


@pytest.mark.parametrize("flip", [False, True], ids=["front", "flipped"])
@pytest.mark.parametrize("scale", SCALES)
def test_matches_float64(harness, scale, flip):
    """Hit or miss as float64 wherever the local radius is further from 1 than twice its rounding bound; t
    within intersect_disk's own first-order bound dt (the bound its self-hit rejection relies on; measured
    worst 0.2 dt); the point within its Hit.err of the stored plane (the kernel's claim); the normal, the
    inverse transpose's normal_sign normalize(L_z), within 8u (rsqrt 4 roundings, the dot 3, the product
    1). Rays from 3 sizes away through local radii up to 1.2, so that a fifth miss."""
    k = disk(scale, flip)
    rng = np.random.default_rng(1)
    o, d = disk_rays(rng, k, 512, 1.2 * np.sqrt(rng.uniform(size=512)), 3)
    o, d = f32(o), f32(d)
    s = affine_shape_structs([k])[0]
    out, truth = trace(harness, k, o, d), disk_truth(s, o, d)
    clear = np.abs(truth["r"] - 1) > 2 * truth["edge"]
    np.testing.assert_array_equal(np.isfinite(out["t"][clear]), np.isfinite(truth["t"][clear]))
    hit = np.isfinite(out["t"]) & np.isfinite(truth["t"])
    assert hit.sum() > 300 and (clear & ~hit).sum() > 50
    assert np.all(np.abs(out["t"] - truth["t"])[hit] <= truth["dt"][hit])
    assert np.all(disk_distance(s, out["p"][hit]) <= out["err"][hit])
    assert np.all(np.linalg.norm(out["n"] - truth["n"], axis=1) <= 8 * U)
    # Mitsuba's normal: +z under the inverse transpose, turned by flip_normals
    m = k.matrix[:3, :3]
    expected = np.linalg.inv(m).T @ [0, 0, 1.0]
    assert np.dot(out["n"][0], expected) * (-1 if flip else 1) > 0


@pytest.mark.parametrize("scale", SCALES)
def test_rays_leaving_never_meet_it_again(harness, scale):
    """From each hit, offset by Hit.err to either side (ray.h's offset_ray_origin), rays in random directions
    of that side: a plane is never met again, from the side the ray came from or through it."""
    k = disk(scale, seed=2)
    rng = np.random.default_rng(3)
    o, d = disk_rays(rng, k, 256, 0.99 * np.sqrt(rng.uniform(size=256)), 3)
    out = trace(harness, k, f32(o), f32(d))
    h = np.isfinite(out["t"])
    hits = {key: v[h] for key, v in out.items()}
    hits["n"] = hits["n"] * -np.sign(np.sum(hits["n"] * d[h], 1))[:, None]  # facing the ray, as Hit.n
    for side in (1, -1):
        dirs = rng.normal(size=(int(h.sum()), 3))
        dirs *= (np.sign(np.sum(dirs * hits["n"], 1)) * side)[:, None]
        again = trace(harness, k, f32(leaving(hits, side)), f32(dirs / np.linalg.norm(dirs, axis=1, keepdims=True)))
        assert not np.any(np.isfinite(again["t"]))


def test_uv_and_derivatives_are_mitsubas(harness):
    """(u, v) = (r, phi / 2 pi in [0, 1)), dp/du = M (cos, sin, 0), dp/dv = M (-sin, cos, 0) 2 pi r (Mitsuba's
    disk.cpp), at points c + M (x, y, 0) rounded to float32. Mapping back rounds p - c and a row of MADs:
    about 6u of |L| |p - c| in local units, so u within 1e-5 and v within 1e-5 / (2 pi r) (r >= 0.05 here; v
    compared around the circle); the derivatives, from (cos, sin) of that point and float32 products, within
    1e-5 of their size. The normal as test_matches_float64's."""
    k = disk(1.0, seed=4)
    rng = np.random.default_rng(5)
    r, phi = np.sqrt(rng.uniform(0.0025, 1, 512)), rng.uniform(0, 2 * np.pi, 512)
    m = k.matrix
    p = f32(np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros(512)], 1) @ m[:3, :3].T + m[:3, 3])
    out = harness.run(SOURCE, "surface", 512, [affine_shape_structs([k]), planar(p)], {"out": 11})["out"]
    u, v, dpdu, dpdv, n = out[0], out[1], out[2:5].T, out[5:8].T, out[8:11].T
    np.testing.assert_allclose(u, r, atol=1e-5)
    turn = np.abs((v - phi / (2 * np.pi) + 0.5) % 1 - 0.5)
    assert np.all(turn <= 1e-5 / (2 * np.pi * r)) and np.all((v >= 0) & (v < 1))
    cs = np.stack([np.cos(phi), np.sin(phi), np.zeros(512)], 1)
    sc = np.stack([-np.sin(phi), np.cos(phi), np.zeros(512)], 1)
    want_u, want_v = cs @ m[:3, :3].T, (sc @ m[:3, :3].T) * (2 * np.pi * r)[:, None]
    assert np.all(np.linalg.norm(dpdu - want_u, axis=1) <= 1e-5 * np.linalg.norm(want_u, axis=1))
    assert np.all(np.linalg.norm(dpdv - want_v, axis=1) <= 1e-5 * np.linalg.norm(want_v, axis=1) / r)
    want_n = np.linalg.inv(m[:3, :3]).T @ [0, 0, 1.0]
    np.testing.assert_allclose(n, np.broadcast_to(want_n / np.linalg.norm(want_n), n.shape), atol=8 * U)
