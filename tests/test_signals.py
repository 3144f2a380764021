"""SIGTERM, SIGHUP and SIGINT (Ctrl-C) sent to a real `python -m raytrace render` child.

Before its passes begin (the scene loading, the kernel build) any of them ends it with one line on stderr, exit
status 128 + the signal's number, no traceback, and nothing left in the output directory (no output, no
temporary file); so does SIGHUP at any time, and a second signal. Once the passes have begun, SIGINT and SIGTERM
end the render after the current pass and write the samples done (their true spp in the metadata), with one line
saying so and the same exit status; one arriving while the image is written lets it be written. A signal the
parent ignored (nohup) stays ignored."""
import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from helpers import CORNELL, child_env

BIG = ["--width", 4096, "--height", 4096, "--spp", 1, "--light-samples", 1, "--no-progress"]


def start(out_dir, output, size=BIG, preexec_fn=None):
    argv = [sys.executable, "-m", "raytrace", "render", CORNELL, "-o", out_dir / output,
            "--stats-json", out_dir / "stats.json", *size]
    return subprocess.Popen(list(map(str, argv)), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=child_env(), preexec_fn=preexec_fn)


def wait_for_temporary(child, out_dir, suffix, written):
    """Until the image's temporary file exists (the render is under way) and, if `written`, holds bytes
    (the image is being written)."""
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        for path in out_dir.glob(".raytrace-*" + suffix):
            try:
                if not written or path.stat().st_size > 0:
                    return
            except FileNotFoundError:
                pass
        assert child.poll() is None, f"ended before the moment (status {child.returncode}): {child.stderr.read()}"
        time.sleep(0.002)
    child.kill()
    pytest.fail("no temporary file appeared")


def signalled_at_its_temporary(tmp_path, output, signum, written):
    """A render of BIG into `output`, sent `signum` once its temporary exists (and, if `written`, holds bytes);
    (stdout, stderr, the child) once it has ended."""
    child = start(tmp_path, output)
    try:
        wait_for_temporary(child, tmp_path, os.path.splitext(output)[1], written)
        child.send_signal(signum)
        stdout, stderr = child.communicate(timeout=300)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    return stdout, stderr, child


@pytest.mark.parametrize("signum, output, written", [
    (signal.SIGHUP, "big.png", True), (signal.SIGTERM, "big.png", False), (signal.SIGHUP, "big.exr", False),
    (signal.SIGINT, "big.png", False),
], ids=["hup-writing-png", "term-loading", "hup-loading", "int-loading"])
def test_signal_leaves_nothing(tmp_path, signum, output, written):
    """The output's temporary is made before the scene is read: a signal as it appears lands before the passes
    (nothing to keep), and SIGHUP while the image is written ends the command too."""
    stdout, stderr, child = signalled_at_its_temporary(tmp_path, output, signum, written)
    name = signal.Signals(signum).name
    assert child.returncode == 128 + signum, stderr
    assert stderr == f"raytrace: interrupted by {name}; nothing written\n" and stdout == ""
    assert list(tmp_path.iterdir()) == []


# scene 0 at 512 x 512: 16 passes of 16 samples, a quarter second each; Sobol's points, whose first n are the
# points of a render of n (a grid of 256 is not the grid of 128 and more)
PASSES = ["--spp", 256, "--sampler", "sobol", "--light-sampler", "sobol", "--no-progress"]


