#!/usr/bin/env python3
"""Mitsuba 3 as an AVX2 CPU runs it, on an AVX-512 one: the project's second CPU kind, measured where no AVX2
machine is lent (raytrace's twin is RAYTRACE_TARGET=x86-64-v3). A developer rig, run with Mitsuba's Python
(mitsuba_path.py's header says how to install it).

- Dr.Jit's LLVM backend compiles for x86-64-v3 at 8 lanes: jit_llvm_set_target, Dr.Jit's C++ API, reached
  by ctypes.
- Embree is opened with isa=avx2, a device configuration (Embree's API manual, rtcNewDevice). Mitsuba opens
  its device with a fixed one, so embree_config.c, preloaded, appends to it: the process builds it with $CC
  or cc and runs itself again.

Memory and caches stay the AVX-512 machine's. Scene 0 against Mitsuba, 2-core Xeon (CPUID family 6 model
207): 2.91x with both at this level, 3.32x native, where a real Zen 3 gave 3.09x.

Used by mitsuba_path.py and mitsuba_xml_render.py --isa avx2 (select), or around any Mitsuba script:
  MTS/bin/python devtools/peers/mitsuba_isa.py avx2 SCRIPT [ARGUMENTS ...]
"""
import ctypes
import hashlib
import os
import runpy
import subprocess
import sys
import tempfile

# x86-64-v3 (the psABI's AVX2 level, raytrace's own name for it), its features spelled out because Dr.Jit
# passes the feature string as given: without -avx512f the host's AVX-512 would come back in.
LEVELS = {"avx2": ("x86-64-v3", "+avx,+avx2,+bmi,+bmi2,+f16c,+fma,+lzcnt,+movbe,+popcnt,+sse4.2,-avx512f", 8)}


def preload_embree_config(config):
    """Run this process again with embree_config.c preloaded and appending `config` to Embree's device
    configuration; return at once where that is already so."""
    if os.environ.get("RAYTRACE_EMBREE_CONFIG") == config:
        return
    source = os.path.join(os.path.dirname(os.path.abspath(__file__)), "embree_config.c")
    with open(source, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()[:16]
    library = os.path.join(tempfile.gettempdir(), f"raytrace-embree-config-{digest}.so")
    if not os.path.exists(library):
        partial = f"{library}.{os.getpid()}"
        subprocess.run([os.environ.get("CC", "cc"), "-O2", "-shared", "-fPIC", "-o", partial, source, "-ldl"],
                       check=True)
        os.replace(partial, library)
    env = dict(os.environ, RAYTRACE_EMBREE_CONFIG=config,
               LD_PRELOAD=" ".join(filter(None, [library, os.environ.get("LD_PRELOAD")])))
    os.execve(sys.executable, [sys.executable] + sys.argv, env)


def _drjit_core():
    import drjit
    return ctypes.CDLL(os.path.join(os.path.dirname(drjit.__file__), "libdrjit-core.so"))


def set_llvm_target(cpu, features, lanes):
    """Point Dr.Jit's LLVM backend at another CPU; kernels compiled from here on are for it (its disk cache
    keys them by the target too). The functions are C++ ones, called by their mangled names."""
    set_target = _drjit_core()._Z19jit_llvm_set_targetPKcS0_j
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(cpu.encode(), features.encode(), lanes)


def llvm_target():
    """The CPU Dr.Jit's LLVM backend compiles for."""
    target_cpu = _drjit_core()._Z19jit_llvm_target_cpuv
    target_cpu.restype = ctypes.c_char_p
    return target_cpu().decode()


def restrict(level, variant):
    """Before a scene loads: Embree and Dr.Jit at `level` (a key of LEVELS), Mitsuba at `variant` (an llvm one).
    May run the process again first (see preload_embree_config)."""
    if not variant.startswith("llvm_"):
        raise SystemExit(f"mitsuba_isa: {level} needs an llvm variant, not {variant}")
    preload_embree_config(f"isa={level}")
    import mitsuba
    mitsuba.set_variant(variant)
    set_llvm_target(*LEVELS[level])


def select(ap, isa, variant):
    """Mitsuba at `variant`, Dr.Jit and Embree at `isa` (a script's --isa: "native", or a key of LEVELS through
    restrict); ap.error where `isa` needs an llvm variant and `variant` is none."""
    if isa == "native":
        import mitsuba
        mitsuba.set_variant(variant)
    elif not variant.startswith("llvm_"):
        ap.error(f"--isa {isa} needs an llvm variant, not --variant {variant}")
    else:
        restrict(isa, variant)


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in LEVELS:
        raise SystemExit(f"usage: mitsuba_isa.py {{{','.join(LEVELS)}}} SCRIPT [ARGUMENTS ...]")
    restrict(sys.argv[1], "llvm_ad_rgb")
    script = sys.argv[2]
    sys.argv = sys.argv[2:]
    runpy.run_path(script, run_name="__main__")
    print(f"mitsuba_isa: Dr.Jit compiled for {llvm_target()}", file=sys.stderr)


if __name__ == "__main__":
    main()
