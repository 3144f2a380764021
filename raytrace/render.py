"""Rendering a Scene: options, progressive passes, statistics. A pass runs on this process's device
(renderer/device_render.py: the specialised program, the scene's tables gathered by renderer/scene_tables.py and
bound by name by renderer/interface.py, banded launches) or on Dask workers (renderer/distributed.py);
passes accumulate in renderer/progressive.py.

Renders of any size: a launch renders a band of whole rows into a device buffer of one band, which the host
adds into its sums before the next launch, so device memory is bounded by max_band_bytes; host memory grows
with the image (progressive.BYTES_PER_PIXEL), and a render it cannot hold is refused before any device work."""
import sys
import time
import dataclasses
from dataclasses import dataclass, field

import numpy as np

from . import samplers, structs
from .errors import InputError
from .memory import available_memory
from .scene.model import SHADINGS
from .scene.ranges import MAX_IMAGE_SIDE, MAX_SAMPLES as MAX_SPP
from .renderer.device_render import LocalPasses, band_rows
from .renderer.program import Features
from .renderer.progressive import (BYTES_PER_PIXEL, CHANNELS, MIN_PASSES_FOR_TARGET, PASS_WORK, Accumulator,
                                   first_half, pass_size, row_chunks)

MAX_BAND_BYTES = 64 << 20     # the device output buffer: below the 128 MiB any full-profile device allows
HEADROOM_BYTES = 512 << 20    # besides the sums and images: the runtime, the program, the band buffers


@dataclass
class RenderOptions:
    width: int | None = None
    height: int | None = None
    spp: int | None = None
    light_samples: int | None = None
    sampler: str | None = None
    light_sampler: str | None = None
    texture_filter: str = "trilinear"
    shading: str | None = None         # None: the scene's ("phong" or "direct")
    seed: int = 0
    time_limit: float | None = None    # seconds: no pass starts that would end after it
    target_error: float | None = None  # stop when the estimated relative RMSE is at most this
    device: str | None = None
    lanes: int | None = None
    features: Features | None = None  # None: derived from the scene
    progress: bool | None = None      # None: a bar on stderr when the render takes over a second
    max_band_bytes: int = MAX_BAND_BYTES  # the device output buffer's size, at least one row
    max_pass_work: int = PASS_WORK        # rays of a pass, roughly, at most (progressive.pass_size)
    scheduler: str | None = None  # a Dask scheduler's address, "local:N" or "tcp://host:port" (distributed.py)
    client: object = None         # or a dask.distributed.Client to use


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


def _pick(scene, given, scene_key, option, low, high):
    """A count from the command line (`option`) or else the scene's (`scene_key`), checked against one set of
    limits and reported against where it came from."""
    source, key, value = ("command line", option, given) if given is not None else (
        scene.path, scene_key, getattr(scene, scene_key.split(".")[-1]))
    ok = isinstance(value, int) and not isinstance(value, bool) and low <= value <= high
    return _option(value, source, key, lambda v: ok, f"must be an integer in [{low}, {high}]")


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
    width = _pick(scene, options.width, "image.width", "--width", 1, MAX_IMAGE_SIDE)
    height = _pick(scene, options.height, "image.height", "--height", 1, MAX_IMAGE_SIDE)
    spp = _pick(scene, options.spp, "render.spp", "--spp", 1, MAX_SPP)
    nl = _pick(scene, options.light_samples, "render.light_samples", "--light-samples", 1, MAX_SPP)
    pixel = _pattern(pick(options.sampler, scene.sampler), spp, "--sampler", "--spp")
    light = _pattern(pick(options.light_sampler, scene.light_sampler), nl, "--light-sampler", "--light-samples")
    _option(options.texture_filter, cli, "--texture-filter", lambda v: v in structs.FILTERS,
            f"unknown filter (have: {', '.join(structs.FILTERS)})")
    _option(options.seed, cli, "--seed", lambda v: 0 <= v < 2**32, "must be in [0, 2^32)")
    _option(options.time_limit, cli, "--time-limit", lambda v: v is None or 0 < v < float("inf"),
            "must be a positive number of seconds")
    _option(options.target_error, cli, "--target-error", lambda v: v is None or 0 < v < float("inf"),
            "must be a positive relative RMSE")
    return width, height, spp, nl, pixel, light


def check_memory(width, height):
    """Refuse a render whose host memory (its sums and images, progressive.BYTES_PER_PIXEL) cannot be had:
    better one line now than a MemoryError, or the kernel's OOM killer, after minutes of rendering."""
    needed, available = width * height * BYTES_PER_PIXEL + HEADROOM_BYTES, available_memory()
    if needed > available:
        raise InputError("command line", "--width/--height", f"{width}x{height}",
                         f"needs about {needed / 2**30:.1f} GiB of memory, {available / 2**30:.1f} GiB available")


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


