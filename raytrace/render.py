"""Rendering a Scene: options, progressive passes, statistics. A pass runs on this process's device
(renderer/device_render.py: the specialised program, the scene's tables gathered by renderer/scene_tables.py and
bound by name by renderer/interface.py, banded launches) or on Dask workers (renderer/distributed.py);
passes accumulate in renderer/progressive.py.

Renders of any size: a launch renders a band of whole rows into a device buffer of one band, which the host
adds into its sums before the next launch, so device memory is bounded by max_band_bytes; host memory grows
with the image (progressive.BYTES_PER_PIXEL), and a render it cannot hold is refused before any device work.
On a GPU the sums stay on the device instead (renderer/device_sums.py), where they fit."""
import dataclasses
import functools
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from . import aovs as aov_types, samplers, structs
from .errors import POSITIVE_SECONDS, TRUE_OR_FALSE, InputError, check_path
from .numerics import is_real
from .memory import available_memory
from .renderer.cpu_target import lanes_for
from .renderer.device_render import LocalPasses, band_rows
from .renderer.program import Features
from .renderer.progressive import (BYTES_PER_PIXEL, MIN_PASSES_FOR_TARGET, PASS_WORK,
                                   first_half, pass_size, row_chunks)
from .options import API, CHECKPOINT_EVERY, MAX_BAND_BYTES, RenderOptions, unknown_keyword  # noqa: F401 (MAX_BAND_BYTES: callers')
from .checkpoint import FINAL, Checkpoints
from .image import Image
from .progress import Progress
from .watch import PassReport, call, check_watchers
from .scene.model import SCENE_EXPECTED, Scene
from .scene.ranges import MAX_SAMPLES
from .scene.model_check import check_value, ensure_checked

HEADROOM_BYTES = 512 << 20    # besides the sums and images: the runtime, the program, the band buffers


@dataclass
class RenderStats:
    """What a render did, as `--stats-json` writes it (docs/cli.md): kernel, wall and build seconds, the rays
    traced and their rate, the device and its build options, the image size, the samples taken and asked for,
    the patterns, filter and seed, the passes, what stopped the render, the estimated error and its history
    pass by pass, and `extra` (device memory, the code-generation target, NaN or Inf values zeroed: 0)."""
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
    stopped_by: str        # "spp", "time-limit", "target-error", or a watcher's reason (the command line's "SIGINT")
    estimated_rmse: float | None
    estimated_relative_rmse: float | None
    history: list = field(default_factory=list)  # per pass: samples, seconds, estimated errors
    extra: dict = field(default_factory=dict)
    aovs: list = field(default_factory=list)  # [name, type] of each AOV stored (raytrace/aovs.py)

    def __post_init__(self):
        # render_progressive's AOVs by name, H x W x C float32: no field, so that --stats-json
        # (dataclasses.asdict) holds no arrays; each instance's own dict, not one shared by all
        self.aov_images = {}


def _option(value, source, key, check, problem):
    if not check(value):
        raise InputError(source, key, value, problem)
    return value


# render()'s options that override a value of the scene, with the table of keys.py that declares that value.
OVERRIDES = {"width": "image", "height": "image", "spp": "render", "light_samples": "render", "sampler": "render",
             "light_sampler": "render", "light_selection": "render", "shading": "render", "max_depth": "render",
             "seed": "render"}


def final_model(scene, options):
    """The model a render renders: `scene` with the options that override its values (OVERRIDES), each checked
    as its key is in a scene file, then the whole checked as one (scene/rules.py's rules hold between the
    scene's values and the options' alike). A broken rule names the scene's value as its file does (the same
    line whether `shading = "phong"` is in the file or given as an option); a value changed in Python behind
    the checks is named as render()'s."""
    ensure_checked(scene, API)
    given = {name: check_value(API, table, name, getattr(options, name))
             for name, table in OVERRIDES.items() if getattr(options, name) is not None}
    if options.target_error is not None and options.spp is None:  # the target, not a count, ends the render
        sampler = given.get("sampler", scene.sampler)
        if sampler not in samplers.EXTENDING:
            raise InputError(API, "target_error", options.target_error, "with no spp renders until the target, "
                             f"which only a pattern that extends can ({', '.join(samplers.EXTENDING)}); the sampler "
                             f"is {sampler!r}: choose one of those, or give spp")
        given["spp"] = MAX_SAMPLES
    if options.aov is not None:  # (not a key's value: Mitsuba's string, or a list)
        given["aovs"] = aov_types.parse(options.aov, API, "aov")
    if not given:
        return scene
    if given.get("width", scene.width) != scene.width or given.get("height", scene.height) != scene.height:
        # a crop window is a window of the scene's own film: a film of another size is rendered whole
        given.update(crop_offset_x=0, crop_offset_y=0, crop_width=None, crop_height=None)
    final = dataclasses.replace(scene, **given)
    ensure_checked(final, scene.path)
    return final


