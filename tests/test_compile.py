"""Every shipped scene's specialised kernel compiles for every target (raytrace/compile.py): PoCL here, and
NVIDIA PTX, AMD GCN and SPIR with Debian's clang, so that a construct only PoCL accepts fails here, not on a
user's GPU. clang is a test dependency: .ci/run installs it, and without it these tests fail, not skip."""
import dataclasses

import pytest

from helpers import ROOT
from raytrace.tools.compile import TARGETS, compile_scene
from raytrace.renderer.program import Features
from raytrace.scene import load_scene

SCENES = sorted(p.name for p in (ROOT / "scenes").glob("*.toml"))


@pytest.fixture(scope="module", params=SCENES)
def scene(request):
    return load_scene(ROOT / "scenes" / request.param)


@pytest.mark.parametrize("target", TARGETS)
def test_scene_compiles(scene, target):
    result = compile_scene(scene, target)
    assert result["bytes"] > 1000
    assert result["lanes"] == (1 if target != "pocl" else result["lanes"])
    assert f"-DLANES={result['lanes']}" in result["options"]


@pytest.mark.parametrize("target", [t for t in TARGETS if t != "pocl"])
def test_a_kernel_clang_rejects_fails(monkeypatch, cornell, target):
    """The failure path: a lane width lanes.h refuses (#error) makes clang fail, and compile_scene says so
    with clang's error line rather than reporting success."""
    monkeypatch.setattr(Features, "options", lambda self: ["-DLANES=3"])
    with pytest.raises(RuntimeError, match="LANES must be"):
        compile_scene(dataclasses.replace(cornell), target)


@pytest.mark.parametrize("target", TARGETS)
def test_every_feature_at_once_compiles(monkeypatch, cornell, target):
    """No shipped scene turns on every feature (smooth normals beside every map, with the BVH): that build
    compiles for every target too."""
    every = Features(smooth_normals=True, bvh=True)
    monkeypatch.setattr(Features, "of", classmethod(lambda cls, scene, lanes: dataclasses.replace(every, lanes=lanes)))
    result = compile_scene(cornell, target)
    assert "-DHAS_SMOOTH_NORMALS=1" in result["options"] and "-DHAS_HEIGHT_MAPS=1" in result["options"]
    assert "-DHAS_BVH=1" in result["options"] and result["bytes"] > 1000
