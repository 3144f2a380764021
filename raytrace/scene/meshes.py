"""Triangle meshes as numpy arrays, and reading them from OBJ and PLY files.

Files are parsed by trimesh (MIT, well kept, needs only numpy): one library reads OBJ and ascii and
binary PLY, and fan-triangulates quads and n-gons. We call its format readers
(trimesh.exchange.obj.load_obj, trimesh.exchange.ply.load_ply) and not trimesh.load, whose Trimesh
recomputes vertex normals, dropping the file's own (an OBJ's always; a PLY's when load_ply's default
"texture fix" has reindexed the vertices but not their normals, e.g. when one is unused). With
fix_texture=False the readers' raw arrays keep each vertex's position, normal and uv together.

One gap is filled here: trimesh's binary PLY reader needs all face lists to have one length, so
binary files mixing triangles, quads and n-gons are read by a small reader of our own.

Real files are messy, and trimesh is lenient, so everything it lets through is checked here: a file
without faces, non-finite coordinates, indices out of range, and face references to texture
coordinates or normals that trimesh silently drops raise InputError naming the file; degenerate faces
(repeated indices, zero area) are dropped and counted. Limits: OBJ materials are ignored, and PLY
texture coordinates stored per face corner ("texcoord" lists) keep one uv per vertex.
"""
import io
import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

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
    path = Path(path)
    readers = {".obj": _read_obj, ".ply": _read_ply}
    if path.suffix.lower() not in readers:
        raise InputError(path, "file", str(path), "must be an .obj or .ply file")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(path, "file", str(path), e.strerror or "cannot be read") from None
    vertices, faces, normals, uvs = readers[path.suffix.lower()](path, data)
    return _checked(path, vertices, faces, normals, uvs)


def _read_obj(path, data):
    """The file's (vertices, polygons, normals, uvs), from all its `usemtl` groups."""
    if b"\0" in data:
        raise InputError(path, "file", None, "is binary data, not OBJ text")
    text = data.decode("latin-1")  # only ASCII matters; names and comments in other encodings pass
    _check_obj_indices(path, text)
    from trimesh.exchange.obj import load_obj  # here, not at the top: importing trimesh takes 0.5 s
    try:
        parts = load_obj(io.StringIO(text), skip_materials=True, group_material=False).get("geometry", {})
    except IndexError:
        raise InputError(path, "f", None, "a face refers to a vertex that does not exist") from None
    except Exception as e:  # trimesh raises whatever its parsing hits on malformed text
        raise InputError(path, "file", None, f"cannot be read as OBJ ({type(e).__name__}: {e})") from None
    parts = [p for p in parts.values() if len(p.get("faces", ()))]
    if not parts:
        raise InputError(path, "f", None, "the file has no faces")
    uvs = [getattr(p.get("visual"), "uv", None) for p in parts]
    normals = [p.get("vertex_normals") for p in parts]
    for key, refs, got, what in (("vt", r"\d/-?\d", uvs, "texture coordinates"),
                                 ("vn", r"\d/-?\d*/-?\d", normals, "normals")):
        if re.search(r"^f[ \t][^\n]*?" + refs, text, re.M) and any(g is None for g in got):
            raise InputError(path, key, None, f"faces refer to {what} that do not exist, or only some faces "
                                              f"have them")
    offsets = np.cumsum([0] + [len(p["vertices"]) for p in parts])
    return (np.concatenate([p["vertices"] for p in parts]),
            np.concatenate([fan(np.asarray(p["faces"])) + o for p, o in zip(parts, offsets)]),
            None if any(n is None for n in normals) else np.concatenate(normals),
            None if any(uv is None for uv in uvs) else np.concatenate(uvs))


def _check_obj_indices(path, text):
    """What trimesh gets silently wrong: index 0 (OBJ counts from 1; trimesh reads it as the first
    vertex), and negative (relative) indices once vertices follow faces (trimesh counts back from the
    end of the file, not from the face)."""
    zero = re.search(r"^f[ \t][^\n]*?(?<=[ \t/])-?0(?=[ \t/\r]|$)", text, re.M)
    if zero:
        raise InputError(path, "f", zero.group(0).strip(), "indices start at 1")
    relative = re.search(r"^f[ \t][^\n]*?(?<=[ \t/])-\d", text, re.M)
    if relative and max(text.rfind(f"\n{k} ") for k in ("v", "vt", "vn")) > relative.start():
        raise InputError(path, "f", relative.group(0).strip(),
                         "relative (negative) indices are supported only when all vertices come first")


def _read_ply(path, data):
    """The file's (vertices, polygons, normals, uvs). fix_texture=False keeps the file's vertex order."""
    from trimesh.exchange.ply import load_ply
    try:
        read = load_ply(io.BytesIO(data), fix_texture=False, skip_materials=True)
    except IndexError:
        raise InputError(path, "face", None, "a face refers to a vertex that does not exist") from None
    except Exception as e:  # trimesh raises whatever its parsing hits on malformed data
        if data.startswith(b"ply") and b"format binary" in data[:data.find(b"end_header")]:
            return _read_binary_ply(path, data)
        raise InputError(path, "file", None, f"cannot be read as PLY ({type(e).__name__}: {e})") from None
    faces = read.get("faces")
    if faces is None or not len(faces):
        raise InputError(path, "face", None, "the file has no faces")
    return read["vertices"], fan(np.asarray(faces)), read.get("vertex_normals"), \
        getattr(read.get("visual"), "uv", None)