def _options(options):
    """The options that are not the scene's values."""
    _option(options.texture_filter, API, "texture_filter", lambda v: v in structs.FILTERS,
            f"unknown filter (have: {', '.join(structs.FILTERS)})")
    _option(options.time_limit, API, "time_limit", lambda v: v is None or is_real(v) and 0 < v < float("inf"),
            POSITIVE_SECONDS)
    _option(options.target_error, API, "target_error", lambda v: v is None or is_real(v) and 0 < v < float("inf"),
            "must be a positive relative RMSE")
    _option(options.checkpoint_every, API, "checkpoint_every", lambda v: is_real(v) and 0 <= v < float("inf"),
            "must be a number of seconds, at least 0")
    _option(options.resume, API, "resume", lambda v: v is False or v is True and options.checkpoint is not None,
            "True needs a checkpoint file to resume from")
    if options.checkpoint is not None:
        check_path(options.checkpoint, API, "checkpoint")


def resolve(scene, options):
    """The final model's settings (final_model): (width, height, spp, light samples, pixel pattern, light
    pattern)."""
    final = final_model(scene, options)
    return _settings(final)


def _settings(final):
    """The image is the film's crop window (the whole film by default)."""
    _, _, width, height = final.crop
    return (width, height, final.spp, final.light_samples, samplers.pattern(final.sampler, final.spp),
            samplers.pattern(final.light_sampler, final.light_samples))


# An AOV plane's bytes a pixel on the host: its float64 sum (progressive.Accumulator.aov_total), its float32
# mean and the float32 array image.aovs holds
AOV_BYTES_PER_PLANE = 8 + 4 + 4


def check_memory(width, height, aov_planes=0):
    """Refuse a render whose host memory (its sums and images, progressive.BYTES_PER_PIXEL, and its AOVs' as
    many per plane, aov_planes of them: aovs.plane_count) cannot be had: better one line now than a MemoryError,
    or the kernel's OOM killer, after minutes of rendering."""
    needed = width * height * (BYTES_PER_PIXEL + AOV_BYTES_PER_PLANE * aov_planes) + HEADROOM_BYTES
    available = available_memory()
    if needed > available:
        raise InputError(API, "width/height", f"{width}x{height}",
                         f"needs about {needed / 2**30:.1f} GiB of memory, {available / 2**30:.1f} GiB available")


def _keywords_checked(function):
    """`function`, whose TypeError for a keyword it does not take names the option the caller may have meant
    (render(samples=16): did you mean 'spp'?); its signature stays the function's own (inspect follows
    __wrapped__)."""
    @functools.wraps(function)
    def checked(*args, **kwargs):
        unknown = unknown_keyword({k: v for k, v in kwargs.items() if k != "scene"})
        if unknown:
            raise unknown
        return function(*args, **kwargs)
    return checked


