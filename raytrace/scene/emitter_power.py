"""The power each emitter of Scene.emitters emits (float64, the luminance of its RGB power), which a light
selection by power weighs the emitters by: pbrt-v4's Light::Phi (section 12.1 to 12.5) for each kind, with
Mitsuba's parameters.

- an area emitter on a shape (ShapeEmitter), emitting L from its front side: pi A L, which packing.py's
  selection forms from the area it packs for the kernel;
- point: 4 pi I;
- spot: 2 pi I (1 - (cos(beam_width) + cos(cutoff_angle)) / 2), pbrt-v4's SpotLight::Phi (which ramps
  smoothly between the two cones; Mitsuba's linear ramp in the angle differs by little), times its texture's
  mean luminance (the texture spans the square around the cone: an approximation);
- directional: pi r^2 E, r the radius of the sphere around the scene's bounding box (pbrt-v4's
  DistantLight::Phi, Mitsuba's bounding sphere);
- projector: its intensity pi scale E(u, v) / cos^3 integrated over the directions of its image, cos^3 dA on
  the plane z = 1: pi scale A mean(E), A the image's area on that plane (exact; pbrt-v4's ProjectionLight::Phi
  sums the same per pixel).
"""
import math

import numpy as np

from .model import DirectionalEmitter, PointEmitter, ProjectorEmitter, SpotEmitter
from .texture_lookups import luminance, texture_mean


def emitter_power(scene, emitter):
    """Phi of `emitter`, a delta light of scene.emitters (float64 >= 0)."""
    if isinstance(emitter, PointEmitter):
        return 4 * math.pi * luminance(emitter.intensity)
    if isinstance(emitter, SpotEmitter):
        cones = 1 - (math.cos(math.radians(emitter.beam)) + math.cos(math.radians(emitter.cutoff_angle))) / 2
        return 2 * math.pi * luminance(emitter.intensity) * cones * _image_mean(scene, emitter.texture)
    if isinstance(emitter, DirectionalEmitter):
        return math.pi * scene_radius(scene) ** 2 * luminance(emitter.irradiance)
    if isinstance(emitter, ProjectorEmitter):
        half = math.tan(math.radians(emitter.fov) / 2)
        area = (2 * half) * (2 * half / emitter.aspect)
        return math.pi * emitter.scale * area * luminance(emitter.irradiance) * _image_mean(scene, emitter.texture)
    raise TypeError(f"not an emitter: {type(emitter).__name__}")


def _image_mean(scene, lookup):
    """The mean luminance of a light's image (a TextureLookup; 1 for none)."""
    if lookup is None:
        return 1.0
    if lookup.kind == "checkerboard":
        return luminance((np.asarray(lookup.colour0) + np.asarray(lookup.colour1)) / 2)
    return luminance(texture_mean(scene.textures[lookup.texture]))


def scene_radius(scene):
    """The radius of the sphere around the scene's bounding box (its shapes and [[lights]]): half its diagonal."""
    points = [np.zeros((0, 3))]
    for r in [*scene.rectangles, *scene.lights]:
        for sx in (-0.5, 0.5):
            for sy in (-0.5, 0.5):
                points.append((r.center + sx * r.size[0] * r.tangent + sy * r.size[1] * r.bitangent)[None])
    points += [np.asarray(t.vertices, np.float64) for t in scene.triangles]
    points += [m.mesh.vertices for m in scene.meshes]
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    points += [e.center + corners @ np.abs(e.matrix).T for e in scene.ellipsoids]  # the box around it
    points += [corners @ s.matrix[:3, :3].T + s.matrix[:3, 3] for s in [*scene.disks, *scene.cylinders]]
    points += [np.array(inst.bounds(scene.groups[inst.group])) for inst in scene.instances]
    p = np.concatenate(points)
    return float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)) / 2) if len(p) else 0.0
