"""raytrace: a ray tracer whose per-pixel pipeline is one OpenCL C kernel, driven from Python.

    import raytrace
    scene = raytrace.load_scene("scenes/cornell.toml")
    image, stats = raytrace.render(scene, spp=16, light_samples=16)   # H x W x 3 float32, linear
"""
from .errors import InputError
from .render import RenderStats, render
from .scene import Scene, load_scene

__all__ = ["InputError", "RenderStats", "Scene", "load_scene", "render"]