@_keywords_checked
def render(scene, *, width=None, height=None, spp=None, light_samples=None, sampler=None, light_sampler=None,
           light_selection=None, texture_filter="trilinear", shading=None, max_depth=None, seed=None, time_limit=None, target_error=None,
           device=None,
           scheduler=None, lanes=None, features=None, progress=None, max_band_bytes=MAX_BAND_BYTES,
           max_pass_work=PASS_WORK, accumulate=None, client=None, aov=None, denoise=False, watch=None,
           checkpoint=None, checkpoint_every=CHECKPOINT_EVERY, resume=False, checkpoint_command=None):
    """Render `scene` (from load_file, load_dict or load_string); returns (image, stats).

    image is a raytrace.Image: an H x W x 3 float32 numpy array of linear radiance (row 0 at the top) that
    also holds the estimated variance of each pixel's mean (image.variance) and saves itself as the command
    line does (image.write("out.exr")). stats is a RenderStats: the fields of --stats-json.

    Every value is checked before any work, and the scene too if it changed since it was loaded (so that no
    value reaches the kernel unchecked); a bad one raises InputError naming it, e.g. `render(): spp = 15`.

    Args:
        scene: the Scene to render.
        width: the image width in pixels, in [1, 16384] (None: the scene's); a film of another size than the
            scene's is rendered whole (the scene's crop window is of its own film).
        height: the image height in pixels, in [1, 16384] (None: the scene's), as width.
        spp: pixel samples, in [1, 65536]; a square number for the grid samplers (None: the scene's).
        light_samples: samples per light per pixel sample, in [1, 65536] (None: the scene's).
        sampler: the pixel sample pattern: center, grid, rotated-grid-cw, rotated-grid-ccw, random,
            jittered, halton or sobol (docs/sampling.md; None: the scene's).
        light_sampler: the light sample pattern, the same choice (None: the scene's).
        light_selection: how each light sample chooses the emitting shape it samples: "power" (in proportion
            to the emitters' power) or "uniform" (None: the scene's).
        texture_filter: nearest, bilinear, trilinear or anisotropic.
        shading: "phong" (the course's model), "direct" (radiometric direct lighting; a light's colour is
            then its radiance; refused for a scene with an ambient term) or "path" (global illumination by path
            tracing, the same lights and surfaces) (None: the scene's).
        max_depth: the path model's vertices per path, in [-1, 1024], Mitsuba's convention: 1 the emitters
            seen directly, 2 direct light, -1 unbounded (None: the scene's; only with shading "path").
        seed: the seed of the random patterns' per-pixel randomisation, in [0, 2^32) (None: the scene's).
        time_limit: seconds; no pass starts that would end after it (the first always runs).
        target_error: stop once the estimated relative RMSE of the image is at most this.
        device: the OpenCL device: "cpu", "gpu", "P:D" indices or part of its name (None: the first CPU).
        scheduler: render on a Dask cluster: "local:N" (N worker processes on this machine; a script must
            then keep its code under ``if __name__ == "__main__":``) or "tcp://host:port".
        lanes: pixels per work-item, 1, 4, 8 or 16 (None: the device's widest).
        features: a raytrace.Features to force a kernel variant (None: what the scene needs).
        progress: a progress bar on stderr: True, False, or None for one once the render takes a second.
        max_band_bytes: the device output buffer's size in bytes, at least one row.
        max_pass_work: rays of a pass, roughly, at most.
        accumulate: where the passes add up: "device" (the sums stay on the device between passes and the
            host reads the images once: docs/gpu.md), "host" (float64 sums on the host, each pass read back),
            or None: the device on GPUs, the host on CPUs and on a Dask cluster.
        client: a dask.distributed.Client to render on, instead of scheduler.
        aov: AOVs to store beside the image (raytrace/aovs.py): a string of items separated by commas, or a
            list of them, each a short name (albedo, normal, depth, position, uv, geo_normal) or Mitsuba's
            "name:type"; image.aovs then holds each as an H x W x C float32 array by its name (None: the
            scene's, from its `aovs` or Mitsuba's aov integrator; "" or []: none).
        denoise: the image denoised by Intel Open Image Denoise (raytrace.denoise; the denoise extra), with
            the AOVs albedo and normal, added to `aov` where it lacks them; image.aovs["noisy"] keeps the render.
        watch: a list of watchers (raytrace.Watcher), told of the build, each pass (its samples, estimated error
            and image so far; one may stop the render) and the end (raytrace/watch.py).
        checkpoint: a file to keep the render's state in (every checkpoint_every seconds, and at the end), from
            which resume=True continues it to the uninterrupted render's image, bit for bit (docs/cli.md).
        checkpoint_every: seconds between checkpoints, >= 0 (0: after every pass).
        resume: continue the render kept in `checkpoint`, made by the same scene, options and raytrace.
        checkpoint_command: what the command line keeps in the checkpoint to resume the render (internal).

    Returns:
        (Image, RenderStats)
    """
    _option(denoise, API, "denoise", lambda v: isinstance(v, bool), TRUE_OR_FALSE)
    if denoise:  # before any work: the extra, then the AOVs it reads
        from .denoise import aov_request, require
        require("render(denoise=True)")
        if isinstance(scene, Scene):  # (render_progressive refuses anything else)
            aov = aov_request(aov, scene, API, "aov")
    image, variance, stats = render_progressive(
        scene, width=width, height=height, spp=spp, light_samples=light_samples, sampler=sampler,
        light_sampler=light_sampler, light_selection=light_selection, texture_filter=texture_filter, shading=shading, max_depth=max_depth, seed=seed,
        time_limit=time_limit, target_error=target_error, device=device, scheduler=scheduler, lanes=lanes,
        features=features, progress=progress, max_band_bytes=max_band_bytes, max_pass_work=max_pass_work,
        client=client, accumulate=accumulate, aov=aov, watch=watch, checkpoint=checkpoint,
        checkpoint_every=checkpoint_every, resume=resume, checkpoint_command=checkpoint_command)
    image = Image.of(image, variance, stats, scene.path, stats.aov_images)
    if denoise:
        from .denoise import denoise as denoised
        image = denoised(image)
    return image, stats


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


