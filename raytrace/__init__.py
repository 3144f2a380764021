"""raytrace: a ray tracer whose per-pixel pipeline is one OpenCL C kernel, driven from Python.

    import raytrace
    scene = raytrace.load_file("scenes/cornell.toml")      # or load_dict({...}), load_string("...")
    params = raytrace.parameters(scene)                      # its values by name, editable
    params["lights[0].colour"] = [1.0, 0.9, 0.8]
    params.update()                                          # checked as a file's value would be
    image, stats = raytrace.render(scene, spp=16, light_samples=16)
    image.write("cornell.png")                               # as the command line writes it

The package: render.py (render), options.py (its options, shared with the command line), image.py (what it
returns), parameters.py (editing a loaded scene), image_file.py (writing images), scene/ (the scene model,
its readers and checks), renderer/ (the host side of the kernel in kernels/), commands/ (the commands that
measure and verify the renderer: bench, converge, stability, compile, assets), cli.py.
"""
from .errors import InputError
from .image import Image
from .parameters import SceneParameters, parameters
from .render import RenderStats, render
from .renderer.program import Features
from .scene import Scene, load_dict, load_file, load_string

__all__ = ["Features", "Image", "InputError", "RenderStats", "Scene", "SceneParameters", "load_dict", "load_file",
           "load_string", "parameters", "render"]
