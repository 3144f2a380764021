"""Hostile use of the commands: the broken promises a hostile run of the command line found (issue 43; each
test's docstring names its item), each reproduced as the user met it, through the command line in a child
process where the user used one: empty and bad option values, bad environment variables, scheduler addresses
that do not answer as Dask, peers that write bad images, a full disk, Ctrl-C while the modules load, during a
build and during a cluster's render, and odd mesh files. The promise: bad input ends in one line naming the
file or option, the key and the value, exit status 2, and nothing left behind."""
import contextlib
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import CORNELL, ROOT, child_env, mount, run
from raytrace.errors import InputError
from raytrace.scene import load_file

DIRECT = ROOT / "scenes" / "cornell_direct.toml"
TINY = ["--width", 8, "--height", 8, "--spp", 1, "--light-samples", 1]


def one_line(r, starts, progress=False):
    """Exit status 2, one line on stderr that starts with `starts`, nothing on stdout (with `progress`, the
    lines a command printed before it met the bad value may stand there)."""
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr[-3000:]
    assert lines[0].startswith(starts), lines[0]
    assert progress or r.stdout == ""


def test_a_direct_lights_radiance_beyond_the_brightness_limit_is_named_as_radiance(tmp_path):
    """Found (item 7): `lights[0].colour: missing` for a direct-mode light, which has no colour but a radiance."""
    text = DIRECT.read_text()
    assert "\nradiance = 60.0\n" in text
    for value in ("1e19", "3.4e38", "10000000000000000000000"):
        path = tmp_path / f"{value}.toml"
        lines = text.splitlines()
        path.write_text("\n".join(f"radiance = {value}" if line.startswith("radiance") else line
                                  for line in lines) + "\n")
        with pytest.raises(InputError) as error:
            load_file(path)
        assert error.value.key == "lights[0].radiance" and "2^62" in error.value.problem, str(error.value)


def test_a_peer_template_may_hold_other_braces(tmp_path):
    """Found (item 3): `... | awk '{print}'` in a --peer template ended in KeyError: 'print'. Only {sampler}, {spp} and
    {out} are placeholders; any other brace is the shell's."""
    from raytrace.commands.converge_peer import fill
    command = fill("peer --sampler {sampler} --spp {spp} --out {out} | awk '{print}' {x}", "sobol", 4, "a b.exr")
    assert command == "peer --sampler sobol --spp 4 --out 'a b.exr' | awk '{print}' {x}"


def test_bench_scaling_into_an_existing_file_is_named(tmp_path):
    """Found (item 10): `bench --scaling FILE` ended in `FILE: File exists`, naming no option."""
    file = tmp_path / "results"
    file.write_text("mine")
    r = run("bench", "--scaling", file, "--max-triangles", 100)
    one_line(r, f"raytrace: error: command line: --scaling = '{file}': is a file, not a directory")
    assert file.read_text() == "mine"


@pytest.mark.parametrize("argv, option", [
    (["bench", "--scaling", ""], "--scaling"),
    (["bench", str(CORNELL), *TINY, "--json", ""], "--json"),
    (["bench", str(CORNELL), *TINY, "--peer", ""], "--peer"),
    (["render", str(CORNELL), "-o", "x.png", *TINY, "--stats-json", ""], "--stats-json"),
    (["render", str(CORNELL), "-o", "", *TINY], "-o"),
    (["stability", "--json", ""], "--json"),
    (["converge", str(CORNELL), "--samplers", "grid", "--max-spp", 1, "--out", ""], "--out"),
    (["render", "", "-o", "x.png"], "scene"),
])
def test_an_empty_value_is_refused(tmp_path, argv, option):
    """Found (item 15): empty paths and commands were taken silently: `bench --scaling ''` ran the whole bench,
    `converge --out ''` wrote into the working directory, `--json ''` and `--peer ''` were ignored."""
    r = run(*argv, cwd=tmp_path)
    one_line(r, f"raytrace: error: command line: {option} = '': must not be empty")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("option", ["--texture-filter", "--spp", "--output"])
