"""Rendering a Scene: options, the specialised program, banded launches, statistics (the structs it
sends are packed by raytrace/structs.py)."""
import sys
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from . import samplers, types
from .structs import scene_structs, texture_structs
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
    texture_filter: str = "trilinear"
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
    texture_filter: str
    seed: int
    texture_bytes: int
    extra: dict = field(default_factory=dict)


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
    _option(options.texture_filter, cli, "--texture-filter", lambda v: v in types.FILTERS,
            f"unknown filter (have: {', '.join(types.FILTERS)})")
    return width, height, spp, nl, sampler


def render(scene, **kwargs):
    """Render `scene`; returns (H x W x 3 float32 linear image, RenderStats)."""
    options = RenderOptions(**kwargs)
    width, height, spp, n_light, sampler = resolve(scene, options)
    device = select_device(options.device)
    context, queue = context_for(device)
    features = options.features or Features.of(scene, options.lanes or default_lanes(device))
    program, build_seconds = render_program(context, features)

    textures = texture_structs(scene)
    texture_bytes = textures[2].nbytes if scene.textures else 0  # the packed texels of every level
    ro = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    buffers = [cl.Buffer(context, ro, hostbuf=a) for a in (
        *scene_structs(scene, width, height, spp, n_light, options.texture_filter), *textures,
        samplers.pixel_samples(sampler, spp).astype(np.float32), samplers.light_samples(n_light).astype(np.float32))]
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
                        [*features.options()], width, height, spp, n_light, sampler, options.texture_filter,
                        options.seed, texture_bytes, {"nonfinite_values": nonfinite})
    return image, stats
