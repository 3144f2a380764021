"""Error-bounded hit points and ray offsets (kernels/ray.h and each shape's *_point): the bound holds, the
offset origin lies strictly on the side the ray leaves to, and a ray leaving a surface never hits it again,
from the offset origin; at scales 1e-3 to 1e4 and 1e4 units from the origin.

The float64 side measures distances from the surfaces as the kernel stores them (the float32 struct values,
read back from the packed structs), so only the kernel's arithmetic is under test."""
import dataclasses

import numpy as np
import pytest

from helpers import planar
from raytrace.commands.stability.probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, scene_args
from raytrace.scene import Ellipsoid, Rectangle, Triangle
from raytrace.renderer.packing import ellipsoid_structs, rectangle_structs, triangle_structs
from raytrace.scene.transform import f32, transformed
from raytrace.numerics import U

SOURCE = """
#include "intersect.cl"
__kernel void leave(int n, SCENE_PARAMETERS, __global const float *o, __global const float *d,
                    __global const float *w, __global float *t, __global float *p, __global float *err,
                    __global float *nrm, __global float *origin, __global float *again)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    Ray r = {IN3(o), IN3(d)};
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    vec3 out = IN3(w); /* any direction, turned to the side of the facing normal: away from the surface */
    out = v3_scale(out, select((vfloat)(1.0f), (vfloat)(-1.0f), v3_dot(out, hit.n) < 0.0f));
    Ray offset = {offset_ray_origin(hit.p, hit.err, hit.n), out};
    OUT(t, hit.t);
    OUT3(p, hit.p);
    OUT(err, hit.err);
    OUT3(nrm, hit.n);
    OUT3(origin, offset.o);
    OUT(again, closest_hit(&s, offset, (vfloat)(INFINITY)).t);
}
"""

SHAPES = {
    "rectangle": Rectangle(np.array([0.2, -0.1, 0.3]), np.array([1.4, 0.9]), np.array([2.0, -1, 2]) / 3,
                           np.array([1.0, 2, 0]) / np.sqrt(5)),
    "triangle": Triangle(np.array([[-0.6, -0.4, 0.1], [0.7, -0.2, 0.5], [0.1, 0.8, -0.3]])),
    "ellipsoid": Ellipsoid(np.array([0.1, 0.2, -0.1]), np.array([[0.6, 0.2, 0.0], [-0.1, 0.3, 0.1], [0.0, 0.1, 0.5]])),
    "ellipsoid 1:1e3": Ellipsoid(np.zeros(3), np.array([[0.6, 0.48, 0.0], [-0.00048, 0.0006, 0.0], [0, 0, 0.5]])),
}
TRANSFORMS = [(1.0, 0.0), (1e-3, 0.0), (1e4, 0.0), (1.0, 1e4), (1e2, -1e4), (1e-2, 30.0)]
THIN = {"ellipsoid 1:1e3": 7.7e-4}  # the shortest axis


def resolved(name, scale, offset):
    """Whether float32 resolves the shape there: its thinnest dimension spans at least 256 float spacings at
    its distance from the origin (the 1:1e3 ellipsoid 1e4 units out is under one spacing thick; there the
    first-order distance this test measures is meaningless, and so is the shape)."""
    return THIN.get(name, 1.0) * scale >= 256 * float(np.spacing(np.float32(2 * abs(offset) + scale)))


CASES = [(name, s, o) for name in SHAPES for s, o in TRANSFORMS if resolved(name, s, o)]


def scene_of(cornell, name, scale, offset):
    shape = SHAPES[name]
    kind = {Rectangle: "rectangles", Triangle: "triangles", Ellipsoid: "ellipsoids"}[type(shape)]
    shapes = {"rectangles": [], "triangles": [], "ellipsoids": [], kind: [shape]}
    one = dataclasses.replace(cornell, lights=[], **shapes)
    return transformed(one, scale, np.array([1.0, -0.7, 0.4]) * offset)


