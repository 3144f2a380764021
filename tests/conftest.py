"""Shared fixtures: the OpenCL device (real PoCL), and a harness that runs small test kernels over
LANES-wide inputs so every kernel function is checked at both widths the renderer uses."""
import numpy as np
import pyopencl as cl
import pytest

from raytrace.device import context_for, select_device
from raytrace.kernel import build
from raytrace.scene import load_scene
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Macros for test kernels: work-item i handles elements [i*LANES, (i+1)*LANES) of planar arrays, where a
# 3-vector array holds n x's, then n y's, then n z's.
PRELUDE = """
#include "lanes.h"
#define I ((int)get_global_id(0))
#define IN(p) VLOAD(I, (p))
#define IN3(p) v3(VLOAD(I, (p)), VLOAD(I, (p) + n), VLOAD(I, (p) + 2 * n))
#define OUT(p, v) VSTORE((v), I, (p))
#define OUT3(p, v) do { vec3 v_ = (v); VSTORE(v_.x, I, (p)); VSTORE(v_.y, I, (p) + n); \\
                        VSTORE(v_.z, I, (p) + 2 * n); } while (0)
"""


@pytest.fixture(scope="session")
def device():
    return select_device(None)


@pytest.fixture(scope="session")
def cl_env(device):
    return context_for(device)


@pytest.fixture(scope="session")
def cornell():
    return load_scene(ROOT / "scenes" / "cornell.toml")


@pytest.fixture(params=[1, 8], ids=["lanes1", "lanes8"])
def lanes(request):
    return request.param


class Harness:
    """Build a test kernel once per (source, options) and run it on numpy arrays."""
    _programs = {}

    def __init__(self, cl_env, lanes):
        (self.context, self.queue), self.lanes = cl_env, lanes

    def program(self, source, **defines):
        options = [f"-DLANES={self.lanes}"] + [f"-D{k}={int(v)}" for k, v in defines.items()]
        key = (self.context, source, tuple(options))
        if key not in self._programs:
            self._programs[key] = build(self.context, PRELUDE + source, options)[0]
        return self._programs[key]

    def buffer(self, array):
        array = np.ascontiguousarray(array)
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                         hostbuf=array if array.size else np.zeros(1, array.dtype))

    def run(self, source, name, n, args, outputs, **defines):
        """Run kernel `name` over n elements (n a multiple of LANES). `args`: numpy arrays (copied in,
        float64 ones as float32), numpy scalars, or cl buffers. `outputs`: {name: components}; returns
        {name: float64 array of shape (n,) or (components, n)}. The kernel receives `int n`, the args,
        then the output buffers."""
        assert n % self.lanes == 0
        kernel_args = [np.int32(n)]
        for a in args:
            if isinstance(a, np.ndarray):
                a = self.buffer(a.astype(np.float32) if a.dtype == np.float64 else a)
            kernel_args.append(a)
        host = {k: np.empty((c, n), np.float32) for k, c in outputs.items()}
        bufs = {k: cl.Buffer(self.context, cl.mem_flags.WRITE_ONLY, h.nbytes) for k, h in host.items()}
        cl.Kernel(self.program(source, **defines), name)(self.queue, (n // self.lanes,), None,
                                                        *kernel_args, *bufs.values())
        for k in host:
            cl.enqueue_copy(self.queue, host[k], bufs[k])
        return {k: (h[0] if outputs[k] == 1 else h).astype(np.float64) for k, h in host.items()}


@pytest.fixture
def harness(cl_env, lanes):
    return Harness(cl_env, lanes)


def planar(v):
    """(n, 3) -> (3, n) float32, the layout IN3 reads."""
    return np.ascontiguousarray(np.asarray(v, dtype=np.float64).T, dtype=np.float32)
