"""Rendering on a Dask cluster (`--scheduler`, `render(..., scheduler=...)`): the `dist` extra, imported only
when a scheduler is given.

The work unit is one progressive pass over one band of rows, the unit the local render already launches:
a worker renders it with the same kernel, the same sample indices and the same banding, so its float32 sums
are the very numbers the local render would add. The client adds them into its float64 sums in a fixed
order, pass by pass and, within a pass, band by band, as the local render does; the image and its error
estimate are then bit for bit the local render's, whatever the number of workers and the order in which
tasks finish, on workers whose devices are of one kind. Bands, not tiles: a band is what the kernel's
launch and output buffer already are, and its rows are contiguous in the client's sums.

A worker builds its OpenCL context, the program and the scene's device buffers once per scene and options
(contexts cannot be pickled): `_device_renders` keeps them per worker process, keyed by a digest of the
scene and options, which the client pickles once and scatters as bytes to every worker. Tasks carry their
pass and band in their arguments and are submitted with pure=False, so Dask never merges two of them. A
worker that dies loses nothing but time: the scheduler runs its tasks again elsewhere, with the same
arguments and so the same sums.

Addresses: `local:N` starts a LocalCluster of N worker processes of one thread each (PoCL's threads shared
out among them); `tcp://host:port` is a running scheduler (`dask scheduler`, `dask worker ...`)."""
import ast
import contextlib
import dataclasses
import hashlib
import os
import pickle
import re
import shutil
import signal
import socket
import sys
import tempfile
import threading
import time

from .. import aovs as aov_types
from ..errors import API, InputError
from .device_render import DeviceRender
from .progressive import CHANNELS, Accumulator

PASSES_AHEAD = 2  # passes submitted beyond the one being merged: the workers never wait on the client
CONNECT_SECONDS = 10

_clients = {}  # address -> (client, cluster or None), for the life of the process
_scratch = {}  # address -> the scratch folder of the local cluster started for it
_device_renders = {}  # on a worker: digest -> DeviceRender


def client_for(address):
    """The Dask client of `address` ("local:N" or a scheduler's "tcp://host:port"), made once per process;
    an address that cannot be used is bad input."""
    if address not in _clients:
        _clients[address] = _connect(address)
        print(f"dask: {address}: dashboard at {_clients[address][0].dashboard_link}", file=sys.stderr, flush=True)
    return _clients[address][0]


def _is_main_test(test):
    """Whether an if statement's test is `__name__ == "__main__"` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def _unguarded_script_line():
    """(the script, the line) where a script run as a file reaches this call from its top-level code outside
    an `if __name__ == "__main__":` block, or None. Worker processes started by multiprocessing's spawn import
    the script again, running its top-level code: unguarded, that code starts workers of its own, and Dask
    answers with pages of "Nanny failed to start" tracebacks instead of one line."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    frame = sys._getframe()
    while frame is not None and frame.f_globals is not getattr(main, "__dict__", None):
        frame = frame.f_back
    if not path or frame is None:  # an interpreter, python -c, a notebook: no file to run again
        return None
    while frame.f_back is not None and frame.f_back.f_globals is main.__dict__:
        frame = frame.f_back
    if frame.f_code.co_name != "<module>":
        return None
    try:
        tree = ast.parse(open(path, encoding="utf-8").read())
    except (OSError, SyntaxError, UnicodeDecodeError):
        return None
    line = frame.f_lineno
    guarded = any(isinstance(node, ast.If) and _is_main_test(node.test) and node.lineno <= line <= node.end_lineno
                  for node in tree.body)
    return None if guarded else (path, line)


