"""Every struct in kernels/types.h against its numpy mirror in raytrace/types.py: sizes and offsets as
this device's compiler lays them out."""
import numpy as np
import pyopencl as cl

from raytrace import types
from raytrace.kernel import build


def layout_source():
    checks = []
    for struct, dtype in types.STRUCTS.items():
        checks.append(f"sizeof({struct})")
        checks += [f"__builtin_offsetof({struct}, {field})" for field in dtype.names]
    body = "\n".join(f"    out[{i}] = {c};" for i, c in enumerate(checks))
    return f'#include "types.h"\n__kernel void layout(__global int *out)\n{{\n{body}\n}}\n', len(checks)


def host_layout():
    values = []
    for dtype in types.STRUCTS.values():
        values.append(dtype.itemsize)
        values += [dtype.fields[name][1] for name in dtype.names]
    return values


def test_struct_layout_matches_device(cl_env):
    context, queue = cl_env
    source, n = layout_source()
    program, _ = build(context, source)
    out = np.zeros(n, np.int32)
    buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "layout")(queue, (1,), None, buf)
    cl.enqueue_copy(queue, out, buf)
    assert out.tolist() == host_layout()


def test_no_struct_has_hidden_padding():
    """Only 4-byte fields: the field sizes add up to the struct size, on every OpenCL device."""
    for dtype in types.STRUCTS.values():
        assert sum(dtype.fields[name][0].itemsize for name in dtype.names) == dtype.itemsize


def test_constants_match_device(cl_env):
    """The WRAP_*, TEXELS_*, FILTER_*, RANDOMIZE_* and SHAPE_* macros of kernels/types.h against their mirrors in raytrace/types.py."""
    names = {f"WRAP_{k.upper()}": v for k, v in types.WRAP_MODES.items()}
    names |= {f"FILTER_{k.upper()}": v for k, v in types.FILTERS.items()}
    names |= {f"RANDOMIZE_{k.upper()}": v for k, v in types.RANDOMIZE.items()}
    names |= {f"SHAPE_{k.upper()}": v for k, v in types.SHAPES.items()}
    names |= {"TEXELS_SRGB8": types.TEXELS_SRGB8, "TEXELS_UNORM8": types.TEXELS_UNORM8,
              "TEXELS_FLOAT": types.TEXELS_FLOAT}
    context, queue = cl_env
    body = "\n".join(f"    out[{i}] = {name};" for i, name in enumerate(names))
    program, _ = build(context, f'#include "types.h"\n__kernel void constants(__global int *out)\n{{\n{body}\n}}\n')
    out = np.zeros(len(names), np.int32)
    buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "constants")(queue, (1,), None, buf)
    cl.enqueue_copy(queue, out, buf)
    assert out.tolist() == list(names.values())
