"""The benchmark suite: `python -m raytrace bench [SCENE ...]`.

Per scene: rays per second of the renderer's kernel (as `render` picks it for the device) against the
scalar kernel (LANES=1) on the same device in the same process, so that machines and loads cancel out in
the ratio; then the whole `python -m raytrace render` in child processes, with an empty kernel cache
(cold) and with the cache it filled (warm), for build seconds, process seconds and peak host memory; and
the BVH nodes and primitives tested per camera and per shadow ray, counted by a measuring build of the
kernel (visits.py).
The scenes' own renders are taken in turns (one of each, then again), so that each scene's time against
the first's is measured in the same minutes: a shared machine's speed drifts over minutes (measured in
commit afe4453). Two ratios: "x first's s" of the two fastest renders, and "paired", the median over turns
of the ratio of one turn's two renders (taken seconds apart, so that a slow spell falls on both). Rates are
of the kernels' own time (the device's profiling events); "wall s" is the whole render (launches, read-back,
the host's sums), what a peer's own timer holds: on a GPU, whose kernels take milliseconds, the two differ."""
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..errors import InputError
from ..outputs import scene_inputs
from ..renderer.cpu_target import cpu_flags, cpu_level
from ..renderer.device import default_lanes, select_device
from ..renderer.program import Features
from ..render import RenderOptions, check_memory, render, resolve
from ..scene import load_file
from . import ROOT, child_env
from .visits import PER_RAY, node_visits

# Scene 0, textures, texture filtering under strong minification, and the largest mesh scene that renders
# in seconds (10^5 triangles; mesh_million's BVH build alone takes longer than the rest of the suite).
SUITE = ["cornell.toml", "textured_cornell.toml", "grid_floor.toml", "mesh_cornell.toml"]


class BenchError(Exception):
    """A child render failed: not the user's input, so exit status 1 rather than 2."""


def suite_scenes():
    """The default suite's scene files, relative to the working directory where possible."""
    return [Path(os.path.relpath(ROOT / "scenes" / name)) for name in SUITE]


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
    except OSError:
        names = []
    return names[0] if names else platform.processor()


def _features(scene, kwargs):
    """The kernel variant `render` picks for the scene on the device."""
    return Features.of(scene, default_lanes(select_device(kwargs.get("device"))))


def in_turns(scenes, repeat, kwargs, features=None, alternate=False):
    """`repeat` renders of each scene by its `features` (default: the kernel `render` picks), taken in turns:
    every scene once, then every scene again, so that a slow spell of the machine falls on all of them; with
    `alternate`, every other turn in reverse order (a render can run faster or slower for following another).
    Returns (each scene's fastest RenderStats, each scene's render seconds turn by turn)."""
    features = features or [_features(scene, kwargs) for scene in scenes]
    for scene, f in zip(scenes, features):
        render(scene, **kwargs, features=f, progress=False)  # build and first launch (code generation): not timed
    best, seconds = [None] * len(scenes), [[] for _ in scenes]
    for turn in range(repeat):
        order = range(len(scenes)) if not (alternate and turn % 2) else reversed(range(len(scenes)))
        for k in order:
            scene, f = scenes[k], features[k]
            stats = render(scene, **kwargs, features=f, progress=False)[1]
            seconds[k].append(stats.render_seconds)
            if best[k] is None or stats.render_seconds < best[k].render_seconds:
                best[k] = stats
    return best, seconds


def paired_ratios(seconds):
    """Each scene's time against the first scene's as the median over turns of the two renders of one turn,
    taken seconds apart: a slow spell of a shared machine falls on both, where the ratio of the two fastest
    renders can pair a lucky minute with an unlucky one."""
    return [statistics.median(t / t0 for t, t0 in zip(times, seconds[0])) for times in seconds]


def _render_argv(kwargs):
    """The command-line options of `render` that give these render() keyword arguments."""
    return [a for key, value in kwargs.items() if value is not None
            for a in ("--" + key.replace("_", "-"), str(value))]


