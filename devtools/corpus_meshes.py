"""The meshes of the Mitsuba corpus's scenes that need one of their own (issue 58): `python -m devtools.corpus_meshes`
writes them into scenes/mitsuba/meshes.

- `vertex_colours.ply` (binary PLY, 12 x 12 vertices, 242 triangles): a wavy sheet over [-1, 1]^2, z = 0.12 sin(3 x)
  cos(2 y), whose vertices carry float colours r, g, b (Mitsuba's `vertex_color` attribute, read by its
  `mesh_attribute` texture): a hue wheel around the centre, saturated towards the rim, every channel in [0.05,
  0.9]. Floats, because Mitsuba takes a PLY file's colour values as they are (8-bit codes would be 0 to 255).

Nothing is random: the same bytes each run.
"""
import argparse
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "scenes" / "mitsuba" / "meshes"


def vertex_colours(n=12):
    """(vertices (V, 3), colours (V, 3), quads (F, 4)) of the sheet."""
    xs, ys = np.meshgrid(np.linspace(-1.0, 1.0, n), np.linspace(-1.0, 1.0, n))
    x, y = xs.ravel(), ys.ravel()
    vertices = np.stack([x, y, 0.12 * np.sin(3.0 * x) * np.cos(2.0 * y)], 1)
    hue, saturation = np.arctan2(y, x) / (2 * np.pi) + 0.5, np.clip(np.hypot(x, y) / np.sqrt(2), 0.0, 1.0)
    wheel = 0.5 + 0.5 * np.cos(2 * np.pi * (hue[:, None] - np.array([0.0, 1 / 3, 2 / 3])))
    colours = 0.05 + 0.85 * ((1 - saturation[:, None]) * 0.5 + saturation[:, None] * wheel)
    quads = np.array([(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
                      for j in range(n - 1) for i in range(n - 1)])
    return vertices, colours, np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def write_ply(path, vertices, colours, triangles):
    """A binary little-endian PLY of triangles: Mitsuba 3.9.1's reader takes neither quads ("is this a triangle
    mesh?!") nor this file in ASCII (its faces read as trailing tokens)."""
    header = "\n".join(["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}",
                        "property float x", "property float y", "property float z", "property float r",
                        "property float g", "property float b", f"element face {len(triangles)}",
                        "property list uchar int vertex_indices", "end_header"]) + "\n"
    rows = np.hstack([vertices, colours]).astype("<f4").tobytes()
    faces = np.zeros(len(triangles), [("n", "u1"), ("i", "<i4", (3,))])
    faces["n"], faces["i"] = 3, triangles
    Path(path).write_bytes(header.encode() + rows + faces.tobytes())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    write_ply(args.out / "vertex_colours.ply", *vertex_colours())
    print(args.out / "vertex_colours.ply")


if __name__ == "__main__":
    main()
