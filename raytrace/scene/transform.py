"""Similarity transforms of a whole scene: x -> scale x + offset applied to the camera, the lights and every
shape, in float64 before the scene is packed for the kernel. The image of a scene must not depend on where it
sits or on its unit of length; the robustness tests and `python -m raytrace stability` check this.

A transformed scene is stored in float32, which rounds each coordinate by up to half a float spacing at its
magnitude: 2^-24 |x|, about 6e-4 at 1e4. That moves every point of a small scene far from the origin by a
visible fraction of its size, whatever the renderer does. `stored_back` gives the scene with exactly that
rounding undone by the inverse transform, so that the renderer's own error can be told apart from it."""
import dataclasses

import numpy as np

from ..numerics import f32
from .model import normalize


def _map(scene, point, length):
    replace = dataclasses.replace
    cam = scene.camera
    lengths = {k: float(length(getattr(cam, k))) for k in ("near_clip", "far_clip", "aperture_radius",
                                                           "focus_distance", "dropped_near_clip")
               if getattr(cam, k) is not None}
    if cam.size is not None:  # an orthographic view's
        lengths["size"] = length(cam.size)
    camera = replace(cam, position=point(cam.position), look_at=point(cam.look_at), **lengths)
    rect = lambda r: replace(r, center=point(r.center), size=length(r.size))  # noqa: E731
    return replace(
        scene, camera=camera, lights=[rect(light) for light in scene.lights],
        rectangles=[rect(r) for r in scene.rectangles],
        triangles=[replace(t, vertices=point(t.vertices)) for t in scene.triangles],
        meshes=[replace(m, mesh=replace(m.mesh, vertices=point(m.mesh.vertices))) for m in scene.meshes],
        ellipsoids=[replace(e, center=point(e.center), axes=length(e.axes)) for e in scene.ellipsoids],
        disks=[replace(k, to_world=_mapped(k.to_world, point, length)) for k in scene.disks],
        cylinders=[replace(k, to_world=_mapped(k.to_world, point, length)) for k in scene.cylinders])


def _mapped(to_world, point, length):
    """A disk's or cylinder's to_world followed by the similarity: its origin a point, its axes lengths."""
    m = np.array(to_world, np.float64)
    m[:3, 3], m[:3, :3] = point(m[:3, 3]), length(m[:3, :3])
    return m


def transformed(scene, scale=1.0, offset=(0.0, 0.0, 0.0)):
    """A copy of `scene` with every point x at scale * x + offset and every length times scale (scale > 0)."""
    offset = np.asarray(offset, dtype=np.float64)
    return _map(scene, lambda x: scale * np.asarray(x, np.float64) + offset, lambda v: scale * np.asarray(v))


def stored_back(scene, scale=1.0, offset=(0.0, 0.0, 0.0)):
    """`scene` as `transformed(scene, scale, offset)` stores it in float32, mapped back by the inverse
    transform in float64: the same geometry as the transformed scene's, placed where float32 resolves it."""
    offset = np.asarray(offset, dtype=np.float64)
    return _map(scene, lambda x: (f32(scale * np.asarray(x, np.float64) + offset) - offset) / scale,
                lambda v: f32(scale * np.asarray(v)) / scale)


AFFINE = "must be affine (last row 0 0 0 1) and invertible"  # a mesh's matrix, a Mitsuba to_world


def mesh_matrix(scale, axis, degrees, translate):
    """4 x 4 matrix of x -> translate + R(axis, degrees) (scale * x), acting on column vectors (Rodrigues)."""
    k = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    angle = np.radians(degrees)
    m = np.eye(4)
    m[:3, :3] = (np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross) @ np.diag(scale)
    m[:3, 3] = translate
    return m


# The course's shapes under a 4 x 4 affine matrix m (a scene file's scale, rotate, translate or matrix keys), in
# float64. In every one the front of the image is the image of the front, as a mesh's (scene_file.py reverses
# a mirrored mesh's faces) and Mitsuba's rectangle (its normal is to_world's inverse transpose of +z) have it.

# A rectangle's image is one where its sides L t and L b stay at right angles. Their cosine is computed from
# t and b (unit and orthogonal to a few roundings) and L (the product of a few rounded factors), whose errors
# are within a few float64 roundings eps of their largest terms: of sigma_1 in L t and L b, which are at least
# sigma_3 long (the singular values of L). So an exact rectangle's image has a computed cosine within c eps
# kappa, kappa = sigma_1 / sigma_3, c counting the roundings (about 2 x 15 for a product of three factors and
# the dot product): SHEAR_ROUNDINGS = 64 leaves twice that. A transform that turns the sides further shears the
# rectangle into a parallelogram, which a rectangle cannot be (a mesh can).
SHEAR_ROUNDINGS = 64


def rectangle_shear(m, normal, tangent):
    """|cos| of the angle between the images of a rectangle's sides (unit normal and tangent) under m, and
    the largest a rectangle's image can show through float64's rounding (SHEAR_ROUNDINGS eps kappa)."""
    linear = m[:3, :3]
    s, t = linear @ tangent, linear @ np.cross(normal, tangent)
    cosine = abs(np.dot(s, t)) / (np.linalg.norm(s) * np.linalg.norm(t))
    return cosine, SHEAR_ROUNDINGS * np.finfo(np.float64).eps * np.linalg.cond(linear)


def placed_rectangle(m, center, size, normal, tangent):
    """(center, size, normal, tangent) of the rectangle's image under m (rectangle_shear must allow it): the
    centre mapped; the sides tangent * size x and bitangent * size y by the linear part L; the normal by L's
    inverse transpose, which keeps the front (n' . L n = n . n > 0: the image of a point in front is in front,
    mirror or not). For sides at right angles that normal is sign(det L) (L t x L b) / |L t x L b| (L t x L b =
    det L L^-T (t x b), t x b = n), computed so: at right angles to the sides it spans whatever L's condition.
    The model's bitangent, normal x tangent, is then L b's direction times sign(det L): a mirror's rectangle
    has the same points and front, its v axis (a texture's) turned, as Mitsuba's rectangle read by mitsuba.py
    has."""
    linear = m[:3, :3]
    s, t = linear @ tangent, linear @ np.cross(normal, tangent)
    n = np.cross(s, t) * np.sign(np.linalg.det(linear))
    return (linear @ center + m[:3, 3], size * np.array([np.linalg.norm(s), np.linalg.norm(t)]),
            normalize(n) + 0.0, normalize(s) + 0.0)  # + 0.0: no -0.0 (the kernel's frames test signs)


BARYCENTRIC_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # a triangle's uv where none is given: (b1, b2)


def placed_triangle(m, vertices, uv):
    """(vertices, uv) of a triangle's image under m: its corners mapped, in the reverse order under a mirror
    (det L < 0), so that they stay counter-clockwise seen from the image of the front, each with its own uv
    (where none is given, the (b1, b2) it had, which the new order would otherwise swap): every point keeps
    its (u, v)."""
    vertices = vertices @ m[:3, :3].T + m[:3, 3]
    if np.linalg.det(m[:3, :3]) < 0:
        return vertices[[0, 2, 1]], (BARYCENTRIC_UV if uv is None else uv)[[0, 2, 1]]
    return vertices, uv


def placed_ellipsoid(m, center, axes):
    """(center, axes) of an ellipsoid's image under m: M (c + [a b c] x) = M c + [L a, L b, L c] x, so the
    axes (rows a, b, c) are mapped by the linear part L. Its outside stays outside: no orientation to keep."""
    return m[:3, :3] @ center + m[:3, 3], axes @ m[:3, :3].T