# PLY scalar types as struct codes, which numpy reads too (np.dtype("<i") is int32).
PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
             "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
             "double": "d", "float64": "d"}
PLY_UV_NAMES = (("texture_u", "texture_v"), ("u", "v"), ("s", "t"))  # trimesh's, in its order


def _read_binary_ply(path, data):
    """Binary PLY that trimesh refuses: its binary reader needs every face list to have one length, and
    quad meshes with a few triangles (or n-gons) do not. Header parsed here, vertices read by numpy,
    faces record by record (Python: about 3 s per million faces), then fanned by size."""
    try:
        head, body = data.split(b"end_header", 1)
        tables = _ply_elements(head.decode("ascii"), body[body.index(b"\n") + 1:])
        vertex, polygons = tables["vertex"], tables["face"]
        columns = vertex.dtype.names
        normals = np.stack([vertex[k] for k in ("nx", "ny", "nz")], 1) if "nz" in columns else None
        uv = next(((u, v) for u, v in PLY_UV_NAMES if u in columns and v in columns), None)
        sizes = np.array([len(p) for p in polygons])
        faces = [fan(np.array([p for p in polygons if len(p) == k])) for k in np.unique(sizes[sizes >= 3])]
    except Exception as e:  # truncated data, unknown types, missing elements: all malformed files
        raise InputError(path, "file", None, f"cannot be read as binary PLY ({type(e).__name__}: {e})") from None
    return (np.stack([vertex[k] for k in "xyz"], 1), np.concatenate(faces) if faces else np.zeros((0, 3), int),
            normals, None if uv is None else np.stack([vertex[uv[0]], vertex[uv[1]]], 1))


def _ply_elements(header, body):
    """{element name: structured array, or for elements with list properties, their index lists}."""
    lines = [line.split() for line in header.splitlines()]
    endian = ">" if ["format", "binary_big_endian", "1.0"] in lines else "<"
    elements = []
    for line in lines:
        if line[:1] == ["element"]:
            elements.append((line[1], int(line[2]), []))
        elif line[:1] == ["property"]:
            elements[-1][2].append(line[1:])
    offset, tables = 0, {}
    for name, count, properties in elements:
        if any(p[0] == "list" for p in properties):
            tables[name], offset = _ply_lists(body, offset, count, properties, endian)
        else:
            dtype = np.dtype([(p[1], endian + PLY_TYPES[p[0]]) for p in properties])
            tables[name] = np.frombuffer(body, dtype, count, offset)
            offset += count * dtype.itemsize
    return tables


def _ply_lists(body, offset, count, properties, endian):
    """The vertex index lists of `count` records that have list properties, and the offset after them."""
    polygons = []
    for _ in range(count):
        for p in properties:
            if p[0] == "list":
                n = struct.unpack_from(endian + PLY_TYPES[p[1]], body, offset)[0]
                offset += struct.calcsize(endian + PLY_TYPES[p[1]])
                values = struct.unpack_from(f"{endian}{n}{PLY_TYPES[p[2]]}", body, offset)
                offset += struct.calcsize(f"{endian}{n}{PLY_TYPES[p[2]]}")
                if p[3] in ("vertex_indices", "vertex_index"):
                    polygons.append(values)
            else:
                offset += struct.calcsize(endian + PLY_TYPES[p[0]])
    return polygons, offset


def _checked(path, vertices, faces, normals, uvs):
    """The validated Mesh (float64 arrays, int32 faces) and the number of degenerate faces dropped."""
    vertices = np.asarray(vertices, np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise InputError(path, "vertices", None, "every vertex needs x, y and z")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise InputError(path, f"vertices[{np.argmax(bad)}]", vertices[np.argmax(bad)].tolist(), "must be finite")
    if not len(faces):
        raise InputError(path, "faces", None, "no face has three or more vertices")
    out = (faces < 0) | (faces >= len(vertices))
    if out.any():
        row = np.argmax(out.any(axis=1))
        raise InputError(path, f"faces[{row}]", faces[row].tolist(), f"indices must be in [0, {len(vertices) - 1}]")
    if uvs is not None:
        uvs = np.asarray(uvs, np.float64)
        bad = ~np.isfinite(uvs).all(axis=1)
        if bad.any():
            raise InputError(path, f"uvs[{np.argmax(bad)}]", uvs[np.argmax(bad)].tolist(), "must be finite")
    degenerate = degenerate_faces(vertices, faces)
    faces = faces[~degenerate].astype(np.int32)
    if not len(faces):
        raise InputError(path, "faces", None, f"all {int(degenerate.sum())} faces are degenerate (zero area)")
    if normals is not None:
        normals = _unit_normals(np.asarray(normals, np.float64), vertices, faces)
    return Mesh(vertices, faces, normals, uvs), int(degenerate.sum())


def _unit_normals(normals, vertices, faces):
    """The file's normals, normalised; zero or non-finite ones are replaced by area-weighted ones."""
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    usable = np.isfinite(length) & (length > 0)
    unit = np.divide(normals, length, out=np.zeros_like(normals), where=usable)
    if not usable.all():
        unit[~usable[:, 0]] = vertex_normals(vertices, faces)[~usable[:, 0]]
    return unit
