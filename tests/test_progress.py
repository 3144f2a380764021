"""The progress bar (raytrace/progress.py): a real `python -m raytrace render` child whose stderr is a terminal
(a pseudo-terminal) shows the bar from its first moment, the kernel build labelled before any pass, then the
samples done of those asked for, pass k of the passes planned and the time left; off a terminal a short
render shows none. The time left against its closed forms.

Mutations tried (each fails a test here): the bar opened at the first pass, as before (no build label);
the rate taken over the time since the bar opened, build included (the time left after a slow build is
too long); the target error's samples as spp (error / target) instead of its square."""
import fcntl
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios

import pytest

from raytrace.progress import seconds_left
from raytrace.watch import PassReport
from helpers import CORNELL, child_env


def report(spp, seconds, relative=None, max_spp=256):
    return PassReport(passes=spp // 16, planned_passes=max_spp // 16, spp=spp, max_spp=max_spp, seconds=seconds,
                      estimated_rmse=None, estimated_relative_rmse=relative, width=8, height=8)


def test_time_left_towards_the_samples_the_time_limit_and_the_target():
    """At 0.01 s a sample: 64 of 256 samples done leaves 192 x 0.01 s; a time limit of 3 s at 2 s leaves 1 s;
    an error of 0.02 at 64 samples reaches a target of 0.01 at 64 x (0.02 / 0.01)^2 = 256 samples, 0.01 at
    128 samples leaves 0 s (reached), and the samples asked for bound the target's count."""
    assert seconds_left(report(64, 1.0), None) is None
    assert seconds_left(report(64, 1.0), 0.01) == pytest.approx(1.92)
    assert seconds_left(report(64, 2.0), 0.01, time_limit=3.0) == pytest.approx(1.0)
    assert seconds_left(report(64, 1.0, relative=0.02, max_spp=65536), 0.01, target_error=0.01) == \
        pytest.approx(1.92)
    assert seconds_left(report(128, 1.0, relative=0.01, max_spp=65536), 0.01, target_error=0.01) == 0.0
    assert seconds_left(report(64, 1.0, relative=0.1), 0.01, target_error=0.01) == pytest.approx(1.92)


def on_a_terminal(argv):
    """Run the command with its stderr on a pseudo-terminal of 160 columns (a new one has 0, into which tqdm
    draws nothing); (exit status, what the terminal received)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 160, 0, 0))
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=slave, env=child_env())
    os.close(slave)
    received = b""
    while True:
        ready, _, _ = select.select([master], [], [], 300)
        if not ready:
            child.kill()
            pytest.fail("no output for 300 s")
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the child closed its end
            break
        if not chunk:
            break
        received += chunk
    os.close(master)
    return child.wait(), received.decode(errors="replace")


def test_a_terminal_sees_the_bar_from_the_first_moment(tmp_path):
    """The build's label comes before any pass; then each redraw says spp done/asked, pass k/16 and the time
    left; the passes counted match the samples (16 a pass)."""
    status, text = on_a_terminal([sys.executable, "-m", "raytrace", "render", CORNELL, "-o", str(tmp_path / "a.png"),
                                  "--spp", "256", "--sampler", "sobol", "--light-sampler", "sobol"])
    assert status == 0, text
    build = text.find("building the kernel")
    rendering = [m for m in re.finditer(r"rendering: +\d+%\|[^|]*\| (\d+)/256 spp \[[\d:]+, pass (\d+)/16, "
                                        r"est\. rel\. error [^,]+, ([\d:]+|\?) left\]", text)]
    assert 0 <= build < rendering[0].start(), text
    assert len(rendering) >= 2
    for m in rendering:
        assert int(m.group(1)) == 16 * int(m.group(2))
    assert any(m.group(3) != "?" for m in rendering)


def test_off_a_terminal_a_short_render_shows_no_bar(tmp_path):
    result = subprocess.run([sys.executable, "-m", "raytrace", "render", CORNELL, "-o", str(tmp_path / "a.png"),
                             "--width", "32", "--height", "24", "--spp", "4"], capture_output=True, text=True,
                            env=child_env())
    assert result.returncode == 0 and result.stderr.count("\n") == 1 and "building" not in result.stderr


def test_the_rate_is_this_runs_passes_not_the_build(tmp_path):
    """A build of 1.2 s, then 16 samples in 0.16 s of passes: the time left for 240 samples more is 2.4 s
    ("00:02"), not the 18 s the time since the bar opened would give."""
    import io
    import time
    from raytrace.progress import Progress
    out = io.StringIO()
    bar = Progress(True, file=out)
    bar.building("building the kernel")
    time.sleep(1.2)
    bar.started(report(0, 0.0))
    bar.pass_done(report(16, 0.16))
    bar.finished(None)
    assert "pass 1/16, est. rel. error ?, 00:02 left" in out.getvalue()


def test_a_terminal_is_told_that_ctrl_c_ends_after_the_pass(tmp_path):
    """On a terminal the first Ctrl-C is answered at once (a pass may take seconds, and a user who sees nothing
    presses again, losing the render): one line saying the render ends after the pass under way; then the line
    of what was written. Off a terminal (tests/test_signals.py) only the latter."""
    import signal
    import threading
    import time
    out = tmp_path / "a.exr"
    argv = [sys.executable, "-m", "raytrace", "render", CORNELL, "-o", str(out), "--spp", "256", "--sampler",
            "sobol", "--light-sampler", "sobol", "--checkpoint", str(tmp_path / "a.ckpt"), "--checkpoint-every", "0"]
    result = {}

    def run():
        result["status"], result["text"] = on_a_terminal(argv)
    reader = threading.Thread(target=run)
    reader.start()
    deadline = time.monotonic() + 300
    while not (tmp_path / "a.ckpt").exists():
        assert time.monotonic() < deadline and reader.is_alive()
        time.sleep(0.002)
    children = subprocess.run(["pgrep", "-f", str(out)], capture_output=True, text=True).stdout.split()
    for pid in children:
        if int(pid) != os.getpid():
            os.kill(int(pid), signal.SIGINT)
    reader.join(300)
    assert result["status"] == 130, result["text"]
    notice = result["text"].find("raytrace: SIGINT: ending after the pass under way; again to end at once, writing "
                                 "nothing")
    wrote = result["text"].find(f"raytrace: interrupted by SIGINT: wrote {out} with ")
    assert 0 <= notice < wrote, result["text"]