def _probe(address, host, port):
    """Whether a Dask scheduler answers at host:port within CONNECT_SECONDS, before Dask's client is let near
    it: a scheduler sends its handshake as soon as a connection opens (a frame count, then msgpack frames),
    while a server that accepts and stays silent would keep the client waiting past any timeout, and one
    that answers something else (a dashboard's HTTP, junk) would have the client decode its bytes as frame
    lengths (a MemoryError). InputError names the address and what it did."""
    deadline = time.monotonic() + CONNECT_SECONDS
    try:
        with socket.create_connection((host, port), timeout=CONNECT_SECONDS) as connection:
            data = b""
            while len(data) < 25 and time.monotonic() < deadline:
                connection.settimeout(max(0.01, deadline - time.monotonic()))
                chunk = connection.recv(64)
                if not chunk:
                    break
                data += chunk
    except socket.timeout:
        raise InputError(API, "scheduler", address, f"no Dask scheduler answered in {CONNECT_SECONDS} s") from None
    except OSError as e:
        raise InputError(API, "scheduler", address, f"cannot reach the scheduler: {e.strerror or e}") from None
    frames = int.from_bytes(data[8:16], "little") if len(data) >= 16 else 0
    if len(data) < 25 or not 1 <= frames <= 64 or not (0x80 <= data[24] <= 0x8F or data[24] in (0xDE, 0xDF)):
        said = "nothing" if not data else f"{len(data)} bytes that are no Dask handshake"
        raise InputError(API, "scheduler", address, f"answered {said} in {CONNECT_SECONDS} s: not a Dask scheduler")