def _zero_nonfinite(image):
    """Zero the NaN and Inf values of an H x W x C image in place, chunk by chunk; returns their number.
    They are a kernel bug, never to reach an image file, so they are counted in the stats."""
    count = 0
    for rows in row_chunks(image.shape[0], image[0].nbytes):
        band = image[rows]
        bad = ~np.isfinite(band)
        count += int(np.count_nonzero(bad))
        band[bad] = 0.0
    return count


@dataclass
class Resolved:
    """A render's options checked against its scene: what every device rendering it must agree on."""
    width: int
    height: int
    spp: int
    n_light: int
    pixel: samplers.Pattern
    light: samplers.Pattern
    work: int    # rays per pixel sample, at most
    passes: list  # (first pixel sample, samples, samples summed apart: progressive.first_half) of every pass


def resolve_all(scene, options):
    """resolve(), and the passes: their sizes follow from the options alone, so every device agrees on them."""
    width, height, spp, n_light, pixel, light = resolve(scene, options)
    work = 1 + len(scene.lights) * n_light
    stoppable = options.time_limit is not None or options.target_error is not None
    per_pass = pass_size(spp, width * height * work, options.max_pass_work // (2 if stoppable else 1))
    sizes = [(s, min(per_pass, spp - s)) for s in range(0, spp, per_pass)]
    passes = [(s, n, first_half(s, n)) for s, n in sizes]
    return Resolved(width, height, spp, n_light, pixel, light, work, passes)


def _passes(scene, options, r):
    """Where the passes run: this process's device, or Dask tasks of one band each (renderer/distributed.py)."""
    if options.scheduler is None and options.client is None:
        return LocalPasses(scene, options, r)
    from .renderer.distributed import DaskPasses, client_for
    client = options.client or client_for(options.scheduler)
    rows = band_rows(r, options.max_band_bytes)
    return DaskPasses(client, scene, options, r, [(row0, min(rows, r.height - row0))
                                                  for row0 in range(0, r.height, rows)])


def render_progressive(scene, **kwargs):
    """Render `scene` in passes until its spp, time limit or target error; returns (H x W x 3 float32
    linear image, H x W x 3 float32 estimated variance of each pixel's mean or None, RenderStats)."""
    options = RenderOptions(**kwargs)
    if options.shading is not None:
        _option(options.shading, "command line", "--shading", lambda v: v in SHADINGS, f"must be one of {SHADINGS}")
        scene = dataclasses.replace(scene, shading=options.shading)
    r = resolve_all(scene, options)
    check_memory(r.width, r.height)
    passes = _passes(scene, options, r)
    acc, rays, render_seconds, history = Accumulator((CHANNELS, r.height, r.width)), 0.0, 0.0, []
    progress, stopped_by = _Progress(r.spp, options.progress), "spp"
    start = time.perf_counter()
    for k, (_, n, n_first) in enumerate(r.passes):
        pass_start = time.perf_counter()
        seconds, pass_rays = passes.run_pass(k, acc)
        acc.end_pass(n, n_first)
        render_seconds, rays = render_seconds + seconds, rays + pass_rays
        now = time.perf_counter()
        rmse, relative = acc.estimated_rmse(keep_variance=acc.n_total >= r.spp)  # the last pass: images() reuses it
        history.append({"pass": acc.passes, "samples": acc.n_total, "seconds": now - start,
                        "pass_seconds": now - pass_start,
                        "kernel_seconds": render_seconds, "estimated_rmse": rmse,
                        "estimated_relative_rmse": relative})
        progress.update(now - start, acc.n_total, acc.passes, relative)
        if acc.n_total >= r.spp:
            break
        if (options.target_error is not None and acc.passes >= MIN_PASSES_FOR_TARGET
                and relative <= options.target_error):
            stopped_by = "target-error"
            break
        if options.time_limit is not None and now - start + (now - pass_start) > options.time_limit:
            stopped_by = "time-limit"
            break
    passes.cancel()
    progress.close()
    wall_seconds = time.perf_counter() - start

    image, variance = acc.images()  # rmse and relative are the last pass's
    nonfinite = sum(_zero_nonfinite(a) for a in (image, variance) if a is not None)
    info = passes.info()
    stats = RenderStats(render_seconds, wall_seconds, info["build_seconds"], int(rays), rays / render_seconds / 1e6,
                        info["device"], info["build_options"], r.width, r.height, acc.n_total, r.spp, r.n_light,
                        r.pixel.name, r.light.name, options.texture_filter, options.seed, info["texture_bytes"],
                        acc.passes, stopped_by, rmse, relative, history,
                        {**info["extra"], "nonfinite_values": nonfinite})
    return image, variance, stats