def stored_surface(scene):
    """(signed distance, unit outward gradient) of the scene's one shape as the kernel stores it (float32
    values), as functions of points."""
    if scene.rectangles or scene.triangles:
        if scene.rectangles:
            s = rectangle_structs(scene.rectangles)[0]
            c, n = (np.array(list(s[k]), np.float64) for k in ("center", "normal"))
        else:
            s = triangle_structs(scene.triangles)[0]
            c, v1, v2 = (np.array(list(s[k]), np.float64) for k in ("v0", "v1", "v2"))
            n = np.cross(v1 - c, v2 - c)
        n = n / np.linalg.norm(n)
        return (lambda p: (p - c) @ n), (lambda p: np.broadcast_to(n, p.shape))
    s = ellipsoid_structs(scene.ellipsoids)[0]
    c, m = np.array(list(s["center"]), np.float64), s["world_to_unit"].astype(np.float64).reshape(3, 3)
    gradient = lambda p: ((p - c) @ m.T) @ m  # noqa: E731  (half the gradient of |M (p - c)|^2)

    def distance(p):  # first order, (|q|^2 - 1) / |grad |q|^2|: the points are within 2^-14 of the size
        q = (p - c) @ m.T
        return (np.sum(q * q, axis=1) - 1) / (2 * np.linalg.norm(gradient(p), axis=1))
    return distance, lambda p: gradient(p) / np.linalg.norm(gradient(p), axis=1, keepdims=True)


