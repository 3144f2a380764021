"""The benchmark: rays per second of the renderer's kernel variants, each against a baseline (the scalar
kernel, LANES=1, on the same device) run in the same process, so that machines and loads cancel out."""
import sys

from .kernel import Features
from .render import render
from .scene import load_scene


def _best(scene, repeat, **kwargs):
    render(scene, **kwargs, progress=False)  # build and first launch (code generation): not timed
    runs = [render(scene, **kwargs, progress=False)[1] for _ in range(repeat)]
    return min(runs, key=lambda s: s.render_seconds)


def benchmark(scene_path, repeat=3, out=sys.stdout, **kwargs):
    scene = load_scene(scene_path)
    lanes = 8
    variants = {
        "baseline: scalar (LANES=1), specialised": dict(features=Features.of(scene, 1)),
        f"LANES={lanes}, specialised": dict(features=Features.of(scene, lanes)),
        f"LANES={lanes}, all features": dict(features=Features(lanes)),
    }
    results, base = [], None
    for name, extra in variants.items():
        stats = _best(scene, repeat, **kwargs, **extra)
        base = base or stats.mrays_per_s
        results.append({"variant": name, "mrays_per_s": stats.mrays_per_s, "ratio": stats.mrays_per_s / base,
                        "render_seconds": stats.render_seconds, "rays": stats.rays,
                        "build_options": stats.build_options})
        print(f"{name:42s} {stats.mrays_per_s:8.2f} Mrays/s  x{stats.mrays_per_s / base:5.2f}  "
              f"({stats.rays} rays in {stats.render_seconds:.3f} s)", file=out, flush=True)
    print(f"scene {scene_path}, {stats.width}x{stats.height}, {stats.spp} spp x {stats.light_samples} "
          f"light samples, {stats.device}, best of {repeat}", file=out)
    return {"scene": str(scene_path), "width": stats.width, "height": stats.height, "spp": stats.spp,
            "light_samples": stats.light_samples, "device": stats.device, "results": results}
