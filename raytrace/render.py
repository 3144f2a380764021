"""Rendering a Scene: options, the specialised program, progressive passes of banded launches, statistics
(the structs it sends are packed by raytrace/structs.py, passes accumulate in raytrace/progressive.py)."""
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
from .progressive import MIN_PASSES_FOR_TARGET, Accumulator, pass_size

MAX_SPP = 1 << 16


@dataclass
class RenderOptions:
    width: int | None = None
    height: int | None = None
    spp: int | None = None
    light_samples: int | None = None
    sampler: str | None = None
    light_sampler: str | None = None
    texture_filter: str = "trilinear"
    seed: int = 0
    time_limit: float | None = None    # seconds: no pass starts that would end after it
    target_error: float | None = None  # stop when the estimated relative RMSE is at most this
    device: str | None = None
    lanes: int | None = None
    features: Features | None = None  # None: derived from the scene
    progress: bool | None = None      # None: a bar on stderr when the render takes over a second


@dataclass
class RenderStats:
    render_seconds: float  # kernel time on the device
    wall_seconds: float    # the passes, accumulation included (not the build)
    build_seconds: float
    rays: int
    mrays_per_s: float
    device: str
    build_options: list
    width: int
    height: int
    spp: int               # pixel samples taken
    max_spp: int           # pixel samples asked for
    light_samples: int
    sampler: str
    light_sampler: str
    texture_filter: str
    seed: int
    texture_bytes: int
    passes: int
    stopped_by: str        # "spp", "time-limit" or "target-error"
    estimated_rmse: float | None
    estimated_relative_rmse: float | None
    history: list = field(default_factory=list)  # per pass: samples, seconds, estimated errors
    extra: dict = field(default_factory=dict)


def _option(value, source, key, check, problem):
    if not check(value):
        raise InputError(source, key, value, problem)
    return value


def _pattern(name, n, key, count_key):
    problem = samplers.count_problem(name, n)
    if problem and name in samplers.SAMPLERS:
        raise InputError("command line", count_key, n, f"{problem} (or choose another {key})")
    if problem:
        raise InputError("command line", key, name, problem)
    return samplers.pattern(name, n)


def resolve(scene, options):
    """Command-line overrides on top of the scene's own settings, validated: (width, height, spp,
    light samples, pixel pattern, light pattern)."""
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
    pixel = _pattern(pick(options.sampler, scene.sampler), spp, "--sampler", "--spp")
    light = _pattern(pick(options.light_sampler, scene.light_sampler), nl, "--light-sampler", "--light-samples")
    _option(options.texture_filter, cli, "--texture-filter", lambda v: v in types.FILTERS,
            f"unknown filter (have: {', '.join(types.FILTERS)})")
    _option(options.seed, cli, "--seed", lambda v: 0 <= v < 2**32, "must be in [0, 2^32)")
    _option(options.time_limit, cli, "--time-limit", lambda v: v is None or 0 < v < float("inf"),
            "must be a positive number of seconds")
    _option(options.target_error, cli, "--target-error", lambda v: v is None or 0 < v < float("inf"),
            "must be a positive relative RMSE")
    return width, height, spp, nl, pixel, light


def render(scene, **kwargs):
    """Render `scene`; returns (H x W x 3 float32 linear image, RenderStats)."""
    image, _, stats = render_progressive(scene, **kwargs)
    return image, stats


