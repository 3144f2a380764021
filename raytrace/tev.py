"""Streaming a render to the tev image viewer (https://github.com/Tom94/tev), a watcher (watch.py): the image
is created in tev when the passes begin and replaced by the mean of the samples after each pass, so a long
render can be looked at, in linear float, while it converges. `python -m raytrace render ... --display tev`
(or tev:HOST:PORT) on the command line; render(scene, watch=[TevDisplay("name")]) from Python.

tev listens on 127.0.0.1:14158 unless told otherwise (its --hostname); tevclient (PyPI, tev's author's) encodes
its packets: CreateImage (name, size, channel names) and UpdateImage (a tile of pixels, channel by channel).
The socket is ours, not tevclient.Ipc's, for its timeouts: a tev that is not there, or that hangs, costs the
render one warning line and nothing else; rendering goes on without the display.

What is sent: the mean's R, G, B channels, float32 as the image file holds them. Not the variance: a pass's
report carries the mean alone (watch.PassReport), and tev shows the noise well enough by itself.

How often: after every pass, unless the display has taken more than DISPLAY_SHARE of the render's wall time
so far (report.image() is host work, and a device-accumulated render reads its sums back for it: what the
device path otherwise does once). Passes are sized to about 2^27 rays (renderer/progressive.PASS_WORK), a
fraction of a second or more, so a display of an image no larger than the passes' work is sent every pass;
only a large image on a fast device, where the update costs as much as the pass, skips some. The final image
is always sent."""
import socket
import time

from .errors import InputError
from .watch import DISPLAY_SHARE, Watcher

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 14158  # tev's default --hostname
CHANNELS = ["R", "G", "B"]
TILE = 128  # rows and columns of an UpdateImage packet at most: tevclient.Ipc's tiling, 192 KiB a packet
CONNECT_SECONDS = 2.0  # a local tev answers in microseconds; a remote one in well under this
SEND_SECONDS = 10.0    # a packet of one tile (192 KiB) that takes longer: a tev that hangs, given up
DISPLAY_VALUE = "tev or tev:HOST:PORT (PORT in [1, 65535])"


def parse_display(value, source="command line", key="--display"):
    """(host, port) of a --display value: "tev" (tev's default address) or "tev:HOST:PORT" (a name or an IPv4
    address: tev listens on IPv4 alone); InputError for anything else."""
    kind, colon, address = value.partition(":")
    if kind != "tev":
        raise InputError(source, key, value, f"unknown display; must be {DISPLAY_VALUE}")
    if not colon:
        return DEFAULT_HOST, DEFAULT_PORT
    host, _, port = address.rpartition(":")
    if not host or not (port.isascii() and port.isdigit()) or not 1 <= int(port) <= 65535:
        raise InputError(source, key, value, f"must be {DISPLAY_VALUE}")
    return host, int(port)


def _warn_stderr(text):
    import sys
    print(f"raytrace: warning: {text}", file=sys.stderr)


class TevDisplay(Watcher):
    """Shows a render in tev: `name` the image's name there (the output file's, say), `host` and `port` tev's
    address, `label` how the one warning names this display (default "tev HOST:PORT"), `warn` what prints it
    (default: a line on stderr, as the command line's warnings are), `max_share` the share of the render's
    wall time the display may take (None: no limit, every pass shown whatever it costs)."""

    def __init__(self, name="raytrace", host=DEFAULT_HOST, port=DEFAULT_PORT, label=None, warn=None,
                 max_share=DISPLAY_SHARE):
        self.name, self.host, self.port, self.max_share = name, host, port, max_share
        self.label = label or f"tev {host}:{port}"
        self.warn = warn or _warn_stderr
        self.socket, self.sent_spp, self.display_seconds = None, None, 0.0

    def started(self, report):
        from tevclient import packet  # imported with the display: a render without one never needs it
        self.packet = packet
        try:
            self.socket = socket.create_connection((self.host, self.port), timeout=CONNECT_SECONDS)
            self.socket.settimeout(SEND_SECONDS)
            self.socket.sendall(packet.create_image(self.name, report.width, report.height, CHANNELS))
        except OSError as e:
            self._give_up("cannot connect", e)

    def pass_done(self, report):
        if self.socket is not None and (self.max_share is None
                                        or self.display_seconds <= self.max_share * report.seconds):
            self._update(report)
        return None

    def finished(self, report):
        if self.socket is not None and report is not None and self.sent_spp != report.spp:
            self._update(report)
        if self.socket is not None:
            self.socket.close()
            self.socket = None

    def _update(self, report):
        start = time.perf_counter()
        image = report.image()
        try:
            for y in range(0, report.height, TILE):
                for x in range(0, report.width, TILE):
                    tile = image[y:y + TILE, x:x + TILE]
                    self.socket.sendall(self.packet.update_image(self.name, tile, CHANNELS, x, y))
        except OSError as e:
            self._give_up("connection lost", e)
            return
        self.sent_spp = report.spp
        self.display_seconds += time.perf_counter() - start

    def _give_up(self, what, error):
        """One warning line; the render goes on without the display."""
        if self.socket is not None:
            self.socket.close()
        self.socket = None
        self.warn(f"{self.label}: {what} ({error.strerror or error}): rendering without it")
