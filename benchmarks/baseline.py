"""This checkout's kernel against a baseline's: `python -m benchmarks.baseline DIR [SCENE ...] [--repeat K]`.

DIR is another kernels/ directory: another commit's, checked out beside this one (`git worktree add
/tmp/base COMMIT`, then `python -m benchmarks.baseline /tmp/base/kernels`), or a copy with one change tried out. Both kernels
are built for the same features from the same scene tables, packed by this checkout's host, and rendered in
turns in one process (ours then the baseline's, then the baseline's then ours, and so on), so that a shared
machine's drift falls on both: a kernel change is then measured far more finely than two processes minutes
apart could tell it (measured in commit b07df41). The host packs this checkout's structs, so the baseline's
kernels/types.h must be the same file; a change to the host (packing, the BVH's build) needs two processes
instead.

Per scene it prints both kernels' fastest render and two ratios, ours over the baseline's (below 1: ours
is faster): of the two fastest renders, and "paired", the median over turns of one turn's two renders."""
import argparse
import dataclasses
import statistics
import sys
from pathlib import Path

from raytrace.errors import InputError
from raytrace.renderer.program import kernel_dir
from raytrace.commands.bench import _features, checked_scenes, in_turns


def baseline_kernels(directory):
    """The baseline's kernels/ directory as an absolute path, or InputError naming DIR: it must hold
    render.cl and the same types.h as this checkout's."""
    path = Path(directory)
    if not directory or not (path / "render.cl").is_file():
        raise InputError("command line", "DIR", directory, "holds no render.cl (give a kernels/ directory)")
    try:
        theirs = (path / "types.h").read_bytes()
    except OSError as e:
        raise InputError("command line", "DIR", directory, f"its types.h cannot be read: {e.strerror}") from None
    if theirs != (kernel_dir() / "types.h").read_bytes():
        raise InputError("command line", "DIR", directory, "its types.h differs from this checkout's (the "
                         "host packs this checkout's structs): compare such kernels in two processes")
    return str(path.resolve())


def against_baseline(scene_paths, baseline, repeat=3, out=sys.stdout, **kwargs):
    """Each scene rendered `repeat` times by this checkout's kernel and by the baseline's (a kernels/
    directory checked by baseline_kernels), in turns; prints a line a scene and returns the rows."""
    baseline = baseline_kernels(baseline)
    scenes = checked_scenes(scene_paths, kwargs)
    rows = []
    for path, scene in scenes:
        print(f"bench: {path}: this kernel and the baseline's, in turns, {repeat} each", file=sys.stderr, flush=True)
        ours = _features(scene, kwargs)
        best, (mine, theirs) = in_turns([scene, scene], repeat, kwargs,
                                        [ours, dataclasses.replace(ours, kernels=baseline)], alternate=True)
        stats = best[0]
        row = {"scene": str(path), "seconds": min(mine), "baseline_seconds": min(theirs),
               "ratio": min(mine) / min(theirs), "paired_ratio": statistics.median(a / b for a, b in zip(mine, theirs))}
        print(f"{path}: {row['seconds']:.4f} s, baseline {row['baseline_seconds']:.4f} s: x{row['ratio']:.3f} "
              f"(paired x{row['paired_ratio']:.3f})", file=out, flush=True)
        rows.append(row)
    print(f"ours against {baseline}; {stats.device} [{stats.extra['target']}]; best of {repeat}", file=out)
    return rows


def main(argv=None):
    """The rig's command line: bench's render options and its suite of scenes."""
    from raytrace.commands.bench import suite_scenes

    p = argparse.ArgumentParser(prog="python -m benchmarks.baseline", description=__doc__.split("\n")[0])
    p.add_argument("baseline", metavar="DIR", help="the baseline's kernels/ directory, with this checkout's types.h")
    p.add_argument("scene", nargs="*", help="scene files (default: bench's suite)")
    p.add_argument("--repeat", type=int, default=3, help="renders of each kernel, in turns (default 3)")
    for option, default in (("--width", 512), ("--height", 512), ("--spp", 16), ("--light-samples", 16)):
        p.add_argument(option, type=int, default=default, help=f"as bench (default {default})")
    p.add_argument("--device", help="OpenCL device, as render's --device")
    args = p.parse_args(argv)
    if args.repeat < 1:
        raise InputError("command line", "--repeat", args.repeat, "must be at least 1")
    against_baseline(args.scene or suite_scenes(), args.baseline, repeat=args.repeat, width=args.width,
                     height=args.height, spp=args.spp, light_samples=args.light_samples, device=args.device)


if __name__ == "__main__":
    from benchmarks import run_rig
    sys.exit(run_rig("benchmarks.baseline", main))
