"""Triangle meshes as numpy arrays (Mesh and its geometry), and load_mesh, which reads them from OBJ and PLY
files: obj_file.py and ply_file.py read the formats; the checks every mesh file passes are here.

Files are parsed by trimesh (MIT, well kept, needs only numpy): one library reads OBJ and ascii and
binary PLY, and fan-triangulates quads and n-gons. We call its format readers
(trimesh.exchange.obj.load_obj, trimesh.exchange.ply.load_ply) and not trimesh.load, whose Trimesh
recomputes vertex normals, dropping the file's own (an OBJ's always; a PLY's when load_ply's default
"texture fix" has reindexed the vertices but not their normals, e.g. when one is unused). With
fix_texture=False the readers' raw arrays keep each vertex's position, normal and uv together.

Real files are messy, and trimesh is lenient, so everything it lets through is checked, and hostile files
(random bytes, truncations, absurd counts) get one InputError naming the file too. Checked here, for both
formats (_checked): a file without faces, indices out of range, and NaN, infinite or too large vertex
coordinates (beyond raytrace.numerics.COORDINATE_LIMIT), uvs and normals (beyond float32's range), named
by their row; degenerate faces (repeated indices, zero area) are dropped and counted. The readers check what
only their format has before trimesh sees it (see their docstrings), and wrap whatever trimesh still raises
(quiet, why); its log warnings are silenced here.

At import time, imports run one way: obj_file and ply_file import this module's geometry (fan) and shared
checks; load_mesh imports the readers only when it is called (at the top the import would be circular).
The shared checks stay here, beside the Mesh they validate, so that neither reader imports the other.
"""
import logging
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..numerics import COORDINATE_LIMIT, FLOAT32_MAX

# trimesh logs warnings (e.g. "PLY failed to populate") that Python's last-resort handler would print on
# stderr beside our one line; its errors reach the user as InputError instead.
logging.getLogger("trimesh").addHandler(logging.NullHandler())


# Twice the area over the longest edge squared: at or below this a triangle has no usable plane
# (raytrace.scene refuses triangles written in a scene file by the same ratio).
DEGENERATE = 1e-9


@dataclass
class Mesh:
    vertices: np.ndarray              # (V, 3) float64
    faces: np.ndarray                 # (F, 3) int32, counter-clockwise seen from the front
    normals: np.ndarray | None = None  # (V, 3) float64 unit shading normals, per vertex
    uvs: np.ndarray | None = None     # (V, 2) float64 texture coordinates, per vertex

    def triangle_bounds(self):
        """(lo, hi), each (F, 3): every triangle's axis-aligned box, the BVH's input."""
        corners = self.vertices[self.faces]
        return corners.min(axis=1), corners.max(axis=1)


def vertex_normals(vertices, faces):
    """Area-weighted vertex normals (for `smooth = true`): the unnormalised face normals
    (v1 - v0) x (v2 - v0), whose length is twice the face's area, summed over all faces around a
    position and normalised. Summing by position, not by vertex index, makes vertices that a file (or a
    uv seam) splits at one position share one normal, so the shading has no seam. Zero where the sum
    cancels or a vertex has no face; callers fall back to the geometric normal there."""
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    face_normal = np.cross(v1 - v0, v2 - v0)
    position = same_position(vertices)
    corners = position[faces].ravel()
    total = np.stack([np.bincount(corners, np.repeat(face_normal[:, k], 3), len(vertices)) for k in range(3)], 1)
    length = np.linalg.norm(total, axis=1, keepdims=True)
    return np.divide(total, length, out=np.zeros_like(total), where=length > 0)[position]


def same_position(vertices):
    """For each vertex, an id shared by exactly the vertices at the same position (sort, compare
    neighbours: 0.2 s for a million vertices, against 0.5 s for np.unique(axis=0))."""
    order = np.lexsort(vertices.T[::-1])
    ordered = vertices[order]
    new = np.concatenate([[True], (ordered[1:] != ordered[:-1]).any(axis=1)])
    ids = np.empty(len(vertices), np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids


def degenerate_faces(vertices, faces):
    """Mask of faces with a repeated index or (numerically) zero area."""
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    twice_area = np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=1)
    longest = np.max([np.sum((a - b) ** 2, axis=1) for a, b in ((v1, v0), (v2, v1), (v0, v2))], axis=0)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    return repeated | ~(twice_area > DEGENERATE * longest)


