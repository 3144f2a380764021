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
