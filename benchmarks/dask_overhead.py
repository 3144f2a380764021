"""What rendering on Dask costs on one machine: `python -m benchmarks.dask_overhead [SCENE ...]`.

For each scene, the wall time of a render in this process and on LocalClusters of 1 and 2 worker processes
on the same cores (each cluster warmed by a first, untimed render: the workers' programs and scene buffers
are built once per worker, not per render); then the two rates docs/dask.md's model of many machines is
built from: how fast the client adds a band's float32 sums into its float64 image (MB/s), and what the
scheduler spends on a task that does nothing (ms a task, submitted and gathered in one batch). Prints a
table and writes JSON (--json)."""
import argparse
import json
import sys
import time

import numpy as np

from raytrace import load_file
from raytrace.render import render_progressive
from raytrace.renderer.distributed import client_for, close_all
from raytrace.renderer.progressive import Accumulator

DEFAULT = dict(width=2048, height=2048, spp=64, progress=False)


def wall(scene, **options):
    start = time.perf_counter()
    _, _, stats = render_progressive(scene, **options)
    return time.perf_counter() - start, stats


def merge_rate(width=2048, rows=256, passes=8):
    """MB/s of float32 band sums added into a float64 image of `width` columns, as the client does."""
    acc = Accumulator((3, rows * passes, width))
    sums = np.random.default_rng(0).random((3, rows, width), dtype=np.float32)
    start = time.perf_counter()
    for k in range(passes):
        for row0 in range(0, rows * passes, rows):
            acc.add_rows(row0, sums)
        acc.end_pass(1)
    return passes * passes * sums.nbytes / (time.perf_counter() - start) / 1e6


def task_cost(client, n=2000):
    """Seconds a no-op task costs the scheduler and the client, submitted and gathered in one batch."""
    client.gather(client.map(abs, range(100), pure=False))  # warm
    start = time.perf_counter()
    client.gather(client.map(abs, range(n), pure=False))
    return (time.perf_counter() - start) / n


def measure(scene_paths, options, out=sys.stdout):
    rows = []
    clients = {n: client_for(f"local:{n}") for n in (1, 2)}  # as --scheduler local:N starts them
    try:
        for path in scene_paths:
            scene = load_file(path)
            render_progressive(scene, **dict(options, spp=1))  # this process's build
            alone, stats = wall(scene, **options)
            row = {"scene": str(path), "single_process_s": alone, "passes": stats.passes, "rays": stats.rays}
            for n, client in clients.items():
                render_progressive(scene, **dict(options, spp=1), client=client)  # the workers' builds
                seconds, _ = wall(scene, **options, client=client)
                row[f"local_{n}_s"], row[f"local_{n}_overhead"] = seconds, seconds / alone - 1
            rows.append(row)
            print(f"{path}: one process {alone:.2f} s; local:1 {row['local_1_s']:.2f} s "
                  f"({100 * row['local_1_overhead']:+.1f}%); local:2 {row['local_2_s']:.2f} s "
                  f"({100 * row['local_2_overhead']:+.1f}%); {stats.passes} passes", file=out, flush=True)
        rates = {"merge_mb_per_s": merge_rate(), "task_ms": 1e3 * task_cost(clients[2])}
        print(f"client merge: {rates['merge_mb_per_s']:.0f} MB/s of float32 sums; scheduler: "
              f"{rates['task_ms']:.2f} ms a task", file=out, flush=True)
    finally:
        close_all()
    return {"options": {k: v for k, v in options.items() if k != "progress"}, "scenes": rows, **rates}


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m benchmarks.dask_overhead", description=__doc__.split("\n")[0])
    parser.add_argument("scene", nargs="*", default=["scenes/cornell.toml", "scenes/mesh_cornell.toml"])
    parser.add_argument("--width", type=int, default=DEFAULT["width"])
    parser.add_argument("--height", type=int, default=DEFAULT["height"])
    parser.add_argument("--spp", type=int, default=DEFAULT["spp"])
    parser.add_argument("--json", help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    result = measure(args.scene, dict(DEFAULT, width=args.width, height=args.height, spp=args.spp))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
