"""Texture coordinates, dp/du and dp/dv, tangent frames and ray differentials per shape (kernels/surface.cl,
camera.cl) against the float64 reference (tests/reference_textures.py)."""
import numpy as np
import pytest

import reference
import reference_textures as ref
from helpers import planar
from raytrace.scene import Ellipsoid, Rectangle, Triangle
from raytrace.renderer.packing import (camera_struct, ellipsoid_structs, rectangle_structs, triangle_structs,
                              triangle_uv_structs)

SOURCE = """
#include "camera.cl"
#include "surface.cl"
/* The 20 outputs of the lanes' surface points: uv, dpdu, dpdv, n, then the frame's t, b, n. */
inline void put(int n, __global float *out, const SurfaceLanes *lanes)
{
    Surface sp = surface_fill(lanes);
    Frame f = shading_frame(sp);
    OUT(out, sp.uv.x);
    OUT(out + n, sp.uv.y);
    vec3 v[6] = {sp.dpdu, sp.dpdv, sp.n, f.t, f.b, f.n};
    for (int c = 0; c < 6; ++c)
        OUT3(out + (2 + 3 * c) * n, v[c]);
}
/* Lane k of work-item I is element i = I LANES + k; each lane's surface point is scalar code. */
#define EACH(point) SurfaceLanes lanes; \
    for (int k = 0, i = I * LANES; k < LANES; ++k, ++i) set_surface_lane(&lanes, k, point)

__kernel void rectangle(int n, __global const Rectangle *r, __global const float *p, __global float *out)
{
    EACH(surface_rectangle(r, (float3)(p[i], p[i + n], p[i + 2 * n])));
    put(n, out, &lanes);
}

__kernel void triangle(int n, __global const Triangle *t, __global const TriangleUV *uv,
                       __global const float *b, __global float *out)
{
    EACH(surface_triangle(t, uv, b[i], b[i + n]));
    put(n, out, &lanes);
}

__kernel void ellipsoid(int n, __global const Ellipsoid *e, __global const float *p, __global float *out)
{
    EACH(surface_ellipsoid(e, (float3)(p[i], p[i + n], p[i + 2 * n])));
    put(n, out, &lanes);
}

/* (du/dx, dv/dx, du/dy, dv/dy) on a rectangle for camera rays with unit directions d hitting at p. */
__kernel void footprint(int n, __constant const Camera *cam, __global const Rectangle *r, float spacing,
                        float inv_w, float inv_h, __global const float *d, __global const float *p,
                        __global float *out)
{
    EACH(surface_rectangle(r, (float3)(p[i], p[i + n], p[i + 2 * n])));
    Surface sp = surface_fill(&lanes);
    vec3 dpdx, dpdy;
    camera_footprint(cam, spacing, inv_w, inv_h, IN3(d), IN3(p), sp.n, &dpdx, &dpdy);
    UVDerivatives duv = uv_derivatives(sp, dpdx, dpdy);
    OUT(out, duv.u_x);
    OUT(out + n, duv.v_x);
    OUT(out + 2 * n, duv.u_y);
    OUT(out + 3 * n, duv.v_y);
}
"""

KEYS = ("u", "v", "dpdu", "dpdv", "normal", "t", "b", "n_uv")


def unpack(out):
    """The kernel's 20 rows as a dict of N-vectors and N x 3 arrays."""
    rows = out.T
    parts = [rows[:, 0], rows[:, 1]] + [rows[:, k:k + 3] for k in range(2, 20, 3)]
    return dict(zip(KEYS, parts))


