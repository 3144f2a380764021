"""The process's environment, the CPU and the variables a user sets: the code-generation target and lane width
come from the CPU's own features (raytrace/renderer/cpu_target.py); RAYTRACE_LANES, RAYTRACE_TARGET,
RAYTRACE_DEVICE, POCL_CACHE_DIR and POCL_DEVICES as hostile input get one line naming the variable and its
value, exit status 2, and no output."""
import os
import subprocess

import pytest

from helpers import CORNELL, SESSION_DEVICE, SESSION_KIND, on_pocl, run
from raytrace.errors import InputError
from raytrace.renderer import cpu_target

V2 = {"cx16", "lahf_lm", "popcnt", "sse4_1", "sse4_2", "ssse3"}
V3 = V2 | {"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "abm", "movbe", "xsave"}
V4 = V3 | {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"}
SMALL = ["--width", "8", "--height", "8", "--spp", "1", "--light-samples", "1", "--no-progress"]


def render_with(tmp_path, env, *args):
    out = tmp_path / "x.png"
    r = run("render", CORNELL, "-o", out, *SMALL, *args, env={**os.environ, **env})
    return r, out


def one_line(r, text):
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and text in r.stderr, (r.returncode, r.stderr)


@pytest.mark.parametrize("flags,pocl,target,lanes", [
    (V4, "znver3", "x86-64-v4", 16),        # AMD Zen 4: LLVM 14 says znver3 (AVX2); the CPU has AVX-512
    (V3, "generic", "x86-64-v3", 8),        # a CPU newer than LLVM 14 without AVX-512
    (V3, "znver3", "znver3", 8),            # Zen 3: PoCL's name has the width, and is tuned for the CPU
    (V4, "icelake-client", "icelake-client", 16),
    (V2, "nehalem", "nehalem", 4),
    (V4 - {"avx512vl"}, "knl", "x86-64-v3", 8),  # AVX-512 without VL is not x86-64-v4
    (V2 - {"popcnt"}, "core2", "core2", 4),  # below every level: PoCL's own choice
])
def test_target_and_lanes_follow_the_cpu_features(monkeypatch, flags, pocl, target, lanes):
    monkeypatch.delenv("RAYTRACE_TARGET", raising=False)
    monkeypatch.delenv("RAYTRACE_LANES", raising=False)
    chosen = cpu_target.choose_target(pocl, flags)
    assert (chosen.llvm_cpu, chosen.lanes) == (target, lanes)


@pytest.mark.parametrize("env,key", [
    ({"RAYTRACE_TARGET": "x86-64-v4"}, "RAYTRACE_TARGET"),                       # the CPU lacks AVX-512
    ({"RAYTRACE_TARGET": "znver3"}, "RAYTRACE_TARGET"),                          # not a level
    ({"RAYTRACE_TARGET": "x86-64-v3", "RAYTRACE_LANES": "16"}, "RAYTRACE_LANES"),  # wider than AVX2
    ({"RAYTRACE_LANES": "3"}, "RAYTRACE_LANES"),
])
def test_overrides_the_cpu_cannot_run_are_refused(monkeypatch, env, key):
    for name in ("RAYTRACE_TARGET", "RAYTRACE_LANES"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    with pytest.raises(InputError) as info:
        cpu_target.choose_target("haswell", V3)
    assert (info.value.source, info.value.key, info.value.value) == ("environment", key, env[key])


@pytest.mark.parametrize("value", ["3", "0", "-1", "1000000", "abc", "", "8.0"])
def test_bad_lane_widths_are_one_line(tmp_path, value):
    """The issue's item 2: these ended in tracebacks."""
    r, out = render_with(tmp_path, {"RAYTRACE_LANES": value})
    one_line(r, f"environment: RAYTRACE_LANES = '{value}': must be one of 1, 4, 8, 16")
    assert not out.exists()


@on_pocl
def test_lanes_wider_than_the_target_are_refused_before_building(tmp_path):
    """The issue's items 2 and 3: on AMD Zen 4, whose LLVM 14 target is AVX2's znver3, 16 lanes aborted the
    process (LLVM out of memory, or INVALID_KERNEL_NAME after ABI warnings). An AVX2 target, which every
    machine of this project runs, reproduces it: render and compile refuse 16 lanes in one line, rc 2."""
    r, out = render_with(tmp_path, {"RAYTRACE_TARGET": "x86-64-v3", "RAYTRACE_LANES": "16"})
    one_line(r, "environment: RAYTRACE_LANES = '16': wider than the target's 256-bit vectors")
    assert not out.exists()
    r = run("compile", CORNELL, "--target", "pocl", "--lanes", "16", env={**os.environ, "RAYTRACE_TARGET": "x86-64-v3"})
    one_line(r, "command line: --lanes = 16: wider than the target's 256-bit vectors (x86-64-v3, AVX2)")


def test_an_avx2_target_with_its_own_width_renders(tmp_path):
    r, out = render_with(tmp_path, {"RAYTRACE_TARGET": "x86-64-v3", "RAYTRACE_LANES": "8"}, "--stats-json",
                         tmp_path / "s.json")
    assert r.returncode == 0 and out.exists(), r.stderr
    assert "-DLANES=8" in (tmp_path / "s.json").read_text()


def test_unusable_pocl_cache_dirs_are_one_line(tmp_path):
    """The issue's item 4: POCL_CACHE_DIR naming a file, or a directory under a file, ended in a build-failure
    traceback (or in PoCL showing no device at all)."""
    a_file = tmp_path / "afile"
    a_file.write_text("")
    for value in (a_file, a_file / "sub"):
        r, out = render_with(tmp_path, {"POCL_CACHE_DIR": str(value)})
        one_line(r, f"environment: POCL_CACHE_DIR = '{value}': PoCL cannot keep its kernel cache there")
        assert not out.exists()


def test_read_only_pocl_cache_dir_is_one_line(tmp_path):
    """A read-only file system (a tmpfs mounted read-only where root can mount one, else a directory without
    write permission, which binds everyone but root)."""
    cache = tmp_path / "ro"
    cache.mkdir()
    mounted = os.geteuid() == 0 and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(cache)], capture_output=True).returncode == 0
    if not mounted:
        if os.geteuid() == 0:
            pytest.skip("root without mount: permissions do not bind root")
        cache.chmod(0o555)
    try:
        r, out = render_with(tmp_path, {"POCL_CACHE_DIR": str(cache)})
        one_line(r, f"environment: POCL_CACHE_DIR = '{cache}': PoCL cannot keep its kernel cache there")
    finally:
        if mounted:
            subprocess.run(["umount", str(cache)], check=True)
        else:
            cache.chmod(0o755)


@on_pocl
def test_no_device_names_the_variable_that_hid_them(tmp_path):
    """The issue's item 15: POCL_DEVICES=nosuch said "command line: --device: no OpenCL device found"."""
    r, out = render_with(tmp_path, {"POCL_DEVICES": "nosuch"})
    one_line(r, "environment: POCL_DEVICES = 'nosuch': leaves no OpenCL device")
    assert not out.exists()


def test_raytrace_device_moves_the_process(tmp_path):
    """RAYTRACE_DEVICE picks the device wherever none is given (the test suite on a GPU, .ci/gpu); a spec that
    matches no device is one line naming the variable, and nothing is written."""
    r, out = render_with(tmp_path, {"RAYTRACE_DEVICE": "nosuch"})
    one_line(r, "environment: RAYTRACE_DEVICE = 'nosuch': matches no device (have: ")
    assert not out.exists()
    r, out = render_with(tmp_path, {"RAYTRACE_DEVICE": SESSION_KIND})
    assert r.returncode == 0 and out.exists() and SESSION_DEVICE in r.stdout + r.stderr, r.stderr
