"""The ranges a scene's values keep, so that the kernel's float32 arithmetic stays finite. One rule, applied by
scene_file.py and rules.py to every value with its key:

1. Every number is a finite float32, |x| <= FLOAT32_MAX (checked as each value is read).
2. Every point the kernel computes with (the camera and what it looks at, the corners of rectangles and lights,
   an ellipsoid's bounding box, triangle and mesh vertices, points displaced by a height map) lies within
   COORDINATE_LIMIT = 2^60 of the origin on every axis: the squared distance of two such points is then at
   most 3 (2^61)^2 = 2^123.6, and the dot products and sums built from them stay below float32's 2^128.
3. A rectangle's or light's area is a normal float32 (at least 2^-126), and an ellipsoid's shortest
   semi-axis (the smallest singular value of its axes) is at least 2^-60 max(1, extent), the extent being
   the largest coordinate of rule 2: its map into unit-sphere space stretches distances by at most 1 over
   that, so unit-sphere coordinates stay below 2^62 and their squares below 2^124.
4. The brightest value a pixel can take, max(k (ambient + 2 sum L), max L) (k the largest albedo: a colour,
   or a colour map's brightest texel, which replaces it; n.l and the specular power are each at most 1), is at
   most BRIGHTEST_LIMIT = 2^62: the variance image holds squares of pixel values (2^124 at most), and a launch
   sums up to 2^16 light samples in each of up to 2^16 pixel samples (2^94 at most)."""
import math

import numpy as np

from ..numerics import COORDINATE_LIMIT, FLOAT32_MAX, FLOAT32_TINY
from .model import RADIOMETRIC, Camera, Ellipsoid, MeshShape, Rectangle, Triangle

MAX_IMAGE_SIDE = 16384  # pixels, the same for a scene file and the command line
MAX_SAMPLES = 1 << 16   # pixel samples and light samples
ELLIPSOID_AXIS_RATIO = 2.0 ** -60
BRIGHTEST_LIMIT = 2.0 ** 62


def float32_problem(x):
    """Why the number x cannot be a float32 value, or None."""
    if isinstance(x, int) and abs(x) > FLOAT32_MAX:  # a TOML integer may be beyond float64 as well
        return f"beyond float32's range (|x| <= {FLOAT32_MAX:.6g})"
    if not math.isfinite(x):
        return "must be a finite number"
    if abs(x) > FLOAT32_MAX:
        return f"beyond float32's range (|x| <= {FLOAT32_MAX:.6g})"
    return None


def corners(shape):
    """(N, 3) points bounding `shape` (a Camera, Rectangle or Light, Triangle, Ellipsoid or MeshShape)."""
    if isinstance(shape, Camera):
        return np.array([shape.position, shape.look_at])
    if isinstance(shape, Rectangle):
        half = shape.size[0] / 2 * np.abs(shape.tangent) + shape.size[1] / 2 * np.abs(shape.bitangent)
        return np.array([shape.center - half, shape.center + half])
    if isinstance(shape, Ellipsoid):
        half = np.linalg.norm(shape.axes, axis=0)  # the bounding box of center + axes.T @ unit sphere
        return np.array([shape.center - half, shape.center + half])
    if isinstance(shape, Triangle):
        return shape.vertices
    if isinstance(shape, MeshShape):
        v = shape.mesh.vertices
        return np.array([v.min(axis=0), v.max(axis=0)])
    raise TypeError(shape)


def extent(points):
    return float(np.abs(points).max())


def shortest_semi_axis(ellipsoid):
    return float(np.linalg.svd(ellipsoid.axes, compute_uv=False).min())


def largest_texel(texture):
    """The largest value of a texture's colour channels (8-bit codes stand for [0, 1])."""
    level = texture.levels[0]
    return 1.0 if level.dtype == np.uint8 else float(np.abs(level[..., :3]).max())


def largest_albedo(scene, material):
    """The material's largest colour, or the brightest texel of its colour map, which replaces the colour
    (kernels/material.cl's texture_material, docs/textures.md)."""
    if material.colour_map >= 0:
        return largest_texel(scene.textures[material.colour_map])
    return float(np.max(material.colour))


