"""Rendering on Dask (raytrace/renderer/distributed.py): bit for bit the single-process render, whatever the number of
workers, their kind of cluster (a LocalCluster, `dask scheduler` and `dask worker` processes) or a worker
killed mid-render; --time-limit and --target-error stop it; what cannot be used is one line, exit status 2.

Bit for bit is the promise, not a tolerance: the workers run the same kernel on the same kind of device
(this machine's PoCL) and return float32 sums the client adds in pass and band order, as the local render
does, so any difference is a bug (an order, a lost or repeated band)."""
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from helpers import CORNELL, ROOT, on_pocl, run
from raytrace import load_file
from raytrace.errors import InputError
from raytrace.render import render_progressive
from raytrace.renderer.device_render import OUTPUT_PLANES

distributed = pytest.importorskip("dask.distributed")

SMALL = dict(width=64, height=48, spp=16, light_samples=4, progress=False)
ONE_ROW = dict(max_band_bytes=OUTPUT_PLANES * 4 * 64)  # one row a band: 48 tasks a pass


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  env={"POCL_MAX_PTHREAD_COUNT": "1"}, silence_logs=40) as cluster:
        with distributed.Client(cluster) as client:
            yield cluster, client


@pytest.fixture(scope="module")
def scene0():
    return load_file(CORNELL)


def assert_same(local, remote):
    (a, va, sa), (b, vb, sb) = local, remote
    np.testing.assert_array_equal(b, a)
    np.testing.assert_array_equal(vb, va)
    assert (sb.rays, sb.passes, sb.estimated_rmse) == (sa.rays, sa.passes, sa.estimated_rmse)


@pytest.mark.parametrize("scene_file", ["cornell.toml", "textured_cornell.toml", "mesh_cornell.toml",
                                        "cornell_direct.toml"])
def test_bit_identical_to_one_process(cluster, scene_file):
    """Scene 0, a textured scene (mip levels and texels scattered to the workers), a mesh with a BVH, and the
    direct model with sobol's one sequence over each pixel's samples (kernels/samplers.cl); one
    row a band, so that the two workers finish the 48 bands of a pass in no fixed order; two passes of 8, the
    first with its first half's sums (the error estimate's prefix) from the workers too."""
    scene = load_file(ROOT / "scenes" / scene_file)
    options = dict(SMALL, max_pass_work=64 * 48 * 5 * 8, **ONE_ROW)
    local = render_progressive(scene, **options)
    remote = render_progressive(scene, **options, client=cluster[1])
    assert_same(local, remote)
    assert "(Dask, 2 workers)" in remote[2].device and remote[2].passes >= 2


def test_banding_changes_nothing(cluster, scene0):
    """A band of any height gives the same sums pixel by pixel: the default banding on the cluster against
    one row a band in one process."""
    assert_same(render_progressive(scene0, **SMALL, **ONE_ROW), render_progressive(scene0, **SMALL, client=cluster[1]))


def test_a_short_last_band_changes_nothing(cluster, scene0):
    """50 rows in bands of 7: the last band holds 1 row, clipped to the image (render.py's _passes); a band of 7
    rows past the image's end fails on the worker."""
    options = dict(SMALL, height=50, max_band_bytes=OUTPUT_PLANES * 4 * 64 * 7)
    assert_same(render_progressive(scene0, **options), render_progressive(scene0, **options, client=cluster[1]))


def test_a_killed_worker_changes_nothing(cluster, scene0):
    """SIGKILL to one worker while a render of 64 passes of one sample is under way: the scheduler runs its
    tasks again elsewhere (the nanny starts a new worker) and the image is still the single-process one. The
    kill must land before the render ends, or the test proves nothing: it asserts that too (a render of one
    pass ended before it on a fast machine)."""
    options = dict(SMALL, spp=64, max_pass_work=64 * 48 * 5, **ONE_ROW)
    local = render_progressive(scene0, **options)
    client = cluster[1]
    victim = sorted(client.run(os.getpid).values())[0]
    done, killed_before_done = threading.Event(), []

    def kill_when_busy():
        deadline = time.time() + 30
        while time.time() < deadline and not any(client.processing().values()):
            time.sleep(0.01)
        time.sleep(0.2)
        killed_before_done.append(not done.is_set())
        os.kill(victim, signal.SIGKILL)
    killer = threading.Thread(target=kill_when_busy)
    killer.start()
    remote = render_progressive(scene0, **options, client=client)
    done.set()
    killer.join()
    assert killed_before_done == [True], "the render ended before the kill: the test proved nothing"
    assert_same(local, remote)
    assert local[2].passes == 64
    client.wait_for_workers(2, timeout=60)


