"""What denoising buys: `python -m benchmarks.denoise --out DIR [SCENE ...] [--spp 4,16,64]
[--reference-spp 4096] [--width W --height H] [--record PATH]`.

For each scene (default: scenes/cornell_box.toml and scenes/materials.toml, the path model's diffuse box and its
mirror, gold and glass), a reference as converge renders its own (sobol pixels and lights, the seed offset by
converge.REFERENCE_SEED_OFFSET, so that its samples are independent of the ones it judges), then a render at
each sample count with the albedo and normal AOVs, measured against the reference three ways: noisy (the
render itself), denoised (Intel Open Image Denoise's RT filter with the noisy AOVs, cleanAux off: what
--denoise does) and denoised with the AOVs prefiltered (raytrace/denoise.py's `prefilter`). RMSE over all
pixels and channels of the linear images, and relative RMSE (over the reference's mean): the same measure as
converge's; and the RMSE of the images clamped to [0, 1] (converge --clamp's: what a display shows), since the
linear one of the Cornell box is the light's edge pixels' (radiance 18, against the walls' 0.1-0.7), which a
denoiser moves by more than the noise it removes elsewhere. The reference's own estimated RMSE is printed
beside them: no image can be shown closer than that.

Written to DIR: denoise.json (the rows and the machine), SCENE-reference.exr (kept: a rerun with the same
reference samples and seed reads it instead of rendering it again), and SCENE-SPP.png: noisy, denoised and
the reference side by side, in the course's 8-bit encoding, to look at. With --record PATH, also the
measurement record the performance page shows (benchmarks/record.py's format)."""
import argparse
import datetime
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from raytrace.commands.bench import checked_scenes, machine
from raytrace.commands.converge import REFERENCE_SEED_OFFSET, clamped_rmse
from raytrace.denoise import AUX as DENOISE_AOVS, denoise, require
from raytrace.errors import InputError
from raytrace.image_file import write_image
from raytrace.numerics import rmse
from raytrace.render import render

from benchmarks.record import commit, machine_kind

SCENES = ["scenes/cornell_box.toml", "scenes/materials.toml"]
WAYS = ("noisy", "denoised", "prefiltered")
AUX = [name for name, _ in DENOISE_AOVS.values()]  # render()'s aov: the short names
GAP = 4  # black pixels between the panels of a PNG


def read_reference(path, spp, seed, shape):
    """The reference a previous run left at `path`, if it has these samples, seed and size; else None."""
    if not path.exists():
        return None
    buf = oiio.ImageBuf(str(path))
    spec = buf.spec()
    if (spec.getattribute("raytrace:spp"), spec.getattribute("raytrace:seed")) != (spp, seed) or \
            (spec.height, spec.width) != shape:
        return None
    return buf.get_pixels(oiio.FLOAT)[..., :3], spec.getattribute("raytrace:estimated_rmse")


def reference(scene, path, spp, seed, common):
    """(image, its estimated RMSE): rendered as converge renders its own, or read back from `path`."""
    shape = (common.get("height") or scene.height, common.get("width") or scene.width)
    kept = read_reference(path, spp, seed + REFERENCE_SEED_OFFSET, shape)
    if kept is not None:
        return kept
    image, stats = render(scene, spp=spp, sampler="sobol", light_sampler="sobol", seed=seed + REFERENCE_SEED_OFFSET,
                          progress=False, **common)
    image.write(path)
    return np.asarray(image), stats.estimated_rmse


def side_by_side(path, *images):
    """The images left to right, GAP black columns apart, as a PNG (write_image's 8-bit encoding)."""
    h = images[0].shape[0]
    gap = np.zeros((h, GAP, 3), np.float32)
    row = [part for image in images for part in (np.asarray(image, np.float32), gap)][:-1]
    write_image(path, np.concatenate(row, axis=1))


