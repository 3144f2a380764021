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


def _map(scene, point, length):
    replace = dataclasses.replace
    cam = scene.camera
    camera = replace(cam, position=point(cam.position), look_at=point(cam.look_at))
    rect = lambda r: replace(r, center=point(r.center), size=length(r.size))  # noqa: E731
    return replace(
        scene, camera=camera, lights=[rect(light) for light in scene.lights],
        rectangles=[rect(r) for r in scene.rectangles],
        triangles=[replace(t, vertices=point(t.vertices)) for t in scene.triangles],
        meshes=[replace(m, mesh=replace(m.mesh, vertices=point(m.mesh.vertices))) for m in scene.meshes],
        ellipsoids=[replace(e, center=point(e.center), axes=length(e.axes)) for e in scene.ellipsoids])


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
