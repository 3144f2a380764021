"""Streaming a render to tev (raytrace/tev.py, `render --display tev[:HOST:PORT]`), received by a listener that
reads tev's protocol on a real socket (tev_listener.py): the image tev is given after each pass is the render's
mean at that pass's samples, the last one the image written; a tev that is not there, or that goes away, is one
warning and the render goes on.

The images are compared with renders of the same scene at each pass's sample count (sobol, which any count
continues, so a render of s samples takes the same samples as the first s of a longer one): the same samples
summed in other passes, in float32 inside a pass, differ by the rounding of the regrouped sums, at most about
s float32 epsilons relative for the non-negative radiance of s samples (observed: 1 epsilon, 1.2e-7, at 2048
and 4096 samples). The last image is compared exactly with the file's: the same array.

Mutations tried, each failing a test here: no update in pass_done (the frames are fewer than the passes); no
final update in finished (test_a_slow_display_skips_passes_not_the_end); only the first tile of each update
sent (the frames of the 200 x 150 image never complete); x and y of the tiles swapped; the channels named
B, G, R; the connection error not caught at started() (the missing tev's render fails); the socket not
dropped after the first failed send (a warning per pass); DISPLAY_SHARE's test inverted (the
every-pass test's frames are fewer)."""
import json
import socket
import threading

import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
from helpers import CORNELL, run
from raytrace.errors import InputError
from raytrace.tev import DEFAULT_HOST, DEFAULT_PORT, TevDisplay, parse_display
from raytrace.watch import PassReport, Watcher
from tev_listener import TevListener

SOBOL = dict(sampler="sobol", progress=False)


class Means(Watcher):
    """The mean after each pass, as a watcher sees it."""

    def __init__(self):
        self.images = []

    def pass_done(self, report):
        self.images.append((report.spp, report.image().copy()))


@pytest.fixture
def listener():
    tev = TevListener()
    yield tev
    tev.close()


def test_the_listener_reads_tevclient(listener):
    """The listener against tevclient's own client (tevclient.Ipc, which tiles as it likes): what it sent is
    what the listener has."""
    import tevclient
    pixels = np.random.default_rng(1).random((150, 200, 3), dtype=np.float32)
    with tevclient.Ipc("127.0.0.1", listener.port) as tev:
        tev.create_image("t", 200, 150, ["R", "G", "B"])
        tev.update_image("t", pixels, ["R", "G", "B"])
    listener.close()
    assert listener.created == [("t", 200, 150, ["R", "G", "B"])] and not listener.errors
    assert len(listener.frames) == 1
    np.testing.assert_array_equal(listener.frames[0][1], pixels)


def test_every_pass_reaches_tev(listener, cornell):
    """Through render(watch=...): 200 x 150 is four tiles of 128 x 128 at most, each update whole. The passes
    take milliseconds, less than the display's share allows (see test_a_slow_display_skips_passes_not_the_end):
    max_share=None shows them all."""
    means, warnings = Means(), []
    display = TevDisplay("cornell", port=listener.port, warn=warnings.append, max_share=None)
    image, stats = raytrace.render(cornell, width=200, height=150, spp=8, light_samples=1, **SOBOL,
                                   max_pass_work=200 * 150 * 2 * 2, watch=[display, means])
    listener.close()
    assert stats.passes == 4 and not warnings and not listener.errors
    assert listener.created == [("cornell", 200, 150, ["R", "G", "B"])]
    assert len(listener.frames) == stats.passes
    for (name, frame), (spp, mean) in zip(listener.frames, means.images):
        assert name == "cornell"
        np.testing.assert_array_equal(frame, mean, err_msg=f"at {spp} spp")
    np.testing.assert_array_equal(listener.frames[-1][1], image)


