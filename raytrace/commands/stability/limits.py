"""Cases 9 and 10, image_sizes and deep_accumulation: image sizes and sample counts at their limits."""
import dataclasses

import numpy as np

from ...numerics import U
from ...scene.ranges import brightest
from .common import TINY, Row, nonfinite, outside


# ---------------------------------------------------------------------------------------------------------
# 9, 10. Image sizes and sample counts at their limits

def image_sizes(env):
    """Scene 0 through raytrace.render at 1 x 1, 1 x 4096 and 4096 x 1 (the last 179.93 degrees wide).

    The 1 x 1 pixel at 16 spp (the 4 x 4 grid) takes exactly the rays of a 4 x 4 image's pixel centres (the
    screen coordinates (k + 1/2) / 4 are exact in both), and the grid's light samples are the same in every
    pixel: it must equal that image's mean up to the kernel's float32 sum of its 16 samples (15 roundings of
    at most the sum) and one rounding of the result: 16u relative. The 1 x 4096 column takes the rays of the
    middle column of a 3 x 4096 image (same height; their screen x differ by one rounding of (2/3) 1.5 - 1, a
    direction change of 1e-11 rad), so its pixels must equal those to a few roundings of the shading: 8u
    relative. Every value lies in [0, brightest()], with no NaN or Inf."""
    cornell, limit = env.cornell, brightest(env.cornell)
    one, bad1 = env.render(cornell, width=1, height=1, spp=16, light_samples=16)
    grid, bad2 = env.render(cornell, width=4, height=4, spp=1, sampler="center", light_samples=16)
    column, bad3 = env.render(cornell, width=1, height=4096, spp=1, sampler="center", light_samples=4)
    wider, bad4 = env.render(cornell, width=3, height=4096, spp=1, sampler="center", light_samples=4)
    row, bad5 = env.render(cornell, width=4096, height=1, spp=1, sampler="center", light_samples=4)
    mean = grid.astype(np.float64).mean(axis=(0, 1))
    return [Row("1 x 1 at 16 spp against the mean of the same rays as a 4 x 4 image: relative",
                float(np.max(np.abs(one[0, 0] - mean) / mean) / U), "u", 16, "the kernel's float32 sum of 16",
                bad1 + bad2 + nonfinite(one, grid)),
            Row("1 x 4096 against the middle column of 3 x 4096: relative",
                float(np.max(np.abs(column[:, 0] - wider[:, 1]) / np.maximum(wider[:, 1], TINY)) / U), "u", 8,
                "the same rays to 1e-11 rad", bad3 + bad4 + nonfinite(column, wider)),
            Row(f"1 x 1, 1 x 4096, 4096 x 1: values outside [0, {limit:.3g}]", outside((one, column, row), limit),
                "values", 0, "max k (ambient + 2 sum L)", bad5 + nonfinite(row))]


def deep_accumulation(env):
    """65536 samples of one value: scene 0's back wall seen head-on through a 1 degree field of view (every
    sample sees it) under a black light (direct light exactly 0: every sample is k ambient = fl(0.7 * 0.1)
    exactly), 8 x 1 pixels, 1 light sample. The mean of 65536 equal float32 values must be that value to
    float32 rounding: the host accumulates in float64 (65536 additions of values below 1 lose at most 65536
    2^-53 of the sum) and rounds the mean to float32 once (u); 1e-6 is about 16u. A float32 sum of many
    samples anywhere on the way would show: a running float32 sum of n equal values drifts by up to n u / 2
    of their mean (2e-4 at n = 32768)."""
    camera = dataclasses.replace(env.cornell.camera, position=np.array([0.0, 0.0, 1.0]),
                                 look_at=np.array([0.0, 1.0, 1.0]), fov_deg=1.0)
    scene = dataclasses.replace(env.cornell, camera=camera,
                                lights=[dataclasses.replace(env.cornell.lights[0], colour=np.zeros(3))])
    single, bad1 = env.render(scene, width=8, height=1, spp=1, light_samples=1)
    deep, bad2 = env.render(scene, width=8, height=1, spp=65536, light_samples=1)
    return [Row("8 x 1 at 65536 spp of a constant against 1 spp: relative",
                float(np.max(np.abs(deep.astype(np.float64) - single) / single)), "", 1e-6,
                "float64 accumulation, one rounding", bad1 + bad2 + nonfinite(single, deep))]
