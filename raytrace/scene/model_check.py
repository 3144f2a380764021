"""The checks of a scene file, applied to a Scene object: what render() runs on a scene that was built or
changed in Python (dataclasses.replace, a list appended to) rather than read by scene_file.py, so that no
value reaches the kernel unchecked, whatever the path.

Each value of the model is read back through the scene file's own reader (scene_file.Reader), under the
declaration of the key it came from (keys.py), and the scene as a whole through ranges.py's rules: the same
checks and the same messages, naming the value by its place in the model (lights[0].colour,
materials[2].shininess, triangles[5].vertices). A fingerprint of the model (model.fingerprint), taken when a
check passes, lets a scene that has not changed since skip the work.
"""
import numpy as np

from . import ranges
from .. import samplers
from .model import (RADIOMETRIC, SHADINGS, Camera, Ellipsoid, EnvironmentMap, Light, MeshShape, Rectangle, Triangle,
                    fingerprint, normalize)
from .environment_map import ROWS_PROBLEM
from .textures import check_pixels
from .scene_file import LIGHTS_SPEC, Reader, check_frame, check_triangle, map_placement

# (the model's attribute, the key of keys.py's table it was read from)
CAMERA = [("position", "position"), ("look_at", "look_at"), ("ref_up", "up"), ("fov_deg", "fov"),
          ("focal_length", "focal_length")]
RECTANGLE = [("center", "center"), ("size", "size"), ("normal", "normal"), ("tangent", "tangent")]
MATERIAL = [("colour", "colour"), ("shininess", "shininess"), ("height_scale", "height_scale"),
            ("uv_scale", "uv_scale"), ("uv_offset", "uv_offset"), ("wrap", "wrap"), ("bsdf", "type"), ("eta", "eta"),
            ("k", "k"), ("int_ior", "int_ior"), ("ext_ior", "ext_ior"), ("alpha", "alpha")]


def _value(x):
    return x.tolist() if isinstance(x, np.ndarray) else x.item() if isinstance(x, np.generic) else x


def _reader(source, prefix, spec, obj, fields):
    """A scene-file reader over the values of `obj`, as its table would have held them."""
    return Reader(source, {key: _value(getattr(obj, attr)) for attr, key in fields}, prefix, spec)


def _read(reader, fields):
    for _, key in fields:
        kind = reader.spec[key].kind
        getattr(reader, {"number": "number", "integer": "integer", "string": "string", "vector": "vector",
                         "number-or-vector": "vector", "vectors": "vectors"}[kind])(key)


def _typed(source, prefix, obj, cls):
    if not isinstance(obj, cls):
        Reader(source, {}, prefix).fail("", type(obj).__name__, f"must be a raytrace.scene.{cls.__name__}")


def _check_environment_map(source, scene):
    """The envmap emitter as the scene file's reader would have made it (scene_file._environment)."""
    m = scene.environment_map
    _typed(source, "environment", m, EnvironmentMap)
    top = Reader(source, {}, "")
    if scene.shading != "path":
        top.fail("environment", m.path, 'is the path model\'s: only with shading = "path"')
    if scene.environment is not None:
        top.fail("environment", _value(scene.environment), "a constant radiance and an envmap cannot both be set")
    e = Reader(source, {"scale": m.scale, "up": _value(m.up), "forward": _value(m.forward)}, "environment.",
               "environment")
    map_placement(e)
    texels = m.texels
    if not (isinstance(texels, np.ndarray) and texels.ndim == 3 and texels.shape[2] == 3 and texels.size
            and texels.dtype.kind == "f"):
        shape = getattr(texels, "shape", type(texels).__name__)
        e.fail("texels", str(shape), "must be a non-empty H x W x 3 float array of linear RGB")
    if texels.shape[0] < 2:
        e.fail("texels", str(texels.shape), ROWS_PROBLEM)
    try:
        check_pixels(texels, "float", "environment")
    except ValueError as problem:
        e.fail("texels", m.path, str(problem))


def _index(source, key, value, count):
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and 0 <= value < count
    if not ok:
        Reader(source, {}, "").fail(key, _value(value), f"must be an index in [0, {count - 1}]")


def ensure_checked(scene, source="render()"):
    """check_model(scene) unless it passed the checks (of its file or of this module) as it is now."""
    if scene.checked != fingerprint(scene):
        check_model(scene, source)
        scene.checked = fingerprint(scene)


