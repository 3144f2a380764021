"""OpenCL device selection, contexts and the lane width a device wants."""
import errno
import os
import re
import tempfile
from functools import lru_cache
from pathlib import Path

import pyopencl as cl

from ..errors import API, InputError
from .cpu_target import apply_target, lanes_for


def _check_pocl_cache_dir():
    """PoCL keeps built kernels in POCL_CACHE_DIR, creating it as needed; one it cannot write fails every build
    (or hides every device), so it is checked first: the directory, or its nearest existing parent, must take
    a new file."""
    value = os.environ.get("POCL_CACHE_DIR")
    if not value:
        return
    path = Path(value).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        if not path.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, "not a directory", str(path))
        tempfile.TemporaryFile(dir=path).close()
    except OSError as e:
        raise InputError("environment", "POCL_CACHE_DIR", value,
                         f"PoCL cannot keep its kernel cache there: {path}: {e.strerror or e}") from None


def list_devices():
    _check_pocl_cache_dir()
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # no ICD at all: PLATFORM_NOT_FOUND_KHR
        platforms = []
    return [(p, d) for p in platforms for d in p.get_devices()]


def _no_device():
    """The one-line error for a machine where OpenCL offers no device: the environment variable that hid them,
    if one is set."""
    for variable in ("POCL_DEVICES", "OCL_ICD_VENDORS", "OCL_ICD_FILENAMES"):
        if os.environ.get(variable) is not None:
            return InputError("environment", variable, os.environ[variable], "leaves no OpenCL device")
    return InputError("environment", "OpenCL", None, "no device found (the pocl-binary-distribution package "
                      "from PyPI provides a CPU one)")


DEVICE_TYPES = {"cpu": cl.device_type.CPU, "gpu": cl.device_type.GPU}


def select_device(spec=None):
    """`spec`: None (RAYTRACE_DEVICE's spec where it is set, else the first CPU device, else the first device),
    "cpu" or "gpu" (the first of that type), "P:D" indices, or a name substring. RAYTRACE_DEVICE moves a
    whole process to another device, the test suite included (.ci/gpu runs it on a GPU that way)."""
    devices = list_devices()
    if not devices:
        raise _no_device()
    source, key = API, "device"
    if spec is None and os.environ.get("RAYTRACE_DEVICE") is not None:
        spec, source, key = os.environ["RAYTRACE_DEVICE"], "environment", "RAYTRACE_DEVICE"
    if spec is not None and not spec.strip():
        raise InputError(source, key, spec, "must name a device: cpu, gpu, P:D indices or part of a name")
    names = "; ".join(f"{p.name}: {d.name}" for p, d in devices)
    if spec is None:
        cpus = [d for _, d in devices if d.type & cl.device_type.CPU]
        device = (cpus or [devices[0][1]])[0]
    elif spec.lower() in DEVICE_TYPES:
        of_type = [d for _, d in devices if d.type & DEVICE_TYPES[spec.lower()]]
        if not of_type:
            raise InputError(source, key, spec, f"no {spec.upper()} device (have: {names})")
        device = of_type[0]
    elif re.fullmatch(r"[0-9]+:[0-9]+", spec):
        p, d = (int(x) for x in spec.split(":"))
        platforms = cl.get_platforms()
        if p >= len(platforms) or d >= len(platforms[p].get_devices()):
            raise InputError(source, key, spec, "no such platform:device index")
        device = platforms[p].get_devices()[d]
    else:
        matches = [d for p, d in devices if spec.lower() in f"{p.name} {d.name}".lower()]
        if not matches:
            raise InputError(source, key, spec, f"matches no device (have: {names})")
        device = matches[0]
    apply_target(device)
    return device


@lru_cache(maxsize=None)
def context_for(device):
    context = cl.Context([device])
    return context, cl.CommandQueue(context, properties=cl.command_queue_properties.PROFILING_ENABLE)


def default_lanes(device):
    """Pixels per work-item: on PoCL's CPU device the floats in one vector of its target (cpu_target.py),
    on other CPUs 8 (explicit float8), on GPUs 1 (the hardware already has lanes); RAYTRACE_LANES overrides."""
    target = apply_target(device)
    if target is not None:
        return target.lanes
    return lanes_for(None, 8 if device.type & cl.device_type.CPU else 1)


def describe(device):
    return f"{device.platform.name}: {device.name}"
