"""The scene's triangles and its bounding volume hierarchy, built on the host: every triangle as one soup of
arrays (the scene file's triangles and every mesh's faces), the boxes of all shapes, the BVH over them
(bvh.py) and the soup renumbered in the order of the BVH's leaves. packing.py turns these into the kernel's
structs; scene_tables.py keeps them per live scene."""
from dataclasses import dataclass

import numpy as np

from . import bvh
from .. import structs
from ..errors import InputError
from .culling import culled_subtrees
from ..scene.texture_lookups import attribute_names

DEFAULT_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # uv = (b1, b2)


@dataclass
class TriangleSoup:
    """Every triangle of a scene in the scene's order (the scene file's triangles, then each mesh's), as
    arrays: corners v (F, 3, 3), per-corner uvs (F, 3, 2), per-corner shading normals (F, 3, 3; the face's
    own normal where a mesh is not smooth), materials (F,). With a BVH the kernel gets them in its leaves'
    order (in_leaf_order)."""
    v: np.ndarray
    uv: np.ndarray
    normals: np.ndarray
    material: np.ndarray
    attributes: dict  # {name: per-corner values (F, 3, 3)} of the mesh attributes the materials read, 0 elsewhere
                      # (a face attribute's value at its triangle's three corners: constant over it)


def triangle_soup(scene):
    tris = scene.triangles
    v = [np.array([t.vertices for t in tris], np.float64).reshape(-1, 3, 3)]
    uv = [np.array([DEFAULT_UV if t.uv is None else t.uv for t in tris], np.float64).reshape(-1, 3, 2)]
    normals, material = [None], [np.array([t.material for t in tris], np.int32)]
    for shape in scene.meshes:
        m = shape.mesh
        v.append(m.vertices[m.faces])
        uv.append(m.uvs[m.faces] if m.uvs is not None else np.broadcast_to(DEFAULT_UV, (len(m.faces), 3, 2)))
        normals.append(m.normals[m.faces] if shape.smooth else None)
        material.append(np.full(len(m.faces), shape.material, np.int32))
    v = np.concatenate(v)
    face = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 1])
    face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
    flat = lambda part: np.repeat(face[part, None], 3, axis=1)  # noqa: E731
    starts = np.cumsum([0] + [len(a) for a in material])
    normals = [flat(slice(a, b)) if n is None else n for n, a, b in zip(normals, starts[:-1], starts[1:])]
    attributes = {}
    for name in attribute_names(scene.materials):  # one value broadcast to three channels, as Mitsuba's eval
        def corners(mesh):
            """A mesh's values of `name` per corner; zeros where it has none, or has them in a size no material
            of its reads (rules.py checks the sizes of those its materials read: an rgba colour unread is no
            error, and no lookup reaches it)."""
            values = mesh.corner_values(name) if name in mesh.attributes else None
            if values is None or values.shape[-1] not in (1, 3):
                return np.zeros((len(mesh.faces), 3, 3))
            return np.broadcast_to(values, (len(mesh.faces), 3, 3))
        attributes[name] = np.concatenate([np.zeros((len(tris), 3, 3))] + [corners(s.mesh) for s in scene.meshes])
    return TriangleSoup(v, np.concatenate(uv), np.concatenate(normals), np.concatenate(material), attributes)


def primitive_boxes(scene, soup):
    """(lo, hi, refs): the axis-aligned box of every shape (float64, (N, 3) each) and its reference,
    index * PRIM_KINDS + kind (kernels/types.h). An ellipsoid c + A x, |x| = 1, reaches c_j +- |row j of A|; a
    disk c + A (x, y, 0), x^2 + y^2 <= 1, c_j +- |(A_j0, A_j1)|; a cylinder, that from c and from c + A_2."""
    rect_corners = [r.center + np.outer([-1, 1], r.size[0] / 2 * np.abs(r.tangent) + r.size[1] / 2 * np.abs(r.bitangent))
                    for r in scene.rectangles]
    boxes = [(c[0], c[1]) for c in rect_corners]
    boxes += [(e.center - np.linalg.norm(e.matrix, axis=1), e.center + np.linalg.norm(e.matrix, axis=1))
              for e in scene.ellipsoids]
    for shape in scene.disks:
        m = shape.matrix
        reach = np.linalg.norm(m[:3, :2], axis=1)
        boxes.append((m[:3, 3] - reach, m[:3, 3] + reach))
    for shape in scene.cylinders:
        m = shape.matrix
        reach, ends = np.linalg.norm(m[:3, :2], axis=1), np.stack([m[:3, 3], m[:3, 3] + m[:3, 2]])
        boxes.append((ends.min(axis=0) - reach, ends.max(axis=0) + reach))
    kinds = [(structs.SHAPES["rectangle"], len(scene.rectangles)), (structs.SHAPES["triangle"], len(soup.v)),
             (structs.SHAPES["ellipsoid"], len(scene.ellipsoids)), (structs.SHAPES["disk"], len(scene.disks)),
             (structs.SHAPES["cylinder"], len(scene.cylinders))]
    refs = np.concatenate([np.arange(n, dtype=np.int32) * structs.PRIM_KINDS + kind for kind, n in kinds])
    lo, hi = (np.array([b[k] for b in boxes], np.float64).reshape(-1, 3) for k in (0, 1))
    n_rect = len(scene.rectangles)
    lo = np.concatenate([lo[:n_rect], soup.v.min(axis=1), lo[n_rect:]])
    hi = np.concatenate([hi[:n_rect], soup.v.max(axis=1), hi[n_rect:]])
    return lo, hi, refs


def bvh_structs(scene, use_bvh, soup=None):
    """(nodes, primitive references, culled subtrees) of the hierarchy over every shape, or one dummy of
    each without it."""
    if not use_bvh:
        return np.zeros(1, structs.BVH_NODE), np.zeros(1, np.int32), np.zeros(1, np.uint32)
    lo, hi, refs = primitive_boxes(scene, soup or triangle_soup(scene))
    if len(refs) > np.iinfo(np.int32).max // structs.PRIM_KINDS:  # index * PRIM_KINDS + kind must fit an int
        raise InputError(scene.path, "shapes", f"{len(refs)} shapes", "more shapes than the kernel can reference")
    try:
        nodes, order = bvh.build(lo, hi)
    except ValueError as e:  # a tree deeper than the kernel's stack
        raise InputError(scene.path, "shapes", f"{len(refs)} shapes", str(e)) from None
    return nodes, refs[order], culled_subtrees(nodes, refs[order])


def in_leaf_order(soup, prims):
    """The soup's triangles renumbered in the order the BVH's leaves reference them, and the references
    renumbered to match. A leaf's triangles then lie side by side in memory, and those of the leaves around
    it close by (the nodes are depth first), wherever the mesh file put them: traversal reads them with
    fewer cache misses (a torus of 10^6 triangles, whose rows of faces lie apart in its own order: bvh.cl
    spent a fifth of its time waiting on triangle loads before). Rectangles, ellipsoids, disks and cylinders keep their
    numbers (lights and culling name rectangles by theirs)."""
    triangle = (prims & (structs.PRIM_KINDS - 1)) == structs.SHAPES["triangle"]
    order = prims[triangle] >> structs.PRIM_KIND_BITS
    prims = prims.copy()
    prims[triangle] = np.arange(len(order), dtype=prims.dtype) * structs.PRIM_KINDS + structs.SHAPES["triangle"]
    return TriangleSoup(soup.v[order], soup.uv[order], soup.normals[order], soup.material[order],
                        {name: values[order] for name, values in soup.attributes.items()}), prims
