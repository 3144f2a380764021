"""Cases 7 and 8, extreme_fov and far_camera: camera rays at extreme fields of view; a camera far away."""
import dataclasses

import numpy as np

from .reference_camera import camera_directions
from ...numerics import U, f32, rmse
from ...renderer.packing import camera_struct
from .common import Row, nonfinite


# ---------------------------------------------------------------------------------------------------------
# 7. Camera rays at extreme fields of view

CAMERA = """
#include "camera.cl"
__kernel void rays(int n, __constant const Camera *cam, __global const float *x, __global const float *y,
                   __global float *d)
{
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    OUT3(d, generate_camera_ray(cam, IN(x), IN(y), lens, &tmax).d);
}
"""


def extreme_fov(env):
    """Camera rays of scene 0's camera with vertical fields of view of 1e-3 and 179.9 degrees, 64 x 48, at a
    127 x 95 grid of pixel positions from corner to corner plus the centre's row and column; against the
    docs/model.md's camera in float64.

    d = f forward + sx right + sy up, sx = (2x/W - 1) scale_x: the screen coordinate carries at most 5u
    (1/W rounded, a product and a sum), so sx at most 5u scale_x + 2u |sx| (scale_x stored, the product);
    the stored basis and the two mads add at most 4u of each term. So |dd| <= 6u (f + |sx| + |sy| + scale_x
    + scale_y), and the direction moves by at most |dd| / |d|, plus u when normalised: 7u k, k = (f + |sx| +
    |sy| + scale_x + scale_y) / |d|. Near 180 degrees k is large at the centre, where tan(fov/2) magnifies
    the screen coordinate's rounding: the map's conditioning. The length: d.d rounds five times (half that
    in its root), rsqrt to 2 ulp (4u), the product once: ||d| - 1| <= 7.5u."""
    w, h = 64, 48
    x, y = (a.ravel() for a in np.meshgrid(f32([*np.linspace(0, w, 127), w / 2]),
                                           f32([*np.linspace(0, h, 95), h / 2])))
    rows = []
    for fov in (1e-3, 179.9):
        camera = dataclasses.replace(env.cornell.camera, fov_deg=fov)
        args = [camera_struct(camera, w, h), x.astype(np.float32), y.astype(np.float32)]
        d = env.probe.run(CAMERA, "rays", len(x), args, {"d": 3})["d"].T
        truth, k = camera_directions(camera, x, y, w, h)
        length = np.linalg.norm(d, axis=1)
        rows += [Row(f"fov {fov:g} deg: direction error (of {len(x)}, k up to {k.max():.3g})",
                     float(np.max(np.linalg.norm(d / length[:, None] - truth, axis=1) / (U * k))), "u k", 7,
                     "screen 5u, scale 2u, basis and mads 4u", nonfinite(d)),
                 Row(f"fov {fov:g} deg: |length - 1|", float(np.max(np.abs(length - 1)) / U), "u", 7.5,
                     "d.d 2.5u, rsqrt 4u, product u")]
    return rows


# ---------------------------------------------------------------------------------------------------------
# 8. A camera far away

def seen_from(scene, distance, shift=(0.0, 0.0, 0.0)):
    """`scene` with its camera moved along its axis to `distance` from look_at, its field of view narrowed to
    frame the look_at plane alike, then both camera points moved by `shift`."""
    cam = scene.camera
    axis = cam.position - cam.look_at
    tan_half = np.tan(np.radians(cam.fov_deg) / 2) * np.linalg.norm(axis) / distance
    camera = dataclasses.replace(cam, position=cam.look_at + axis * distance / np.linalg.norm(axis) + shift,
                                 look_at=cam.look_at + shift, fov_deg=float(np.degrees(2 * np.arctan(tan_half))))
    return dataclasses.replace(scene, camera=camera)


def far_camera(env):
    """Scene 0 seen from 1e5 units away on the course camera's axis, through the field of view (1.4e-3
    degrees) that frames the look_at plane as the course camera does; 48 x 48, 16 x 16 grid samples.

    Compared with the view from 1e3 units away on the same axis: float32 moves the far camera's position by
    up to 4e-3, and the near camera is moved alike, so that both share the axis the kernel sees. (The course
    camera itself, 3 units away at 45 degrees, sees another picture: its perspective shows the side walls,
    which the far camera sees edge-on.) From 1e3 to 1e5 units the perspective moves the image of a point at
    depth z and off-axis distance x by x z (1/1e3 - 1/1e5): at most 1.9e-3 units, 0.04 pixels; the near
    camera's own float32 error is 1% of the far one's. What remains is float32 at 1e5 units: one rounding
    there moves a hit point across the ray by u 1e5 = 6e-3 units (0.11 pixels), and the camera ray, the
    crossing's (u, v) and the triangle test's shear each take a few; the ellipsoid's normal, computed from its
    unit-sphere hit 3e5 radii from the ray's origin, tilts by about u 3e5 = 0.02 rad per rounding. A known
    limit, held to what a misregistration by that resolution costs: u 1e5 over the pixel's width in scene
    units (0.12 pixels here) times the RMSE between the near view and itself moved by one pixel (the smaller
    of x and y)."""
    far = seen_from(env.cornell, 1e5)
    image, bad = env.render(far, width=48, height=48, spp=16, light_samples=16)
    moved = f32(far.camera.position) - far.camera.position
    near, bad_near = env.render(seen_from(env.cornell, 1e3, moved), width=48, height=48, spp=16, light_samples=16)
    shifted = min(rmse(near[1:], near[:-1]), rmse(near[:, 1:], near[:, :-1]))
    pixel = 2 * np.tan(np.radians(far.camera.fov_deg) / 2) * 1e5 / 48  # scene units across one pixel
    resolution = U * 1e5 / pixel
    return [Row("camera 1e5 away, fov 1.4e-3 deg: RMSE against the same view from 1e3 away", rmse(image, near),
                "", resolution * shifted, f"a shift by float32's resolution there, {resolution:.2f} pixels",
                bad + bad_near + nonfinite(image, near), known_limit=True)]
