"""OpenCL device selection, contexts and the lane width a device wants."""
import ctypes
import os
import struct
from functools import lru_cache

import pyopencl as cl

from ..errors import InputError

# LLVM 14 (in PoCL 3.0 from PyPI) names CPUs newer than itself "generic", which its own compiler then
# rejects ("unknown target CPU 'generic'", pocl issue 1049): every build fails on, e.g., AMD Zen 5.
# PoCL 3.0 offers no setting for it, so we point the device's llvm_cpu field at a CPU LLVM 14 knows
# and this one can run: x86-64-v3 (AVX2 + FMA), the baseline the PoCL notes measured.
_FALLBACK_CPU = b"x86-64-v3"
_patched = {}  # device address -> the name buffer its llvm_cpu now points at (kept alive)


def _fix_generic_pocl_cpu(device):
    if device.int_ptr in _patched or "pthread" not in device.version \
            or not device.version.rstrip().endswith("-generic"):
        return
    cpu = ctypes.create_string_buffer(_FALLBACK_CPU)
    with open("/proc/self/mem", "rb", buffering=0) as mem:  # reads of bad addresses fail, never crash
        mem.seek(device.int_ptr)
        blob = mem.read(4096)
        for offset in range(0, len(blob), 8):
            (pointer,) = struct.unpack_from("<Q", blob, offset)
            if not 4096 <= pointer < 1 << 47:
                continue
            try:
                mem.seek(pointer)
                if mem.read(8) != b"generic\0":
                    continue
            except OSError:
                continue
            ctypes.c_void_p.from_address(device.int_ptr + offset).value = ctypes.addressof(cpu)
            _patched[device.int_ptr] = cpu
            return  # the first such field is llvm_cpu, the target of code generation


def list_devices():
    return [(p, d) for p in cl.get_platforms() for d in p.get_devices()]


DEVICE_TYPES = {"cpu": cl.device_type.CPU, "gpu": cl.device_type.GPU}


def select_device(spec=None):
    """`spec`: None (the first CPU device, else the first device), "cpu" or "gpu" (the first of that type),
    "P:D" indices, or a name substring."""
    devices = list_devices()
    if not devices:
        raise InputError("command line", "--device", spec, "no OpenCL device found")
    if spec is None:
        cpus = [d for _, d in devices if d.type & cl.device_type.CPU]
        device = (cpus or [devices[0][1]])[0]
    elif spec.lower() in DEVICE_TYPES:
        of_type = [d for _, d in devices if d.type & DEVICE_TYPES[spec.lower()]]
        if not of_type:
            names = "; ".join(f"{p.name}: {d.name}" for p, d in devices)
            raise InputError("command line", "--device", spec, f"no {spec.upper()} device (have: {names})")
        device = of_type[0]
    elif ":" in spec and all(part.isdigit() for part in spec.split(":")):
        p, d = (int(x) for x in spec.split(":"))
        platforms = cl.get_platforms()
        if p >= len(platforms) or d >= len(platforms[p].get_devices()):
            raise InputError("command line", "--device", spec, "no such platform:device index")
        device = platforms[p].get_devices()[d]
    else:
        matches = [d for p, d in devices if spec.lower() in f"{p.name} {d.name}".lower()]
        if not matches:
            names = "; ".join(f"{p.name}: {d.name}" for p, d in devices)
            raise InputError("command line", "--device", spec, f"matches no device (have: {names})")
        device = matches[0]
    _fix_generic_pocl_cpu(device)
    return device


@lru_cache(maxsize=None)
def context_for(device):
    context = cl.Context([device])
    return context, cl.CommandQueue(context, properties=cl.command_queue_properties.PROFILING_ENABLE)


def default_lanes(device):
    """8 pixels per work-item on CPUs (explicit float8), 1 on GPUs (the hardware already has lanes)."""
    env = os.environ.get("RAYTRACE_LANES")
    if env:
        return int(env)
    return 8 if device.type & cl.device_type.CPU else 1


def describe(device):
    return f"{device.platform.name}: {device.name}"