class _Progress:
    """A tqdm bar on stderr over the pixel samples, shown once the render has taken a second."""

    def __init__(self, total, wanted):
        self.total, self.wanted, self.bar = total, wanted, None

    def update(self, elapsed, done, passes, relative_error):
        if self.bar is None and self.wanted is not False and done < self.total and (self.wanted or elapsed > 1.0):
            from tqdm import tqdm
            self.bar = tqdm(total=self.total, unit="spp", file=sys.stderr, leave=False)
        if self.bar is not None:
            self.bar.update(done - self.bar.n)
            error = "?" if relative_error is None else f"{relative_error:.2e}"
            self.bar.set_postfix_str(f"pass {passes}, est. rel. error {error}", refresh=False)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def render_progressive(scene, **kwargs):
    """Render `scene` in passes until its spp, time limit or target error; returns (H x W x 3 float32
    linear image, H x W x 3 float32 estimated variance of each pixel's mean or None, RenderStats)."""
    options = RenderOptions(**kwargs)
    width, height, spp, n_light, pixel, light = resolve(scene, options)
    device = select_device(options.device)
    context, queue = context_for(device)
    features = options.features or Features.of(scene, options.lanes or default_lanes(device))
    program, build_seconds = render_program(context, features)

    textures = texture_structs(scene)
    texture_bytes = textures[2].nbytes if scene.textures else 0  # the packed texels of every level
    ro = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    structs = scene_structs(scene, width, height, spp, n_light, options.texture_filter, pixel, light, options.seed)
    buffers = [cl.Buffer(context, ro, hostbuf=a) for a in (*structs, *textures, pixel.table(), light.table())]
    out = np.empty((4, height, width), np.float32)
    out_buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    kernel = cl.Kernel(program, "render")

    columns = -(-width // features.lanes)
    work = 1 + len(scene.lights) * n_light  # rays per pixel sample, at most
    per_pass = pass_size(spp, width * height * work)
    band = max(1, min(height, (1 << 23) // max(1, columns * features.lanes * work * per_pass)))
    acc, rays, render_seconds, history = Accumulator((3, height, width)), 0.0, 0.0, []
    progress, stopped_by = _Progress(spp, options.progress), "spp"
    start = time.perf_counter()
    while acc.n_total < spp:
        pass_start, n = time.perf_counter(), min(per_pass, spp - acc.n_total)
        for row0 in range(0, height, band):
            rows = min(band, height - row0)
            event = kernel(queue, (columns, rows), None, *buffers, np.int32(acc.n_total), np.int32(n),
                           np.int32(row0), out_buf)
            event.wait()
            render_seconds += (event.profile.end - event.profile.start) * 1e-9
        cl.enqueue_copy(queue, out, out_buf)
        acc.add(out[:3], n)
        rays += out[3].sum(dtype=np.float64)
        now = time.perf_counter()
        rmse, relative = acc.estimated_rmse()
        history.append({"pass": acc.passes, "samples": acc.n_total, "seconds": now - start,
                        "pass_seconds": now - pass_start,
                        "kernel_seconds": render_seconds, "estimated_rmse": rmse,
                        "estimated_relative_rmse": relative})
        progress.update(now - start, acc.n_total, acc.passes, relative)
        if acc.n_total >= spp:
            break
        if (options.target_error is not None and acc.passes >= MIN_PASSES_FOR_TARGET
                and relative <= options.target_error):
            stopped_by = "target-error"
            break
        if options.time_limit is not None and now - start + (now - pass_start) > options.time_limit:
            stopped_by = "time-limit"
            break
    progress.close()
    wall_seconds = time.perf_counter() - start

    planar = lambda a: np.ascontiguousarray(np.moveaxis(a, 0, -1), dtype=np.float32)  # noqa: E731
    image, variance = planar(acc.mean()), acc.variance()
    variance = None if variance is None else planar(variance)
    nonfinite = 0
    for a in (image, variance):  # a kernel bug, never to reach an image file: reported in the stats, zeroed
        if a is not None:
            finite = np.isfinite(a)
            nonfinite += int(finite.size - np.count_nonzero(finite))
            a[~finite] = 0.0
    rmse, relative = acc.estimated_rmse()
    stats = RenderStats(render_seconds, wall_seconds, build_seconds, int(rays), rays / render_seconds / 1e6,
                        describe(device), [*features.options()], width, height, acc.n_total, spp, n_light,
                        pixel.name, light.name, options.texture_filter, options.seed, texture_bytes, acc.passes,
                        stopped_by, rmse, relative, history, {"nonfinite_values": nonfinite})
    return image, variance, stats