def path_vertices(scene):
    """Vertices a pixel sample's path has at most, for sizing passes: 1 outside the path model; there
    max_depth - 1 bounces, counted as at most 8 (Russian roulette ends most paths by then)."""
    if scene.shading != "path":
        return 1
    return max(1, min(8, scene.max_depth - 1 if scene.max_depth >= 0 else 8))


def resolve_all(final, options):
    """The final model's settings and the passes: their sizes follow from the model and the options alone, so
    every device agrees on them."""
    _options(options)
    width, height, spp, n_light, pixel, light = _settings(final)
    work = (1 + len(final.lights) * n_light) * path_vertices(final)
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
    lanes_for(None, None)  # the environment's lane width, checked here before the workers meet it
    client = options.client or client_for(options.scheduler)
    rows = band_rows(r, options.max_band_bytes)
    return DaskPasses(client, scene, options, r, [(row0, min(rows, r.height - row0))
                                                  for row0 in range(0, r.height, rows)])


def _spp_from(scene, options):
    """Where a render's pixel sample count came from: "option" (spp=), "target_error" (none given: the target
    ends the render, MAX_SAMPLES at most), "scene" (its file's, or a model's) or "default" (its file gives none)."""
    if options.spp is not None:
        return "option"
    if options.target_error is not None:
        return "target_error"
    given = scene.source is None or "spp" in (scene.source.get("render") or {})
    return "scene" if given else "default"


@_keywords_checked
def render_progressive(scene, **kwargs):
    """Render `scene` in passes until its spp, time limit or target error; returns (H x W x 3 float32
    linear image, H x W x 3 float32 estimated variance of each pixel's mean or None, RenderStats). The
    keyword arguments are render()'s (raytrace/options.py); the command line calls this."""
    options = RenderOptions(**kwargs)
    if not isinstance(scene, Scene):
        raise InputError(API, "scene", type(scene).__name__, SCENE_EXPECTED)
    final = final_model(scene, options)
    options = dataclasses.replace(options, seed=final.seed)  # the devices read the seed from the options
    # The kernel reads a model's shading, max_depth and light selection, the rest of the settings from `r`: when
    # the options leave those as they are, the passes render the scene itself, whose packed geometry is kept
    # between renders. A crop window stays the scene's, unless final_model drops it with the film's size: then
    # the kernel reads the final model's whole film.
    if (final.shading, final.max_depth, final.light_selection, final.crop[:2], final.aovs) != (
            scene.shading, scene.max_depth, scene.light_selection, scene.crop[:2], scene.aovs) or (
            scene.crop != (0, 0, scene.width, scene.height) and final.crop != scene.crop):
        scene = final
    _option(options.accumulate, API, "accumulate", lambda v: v in (None, "device", "host"),
            'must be "device" or "host"')
    if options.accumulate == "device" and (options.scheduler is not None or options.client is not None):
        raise InputError(API, "accumulate", options.accumulate, "a Dask render adds its bands on the client: "
                         'use "host" or None')
    r = resolve_all(final, options)
    check_memory(r.width, r.height, aov_types.plane_count(aov_types.mask(final.aovs)))
    watchers = [Progress(options.progress, options.time_limit, options.target_error),
                *check_watchers(options.watch, API, "watch")]
    try:
        return _render_passes(scene, final, options, r, watchers)
    except BaseException:
        for w in watchers:  # their threads and sockets end whatever happened (watch.py: finished(None))
            finished = getattr(w, "finished", None)
            if callable(finished):
                try:
                    finished(None)
                except Exception:  # the render's own exception is the one to tell
                    pass
        raise


