"""A render's options, declared once: their names, types, defaults and help. raytrace.render() takes them as
keyword arguments (tests/test_api.py holds its signature to this declaration), the command line's render,
bench and converge offer those marked for it as --options (cli.py builds them from here), and the manual
lists both from the same source.

Errors about an option's value name it as the caller wrote it: `render(): spp = 15: ...` from Python, and
`command line: --spp = 15: ...` once cli.py has translated the name (command_line_name).
"""
import typing
from dataclasses import MISSING, dataclass, field, fields

from . import samplers, structs
from .errors import API, did_you_mean  # noqa: F401 (API: the source of an option's errors, here with the options)
from .renderer.progressive import PASS_WORK
from .scene.model import LIGHT_SELECTIONS, SHADINGS

CHECKPOINT_EVERY = 60.0  # seconds between a render's checkpoints, by default
MAX_BAND_BYTES = 64 << 20  # the device output buffer: below the 128 MiB any full-profile device allows


def option(default, doc, cli=True, choices=None, metavar=None):
    """A field of RenderOptions: its default, one line of documentation, whether the command line offers it."""
    return field(default=default, metadata={"doc": doc, "cli": cli, "choices": choices, "metavar": metavar})


@dataclass
class RenderOptions:
    """What a render may be asked beside its scene; None takes the scene's own value where it has one."""
    width: int | None = option(None, "image width in pixels (default: the scene's)")
    height: int | None = option(None, "image height in pixels (default: the scene's)")
    spp: int | None = option(None, "pixel samples (a square number for the grid samplers; default: the scene's)")
    light_samples: int | None = option(None, "samples per light per pixel sample (default: the scene's)")
    sampler: str | None = option(None, "the pixel sample pattern (default: the scene's)", choices=samplers.SAMPLERS)
    light_sampler: str | None = option(None, "the light sample pattern (default: the scene's)",
                                       choices=samplers.SAMPLERS)
    light_selection: str | None = option(None, "how each light sample chooses the emitting shape it samples: by "
                                         "power or uniformly (default: the scene's)",
                                         choices=LIGHT_SELECTIONS)
    texture_filter: str = option("trilinear", "how textures are filtered", choices=tuple(structs.FILTERS))
    shading: str | None = option(None, "the shading model: phong (the course's), direct (radiometric direct "
                                 "lighting; a light's colour is then its radiance) or path (global illumination) "
                                 "(default: the scene's)", choices=SHADINGS)
    max_depth: int | None = option(None, "the path model's vertices per path: 1 the emitters seen directly, 2 "
                                   "direct light, -1 unbounded (default: the scene's)")
    seed: int | None = option(None, "seed of the random sample patterns' randomisation, in [0, 2^32) (default: the "
                              "scene's, 0 unless it gives one)")
    time_limit: float | None = option(None, "stop before a pass that would end after this many seconds",
                                      metavar="SECONDS")
    target_error: float | None = option(None, "stop once the estimated relative RMSE of the image is at most this")
    device: str | None = option(None, 'the OpenCL device: "cpu", "gpu", "P:D" indices or part of its name '
                                "(default: the first CPU device)")
    scheduler: str | None = option(None, "render on a Dask cluster: local:N (N worker processes here) or "
                                   "tcp://host:port (a running scheduler); needs the dist extra", metavar="ADDRESS")
    lanes: int | None = option(None, "pixels per work-item (default: the device's widest)", cli=False)
    features: object = option(None, "a raytrace.Features to force a kernel variant (default: the scene's)",
                              cli=False)
    progress: bool | None = option(None, "a progress bar on stderr: True, False, or None for one once the render "
                                   "takes over a second", cli=False)
    max_band_bytes: int = option(MAX_BAND_BYTES, "the device output buffer's size in bytes, at least one row",
                                 cli=False)
    max_pass_work: int = option(PASS_WORK, "rays of a pass, roughly, at most", cli=False)
    accumulate: str | None = option(None, 'where the passes add up: "device" (the sums stay on the device and the '
                                    'host reads the images once) or "host" (float64 sums, each pass read back) '
                                    "(default: the device on GPUs, the host on CPUs)",
                                    choices=("device", "host"))
    client: object = option(None, "a dask.distributed.Client to render on, instead of scheduler", cli=False)
    aov: str | list | tuple | None = option(None, 'AOVs to store beside the image: albedo, normal, depth, position, '
                                            'uv, geo_normal, shape, or Mitsuba\'s "name:type" items, separated by commas '
                                            "(an EXR output's channels NAME.R ...; default: the scene's)",
                                            metavar="NAMES")
    denoise: bool = option(False, "denoise the image with Intel Open Image Denoise (the denoise extra), given "
                           "the albedo and normal AOVs", cli=False)
    watch: list | None = option(None, "watchers called as the render goes (raytrace.Watcher: the progress of each "
                                "pass, its image)", cli=False)
    checkpoint: str | None = option(None, "a file the render's state is kept in, every checkpoint_every seconds and "
                                    "at the end, to resume from", cli=False)
    checkpoint_every: float = option(CHECKPOINT_EVERY, "seconds between checkpoints (0: after every pass)", cli=False)
    resume: bool = option(False, "continue the render kept in checkpoint (the same scene and options)", cli=False)
    checkpoint_command: dict | None = option(None, "what the command line keeps in a checkpoint to resume it",
                                             cli=False)


# Other renderers' words for render()'s options (Mitsuba 3's sample_count, pbrt-v4's pixelsamples, a
# newcomer's samples), for "did you mean" in the errors of render() and the command line.
SYNONYMS = {"samples": "spp", "sample_count": "spp", "pixel_samples": "spp", "pixelsamples": "spp",
            "light_sample_count": "light_samples", "integrator": "shading", "maxdepth": "max_depth",
            "filter": "texture_filter"}


def unknown_keyword(kwargs):
    """render()'s TypeError for a keyword it does not take, with the option the caller may have meant."""
    names = [f.name for f in fields(RenderOptions)]
    for given in kwargs:
        if given not in names:
            return TypeError(f"render() got an unexpected keyword argument {given!r}"
                             f"{did_you_mean(given, names, ';', SYNONYMS)}")
    return None


def declared():
    """(name, default, doc, cli, choices, metavar) of every option, in the order of the declaration."""
    return [(f.name, None if f.default is MISSING else f.default, f.metadata["doc"], f.metadata["cli"],
             f.metadata["choices"], f.metadata["metavar"]) for f in fields(RenderOptions)]


def option_type(name):
    """The type an option's value has when given (int for `int | None`): what the command line parses to."""
    declared_type = next(f.type for f in fields(RenderOptions) if f.name == name)
    given = [t for t in typing.get_args(declared_type) if t is not type(None)] or [declared_type]
    return given[0]


def command_line_name(name):
    """An option's name on the command line: spp -> --spp, light_samples -> --light-samples; a pair written
    width/height names both."""
    return "/".join("--" + part.replace("_", "-") for part in str(name).split("/"))
