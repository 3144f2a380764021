"""Phong terms, light sample points and shadow rays (kernels/shading.cl, lights.cl, intersect.cl)."""
import dataclasses

import numpy as np

import reference
from conftest import planar
from raytrace import samplers
from raytrace.structs import light_structs
from raytrace.probe import scene_args

PHONG = """
#include "shading.cl"
__kernel void lobes(int n, __global const float *nrm, __global const float *l, __global const float *v,
                    float shininess, __global float *out)
{
    OUT(out, phong_lobes(IN3(nrm), IN3(l), IN3(v), (vfloat)(shininess)));
}

__kernel void points(int n, __global const Light *light, __global const float *uv, __global float *p)
{
    vec2 u = {IN(uv), IN(uv + n)};
    OUT3(p, light_point(light, u));
}
"""

SHADOW = """
#include "shading.cl"
__kernel void shadow(int n, __constant const RenderParams *params, __global const Rectangle *rects,
                     __global const Triangle *tris, __global const Ellipsoid *ells, __global const Light *lights,
                     __global const Material *materials, __global const float *p, __global const float *q,
                     __global float *blocked)
{
    const Scene s = {rects, tris, 0, 0, ells, lights, materials, 0, params};
    vec3 from = IN3(p);
    Ray r = {from, v3_sub(IN3(q), from)};
    OUT(blocked, MASK_TO_ONE(occluded(&s, r)));
}

/* The renderer's own way off a surface: the camera ray's hit, its offset origin, the segment to q. */
__kernel void leave(int n, __constant const RenderParams *params, __global const Rectangle *rects,
                    __global const Triangle *tris, __global const Ellipsoid *ells, __global const Light *lights,
                    __global const Material *materials, __global const float *o, __global const float *d,
                    __global const float *q, __global float *blocked)
{
    const Scene s = {rects, tris, 0, 0, ells, lights, materials, 0, params};
    Ray r = {IN3(o), IN3(d)};
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    vec3 origin = offset_ray_origin(hit.p, hit.err, hit.n);
    OUT(blocked, MASK_TO_ONE(occluded(&s, shadow_segment(origin, IN3(q), light_point_error(lights),
                                                         v3_uniform(lights->shape.normal)))));
}
"""


def unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_phong_lobes(harness):
    """max(0, n.l) + max(0, r.v)^s with r = 2(n.l)n - l, against float64; exp2(s log2 x) in float32 is good
    to about s * 2^-22 relative, so 1e-5 absolute for terms <= 2 and s <= 64."""
    rng = np.random.default_rng(13)
    n = 512
    nrm, l, v = (unit(rng.normal(size=(n, 3))) for _ in range(3))
    l[:64] = nrm[:64]  # mirror cases: r = n, r.v = n.v
    for s in (1.0, 16.0, 64.0):
        out = harness.run(PHONG, "lobes", n, [planar(nrm), planar(l), planar(v), np.float32(s)], {"out": 1})
        ndl = np.sum(nrm * l, 1)
        r = 2 * ndl[:, None] * nrm - l
        ref = np.maximum(ndl, 0) + np.maximum(np.sum(r * v, 1), 0) ** s
        np.testing.assert_allclose(out["out"], ref, atol=1e-5)


def test_light_points(harness, cornell):
    light = cornell.lights[0]
    uv = samplers.grid(16)
    out = harness.run(PHONG, "points", 16, [light_structs([light]), planar(uv)], {"p": 3})
    np.testing.assert_allclose(out["p"].T, reference.light_points(light, uv), atol=1e-7)
    assert np.allclose(out["p"][2], 1.95) and out["p"][0].min() > -0.25 and out["p"][1].max() < 0.15


def test_shadow_rays(harness, cornell):
    """Segments from visible surface points to light samples: blocked exactly when the float64
    reference is, except segments passing within 1e-3 of an occluder's silhouette."""
    rng = np.random.default_rng(17)
    n = 2048
    o = np.tile(cornell.camera.position, (n, 1))
    d = unit(rng.normal([0, 1, -0.2], [0.35, 0.1, 0.3], (n, 3)))
    hit = reference.closest_hit(cornell, o, d, tmin=0.0)
    ok = (hit["material"] >= 0)
    p = o + np.where(ok, hit["t"], 0)[:, None] * d  # rays that see nothing or the light: any finite point
    p_off = p + hit["normal"] * 2.44140625e-4 * (1 + np.abs(p).max(1, keepdims=True))
    q = reference.light_points(cornell.lights[0], rng.uniform(0, 1, (n, 2)))
    ref = reference.occluded(cornell, p_off, q)
    out = harness.run(SHADOW, "shadow", n, [*scene_args(cornell), planar(p_off), planar(q)], {"blocked": 1},
                      HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)["blocked"] > 0
    # silhouette: nudging the light point by 1e-3 changes the reference's answer
    nudged = [reference.occluded(cornell, p_off, q + dq) for dq in np.eye(3) * 1e-3]
    clear = ok & np.all([x == ref for x in nudged], axis=0)
    assert np.count_nonzero(clear & ref) > 100 and np.count_nonzero(clear & ~ref) > 100
    np.testing.assert_array_equal(out[clear], ref[clear])


def test_no_acne(harness, cornell):
    """Shadow segments from camera-ray hits on every surface to the light's centre, leaving as the renderer
    does (the hit point's error-bounded offset, the segment's end pushed off the light), are never blocked
    where the float64 reference says the point is lit: no surface shadows itself. Also with the light moved
    up into the ceiling's plane (flush, the segment ends on the ceiling): the ceiling does not block it."""
    rng = np.random.default_rng(19)
    n = 2048
    o = np.tile(cornell.camera.position, (n, 1)).astype(np.float32).astype(float)
    d = unit(rng.normal([0, 1, -0.1], [0.4, 0.1, 0.4], (n, 3))).astype(np.float32).astype(float)
    for light in (cornell.lights[0], dataclasses.replace(cornell.lights[0], center=np.array([0.0, 0.0, 2.0]))):
        scene = dataclasses.replace(cornell, lights=[light])
        hit = reference.closest_hit(scene, o, d, tmin=0.0)
        on_surface = hit["material"] >= 0
        p = o + np.where(on_surface, hit["t"], 0)[:, None] * d
        q = np.tile(light.center, (n, 1))
        lit = on_surface & (np.sum(hit["normal"] * (q - p), 1) > 0) & ~reference.occluded(scene, p, q)
        out = harness.run(SHADOW, "leave", n, [*scene_args(scene), planar(o), planar(d), planar(q)],
                          {"blocked": 1}, HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)["blocked"] > 0
        assert np.count_nonzero(lit) > 500
        assert not np.any(out[lit])
