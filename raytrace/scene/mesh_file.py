"""Reading a mesh file (load_mesh): the reader of its format (obj_file.py, ply_file.py, serialized_file.py), then
the checks every mesh file passes, whatever its format.

Real files are messy, and trimesh is lenient, so everything it lets through is checked, and hostile files
(random bytes, truncations, absurd counts) get one InputError naming the file too. Checked here, for both
formats (_checked): a file without faces, indices out of range, and NaN, infinite or too large vertex
coordinates (beyond raytrace.numerics.COORDINATE_LIMIT), uvs and normals (beyond float32's range), named
by their row; degenerate faces (repeated indices, zero area) are dropped and counted. The readers check what
only their format has before trimesh sees it (see their docstrings).
"""
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..numerics import COORDINATE_LIMIT, FLOAT32_MAX
from . import obj_file, ply_file, serialized_file
from .meshes import Mesh, degenerate_faces, kept_faces, value_problem, vertex_normals


def load_mesh(path, source=None, key="file", shape_index=0):
    """Read an OBJ, PLY or Mitsuba .serialized file (its shape `shape_index`): (Mesh, number of degenerate faces
    dropped). Normals and uvs are the file's (None if it has none); a bad file raises InputError. A file that
    cannot be opened is named as the scene names it (`source`'s `key`: the scene file and shapes[3].file); what
    is wrong inside it, by its own name and line (or part)."""
    path = Path(path)
    where = (path, "file") if source is None else (source, key)
    readers = {".obj": obj_file.read_obj, ".ply": ply_file.read_ply,
               ".serialized": lambda path, data: serialized_file.read_serialized(path, data, shape_index)}
    if path.suffix.lower() not in readers:
        raise InputError(*where, str(path), "must be an .obj, .ply or .serialized file")
    if path.exists() and not path.is_file():  # a FIFO or /dev/zero would block or never end
        raise InputError(*where, str(path), "is not a regular file")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(*where, str(path), e.strerror or "cannot be read") from None
    try:
        vertices, faces, normals, uvs, *attributes = readers[path.suffix.lower()](path, data)
        return _checked(path, vertices, faces, normals, uvs, *attributes)
    except MemoryError:
        raise InputError(path, "file", str(path), "does not fit in memory") from None


class MeshCache:
    """The meshes read while one scene loads, by (resolved path, modification time, size, shape index): a file
    that several shapes name (an instanced shapegroup's, flattened into one shape per instance) is parsed once.
    Its Meshes are shared: their users transform copies, never the arrays themselves. Scoped to one load, so a
    file edited between loads is read again, and nothing outlives the scene."""
    def __init__(self):
        self.meshes = {}

    def load(self, path, source=None, key="file", shape_index=0):
        try:
            status = Path(path).stat()
            cached = (str(Path(path).resolve()), status.st_mtime_ns, status.st_size, shape_index)
        except (OSError, ValueError):  # load_mesh names what is wrong with the path
            return load_mesh(path, source, key, shape_index)
        if cached not in self.meshes:
            self.meshes[cached] = load_mesh(path, source, key, shape_index)
        return self.meshes[cached]


def _checked(path, vertices, faces, normals, uvs, attributes=None):
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
    attributes = kept_faces(attributes or {}, ~degenerate)  # values checked where a material reads them (rules)
    return Mesh(vertices, faces, normals, uvs, attributes), int(degenerate.sum())


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