def run_child(scene_path, kwargs, cache_dir, work_dir):
    """`python -m raytrace render` of the scene in a child process with PoCL's kernel cache in cache_dir:
    its wall seconds, its own peak RSS and the build times from its --stats-json."""
    stats_path, log = work_dir / "stats.json", work_dir / "stderr.txt"
    argv = [sys.executable, "-m", "raytrace", "render", str(scene_path), "-o", str(work_dir / "out.png"),
            "--no-progress", "--stats-json", str(stats_path), *_render_argv(kwargs)]
    # The child runs this checkout's package; CUDA_CACHE_PATH makes "cold" mean the same on NVIDIA's driver.
    env = child_env(POCL_CACHE_DIR=str(cache_dir), CUDA_CACHE_PATH=str(cache_dir))
    with open(log, "w") as err:
        start = time.perf_counter()
        child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=err, env=env)
        try:  # wait4 gives this child's own peak RSS; RUSAGE_CHILDREN would be the largest of all children so far
            _, status, usage = os.wait4(child.pid, 0)
        except BaseException:  # interrupted (raytrace.outputs.Interrupted): the child goes too
            child.kill()
            child.wait()
            raise
        seconds = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        lines = log.read_text().strip().splitlines() or ["no message"]
        raise BenchError(f"{scene_path}: the child render exited with status {child.returncode}: {lines[-1]}")
    stats = json.loads(stats_path.read_text())
    first = stats["history"][0]
    # PoCL generates the kernel's code at its first launch, outside the profiled kernel time: the first
    # pass's time beyond its kernel seconds is that code generation (and one pass's accumulation).
    first_launch = first["pass_seconds"] - first["kernel_seconds"]
    return {"process_seconds": seconds, "peak_rss_bytes": usage.ru_maxrss * 1024,
            "build_seconds": stats["build_seconds"], "first_launch_seconds": first_launch,
            "build_and_first_launch_seconds": stats["build_seconds"] + first_launch}


def _processes(scene_path, kwargs):
    """A cold child render (a fresh, empty kernel cache) and a warm one (the cache it filled)."""
    with tempfile.TemporaryDirectory(prefix="raytrace-bench-") as tmp:
        cache = Path(tmp) / "kernel-cache"
        cache.mkdir()
        return run_child(scene_path, kwargs, cache, Path(tmp)), run_child(scene_path, kwargs, cache, Path(tmp))


def measure(scene_path, scene, repeat, kwargs, stats):
    """One row of the table (and of the JSON), around `stats`, the scene's best render from in_turns."""
    say = lambda what: print(f"bench: {scene_path}: {what}", file=sys.stderr, flush=True)  # noqa: E731
    features = _features(scene, kwargs)
    say(f"scalar baseline (LANES=1), best of {repeat}")
    [scalar], _ = in_turns([scene], repeat, kwargs, [Features.of(scene, 1)])
    say("child processes, cold and warm kernel cache")
    cold, warm = _processes(scene_path, kwargs)
    say("BVH nodes and primitives tested (a counting build)")
    visits = node_visits(scene, features, **kwargs, progress=False)
    nominal = stats.width * stats.height * stats.spp * (1 + stats.light_samples * len(scene.lights))
    return {"scene": str(scene_path), "lights": len(scene.lights), "triangles": scene.triangle_count,
            "width": stats.width, "height": stats.height, "spp": stats.spp, "light_samples": stats.light_samples,
            "lanes": features.lanes, "build_options": stats.build_options,
            "rays": stats.rays, "render_seconds": stats.render_seconds, "mrays_per_s": stats.mrays_per_s,
            "nominal_rays": nominal, "nominal_mrays_per_s": nominal / stats.render_seconds / 1e6,
            "wall_seconds": stats.wall_seconds, "nominal_wall_mrays_per_s": nominal / stats.wall_seconds / 1e6,
            "sums": stats.extra["sums"],
            "scalar_render_seconds": scalar.render_seconds, "scalar_mrays_per_s": scalar.mrays_per_s,
            "ratio_to_scalar": stats.mrays_per_s / scalar.mrays_per_s,
            "build_seconds_cold": cold["build_and_first_launch_seconds"],
            "build_seconds_warm": warm["build_and_first_launch_seconds"],
            "process_seconds_cold": cold["process_seconds"], "process_seconds_warm": warm["process_seconds"],
            "peak_host_bytes": max(cold["peak_rss_bytes"], warm["peak_rss_bytes"]),
            "device_bytes": stats.extra["device_bytes"], "device": stats.device, "target": stats.extra["target"],
            **{key: visits[key] for key in (*PER_RAY, "pixels_with_half_the_shadow_visits", "path_lanes_busy")},
            "cold": cold, "warm": warm}


