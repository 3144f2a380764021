"""The meshes of the Mitsuba corpus's scenes that need one of their own (issue 58): `python -m devtools.corpus_meshes`
writes them into scenes/mitsuba/meshes.

- `vertex_colours.ply` (binary PLY, 12 x 12 vertices, 242 triangles): a wavy sheet over [-1, 1]^2, z = 0.12 sin(3 x)
  cos(2 y), whose vertices carry float colours r, g, b (Mitsuba's `vertex_color` attribute, read by its
  `mesh_attribute` texture): a hue wheel around the centre, saturated towards the rim, every channel in [0.05,
  0.9]. Floats, because Mitsuba takes a PLY file's colour values as they are (8-bit codes would be 0 to 255).
- `face_attributes.ply` (binary PLY, 9 x 9 vertices, 128 triangles): a sheet over [-1, 1]^2 folded into a low
  ridge, z = 0.25 (1 - |x|) cos(1.5 y), whose faces carry float colours r, g, b (Mitsuba's `face_color`: one
  colour per triangle, constant over it, the two triangles of each square apart, so that a renderer which
  interpolated them, or gave a square one colour, shows it) and whose vertices carry one value roughness_0
  (Mitsuba's one-value `vertex_roughness`), 0.08 at x = -1 rising to 0.5 at x = 1, for a rough conductor's alpha.
- `spheres.serialized` (Mitsuba's serialized format, version 4, float32, two shapes): shape 0 "sphere", a unit
  UV sphere of 16 x 32 quads (a seam of split vertices at u = 0, the poles split per quad) carrying its exact
  normals (the positions) and uvs; shape 1 "blob", a unit sphere of 24 x 48 quads, r = 1 + 0.1 sin(3 phi)
  sin(2 theta)^2, without normals or a seam (so Mitsuba computes its normals, angle-weighted, with no crease).

Nothing is random: the same bytes each run.
"""
import argparse
import struct
import zlib
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "scenes" / "mitsuba" / "meshes"


def grid(n):
    """(x, y, triangles) of an n x n grid of vertices over [-1, 1]^2, each square two triangles (a, b, c), (a, c, d),
    counter-clockwise seen from +z, one square's two after each other."""
    xs, ys = np.meshgrid(np.linspace(-1.0, 1.0, n), np.linspace(-1.0, 1.0, n))
    quads = np.array([(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
                      for j in range(n - 1) for i in range(n - 1)])
    return xs.ravel(), ys.ravel(), np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], 1).reshape(-1, 3)


