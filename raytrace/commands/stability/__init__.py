"""The numerical stability suite (`python -m raytrace stability`, tests/stability/): the kernel's float32
results at the edges of its input space, against float64 computed here, independently, in numpy.

Each case is one function returning rows: what is measured, the largest error found, and the bound it is
held to, argued in the case's docstring from the float32 rounding of the computation (u = 2^-24, the unit
roundoff; OpenCL 1.2's ulp limits for the builtins) and the conditioning of the problem. Float64 always
works on the float32 values the kernel reads (the packed structs), so that only the kernel's arithmetic is
measured. A row passes when its error is within its bound and no NaN or Inf appeared; a known limit is a
row whose bound is a stated limit of float32 rather than a guarantee, held so that it cannot get worse.

One module per group of cases, in the order of CASES: meshes, rectangles, ellipsoids, affine_shapes (disks and
cylinders), lights, phong, camera,
limits (image sizes and sample counts), degenerate_input, textures, transforms, instances; common.py holds what several of them share,
table.py runs them and prints the table."""
from .cases import CASES
from .common import Env, Row
from .table import format_row, report, run_case

__all__ = ["CASES", "Env", "Row", "format_row", "report", "run_case"]