def rays_at(scene, rng, n):
    """Rays from about four sizes away towards random points of the shape's bounding box: many hit, some
    graze."""
    pts = np.concatenate([np.atleast_2d(x) for x in
                          [r.center + np.outer([-1, 1], r.size[0] / 2 * r.tangent + r.size[1] / 2 * r.bitangent)
                           for r in scene.rectangles] + [t.vertices for t in scene.triangles]
                          + [e.center + np.vstack([e.axes, -e.axes]) for e in scene.ellipsoids]])
    lo, hi = pts.min(0), pts.max(0)
    size = np.linalg.norm(hi - lo) + max((r.size.max() for r in scene.rectangles), default=0)
    target = rng.uniform(lo, hi, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return f32(target - 4 * size * d), f32(d), size


@pytest.mark.parametrize("name, scale, offset", CASES, ids=[f"{n}-s{s:g}-at{o:g}" for n, s, o in CASES])
def test_leaving_a_surface(harness, cornell, name, scale, offset):
    """For every hit: (1) the kernel's hit point is within its error bound of the stored surface; (2) the
    bound is tight enough to be useful: below 2^-14 of the magnitudes involved (the float32 spacing of the
    coordinates is 2^-24 of them, so this leaves a factor of 1024 for the gamma factors, which are at most
    13 roundings here); (3) the offset origin is strictly on the side the ray leaves to; (4) rays leaving from
    it in any direction of that side never hit the shape again (a plane, a triangle or the outside of an
    ellipsoid cannot be met again there). The raw hit point itself may lie up to its bound on the wrong side,
    where a ray leaving it does cross the surface: that is what the offset is for."""
    scene = scene_of(cornell, name, scale, offset)
    rng = np.random.default_rng(hash(name) % 2**32)
    n = 1024
    o, d, size = rays_at(scene, rng, n)
    w = rng.normal(size=(n, 3))
    out = harness.run(SOURCE, "leave", n, {**scene_args(scene), "o": planar(o), "d": planar(d), "w": planar(w)},
                      {"t": 1, "p": 3, "err": 1, "nrm": 3, "origin": 3, "again": 1},
                      HAS_RECTANGLES=int(bool(scene.rectangles)), HAS_TRIANGLES=int(bool(scene.triangles)),
                      HAS_ELLIPSOIDS=int(bool(scene.ellipsoids)))
    hit = np.isfinite(out["t"])
    assert np.count_nonzero(hit) > n // 8
    p, nrm, origin = out["p"].T[hit], out["nrm"].T[hit], out["origin"].T[hit]
    distance, outward = stored_surface(scene)
    side = np.sign(np.sum(nrm * outward(p), axis=1))  # +1 where the facing normal points outwards
    assert np.all(np.abs(distance(p)) <= out["err"][hit]), "the error bound holds"
    magnitude = np.abs(p).max(axis=1) + size * scale
    assert np.all(out["err"][hit] <= 2.0**-14 * magnitude), "the bound is not vacuous"
    assert np.all(side * distance(origin) > 0), "the offset origin is on the side it leaves to"
    assert not np.any(np.isfinite(out["again"][hit])), "no self-hit from the offset origin"


OFFSET = """
#include "ray.h"
__kernel void offset(int n, __global const float *p, __global const float *err, __global const float *nrm,
                     __global float *o)
{
    OUT3(o, offset_ray_origin(IN3(p), IN(err), IN3(nrm)));
}
"""


def test_offset_rounds_away(harness):
    """p + err n, rounded one float further along n: every coordinate moves by at least err |n_i| (exactly,
    in float64) where n_i != 0 and err > 0, and not at all where n_i = 0, including where err |n_i| is below
    half a float spacing of p_i and the plain sum would round back to p (the cases with err = 1e-3 ulp).
    Without the rounding step those stay at p."""
    rng = np.random.default_rng(23)
    n = 512
    p = (rng.uniform(-1, 1, (n, 3)) * 10.0 ** rng.integers(-3, 5, (n, 1))).astype(np.float32).astype(np.float64)
    nrm = rng.normal(size=(n, 3))
    nrm[::4, rng.integers(0, 3)] = 0.0
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = nrm.astype(np.float32).astype(np.float64)
    err = np.abs(p).max(1) * U * 10.0 ** rng.uniform(-3, 2, n)
    err[:8] = 0.0
    o = harness.run(OFFSET, "offset", n, [planar(p), err.astype(np.float32), planar(nrm)], {"o": 3})["o"].T
    err32 = err.astype(np.float32).astype(np.float64)
    moved = (o - p) * np.sign(nrm)
    need = err32[:, None] * np.abs(nrm)
    assert np.all(moved[nrm != 0] >= need[nrm != 0]) and np.all(moved[(nrm != 0) & (err32[:, None] > 0)] > 0)
    assert np.all(o[(nrm == 0) | (err32[:, None] == 0)] == p[(nrm == 0) | (err32[:, None] == 0)])


def points_on(scene, rng, n):
    """float32-rounded points of the scene's one shape (within half a float spacing of it, either side)."""
    if scene.rectangles:
        r = scene.rectangles[0]
        uv = rng.uniform(-0.5, 0.5, (n, 2)) * r.size
        p = r.center + uv[:, :1] * r.tangent + uv[:, 1:] * r.bitangent
    elif scene.triangles:
        b = rng.dirichlet(np.ones(3), n)
        p = b @ scene.triangles[0].vertices
    else:
        e = scene.ellipsoids[0]
        x = rng.normal(size=(n, 3))
        p = e.center + (x / np.linalg.norm(x, axis=1, keepdims=True)) @ e.axes
    return p.astype(np.float32).astype(np.float64)


@pytest.mark.parametrize("name, scale, offset", CASES, ids=[f"{n}-s{s:g}-at{o:g}" for n, s, o in CASES])
def test_rays_starting_on_the_surface(harness, cornell, name, scale, offset):
    """Rays from float32 points of a surface, leaving it (any direction for a plane, outwards for an
    ellipsoid), with no offset at all. Such a point lies up to half a float spacing off the stored surface,
    either side, so some of these rays do cross it at a tiny t, truly; the intersection routines must not
    report a crossing that does not exist, which their own rounding bounds decide (t > dt for planes and
    triangles, |c| within its bound for an ellipsoid's origin). Truth is float64 on the same float32 values.
    Without those bounds the routines report crossings from the wrong side (measured: without dt, 12 of
    the rectangle and 8 of the triangle cases fail; without the ellipsoid's bound on c, 14 of its cases)."""
    scene = scene_of(cornell, name, scale, offset)
    rng = np.random.default_rng(29)
    n = 1024
    o = points_on(scene, rng, n)
    d = rng.normal(size=(n, 3))
    distance, outward = stored_surface(scene)
    if scene.ellipsoids:
        d *= np.sign(np.sum(d * outward(o), axis=1))[:, None]
        crosses = distance(o) < 0  # inside, going out: it meets the surface once, at a tiny t
    else:
        crosses = -distance(o) / np.sum(d * outward(o), axis=1) > 0
    out = harness.run(CLOSEST_HIT, "closest", n, {**scene_args(scene), "o": planar(o), "d": planar(d)}, CLOSEST_HIT_OUTPUTS,
                      HAS_RECTANGLES=int(bool(scene.rectangles)), HAS_TRIANGLES=int(bool(scene.triangles)),
                      HAS_ELLIPSOIDS=int(bool(scene.ellipsoids)))
    hit = np.isfinite(out["t"])
    assert np.all(crosses[hit]), "no crossing from the wrong side"