def brightest(scene):
    """An upper bound on every pixel value of the scene's Phong image (rule 4)."""
    k = max(largest_albedo(scene, m) for m in scene.materials)
    lights = [float(light.colour.max()) for light in scene.lights]
    return max(k * (float(scene.ambient.max()) + 2 * sum(lights)), *lights)


def _far_key(shape):
    """The key of `shape`'s table that places it: its position or centre when that is beyond the limit
    itself, else what reaches out from it."""
    anchor, reach = {Camera: ("position", "look_at"), Ellipsoid: ("center", "axes"), Triangle: ("vertices",) * 2,
                     MeshShape: ("scale", "scale")}.get(type(shape), ("center", "size"))
    at = shape.position if isinstance(shape, Camera) else getattr(shape, "center", None)
    return anchor if at is None or np.abs(at).max() > COORDINATE_LIMIT else reach


def _check_extents(places):
    """Rule 2, naming the first shape beyond it; returns the scene's extent."""
    largest = 1.0
    for reader, shape in places:
        far = extent(corners(shape))
        if far > COORDINATE_LIMIT:
            key = _far_key(shape)
            reader.fail(key, reader.raw(key), f"puts a point {far:.4g} from the origin, beyond the {COORDINATE_LIMIT:.4g} "
                        "(2^60) within which float32 arithmetic on coordinates stays finite")
        largest = max(largest, far)
    return largest


def _check_sizes(places, scale):
    """Rule 3."""
    for reader, shape in places:
        if isinstance(shape, Rectangle) and not (shape.size.min() >= FLOAT32_TINY
                                                 and shape.size.prod() >= FLOAT32_TINY):
            reader.fail("size", reader.raw("size"), f"both sides and the area must be at least {FLOAT32_TINY:.4g} "
                        "(normal float32 numbers)")
        if isinstance(shape, Ellipsoid) and shortest_semi_axis(shape) < ELLIPSOID_AXIS_RATIO * scale:
            reader.fail("axes", reader.raw("axes"), f"shortest semi-axis {shortest_semi_axis(shape):.4g} below 2^-60 "
                        f"of the scene's extent {scale:.4g}: unit-sphere coordinates would overflow float32")


def _check_heights(scene, material_readers):
    """Rule 2 for the points a height map displaces."""
    for material, reader in zip(scene.materials, material_readers):
        if material.height_map >= 0:
            reach = material.height_scale * largest_texel(scene.textures[material.height_map])
            if reach > COORDINATE_LIMIT:
                reader.fail("height_scale", material.height_scale, f"with {reader.raw('height_map')} displaces points "
                            f"by up to {reach:.4g}, beyond "
                            f"the {COORDINATE_LIMIT:.4g} (2^60) within which float32 coordinates stay finite")


def _check_brightness(scene, material_readers, light_readers, scene_reader):
    """Rule 4, naming the largest factor: the brightest light, the largest albedo or the ambient term."""
    value = brightest(scene)
    if value <= BRIGHTEST_LIMIT:
        return
    albedos = [largest_albedo(scene, m) for m in scene.materials]
    lights = [float(light.colour.max()) for light in scene.lights]
    brightest_material = int(np.argmax(albedos))
    material_key = "texture" if scene.materials[brightest_material].colour_map >= 0 else "colour"
    terms = {(scene_reader, "ambient"): float(scene.ambient.max()),
             (light_readers[int(np.argmax(lights))], "radiance" if scene.shading in RADIOMETRIC else "colour"): max(lights),
             (material_readers[brightest_material], material_key): max(albedos)}
    reader, key = max(terms, key=terms.get)
    reader.fail(key, reader.raw(key), f"makes a pixel as bright as {value:.4g}, beyond the "
                f"{BRIGHTEST_LIMIT:.4g} (2^62) up to which float32 sums of samples and squares of pixel values stay finite")


def check_scene(scene, places, material_readers, light_readers, scene_reader):
    """Rules 2 to 4 for a parsed scene. `places` pairs the camera, each light and each shape with the reader
    of its table (whose fail(key, value, problem) names the file and the key); the other readers are those
    of the materials (in order), the lights (in order) and the whole file."""
    scale = _check_extents(places)
    _check_sizes(places, scale)
    _check_heights(scene, material_readers)
    _check_brightness(scene, material_readers, light_readers, scene_reader)
