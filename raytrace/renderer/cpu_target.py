"""The code-generation target of PoCL's CPU device, and the lane width that fills its vectors.

PoCL 3.0's LLVM 14 names its target after the CPU, and knows nothing newer than itself: a newer CPU gets
"generic", which its own compiler then rejects (pocl issue 1049), or an older sibling's name, AMD Zen 4 the
AVX2-only "znver3" although it has AVX-512. So the vector width comes from the CPU's own features instead:
the highest x86-64 micro-architecture level (the x86-64 psABI's v2, v3, v4) whose instructions /proc/cpuinfo
lists. PoCL's own target is kept where it has that level's width (its scheduling model is the CPU's: the
level's generic name was slower, measured in commit defb116), else the level is the target; the lane width is the
number of floats in one vector (16 with AVX-512, 8 with AVX2, 4 with SSE). PoCL 3.0 has no setting for its
target, so the device's llvm_cpu field is pointed at the level's name (the pointer swap of _point_llvm_cpu).

RAYTRACE_TARGET (a level, or "pocl" for PoCL's own choice) and RAYTRACE_LANES (1, 4, 8 or 16) override
both; a level this CPU cannot run, or lanes wider than the target's vectors (LLVM 14 then runs out of
memory building the kernel, an abort no caller can catch), is an InputError naming the variable."""
import ctypes
import os
import struct
from dataclasses import dataclass
from functools import lru_cache

from ..errors import InputError
from ..structs import LANE_WIDTHS

