"""Checkpoints and resuming (raytrace/checkpoint.py, `render --checkpoint/--resume`): a real `python -m raytrace
render` child killed with SIGKILL at several moments, then resumed, writes the image the uninterrupted render
writes, bit for bit (every channel of the EXR: the image and its variance); a checkpoint made for another scene,
other options, another raytrace or nothing at all is refused in one line; a Dask render's checkpoint resumes
here, and a device's sums (accumulate="device") resume too.

Equality is exact, not a tolerance: the passes are deterministic functions of their sample indices, the state
restored is the state saved (float64 and float32 arrays written as they are), so any difference is a bug.
Mutations tried (each fails a test here): restoring the prefix from the total (the later passes' error estimates
differ: the final variance alone does not show it, the prefix being taken again at the next power of two);
resuming at pass k + 1 (a pass left out); dropping the "scene" part of the fingerprint (the changed scene
resumes); not restoring DeviceSums' low halves (the device sums differ)."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
from raytrace import checkpoint
from raytrace.watch import Watcher
from helpers import CORNELL, child_env

# scene 0 at 512 x 512, 256 spp of Sobol's points: 16 passes of 16, a checkpoint after each
RENDER = ["--spp", 256, "--sampler", "sobol", "--light-sampler", "sobol", "--no-progress"]
PASSES = 16
SMALL = dict(width=64, height=48, spp=64, sampler="sobol", light_sampler="sobol", progress=False,
             max_pass_work=1 << 19)  # 8 passes of 8 samples


def run(*argv, **kwargs):
    return subprocess.run([sys.executable, "-m", "raytrace", "render", *map(str, argv)], capture_output=True,
                          text=True, env=child_env(), **kwargs)


def channels(path):
    return oiio.ImageBuf(str(path)).get_pixels(oiio.FLOAT)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole") / "whole.exr"
    result = run(CORNELL, "-o", out, *RENDER)
    assert result.returncode == 0, result.stderr
    return channels(out)


def passes_kept(path):
    meta, _ = checkpoint.load(path)
    return meta["progress"]["counts"]["passes"]


@pytest.mark.parametrize("kill_after", [1, 8, 15, "during-write"])
def test_killed_and_resumed_is_the_uninterrupted_render(tmp_path, uninterrupted, kill_after):
    """SIGKILL once the checkpoint holds 1, 8 or 15 of the 16 passes, or in the middle of the run at a moment
    not chosen by a pass (a checkpoint may be being written then: the rename makes it whole or absent); the
    resumed render's EXR equals the uninterrupted one in every channel."""
    ck, out = tmp_path / "render.ckpt", tmp_path / "resumed.exr"
    child = subprocess.Popen([sys.executable, "-m", "raytrace", "render", CORNELL, "-o", str(tmp_path / "x.exr"),
                              *map(str, RENDER), "--checkpoint", str(ck), "--checkpoint-every", "0"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=child_env())
    deadline = time.monotonic() + 300
    try:
        while True:
            assert child.poll() is None and time.monotonic() < deadline, child.stderr.read()
            if ck.exists():
                if kill_after == "during-write":
                    time.sleep(0.37)  # a moment of no pass's choosing
                    break
                if passes_kept(ck) >= kill_after:
                    break
            time.sleep(0.001)
    finally:
        child.send_signal(signal.SIGKILL)
        child.communicate()
    kept = passes_kept(ck)
    assert 1 <= kept < PASSES
    result = run("--resume", ck, "-o", out, "--no-progress")
    assert result.returncode == 0, result.stderr
    assert np.array_equal(channels(out), uninterrupted)
    assert passes_kept(ck) == PASSES  # the resumed render checkpointed again, to its end


def test_resumed_twice(tmp_path, uninterrupted):
    """A resumed render stopped again (its watcher-kept SIGINT) and resumed again still ends at the same bits;
    its statistics count every pass and second."""
    ck = tmp_path / "twice.ckpt"
    child = subprocess.Popen([sys.executable, "-m", "raytrace", "render", CORNELL, "-o", str(tmp_path / "a.exr"),
                              *map(str, RENDER), "--checkpoint", str(ck), "--checkpoint-every", "0"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=child_env())
    while not ck.exists():
        assert child.poll() is None
        time.sleep(0.001)
    child.send_signal(signal.SIGINT)  # kept: the samples done are written, and checkpointed
    child.communicate(timeout=300)
    assert child.returncode == 130
    first = passes_kept(ck)
    result = run("--resume", ck, "-o", tmp_path / "b.exr", "--stats-json", tmp_path / "b.json")
    assert result.returncode == 0, result.stderr
    assert np.array_equal(channels(tmp_path / "b.exr"), uninterrupted)
    stats = json.loads((tmp_path / "b.json").read_text())
    assert first < PASSES and stats["passes"] == len(stats["history"]) == PASSES and stats["spp"] == 256


class StopAfter(Watcher):
    def __init__(self, passes):
        self.passes = passes

    def pass_done(self, report):
        return "enough" if report.passes >= self.passes else None


@pytest.mark.parametrize("accumulate", ["host", "device"])
def test_resume_from_python(tmp_path, accumulate):
    """render(checkpoint=..., resume=True): the host's float64 sums and a device's double-float sums both come
    back to the uninterrupted render's bits."""
    scene = raytrace.load_file(CORNELL)
    whole, whole_stats = raytrace.render(scene, **SMALL, accumulate=accumulate)
    ck = tmp_path / "py.ckpt"
    part, stats = raytrace.render(scene, **SMALL, accumulate=accumulate, checkpoint=str(ck), checkpoint_every=0,
                                  watch=[StopAfter(3)])
    assert stats.stopped_by == "enough" and stats.passes == 3 and stats.spp == 24  # passes of 8
    resumed, stats = raytrace.render(scene, **SMALL, accumulate=accumulate, checkpoint=str(ck), resume=True)
    assert stats.passes == 8 and stats.stopped_by == "spp"
    assert np.array_equal(resumed, whole) and np.array_equal(resumed.variance, whole.variance)
    # the error estimated after each pass too: the state's prefix, not only its total, came back
    errors = [[h["samples"], h["estimated_rmse"]] for h in stats.history]
    assert errors == [[h["samples"], h["estimated_rmse"]] for h in whole_stats.history]


def test_the_aovs_resume_too(tmp_path):
    """The AOVs' sums are in the checkpoint: a render with depth and normal AOVs stopped after 3 passes and
    resumed has the uninterrupted render's AOVs, bit for bit; a checkpoint without them is refused for a render
    with them (the AOVs are the final model's)."""
    scene = raytrace.load_file(CORNELL)
    whole, _ = raytrace.render(scene, **SMALL, aov="depth,normal")
    ck = tmp_path / "aov.ckpt"
    raytrace.render(scene, **SMALL, aov="depth,normal", checkpoint=str(ck), checkpoint_every=0, watch=[StopAfter(3)])
    resumed, _ = raytrace.render(scene, **SMALL, aov="depth,normal", checkpoint=str(ck), resume=True)
    assert resumed.aovs.keys() == whole.aovs.keys() == {"depth", "normal"}
    assert all(np.array_equal(resumed.aovs[name], whole.aovs[name]) for name in whole.aovs)
    with pytest.raises(raytrace.InputError, match="was made for another scene"):
        raytrace.render(scene, **SMALL, checkpoint=str(ck), resume=True)


def test_a_dask_render_resumes_here(tmp_path):
    """A Dask render (one local worker) stopped after 2 passes resumes in this process to the local render's
    bits (the bands are the local render's: renderer/distributed.py)."""
    pytest.importorskip("dask.distributed")
    scene = raytrace.load_file(CORNELL)
    whole, _ = raytrace.render(scene, **SMALL)
    ck = tmp_path / "dask.ckpt"
    _, stats = raytrace.render(scene, **SMALL, scheduler="local:1", checkpoint=str(ck), checkpoint_every=0,
                               watch=[StopAfter(2)])
    assert stats.passes == 2
    resumed, _ = raytrace.render(scene, **SMALL, checkpoint=str(ck), resume=True)
    assert np.array_equal(resumed, whole) and np.array_equal(resumed.variance, whole.variance)


@pytest.fixture
def small_checkpoint(tmp_path):
    ck = tmp_path / "small.ckpt"
    result = run(CORNELL, "-o", tmp_path / "small.png", "--width", 32, "--height", 24, "--spp", 4,
                 "--no-progress", "--checkpoint", ck)
    assert result.returncode == 0, result.stderr
    return ck


def refused(tmp_path, *argv):
    result = run(*argv, "-o", tmp_path / "never.png", "--no-progress")
    assert result.returncode == 2 and result.stdout == "" and result.stderr.count("\n") == 1, result.stderr
    assert not (tmp_path / "never.png").exists()
    return result.stderr


def test_another_scene_is_refused(tmp_path):
    """The scene file changed since the checkpoint (a material's colour): its fingerprint differs."""
    scene = tmp_path / "scene.toml"
    text = open(CORNELL).read()
    scene.write_text(text)
    ck = tmp_path / "s.ckpt"
    result = run(scene, "-o", tmp_path / "a.png", "--width", 32, "--height", 24, "--spp", 4, "--no-progress",
                 "--checkpoint", ck)
    assert result.returncode == 0, result.stderr
    scene.write_text(text.replace("white = { colour = [0.7, 0.7, 0.7] }", "white = { colour = [0.7, 0.7, 0.6] }"))
    assert scene.read_text() != text
    assert refused(tmp_path, "--resume", ck) == (
        f"raytrace: error: command line: --resume = '{ck}': was made for another scene (or the scene changed "
        "since): refusing to continue it\n")


def test_other_options_are_refused(tmp_path, small_checkpoint):
    """From Python, other options than the checkpoint's: refused, naming them."""
    with pytest.raises(raytrace.InputError, match="was made for another scene"):
        raytrace.render(raytrace.load_file(CORNELL), width=32, height=24, spp=9, checkpoint=str(small_checkpoint),
                        resume=True)  # spp is the final model's: the scene part
    with pytest.raises(raytrace.InputError, match="was made for other options"):
        raytrace.render(raytrace.load_file(CORNELL), width=32, height=24, spp=4, checkpoint=str(small_checkpoint),
                        resume=True, texture_filter="nearest")


def test_another_version_is_refused(tmp_path, small_checkpoint):
    meta, arrays = checkpoint.load(small_checkpoint)
    meta["fingerprint"]["version"] = "0.0.1+kernels.0000000000000000"
    checkpoint.save(small_checkpoint, {k: v for k, v in meta.items() if k != "format"}, arrays)
    assert "was made for another raytrace or kernel source" in refused(tmp_path, "--resume", small_checkpoint)


@pytest.mark.parametrize("content, problem", [
    (b"", "is not a raytrace checkpoint (not an .npz archive)"),
    (b"PK\x03\x04 not really", "is not a raytrace checkpoint (not an .npz archive)"),
])
def test_a_file_that_is_no_checkpoint_is_refused(tmp_path, content, problem):
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(content)
    assert refused(tmp_path, "--resume", bad) == f"raytrace: error: command line: --resume = '{bad}': {problem}\n"


def test_an_npz_of_something_else_is_refused(tmp_path):
    other, unreadable = tmp_path / "other.npz", tmp_path / "unreadable.npz"
    np.savez(other, meta=np.frombuffer(b'{"format": "not ours"}', np.uint8))
    assert "no 'raytrace checkpoint 1' header" in refused(tmp_path, "--resume", other)
    np.savez(unreadable, image=np.zeros(3))
    assert "(no meta it can read)" in refused(tmp_path, "--resume", unreadable)


def test_a_missing_checkpoint_is_refused(tmp_path):
    assert "cannot read: No such file or directory" in refused(tmp_path, "--resume", tmp_path / "none.ckpt")


def test_options_beside_resume_are_refused(tmp_path, small_checkpoint):
    assert refused(tmp_path, "--resume", small_checkpoint, "--spp", 8) == (
        "raytrace: error: command line: --spp: is not taken with --resume: the checkpoint's scene and options are "
        "the ones it continues\n")
    assert "scene: is not taken with --resume" in refused(tmp_path, CORNELL, "--resume", small_checkpoint)


def test_a_checkpoint_that_is_an_output_or_input_is_refused(tmp_path):
    out = tmp_path / "same.png"
    result = run(CORNELL, "--checkpoint", out, "-o", out, "--no-progress")
    assert result.returncode == 2 and "--checkpoint = " in result.stderr and "also another output" in result.stderr
    assert "is an input of this run" in refused(tmp_path, CORNELL, "--checkpoint", CORNELL)


def damaged(path, change):
    """The checkpoint at `path` with `change(meta, arrays)` applied, written back as a file of its own."""
    meta, arrays = checkpoint.load(path)
    change(meta, arrays)
    bad = path.with_name("damaged.ckpt")
    checkpoint.save(bad, {k: v for k, v in meta.items() if k != "format"}, arrays)
    return bad


def counts(meta):
    return meta["progress"]["counts"]


@pytest.mark.parametrize("change, problem", [
    (lambda m, a: counts(m).update(passes=3), "is damaged: n_prefix = 32, its 3 passes give 16"),
    (lambda m, a: counts(m).update(passes=1 << 31), "is damaged: passes = 2147483648"),
    (lambda m, a: counts(m).update(n_total=1 << 31), "is damaged: n_total = 2147483648, its 8 passes give 64"),
    (lambda m, a: m["progress"].update(counts=[1, 2]), "is damaged: progress: no counts"),
    (lambda m, a: m["progress"].update(history=m["progress"]["history"][:-1]),
     "is damaged: history: not one entry a pass (8)"),
    (lambda m, a: m["progress"].update(history=[1] * 8), "is damaged: history: not one entry a pass (8)"),
    (lambda m, a: m["progress"].update(wall_seconds="nan"), "is damaged: wall_seconds = 'nan'"),
    (lambda m, a: m["progress"].update(render_seconds=-1.0), "is damaged: render_seconds = -1.0"),
    (lambda m, a: a.pop("prefix"), "is damaged: prefix: missing"),
    (lambda m, a: a["total"].__setitem__((0, 0, 0), np.nan), "is damaged: total: not finite"),
    (lambda m, a: a.update(total=a["total"][:, :1]), "is damaged: total: float64 (3, 1, 64), expected float64 "
                                                     "(3, 48, 64)"),
    (lambda m, a: m.update(fingerprint=[1]), "was made for another raytrace or kernel source"),
])
def test_a_damaged_checkpoint_is_refused_in_one_line(tmp_path, change, problem):
    """A checkpoint whose fingerprint matches but whose state its schedule cannot give (counts, history, seconds,
    arrays): refused naming what is wrong, never a traceback or a wrong image."""
    scene = raytrace.load_file(CORNELL)
    ck = tmp_path / "whole.ckpt"
    raytrace.render(scene, **SMALL, checkpoint=str(ck))
    bad = damaged(ck, change)
    with pytest.raises(raytrace.InputError) as e:
        raytrace.render(scene, **SMALL, checkpoint=str(bad), resume=True)
    assert str(e.value) == f"render(): checkpoint = '{bad}': {problem}" + (
        "" if problem.startswith("is damaged") else ": refusing to continue it")


@pytest.mark.parametrize("stop", [dict(target_error=0.05), dict(time_limit=1e-9)], ids=["target-error", "time-limit"])
def test_a_render_its_target_ended_stays_ended(tmp_path, stop):
    """Resuming the checkpoint of a render its target error or time limit stopped renders no pass more: the
    image is the one it wrote."""
    scene = raytrace.load_file(CORNELL)
    ck = tmp_path / "ended.ckpt"
    first, stats = raytrace.render(scene, **SMALL, **stop, checkpoint=str(ck))
    assert stats.stopped_by in ("target-error", "time-limit") and stats.passes < 8
    again, resumed = raytrace.render(scene, **SMALL, **stop, checkpoint=str(ck), resume=True)
    assert resumed.passes == stats.passes and resumed.stopped_by == stats.stopped_by
    assert np.array_equal(again, first) and np.array_equal(again.variance, first.variance)


def test_a_finished_dask_checkpoint_resumes_on_dask(tmp_path):
    """No pass left to render: the statistics' device is asked of a worker (found: a traceback)."""
    pytest.importorskip("dask.distributed")
    scene = raytrace.load_file(CORNELL)
    ck = tmp_path / "done.ckpt"
    whole, _ = raytrace.render(scene, **SMALL, scheduler="local:1", checkpoint=str(ck))
    again, stats = raytrace.render(scene, **SMALL, scheduler="local:1", checkpoint=str(ck), resume=True)
    assert np.array_equal(again, whole) and "Dask" in stats.device


def test_a_checkpoint_that_cannot_be_written_is_refused_before_any_work(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(raytrace.InputError, match="checkpoint = '.*file/x.ckpt': cannot write in its directory: "
                                                  "Not a directory"):
        raytrace.render(raytrace.load_file(CORNELL), **SMALL, checkpoint=str(tmp_path / "file" / "x.ckpt"),
                        watch=[StopAfter(0)])


def test_checkpoint_every_beside_resume_is_the_resumed_runs(tmp_path, small_checkpoint):
    """How often a resumed run checkpoints changes no bit: --checkpoint-every beside --resume is taken, and
    kept for the next resume."""
    result = run("--resume", small_checkpoint, "-o", tmp_path / "again.png", "--checkpoint-every", 5, "--no-progress")
    assert result.returncode == 0, result.stderr
    meta, _ = checkpoint.load(small_checkpoint, arrays=False)
    assert meta["command"]["checkpoint_every"] == 5.0