def vertex_colours(n=12):
    """(vertices (V, 3), colours (V, 3), triangles (F, 3)) of the sheet."""
    xs, ys = np.meshgrid(np.linspace(-1.0, 1.0, n), np.linspace(-1.0, 1.0, n))
    x, y = xs.ravel(), ys.ravel()
    vertices = np.stack([x, y, 0.12 * np.sin(3.0 * x) * np.cos(2.0 * y)], 1)
    hue, saturation = np.arctan2(y, x) / (2 * np.pi) + 0.5, np.clip(np.hypot(x, y) / np.sqrt(2), 0.0, 1.0)
    wheel = 0.5 + 0.5 * np.cos(2 * np.pi * (hue[:, None] - np.array([0.0, 1 / 3, 2 / 3])))
    colours = 0.05 + 0.85 * ((1 - saturation[:, None]) * 0.5 + saturation[:, None] * wheel)
    quads = np.array([(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
                      for j in range(n - 1) for i in range(n - 1)])
    return vertices, colours, np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def face_attributes(n=9):
    """(vertices (V, 3), roughness (V,), triangles (F, 3), face colours (F, 3)) of the ridge."""
    x, y, triangles = grid(n)
    vertices = np.stack([x, y, 0.25 * (1 - np.abs(x)) * np.cos(1.5 * y)], 1)
    roughness = 0.08 + 0.42 * (x + 1) / 2
    square, half = np.arange(len(triangles)) // 2, np.arange(len(triangles)) % 2
    hue = (square % (n - 1) + 2 * (square // (n - 1))) / (n - 1) / 3 + 0.5 * half  # along the rows and columns
    wheel = 0.5 + 0.5 * np.cos(2 * np.pi * (hue[:, None] - np.array([0.0, 1 / 3, 2 / 3])))
    colours = 0.08 + 0.8 * wheel
    return vertices, roughness, triangles, colours


def write_ply(path, vertices, triangles, vertex=(), face=()):
    """A binary little-endian PLY of triangles with float properties, vertex and face [(name, values)]: Mitsuba
    3.9.1's reader takes neither quads ("is this a triangle mesh?!") nor these files in ASCII (its faces read as
    trailing tokens)."""
    header = "\n".join(["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}",
                        "property float x", "property float y", "property float z",
                        *[f"property float {name}" for name, _ in vertex], f"element face {len(triangles)}",
                        "property list uchar int vertex_indices", *[f"property float {name}" for name, _ in face],
                        "end_header"]) + "\n"
    rows = np.column_stack([vertices, *[values for _, values in vertex]]).astype("<f4").tobytes()
    faces = np.zeros(len(triangles), [("n", "u1"), ("i", "<i4", (3,)), ("p", "<f4", (len(face),))])
    faces["n"], faces["i"] = 3, triangles
    if face:
        faces["p"] = np.column_stack([values for _, values in face])
    Path(path).write_bytes(header.encode() + rows + faces.tobytes())


def serialized_shape(name, vertices, triangles, normals=None, uvs=None, colours=None, version=4, double=False,
                     level=9):
    """One shape of Mitsuba's serialized format (src/shapes/serialized.cpp's documentation): the uncompressed header
    (0x041C, version), then one zlib stream of the flags, the name (version 4), the counts and the arrays."""
    real = "<f8" if double else "<f4"
    flags = ((normals is not None) * 0x0001 | (uvs is not None) * 0x0002 | (colours is not None) * 0x0008 |
             (0x2000 if double else 0x1000))
    payload = struct.pack("<I", flags) + (name.encode() + b"\0" if version == 4 else b"")
    payload += struct.pack("<QQ", len(vertices), len(triangles))
    payload += b"".join(np.asarray(a, real).tobytes() for a in (vertices, normals, uvs, colours) if a is not None)
    payload += np.asarray(triangles, "<u4").tobytes()
    return struct.pack("<HH", 0x041C, version) + zlib.compress(payload, level)


def serialized_file(shapes, version=4):
    """A serialized file of shapes (serialized_shape's bytes): them, then the end-of-file dictionary of their offsets
    (uint64 in version 4, uint32 in version 3) and their count."""
    offsets = np.cumsum([0] + [len(s) for s in shapes[:-1]])
    return b"".join(shapes) + np.asarray(offsets, "<u8" if version == 4 else "<u4").tobytes() + struct.pack(
        "<I", len(shapes))


def uv_sphere(rows, cols, seam=True):
    """(unit positions (V, 3), uvs (V, 2), triangles (F, 3)) of a sphere of rows x cols quads, counter-clockwise seen
    from outside; with `seam`, a column of vertices repeated at u = 1 and a pole vertex per quad (a UV-mapped
    exporter's), else every position once."""
    cols_v = cols + 1 if seam else cols
    u, v = np.meshgrid(np.arange(cols_v) / cols, np.arange(1, rows) / rows)
    phi, theta = 2 * np.pi * u.ravel(), np.pi * v.ravel()
    ring = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)
    poles = cols if seam else 1
    top = np.tile([0.0, 0.0, 1.0], (poles, 1))
    vertices = np.concatenate([top, ring, -top])
    uvs = np.concatenate([np.stack([(np.arange(poles) + 0.5) / cols, np.zeros(poles)], 1),
                          np.stack([u.ravel(), v.ravel()], 1), np.stack([(np.arange(poles) + 0.5) / cols,
                                                                         np.ones(poles)], 1)])

    def at(j, i):  # ring j (1 to rows - 1), column i
        return poles + (j - 1) * cols_v + (i % cols_v if seam else i % cols)
    triangles = []
    for i in range(cols):
        triangles.append((i if seam else 0, at(1, i), at(1, i + 1)))
        for j in range(1, rows - 1):
            triangles += [(at(j, i), at(j + 1, i), at(j + 1, i + 1)), (at(j, i), at(j + 1, i + 1), at(j, i + 1))]
        bottom = poles + (rows - 1) * cols_v + (i if seam else 0)
        triangles.append((at(rows - 1, i), bottom, at(rows - 1, i + 1)))
    return vertices, uvs, np.array(triangles)


def spheres():
    """The two shapes of spheres.serialized, as serialized_shape's bytes."""
    vertices, uvs, triangles = uv_sphere(16, 32)
    sphere = serialized_shape("sphere", vertices, triangles, normals=vertices, uvs=uvs)
    vertices, _, triangles = uv_sphere(24, 48, seam=False)
    phi, theta = np.arctan2(vertices[:, 1], vertices[:, 0]), np.arccos(np.clip(vertices[:, 2], -1, 1))
    blob = vertices * (1 + 0.1 * np.sin(3 * phi) * np.sin(2 * theta) ** 2)[:, None]
    return [sphere, serialized_shape("blob", blob, triangles)]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    vertices, colours, triangles = vertex_colours()
    write_ply(args.out / "vertex_colours.ply", vertices, triangles, vertex=list(zip("rgb", colours.T)))
    vertices, roughness, triangles, colours = face_attributes()
    write_ply(args.out / "face_attributes.ply", vertices, triangles, vertex=[("roughness_0", roughness)],
              face=list(zip("rgb", colours.T)))
    (args.out / "spheres.serialized").write_bytes(serialized_file(spheres()))
    for name in ("vertex_colours.ply", "face_attributes.ply", "spheres.serialized"):
        print(args.out / name)


if __name__ == "__main__":
    main()
