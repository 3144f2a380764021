"""`python -m raytrace compile SCENE --target T`: the scene's specialised kernel compiled for another device
than this one, to catch a construct that only PoCL accepts before a GPU user does.

The kernel is the renderer's own source with the scene's -D options (raytrace/renderer/program.py's Features), built
with LANES=1 as GPUs run it, by Debian's clang (OpenCL C 1.2, clang's default OpenCL header):
nvptx (NVIDIA, PTX assembly), amdgcn (AMD, an object for gfx90a; -nogpulib, as there is no ROCm device
library here) and spir (SPIR 64-bit LLVM bitcode, what OpenCL drivers that take SPIR consume). `pocl` builds
it with this machine's PoCL at the device's own lane width and reports the size of the binary it keeps."""
import shutil
import subprocess
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from ..errors import InputError
from ..renderer.program import Features, build, kernel_dir

CLANG_TARGETS = {
    "nvptx": ["-target", "nvptx64-nvidia-cuda", "-S"],
    "amdgcn": ["-target", "amdgcn-amd-amdhsa", "-mcpu=gfx90a", "-nogpulib", "-c"],
    "spir": ["-target", "spir64", "-emit-llvm", "-c"],
}
TARGETS = ["pocl", *CLANG_TARGETS]
SOURCE = '#include "render.cl"\n'


def _clang(features, target):
    """(bytes of the output, seconds); a compile error raises RuntimeError with clang's first error line."""
    clang = shutil.which("clang")
    if clang is None:
        raise InputError("command line", "--target", target, "needs clang (Debian: apt-get install clang)")
    with tempfile.TemporaryDirectory() as tmp:
        source, output = Path(tmp) / "render_entry.cl", Path(tmp) / "out"
        source.write_text(SOURCE)
        command = [clang, "-x", "cl", "-cl-std=CL1.2", "-Xclang", "-finclude-default-header", "-O2",
                   *CLANG_TARGETS[target], *features.options(), "-I", str(kernel_dir()), str(source), "-o", str(output)]
        start = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if result.returncode != 0:
            errors = [line for line in result.stderr.splitlines() if "error" in line] or [result.stderr.strip()]
            raise RuntimeError(errors[0])
        return output.stat().st_size, seconds


def _pocl(features):
    from ..renderer.device import context_for, select_device
    context, _ = context_for(select_device(None))
    program, seconds = build(context, SOURCE, features.options())
    return sum(len(b) for b in program.binaries), seconds


def compile_scene(scene, target, lanes=None):
    """{target, lanes, options, bytes, seconds} of the scene's kernel built for `target`."""
    if target not in TARGETS:
        raise InputError("command line", "--target", target, f"unknown target (have: {', '.join(TARGETS)})")
    if target == "pocl":
        from ..renderer.device import default_lanes, select_device
        features = Features.of(scene, lanes or default_lanes(select_device(None)))
        size, seconds = _pocl(features)
    else:
        features = replace(Features.of(scene, 1), lanes=lanes or 1)
        size, seconds = _clang(features, target)
    return {"target": target, "lanes": features.lanes, "options": features.options(), "bytes": size,
            "seconds": seconds}