def _connect(address):
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InputError(API, "scheduler", address, "needs Dask: pip install -e \".[dist]\"") from None
    local = re.fullmatch(r"local:([0-9]+)", address)
    if local:
        n = int(local.group(1))
        cores = os.cpu_count() or 1
        if not 1 <= n <= cores:  # more worker processes than cores only share the cores, at a cost each
            raise InputError(API, "scheduler", address, f"local:N needs 1 <= N <= {cores} workers, the cores "
                             "this machine has")
        unguarded = _unguarded_script_line()
        if unguarded:
            raise InputError(API, "scheduler", address, f"starts worker processes that run {unguarded[0]} again from "
                             f"the top, whose line {unguarded[1]} would start them again: put the script's code under "
                             "if __name__ == \"__main__\":")
        threads = str(max(1, (os.cpu_count() or 1) // n))  # PoCL's pthread device would take every core each
        # silence_logs: CRITICAL only, as a task's failure reaches the client as its one-line error (a
        # worker's InputError pickles whole) and Dask's own "Compute Failed" log would add lines to it.
        # The workers' scratch space (Dask's locks and spill files) in a folder of this run's, removed by
        # close_all, rather than a dask-scratch-space left in the temporary directory
        scratch = _scratch.setdefault(address, tempfile.mkdtemp(prefix="raytrace-dask-"))
        import dask
        with dask.config.set({"temporary-directory": scratch}), _terminal_signals_ignored():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   env={"POCL_MAX_PTHREAD_COUNT": threads}, silence_logs=50, local_directory=scratch)
        return Client(cluster), cluster
    if address.startswith("tls://"):
        raise InputError(API, "scheduler", address, "TLS needs the cluster's certificates: pass a "
                         "dask.distributed.Client made with its security settings as render(client=...)")
    match = re.fullmatch(r"tcp://([^\s/]+):([0-9]+)", address)
    if not match:
        raise InputError(API, "scheduler", address, "must be local:N or tcp://host:port")
    _probe(address, match.group(1).strip("[]"), int(match.group(2)))
    try:
        return Client(address, timeout=CONNECT_SECONDS), None
    except (OSError, TimeoutError) as e:
        raise InputError(API, "scheduler", address,
                         f"cannot reach the scheduler in {CONNECT_SECONDS} s ({type(e).__name__})") from None


@contextlib.contextmanager
def _terminal_signals_ignored():
    """SIGINT and SIGHUP ignored while a local cluster starts its processes, which inherit that (an ignored
    signal stays ignored across fork and exec, and Python keeps it so): Ctrl-C at a terminal reaches the
    whole process group, and the workers would each print a KeyboardInterrupt traceback. This process
    handles the signal and closes the cluster (cli.py's _dask_closed)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGHUP)}
    try:
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)


def close_all():
    """Close every client and the clusters this process started, and remove their scratch folders."""
    while _clients:
        client, cluster = _clients.popitem()[1]
        client.close()
        if cluster is not None:
            cluster.close()
    while _scratch:
        shutil.rmtree(_scratch.popitem()[1], ignore_errors=True)


def pickled_render(scene, options):
    """(bytes, digest): the scene and every option that reaches the device, pickled once, and the key of a
    worker's DeviceRender for them."""
    payload = pickle.dumps((scene, options))
    return payload, hashlib.sha256(payload).hexdigest()


def render_band(payload, resolved, digest, sample0, n, n_first, row0, rows):
    """On a worker: the float32 sums of pixel samples [sample0, sample0 + n) over `rows` rows from row0, those
    of the first n_first of them or None (n_first 0), the rays traced, the kernel seconds, and what the
    statistics say of the worker's device. `payload` is pickled_render's, unpickled once per worker and
    render; `resolved` is the client's render.Resolved: the options checked once, against the client's scene
    file."""
    d = _device_render(payload, resolved, digest)
    d.set_samples(sample0, n, n_first)
    sums, first, rays, seconds, aovs = d.bands.run_band(d.queue, d.args, row0, rows)
    return (sums.copy(), None if first is None else first.copy(), rays, seconds, d.info(),
            None if aovs is None else aovs.copy())


def _device_render(payload, resolved, digest):
    """This worker's DeviceRender of the render `digest`, built on its first task."""
    if digest not in _device_renders:
        _device_renders.clear()  # one scene at a time: device memory is the worker's to keep small
        _device_renders[digest] = DeviceRender(*pickle.loads(payload), resolved)
    return _device_renders[digest]


def worker_info(payload, resolved, digest):
    """A worker's DeviceRender.info() for this render, its device built as for a band."""
    return _device_render(payload, resolved, digest).info()


class DaskPasses:
    """The passes of one render as Dask tasks, a band of one pass each: submitted PASSES_AHEAD passes ahead
    of the one the client merges, merged in pass and band order. `bands` are (first row, rows)."""

    def __init__(self, client, scene, options, resolved, bands):
        self.client, self.passes, self.bands, self.resolved = client, resolved.passes, bands, resolved
        payload, self.digest = pickled_render(
            scene, dataclasses.replace(options, scheduler=None, client=None, progress=False))
        self.payload = client.scatter(payload, broadcast=True, hash=False)
        self.futures, self.last_info = {}, None
        self.aov_planes = aov_types.plane_count(aov_types.mask(scene.aovs))

    def _submit(self, k):
        self.futures[k] = [self.client.submit(render_band, self.payload, self.resolved, self.digest,
                                              *self.passes[k], row0, rows, pure=False) for row0, rows in self.bands]

    def accumulator(self):
        """The client's float64 sums: the bands come from the workers' devices."""
        return Accumulator((CHANNELS, self.resolved.height, self.resolved.width), self.aov_planes)

    def run_pass(self, k, acc):
        """Pass k's bands added into `acc` in band order; returns the kernel seconds."""
        for j in range(k, min(k + 1 + PASSES_AHEAD, len(self.passes))):
            if j not in self.futures:
                self._submit(j)
        seconds = 0.0
        for (row0, _), future in zip(self.bands, self.futures.pop(k)):
            sums, first, band_rays, band_seconds, self.last_info, aovs = future.result()
            acc.add_rows(row0, sums, first, band_rays, aovs)
            seconds += band_seconds
        return seconds

    def device_fingerprint(self):
        """A checkpoint's record of the device (as LocalPasses'): the workers', known once a band came back (None
        before: render.py asks again after the first pass)."""
        if self.last_info is None:
            return None
        return {"device": self.last_info["device"], "build_options": self.last_info["build_options"]}

    def info(self):
        """The statistics' device: the last band's worker's, the workers being of one kind (asked of a worker
        where no band came back: a finished render resumed)."""
        if self.last_info is None:
            self.last_info = self.client.submit(worker_info, self.payload, self.resolved, self.digest,
                                                pure=False).result()
        n = len(self.client.scheduler_info()["workers"])
        return {**self.last_info, "device": f"{self.last_info['device']} (Dask, {n} workers)",
                "extra": {**self.last_info["extra"], "sums": "host"}}

    def cancel(self):
        """Drop the passes submitted ahead of a render that stopped early."""
        self.client.cancel([f for futures in self.futures.values() for f in futures])
        self.futures.clear()
