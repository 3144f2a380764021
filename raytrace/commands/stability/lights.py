"""Case 5, lights_at_horizon: lights on the horizon of the shaded point, or below it."""
import dataclasses

import numpy as np

from ... import samplers
from .probe import planar, scene_args
from ...scene import Light
from ...numerics import f32
from .common import Row, nonfinite, shapes, unit


# ---------------------------------------------------------------------------------------------------------
# 5. Lights on the horizon of the shaded point

SHADE = """
#include "shading.cl"
__kernel void shade_at(int n, SCENE_PARAMETERS, __global const uint2 *light_samples,
                       __global const float *p, __global const float *nrm, __global const float *d,
                       __global float *colour)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    Ray r = {v3_sub(IN3(p), IN3(d)), IN3(d)};
    Hit hit;
    hit.t = 1.0f;
    hit.p = IN3(p);
    hit.err = 0.0f;
    hit.n = IN3(nrm);
    hit.material = (vint)(0);
    hit.emitted = v3_splat(0.0f, 0.0f, 0.0f);
    ShadingPoint sp = {IN3(p), (vfloat)(0.0f), IN3(nrm), IN3(nrm), v3_splat(1.0f, 1.0f, 1.0f),
                       (vfloat)(materials[0].shininess)};
    vfloat rays = 0.0f;
    PixelSample ps = start_pixel_sample((vuint)(0), (vint)(0));
    ps.dimension = 1;
    OUT3(colour, shade(&s, r, hit, sp, light_samples, &ps, &rays));
}
"""
AMBIENT = np.array([0.1, 0.2, 0.3])


def shade(env, light, p, n, d):
    """shade() at points p of a surface with normal n, seen along d (colour k = 1, shininess 16), under one
    light with 16 grid samples, ambient AMBIENT, nothing in the way: (m, 3) colours."""
    scene = dataclasses.replace(shapes(env), lights=[light], ambient=AMBIENT)
    grid = samplers.pattern("grid", 16)
    args = {**scene_args(scene, light_samples=16, light_pattern=grid), "light_samples": grid.table(),
            "p": planar(p), "nrm": planar(n), "d": planar(d)}
    return env.probe.run(SHADE, "shade_at", len(p), args, {"colour": 3})["colour"].T


def lights_at_horizon(env):
    """shade() where every light sample lies on the shaded point's horizon or below it must return the
    ambient term exactly (k = 1: the ambient colour itself), with no NaN: samples at n.l <= 0 add nothing
    (docs/model.md), and nothing here may round them above.

    On the horizon: a light lying in the surface's own plane, for planes normal to each axis (either side):
    there q - p has an exact zero along the normal, so n.l is exactly 0; a quarter of the points sit on
    light samples (q = p, where l = normalize(0) is NaN and must not leak). Not on tilted planes: their float32
    points lie up to half a spacing either side of the plane, so that even float64 on the same values puts
    such samples above or below at random. Below the horizon: points of tilted planes under a small light
    1e-2 or 1e-5 rad below their horizon, far beyond the rounding of n.l (a few u). Bound 0 for both."""
    rng = np.random.default_rng(5)
    m, on, below = 256, [], []
    for k in range(3):  # a 1 x 1 light in the plane x_k = 0.75: its 4 x 4 grid samples are exact floats
        normal, tangent = np.eye(3)[k], np.eye(3)[(k + 1) % 3]
        p = f32(rng.uniform(-1, 1, (m, 3)))
        p[: m // 4, (k + 1) % 3], p[: m // 4, (k + 2) % 3] = rng.choice([-0.375, -0.125, 0.125, 0.375], (2, m // 4))
        p[:, k] = 0.75
        n = normal * rng.choice([-1.0, 1.0], (m, 1))
        view = f32(unit(-n + 0.8 * unit(rng.normal(size=(m, 3)))))
        on.append(shade(env, Light(0.75 * normal, np.ones(2), normal, tangent), p, n, view))
    for angle in (1e-2, 1e-5):
        p, centre = f32(rng.uniform(-1, 1, (m, 3))), np.array([0.3, -0.2, 2.5])
        towards = unit(centre - p)
        n = f32(np.cos(angle) * unit(np.cross(towards, rng.normal(size=(m, 3)))) - np.sin(angle) * towards)
        size = 0.1 * angle * np.linalg.norm(centre - p, axis=1).min() * np.ones(2)  # within 0.15 angle of centre
        light = Light(centre, size, np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0]))
        below.append(shade(env, light, p, n, f32(unit(-n + 0.8 * unit(rng.normal(size=(m, 3)))))))
    ambient = f32(AMBIENT)
    return [Row(f"light in the shaded plane, samples on 1/4 of the points: |colour - ambient| (of {3 * m})",
                float(np.max(np.abs(np.concatenate(on) - ambient))), "", 0, "n.l = 0 exactly adds nothing",
                nonfinite(*on)),
            Row(f"light 1e-2 and 1e-5 rad below the horizon: |colour - ambient| (of {2 * m})",
                float(np.max(np.abs(np.concatenate(below) - ambient))), "", 0, "n.l < 0 adds nothing",
                nonfinite(*below))]