def test_a_value_of_two_dashes_is_refused(tmp_path, option):
    """Found by the fuzz suite: argparse takes `--texture-filter=--` as the option with no value at all (it
    drops '--' as the end of the options), and render's check of the filter raised TypeError on the empty list
    with a traceback, exit status 1. Each option of one value refuses it in one line, exit 2, nothing written."""
    argv = ["render", str(CORNELL), *TINY, "-o", "x.png", f"{option}=--"]
    r = run(*argv, cwd=tmp_path)
    one_line(r, f"raytrace: error: command line: {option} = '--': takes a value; '--' is none")
    assert list(tmp_path.iterdir()) == []


def test_an_empty_raytrace_device_is_refused(tmp_path):
    """Found (item 15): RAYTRACE_DEVICE='' picked the first device."""
    r = run("render", CORNELL, "-o", tmp_path / "x.png", *TINY, env={**os.environ, "RAYTRACE_DEVICE": ""})
    one_line(r, "raytrace: error: environment: RAYTRACE_DEVICE = '': must name a device")
    assert list(tmp_path.iterdir()) == []


def test_an_obj_with_one_component_uvs_renders(tmp_path):
    """Found (item 1): `vt u` lines (legal OBJ; trimesh opens the file) ended in a ValueError packing the triangles.
    v is then 0, as the format has it; the image is finite and the uvs are those of the file."""
    obj = tmp_path / "one.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\nvt 0.25\nvt 0.75\nf 1/1 2/2 3/3\n")
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(Path(CORNELL).read_text().replace('[[shapes]]', f'[[shapes]]\ntype = "mesh"\nfile = "{obj}"\n'
                                                 'material = "white"\n\n[[shapes]]', 1))
    scene = load_file(scene_file)
    assert scene.meshes[0].mesh.uvs.tolist() == [[0.5, 0.0], [0.25, 0.0], [0.75, 0.0]]
    out = tmp_path / "x.exr"
    r = run("render", scene_file, "-o", out, *TINY)
    assert r.returncode == 0, r.stderr


class _Server:
    """A TCP server on 127.0.0.1 that accepts connections and then does `behaviour` with each: 'silent' (reads
    and never answers), 'junk' (answers bytes that are no Dask handshake) or 'http' (answers like a web server,
    after a request that never comes: silent too)."""

    def __init__(self, behaviour):
        self.socket = socket.socket()
        self.socket.bind(("127.0.0.1", 0))
        self.socket.listen()
        self.port, self.behaviour, self.connections = self.socket.getsockname()[1], behaviour, []
        threading.Thread(target=self.serve, daemon=True).start()

    def serve(self):
        while True:
            try:
                connection, _ = self.socket.accept()
            except OSError:
                return
            self.connections.append(connection)
            if self.behaviour == "junk":
                connection.sendall(b"\xff" * 64)

    def close(self):
        for c in self.connections:
            c.close()
        self.socket.close()


@pytest.mark.parametrize("behaviour, problem", [("silent", "no Dask scheduler answered in 1 s"),
                                                ("junk", "answered 64 bytes that are no Dask handshake")])
def test_a_scheduler_address_that_does_not_answer_as_dask_is_one_line_in_time(monkeypatch, behaviour, problem):
    """Found (items 6 and 8): a port that accepts and never answers hung past 400 s, though the message
    promises 10 s; one that answers junk ended in 'out of memory: try a smaller --width/--height'. Here with
    the promise made 1 s (the same code path as its 10 s)."""
    from raytrace.renderer import distributed
    monkeypatch.setattr(distributed, "CONNECT_SECONDS", 1)
    server = _Server(behaviour)
    address = f"tcp://127.0.0.1:{server.port}"
    start = time.monotonic()
    try:
        with pytest.raises(InputError) as error:
            distributed.client_for(address)
    finally:
        server.close()
    assert time.monotonic() - start < 3
    assert (error.value.source, error.value.key, error.value.value) == ("render()", "scheduler", address)
    assert problem in error.value.problem