@pytest.mark.parametrize("stop", [dict(time_limit=0.3), dict(target_error=0.2)])
def test_time_limit_and_target_error_stop_it(cluster, scene0, stop):
    """A render of 128 passes of 512 samples stops long before them, as a local render would; the passes
    submitted ahead are cancelled."""
    _, _, stats = render_progressive(scene0, width=256, height=256, spp=65536, light_samples=1, sampler="random",
                                     progress=False, client=cluster[1], **stop)
    assert stats.stopped_by == ("time-limit" if "time_limit" in stop else "target-error")
    assert stats.spp <= 8 * 512 and stats.passes >= (1 if "time_limit" in stop else 4)


@on_pocl
def test_a_worker_without_a_device_is_one_line(scene0):
    """PoCL with its devices hidden on the workers: the worker's error reaches the client whole."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  env={"POCL_DEVICES": "none"}, silence_logs=40) as cluster, \
            distributed.Client(cluster) as client:
        with pytest.raises(InputError, match="environment: POCL_DEVICES = 'none': leaves no OpenCL device"):
            render_progressive(scene0, **SMALL, client=client)


def test_missing_dask_is_one_line(monkeypatch, scene0):
    from raytrace.renderer import distributed as ours
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    monkeypatch.setattr(ours, "_clients", {})
    with pytest.raises(InputError, match=r"^render\(\): scheduler = 'local:2': needs Dask"):
        render_progressive(scene0, **SMALL, scheduler="local:2")


@pytest.mark.parametrize("address, problem", [
    ("local:0", f"local:N needs 1 <= N <= {os.cpu_count()} workers, the cores this machine has"),
    ("local:257", "local:N needs 1 <= N <= "),
    (f"local:{os.cpu_count() + 1}", f"local:N needs 1 <= N <= {os.cpu_count()} workers"),  # one worker past the cores
    ("local:1x", "must be local:N or tcp://host:port"),  # trailing junk, not a LocalCluster of 1
    ("local:1:8786", "must be local:N or tcp://host:port"),
    ("udp://x:1", "must be local:N or tcp://host:port"),
    ("tcp://127.0.0.1:9", "cannot reach the scheduler"),
])
def test_bad_schedulers_are_one_line(tmp_path, address, problem):
    out = tmp_path / "x.png"
    r = run("render", CORNELL, "-o", out, "--width", "16", "--height", "16", "--spp", "1", "--scheduler", address)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and problem in r.stderr, r.stderr
    assert not out.exists()


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_dask_worker_processes_over_tcp(tmp_path):
    """`dask scheduler` and two `dask worker` processes, the command line's --scheduler tcp://...: the EXR it
    writes holds the single-process render's values bit for bit."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]  # the dask command of this environment
    env = {**os.environ, "POCL_MAX_PTHREAD_COUNT": "1"}
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--dashboard-address",
                               ":0"], env=env, stderr=subprocess.DEVNULL)]
    try:
        procs += [subprocess.Popen([*dask, "worker", address, "--nthreads", "1", "--no-dashboard"], env=env,
                                   stderr=subprocess.DEVNULL) for _ in range(2)]
        with distributed.Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        options = ["--width", "64", "--height", "48", "--spp", "16", "--light-samples", "4"]
        r_local = run("render", CORNELL, "-o", tmp_path / "local.exr", *options)
        r_remote = run("render", CORNELL, "-o", tmp_path / "remote.exr", *options, "--scheduler", address)
        assert r_local.returncode == 0 and r_remote.returncode == 0, r_remote.stderr
        assert "(Dask, 2 workers)" in r_remote.stdout + r_remote.stderr
        import OpenImageIO as oiio
        local, remote = (oiio.ImageBuf(str(tmp_path / f"{n}.exr")).get_pixels(oiio.FLOAT) for n in ("local", "remote"))
        np.testing.assert_array_equal(remote, local)
        assert local.mean() > 0.05
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=30)


def test_converge_and_scaling_take_a_scheduler(tmp_path, capsys):
    """converge's renders (its reference too) and bench --scaling's run on the cluster: converge's errors
    are the single-process run's to the last digit; bench without --scaling refuses the option."""
    from raytrace import cli
    args = ["converge", str(CORNELL), "--samplers", "random", "--max-spp", "4", "--width", "8", "--height", "8",
            "--light-samples", "4", "--reference-spp", "16"]
    assert cli.main([*args, "--out", str(tmp_path / "here")]) == 0
    assert cli.main([*args, "--out", str(tmp_path / "there"), "--scheduler", "local:1"]) == 0
    errors = [[line.split(",")[3:] for line in (tmp_path / where / "converge.csv").read_text().splitlines()]
              for where in ("here", "there")]  # rmse, estimated_rmse, flip: all but the seconds
    assert errors[0] == errors[1] and len(errors[0]) == 4
    assert cli.main(["bench", "--scaling", str(tmp_path / "scaling"), "--max-triangles", "100",
                     "--scheduler", "local:1"]) == 0
    assert (tmp_path / "scaling" / "scaling.csv").exists()
    capsys.readouterr()
    assert cli.main(["bench", "--scheduler", "local:1"]) == 2
    assert "bench takes it only with --scaling" in capsys.readouterr().err
