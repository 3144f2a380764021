"""Our render of a scene against another renderer's image of it:
`python -m benchmarks.against_reference SCENE REFERENCE.exr --spp N --light-samples M --out DIR`.

The comparison issue 19 asks for, with Mitsuba 3's `direct` integrator as the other renderer (a script of
its own, not part of this project, renders the reference): the RMSE of ours against the reference on
[0, 1]-clamped linear RGB (what an 8-bit image of either shows) and unclamped, per channel mean and the
largest difference, ours.exr, and side.png: ours, the reference and 10 |ours - reference|, side by side, in
the course's 8-bit encoding. Both images must be of the same size and orientation (row 0 at the top)."""
import argparse
import json
from pathlib import Path

import numpy as np

from raytrace import load_file
from raytrace.numerics import rmse
from raytrace.render import render_progressive
from raytrace.image_file import write_image_file
from raytrace.commands.converge import clamped_rmse, read_reference

DIFFERENCE_GAIN = 10.0


def compare(ours, reference):
    """The figures of `ours` against `reference` (H x W x 3, linear)."""
    return {"rmse_clamped": clamped_rmse(ours, reference), "rmse": rmse(ours, reference),
            "mean_ours": ours.reshape(-1, 3).mean(0).tolist(), "mean_reference": reference.reshape(-1, 3).mean(0).tolist(),
            "max_abs_clamped": float(np.abs(np.clip(ours, 0.0, 1.0) - np.clip(reference, 0.0, 1.0)).max())}


def side_by_side(ours, reference):
    """ours | reference | DIFFERENCE_GAIN |ours - reference| (of the clamped images), H x 3W x 3."""
    clamped = [np.clip(a, 0.0, 1.0) for a in (ours, reference)]
    return np.concatenate([*clamped, DIFFERENCE_GAIN * np.abs(clamped[0] - clamped[1])], axis=1)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m benchmarks.against_reference",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("scene")
    parser.add_argument("reference", help="the other renderer's image (EXR, linear), the scene's size")
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--light-samples", type=int, default=16)
    parser.add_argument("--sampler", default="sobol")
    parser.add_argument("--texture-filter", default="trilinear",
                        help="bilinear matches a peer that looks textures up bilinearly at every sample")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    scene = load_file(args.scene)
    reference, _ = read_reference(args.reference, scene.width, scene.height)
    ours, _, stats = render_progressive(scene, spp=args.spp, light_samples=args.light_samples, sampler=args.sampler,
                                        light_sampler=args.sampler, texture_filter=args.texture_filter)
    args.out.mkdir(parents=True, exist_ok=True)
    write_image_file(args.out / "ours.exr", ours)
    write_image_file(args.out / "side.png", side_by_side(ours, reference))
    figures = {"scene": args.scene, "reference": args.reference, "spp": stats.spp,
               "light_samples": stats.light_samples, "sampler": args.sampler,
               "texture_filter": args.texture_filter,
               "our_estimated_rmse": stats.estimated_rmse, **compare(ours, reference)}
    (args.out / "against_reference.json").write_text(json.dumps(figures, indent=1) + "\n")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
