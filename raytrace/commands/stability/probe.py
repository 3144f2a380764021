"""Running small kernels around the renderer's own OpenCL functions on numpy arrays: the stability suite
(`python -m raytrace stability`) and the test suite (tests/conftest.py's `harness`) both use it.

Work-item i handles elements [i LANES, (i + 1) LANES) of planar arrays: a 3-vector array holds n x's, then
n y's, then n z's. The macros below read and write them at either lane width."""
import numpy as np
import pyopencl as cl

from ...renderer.device import context_for, select_device
from ...renderer.program import build
from ...renderer.interface import KernelArguments
from ...renderer.scene_tables import scene_tables

PRELUDE = """
#include "lanes.h"
#define I ((int)get_global_id(0))
#if LANES == 1
#define IN(p) ((p)[I])
#define OUT(p, v) ((p)[I] = (v))
#else
#define IN(p) CAT(vload, LANES)(I, (p))
#define OUT(p, v) CAT(vstore, LANES)((v), I, (p))
#endif
#define IN3(p) v3(IN(p), IN((p) + n), IN((p) + 2 * n))
#define OUT3(p, v) do { vec3 v_ = (v); OUT((p), v_.x); OUT((p) + n, v_.y); OUT((p) + 2 * n, v_.z); } while (0)
"""


def planar(v):
    """(n, 3) -> (3, n) float32, the layout IN3 reads."""
    return np.ascontiguousarray(np.asarray(v, dtype=np.float64).T, dtype=np.float32)


def _padded(a, n, padded):
    """A per-element array (numeric, last axis n) with its last element repeated up to `padded`."""
    if not isinstance(a, np.ndarray) or a.dtype.names is not None or not a.ndim or a.shape[-1] != n:
        return a
    return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, padded - n)], mode="edge")


class Probe:
    """Builds a kernel source once per (source, options) and runs it over numpy arrays."""
    _programs = {}

    def __init__(self, lanes, device=None, env=None):
        """env: an existing (context, queue) to share, so that programs built once are reused."""
        self.lanes = lanes
        self.context, self.queue = env or context_for(select_device(device))

    def _program(self, source, defines):
        options = [f"-DLANES={self.lanes}"] + [f"-D{k}={int(v)}" for k, v in defines.items()]
        key = (self.context, source, tuple(options))
        if key not in self._programs:
            self._programs[key] = build(self.context, PRELUDE + source, options)[0]
        return self._programs[key]

    @staticmethod
    def _array(array):
        """What a buffer is made of: float64 as float32, contiguous, at least one element."""
        array = np.ascontiguousarray(array.astype(np.float32) if array.dtype == np.float64 else array)
        return array if array.size else np.zeros(1, array.dtype)

    def _buffer(self, array):
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=self._array(array))

    def _local_size(self):
        """The launch's local size: one work-item per group for the vector kernels on a CPU, as the renderer
        launches them (renderer/device_render.py's work_group_shape); else the runtime's choice. PoCL's own
        choice for a launch of 2048 or more work-items of a test kernel that includes bsdf.cl at 16 lanes
        crashed the process (a segmentation fault), where groups of one run any size."""
        return (1,) if self.lanes > 1 and self.queue.device.type & cl.device_type.CPU else None

    def run(self, source, name, n, args, outputs, **defines):
        """Run kernel `name` over n elements. It receives `int n`, the `args` (numpy arrays are copied in,
        float64 as float32; numpy scalars pass as they are), then one float buffer per entry of `outputs`
        ({name: components}). `args` is a list, taken in the kernel's order after n, or a dict, bound by name
        like the renderer's own arguments (renderer/interface.py): a kernel that takes a whole scene declares
        kernels/scene.h's SCENE_PARAMETERS and gets scene_args(scene) by name. Where n is no multiple of
        LANES, the per-element arrays (plain numeric ones whose last axis is n) are padded to one by repeating
        their last element, and the outputs cut back to n. Returns {name: float64 array, (n,) or
        (components, n)}."""
        if n % self.lanes:
            padded = -(-n // self.lanes) * self.lanes
            pad = lambda a: _padded(a, n, padded)  # noqa: E731
            args = {k: pad(a) for k, a in args.items()} if isinstance(args, dict) else [pad(a) for a in args]
            return {k: v[..., :n] for k, v in self.run(source, name, padded, args, outputs, **defines).items()}
        kernel = cl.Kernel(self._program(source, defines), name)
        host = {k: np.empty((c, n), np.float32) for k, c in outputs.items()}
        bufs = {k: cl.Buffer(self.context, cl.mem_flags.WRITE_ONLY, h.nbytes) for k, h in host.items()}
        if isinstance(args, dict):
            bound = KernelArguments(kernel)
            bound.set("n", np.int32(n))
            bound.upload(self.context, {k: self._array(a) for k, a in args.items() if isinstance(a, np.ndarray)})
            for k, a in args.items():
                if not isinstance(a, np.ndarray):
                    bound.set(k, a)
            for k in outputs:
                bound.set(k, host[k], bufs[k])
            bound.launch(self.queue, (n // self.lanes,), self._local_size())
        else:
            kernel_args = [np.int32(n)] + [self._buffer(a) if isinstance(a, np.ndarray) else a for a in args]
            kernel(self.queue, (n // self.lanes,), self._local_size(), *kernel_args, *bufs.values())
        for h, b in zip(host.values(), bufs.values()):
            cl.enqueue_copy(self.queue, h, b)
        return {k: (h[0] if outputs[k] == 1 else h).astype(np.float64) for k, h in host.items()}


# The renderer's closest_hit over a scene's shapes and lights (without a BVH), every field of the Hit a test
# looks at: run it with {**scene_args(scene), "o": planar(o), "d": planar(d)} and CLOSEST_HIT_OUTPUTS.
CLOSEST_HIT = """
#include "intersect.cl"
__kernel void closest(int n, SCENE_PARAMETERS, __global const float *o, __global const float *d,
                      __global float *t, __global float *p, __global float *err, __global float *nrm,
                      __global float *material, __global float *emitted)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    Ray r = {IN3(o), IN3(d)};
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    OUT(t, hit.t);
    OUT3(p, hit.p);
    OUT(err, hit.err);
    OUT3(nrm, hit.n);
    OUT(material, CONVERT_VFLOAT(hit.material));
    OUT(emitted, hit.emitted.x);
}
"""
CLOSEST_HIT_OUTPUTS = {"t": 1, "p": 3, "err": 1, "nrm": 3, "material": 1, "emitted": 1}


def scene_args(scene, **options):
    """The scene's tables (kernels/scene.h's SCENE_PARAMETERS) by name; `options` as scene_tables.scene_tables
    takes them. A kernel that also declares TEXTURE_PARAMETERS gets packing.texture_tables(scene) too."""
    return scene_tables(scene, **options)
