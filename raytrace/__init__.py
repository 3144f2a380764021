"""raytrace: a ray tracer whose per-pixel pipeline is one OpenCL C kernel, driven from Python.

    import raytrace
    scene = raytrace.load_scene("scenes/cornell.toml")
    image, stats = raytrace.render(scene, spp=16, light_samples=16)   # H x W x 3 float32, linear
    raytrace.write_image("cornell.png", image)

The package: render.py (render, render_progressive), image_file.py (writing images), scene/ (the scene model
and its readers), renderer/ (the host side of the kernel in kernels/), commands/ (the commands that measure
and verify the renderer: bench, converge, stability, compile, assets), cli.py.
"""
from .errors import InputError
from .image_file import write_image
from .render import RenderStats, render, render_progressive
from .renderer.program import Features
from .scene import Scene, load_scene

__all__ = ["Features", "InputError", "RenderStats", "Scene", "load_scene", "render", "render_progressive", "write_image"]
