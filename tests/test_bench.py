"""The benchmark suite (`python -m raytrace bench`) as a user runs it: one real, tiny run through the command
line with its JSON checked field by field, bad input answered before any measuring, and the suite's scenes."""
import json
import math

import pyopencl as cl
import pytest

from helpers import ROOT
from raytrace.commands import bench
from raytrace.renderer.program import Features
from raytrace.render import render
from raytrace.scene import load_file
from helpers import CORNELL, run

TINY = ["--width", 16, "--height", 16, "--spp", 1, "--light-samples", 1, "--repeat", 1]
FIELDS = ["scene", "lights", "width", "height", "spp", "light_samples", "rays", "render_seconds", "mrays_per_s",
          "nominal_rays", "nominal_mrays_per_s", "scalar_render_seconds", "scalar_mrays_per_s", "ratio_to_scalar",
          "build_seconds_cold", "build_seconds_warm", "process_seconds_cold", "process_seconds_warm",
          "peak_host_bytes", "device_bytes", "device", "build_options", "cold", "warm", "time_ratio_to_first",
          "paired_time_ratio_to_first", "visits_per_camera_ray", "visits_per_shadow_ray", "primitives_per_camera_ray",
          "primitives_per_shadow_ray", "pixels_with_half_the_shadow_visits", "path_lanes_busy"]


