"""Camera rays (kernels/camera.cl) against the float64 reference (docs/model.md, camera)."""
import numpy as np
import pytest

import reference
from raytrace.renderer.packing import camera_struct

SOURCE = """
#include "camera.cl"
__kernel void rays(int n, __constant const Camera *cam, __global const float *x, __global const float *y,
                   __global float *o, __global float *d)
{
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    Ray r = generate_camera_ray(cam, IN(x), IN(y), lens, &tmax);
    OUT3(o, r.o);
    OUT3(d, r.d);
}
"""

# A direction is the normalised sum of three float32 products with components of size <= ~2: a few
# roundings of 2^-24 each, so 2e-6 absolute per component bounds it with room, and still fails for any
# formula error (a wrong sign, the report's doubled focal length, a swapped axis moves it by >= 1e-2).
TOL = 2e-6


def run_rays(harness, scene, x, y, width, height):
    cam = camera_struct(scene.camera, width, height)
    out = harness.run(SOURCE, "rays", len(x), [cam, x.astype(np.float32), y.astype(np.float32)], {"o": 3, "d": 3})
    return out["o"].T, out["d"].T


@pytest.mark.parametrize("width,height", [(64, 64), (96, 48), (40, 80)])
def test_rays_match_reference(harness, cornell, width, height):
    rng = np.random.default_rng(1)
    corners = np.array([[0, 0], [width, 0], [0, height], [width, height], [width / 2, height / 2]], float)
    xy = np.concatenate([corners, rng.uniform(0, 1, (59, 2)) * [width, height]])
    o, d = run_rays(harness, cornell, xy[:, 0], xy[:, 1], width, height)
    ro, rd = reference.camera_rays(cornell, xy[:, 0], xy[:, 1], width, height)
    np.testing.assert_allclose(o, ro, atol=1e-7)
    np.testing.assert_allclose(d, rd, atol=TOL)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=TOL)


def test_orientation_and_aspect(harness, cornell):
    """Centre looks at look_at; top-left goes up and left; the horizontal half-angle follows W/H."""
    w, h = 80, 40
    x = np.array([w / 2, 0, w, w / 2, w / 2] + [w / 2] * 3, float)
    y = np.array([h / 2, 0, h, 0, h] + [h / 2] * 3, float)
    _, d = run_rays(harness, cornell, x, y, w, h)
    forward, right, up = cornell.camera.basis()
    np.testing.assert_allclose(d[0], forward, atol=TOL)
    assert d[1] @ right < 0 and d[1] @ up > 0      # pixel (0, 0) is top left
    assert d[2] @ right > 0 and d[2] @ up < 0      # pixel (W, H) is bottom right
    tan_v = np.tan(np.radians(cornell.camera.fov_deg) / 2)
    assert (d[3] @ up) / (d[3] @ forward) == pytest.approx(tan_v, rel=1e-5)   # vertical fov
    assert (d[2] @ right) / (d[2] @ forward) == pytest.approx(tan_v * w / h, rel=1e-5)  # aspect


LENS_SOURCE = """
#include "camera.cl"
__kernel void rays(int n, __constant const Camera *cam, __global const float *x, __global const float *y,
                   __global const float *u, __global const float *v, __global float *o, __global float *d,
                   __global float *tmax)
{
    vec2 lens = {IN(u), IN(v)};
    vfloat far;
    Ray r = generate_camera_ray(cam, IN(x), IN(y), lens, &far);
    OUT3(o, r.o);
    OUT3(d, r.d);
    OUT(tmax, far);
}
"""


