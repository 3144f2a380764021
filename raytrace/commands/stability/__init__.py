"""The numerical stability suite (`python -m raytrace stability`, tests/stability/): the kernel's float32
results at the edges of its input space, against float64 computed here, independently, in numpy.

Each case is one function returning rows: what is measured, the largest error found, and the bound it is
held to, argued in the case's docstring from the float32 rounding of the computation (u = 2^-24, the unit
roundoff; OpenCL 1.2's ulp limits for the builtins) and the conditioning of the problem. Float64 always
works on the float32 values the kernel reads (the packed structs), so that only the kernel's arithmetic is
measured. A row passes when its error is within its bound and no NaN or Inf appeared; a known limit is a
row whose bound is a stated limit of float32 rather than a guarantee, held so that it cannot get worse.

One module per group of cases, in the order of CASES: meshes, rectangles, ellipsoids, lights, phong, camera,
limits (image sizes and sample counts), degenerate_input, textures; common.py holds what several of them share,
table.py runs them and prints the table."""
from .common import Env, Row
from .meshes import mesh_edges
from .rectangles import grazing_rectangles
from .ellipsoids import extreme_ellipsoids, grazing_ellipsoids
from .lights import lights_at_horizon
from .phong import phong_power
from .camera import extreme_fov, far_camera
from .limits import deep_accumulation, image_sizes
from .degenerate_input import degenerate_input
from .textures import textured_grazing

CASES = [mesh_edges, grazing_rectangles, grazing_ellipsoids, extreme_ellipsoids, lights_at_horizon, phong_power,
         extreme_fov, far_camera, image_sizes, deep_accumulation, degenerate_input, textured_grazing]

# table.py reads CASES from this package, so it is imported after CASES is defined.
from .table import format_row, report, run_case  # noqa: E402

__all__ = ["CASES", "Env", "Row", "format_row", "report", "run_case"]