def check_frame(got, dpdu, dpdv):
    """Orthonormal, right-handed (t x b = n), t along dpdu's tangential part, b on dpdv's side: float32
    rounding of unit vectors (1e-5)."""
    t, b, n = got["t"], got["b"], got["n_uv"]
    for a, c in ((t, t), (b, b), (n, n)):
        np.testing.assert_allclose(np.einsum("ij,ij->i", a, c), 1, atol=1e-5)
    for a, c in ((t, b), (b, n), (n, t)):
        np.testing.assert_allclose(np.einsum("ij,ij->i", a, c), 0, atol=1e-5)
    np.testing.assert_allclose(np.cross(t, b), n, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", b, dpdv) >= -1e-6)
    assert np.all(np.einsum("ij,ij->i", t, dpdu) >= -1e-6)


def compare(got, want, atol):
    """Kernel against reference: uv and frame to atol, dpdu and dpdv relative to their size."""
    np.testing.assert_allclose(got["u"], want["u"], atol=atol)
    np.testing.assert_allclose(got["v"], want["v"], atol=atol)
    for key in ("dpdu", "dpdv"):
        scale = np.linalg.norm(want[key], axis=1, keepdims=True)
        np.testing.assert_allclose(got[key] / scale, want[key] / scale, atol=atol)
    frame = ref.shading_frame(want)
    for key, expected in zip(("t", "b", "n_uv"), frame):
        np.testing.assert_allclose(got[key], expected, atol=atol)
    check_frame(got, want["dpdu"], want["dpdv"])


RECTANGLES = [Rectangle(np.array([0.0, 0, 0]), np.array([2.0, 2.0]), np.array([0.0, 0, 1]), np.array([1.0, 0, 0])),
              Rectangle(np.array([0.3, -0.2, 0.5]), np.array([0.7, 1.9]), np.array([1.0, 2, 2]) / 3,
                        np.array([2.0, -2, 1]) / 3)]


@pytest.mark.parametrize("rect", RECTANGLES, ids=["floor", "oblique"])
def test_rectangle(harness, rect):
    """uv are float32 dot products of O(1) terms over sizes O(1): 1e-5."""
    rng = np.random.default_rng(0)
    uv = rng.uniform(0, 1, (64, 2))
    offset = uv - 0.5
    p = rect.center + offset[:, :1] * rect.size[0] * rect.tangent + offset[:, 1:] * rect.size[1] * rect.bitangent
    got = unpack(harness.run(SOURCE, "rectangle", 64, [rectangle_structs([rect]), planar(p)], {"out": 20})["out"])
    want = ref.rectangle_surface(rect.center, rect.size, rect.normal, rect.tangent, p)
    np.testing.assert_allclose(np.stack([want["u"], want["v"]], axis=1), uv)
    compare(got, want, 1e-5)


TRIANGLE_UVS = {"default": None, "given": np.array([[0.2, 0.1], [2.0, 0.4], [0.7, 1.5]]),
                "mirrored": np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]), "degenerate": np.full((3, 2), 0.5)}


@pytest.mark.parametrize("name", TRIANGLE_UVS)
def test_triangle(harness, name):
    """Per-vertex uv interpolated, dp/du dp/dv from the host's float64 solve (rounded once): 1e-5. A
    mirrored uv layout turns the frame's normal to the back; a degenerate one still gets a frame."""
    tri = Triangle(np.array([[0.1, 0.2, 0.3], [1.2, -0.3, 0.5], [0.4, 0.9, 1.1]]), 0, TRIANGLE_UVS[name])
    rng = np.random.default_rng(1)
    b = rng.dirichlet([1, 1, 1], 64)[:, 1:]
    args = [triangle_structs([tri]), triangle_uv_structs([tri]), np.ascontiguousarray(b.T)]
    got = unpack(harness.run(SOURCE, "triangle", 64, args, {"out": 20})["out"])
    want = ref.triangle_surface(tri.vertices, tri.uv, b[:, 0], b[:, 1])
    compare(got, want, 1e-5)
    flipped = np.einsum("ij,ij->i", got["n_uv"], want["normal"]) < 0
    assert np.all(flipped) if name == "mirrored" else not np.any(flipped)


ELLIPSOID = Ellipsoid(np.array([0.5, 0.4, 0.4]), np.array([[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.0, 0.0, 0.4]]))