def test_a_tls_scheduler_is_one_line(tmp_path):
    """Found (item 2): --scheduler tls://127.0.0.1:1 ended in `TypeError: TLS expects a ssl_context`."""
    r = run("render", CORNELL, "-o", tmp_path / "x.png", *TINY, "--scheduler", "tls://127.0.0.1:1")
    one_line(r, "raytrace: error: command line: --scheduler = 'tls://127.0.0.1:1': TLS needs the cluster's")
    assert list(tmp_path.iterdir()) == []


BAD_PEER = """
import json, sys
import numpy as np
import OpenImageIO as oiio
sampler, spp, out, what = sys.argv[1:5]
if what == "empty":
    open(out, "wb").close()
elif what == "size":
    oiio.ImageBuf(np.zeros((3, 5, 3), np.float32)).write(out)
elif what == "nan":
    oiio.ImageBuf(np.full((8, 8, 3), np.nan, np.float32)).write(out)
print(json.dumps({"median_s": 0.01}))
"""


@pytest.mark.parametrize("what, problem", [("missing", "cannot read"), ("empty", "cannot read"),
                                           ("size", "is 5 x 3"), ("nan", "holds NaN or Inf")])
def test_a_peers_bad_image_names_the_peer(tmp_path, what, problem):
    """Found (item 9): a converge --peer whose EXR is missing, empty, the wrong size or holds NaN was reported as
    `--reference = '<a temporary file>'`, naming an option the user did not give."""
    script = tmp_path / "peer.py"
    script.write_text(BAD_PEER)
    template = f"{sys.executable} {script} {{sampler}} {{spp}} {{out}} {what}"
    out = tmp_path / "out"
    r = run("converge", CORNELL, "--samplers", "random", "--max-spp", 1, "--width", 8, "--height", 8,
            "--light-samples", 1, "--reference-spp", 4, "--peer", template, "--peer-samplers", "independent",
            "--out", out)
    one_line(r, f"raytrace: error: command line: --peer = {template!r}: the image of its independent render at 1 "
                f"spp: {problem}", progress=True)
    assert not out.exists()


def test_a_gamma_encoded_reference_is_refused(tmp_path):
    """Decided (issue 43, also seen): a PNG given as converge --reference was compared as if its 8-bit codes
    were linear radiance. Only linear float files (EXR, HDR) are references."""
    png = tmp_path / "ref.png"
    assert oiio.ImageBuf(np.zeros((8, 8, 3), "float32")).write(str(png))
    r = run("converge", CORNELL, "--samplers", "random", "--max-spp", 1, "--width", 8, "--height", 8,
            "--reference", png, "--out", tmp_path / "out")
    one_line(r, f"raytrace: error: command line: --reference = '{png}': must be a linear float image")


def test_bench_scaling_on_a_full_disk_leaves_nothing(tmp_path):
    """Found (item 12): on a full disk, `bench --scaling DIR` exited 2 but left scaling.csv, scaling.png and a truncated
    visits.png. A full disk here is a 40 KiB tmpfs (root only: skipped where mount is not permitted; not a file
    size limit, under which PoCL's LLVM aborts): the CSV and scaling.png fit, visits.png does not."""
    disk = tmp_path / "full"
    disk.mkdir()
    mount("-t", "tmpfs", "-o", "size=40k", "tmpfs", disk)
    try:
        out = disk / "out"
        r = run("bench", "--scaling", out, "--max-triangles", 100)
        one_line(r, f"raytrace: error: command line: --scaling = '{out}': {out / 'visits.png'}: cannot write: No "
                    "space left on device", progress=True)
        assert list(disk.iterdir()) == []
    finally:
        subprocess.run(["umount", str(disk)], check=True)


