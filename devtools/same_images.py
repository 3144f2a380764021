"""`python -m devtools.same_images save|compare DIR`: every shipped scene rendered small, at both lane
widths, under every sample pattern (scene 0) and every texture filter (the textured scenes), saved as
float32 arrays or compared bit for bit with arrays saved before. A change that must not change any image
(a refactoring, a faster kernel that claims identical results) is checked with it: save before, compare
after. Exit status 1 when an image differs.

`python -m devtools.same_images devices DIR --device SPEC`: scene 0 rendered on PoCL's CPU device and
on another device (a GPU), compared within the bound the tests argue rather than bit for bit (devices round
differently: FMA contraction, their own division and square root); both arrays and the figures
(devices.json) are left in DIR. Exit status 1 when the images differ by more than that bound. With
`--cpu-image FILE`, PoCL's render is that array, made on another machine (DIR/cpu.npy of a devices run there,
e.g. with `--device cpu`), for a GPU machine without PoCL."""
import argparse
import json
import sys
from pathlib import Path

import numpy as np

from raytrace import load_file, render
from raytrace.numerics import rmse

SCENES = Path(__file__).resolve().parents[1] / "scenes"
SIZE = dict(width=48, height=40, spp=4, light_samples=4, progress=False)
PATTERNS = ("grid", "rotated-grid-cw", "rotated-grid-ccw", "random", "jittered", "halton", "sobol")
FILTERS = ("nearest", "bilinear", "trilinear", "anisotropic")
TEXTURED = ("textured_cornell", "textured_shapes", "normal_wall")


def cases(scenes=SCENES):
    """(name, scene file, render options) of every image."""
    for path in sorted(scenes.glob("*.toml")):
        for lanes in (1, 8):
            yield f"{path.stem}-lanes{lanes}", path, dict(lanes=lanes)
    for pattern in PATTERNS:
        yield f"cornell-{pattern}", scenes / "cornell.toml", dict(sampler=pattern, light_sampler=pattern, seed=7)
    for name in TEXTURED:
        for texture_filter in FILTERS:
            yield f"{name}-{texture_filter}", scenes / f"{name}.toml", dict(texture_filter=texture_filter)


# tests/test_render.py's `small` render of scene 0, whose error against the float64 reference renderer that
# test bounds: at most 1% of the pixels beyond 1e-4, an RMSE of at most 3.1e-3, no pixel beyond two flipped
# (pixel sample, light sample) pairs of 2/64 each. Its argument asks only that a render round in float32
# (some tens of roundings per term), so it holds for each device's render; two such renders are then within
# twice each bound of each other (the triangle inequality: pixel by pixel, and for the RMSE, a norm).
DEVICE_SIZE = dict(width=48, height=48, spp=4, light_samples=16, progress=False)
FLIP = 2 / (DEVICE_SIZE["spp"] * DEVICE_SIZE["light_samples"])  # k L (n.l + 1) / (spp N): one flipped pair
DEVICE_BOUNDS = {"share_over_1e-4": 2 * 0.01, "rmse": 2 * 3.1e-3, "max": 2 * (2 * FLIP + 1e-4)}


def compare_devices(directory, device, lanes=None, cpu_image=None):
    """Scene 0 on PoCL's CPU device (or the array saved in `cpu_image`) and on `device` (at `lanes`, default
    the device's own), saved as cpu.npy and device.npy in `directory`; the figures, with `passed` against
    DEVICE_BOUNDS."""
    scene = load_file(SCENES / "cornell.toml")
    if cpu_image is None:
        cpu, cpu_stats = render(scene, **DEVICE_SIZE, device="cpu")
        cpu_side = {"cpu": cpu_stats.device, "cpu_build_options": cpu_stats.build_options}
    else:
        cpu = np.load(cpu_image)
        cpu_side = {"cpu": f"{cpu_image} (rendered elsewhere)", "cpu_build_options": ["saved"]}
    other, other_stats = render(scene, **DEVICE_SIZE, device=device, lanes=lanes)
    if cpu.shape != other.shape:
        raise SystemExit(f"same_images: {cpu_image}: shape {cpu.shape}, not this render's {other.shape}")
    np.save(directory / "cpu.npy", cpu)
    np.save(directory / "device.npy", other)
    err = np.abs(other.astype(np.float64) - cpu).max(axis=-1)
    figures = {"share_over_1e-4": float(np.mean(err > 1e-4)), "rmse": rmse(other, cpu), "max": float(err.max())}
    finite = bool(np.all(np.isfinite(other)))
    return {**cpu_side, "device": other_stats.device, "device_build_options": other_stats.build_options,
            "render": {k: v for k, v in DEVICE_SIZE.items() if k != "progress"}, "finite": finite,
            "figures": figures, "bounds": DEVICE_BOUNDS,
            "passed": finite and all(figures[k] <= bound for k, bound in DEVICE_BOUNDS.items())}


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m devtools.same_images", description=__doc__.split("\n")[0])
    parser.add_argument("mode", choices=["save", "compare", "devices"])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--device", help="devices: the device to compare with PoCL's CPU (render's --device)")
    parser.add_argument("--lanes", type=int, help="devices: that device's lane width (default: its own)")
    parser.add_argument("--cpu-image", type=Path, help="devices: PoCL's render saved before (a devices run's cpu.npy)")
    args = parser.parse_args(argv)
    args.dir.mkdir(parents=True, exist_ok=True)
    if args.mode == "devices":
        if not args.device:
            parser.error("devices needs --device")
        result = compare_devices(args.dir, args.device, args.lanes, args.cpu_image)
        (args.dir / "devices.json").write_text(json.dumps(result, indent=1) + "\n")
        figures, bounds = result["figures"], result["bounds"]
        print(f"{result['device']} ({result['device_build_options'][0]}) against {result['cpu']} "
              f"({result['cpu_build_options'][0]}), scene 0 at 48 x 48, 4 spp x 16 light samples:")
        for key, bound in bounds.items():
            print(f"  {key}: {figures[key]:.3g} (bound {bound:.3g}){'' if figures[key] <= bound else '  EXCEEDED'}")
        print("  within the bound" if result["passed"] else
              "  DIFFERENT: beyond the bound" + ("" if result["finite"] else " (non-finite values)"))
        return 0 if result["passed"] else 1
    loaded, different = {}, 0
    for name, path, options in cases():
        scene = loaded.setdefault(path, load_file(path))
        image, _ = render(scene, **SIZE, **options)
        saved = args.dir / f"{name}.npy"
        if args.mode == "save":
            np.save(saved, image)
            print(f"{name}: saved")
            continue
        same = np.array_equal(np.load(saved).view(np.uint32), image.view(np.uint32))
        different += not same
        print(f"{name}: {'identical' if same else 'DIFFERENT'}")
    if args.mode == "compare":
        print(f"{different} of {len(list(cases()))} images differ")
    return 1 if different else 0


if __name__ == "__main__":
    sys.exit(main())
