"""raytrace: a ray tracer whose per-pixel pipeline is one OpenCL C kernel, driven from Python.

    import raytrace
    scene = raytrace.load_file("scenes/cornell.toml")      # or load_dict({...}), load_string("...")
    params = raytrace.parameters(scene)                      # its values by name, editable
    params["lights[0].colour"] = [1.0, 0.9, 0.8]
    params.update()                                          # checked as a file's value would be
    image, stats = raytrace.render(scene, spp=16, light_samples=16)
    image.write("cornell.png")                               # as the command line writes it
    image, stats = raytrace.show(scene, spp=256)             # in a notebook: the image shown as it converges
    clean, _ = raytrace.render(scene, spp=16, denoise=True)  # Open Image Denoise (the denoise extra)

The package: render.py (render), notebook.py (show), options.py (its options, shared with the command line),
image.py (what it returns), denoise.py (Open Image Denoise on it), parameters.py (editing a loaded scene),
image_file.py (writing images), scene/ (the scene model, its readers and checks), renderer/ (the host side of the
kernel in kernels/), commands/ (the commands that measure and verify the renderer: bench, converge, stability,
compile, assets), cli.py.
"""
import os as _os
import signal as _signal
import sys as _sys

from .errors import interrupted_line as _interrupted_line  # no imports of its own: quick


def _interrupted_while_loading(signum, frame):
    # _interrupted_line is bound before the handler goes in: imported here, from outputs.py, a signal that landed
    # while the package imported outputs.py met the half-made module (ImportError, a traceback; seen in the suite)
    _os.write(2, (_interrupted_line(signum) + "\n").encode())
    _os._exit(128 + signum)


# `python -m raytrace` imports this package, and with it numpy, pyopencl and OpenImageIO (a fraction of a second),
# before __main__.py runs: a signal meanwhile ends the process with the command line's one line and status
# 128 + its number, as one during a command does (nothing is written yet); cli.main then takes the signals over.
# Only that process: importing raytrace anywhere else (a script, a notebook, pytest) changes no signal handler.
_argv = getattr(_sys, "orig_argv", [])
if "-m" in _argv[:-1] and _argv[_argv.index("-m") + 1] == "raytrace":
    for _signum in (_signal.SIGINT, _signal.SIGTERM, _signal.SIGHUP):
        if _signal.getsignal(_signum) is not _signal.SIG_IGN:  # nohup's ignored signals stay ignored
            _signal.signal(_signum, _interrupted_while_loading)

from .denoise import denoise  # noqa: E402 (after the signals: these imports are what takes the time)
from .errors import InputError  # noqa: E402
from .image import Image  # noqa: E402
from .notebook import show  # noqa: E402
from .parameters import SceneParameters, parameters  # noqa: E402
from .render import RenderStats, render  # noqa: E402
from .renderer.program import Features  # noqa: E402
from .scene import Scene, load_dict, load_file, load_string  # noqa: E402
from .watch import PassReport, Watcher  # noqa: E402

__all__ = ["Features", "Image", "InputError", "PassReport", "RenderStats", "Scene", "SceneParameters", "Watcher",
           "denoise", "load_dict", "load_file", "load_string", "parameters", "render", "show"]


def __dir__():  # the API, not the submodules and the standard library the package imported (PEP 562)
    return sorted(__all__)
