"""A session with raytrace's Python API: load a scene, look at and edit its values by name, render, save.
Run from the checkout's root: python docs/example.py OUT_DIR"""
import sys
from pathlib import Path

import raytrace


def main(out):
    out = Path(out)
    scene = raytrace.load_file("scenes/cornell.toml")
    params = raytrace.parameters(scene)
    print(f"{len(params)} values, e.g. camera.fov = {params['camera.fov']}")

    image, stats = raytrace.render(scene, width=128, height=128, spp=16, light_samples=4)
    image.write(out / "before.png")
    print(f"before: mean {image.mean():.4f}, {stats.spp} spp in {stats.passes} pass(es) on {stats.device}")

    params["lights[0].colour"] = [1.0, 0.6, 0.3]    # a warmer light
    params["materials.yellow.shininess"] = 200.0    # a glossier ellipsoid
    print("changed:", sorted(params.update()))

    try:
        params["lights[0].colour"] = [float("nan"), -1.0, 1.0]
        params.update()
    except raytrace.InputError as error:             # refused: the scene stays as it was, the edit staged
        print("refused:", error)
    params["lights[0].colour"] = [1.0, 0.6, 0.3]     # stage a good value instead
    params.update()

    image, stats = raytrace.render(scene, width=128, height=128, spp=16, light_samples=4)
    image.write(out / "after.exr")                    # linear floats, the variance channels, the metadata
    print(f"after: mean {image.mean():.4f}, estimated relative RMSE {stats.estimated_relative_rmse:.2%}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
