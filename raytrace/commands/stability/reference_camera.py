"""The camera model of docs/model.md in float64: the reference that the camera's kernel tests (tests/reference.py)
and the stability suite (stability/camera.py) hold kernels/camera.cl to. It uses nothing of the renderer's
host code, only the scene's Camera (its float64 basis)."""
import numpy as np


def camera_directions(camera, x, y, width, height):
    """Unit directions of the rays through continuous pixel coordinates (x, y) of a width x height image (row
    0 at the top), and their condition numbers (f + |sx| + |sy| + scale_x + scale_y) / |f forward + sx right
    + sy up|: how much the rounding of the terms can move the direction, relative to its length."""
    forward, right, up = camera.basis()
    f, tan_half = camera.focal_length, np.tan(np.radians(camera.fov_deg) / 2)
    x, y = np.asarray(x, np.float64).ravel(), np.asarray(y, np.float64).ravel()
    sx = (2 * x / width - 1) * width / height * f * tan_half
    sy = (1 - 2 * y / height) * f * tan_half
    d = f * forward + sx[:, None] * right + sy[:, None] * up
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], (f + np.abs(sx) + np.abs(sy) + f * tan_half * (1 + width / height)) / length