MIB = 2**20
COLUMNS = [("scene", lambda r: Path(r["scene"]).name),
           ("Mrays/s", lambda r: f"{r['mrays_per_s']:.2f}"),
           ("nominal Mrays/s", lambda r: f"{r['nominal_mrays_per_s']:.2f}"),
           ("render s", lambda r: f"{r['render_seconds']:.3f}"),
           ("wall s", lambda r: f"{r['wall_seconds']:.3f}"),
           ("x first's s", lambda r: f"{r['time_ratio_to_first']:.2f}"),
           ("paired", lambda r: f"{r['paired_time_ratio_to_first']:.2f}"),
           ("build cold s", lambda r: f"{r['build_seconds_cold']:.2f}"),
           ("build warm s", lambda r: f"{r['build_seconds_warm']:.2f}"),
           ("process cold s", lambda r: f"{r['process_seconds_cold']:.2f}"),
           ("process warm s", lambda r: f"{r['process_seconds_warm']:.2f}"),
           ("host peak MiB", lambda r: f"{r['peak_host_bytes'] / MIB:.0f}"),
           ("device MiB", lambda r: f"{r['device_bytes'] / MIB:.1f}"),
           ("x scalar", lambda r: f"{r['ratio_to_scalar']:.2f}"),
           ("nodes/camera ray", lambda r: f"{r['visits_per_camera_ray']:.2f}"),
           ("nodes/shadow ray", lambda r: f"{r['visits_per_shadow_ray']:.2f}"),
           ("prims/camera ray", lambda r: f"{r['primitives_per_camera_ray']:.2f}"),
           ("prims/shadow ray", lambda r: f"{r['primitives_per_shadow_ray']:.2f}"),
           ("path lanes busy", lambda r: "-" if r.get("path_lanes_busy") is None else f"{r['path_lanes_busy']:.2f}")]


# The columns the printed table shows: it fits 100 characters (a terminal, a log); --json holds every figure.
TABLE = ("scene", "Mrays/s", "nominal Mrays/s", "render s", "x first's s", "build cold s", "x scalar")


