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
    shape: np.ndarray = None  # (F,) the shape each is of: a loose triangle's index in scene.triangles, a mesh's
                              # len(scene.triangles) + its index in scene.meshes; -1 in a group (the shape_index AOV)


def triangle_soup(scene):
    tris = scene.triangles
    v = [np.array([t.vertices for t in tris], np.float64).reshape(-1, 3, 3)]
    uv = [np.array([DEFAULT_UV if t.uv is None else t.uv for t in tris], np.float64).reshape(-1, 3, 2)]
    normals, material = [None], [np.array([t.material for t in tris], np.int32)]
    owner = [np.arange(len(tris), dtype=np.int32)]
    for k, shape in enumerate([*scene.meshes, *(m for g in scene.groups for m in g.meshes)]):  # the groups' in
        m = shape.mesh                                                                         # their own space
        owner.append(np.full(len(m.faces), len(tris) + k if k < len(scene.meshes) else -1, np.int32))
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
        attributes[name] = np.concatenate([np.zeros((len(tris), 3, 3))] + [corners(s.mesh) for s in scene.meshes]
                                          + [corners(m.mesh) for g in scene.groups for m in g.meshes])
    return TriangleSoup(v, np.concatenate(uv), np.concatenate(normals), np.concatenate(material), attributes,
                        np.concatenate(owner))


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
    kinds = [(structs.SHAPES["rectangle"], len(scene.rectangles)), (structs.SHAPES["triangle"], scene.triangle_count),
             (structs.SHAPES["ellipsoid"], len(scene.ellipsoids)), (structs.SHAPES["disk"], len(scene.disks)),
             (structs.SHAPES["cylinder"], len(scene.cylinders))]
    refs = np.concatenate([np.arange(n, dtype=np.int32) * structs.PRIM_KINDS + kind for kind, n in kinds])
    lo, hi = (np.array([b[k] for b in boxes], np.float64).reshape(-1, 3) for k in (0, 1))
    n_rect, world = len(scene.rectangles), soup.v[:scene.triangle_count]  # the groups' triangles: theirs
    lo = np.concatenate([lo[:n_rect], world.min(axis=1), lo[n_rect:]])
    hi = np.concatenate([hi[:n_rect], world.max(axis=1), hi[n_rect:]])
    return lo, hi, refs


def bvh_structs(scene, use_bvh, soup=None):
    """(nodes, primitive references, culled subtrees, each group's root node) of the hierarchy over every shape,
    or one dummy of each without it (and no roots)."""
    if not use_bvh:
        return np.zeros(1, structs.BVH_NODE), np.zeros(1, np.int32), np.zeros(1, np.uint32), []
    soup = soup or triangle_soup(scene)
    lo, hi, refs = primitive_boxes(scene, soup)
    if len(refs) > np.iinfo(np.int32).max // structs.PRIM_KINDS:  # index * PRIM_KINDS + kind must fit an int
        raise InputError(scene.path, "shapes", f"{len(refs)} shapes", "more shapes than the kernel can reference")
    try:
        trees = [bvh.build(lo, hi)] if len(refs) else []
        if scene.instances:
            trees += _instance_trees(scene, soup)
    except ValueError as e:  # a tree deeper than the kernel's stack
        raise InputError(scene.path, "shapes", f"{len(refs)} shapes", str(e)) from None
    if not scene.instances:
        nodes, order = trees[0]
        return nodes, refs[order], culled_subtrees(nodes, refs[order]), []
    top = max(_depth(nodes) for nodes, _ in trees[:-len(scene.groups)]) + 1  # under the two-level root
    if top + max(_depth(nodes) for nodes, _ in trees[-len(scene.groups):]) + 1 > structs.BVH_STACK:
        raise InputError(scene.path, "groups", f"{len(scene.groups)} groups", "the instances' tree and a group's are "
                         f"together deeper than the kernel's traversal stack of {structs.BVH_STACK} levels")
    nodes, prims, roots = _two_levels(trees[0] if len(refs) else None, refs, trees[1 if len(refs) else 0:])
    return nodes, prims, culled_subtrees(nodes, prims), roots


def _depth(nodes):
    """The levels of a flattened tree (bvh.py's layout: an interior node's first child is the next node), a level
    of nodes at a time (numpy), as bvh.build makes them: at most BVH_STACK passes, not one per node."""
    level, levels = np.array([0]), 0
    while len(level):
        levels += 1
        inner = level[nodes["count"][level] <= 0]
        level = np.concatenate([inner + 1, nodes["offset"][inner]])
    return levels


def _instance_trees(scene, soup):
    """[(nodes, references)] of the instances' tree (each instance alone in its leaf, bvh.cl) and of each group's
    tree over its triangles (their soup numbers follow the scene's own), in that order."""
    boxes = [inst.bounds(scene.groups[inst.group]) for inst in scene.instances]
    nodes, order = bvh.build(np.array([b[0] for b in boxes]), np.array([b[1] for b in boxes]), max_leaf=1)
    refs = np.arange(len(boxes), dtype=np.int32) * structs.PRIM_KINDS + structs.SHAPES["instance"]
    trees, start = [(nodes, refs[order])], scene.triangle_count
    for group in scene.groups:
        n = sum(len(m.mesh.faces) for m in group.meshes)
        v = soup.v[start:start + n]
        nodes, order = bvh.build(v.min(axis=1), v.max(axis=1))
        refs = (start + np.arange(n, dtype=np.int32)) * structs.PRIM_KINDS + structs.SHAPES["triangle"]
        trees.append((nodes, refs[order]))
        start += n
    return trees


def _two_levels(world, world_refs, trees):
    """(nodes, references, each group's root) of the two-level hierarchy (kernels/instances.cl): a root over the
    scene's own tree (world: (nodes, order) or None) and the instances' tree, then each group's tree (trees:
    the instances', then the groups'); each subtree's child and leaf offsets moved to where it lands."""
    parts = ([(world[0], world_refs[world[1]])] if world is not None else []) + list(trees)
    placed_nodes, placed_refs, node_start, ref_start, starts = [], [], 1 if world is not None else 0, 0, []
    for nodes, refs in parts:
        starts.append(node_start)
        nodes = nodes.copy()
        inner = nodes["count"] <= 0
        nodes["offset"] = np.where(inner, nodes["offset"] + node_start, nodes["offset"] + ref_start)
        placed_nodes.append(nodes)
        placed_refs.append(refs)
        node_start += len(nodes)
        ref_start += len(refs)
    if world is not None:  # the root: the scene's tree first (the next node), the instances' second
        root = np.zeros(1, structs.BVH_NODE)
        a, b = placed_nodes[0][0], placed_nodes[1][0]
        root["lo"], root["hi"] = np.minimum(a["lo"], b["lo"]), np.maximum(a["hi"], b["hi"])
        root["offset"], root["count"] = 1 + len(placed_nodes[0]), 0
        placed_nodes.insert(0, root)
    return np.concatenate(placed_nodes), np.concatenate(placed_refs), starts[len(parts) - len(trees) + 1:]


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
                        {name: values[order] for name, values in soup.attributes.items()}, soup.shape[order]), prims