def test_bench_scaling_with_an_unusable_scheduler_leaves_no_directory(tmp_path):
    """Found (item 13): `bench --scaling DIR --scheduler tcp://127.0.0.1:1` exited 2 and left the empty DIR."""
    out = tmp_path / "out"
    r = run("bench", "--scaling", out, "--max-triangles", 100, "--scheduler", "tcp://127.0.0.1:1")
    one_line(r, "raytrace: error: command line: --scheduler = 'tcp://127.0.0.1:1': cannot reach the scheduler")
    assert list(tmp_path.iterdir()) == []


def test_a_local_cluster_leaves_nothing_in_the_temporary_directory(tmp_path):
    """Found (item 14): every `--scheduler local:N` left dask-scratch-space/{global,purge}.lock in the temporary
    directory."""
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    r = run("render", CORNELL, "-o", tmp_path / "x.png", *TINY, "--scheduler", "local:1", "--no-progress",
            env={**os.environ, "TMPDIR": str(temporary)})
    assert r.returncode == 0, r.stderr
    assert list(temporary.iterdir()) == []


def test_a_bad_raytrace_lanes_with_a_local_cluster_is_one_line(tmp_path):
    """Found (item 11): RAYTRACE_LANES=3 with --scheduler local:1 exited 2 with 8 lines (Dask's "Compute
    Failed" log)."""
    r = run("render", CORNELL, "-o", tmp_path / "x.png", *TINY, "--scheduler", "local:1",
            env={**os.environ, "RAYTRACE_LANES": "3"})
    one_line(r, "raytrace: error: environment: RAYTRACE_LANES = '3': must be one of 1, 4, 8, 16")
    assert list(tmp_path.iterdir()) == []


def test_spirv_prefers_the_clang_that_has_its_backend(tmp_path):
    """Found (item 17): with Debian's clang 14 on the PATH, `compile --target spirv` failed: "unknown argument:
    '-fintegrated-objemitter'" (the flag is newer). Here a stand-in clang on the PATH refuses that flag as
    clang 14 does; SPIR-V is built by PyPI's clang all the same (the test extra's ziglang)."""
    pytest.importorskip("ziglang")
    fake = tmp_path / "bin" / "clang"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\necho \"clang: error: unknown argument: '-fintegrated-objemitter'\" >&2\nexit 1\n")
    fake.chmod(0o755)
    r = run("compile", CORNELL, "--target", "spirv", env={**os.environ, "PATH": f"{fake.parent}:{os.environ['PATH']}"})
    assert r.returncode == 0 and ": spirv: ok," in r.stdout, r.stderr


def _numpy_mapped(pid, timeout=60.0):
    """Wait until process `pid` has mapped numpy's compiled core: the package's first lines (which take the
    signals over) have run, and its slow imports are under way."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        with contextlib.suppress(OSError):
            if "_multiarray_umath" in Path(f"/proc/{pid}/maps").read_text():
                return
        time.sleep(0.002)
    raise AssertionError("the child never loaded numpy")


@pytest.mark.parametrize("delay", [0.0, 0.05, 0.15])
def test_ctrl_c_while_the_modules_load_is_one_line(tmp_path, delay):
    """Found (item 5): Ctrl-C in the first ~0.35 s of `python -m raytrace` (numpy, pyopencl and OpenImageIO loading)
    gave a KeyboardInterrupt traceback. Sent at moments within that span, counted from when numpy's core is
    mapped (on a faster machine a later one may fall into the command itself: the same line). The interpreter's
    own start, before the package's first line runs, is not covered: timed from the child's start, as this test
    once was, a loaded machine (a start of 0.15 s) sent the signal into the interpreter's site module."""
    child = subprocess.Popen([sys.executable, "-m", "raytrace", "render", str(CORNELL), "-o", str(tmp_path / "x.png")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=child_env())
    _numpy_mapped(child.pid)
    time.sleep(delay)
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=120)
    assert (child.returncode, stderr) == (130, "raytrace: interrupted by SIGINT; nothing written\n"), stderr[-2000:]
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_during_a_local_cluster_render_is_one_line(tmp_path):
    """Found (item 4): Ctrl-C during a --scheduler local:2 render printed 68 lines, four workers' KeyboardInterrupt
    tracebacks. A terminal's Ctrl-C reaches the whole process group: sent so here, once the cluster is up. One
    line, whichever moment it lands at: before the passes, nothing written; during them (issue 61), the samples
    done written (tests/test_signals.py holds what they are)."""
    argv = [sys.executable, "-m", "raytrace", "render", str(CORNELL), "-o", str(tmp_path / "x.png"), "--width", 1024,
            "--height", 1024, "--spp", 64, "--scheduler", "local:2", "--no-progress"]
    child = subprocess.Popen(list(map(str, argv)), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=child_env(), start_new_session=True)
    try:
        first = child.stderr.readline()
        assert first.startswith("dask: local:2: dashboard at "), first
        time.sleep(1.0)
        os.killpg(child.pid, signal.SIGINT)
        stdout, stderr = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
            child.wait()
    out = tmp_path / "x.png"
    kept = re.fullmatch(rf"raytrace: interrupted by SIGINT: wrote {re.escape(str(out))} with \d+ of 64 spp in \d+ "
                        r"pass(es)?\n", stderr)
    assert child.returncode == 130 and (kept or stderr == "raytrace: interrupted by SIGINT; nothing written\n"), \
        stderr[-2000:]
    assert [p.name for p in tmp_path.iterdir()] == (["x.png"] if kept else [])


