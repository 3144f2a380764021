"""Where a render's passes add up, timed both ways in one process: `python -m benchmarks.sums [SCENE ...]
[--width W] [--height H] [--spp N] [--light-samples N] [--device SPEC] [--repeat K] [--json PATH]`.

Each scene is rendered with its sums on the device (`accumulate="device"`, raytrace/renderer/device_sums.py)
and on the host (`"host"`, float64 sums of every pass read back), in turns, every other turn in reverse order,
after one untimed render of each (the build, the first launch). Per scene it prints the median whole-render
(wall) and kernel seconds of both and "paired", the median over turns of one turn's device wall time over its
host wall time (below 1: the device's sums save time). What a GPU's sums on the device are for: the host's
share of a render whose kernels take milliseconds (docs/gpu.md); .ci/gpu runs it."""
import argparse
import json
import statistics
import sys

from raytrace.errors import InputError
from raytrace.render import render
from raytrace.commands.bench import checked_scenes

WAYS = ("device", "host")


def sums_both_ways(scene_paths, repeat=5, out=sys.stdout, **kwargs):
    """The rows, a scene each: median wall and kernel seconds both ways, and the paired wall ratio."""
    rows = []
    for path, scene in checked_scenes(scene_paths, kwargs):
        for way in WAYS:
            render(scene, **kwargs, accumulate=way, progress=False)
        wall, kernel = {way: [] for way in WAYS}, {way: [] for way in WAYS}
        for turn in range(repeat):
            for way in WAYS if turn % 2 == 0 else reversed(WAYS):
                stats = render(scene, **kwargs, accumulate=way, progress=False)[1]
                wall[way].append(stats.wall_seconds)
                kernel[way].append(stats.render_seconds)
        row = {"scene": str(path), "device": stats.device, "repeat": repeat,
               **{f"{way}_wall_seconds": statistics.median(wall[way]) for way in WAYS},
               **{f"{way}_kernel_seconds": statistics.median(kernel[way]) for way in WAYS},
               "paired_wall_ratio": statistics.median(d / h for d, h in zip(wall["device"], wall["host"]))}
        print(f"{path}: wall {row['device_wall_seconds']:.4f} s with the sums on the device, "
              f"{row['host_wall_seconds']:.4f} s on the host (kernels {row['device_kernel_seconds']:.4f} and "
              f"{row['host_kernel_seconds']:.4f} s): paired x{row['paired_wall_ratio']:.3f}; {stats.device}",
              file=out, flush=True)
        rows.append(row)
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m benchmarks.sums", description=__doc__.split("\n")[0])
    p.add_argument("scene", nargs="*", default=["scenes/cornell.toml"], help="scene files (default: scene 0)")
    p.add_argument("--repeat", type=int, default=5, help="renders each way, in turns (default 5)")
    for option in ("--width", "--height", "--spp", "--light-samples"):
        p.add_argument(option, type=int, help="as render's (default: the scene's)")
    p.add_argument("--device", help="OpenCL device, as render's --device")
    p.add_argument("--json", help="write the rows as JSON here")
    args = p.parse_args(argv)
    if args.repeat < 1:
        raise InputError("command line", "--repeat", args.repeat, "must be at least 1")
    rows = sums_both_ways(args.scene, repeat=args.repeat, device=args.device, width=args.width, height=args.height,
                          spp=args.spp, light_samples=args.light_samples)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows}, f, indent=1)


if __name__ == "__main__":
    from benchmarks import run_rig
    sys.exit(run_rig("benchmarks.sums", main))