def test_command_line_streams_each_pass(listener, cornell, tmp_path):
    """`python -m raytrace render ... --display tev:127.0.0.1:PORT`: passes of 2048 samples at 64 x 48
    (renderer/progressive.PASS_WORK), three of them, each shown."""
    out, stats_file = tmp_path / "streamed.exr", tmp_path / "stats.json"
    r = run("render", CORNELL, "--width", 64, "--height", 48, "--spp", 6144, "--sampler", "sobol", "-o", out,
            "--stats-json", stats_file, "--no-progress", "--display", f"tev:127.0.0.1:{listener.port}")
    listener.close()
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr and not listener.errors
    stats = json.loads(stats_file.read_text())
    assert stats["passes"] == 3
    assert listener.created == [("streamed.exr", 64, 48, ["R", "G", "B"])]
    assert len(listener.frames) == stats["passes"]
    for (_, frame), entry in zip(listener.frames[:-1], stats["history"]):
        spp = entry["samples"]
        reference, _ = raytrace.render(cornell, width=64, height=48, spp=spp, **SOBOL)
        np.testing.assert_allclose(frame, reference, rtol=spp * 2.0**-23, atol=0, err_msg=f"at {spp} spp")
    written = oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)[..., :3]
    np.testing.assert_array_equal(listener.frames[-1][1], written)


def _refusing_port():
    """A port bound but not listening: a connection to it is refused, and no other process can take it."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    return s


def test_missing_tev_is_one_warning(tmp_path):
    with _refusing_port() as closed:
        port = closed.getsockname()[1]
        out = tmp_path / "alone.exr"
        r = run("render", CORNELL, "--width", 64, "--height", 48, "--spp", 6144, "--sampler", "sobol", "-o",
                out, "--no-progress", "--display", f"tev:127.0.0.1:{port}")
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if "warning" in line]
    assert warnings == [f"raytrace: warning: --display tev:127.0.0.1:{port}: cannot connect (Connection refused): "
                        "rendering without it"]
    assert out.exists() and "in 3 passes" in r.stderr


def test_tev_going_away_is_one_warning(cornell):
    """A tev that reads the CreateImage and closes: a send fails (at once, or at the next once the peer's
    reset has arrived), one warning, and the render's passes all run."""
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def accept_and_leave():
        connection, _ = server.accept()
        connection.recv(64)
        connection.close()

    thread = threading.Thread(target=accept_and_leave, daemon=True)
    thread.start()
    warnings = []
    display = TevDisplay("gone", port=port, warn=warnings.append)
    _, stats = raytrace.render(cornell, width=64, height=48, spp=16, light_samples=1, **SOBOL,
                               max_pass_work=64 * 48 * 2, watch=[display])
    thread.join(timeout=10)
    server.close()
    assert stats.passes == 16 and stats.spp == 16
    assert len(warnings) == 1 and warnings[0].startswith(f"tev 127.0.0.1:{port}: connection lost (")
    assert warnings[0].endswith("): rendering without it")


def test_a_slow_display_skips_passes_not_the_end(listener):
    """A display that costs more than DISPLAY_SHARE of the render skips passes, and the final image is sent
    at the end all the same: reports whose image() takes 50 ms, passes 10 ms apart."""
    import time
    warnings = []
    display = TevDisplay("slow", port=listener.port, warn=warnings.append)
    finals = [np.full((2, 3, 3), k, np.float32) for k in range(5)]

    def report(k, seconds):
        def image():
            time.sleep(0.05)
            return finals[k]
        return PassReport(k, 4, k, 4, seconds, None, None, 3, 2, _image=image)

    display.started(report(0, 0.0))
    for k in range(1, 5):
        display.pass_done(report(k, 0.01 * k))
    display.finished(report(4, 0.04))
    listener.close()
    assert not warnings and not listener.errors
    assert [frame[0, 0, 0] for _, frame in listener.frames] == [1.0, 4.0]  # pass 1, then the end


def test_display_values():
    assert parse_display("tev") == (DEFAULT_HOST, DEFAULT_PORT) == ("127.0.0.1", 14158)
    assert parse_display("tev:example.org:1234") == ("example.org", 1234)


@pytest.mark.parametrize("value", ["foo", "tev:", "tev:host", "tev:host:0", "tev:host:65536", "tev::14158",
                                   "tev:host:x1", "TEV"])
def test_bad_display_values(value, tmp_path):
    with pytest.raises(InputError, match="--display"):
        parse_display(value)
    r = run("render", CORNELL, "-o", tmp_path / "x.png", "--display", value)
    assert r.returncode == 2 and r.stderr.startswith(f"raytrace: error: command line: --display = {value!r}: ")
    assert len(r.stderr.splitlines()) == 1 and not (tmp_path / "x.png").exists()