# The x86-64 psABI's levels: the /proc/cpuinfo flags each adds, and its vector width in bits.
LEVELS = {
    "x86-64-v2": ({"cx16", "lahf_lm", "popcnt", "sse4_1", "sse4_2", "ssse3"}, 128),
    "x86-64-v3": ({"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "abm", "movbe", "xsave"}, 256),
    "x86-64-v4": ({"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"}, 512),
}
# LLVM 14's names for CPUs with AVX-512 and with AVX2, for the width of PoCL's own choice ("pocl").
AVX512_CPUS = {"skylake-avx512", "cascadelake", "cooperlake", "cannonlake", "icelake-client", "icelake-server",
               "tigerlake", "rocketlake", "sapphirerapids", "knl", "knm", "x86-64-v4"}
AVX2_CPUS = {"haswell", "broadwell", "skylake", "alderlake", "znver1", "znver2", "znver3", "bdver4", "x86-64-v3"}
ISA_OF_BITS = {512: "AVX-512", 256: "AVX2", 128: "SSE"}


@dataclass(frozen=True)
class Target:
    """What the kernel is built for: `llvm_cpu` (PoCL's target), its vector width, and the lanes to run."""
    llvm_cpu: str
    vector_bits: int
    lanes: int

    @property
    def lanes_max(self):
        return self.vector_bits // 32

    @property
    def isa(self):
        return ISA_OF_BITS[self.vector_bits]


@lru_cache(maxsize=1)
def cpu_flags():
    try:
        with open("/proc/cpuinfo") as f:
            return set(next(line for line in f if line.startswith("flags")).split(":", 1)[1].split())
    except (OSError, StopIteration):
        return set()


def cpu_level(flags):
    """The highest psABI level all of whose flags (and its predecessors') the CPU has, else None."""
    best, needed = None, set()
    for name, (added, _) in LEVELS.items():
        needed |= added
        if not needed <= flags:
            break
        best = name
    return best


def pocl_cpu_name(device):
    """The LLVM CPU name PoCL chose: what follows the target triple in the device's version string."""
    hstr = device.version.rstrip().split("pthread-", 1)[-1]
    return "-".join(hstr.split("-")[4:])


def _vector_bits(llvm_cpu):
    if llvm_cpu in LEVELS:
        return LEVELS[llvm_cpu][1]
    return 512 if llvm_cpu in AVX512_CPUS else 256 if llvm_cpu in AVX2_CPUS else 128


LANES_ALLOWED = tuple(n for n in LANE_WIDTHS if n > 0)
LANES_CHOICE = f"must be one of {', '.join(map(str, LANES_ALLOWED))}"


def lanes_for(vector_bits, default):
    """RAYTRACE_LANES if set (checked against the target's vector width, where known), else `default`."""
    override = os.environ.get("RAYTRACE_LANES")
    if override is None:
        return default
    if override.strip() not in {str(n) for n in LANES_ALLOWED}:
        raise InputError("environment", "RAYTRACE_LANES", override, LANES_CHOICE)
    lanes = int(override)
    if vector_bits is not None and lanes * 32 > vector_bits:
        raise InputError("environment", "RAYTRACE_LANES", override, _too_wide(vector_bits, ISA_OF_BITS[vector_bits]))
    return lanes


def check_lanes(target, lanes, source, key):
    """Refuse `lanes` (given at `source`'s `key`) that the kernel does not take, or wider than the Target's
    vectors; None targets take any the kernel takes."""
    if not isinstance(lanes, int) or isinstance(lanes, bool) or lanes not in LANES_ALLOWED:
        raise InputError(source, key, lanes, LANES_CHOICE)
    if target is not None and lanes * 32 > target.vector_bits:
        raise InputError(source, key, lanes, _too_wide(target.vector_bits, f"{target.llvm_cpu}, {target.isa}"))


def _too_wide(vector_bits, isa):
    return f"wider than the target's {vector_bits}-bit vectors ({isa}): at most {vector_bits // 32} lanes"


def choose_target(pocl_cpu, flags):
    """The Target for a CPU with these flags whose PoCL device chose `pocl_cpu`, with the overrides."""
    level = cpu_level(flags)
    name = os.environ.get("RAYTRACE_TARGET")
    if name is None:  # PoCL's own name where it already has the level's vector width: it is tuned for the CPU
        keep = level is None or (pocl_cpu != "generic" and _vector_bits(pocl_cpu) == LEVELS[level][1])
        name = pocl_cpu if keep else level
    elif name == "pocl":
        if pocl_cpu == "generic":
            raise InputError("environment", "RAYTRACE_TARGET", name,
                             "PoCL's own choice for this CPU is 'generic', which its compiler rejects")
        name = pocl_cpu
    elif name not in LEVELS:
        raise InputError("environment", "RAYTRACE_TARGET", name, f"must be pocl or one of {', '.join(LEVELS)}")
    elif level is None or list(LEVELS).index(name) > list(LEVELS).index(level):
        raise InputError("environment", "RAYTRACE_TARGET", name,
                         f"this CPU cannot run it (its level: {level or 'below x86-64-v2'})")
    bits = _vector_bits(name)
    return Target(name, bits, lanes_for(bits, bits // 32))


_current = {}  # device address -> (the name its llvm_cpu points at now, the buffer holding it, kept alive)


def _point_llvm_cpu(device, name):
    """Point PoCL's device at LLVM CPU `name`: the first pointer in the device struct to the string of its
    current target is its llvm_cpu field, the target of code generation."""
    current = current_llvm_cpu(device)
    if name == current:
        return
    wanted = ctypes.create_string_buffer(name.encode())
    with open("/proc/self/mem", "rb", buffering=0) as mem:  # reads of bad addresses fail, never crash
        mem.seek(device.int_ptr)
        blob = mem.read(4096)
        for offset in range(0, len(blob), 8):
            (pointer,) = struct.unpack_from("<Q", blob, offset)
            if not 4096 <= pointer < 1 << 47:
                continue
            try:
                mem.seek(pointer)
                if mem.read(len(current) + 1) != current.encode() + b"\0":
                    continue
            except OSError:
                continue
            ctypes.c_void_p.from_address(device.int_ptr + offset).value = ctypes.addressof(wanted)
            _current[device.int_ptr] = (name, wanted)
            return
    raise RuntimeError(f"PoCL's llvm_cpu field ({current}) not found")


def is_pocl_cpu(device):
    return "pthread" in device.version


def current_llvm_cpu(device):
    """The LLVM CPU a PoCL CPU device builds for now (None for other devices)."""
    if not is_pocl_cpu(device):
        return None
    return _current.get(device.int_ptr, (pocl_cpu_name(device),))[0]


def apply_target(device):
    """Choose the Target of a PoCL CPU device (from this CPU's flags and the overrides) and point the device
    at it; None for any other device."""
    if not is_pocl_cpu(device):
        return None
    target = choose_target(pocl_cpu_name(device), cpu_flags())
    _point_llvm_cpu(device, target.llvm_cpu)
    return target


def describe_target(device, lanes):
    """How the kernel runs on `device`: its code-generation target and ISA where PoCL's CPU device builds it,
    and the lane width."""
    target = apply_target(device)
    where = f"{target.llvm_cpu} ({target.isa}), " if target is not None else ""
    return f"{where}{lanes} lanes"
