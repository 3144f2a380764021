"""Fixtures for tests/test_serialized.py: small Mitsuba .serialized files (written by devtools/corpus_meshes.py's
writer, versions 3 and 4, float32 and float64, with and without normals, uvs and colours, two shapes each) and the
arrays Mitsuba 3.9.1 reads from each shape (`mi.load_dict({"type": "serialized", ...})`, then `mi.traverse`):
vertex_positions, faces, vertex_normals (the file's, normalised, or Mitsuba's angle-weighted ones) and
vertex_texcoords, in tests/data/serialized/NAME.npz, keys "SHAPE_positions" and so on. Run with Mitsuba's
Python (variant scalar_rgb):

    /tmp/mts/bin/python -m devtools.peers.mitsuba_serialized

Nothing is random: the same bytes each run.
"""
from pathlib import Path

import numpy as np

from devtools.corpus_meshes import serialized_file, serialized_shape, uv_sphere

OUT = Path(__file__).resolve().parents[2] / "tests" / "data" / "serialized"


def shapes():
    """{file name: (version, [(name, vertices, triangles, normals, uvs, colours, double)])}."""
    sphere, uvs, triangles = uv_sphere(4, 6)
    squashed = sphere * [1.0, 0.7, 0.4] + [0.25, -0.5, 1.0]
    tilted = squashed @ np.array([[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    closed, _, shut = uv_sphere(5, 7, seam=False)
    tetra = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) * 1.0 / 3
    faces = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
    return {
        "v4_single": (4, [("ellipsoid", squashed, triangles, sphere, uvs, None, False),
                          ("closed", closed, shut, None, None, 0.5 + 0.5 * closed, False)]),
        "v4_double": (4, [("tetrahedron", tetra, faces, None, [[0, 0], [1, 0], [0, 1], [1, 1]], None, True),
                          ("tilted", tilted, triangles, sphere * 2.0, None, None, True)]),
        "v3_single": (3, [("", closed, shut, closed, None, None, False),
                          ("", squashed, triangles, None, uvs, 0.5 + 0.5 * sphere, False)]),
        "v3_double": (3, [("", tilted, triangles, sphere, uvs, 0.5 - 0.5 * sphere, True),
                          ("", tetra, faces, None, None, None, True)]),
    }


def main():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    OUT.mkdir(parents=True, exist_ok=True)
    for name, (version, parts) in shapes().items():
        path = OUT / f"{name}.serialized"
        path.write_bytes(serialized_file([serialized_shape(shape, v, t, n, uv, c, version, double)
                                          for shape, v, t, n, uv, c, double in parts], version))
        arrays = {}
        for k, (_, _, _, _, uv, _, _) in enumerate(parts):
            params = mi.traverse(mi.load_dict({"type": "serialized", "filename": str(path), "shape_index": k}))
            arrays[f"{k}_positions"] = np.array(params["vertex_positions"], np.float32).reshape(-1, 3)
            arrays[f"{k}_faces"] = np.array(params["faces"], np.uint32).reshape(-1, 3)
            arrays[f"{k}_normals"] = np.array(params["vertex_normals"], np.float32).reshape(-1, 3)
            if uv is not None:
                arrays[f"{k}_uvs"] = np.array(params["vertex_texcoords"], np.float32).reshape(-1, 2)
        np.savez_compressed(OUT / f"{name}.npz", **arrays)
        print(path, path.stat().st_size, "bytes;", ", ".join(f"{k} {a.shape}" for k, a in arrays.items()))


if __name__ == "__main__":
    main()