def test_a_binary_ply_face_claiming_more_indices_than_it_holds_is_refused(tmp_path):
    """Also seen (issue 43): a binary PLY face claiming 255 indices but holding 3 was read silently (trimesh's
    binary reader takes every face to have the first face's count). Decided: the faces are read record by
    record when their counts differ, and bytes left after the last element, beyond a closing newline, mean a
    count that does not match its data: refused, naming the file."""
    from raytrace.scene.mesh_file import load_mesh
    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              b"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
    vertices = b"".join(struct.pack("<fff", *p) for p in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    faces = struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 255, 0, 2, 3)
    path = tmp_path / "claims.ply"
    path.write_bytes(header + vertices + faces + bytes(2000))
    with pytest.raises(InputError) as error:
        load_mesh(path)
    assert (error.value.source, error.value.key) == (str(path), "file") and "bytes after its last element" in \
        error.value.problem
    faces = struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 3, 0, 2, 3)
    path.write_bytes(header + vertices + faces + b"\n")  # a writer's closing newline: read
    assert load_mesh(path)[0].faces.tolist() == [[0, 1, 2], [0, 2, 3]]


SIGNAL_DURING_BUILD = """
import os, signal, sys, threading
import pyopencl as cl
build = cl.Program.build
def signalled_build(self, *args, **kwargs):  # SIGINT to this process SIGNAL_AFTER seconds into the build
    threading.Timer(float(os.environ["SIGNAL_AFTER"]), os.kill, (os.getpid(), signal.SIGINT)).start()
    return build(self, *args, **kwargs)
cl.Program.build = signalled_build
from raytrace.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("after", [0.005, 0.01, 0.015, 0.02, 0.03])
def test_ctrl_c_during_the_kernels_first_build_is_one_line(tmp_path, after):
    """Found with item 5: a signal early in PoCL's build of the kernel (an empty kernel cache) made its clang
    print "1 error generated." before the command's line (here reproduced 10-20 ms into the build, which
    the child times itself: the command line's own main, a timer started as the build starts)."""
    env = child_env(POCL_CACHE_DIR=str(tmp_path / "cache"), SIGNAL_AFTER=str(after))
    r = subprocess.run([sys.executable, "-c", SIGNAL_DURING_BUILD, "render", str(CORNELL), "-o", str(tmp_path / "x.png"),
                        *map(str, TINY)], capture_output=True, text=True, env=env, timeout=120)
    assert (r.returncode, r.stderr) == (130, "raytrace: interrupted by SIGINT; nothing written\n"), r.stderr
    assert not (tmp_path / "x.png").exists()