def check_model(scene, source="render()"):
    """Raise InputError at the first value of `scene` a scene file could not have held."""
    top = Reader(source, {"ambient": _value(scene.ambient)}, "")
    top.vector("ambient")
    if scene.shading not in SHADINGS:
        top.fail("shading", scene.shading, f"must be one of: {', '.join(SHADINGS)}")
    if scene.shading in RADIOMETRIC and np.any(scene.ambient):
        top.fail("ambient", _value(scene.ambient),
                 f'is the Phong model\'s: shading = "{scene.shading}" has no ambient term')
    image = Reader(source, {"width": scene.width, "height": scene.height}, "", "image")
    image.integer("width"), image.integer("height")
    render = Reader(source, {"spp": scene.spp, "light_samples": scene.light_samples, "sampler": scene.sampler,
                             "light_sampler": scene.light_sampler, "max_depth": scene.max_depth}, "", "render")
    render.integer("spp"), render.integer("light_samples"), render.string("sampler"), render.string("light_sampler")
    render.integer("max_depth")
    if scene.environment is not None:
        if scene.shading != "path":
            top.fail("environment", _value(scene.environment), 'is the path model\'s: only with shading = "path"')
        Reader(source, {"radiance": _value(np.asarray(scene.environment, np.float64))}, "environment.",
               "environment").vector("radiance")
    if scene.environment_map is not None:
        _check_environment_map(source, scene)
    if scene.max_depth != -1 and scene.shading != "path":
        render.fail("max_depth", scene.max_depth, 'is the path model\'s: only with shading = "path"')
    for key, count in (("sampler", "spp"), ("light_sampler", "light_samples")):
        problem = samplers.count_problem(getattr(scene, key), getattr(scene, count))
        if problem:
            render.fail(key, getattr(scene, key), problem)
    problem = samplers.light_problem(scene.light_sampler, scene.light_samples, scene.shading)
    if problem:
        render.fail("light_sampler", scene.light_sampler, problem)

    _typed(source, "camera.", scene.camera, Camera)
    camera = _reader(source, "camera.", "camera", scene.camera, CAMERA)
    _read(camera, CAMERA)
    view = np.asarray(scene.camera.look_at, np.float64) - scene.camera.position
    if not np.any(view):
        camera.fail("look_at", _value(scene.camera.look_at), "must differ from camera.position")
    if np.linalg.norm(np.cross(normalize(view), normalize(np.asarray(scene.camera.ref_up, np.float64)))) < 1e-6:
        camera.fail("up", _value(scene.camera.ref_up), "must not be parallel to the view direction")

    materials = []
    if not scene.materials:
        top.fail("materials", [], "must hold one or more materials")
    for i, m in enumerate(scene.materials):
        r = _reader(source, f"materials[{i}].", "materials.NAME", m, MATERIAL)
        r.table.update(texture=m.colour_map, height_map=m.height_map)  # what ranges.py names in its errors
        _read(r, MATERIAL)
        if m.bsdf != "diffuse" and scene.shading != "path":
            r.fail("type", m.bsdf, 'is the path model\'s: only with shading = "path"')
        for key in ("colour_map", "normal_map", "height_map"):
            if getattr(m, key) != -1:
                _index(source, f"materials[{i}].{key}", getattr(m, key), len(scene.textures))
        materials.append(r)

    emission = "radiance" if scene.shading in RADIOMETRIC else "colour"
    spec = LIGHTS_SPEC if scene.shading in RADIOMETRIC else "lights[]"
    places, lights = [(camera, scene.camera)], []
    if not scene.lights:
        top.fail("lights", [], "must hold one or more lights")
    for i, light in enumerate(scene.lights):
        _typed(source, f"lights[{i}].", light, Light)
        r = _reader(source, f"lights[{i}].", spec, light, RECTANGLE + [("colour", emission)])
        _read(r, RECTANGLE + [("colour", emission)])
        check_frame(r)
        if light.material != -1:
            if scene.shading != "path":
                r.fail("material", light.material, 'a light reflects only in the path model (shading = "path")')
            _index(source, f"lights[{i}].material", light.material, len(scene.materials))
        places.append((r, light))
        lights.append(r)

    shapes = [("rectangles", Rectangle, 'shapes[] type = "rectangle"', RECTANGLE),
              ("triangles", Triangle, 'shapes[] type = "triangle"', [("vertices", "vertices")]),
              ("ellipsoids", Ellipsoid, 'shapes[] type = "ellipsoid"', [("center", "center"), ("axes", "axes")])]
    for name, cls, spec, fields in shapes:
        for i, shape in enumerate(getattr(scene, name)):
            prefix = f"{name}[{i}]."
            _typed(source, prefix, shape, cls)
            r = _reader(source, prefix, spec, shape, fields)
            _read(r, fields)
            _index(source, prefix + "material", shape.material, len(scene.materials))
            if cls is Rectangle:
                check_frame(r)
            elif cls is Triangle:
                check_triangle(r, "vertices", np.asarray(shape.vertices, np.float64))
                if shape.uv is not None:
                    Reader(source, {"uv": _value(shape.uv)}, prefix, spec).vectors("uv")
            else:
                axes = np.asarray(shape.axes, np.float64)
                if not abs(np.linalg.det(axes)) > 1e-6 * np.prod(np.linalg.norm(axes, axis=1)):
                    r.fail("axes", _value(shape.axes), "singular ellipsoid: the three axes must be linearly independent")
            places.append((r, shape))
    for i, shape in enumerate(scene.meshes):
        prefix = f"meshes[{i}]."
        _typed(source, prefix, shape, MeshShape)
        _index(source, prefix + "material", shape.material, len(scene.materials))
        r = Reader(source, {}, prefix)
        for attr in ("vertices", "normals", "uvs"):
            values = getattr(shape.mesh, attr)
            if values is not None and not np.all(np.abs(values) <= ranges.FLOAT32_MAX):  # also NaN
                r.fail(f"mesh.{attr}", None, "must hold finite float32 numbers")
        faces = shape.mesh.faces
        if faces.size and (faces.min() < 0 or faces.max() >= len(shape.mesh.vertices)):
            r.fail("mesh.faces", None, f"must index the {len(shape.mesh.vertices)} vertices")
        places.append((Reader(source, {"scale": None}, prefix), shape))
    ranges.check_scene(scene, places, materials, lights, top)