def fan(polygons):
    """(F, k) polygons -> (F * (k - 2), 3) triangles (0, i, i + 1), a face's triangles consecutive."""
    k = polygons.shape[1]
    first = np.repeat(polygons[:, :1], k - 2, axis=1)
    return np.stack([first, polygons[:, 1:-1], polygons[:, 2:]], axis=2).reshape(-1, 3)


def load_mesh(path):
    """Read an OBJ or PLY file: (Mesh, number of degenerate faces dropped). Normals and uvs are the
    file's (None if it has none); a bad file raises InputError."""
    from . import obj_file, ply_file  # here, not at the top: they import this module
    path = Path(path)
    readers = {".obj": obj_file.read_obj, ".ply": ply_file.read_ply}
    if path.suffix.lower() not in readers:
        raise InputError(path, "file", str(path), "must be an .obj or .ply file")
    if path.exists() and not path.is_file():  # a FIFO or /dev/zero would block or never end
        raise InputError(path, "file", str(path), "is not a regular file")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(path, "file", str(path), e.strerror or "cannot be read") from None
    try:
        vertices, faces, normals, uvs = readers[path.suffix.lower()](path, data)
        return _checked(path, vertices, faces, normals, uvs)
    except MemoryError:
        raise InputError(path, "file", str(path), "does not fit in memory") from None


def _checked(path, vertices, faces, normals, uvs):
    """The validated Mesh (float64 arrays, int32 faces) and the number of degenerate faces dropped."""
    vertices = np.asarray(vertices, np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise InputError(path, "vertices", None, "every vertex needs x, y and z")
    _check_values(path, "vertices", vertices, COORDINATE_LIMIT)
    if not len(faces):
        raise InputError(path, "faces", None, "no face has three or more vertices")
    out = (faces < 0) | (faces >= len(vertices))
    if out.any():
        row = np.argmax(out.any(axis=1))
        raise InputError(path, f"faces[{row}]", faces[row].tolist(), f"indices must be in [0, {len(vertices) - 1}]")
    if uvs is not None:
        uvs = np.asarray(uvs, np.float64)
        _check_values(path, "uvs", uvs, FLOAT32_MAX)
    degenerate = degenerate_faces(vertices, faces)
    faces = faces[~degenerate].astype(np.int32)
    if not len(faces):
        raise InputError(path, "faces", None, f"all {int(degenerate.sum())} faces are degenerate (zero area)")
    if normals is not None:
        normals = np.asarray(normals, np.float64)
        _check_values(path, "normals", normals, FLOAT32_MAX)
        normals = _unit_normals(normals, vertices, faces)
    return Mesh(vertices, faces, normals, uvs), int(degenerate.sum())


def _check_values(path, name, values, limit):
    """Refuse a row (a vertex, uv or normal, numbered as in the file) with a NaN, infinite or too large value."""
    bad = ~(np.abs(values) <= limit).all(axis=1)
    if bad.any():
        row = values[np.argmax(bad)]
        value = row[~(np.abs(row) <= limit)][0]
        raise InputError(path, f"{name}[{np.argmax(bad)}]", row.tolist(), value_problem(f"{value:g}", value, limit))


def _unit_normals(normals, vertices, faces):
    """The file's normals, normalised; zero ones (some exporters write them at creases) are replaced by
    area-weighted ones."""
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    usable = np.isfinite(length) & (length > 0)
    unit = np.divide(normals, length, out=np.zeros_like(normals), where=usable)
    if not usable.all():
        unit[~usable[:, 0]] = vertex_normals(vertices, faces)[~usable[:, 0]]
    return unit


def value_problem(word, value, limit):
    """Why a coordinate, uv or normal component cannot be stored (None if it can, or is not a number)."""
    if value is None or abs(value) <= limit:
        return None
    if not np.isfinite(value):
        return f"{word} is not a finite number"
    if abs(value) > FLOAT32_MAX:
        return f"{word} is beyond float32's range (|x| <= {FLOAT32_MAX:.4g})"
    return f"{word} is beyond {limit:.4g}, the largest coordinate the renderer's float32 arithmetic keeps finite"


def quiet():
    """Silence the Python and numpy warnings trimesh's parsing raises on garbage (an ascii PLY face index of
    3e43 is "invalid value encountered in cast"): Python would print them on stderr beside our one line.
    Everything trimesh returns is checked afterwards (_checked)."""
    return warnings.catch_warnings(action="ignore")


def why(e):
    """An exception as one line, for the files trimesh fails on in ways not checked beforehand."""
    text = str(e).strip().splitlines()
    return f"{type(e).__name__}: {text[0][:200]}" if text else type(e).__name__
