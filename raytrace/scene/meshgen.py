"""Procedural triangle meshes (raytrace.meshes.Mesh) of a requested size, for tests and benchmarks, and
writing meshes as binary PLY.

Every shape is a parametric surface sampled on a (rows + 1) x (cols + 1) grid of (u, v) in [0, 1]^2,
two triangles per cell, all in numpy. Closed shapes repeat their seam vertices (u = 1 beside u = 0, a
whole row at a pole) so each side of a seam keeps its own uv, but the copies take the position (and
normal) of one canonical vertex, bit for bit: the surface is watertight by position, and normals are
smooth across seams. Triangles are counter-clockwise seen from outside (du x dv points out).
"""
import math

import numpy as np

from .meshes import Mesh, vertex_normals

PLY_FACE = np.dtype([("n", "u1"), ("vertex_indices", "<i4", (3,))])


def sphere(triangles, radius=1.0):
    """UV sphere with about `triangles` triangles (|F - triangles| <= sqrt(triangles)), v from the
    south pole (v = 0) to the north pole, analytic normals. F = 2 cols (rows - 1) (the pole rows have one
    triangle per cell), cols ~ 2 rows for square-ish cells at the equator. Two pole copies (u = 1 at
    the south pole, u = 0 at the north) belong to no triangle."""
    rows = max(3, round((1 + math.sqrt(1 + triangles)) / 2))
    cols = max(3, round(triangles / (2 * (rows - 1))))

    def surface(u, v):
        phi, theta = 2 * np.pi * u, np.pi * v
        return radius * np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), -np.cos(theta)], -1)
    mesh = _grid(surface, rows, cols, wrap_u=True, poles=True, smooth=False)
    mesh.normals = mesh.vertices / radius
    return mesh


def torus(triangles, major=1.0, minor=0.35, bumps=(12, 5), amplitude=0.06):
    """Torus around the z axis with about `triangles` triangles (|F - triangles| <= sqrt(triangles)),
    displaced along its normal by amplitude * sin(bumps[0] * 2 pi u) * sin(bumps[1] * 2 pi v) (periodic,
    so it stays closed); area-weighted vertex normals. F = 2 rows cols with cols ~ 3 rows."""
    rows = max(3, round(math.sqrt(triangles / 6)))
    cols = max(3, round(triangles / (2 * rows)))

    def surface(u, v):
        a, b = 2 * np.pi * u, 2 * np.pi * v
        out = np.stack([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)], -1)
        core = major * np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], -1)
        height = minor + amplitude * np.sin(bumps[0] * a) * np.sin(bumps[1] * b)
        return core + height[..., None] * out
    return _grid(surface, rows, cols, wrap_u=True, wrap_v=True)


def terrain(triangles, size=10.0, height=1.5, octaves=6, seed=0):
    """Height field z = h(x, y) over [-size/2, size/2]^2 with about `triangles` triangles
    (|F - triangles| <= sqrt(triangles)): fractal value noise (octaves of random lattices interpolated
    with smoothstep weights, halving in amplitude), seeded; area-weighted vertex normals; open (a boundary)."""
    rows = max(1, round(math.sqrt(triangles / 2)))
    cols = max(1, round(triangles / (2 * rows)))
    rng = np.random.default_rng(seed)
    lattices = [rng.random(((4 << k) + 1, (4 << k) + 1)) for k in range(octaves)]

    def surface(u, v):
        z = sum(0.5 ** k * _value_noise(lattice, u, v) for k, lattice in enumerate(lattices))
        return np.stack([size * (u - 0.5), size * (v - 0.5), height * z / 2], -1)
    return _grid(surface, rows, cols)


def write_ply(path, mesh):
    """Binary little-endian PLY: float32 x y z [nx ny nz] [s t] per vertex (uvs as s, t, the names
    Blender and trimesh use), then int32 triangles: two numpy structured arrays, one write each.
    (trimesh's exporter would need a Trimesh with TextureVisuals for the uvs and writes normals only when
    they sit in its private cache; this is shorter than satisfying it.)"""
    parts = [(names, a) for names, a in ((("x", "y", "z"), mesh.vertices), (("nx", "ny", "nz"), mesh.normals),
                                         (("s", "t"), mesh.uvs)) if a is not None]
    vertex = np.empty(len(mesh.vertices), [(name, "<f4") for names, _ in parts for name in names])
    for names, array in parts:
        for k, name in enumerate(names):
            vertex[name] = array[:, k]
    face = np.empty(len(mesh.faces), PLY_FACE)
    face["n"], face["vertex_indices"] = 3, mesh.faces
    header = ["ply", "format binary_little_endian 1.0", "comment raytrace.meshgen",
              f"element vertex {len(vertex)}", *(f"property float {name}" for name in vertex.dtype.names),
              f"element face {len(face)}", "property list uchar int vertex_indices", "end_header", ""]
    with open(path, "wb") as f:
        f.write("\n".join(header).encode("ascii"))
        f.write(vertex.tobytes())
        f.write(face.tobytes())


def _grid(surface, rows, cols, wrap_u=False, wrap_v=False, poles=False, smooth=True):
    """Mesh of surface(u, v) on the grid: uvs per grid vertex, positions of each vertex's canonical copy
    (seams and poles welded), triangles that are degenerate once welded (at the poles) dropped, and if
    `smooth`, area-weighted normals (summed by position, so across the seams)."""
    v, u = np.meshgrid(np.linspace(0, 1, rows + 1), np.linspace(0, 1, cols + 1), indexing="ij")
    weld = _weld(rows, cols, wrap_u, wrap_v, poles)
    vertices = surface(u, v).reshape(-1, 3)[weld]
    faces = _grid_faces(rows, cols)
    welded = weld[faces]
    keep = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 2] != welded[:, 0])
    faces = faces[keep]
    normals = vertex_normals(vertices, faces) if smooth else None
    return Mesh(vertices, faces.astype(np.int32), normals, np.stack([u, v], -1).reshape(-1, 2))


def _weld(rows, cols, wrap_u, wrap_v, poles):
    """For each grid vertex (row-major), the index of the vertex whose position it shares."""
    r, c = np.meshgrid(np.arange(rows + 1), np.arange(cols + 1), indexing="ij")
    if wrap_u:
        c = c % cols
    if wrap_v:
        r = r % rows
    if poles:
        c = np.where((r == 0) | (r == rows), 0, c)
    return (r * (cols + 1) + c).ravel()


def _grid_faces(rows, cols):
    """Two counter-clockwise (in u, v) triangles per cell of the row-major (rows+1) x (cols+1) grid."""
    a = (np.arange(rows)[:, None] * (cols + 1) + np.arange(cols)).ravel()
    b, c, d = a + 1, a + cols + 2, a + cols + 1  # (u+1, v), (u+1, v+1), (u, v+1)
    return np.stack([a, b, c, a, c, d], 1).reshape(-1, 3)


def _value_noise(lattice, u, v):
    """Lattice values interpolated with smoothstep weights at (u, v) in [0, 1]^2."""
    n = lattice.shape[0] - 1
    x, y = u * n, v * n
    i, j = np.minimum(x.astype(int), n - 1), np.minimum(y.astype(int), n - 1)
    s, t = _smoothstep(x - i), _smoothstep(y - j)
    return ((1 - s) * (1 - t) * lattice[j, i] + s * (1 - t) * lattice[j, i + 1] +
            (1 - s) * t * lattice[j + 1, i] + s * t * lattice[j + 1, i + 1])


def _smoothstep(x):
    return x * x * (3 - 2 * x)