def sphere_points(rng, n):
    """Random unit vectors plus the poles, points next to them, and both sides of the seam (theta = pi)."""
    q = rng.normal(size=(n, 3))
    special = [[0, 0, 1], [0, 0, -1], [1e-4, 0, 1], [0, -1e-4, -1], [-1, 1e-6, 0.3], [-1, -1e-6, 0.3],
               [-1, 0, -0.5], [-1, 1e-3, 0], [-1, -1e-3, 0]]
    q[: len(special)] = special
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e3])
def test_ellipsoid(harness, scale):
    """uv from atan2 of float32 unit-sphere points: 1e-5 (u compared modulo 1: the seam may fall on either
    side). dp/du and dp/dv relative 1e-5; at the poles dp/du vanishes, and the frame must still be a
    finite orthonormal frame, its tangent the limit M (-sin theta, cos theta, 0) of the reference."""
    e = Ellipsoid(ELLIPSOID.center * scale, ELLIPSOID.axes * scale)
    q = sphere_points(np.random.default_rng(2), 64)
    p = e.center + q @ e.matrix.T
    got = unpack(harness.run(SOURCE, "ellipsoid", 64, [ellipsoid_structs([e]), planar(p)], {"out": 20})["out"])
    want = ref.ellipsoid_surface(e.center, e.matrix, p)
    assert all(np.all(np.isfinite(v)) for v in got.values())
    du = got["u"] - want["u"]
    pole = np.abs(q[:, 2]) > 1 - 1e-6  # theta is meaningless there; only the frame's finiteness counts
    np.testing.assert_allclose((du - np.round(du))[~pole], 0, atol=1e-5)
    np.testing.assert_allclose(got["v"], want["v"], atol=1e-5)
    for key in ("dpdu", "dpdv"):
        scale_ = np.linalg.norm(want[key], axis=1, keepdims=True) + 1e-30
        np.testing.assert_allclose((got[key] / scale_)[~pole], (want[key] / scale_)[~pole], atol=1e-5)
    frame = ref.shading_frame(want)
    for key, expected in zip(("t", "b", "n_uv"), frame):
        np.testing.assert_allclose(got[key][~pole], expected[~pole], atol=1e-4)
    check_frame(got, want["dpdu"], want["dpdv"])
    np.testing.assert_allclose(got["n_uv"], want["normal"], atol=1e-5)  # outward: v runs south to north


def test_ray_differentials_on_a_plane(harness, cornell):
    """The analytic footprint of the kernel (offset camera rays meeting the tangent plane, then least
    squares for du, dv) against the reference's uv at the neighbouring pixel samples found by intersecting
    the float64 camera's rays with the floor: on a plane both are exact, so the bound is float32 rounding
    of differences of hit points (|p| ~ 3, footprint ~ 1e-3 of it): 1e-3 relative, plus 1e-7 absolute."""
    floor = Rectangle(np.zeros(3), np.array([100.0, 100.0]), np.array([0.0, 0, 1]), np.array([1.0, 0, 0]))
    width, height, spacing = 64, 48, 0.5
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, width, 256), rng.uniform(30, height, 256)   # the lower rows look at the floor
    cam = cornell.camera
    basis = ref.camera_basis(cam.position, cam.look_at, cam.ref_up)

    def uv_of_pixel(px, py):
        d = ref.camera_direction(basis, cam.fov_deg, cam.focal_length, width, height, px, py)
        t = reference.intersect_rectangle(floor, np.broadcast_to(cam.position, d.shape), d, 0, np.inf)
        s = ref.rectangle_surface(floor.center, floor.size, floor.normal, floor.tangent, cam.position + t[:, None] * d)
        return s["u"], s["v"]

    o, d = reference.camera_rays(cornell, x, y, width, height)
    t = reference.intersect_rectangle(floor, o, d, 0, np.inf)
    assert np.all(np.isfinite(t))
    args = [camera_struct(cam, width, height), rectangle_structs([floor]), np.float32(spacing),
            np.float32(1 / width), np.float32(1 / height), planar(d), planar(o + t[:, None] * d)]
    got = harness.run(SOURCE, "footprint", 256, args, {"out": 4})["out"]
    want = np.array(ref.footprint_by_offset_pixels(uv_of_pixel, x, y, spacing))
    np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-7)
    assert np.abs(want).max() > 1e-3, "a footprint that can be told from zero"


