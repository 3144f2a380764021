"""`python -m benchmarks.baseline DIR` (benchmarks/baseline.py): this checkout's kernel against
another kernels/ directory in one process. The baseline's kernels must really be the ones built (a copy
that cannot build fails, an identical copy renders the same bits), the turns must alternate, and bad
directories are one-line errors before any measuring."""
import shutil

import numpy as np
import pyopencl as cl
import pytest

from helpers import CORNELL, ROOT, run
from raytrace.render import render
from raytrace.renderer.program import Features
from raytrace.scene import load_file
from benchmarks import baseline
from raytrace.commands import bench

TINY = ["--width", 16, "--height", 16, "--spp", 1, "--light-samples", 1]


@pytest.fixture
def copy(tmp_path):
    """A copy of this checkout's kernels/."""
    return shutil.copytree(ROOT / "kernels", tmp_path / "kernels")


def test_the_baselines_kernels_are_built(copy, lanes):
    """An identical copy renders scene 0 to the same bits as this checkout's kernels; a copy whose render.cl
    cannot compile fails to build. It fails if the include path still points at this checkout's kernels."""
    scene = load_file(CORNELL)
    ours = Features.of(scene, lanes)
    options = dict(width=12, height=10, spp=1, light_samples=4, progress=False)
    image = render(scene, features=ours, **options)[0]
    np.testing.assert_array_equal(render(scene, features=Features(**{**vars(ours), "kernels": str(copy)}),
                                         **options)[0], image)
    broken = shutil.copytree(copy, copy.parent / "broken")  # another directory: another program to build
    (broken / "render.cl").write_text('#error "the baseline\'s own render.cl"\n')
    with pytest.raises(cl.RuntimeError, match="the baseline's own render.cl"):
        render(scene, features=Features(**{**vars(ours), "kernels": str(broken)}), **options)


def test_turns_alternate_which_goes_first(monkeypatch):
    order = []
    monkeypatch.setattr(bench, "render", lambda scene, features, **kw: order.append(features) or (None, Stats()))
    _, seconds = bench.in_turns(["scene", "scene"], 3, {}, ["ours", "theirs"], alternate=True)
    assert order == ["ours", "theirs"] + ["ours", "theirs", "theirs", "ours", "ours", "theirs"]
    assert seconds == [[1.0] * 3, [1.0] * 3]


class Stats:
    render_seconds = 1.0


def test_a_real_run(copy):
    r = run(copy, CORNELL, *TINY, "--repeat", 2, module="benchmarks.baseline", cwd=ROOT)
    assert r.returncode == 0, r.stderr
    scene_line, machine = r.stdout.strip().splitlines()
    assert scene_line.startswith(f"{CORNELL}: ") and "baseline" in scene_line and "(paired x" in scene_line
    assert machine.startswith(f"ours against {copy}; ") and machine.endswith("best of 2")


@pytest.mark.parametrize("case", ["no render.cl", "no types.h", "types.h differs", "empty", "bad repeat"])
def test_bad_baselines_one_line_before_measuring(copy, tmp_path, case):
    extra = []
    if case == "no render.cl":
        (copy / "render.cl").unlink()
    elif case == "no types.h":
        (copy / "types.h").unlink()
    elif case == "empty":
        copy = ""
    elif case == "types.h differs":
        (copy / "types.h").write_text((copy / "types.h").read_text() + "\n")
    else:
        extra = ["--repeat", 0]
    r = run(copy, CORNELL, *TINY, *extra, module="benchmarks.baseline", cwd=ROOT)
    assert r.returncode == 2 and r.stdout == ""
    assert len(r.stderr.strip().splitlines()) == 1
    named = "--repeat = 0" if case == "bad repeat" else f"DIR = '{copy}'"
    assert r.stderr.startswith(f"benchmarks.baseline: error: command line: {named}: ")
