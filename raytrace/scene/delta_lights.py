"""Mitsuba 3's emitters that are no shape, in a scene file's [[emitters]] tables: `point`, `spot`, `directional` and
`projector` (src/emitters/*.cpp of v3.9.1), with Mitsuba's parameter names and defaults, read into the model's
PointEmitter, SpotEmitter, DirectionalEmitter and ProjectorEmitter (model.py), appended to Scene.emitters after
the emitting shapes' entries. They are delta lights (pbrt-v4 section 12.1): the radiometric models sample each
once per light sample, and no ray meets them (kernels/emitters.cl's sample_delta). The power each emits
(emitter_power.py) is what a light selection by power weighs them by.

    [[emitters]]
    type = "spot"
    to_world = [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 3], [0, 0, 0, 1]]  # at (0, 0, 3), looking down
    intensity = [10, 9, 8]
    cutoff_angle = 30
"""
import math

import numpy as np

from . import keys, texture_lookups
from .model import DirectionalEmitter, PointEmitter, ProjectorEmitter, SpotEmitter
from .transform import AFFINE

FROM_TO_WORLD = "give either it or to_world (Mitsuba's rule)"
FOV_OR_FOCAL_LENGTH = "give either a focal length or a field of view (fov)"  # (a sensor's too: mitsuba.py)


def read(r, scene, textures, rgb, own_keys):
    """Append the emitter of [[emitters]] table reader `r` (a scene_file.Reader of table "emitters[]") to
    scene.emitters; `textures` (a textures.TextureCache) reads images, `rgb` and `own_keys` are scene_file's."""
    kind = r.string("type")
    r.spec = {**r.spec, **keys.table(f'emitters[] type = "{kind}"')}
    r.check_keys()
    if kind == "point":
        if r.has("position") and r.has("to_world"):
            r.fail("position", r.raw("position"), FROM_TO_WORLD)
        position = r.vector("position") if r.has("position") else to_world(r, invertible=False)[:3, 3]
        scene.emitters.append(PointEmitter(position, rgb(r, "intensity")))
    elif kind == "directional":
        if r.has("direction") and r.has("to_world"):
            r.fail("direction", r.raw("direction"), FROM_TO_WORLD)
        direction = r.vector("direction") if r.has("direction") else to_world(r)[:3, 2]
        if not np.linalg.norm(direction) > 0:
            r.fail("to_world", r.raw("to_world"), "maps +z to no direction")
        scene.emitters.append(DirectionalEmitter(direction / np.linalg.norm(direction), rgb(r, "irradiance")))
    elif kind == "spot":
        cutoff = r.number("cutoff_angle")
        beam = r.number("beam_width") if r.has("beam_width") else None
        texture = _texture(r, "texture", textures, rgb, own_keys) if r.has("texture") else None
        check_spot(r, cutoff, beam, texture is not None)
        scene.emitters.append(SpotEmitter(to_world(r), rgb(r, "intensity"), cutoff, beam, texture))
    else:
        texture, aspect = None, 1.0
        if texture_lookups.is_texture(r.raw("irradiance", 1.0)):
            texture = _texture(r, "irradiance", textures, rgb, own_keys)
            if texture.kind == "bitmap":  # Mitsuba's resolution(): an image's; a checkerboard's 1 x 1
                height, width = textures.textures[texture.texture].levels[0].shape[:2]
                aspect = width / height
            irradiance = np.ones(3)
        else:
            irradiance = rgb(r, "irradiance")
        scene.emitters.append(ProjectorEmitter(to_world(r), fov_x(r, aspect), irradiance, r.number("scale"),
                                               texture, aspect))


def check_spot(r, cutoff, beam, textured):
    """A spot's angles (degrees): beam_width (None: 3/4 of the cutoff) at most cutoff_angle, and with a texture
    a cutoff below 90 degrees, whose tangent spans the image."""
    if beam is not None and not beam <= cutoff:
        r.fail("beam_width", beam, f"must be at most cutoff_angle ({cutoff:g}): Mitsuba's falloff ramps down "
               "from beam_width to cutoff_angle")
    if textured and not cutoff < 90:
        r.fail("cutoff_angle", cutoff, "must be below 90 with a texture, which the cone's tangent spans")


def to_world(r, invertible=True):
    """The table's to_world (4 x 4; the identity where it gives none): affine, and invertible where asked."""
    if not r.has("to_world"):
        return np.eye(4)
    m = r.vectors("to_world")
    if not np.array_equal(m[3], [0, 0, 0, 1]) or (invertible and not abs(np.linalg.det(m[:3, :3])) > 0):
        r.fail("to_world", m.tolist(), AFFINE)
    if invertible and not np.abs(np.linalg.inv(m[:3, :3])).max() <= float(np.finfo(np.float32).max):
        r.fail("to_world", m.tolist(), "its inverse is beyond float32's range")
    return m


def _texture(r, key, textures, rgb, own_keys):
    """The TextureLookup of texture table `key`: an image or a checkerboard (a mesh attribute is a surface's)."""
    value = r.raw(key)
    if not texture_lookups.is_texture(value):
        r.fail(key, value, texture_lookups.TEXTURE_TABLE)
    lookup, _ = texture_lookups.read(type(r)(r.path, value, f"{r.prefix}{key}.", "texture"), "colour", textures,
                                     rgb, own_keys)
    if lookup.kind == "mesh_attribute":
        r.fail(f"{key}.type", lookup.kind, "a light's image must be a bitmap or a checkerboard (a mesh attribute "
               "is a surface's)")
    return lookup


def fov_x(r, aspect):
    """The horizontal field of view (degrees) of a projector's fov, fov_axis or focal_length for an image of
    width / height `aspect` (Mitsuba's parse_fov)."""
    if r.has("fov") and r.has("focal_length"):
        r.fail("focal_length", r.raw("focal_length"), FOV_OR_FOCAL_LENGTH)
    if r.has("fov_axis") and not r.has("fov"):
        r.fail("fov_axis", r.raw("fov_axis"), "only with fov")
    if r.has("fov"):
        fov, axis = r.number("fov"), r.string("fov_axis")
        if axis == "smaller":
            axis = "y" if aspect > 1 else "x"
        elif axis == "larger":
            axis = "x" if aspect > 1 else "y"
    else:
        fov, axis = 2 * math.degrees(math.atan(math.hypot(36, 24) / (2 * r.number("focal_length")))), "diagonal"
    t = math.tan(math.radians(fov) / 2)
    half_width = {"x": t, "y": t * aspect, "diagonal": t / math.sqrt(1 + 1 / aspect ** 2)}[axis]
    return 2 * math.degrees(math.atan(half_width))