def test_footprints_of_the_thin_lens_and_orthographic_cameras(harness, cornell):
    """A thin lens's footprint is the pinhole's through the lens's centre and the hit (pbrt-v4's choice), whatever
    lens point the ray left: given a ray of another direction to the same floor point, the kernel's (u, v)
    derivatives are the pinhole's exact ones. An orthographic camera's neighbouring rays are its ray moved along
    the film (2 spacing / W of the view's width to the right, 2 spacing / H of its height down), parallel: the
    derivatives are the exact uv differences of those rays' floor hits. Tolerances as the pinhole's test above:
    float32 rounding of differences of hit points, 1e-3 relative plus 1e-7 absolute. Mutations tried, each
    failing it: the thin lens's footprint along the ray's own direction; the orthographic dp/dy not carried along
    the view to the plane; its dy upwards. (Its dp/dx not carried to the plane passes: the camera's right is
    horizontal, so that ray meets the floor where it starts.)"""
    import dataclasses
    floor = Rectangle(np.zeros(3), np.array([100.0, 100.0]), np.array([0.0, 0, 1]), np.array([1.0, 0, 0]))
    width, height, spacing = 64, 48, 0.5
    rng = np.random.default_rng(4)
    x, y = rng.uniform(0, width, 256), rng.uniform(30, height, 256)
    cam = cornell.camera
    basis = ref.camera_basis(cam.position, cam.look_at, cam.ref_up)

    def floor_uv(o, d):
        t = reference.intersect_rectangle(floor, o, d, 0, np.inf)
        s = ref.rectangle_surface(floor.center, floor.size, floor.normal, floor.tangent, o + t[:, None] * d)
        return s["u"], s["v"], o + t[:, None] * d

    def pinhole_uv(px, py):
        d = ref.camera_direction(basis, cam.fov_deg, cam.focal_length, width, height, px, py)
        return floor_uv(np.broadcast_to(cam.position, d.shape), d)[:2]

    o, d = reference.camera_rays(cornell, x, y, width, height)
    p = floor_uv(o, d)[2]
    assert np.all(np.isfinite(p))
    lens = dataclasses.replace(cam, kind="thinlens", aperture_radius=0.2, focus_distance=2.0)
    tilted = p - (cam.position + rng.uniform(-0.2, 0.2, (256, 3)))  # from some lens point to the hit
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    args = [camera_struct(lens, width, height), rectangle_structs([floor]), np.float32(spacing),
            np.float32(1 / width), np.float32(1 / height), planar(tilted), planar(p)]
    got = harness.run(SOURCE, "footprint", 256, args, {"out": 4}, HAS_THIN_LENS=1)["out"]
    np.testing.assert_allclose(got, np.array(ref.footprint_by_offset_pixels(pinhole_uv, x, y, spacing)), rtol=1e-3,
                               atol=1e-7)

    ortho = dataclasses.replace(cam, kind="orthographic", fov_deg=None, size=np.array([2.0, 1.5]))
    forward, right, up = cam.basis()

    def ortho_uv(px, py):
        o = (cam.position + ((2 * px / width - 1) * 1.0)[:, None] * right + ((1 - 2 * py / height) * 0.75)[:, None]
             * up)
        return floor_uv(o, np.broadcast_to(forward, o.shape))[:2]

    o = cam.position + ((2 * x / width - 1) * 1.0)[:, None] * right + ((1 - 2 * y / height) * 0.75)[:, None] * up
    p = floor_uv(o, np.broadcast_to(forward, o.shape))[2]
    assert np.all(np.isfinite(p))
    args = [camera_struct(ortho, width, height), rectangle_structs([floor]), np.float32(spacing),
            np.float32(1 / width), np.float32(1 / height), planar(np.broadcast_to(forward, o.shape)), planar(p)]
    got = harness.run(SOURCE, "footprint", 256, args, {"out": 4}, HAS_ORTHOGRAPHIC=1)["out"]
    want = np.array(ref.footprint_by_offset_pixels(ortho_uv, x, y, spacing))
    np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-7)
    assert np.abs(want).max() > 1e-3
