"""Which rectangles shadow rays may skip (kernels/intersect.cl's rectangles_out_of_reach, kernels/bvh.cl's
culled subtrees): the host's half of the test, from the packed float32 values, with margins argued from how
the kernel's shadow rays sample a light and where they end."""
import math

import numpy as np

from .. import structs
from ..numerics import gamma
from ..structs import CULLED_RECTANGLES


def light_sides(light, planes, extent):
    """(bits of `planes` with the light strictly in front, bits with it strictly behind), from the stored
    float32 values. The kernel's shadow rays end near a light point q = c + du t + dv b (two multiply-adds,
    fused or not, and du, dv rounded once: within gamma(4) (|c| + hx + hy) of the rectangle per
    coordinate), pushed off the light by its error bound, at most q's gamma(4) sqrt(3) S + gamma(2) (hx +
    hy) plus gamma(2) |n|.|o - q| <= gamma(2) sqrt(3) 2 S, then rounded one float further and reached along
    a direction that rounds once (shading.cl): within about 23u (S + hx + hy) of the rectangle per
    coordinate for coordinates bounded by S; gamma(32) is taken, sqrt(3) of it along a unit normal. float64
    arithmetic on the stored values adds nothing comparable. Only the first CULLED_RECTANGLES rectangles in
    the scene's order get bits."""
    f64 = lambda key: np.asarray(light[key], np.float64)  # noqa: E731
    hx, hy = float(light["half_x"]), float(light["half_y"])
    signs = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]], np.float64) * [hx, hy]
    corners = f64("center") + signs @ np.stack([f64("tangent"), f64("bitangent")])
    n, c = planes["normal"].astype(np.float64), planes["center"].astype(np.float64)
    distance = corners @ n.T - np.einsum("ij,ij->i", c, n)  # (corner, plane)
    margin = math.sqrt(3) * gamma(32) * (extent + hx + hy)
    bits = np.left_shift(1, np.arange(len(planes)), dtype=np.int64)
    front, behind = np.all(distance > margin, axis=0), np.all(distance < -margin, axis=0)
    return int(bits[front].sum()), int(bits[behind].sum())


def scene_extent(scene, triangles):
    """A bound on every coordinate of the scene's shapes (the packed `triangles` for meshes), lights and
    height-displaced shading points."""
    parts = [np.abs(np.concatenate([triangles[k] for k in ("v0", "v1", "v2")])).max(initial=0.0)]
    for r in [*scene.rectangles, *scene.lights]:
        parts.append((np.abs(r.center) + r.size[0] / 2 * np.abs(r.tangent) + r.size[1] / 2 * np.abs(r.bitangent)).max())
    for e in scene.ellipsoids:
        parts.append((np.abs(e.center) + np.linalg.norm(e.matrix, axis=1)).max())
    for shape in [*scene.disks, *scene.cylinders]:  # the local unit box [-1, 1]^2 x [-1, 1]: around either
        m = shape.matrix
        parts.append((np.abs(m[:3, 3]) + np.abs(m[:3, :3]).sum(axis=1)).max())
    for inst in scene.instances:  # the group's box placed
        parts.append(np.abs(np.concatenate(inst.bounds(scene.groups[inst.group]))).max())
    return float(max(parts)) + max([height_reach(scene, m) for m in scene.materials], default=0.0)


def height_reach(scene, material):
    """How far the material's height map can move a shading point: height_scale times the largest height a
    lookup can return (filters blend texels, so that of the largest |texel| of any level; 8-bit maps read
    [0, 1], float maps any value)."""
    if material.height_map < 0:
        return 0.0
    texture = scene.textures[material.height_map]
    if texture.encoding not in structs.FLOAT_TEXELS:
        return abs(material.height_scale)
    largest = max(float(np.abs(level[:, :, 0]).max()) for level in texture.levels)
    return abs(material.height_scale) * largest


def culled_subtrees(nodes, prims):
    """Per node, the bits of the rectangles its subtree holds when it holds nothing but rectangles among
    the first CULLED_RECTANGLES (those shadow rays may skip, light_structs), else 0: a shadow ray that
    skips all of them skips the node unopened (bvh.cl). Leaves first, a slot at a time, then each interior
    node from its two children, repeated until nothing changes (at most the tree's depth, all nodes at
    once)."""
    index, kind = prims >> structs.PRIM_KIND_BITS, prims & (structs.PRIM_KINDS - 1)
    cullable = (kind == structs.SHAPES["rectangle"]) & (index < CULLED_RECTANGLES)
    out = np.zeros(len(nodes), np.uint32)
    if not cullable.any():
        return out
    bits = np.where(cullable, np.left_shift(np.uint32(1), np.minimum(index, 31).astype(np.uint32)), 0)
    count, first = nodes["count"], nodes["offset"]
    leaves = np.flatnonzero(count > 0)
    ored, only = np.zeros(len(leaves), np.uint32), np.ones(len(leaves), bool)
    for k in range(count.max()):  # at most bvh.build's max_leaf slots
        has = count[leaves] > k
        ored[has] |= bits[first[leaves[has]] + k]
        only[has] &= cullable[first[leaves[has]] + k]
    out[leaves] = np.where(only, ored, 0)
    inner = np.flatnonzero(count <= 0)
    while True:
        left, right = out[inner + 1], out[first[inner]]
        value = np.where((left != 0) & (right != 0), left | right, 0)
        if np.array_equal(value, out[inner]):
            return out
        out[inner] = value