def start_passes(tmp_path, output):
    """A render of many passes, checkpointed after each (a folder apart), and the moment its first pass is done:
    its checkpoint appears."""
    (tmp_path / "ck").mkdir()
    checkpoint = tmp_path / "ck" / "passes.ckpt"
    child = start(tmp_path / "out", output, size=[*PASSES, "--checkpoint", checkpoint, "--checkpoint-every", 0])
    deadline = time.monotonic() + 300
    while not checkpoint.exists():
        assert child.poll() is None and time.monotonic() < deadline, child.stderr.read()
        time.sleep(0.002)
    return child


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
def test_a_signal_during_the_passes_keeps_them(tmp_path, signum):
    """The render ends after the pass under way; the image of the samples done is written, with its true spp
    in its metadata and the statistics, and equals (bit for bit, variance too) a render asked for that many
    samples: its passes are the same passes."""
    import OpenImageIO as oiio
    import raytrace
    (tmp_path / "out").mkdir()
    child = start_passes(tmp_path, "kept.exr")
    child.send_signal(signum)
    stdout, stderr = child.communicate(timeout=300)
    name, out = signal.Signals(signum).name, tmp_path / "out" / "kept.exr"
    assert child.returncode == 128 + signum, stderr
    stats = json.loads((tmp_path / "out" / "stats.json").read_text())
    spp = stats["spp"]
    assert 16 <= spp < 256 and spp % 16 == 0 and stats["stopped_by"] == name and stats["max_spp"] == 256
    assert stderr == f"raytrace: interrupted by {name}: wrote {out} with {spp} of 256 spp in {spp // 16} passes\n"
    assert stdout == "" and sorted(p.name for p in (tmp_path / "out").iterdir()) == ["kept.exr", "stats.json"]
    written = oiio.ImageBuf(str(out))
    assert written.spec().getattribute("raytrace:spp") == spp
    image, _ = raytrace.render(raytrace.load_file(CORNELL), spp=spp, sampler="sobol", light_sampler="sobol",
                               progress=False)
    pixels = written.get_pixels(oiio.FLOAT)
    assert np.array_equal(pixels[..., :3], image) and np.array_equal(pixels[..., 3:], image.variance)


@pytest.mark.parametrize("signum, output", [(signal.SIGINT, "big.exr"), (signal.SIGTERM, "big.png")],
                         ids=["int-exr", "term-png"])
def test_a_signal_while_the_image_is_written_lets_it_be_written(tmp_path, signum, output):
    """The samples are all done and the image is being written (its temporary holds bytes): the signal is kept,
    the image and the statistics are written whole, and the line says so, with the signal's exit status."""
    stdout, stderr, child = signalled_at_its_temporary(tmp_path, output, signum, True)
    name = signal.Signals(signum).name
    assert child.returncode == 128 + signum, stderr
    assert stderr == f"raytrace: interrupted by {name}: wrote {tmp_path / output} with 1 of 1 spp in 1 pass\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([output, "stats.json"])


@pytest.mark.parametrize("signals", [(signal.SIGINT, signal.SIGTERM), (signal.SIGTERM, signal.SIGINT),
                                     (signal.SIGHUP,)], ids=["int-term", "term-int", "hup"])
def test_a_second_signal_or_a_hangup_writes_nothing(tmp_path, signals):
    """A second signal during the passes (the first kept) ends the render at once, and so does SIGHUP (the
    terminal gone): nothing written, the line of the signal that ended it. The two are sent back to back, so
    that the pass under way cannot end between them (under load a pause between them outlasted a pass, and the
    image was written before the second came); which of them Python handles first is its own (two pending at
    once go in the order of their numbers), so either may be the one that ends it."""
    (tmp_path / "out").mkdir()
    child = start_passes(tmp_path, "never.png")
    for signum in signals:
        child.send_signal(signum)
    stdout, stderr = child.communicate(timeout=300)
    ended = signal.Signals(child.returncode - 128)
    assert ended in signals and (len(signals) == 1 or child.returncode - 128 in signals), stderr
    assert stderr == f"raytrace: interrupted by {ended.name}; nothing written\n" and stdout == ""
    assert list((tmp_path / "out").iterdir()) == []