def concentric(u, v):
    """Shirley and Chiu's concentric map of [0, 1)^2 to the unit disk (pbrt-v4 section A.5.1), in float64."""
    a, b = 2 * u - 1, 2 * v - 1
    first = np.abs(a) > np.abs(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(first, a, b)
        phi = np.where(first, np.pi / 4 * b / a, np.pi / 2 - np.pi / 4 * a / b)
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


def camera_reference(camera, x, y, u, v, width, height):
    """(origins, directions, tmax) in float64 of docs/model.md's cameras: Mitsuba's perspective, thinlens and
    orthographic sample_ray, the ray from the near plane to the far one."""
    forward, right, up = camera.basis()
    sx, sy = 2 * x / width - 1, 1 - 2 * y / height
    if camera.kind == "orthographic":
        o = (camera.position + camera.near_clip * forward + (sx * camera.size[0] / 2)[:, None] * right
             + (sy * camera.size[1] / 2)[:, None] * up)
        return o, np.broadcast_to(forward, o.shape), np.full(len(x), camera.far_clip - camera.near_clip)
    t = np.tan(np.radians(camera.fov_deg) / 2)
    d = forward + (sx * t * width / height)[:, None] * right + (sy * t)[:, None] * up
    o = np.broadcast_to(camera.position, d.shape).copy()
    if camera.kind == "thinlens":
        lx, ly = concentric(u, v)
        aperture = camera.aperture_radius * (lx[:, None] * right + ly[:, None] * up)
        d, o = camera.focus_distance * d - aperture, o + aperture
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    cos = d @ forward
    near, far = camera.near_clip / cos, camera.far_clip / cos
    return o + near[:, None] * d, d, far - near


CAMERAS = {"pinhole clipped": dict(near_clip=0.5, far_clip=7.0),
           "thin lens": dict(kind="thinlens", aperture_radius=0.2, focus_distance=3.5, near_clip=0.01, far_clip=1e4),
           "orthographic": dict(kind="orthographic", fov_deg=None, size=np.array([3.0, 1.5]), near_clip=0.25,
                                far_clip=9.0)}


@pytest.mark.parametrize("case", list(CAMERAS))
def test_camera_types_match_reference(harness, cornell, case):
    """Each camera type's rays, with clip planes, against the float64 reference (Mitsuba's sensors), 96 x 48
    pixels: a pinhole's whose origins move to the near plane (its t = near / cos), a thin lens's from its lens
    points (the concentric map of (u, v)) to the focal plane, an orthographic's parallel ones from the near
    plane's points. Tolerances: directions as TOL (a thin lens's sum has one more term and its difference
    from the lens point, a few roundings more of terms of size <= 4: 4e-6); origins within 1e-6 of the
    reference's coordinates of size <= 4 (products and sums of a few roundings, 2^-24 each); tmax within 1e-6
    relative. Mutations tried, each failing it: a thin lens's origin left at the eye; its direction to the
    image plane's point rather than the focal plane's; the near offset not over the cosine; an orthographic
    tmax of far_clip alone."""
    import dataclasses
    camera = dataclasses.replace(cornell.camera, **CAMERAS[case])
    width, height = 96, 48
    rng = np.random.default_rng(7)
    n = 200
    x, y = rng.uniform(0, width, n), rng.uniform(0, height, n)
    u, v = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    u[:4], v[:4] = [0.5, 0.0, 0.99, 0.5], [0.5, 0.3, 0.5, 0.0]  # the centre, the disk's edges
    defines = {"HAS_THIN_LENS": camera.kind == "thinlens", "HAS_ORTHOGRAPHIC": camera.kind == "orthographic"}
    out = harness.run(LENS_SOURCE, "rays", n, [camera_struct(camera, width, height), *(a.astype(np.float32)
                                                                                     for a in (x, y, u, v))],
                      {"o": 3, "d": 3, "tmax": 1}, **defines)
    x, y, u, v = (a.astype(np.float32).astype(np.float64) for a in (x, y, u, v))
    ro, rd, rt = camera_reference(camera, x, y, u, v, width, height)
    np.testing.assert_allclose(out["d"].T, rd, atol=4e-6)
    np.testing.assert_allclose(out["o"].T, ro, atol=1e-6 * 4)
    np.testing.assert_allclose(out["tmax"], rt, rtol=1e-6)


def test_default_clip_planes_leave_the_pinhole_ray_as_it_was(harness, cornell):
    """A camera without clip planes (near 0, far infinity) gives the eye as the origin, exactly, and tmax
    infinity: the pinhole's images stay bit for bit what they were."""
    width, height = 64, 48
    x, y = np.linspace(0, width, 64), np.linspace(0, height, 64)
    zero = np.zeros(64)
    out = harness.run(LENS_SOURCE, "rays", 64, [camera_struct(cornell.camera, width, height),
                                                *(a.astype(np.float32) for a in (x, y, zero, zero))],
                      {"o": 3, "d": 3, "tmax": 1})
    assert np.array_equal(out["o"].T, np.broadcast_to(cornell.camera.position.astype(np.float32), (64, 3)))
    assert np.all(np.isinf(out["tmax"]))
