"""Rendering a Scene: struct buffers, the specialised program, banded launches, statistics."""
import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from . import samplers, types
from .device import context_for, default_lanes, describe, select_device
from .errors import InputError
from .kernel import Features, render_program

MAX_SPP = 1 << 16


@dataclass
class RenderOptions:
    width: int | None = None
    height: int | None = None
    spp: int | None = None
    light_samples: int | None = None
    sampler: str | None = None
    seed: int = 0
    device: str | None = None
    lanes: int | None = None
    features: Features | None = None  # None: derived from the scene
    progress: bool | None = None      # None: a bar on stderr when the render takes over a second


@dataclass
class RenderStats:
    render_seconds: float
    build_seconds: float
    rays: int
    mrays_per_s: float
    device: str
    build_options: list
    width: int
    height: int
    spp: int
    light_samples: int
    sampler: str
    seed: int
    extra: dict = field(default_factory=dict)


def _vec(a):
    return np.asarray(a, dtype=np.float32)


def camera_struct(camera, width, height):
    forward, right, up = camera.basis()
    tan_half = math.tan(math.radians(camera.fov_deg) / 2)
    c = np.zeros((), types.CAMERA)
    c["position"], c["forward"], c["right"], c["up"] = camera.position, forward, right, up
    c["scale_x"] = width / height * camera.focal_length * tan_half
    c["scale_y"] = camera.focal_length * tan_half
    c["focal_length"] = camera.focal_length
    return c


def rectangle_structs(rects):
    a = np.zeros(max(len(rects), 1), types.RECTANGLE)
    for s, r in zip(a, rects):
        s["center"], s["normal"], s["tangent"], s["bitangent"] = r.center, r.normal, r.tangent, r.bitangent
        s["half_x"], s["half_y"], s["material"] = r.size[0] / 2, r.size[1] / 2, r.material
    return a


def triangle_structs(tris):
    a = np.zeros(max(len(tris), 1), types.TRIANGLE)
    for s, t in zip(a, tris):
        v0, v1, v2 = t.vertices
        n = np.cross(v1 - v0, v2 - v1)
        s["v0"], s["v1"], s["v2"], s["normal"], s["material"] = v0, v1, v2, n / np.linalg.norm(n), t.material
    return a


def ellipsoid_structs(ells):
    a = np.zeros(max(len(ells), 1), types.ELLIPSOID)
    for s, e in zip(a, ells):
        s["center"], s["material"] = e.center, e.material
        s["world_to_unit"] = np.linalg.inv(e.matrix).ravel()  # float64 inverse, rounded once
    return a


def light_structs(lights):
    a = np.zeros(len(lights), types.LIGHT)
    a["shape"] = rectangle_structs(lights)
    for s, light in zip(a, lights):
        s["colour"] = light.colour
    return a


def material_structs(materials):
    a = np.zeros(len(materials), types.MATERIAL)
    for s, m in zip(a, materials):
        s["colour"], s["shininess"] = m.colour, m.shininess
    return a


def params_struct(scene, spp=1, light_samples=1, width=1, height=1):
    p = np.zeros((), types.RENDER_PARAMS)
    p["ambient"] = scene.ambient
    p["n_rectangles"], p["n_triangles"] = len(scene.rectangles), len(scene.triangles)
    p["n_ellipsoids"], p["n_lights"] = len(scene.ellipsoids), len(scene.lights)
    p["spp"], p["light_samples"], p["width"], p["height"] = spp, light_samples, width, height
    return p


def _option(value, source, key, check, problem):
    if not check(value):
        raise InputError(source, key, value, problem)
    return value


def resolve(scene, options):
    """Command-line overrides on top of the scene's own settings, validated."""
    cli = "command line"
    pick = lambda value, default: default if value is None else value  # noqa: E731
    width = _option(pick(options.width, scene.width), cli, "--width", lambda v: 1 <= v <= 16384,
                    "must be in [1, 16384]")
    height = _option(pick(options.height, scene.height), cli, "--height", lambda v: 1 <= v <= 16384,
                     "must be in [1, 16384]")
    spp = _option(pick(options.spp, scene.spp), cli, "--spp", lambda v: 1 <= v <= MAX_SPP,
                  f"must be in [1, {MAX_SPP}]")
    nl = _option(pick(options.light_samples, scene.light_samples), cli, "--light-samples",
                 lambda v: 1 <= v <= MAX_SPP, f"must be in [1, {MAX_SPP}]")
    sampler = _option(pick(options.sampler, scene.sampler), cli, "--sampler", lambda v: v in samplers.PIXEL_SAMPLERS,
                      f"unknown sampler (have: {', '.join(samplers.PIXEL_SAMPLERS)})")
    if sampler == "grid":
        _option(spp, cli, "--spp", samplers.is_square, "the grid sampler needs a square number (1, 4, 9, 16, ...)")
    if sampler == "center":
        _option(spp, cli, "--spp", lambda v: v == 1, "the center sampler takes exactly one sample")
    return width, height, spp, nl, sampler


def render(scene, **kwargs):
    """Render `scene`; returns (H x W x 3 float32 linear image, RenderStats)."""
    options = RenderOptions(**kwargs)
    width, height, spp, n_light, sampler = resolve(scene, options)
    device = select_device(options.device)
    context, queue = context_for(device)
    features = options.features or Features.of(scene, options.lanes or default_lanes(device))
    program, build_seconds = render_program(context, features)

    params = params_struct(scene, spp, n_light, width, height)

    ro = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    buffers = [cl.Buffer(context, ro, hostbuf=a) for a in (
        camera_struct(scene.camera, width, height), params, rectangle_structs(scene.rectangles),
        triangle_structs(scene.triangles), ellipsoid_structs(scene.ellipsoids), light_structs(scene.lights),
        material_structs(scene.materials), _vec(samplers.pixel_samples(sampler, spp)),
        _vec(samplers.light_samples(n_light)))]
    out = np.empty((4, height, width), np.float32)
    out_buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    kernel = cl.Kernel(program, "render")

    columns = -(-width // features.lanes)
    work = spp * (1 + len(scene.lights) * n_light)  # shading cost per pixel, roughly
    band = max(1, min(height, (1 << 22) // max(1, columns * features.lanes * work)))
    render_seconds, bar = 0.0, None
    start = time.perf_counter()
    for row0 in range(0, height, band):
        rows = min(band, height - row0)
        event = kernel(queue, (columns, rows), None, *buffers, np.int32(row0), out_buf)
        event.wait()
        render_seconds += (event.profile.end - event.profile.start) * 1e-9
        if bar is None and options.progress is not False and row0 + rows < height and (
                options.progress or time.perf_counter() - start > 1.0):
            from tqdm import tqdm
            bar = tqdm(total=height, initial=row0 + rows, unit="row", file=sys.stderr, leave=False)
        elif bar is not None:
            bar.update(rows)
    if bar is not None:
        bar.close()
    cl.enqueue_copy(queue, out, out_buf)

    image = np.ascontiguousarray(np.moveaxis(out[:3], 0, -1))
    finite = np.isfinite(image)
    nonfinite = int(finite.size - np.count_nonzero(finite))
    if nonfinite:  # a kernel bug, never to reach an image file: reported in the stats, zeroed here
        image[~finite] = 0.0
    rays = int(out[3].sum(dtype=np.float64))
    stats = RenderStats(render_seconds, build_seconds, rays, rays / render_seconds / 1e6, describe(device),
                        [*features.options()], width, height, spp, n_light, sampler, options.seed,
                        {"nonfinite_values": nonfinite})
    return image, stats
