#!/usr/bin/env python3
"""Mitsuba 3's `path` integrator on the path model's scenes, translated one to one: the measuring peer of
docs/global-illumination.md and of `converge --peer` (a developer rig, not a dependency of raytrace).

Install (a venv of its own; Mitsuba's llvm variants need Debian's libLLVM 19):
  apt-get install -y libllvm19
  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba numpy
Run from the repository's root, e.g. a reference of 16 renders of 528 samples:
  /tmp/mts/bin/python devtools/peers/mitsuba_path.py --scene materials --spp 528 --chunks 16 --out ref.exr

--scene cornell_box is `mi.cornell_box()` from Mitsuba's own package (scenes/cornell_box.toml is its
translation) with a box pixel filter in place of its Gaussian. --scene materials is scenes/materials.toml:
spheres; the floor a `rectangle` scaled 4 x 4 with a `bitmap` of grid.png (bilinear,
repeat, to_uv scaled 4 and flipped in v: Mitsuba's v runs down the image, ours up); the light a `rectangle` turned to face -z with an `area` emitter and a black BSDF;
the sky an `envmap` of sky.exr whose to_world has the columns (x, y, z) = (1, 0, 0), (0, 0, 1), (0, -1, 0):
the local axes raytrace's up = +z and forward = -y give; a perspective camera with fov 40 on the y axis,
256 x 256, a box pixel filter, max_depth 8.

Prints one JSON line: median_s (the median of --repeats renders, after a first one that compiles), spp (the
samples per pixel of the average written to --out)."""
import argparse
import json
import os
import statistics
import time

import numpy as np
import mitsuba as mi

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
TEXTURES = os.path.join(ROOT, "assets", "textures")


def cornell_box(sampler, spp, max_depth):
    scene = mi.cornell_box()
    scene["integrator"]["max_depth"] = max_depth
    scene["sensor"]["film"]["rfilter"] = {"type": "box"}
    scene["sensor"]["sampler"] = {"type": sampler, "sample_count": spp}
    return scene


def materials(sampler, spp, max_depth):
    T = mi.ScalarTransform4f
    sphere = lambda c, bsdf: {"type": "sphere", "center": c, "radius": 0.5, "bsdf": bsdf}  # noqa: E731
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {"type": "perspective", "fov": 40.0, "fov_axis": "y",
                   "to_world": T().look_at(origin=[0, -4, 1.6], target=[0, 0, 0.45], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": 256, "height": 256, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": sampler, "sample_count": spp}},
        "floor": {"type": "rectangle", "to_world": T().scale([4, 4, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": {
                      "type": "bitmap", "filename": os.path.join(TEXTURES, "grid.png"), "filter_type": "bilinear",
                      "wrap_mode": "repeat", "to_uv": T().scale([4, -4, 1])}}},
        "light": {"type": "rectangle", "to_world": T().translate([0.5, -0.5, 3.0]) @ T().rotate([1, 0, 0], 180)
                  @ T().scale([0.5, 0.5, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}},
                  "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [8, 8, 8]}}},
        "sky": {"type": "envmap", "filename": os.path.join(TEXTURES, "sky.exr"), "scale": 0.5,
                "to_world": T(np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float))},
        "mirror": sphere([-1.1, 0, 0.5], {"type": "conductor", "material": "none"}),
        "gold": sphere([0, 0.3, 0.5], {"type": "roughconductor", "distribution": "ggx", "alpha": 0.2,
                                       "eta": {"type": "rgb", "value": [0.143, 0.374, 1.442]},
                                       "k": {"type": "rgb", "value": [3.983, 2.385, 1.603]}}),
        "glass": sphere([1.1, -0.2, 0.5], {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", choices=("cornell_box", "materials"), required=True)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sampler", default="multijitter")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--out", required=True)
    ap.add_argument("--chunks", type=int, default=1, help="average this many renders of --spp (seeds 0..)")
    ap.add_argument("--repeats", type=int, default=1)
    a = ap.parse_args()
    mi.set_variant(a.variant)
    scene = mi.load_dict({"cornell_box": cornell_box, "materials": materials}[a.scene](a.sampler, a.spp, a.max_depth))
    mi.render(scene, spp=a.spp, seed=10**6)  # compiles
    times, total = [], None
    for r in range(max(a.repeats, a.chunks)):
        t = time.perf_counter()
        img = np.array(mi.render(scene, spp=a.spp, seed=r))
        times.append(time.perf_counter() - t)
        if r < a.chunks:
            total = img if total is None else total + img
    mi.Bitmap((total / a.chunks).astype(np.float32)).write(a.out)
    spp = scene.sensors()[0].sampler().sample_count()
    print(json.dumps({"median_s": statistics.median(times), "spp": spp * a.chunks, "variant": a.variant}))


if __name__ == "__main__":
    main()