def test_bench_json_and_table(tmp_path):
    """Scene 0 (one light) at 16 x 16, 1 x 1 samples: nominal rays are W * H * spp * (1 + L * lights)."""
    out = tmp_path / "bench.json"
    r = run("bench", CORNELL, *TINY, "--json", out, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    assert data["repeat"] == 1 and data["machine"]["cpu"] and data["machine"]["device"]
    [row] = data["scenes"]
    assert not [key for key in FIELDS if key not in row]
    assert row["lights"] == 1 and row["nominal_rays"] == 16 * 16 * 1 * (1 + 1)
    assert row["nominal_mrays_per_s"] == pytest.approx(512 / row["render_seconds"] / 1e6)
    assert 0 < row["rays"] <= row["nominal_rays"]
    for key in ("mrays_per_s", "scalar_mrays_per_s", "ratio_to_scalar", "process_seconds_cold",
                "process_seconds_warm", "build_seconds_warm"):
        assert 0 < row[key] < math.inf, key
    assert row["build_seconds_cold"] >= row["build_seconds_warm"] and row["time_ratio_to_first"] == 1
    assert row["paired_time_ratio_to_first"] == 1
    assert row["peak_host_bytes"] > 0 and row["device_bytes"] > 0
    for key in ("visits_per_camera_ray", "visits_per_shadow_ray", "primitives_per_camera_ray",
                "primitives_per_shadow_ray", "pixels_with_half_the_shadow_visits"):
        assert 0 < row[key] < math.inf, key  # scene 0 has a BVH
    header, line, machine = r.stdout.strip().splitlines()
    assert header.split()[:2] == ["scene", "Mrays/s"] and line.startswith("cornell.toml ")
    assert header.endswith("render s  x first's s  build cold s  x scalar")
    assert "16x16, 1 spp x 1 light samples; best of 1" in machine and data["machine"]["cpu"] in machine


def test_the_table_fits_100_columns():
    """The table was some 250 columns wide (issue 55): it shows the figures one reads first and fits 100
    characters with the suite's longest scene name and wide figures; --json holds every column."""
    from raytrace.commands.bench import COLUMNS, TABLE, table
    row = {"scene": "/a/long/folder/scenes/textured_shapes.toml", "mrays_per_s": 12345.67,
           "nominal_mrays_per_s": 123456.78, "render_seconds": 123.456, "time_ratio_to_first": 123.45,
           "ratio_to_scalar": 12.34, "build_seconds_cold": 123.45}
    lines = table([row]).splitlines()
    assert max(map(len, lines)) <= 100 and lines[1].startswith("textured_shapes.toml ")
    assert set(TABLE) <= {name for name, _ in COLUMNS}


@pytest.mark.parametrize("args", [["no/such.toml"], [CORNELL, "no/such.toml"], [CORNELL, "--repeat", 0]],
                         ids=["missing", "missing-second", "repeat-0"])
def test_bad_input_one_line_before_measuring(args):
    r = run("bench", *args, *TINY[:8])
    assert r.returncode == 2 and r.stdout == ""
    assert len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("raytrace: error: ")


@pytest.mark.parametrize("name", ["cornell.toml", "textured_cornell.toml"])
def test_device_bytes_are_the_buffers_render_allocates(monkeypatch, name):
    scene = load_file(ROOT / "scenes" / name)
    features = Features.of(scene, 8)
    allocated, buffer = [], cl.Buffer

    def counting(context, flags, size=0, hostbuf=None):
        allocated.append(size or hostbuf.nbytes)
        return buffer(context, flags, size, hostbuf)

    monkeypatch.setattr(cl, "Buffer", counting)
    _, stats = render(scene, width=24, height=8, spp=4, light_samples=4, features=features, progress=False)
    assert stats.extra["device_bytes"] == sum(allocated)


def test_scenes_are_rendered_in_turns(monkeypatch):
    """in_turns renders each scene once untimed (the build), then every scene once per round, and keeps each
    one's fastest: scene k's best of the recorded times, in the order given."""
    a, b = load_file(CORNELL), load_file(ROOT / "scenes" / "textured_cornell.toml")
    order, seconds = [], iter([9, 9, 5, 7, 3, 8, 4, 6])

    class Stats:
        def __init__(self, t):
            self.render_seconds = t

    def fake_render(scene, **kwargs):
        order.append(scene)
        return None, Stats(next(seconds))

    monkeypatch.setattr(bench, "render", fake_render)
    best, seconds = bench.in_turns([a, b], 3, {})
    assert order == [a, b, a, b, a, b, a, b]
    assert [s.render_seconds for s in best] == [3, 6] and seconds == [[5, 3, 4], [7, 8, 6]]


def test_paired_ratios_are_medians_of_one_turns_ratios():
    """Scene b against scene a turn by turn (7/5, 8/3, 6/4): the median 1.5, where the fastest renders' ratio
    (6/3 = 2) pairs a's lucky turn with b's best; the first scene's own ratio is 1."""
    assert bench.paired_ratios([[5, 3, 4], [7, 8, 6]]) == [1.0, 1.5]


def test_suite_scenes():
    """The default suite: scene 0, the textured scenes and the largest mesh scene that renders in seconds."""
    scenes = bench.suite_scenes()
    assert [p.name for p in scenes] == ["cornell.toml", "textured_cornell.toml", "grid_floor.toml",
                                        "mesh_cornell.toml"]
    assert all((ROOT / "scenes" / p.name).is_file() and p.resolve() == ROOT / "scenes" / p.name for p in scenes)


def test_peer_ratio_and_bad_peer(tmp_path):
    """--peer runs the command in the same bench run, measures scene 0 again right after it, and reports that
    nominal rate against the peer's best;
    a peer that prints no JSON line with mrays_per_s is bad input: one error line naming --peer, exit status
    2, and no --json file (outputs are all or nothing), not even a temporary one."""
    out = tmp_path / "bench.json"
    peer = 'echo starting; echo \'{"mrays_per_s": 0.5, "variant": "fake"}\''
    r = run("bench", CORNELL, *TINY, "--json", out, "--peer", peer, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    assert data["peer"]["variant"] == "fake"
    assert data["ratio_to_peer"] == pytest.approx(data["beside_peer_nominal_mrays_per_s"] / 0.5)
    assert data["beside_peer_nominal_mrays_per_s"] > 0
    # the whole render (launches, read-back, sums: what a peer's own timer holds) is slower than its kernels
    assert data["ratio_to_peer_wall"] == pytest.approx(data["beside_peer_wall_mrays_per_s"] / 0.5)
    assert 0 < data["beside_peer_wall_mrays_per_s"] < data["beside_peer_nominal_mrays_per_s"]
    assert data["scenes"][0]["wall_seconds"] > data["scenes"][0]["render_seconds"]
    assert r.stdout.strip().splitlines()[-1].startswith("peer: 0.50 nominal Mrays/s (its median), 0.50 at its best;")
    for bad in ["echo no json", "echo '{\"mrays_per_s\": 0}'", "echo '[1]'", "echo '{\"mrays_per_s\": \"nan\"}'"]:
        out.unlink(missing_ok=True)
        r = run("bench", CORNELL, *TINY, "--json", out, "--peer", bad, cwd=ROOT)
        error = r.stderr.strip().splitlines()[-1]  # after the progress lines
        assert r.returncode == 2 and r.stderr.count("raytrace: error:") == 1 and "Traceback" not in r.stderr, bad
        assert error.startswith(f"raytrace: error: command line: --peer = {bad!r}: ") and "mrays_per_s" in error, bad
        assert list(tmp_path.iterdir()) == []


def test_image_size_out_of_range_is_refused_before_measuring():
    """The size checks, the memory check with them, come before any render."""
    r = run("bench", CORNELL, "--width", 400000, "--height", 400000, "--repeat", 1)
    assert r.returncode == 2 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("fields, best", [
    ({"median_s": 3.0, "min_s": 2.0}, 0.75), ({}, 0.5), ({"median_s": 3.0}, 0.5),
    ({"median_s": 2.0, "min_s": 3.0}, 0.5), ({"median_s": 3.0, "min_s": 0}, 0.5),
    ({"median_s": 3.0, "min_s": None}, 0.5), ({"median_s": "x", "min_s": 1.0}, 0.5),
    ({"median_s": float("nan"), "min_s": 1.0}, 0.5), ({"median_s": float("inf"), "min_s": 1.0}, 0.5)])
def test_peer_best_rate(fields, best):
    """The peer's fastest render's rate: its median rate times median_s / min_s (0.5 * 3 / 2), or its plain
    rate where the two are missing, not numbers, or out of order."""
    assert bench.peer_best_rate({"mrays_per_s": 0.5, **fields}) == pytest.approx(best)


def test_a_failing_child_render_exits_with_1_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """bench in process, its child renders (real processes) given an environment they refuse
    (RAYTRACE_TARGET=bogus, which this process does not read): exit status 1, one error line, after bench's
    progress, naming the scene and holding the child's own error line; and no --json file."""
    from raytrace import cli
    real = bench.child_env
    monkeypatch.setattr(bench, "child_env", lambda env=None, **variables: {**real(env, **variables),
                                                                           "RAYTRACE_TARGET": "bogus"})
    out = tmp_path / "b.json"
    assert cli.main(["bench", str(CORNELL), "--width", "16", "--height", "16", "--spp", "1", "--light-samples",
                     "1", "--repeat", "1", "--json", str(out)]) == 1
    lines = capsys.readouterr().err.splitlines()  # bench's progress lines, then the error
    assert [line for line in lines if "error" in line] == lines[-1:], lines
    assert lines[-1].startswith(f"raytrace: error: {CORNELL}: the child render exited with status 2: raytrace: "
                                "error: environment: RAYTRACE_TARGET = 'bogus'"), lines
    assert list(tmp_path.iterdir()) == []