def _report(r, acc, seconds, rmse=None, relative=None, stopped_by=None):
    """A watch.PassReport of where the render stands, its image made from the sums on request."""
    return PassReport(acc.passes, len(r.passes), acc.n_total, r.spp, seconds, rmse, relative, r.width, r.height,
                      stopped_by, acc.mean)


def _render_passes(scene, final, options, r, watchers):
    """The passes, from a checkpoint's state where one is resumed, until the samples, the time limit, the target
    error or a watcher ends them; returns render_progressive's (image, variance, stats)."""
    call(watchers, "building", "building the kernel")
    passes = _passes(scene, options, r)
    acc = passes.accumulator()
    done = {"render_seconds": 0.0, "wall_seconds": 0.0, "history": [], "stopped_by": None}
    keeper = options.checkpoint and Checkpoints(options, final, r, passes, acc)
    if keeper and options.resume:
        done = keeper.resume(acc)
    render_seconds, history = done["render_seconds"], done["history"]
    # a render its samples, target or time limit ended stays ended; one a watcher stopped (Ctrl-C) goes on
    ended = done["stopped_by"] in FINAL
    stopped_by = done["stopped_by"] if ended else "spp"
    rmse, relative = (history[-1]["estimated_rmse"], history[-1]["estimated_relative_rmse"]) if history else (None,
                                                                                                             None)
    start = time.perf_counter() - done["wall_seconds"]
    call(watchers, "started", _report(r, acc, done["wall_seconds"], rmse, relative))
    for k in range(len(r.passes) if ended else acc.passes, len(r.passes)):
        _, n, n_first = r.passes[k]
        pass_start = time.perf_counter()
        render_seconds += passes.run_pass(k, acc)
        acc.end_pass(n, n_first)
        now = time.perf_counter()
        rmse, relative = acc.estimated_rmse(keep_variance=acc.n_total >= r.spp)  # the last pass: images() reuses it
        history.append({"pass": acc.passes, "samples": acc.n_total, "seconds": now - start,
                        "pass_seconds": now - pass_start,
                        "kernel_seconds": render_seconds, "estimated_rmse": rmse,
                        "estimated_relative_rmse": relative})
        if keeper:
            keeper.after_pass(passes)
        asked = call(watchers, "pass_done", _report(r, acc, now - start, rmse, relative))
        if acc.n_total >= r.spp:
            break
        if asked is not None:
            stopped_by = asked
            break
        if (options.target_error is not None and acc.passes >= MIN_PASSES_FOR_TARGET
                and relative <= options.target_error):
            stopped_by = "target-error"
            break
        if options.time_limit is not None and now - start + (now - pass_start) > options.time_limit:
            stopped_by = "time-limit"
            break
        if keeper:
            keeper.save_if_due(acc, render_seconds, now - start, history)
    passes.cancel()
    wall_seconds = time.perf_counter() - start
    if keeper:
        keeper.save(acc, render_seconds, wall_seconds, history, stopped_by)
    call(watchers, "finished", _report(r, acc, wall_seconds, rmse, relative, stopped_by))

    rays = acc.rays_traced()
    aov_means = acc.aov_means() if final.aovs else None  # (DeviceSums holds none: sums_on_device)
    image, variance = acc.images()  # rmse and relative are the last pass's
    aov_images = aov_types.images(final.aovs, aov_means) if final.aovs else {}
    nonfinite = sum(_zero_nonfinite(a) for a in (image, variance, *aov_images.values()) if a is not None)
    info = passes.info()
    rate = rays / render_seconds / 1e6 if render_seconds > 0 else 0.0
    stats = RenderStats(render_seconds, wall_seconds, info["build_seconds"], int(rays), rate,
                        info["device"], info["build_options"], r.width, r.height, acc.n_total, r.spp, r.n_light,
                        r.pixel.name, r.light.name, options.texture_filter, options.seed, info["texture_bytes"],
                        acc.passes, stopped_by, rmse, relative, history,
                        {**info["extra"], "nonfinite_values": nonfinite, "spp_from": _spp_from(scene, options)},
                        [list(pair) for pair in final.aovs])
    stats.aov_images = aov_images  # (no field: --stats-json holds no arrays)
    return image, variance, stats
