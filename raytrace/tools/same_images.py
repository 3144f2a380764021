"""`python -m raytrace.tools.same_images save|compare DIR`: every shipped scene rendered small, at both lane
widths, under every sample pattern (scene 0) and every texture filter (the textured scenes), saved as
float32 arrays or compared bit for bit with arrays saved before. A change that must not change any image
(a refactoring, a faster kernel that claims identical results) is checked with it: save before, compare
after. Exit status 1 when an image differs."""
import argparse
import sys
from pathlib import Path

import numpy as np

from .. import load_scene, render

SCENES = Path(__file__).resolve().parents[2] / "scenes"
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


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m raytrace.tools.same_images", description=__doc__.split("\n")[0])
    parser.add_argument("mode", choices=["save", "compare"])
    parser.add_argument("dir", type=Path)
    args = parser.parse_args(argv)
    args.dir.mkdir(parents=True, exist_ok=True)
    loaded, different = {}, 0
    for name, path, options in cases():
        scene = loaded.setdefault(path, load_scene(path))
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