def measure(scene_paths, spps, reference_spp, out, seed=0, width=None, height=None, log=sys.stdout):
    """The rows: per scene and sample count, each way's RMSE and relative RMSE against the reference."""
    common = {k: v for k, v in (("width", width), ("height", height)) if v is not None}
    rows, stats = [], None
    for path, scene in checked_scenes(scene_paths, common):
        name = Path(path).stem
        ref, ref_error = reference(scene, out / f"{name}-reference.exr", reference_spp, seed, common)
        mean = float(np.mean(ref, dtype=np.float64))
        print(f"{name}: reference {reference_spp} spp, mean {mean:.4g}, its estimated RMSE {ref_error:.3g}",
              file=log, flush=True)
        for spp in spps:
            image, stats = render(scene, spp=spp, sampler="sobol", light_sampler="sobol", seed=seed, aov=AUX,
                                  progress=False, **common)
            start = time.perf_counter()
            denoised = denoise(image)
            seconds = time.perf_counter() - start
            prefiltered = denoise(image, prefilter=True)
            images = {"noisy": np.asarray(image), "denoised": np.asarray(denoised),
                      "prefiltered": np.asarray(prefiltered)}
            row = {"scene": str(path), "spp": spp, "width": stats.width, "height": stats.height,
                   "reference_spp": reference_spp, "reference_mean": mean, "reference_estimated_rmse": ref_error,
                   "render_seconds": stats.wall_seconds, "denoise_seconds": seconds}
            for way, im in images.items():
                row[f"{way}_rmse"] = rmse(im, ref)
                row[f"{way}_relative_rmse"] = row[f"{way}_rmse"] / mean
                row[f"{way}_clamped_rmse"] = clamped_rmse(im, ref)
            rows.append(row)
            side_by_side(out / f"{name}-{spp}.png", image, denoised, ref)
            print(f"{name} {spp:>3} spp: " + "; ".join(
                f"{way} RMSE {row[f'{way}_rmse']:.4g} ({row[f'{way}_relative_rmse']:.2%}), clamped "
                f"{row[f'{way}_clamped_rmse']:.4g}" for way in WAYS) + f"; denoised in {seconds:.2f} s",
                file=log, flush=True)
    return rows, machine(stats.device, stats.extra["target"])


def figures(rows):
    """The record's figures: per scene and sample count, each way's RMSE, linear and clamped."""
    return [{"what": f"{Path(r['scene']).stem} {what} at {r['spp']} spp, {way}",
             "value": float(f"{r[f'{way}_{key}']:.4g}"), "unit": "RMSE"}
            for r in rows for key, what in (("rmse", "RMSE"), ("clamped_rmse", "RMSE clamped to [0, 1]"))
            for way in WAYS]


def spp_list(text):
    try:
        spps = [int(s) for s in text.split(",")]
    except ValueError:
        spps = []
    if not spps or min(spps) < 1:
        raise InputError("command line", "--spp", text, "must be positive sample counts, comma-separated")
    return spps


def recorded_command(args):
    """The command as the record shows it: every setting spelt out, the output directory as DIR."""
    scenes = [] if args.scene == SCENES else args.scene
    size = [f"--{k} {v}" for k, v in (("width", args.width), ("height", args.height)) if v is not None]
    return " ".join(["python -m benchmarks.denoise", *map(shlex.quote, scenes), "--spp",
                     ",".join(map(str, args.spp)), "--reference-spp", str(args.reference_spp), *size, "--out DIR"])


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m benchmarks.denoise", description=__doc__.split("\n")[0])
    p.add_argument("scene", nargs="*", default=SCENES, help="scene files (default: cornell_box and materials)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--spp", type=spp_list, default=[4, 16, 64], help="sample counts (default 4,16,64)")
    p.add_argument("--reference-spp", type=int, default=4096, help="the reference's samples (default 4096)")
    p.add_argument("--width", type=int, help="image width (default: the scene's)")
    p.add_argument("--height", type=int, help="image height (default: the scene's)")
    p.add_argument("--record", type=Path, help="also write the measurement record here")
    args = p.parse_args(argv)
    require("benchmarks.denoise")
    if not args.out.is_dir():
        raise InputError("command line", "--out", str(args.out), "is no directory")
    rows, info = measure(args.scene, args.spp, args.reference_spp, args.out, width=args.width, height=args.height)
    command = recorded_command(args)
    (args.out / "denoise.json").write_text(json.dumps({"machine": info, "command": command, "rows": rows},
                                                      indent=1) + "\n")
    if args.record:
        record = {"machine": machine_kind(info), "date": datetime.date.today().isoformat(), "commit": commit(),
                  "command": command, "figures": figures(rows)}
        args.record.write_text(json.dumps(record, indent=1) + "\n")
        print(args.record)


if __name__ == "__main__":
    from benchmarks import run_rig
    sys.exit(run_rig("benchmarks.denoise", main))
