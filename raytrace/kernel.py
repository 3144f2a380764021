"""Old name of raytrace.renderer.program, kept so that `raytrace.kernel.Features` still works."""
from .renderer.program import Features  # noqa: F401
