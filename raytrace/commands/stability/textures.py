"""Case 12, textured_grazing: textures at grazing angles."""
import dataclasses

import numpy as np

from ...scene import load_file
from ...scene.ranges import brightest
from .common import SCENES, Row, nonfinite, outside


# ---------------------------------------------------------------------------------------------------------
# 12. Textures at grazing angles

def textured_grazing(env):
    """The grid floor (scene 1, textured) seen along its plane from 1e-2, 1e-4 and 1e-6 above it and from
    in it, under each texture filter, and the textured shapes (their silhouettes are grazing), 64 x 64: the
    ray differentials divide by d.n, which vanishes there, so that a filter footprint grows without bound.
    No NaN or Inf may reach the image, and every value lies in [0, brightest()] (colour maps are at most 1)."""
    floor, textured = load_file(SCENES / "grid_floor.toml"), load_file(SCENES / "textured_shapes.toml")
    images, bad = [], 0
    for height in (1e-2, 1e-4, 1e-6, 0.0):
        camera = dataclasses.replace(floor.camera, position=np.array([0.0, -2.0, height]),
                                     look_at=np.array([0.0, 30.0, height]), fov_deg=10.0)
        for texture_filter in ("nearest", "trilinear", "anisotropic"):
            image, b = env.render(dataclasses.replace(floor, camera=camera), width=64, height=64, spp=4,
                                  light_samples=4, texture_filter=texture_filter)
            images.append(image)
            bad += b + nonfinite(image)
    image, b = env.render(textured, width=64, height=64, spp=4, light_samples=4, texture_filter="anisotropic")
    limit = max(brightest(floor), brightest(textured))
    return [Row(f"grid floor from 1e-2..0 above, 3 filters, and textured shapes: values outside [0, {limit:.3g}]",
                outside(images + [image], limit), "values", 0, "max k (ambient + 2 sum L)", bad + b + nonfinite(image))]
