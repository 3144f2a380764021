"""Triangle meshes as numpy arrays (Mesh and its geometry), and what the file readers share: the test of a
value a mesh can hold (value_problem) and the handling of trimesh's warnings and errors (quiet, why).

Files are parsed by trimesh (MIT, well kept, needs only numpy): one library reads OBJ and ascii and
binary PLY, and fan-triangulates quads and n-gons. We call its format readers
(trimesh.exchange.obj.load_obj, trimesh.exchange.ply.load_ply) and not trimesh.load, whose Trimesh
recomputes vertex normals, dropping the file's own (an OBJ's always; a PLY's when load_ply's default
"texture fix" has reindexed the vertices but not their normals, e.g. when one is unused). With
fix_texture=False the readers' raw arrays keep each vertex's position, normal and uv together.

Imports run one way: obj_file.py and ply_file.py read the formats with this module's parts, and
mesh_file.py (load_mesh) dispatches to them and checks what they return.
"""
import logging
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..numerics import FLOAT32_MAX

# trimesh logs warnings (e.g. "PLY failed to populate") that Python's last-resort handler would print on
# stderr beside our one line; its errors reach the user as InputError instead.
logging.getLogger("trimesh").addHandler(logging.NullHandler())


# Twice the area over the longest edge squared: at or below this a triangle has no usable plane
# (raytrace.scene refuses triangles written in a scene file by the same ratio).
DEGENERATE = 1e-9
NO_FACES = "the file has no faces"  # a mesh file's error, whatever its format


@dataclass
class Mesh:
    vertices: np.ndarray              # (V, 3) float64
    faces: np.ndarray                 # (F, 3) int32, counter-clockwise seen from the front
    normals: np.ndarray | None = None  # (V, 3) float64 unit shading normals, per vertex
    uvs: np.ndarray | None = None     # (V, 2) float64 texture coordinates, per vertex
    attributes: dict = field(default_factory=dict)  # {name: (N, dim) float64}: Mitsuba's mesh attributes, a
    # row per vertex for names "vertex_...", per face (of `faces`) for "face_..." (ply_file.element_attributes)

    def corner_values(self, name):
        """(F, 3, dim): attribute `name` at each face's three corners; a face attribute's value at all three, so
        that interpolating the corners gives the face's value, constant over it (Mitsuba's face attributes)."""
        values = self.attributes[name]
        if is_face_attribute(name):
            return np.repeat(values[:, None, :], 3, axis=1)
        return values[self.faces]

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


def angle_weighted_normals(vertices, faces):
    """Vertex normals as Mitsuba 3 computes them for a mesh file without normals (Mesh::recompute_vertex_normals,
    after Thuermer and Wuethrich, "Computing Vertex Normals from Polygonal Facets", JGT 1998): each face's unit
    normal weighted by its angle at the vertex, summed per vertex index (a vertex a file splits keeps its own
    normal, unlike vertex_normals). Zero where the sum cancels."""
    corners = vertices[faces]  # F x 3 x 3
    face_normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(face_normal, axis=1, keepdims=True)
    face_normal = np.divide(face_normal, length, out=np.zeros_like(face_normal), where=length > 0)
    total = np.zeros_like(vertices)
    for k in range(3):
        a = corners[:, (k + 1) % 3] - corners[:, k]
        b = corners[:, (k + 2) % 3] - corners[:, k]
        angle = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
        np.add.at(total, faces[:, k], face_normal * angle[:, None])
    length = np.linalg.norm(total, axis=1, keepdims=True)
    return np.divide(total, length, out=np.zeros_like(total), where=length > 0)


def same_position(vertices):
    """For each vertex, an id shared by exactly the vertices at the same position (sort, compare
    neighbours: faster than np.unique(axis=0), measured in commit cd6cb18)."""
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


def is_face_attribute(name):
    """Whether a mesh attribute is per face: Mitsuba's names start with "face_" (else "vertex_")."""
    return name.startswith("face_")


def kept_faces(attributes, keep):
    """Mesh attributes after a mesh keeps the faces of the mask `keep` (degenerate ones dropped): face
    attributes keep their rows, aligned with the faces left."""
    return {name: values[keep] if is_face_attribute(name) else values for name, values in attributes.items()}


def fan_polygons(polygons):
    """(triangles (T, 3), the polygon of each triangle (T,)) of polygons of any sizes (a sequence of index
    sequences, or an (F, k) array), each fanned (fan), in the file's order: a polygon's triangles consecutive,
    polygons of fewer than three indices dropped. Grouped by size, so that each group is one numpy fan."""
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2 and polygons.dtype != object:
        count = max(polygons.shape[1] - 2, 0)
        return (fan(polygons) if count else np.zeros((0, 3), np.int64)), np.repeat(np.arange(len(polygons)), count)
    sizes = np.array([len(p) for p in polygons], np.int64)
    triangles, source = [np.zeros((0, 3), np.int64)], [np.zeros(0, np.int64)]
    for k in np.unique(sizes[sizes >= 3]):
        which = np.flatnonzero(sizes == k)
        triangles.append(fan(np.array([polygons[i] for i in which], np.int64).reshape(-1, k)))
        source.append(np.repeat(which, k - 2))
    source = np.concatenate(source)
    order = np.argsort(source, kind="stable")
    return np.concatenate(triangles)[order], source[order]


def fan(polygons):
    """(F, k) polygons -> (F * (k - 2), 3) triangles (0, i, i + 1), a face's triangles consecutive."""
    k = polygons.shape[1]
    first = np.repeat(polygons[:, :1], k - 2, axis=1)
    return np.stack([first, polygons[:, 1:-1], polygons[:, 2:]], axis=2).reshape(-1, 3)


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
