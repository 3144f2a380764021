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

--scene cornell_path and --scene mesh_path translate those scene files (the shapes of the path model's
Lambertian scenes: rectangles, inline and PLY meshes, ellipsoids, rectangular lights) by toml_scene: every
BSDF `twosided` (ours reflect on both sides), a light without a material black, an ellipsoid (Mitsuba's
sphere takes no non-uniform scale) a mesh of --ellipsoid-quads x twice as many quads with its exact normals at
the vertices, the camera a perspective one with the vertical fov; --width and --height override the scene's.
The default, 64 (16,384 triangles), keeps the facets within 6e-4 of the axes' length of the surface (0.03
pixel at 256 x 256 on cornell_path): finer meshes cost Mitsuba time without changing the image beyond the
noise (cornell_path, 64 spp: 2.07 s with 256, 1.33 s with 32).

--isa avx2 runs Mitsuba as an AVX2 CPU would, on an AVX-512 one (mitsuba_isa.py says how); raytrace's twin is
RAYTRACE_TARGET=x86-64-v3.

Prints one JSON line: median_s (the median of --repeats renders, after a first one that compiles), spp (the
samples per pixel of the average written to --out), variant, and llvm_target (Dr.Jit's target CPU)."""
import argparse
import json
import os
import statistics
import time

import numpy as np
import mitsuba as mi

import mitsuba_isa

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


def _write_ply(path, vertices, faces, normals=None):
    """A binary little-endian PLY of float32 vertices (and normals) and int32 triangles."""
    v = np.asarray(vertices, np.float32)
    columns = [v] if normals is None else [v, np.asarray(normals, np.float32)]
    names = "xyz" if normals is None else ["x", "y", "z", "nx", "ny", "nz"]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(v)}",
              *[f"property float {n}" for n in names], f"element face {len(faces)}",
              "property list uchar int vertex_indices", "end_header"]
    f = np.asarray(faces, np.int32)
    rows = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rows["n"], rows["i"] = 3, f
    with open(path, "wb") as out:
        out.write(("\n".join(header) + "\n").encode())
        out.write(np.hstack(columns).astype("<f4").tobytes())
        out.write(rows.tobytes())


def _ellipsoid(center, axes, n_theta=256, n_phi=512):
    """(vertices, faces, normals) of the ellipsoid center + A u, u on the unit sphere, A's columns the axes."""
    a = np.asarray(axes, float).T
    theta = np.linspace(0, np.pi, n_theta + 1)[:, None]
    phi = np.linspace(0, 2 * np.pi, n_phi + 1)[None, :]
    u = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta) + 0 * phi], -1)
    u = u.reshape(-1, 3)
    normals = u @ np.linalg.inv(a)  # A^-T u, as rows
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    k = lambda i, j: i * (n_phi + 1) + j  # noqa: E731
    i, j = np.meshgrid(np.arange(n_theta), np.arange(n_phi), indexing="ij")
    quads = np.stack([k(i, j), k(i + 1, j), k(i + 1, j + 1), k(i, j + 1)], -1).reshape(-1, 4)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return np.asarray(center) + u @ a.T, faces, normals


def _rectangle_to_world(shape):
    """The rectangle [-1, 1]^2 x {0} onto the shape: x along its tangent, z along its normal."""
    n, t = np.asarray(shape["normal"], float), np.asarray(shape["tangent"], float)
    n, t = n / np.linalg.norm(n), t / np.linalg.norm(t)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = t * shape["size"][0] / 2, np.cross(n, t) * shape["size"][1] / 2, n
    m[:3, 3] = shape["center"]
    return mi.ScalarTransform4f(m)


def _mesh_to_world(shape):
    T = mi.ScalarTransform4f
    scale = shape.get("scale", 1.0)
    scale = [scale] * 3 if np.isscalar(scale) else scale
    rotate = shape.get("rotate", {"axis": [1, 0, 0], "degrees": 0.0})
    return T().translate(shape.get("translate", [0, 0, 0])) @ T().rotate(rotate["axis"], rotate["degrees"]) \
        @ T().scale(scale)


