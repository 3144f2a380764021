"""A stand-in for the tev viewer in the tests: a TCP listener on a real socket that reads tev's IPC protocol
as tev's primary instance does (tev's src/Ipc.cpp: SocketConnection::service and
IpcPacket::interpretAsCreateImage / interpretAsUpdateImage), keeps what it was sent, and fails the test on
close() if what it was sent broke the protocol.

The protocol: a stream of packets, each a little-endian uint32 length (the length's own 4 bytes included), an
int8 type, then the type's fields; a string is its UTF-8 bytes and a NUL, a bool one byte.
    CreateImage (4): grab_focus, name, width int32, height int32, n int32, n channel names
    UpdateImage v3 (6): grab_focus, name, n int32, n channel names, x, y, width, height int32, n channel offsets
        int64, n channel strides int64, then float32 data: channel c of pixel p (row-major in the tile) at
        offset[c] + p * stride[c]
Other types (open, reload, close, vector graphics) are kept as their type alone; the tests send none.

What it keeps: `created` (name, width, height, channels) per CreateImage; per image a canvas the updates write
into, and `frames`, a copy of the canvas each time a tile reaching its bottom-right corner arrives: the whole
image once a sender that goes tile by tile, top-left first (tevclient's order, raytrace/tev.py's), has sent
it all."""
import socket
import struct
import threading

import numpy as np

CREATE_IMAGE, UPDATE_IMAGE_V3 = 4, 6


class _Reader:
    def __init__(self, data):
        self.data, self.at = data, 0

    def take(self, fmt):
        """The values of struct format `fmt` (little-endian), as a tuple."""
        values = struct.unpack_from("<" + fmt, self.data, self.at)
        self.at += struct.calcsize("<" + fmt)
        return values

    def one(self, fmt):
        return self.take(fmt)[0]

    def string(self):
        end = self.data.index(b"\0", self.at)
        text, self.at = self.data[self.at:end].decode(), end + 1
        return text


class TevListener:
    """A listener on 127.0.0.1 (an OS-chosen port: .port) serving its connections in a thread, one at a time,
    until close(). Errors in a packet are kept in .errors (a test checks it is empty)."""

    def __init__(self):
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.created, self.frames, self.errors, self.types = [], [], [], []
        self.canvases, self.connections = {}, 0
        self.server.settimeout(0.05)  # accept() wakes to see close()'s flag
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while not self.stopping.is_set():
            try:
                connection, _ = self.server.accept()
            except TimeoutError:
                continue
            self.connections += 1
            with connection:
                connection.settimeout(None)
                self._read(connection)

    def _read(self, connection):
        buffer = b""
        while True:
            chunk = connection.recv(1 << 20)
            if not chunk:
                if buffer:
                    self.errors.append(f"{len(buffer)} bytes of a partial packet at the end")
                return
            buffer += chunk
            while len(buffer) >= 4:
                length = struct.unpack_from("<I", buffer)[0]
                if length < 5:
                    self.errors.append(f"a packet of length {length}")
                    return
                if len(buffer) < length:
                    break
                try:
                    self._packet(_Reader(buffer[4:length]))
                except (struct.error, ValueError, UnicodeDecodeError) as e:
                    self.errors.append(f"unreadable packet: {e}")
                buffer = buffer[length:]

    def _packet(self, r):
        kind = r.one("b")
        self.types.append(kind)
        if kind == CREATE_IMAGE:
            r.one("?")
            name = r.string()
            width, height, n = r.take("iii")
            channels = [r.string() for _ in range(n)]
            self.created.append((name, width, height, channels))
            self.canvases[name] = np.zeros((height, width, n), np.float32)
        elif kind == UPDATE_IMAGE_V3:
            r.one("?")
            name = r.string()
            n = r.one("i")
            channels = [r.string() for _ in range(n)]
            x, y, width, height = r.take("iiii")
            offsets, strides = r.take(f"{n}q"), r.take(f"{n}q")
            data = np.frombuffer(r.data, "<f4", offset=r.at)
            canvas = self.canvases.get(name)
            if canvas is None:
                self.errors.append(f"an update of {name!r}, which no CreateImage made")
                return
            if [c for c in channels if c not in ("R", "G", "B")] or not (
                    0 <= x and x + width <= canvas.shape[1] and 0 <= y and y + height <= canvas.shape[0]):
                self.errors.append(f"an update of {name!r}: channels {channels}, tile {x},{y} {width}x{height}")
                return
            pixels = np.arange(width * height)
            if max(offsets[c] + pixels[-1] * strides[c] + 1 for c in range(n)) > data.size:
                self.errors.append(f"an update of {name!r} with too few floats ({data.size})")
                return
            for c, channel in enumerate(channels):
                values = data[offsets[c] + pixels * strides[c]].reshape(height, width)
                canvas[y:y + height, x:x + width, "RGB".index(channel)] = values
            if x + width == canvas.shape[1] and y + height == canvas.shape[0]:
                self.frames.append((name, canvas.copy()))

    def close(self):
        """Stop listening once the connection being served has ended (its sender closes it), and hold the sender
        to the protocol: every packet read whole and as tev reads it (no .errors), the connection ended within
        30 s. A test's own close() and its fixture's both check; the second has nothing more to do."""
        self.stopping.set()
        self.thread.join(timeout=30)
        self.server.close()
        assert not self.thread.is_alive(), "the sender never closed its connection"
        assert not self.errors, f"tev's protocol broken: {self.errors}"