def test_ignored_hangup_stays_ignored(tmp_path):
    """Under nohup (SIGHUP ignored on entry) a hangup does not stop the render."""
    child = start(tmp_path, "x.png", size=["--width", 1024, "--height", 1024, "--spp", 4, "--light-samples", 4,
                                           "--no-progress"],
                  preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    wait_for_temporary(child, tmp_path, ".png", False)
    child.send_signal(signal.SIGHUP)
    _, stderr = child.communicate(timeout=300)
    assert child.returncode == 0, stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stats.json", "x.png"]


def signal_here(signum):
    """The signal to this thread, the main one: os.kill's process-wide signal may land in another thread (a
    runtime's), and its Python handler then waits for this thread's next check, late on a loaded machine."""
    signal.pthread_kill(threading.main_thread().ident, signum)


def wait_until(condition, seconds=10.0):
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.001)


def test_signal_during_a_file_operation_waits_for_its_end():
    """A signal that arrives while files are made, renamed or removed is raised right after, not in the
    middle (where a temporary could be made and not yet known, or half the outputs renamed); a second
    signal on the way out is ignored."""
    from raytrace import outputs
    steps = []
    with outputs.handle_signals(), pytest.raises(outputs.Interrupted) as e:
        with outputs._held():
            signal_here(signal.SIGTERM)
            wait_until(lambda: outputs._State.signum is not None)  # the handler has run, in this thread
            steps.append("held")
        steps.append("after")
    assert steps == ["held"] and e.value.signum == signal.SIGTERM
    inherited = signal.signal(signal.SIGHUP, signal.SIG_DFL)  # as a terminal's shell starts it, not under nohup
    try:
        with outputs.handle_signals():
            with pytest.raises(outputs.Interrupted):
                signal_here(signal.SIGHUP)
                wait_until(lambda: False)
            signal_here(signal.SIGHUP)  # the second: ignored
            time.sleep(0.05)
    finally:
        signal.signal(signal.SIGHUP, inherited)


def test_a_signal_while_the_handlers_go_in_is_one_line(tmp_path, monkeypatch, capsys):
    """Found: Ctrl-C in the instant cli.main puts its handlers in (python -m raytrace, about 0.25 s after its
    start on a 2-core Xeon) gave a traceback: the first handler raised Interrupted before the command's try had
    begun. Here a real SIGINT reaches this process right after the first of them is in: the command ends with
    status 130, the one line and no output file."""
    from raytrace import cli, outputs
    real, sent = signal.signal, []

    def install_then_interrupt(signum, handler):
        before = real(signum, handler)
        if handler is outputs._on_signal and not sent:
            sent.append(signum)
            os.kill(os.getpid(), signal.SIGINT)
        return before
    monkeypatch.setattr(signal, "signal", install_then_interrupt)
    code = cli.main(["render", str(CORNELL), "-o", str(tmp_path / "x.png"), "--no-progress"])
    assert sent and code == 130
    assert capsys.readouterr().err == "raytrace: interrupted by SIGINT; nothing written\n"
    assert list(tmp_path.iterdir()) == []


HALF_MADE = """
import os, signal, sys
from raytrace import cli

class HalfMade:
    # the signal arrives in the constructor, before the attribute __del__ reads is set (pytools' cache dict,
    # interrupted while pyopencl sets it up)
    def __init__(self):
        os.kill(os.getpid(), signal.SIGINT)
        self.mutex = None

    def __del__(self):
        self.mutex.acquire()

cli.cmd_render = lambda args: HalfMade()
sys.exit(cli.main(["render", sys.argv[1], "-o", sys.argv[2]]))
"""


def test_an_object_a_signal_cut_short_says_nothing_as_it_goes(tmp_path):
    """A signal raised in an object's constructor leaves it half made, and its __del__ fails when the
    exception lets it go, after the command's line: Python would print "Exception ignored in ..." with a
    traceback (it did, for pytools' PersistentDict, 1 of 150 early Ctrl-Cs). Once a signal ends the command,
    that is not printed: one line, exit status 130. It fails without outputs.py's quiet unraisablehook."""
    result = subprocess.run([sys.executable, "-c", HALF_MADE, CORNELL, str(tmp_path / "out.png")],
                            capture_output=True, text=True, env=child_env())
    assert result.returncode == 128 + signal.SIGINT, result.stderr
    assert result.stderr == "raytrace: interrupted by SIGINT; nothing written\n"