def toml_scene(path, sampler, spp, max_depth, width=None, height=None, ellipsoid_quads=64):
    """The path model's Lambertian scene file `path` as a Mitsuba scene dict (the module's docstring)."""
    import tempfile
    import tomllib
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    folder, temp = os.path.dirname(os.path.abspath(path)), tempfile.mkdtemp()
    cam, image = scene["camera"], scene["image"]
    bsdf = lambda colour: {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {  # noqa: E731
        "type": "rgb", "value": list(colour)}}}
    materials = {name: bsdf(m["colour"]) for name, m in scene["materials"].items()}
    out = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth},
           "sensor": {"type": "perspective", "fov": cam["fov"], "fov_axis": "y",
                      "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"],
                                                                 up=cam["up"]),
                      "film": {"type": "hdrfilm", "width": width or image["width"],
                               "height": height or image["height"], "rfilter": {"type": "box"},
                               "pixel_format": "rgb"},
                      "sampler": {"type": sampler, "sample_count": spp}}}
    for k, light in enumerate(scene.get("lights", [])):
        radiance = light["radiance"]
        radiance = [radiance] * 3 if np.isscalar(radiance) else radiance
        out[f"light{k}"] = {"type": "rectangle", "to_world": _rectangle_to_world(light),
                            "bsdf": materials[light["material"]] if "material" in light else bsdf([0, 0, 0]),
                            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": list(radiance)}}}
    for k, shape in enumerate(scene["shapes"]):
        material = materials[shape["material"]]
        if shape["type"] == "rectangle":
            out[f"shape{k}"] = {"type": "rectangle", "to_world": _rectangle_to_world(shape), "bsdf": material}
        elif shape["type"] == "ellipsoid":
            ply = os.path.join(temp, f"shape{k}.ply")
            _write_ply(ply, *_ellipsoid(shape["center"], shape["axes"], ellipsoid_quads, 2 * ellipsoid_quads))
            out[f"shape{k}"] = {"type": "ply", "filename": ply, "bsdf": material}
        elif "file" in shape:
            out[f"shape{k}"] = {"type": "ply", "filename": os.path.join(folder, shape["file"]), "bsdf": material,
                                "to_world": _mesh_to_world(shape), "face_normals": not shape.get("smooth", False)}
        else:
            ply = os.path.join(temp, f"shape{k}.ply")
            _write_ply(ply, shape["vertices"], shape["faces"])
            out[f"shape{k}"] = {"type": "ply", "filename": ply, "bsdf": material, "face_normals": True,
                                "to_world": _mesh_to_world(shape)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", choices=("cornell_box", "materials", "cornell_path", "mesh_path"), required=True)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sampler", default="multijitter")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--out", required=True)
    ap.add_argument("--chunks", type=int, default=1, help="average this many renders of --spp (seeds 0..)")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--width", type=int, help="the toml scenes': image width (default: the scene's)")
    ap.add_argument("--height", type=int, help="the toml scenes': image height (default: the scene's)")
    ap.add_argument("--ellipsoid-quads", type=int, default=64, help="an ellipsoid's mesh: N x 2N quads")
    ap.add_argument("--isa", choices=("native", *mitsuba_isa.LEVELS), default="native",
                    help="avx2: Dr.Jit and Embree as on an AVX2 CPU (llvm variants)")
    a = ap.parse_args()
    mitsuba_isa.select(ap, a.isa, a.variant)
    if a.scene in ("cornell_box", "materials"):
        scene = {"cornell_box": cornell_box, "materials": materials}[a.scene](a.sampler, a.spp, a.max_depth)
    else:
        scene = toml_scene(os.path.join(ROOT, "scenes", a.scene + ".toml"), a.sampler, a.spp, a.max_depth,
                           a.width, a.height, a.ellipsoid_quads)
    scene = mi.load_dict(scene)
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
    print(json.dumps({"median_s": statistics.median(times), "spp": spp * a.chunks, "variant": a.variant,
                      "llvm_target": mitsuba_isa.llvm_target() if a.variant.startswith("llvm_") else None}))


if __name__ == "__main__":
    main()