def table(rows, shown=TABLE):
    """The rows as plain aligned text: the scene's file name left-aligned, the numbers right-aligned."""
    columns = [(name, cell) for name, cell in COLUMNS if name in shown]
    cells = [[name for name, _ in columns]] + [[cell(r) for _, cell in columns] for r in rows]
    widths = [max(len(row[k]) for row in cells) for k in range(len(columns))]
    return "\n".join("  ".join([row[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(row[1:], widths[1:])])
                     for row in cells)


def machine(device, target):
    """The machine line's facts: the device, how the kernel runs on it (`target`: the code-generation target,
    its ISA and the lane width), the CPU (its model and the highest x86-64 level its flags list)."""
    return {"device": device, "target": target, "cpu": cpu_model(), "cpu_level": cpu_level(cpu_flags()),
            "cpu_count": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()}


def run_peer(command, field="mrays_per_s"):
    """Another renderer's benchmark, run by the shell: its last line of output must be a JSON object (after
    any colour codes a logger left on the line) with a positive `field`: for bench, its `mrays_per_s` counted
    the nominal way (every shadow ray of every camera ray); for converge --peer, its render's `median_s`. A
    command that does not keep that promise is bad input: InputError naming --peer."""
    done = subprocess.run(command, shell=True, capture_output=True, text=True, errors="replace")
    lines = done.stdout.strip().splitlines()
    try:
        result = json.loads(lines[-1][lines[-1].index("{"):])
        if not 0 < float(result[field]) < math.inf:
            raise ValueError("not a positive number")
    except (IndexError, ValueError, KeyError, TypeError):
        last = (done.stderr.strip().splitlines() or lines or ["no output"])[-1]
        raise InputError("command line", "--peer", command, f"its last line of output is no JSON object with a "
                         f"positive {field} (exit status {done.returncode}): {last[:200]}") from None
    return result


def checked_scenes(scene_paths, kwargs, outputs=None):
    """(path, Scene) of every scene, all loaded, their options and memory checked and the device selected
    before any measuring, so that bad input costs no minutes of it; `outputs`, a raytrace.outputs.Outputs,
    learns the files they read."""
    scenes = [(path, load_file(path)) for path in scene_paths]
    for _, scene in scenes:
        if outputs is not None:
            outputs.add_inputs(scene_inputs(scene))
        check_memory(*resolve(scene, RenderOptions(**kwargs))[:2])
    select_device(kwargs.get("device"))
    return scenes


def benchmark(scene_paths, repeat=3, out=sys.stdout, peer=None, save=None, outputs=None, **kwargs):
    """Measure every scene (checked_scenes first); prints the table and the machine line, returns everything
    as one dict, which `save` is given at the end."""
    scenes = checked_scenes(scene_paths, kwargs, outputs)
    print(f"bench: every scene's render, best of {repeat}, in turns", file=sys.stderr, flush=True)
    best, seconds = in_turns([scene for _, scene in scenes], repeat, kwargs)
    rows = [measure(path, scene, repeat, kwargs, stats) for (path, scene), stats in zip(scenes, best)]
    for row, paired in zip(rows, paired_ratios(seconds)):
        row["time_ratio_to_first"] = row["render_seconds"] / rows[0]["render_seconds"]
        row["paired_time_ratio_to_first"] = paired
    info, first = machine(rows[0]["device"], rows[0]["target"]), rows[0]
    print(table(rows), file=out)
    print(f"{info['device']}; {first['width']}x{first['height']}, {first['spp']} spp x {first['light_samples']} "
          f"light samples; best of {repeat}; {info['target']}; CPU: {info['cpu']} ({info['cpu_count']} cores, "
          f"{info['cpu_level'] or 'below x86-64-v2'})", file=out, flush=True)
    results = {"machine": info, "repeat": repeat, "scenes": rows}
    if peer:
        results.update(beside_peer(peer, scenes[0][1], first, repeat, kwargs))
        print(f"peer: {float(results['peer']['mrays_per_s']):.2f} nominal Mrays/s (its median), "
              f"{results['peer_best_mrays_per_s']:.2f} at its best; {first['scene']}: "
              f"{results['beside_peer_nominal_mrays_per_s']:.2f} right after the peer "
              f"({first['nominal_mrays_per_s']:.2f} in the suite); best against best: {results['ratio_to_peer']:.2f}x; "
              f"the whole render (its kernel time, launches, read-back and sums) against the peer's: "
              f"{results['ratio_to_peer_wall']:.2f}x", file=out, flush=True)
    if save:
        save(results)
    return results


def beside_peer(command, scene, first, repeat, kwargs):
    """The peer, then the first scene again right after it: a shared machine's speed drifts over minutes
    (measured in commit afe4453), so the ratio takes our fastest render of that window against the peer's
    fastest (the suite's figure, minutes earlier, is kept beside it)."""
    print(f"bench: --peer {command}", file=sys.stderr, flush=True)
    result = run_peer(command)
    print(f"bench: {first['scene']}: again, right after the peer, best of {repeat}", file=sys.stderr, flush=True)
    [again], _ = in_turns([scene], repeat, kwargs)
    beside = first["nominal_rays"] / again.render_seconds / 1e6
    beside_wall = first["nominal_rays"] / again.wall_seconds / 1e6
    best = peer_best_rate(result)
    return {"peer": result, "peer_best_mrays_per_s": best, "beside_peer_nominal_mrays_per_s": beside,
            "ratio_to_peer": beside / best, "beside_peer_wall_mrays_per_s": beside_wall,
            "ratio_to_peer_wall": beside_wall / best}


def peer_best_rate(result):
    """The peer's rate at its fastest render: its mrays_per_s is its nominal rays over median_s (the Mitsuba
    script's contract), so that times median_s / min_s where it reports both sensibly; else mrays_per_s."""
    rate = float(result["mrays_per_s"])
    try:
        fastest, median = float(result["min_s"]), float(result["median_s"])
    except (KeyError, TypeError, ValueError):
        return rate
    return rate * median / fastest if 0 < fastest <= median < math.inf else rate
