"""A scene model's values read back through the scene file's reader (scene_file.Reader), under the declaration
of the key each came from (keys.py), then the scene's rules (rules.py): what render() runs on a model that was
built or changed in Python (dataclasses.replace, a list appended to) rather than read by scene_file.py, and on
the final model that render()'s options make of a scene, so that no value reaches the kernel unchecked,
whatever the path.

A value is named as the scene file names it (camera.fov, render.spp, materials.red.shininess, lights[0].colour),
and shapes by their place in the model (rectangles[0].size, triangles[5].vertices). A fingerprint of the model
(model.fingerprint), taken when a check passes, lets a scene that has not changed since skip the work.
"""
import numpy as np

from . import bsdfs, ranges, rules
from .. import structs
from ..errors import TRUE_OR_FALSE, InputError
from ..numerics import FLOAT32_MAX
from . import delta_lights
from .model import (RADIOMETRIC, WRAPPERS, Camera, Cylinder, Disk, DirectionalEmitter, Ellipsoid, EnvironmentMap, Light,
                    MeshShape, PointEmitter, ProjectorEmitter, Rectangle, Instance, ShapeEmitter, ShapeGroup,
                    SpotEmitter, TextureLookup, Triangle, fingerprint)
from .environment_map import ROWS_PROBLEM
from .textures import check_pixels
from .scene_file import (CAMERA_KEYS, LIGHTS_SPEC, RFILTER_KEYS, Reader, read_camera, read_film, check_affine_shape,
                         check_axes, check_frame, check_triangle, map_placement)

# (the model's attribute, the key of keys.py's table it was read from)
CAMERA = [("position", "position"), ("look_at", "look_at"), ("ref_up", "up"), ("fov_deg", "fov"),
          ("focal_length", "focal_length"), ("kind", "type"), ("near_clip", "near_clip"), ("far_clip", "far_clip"),
          ("aperture_radius", "aperture_radius"), ("focus_distance", "focus_distance"), ("size", "size")]
RECTANGLE = [("center", "center"), ("size", "size"), ("normal", "normal"), ("tangent", "tangent")]
MATERIAL = [("colour", "colour"), ("shininess", "shininess"), ("height_scale", "height_scale"),
            ("uv_scale", "uv_scale"), ("uv_offset", "uv_offset"), ("wrap", "wrap"), ("bsdf", "type")]
# The BSDFs' fields (bsdfs.py): each checked under the key that sets it in its material's type, else under the
# first type's that declares it (the kernel is given every field, whichever type reads it); alpha_v where set.
BSDF_FIELDS = ("eta", "k", "int_ior", "ext_ior", "alpha", "alpha_v", "distribution", "specular", "nonlinear",
               "roughness", "anisotropic", "metallic", "principled_specular", "principled_eta", "spec_tint", "sheen",
               "sheen_tint", "clearcoat", "clearcoat_gloss", "spec_trans", "main_specular_sampling_rate",
               "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate", "flatness", "diff_trans",
               "specular_reflectance_sampling_rate", "specular_transmittance_sampling_rate",
               "diffuse_transmittance_sampling_rate")


_value = rules.value
OWN_CAMERA_KEYS = {key for keys in CAMERA_KEYS.values() for key in keys}
# The keys of the image and render tables a model holds as attributes of the same name.
IMAGE = ("width", "height")
RENDER = ("spp", "light_samples", "sampler", "light_sampler", "light_selection", "shading", "max_depth", "seed",
          "rr_depth", "hide_emitters", "bsdf_samples")
READ = {"number": "number", "integer": "integer", "string": "string", "vector": "vector", "number-or-vector": "vector",
        "vectors": "vectors", "number-or-name": "number_or_name", "boolean": "boolean"}


def _reader(source, prefix, spec, obj, fields):
    """A scene-file reader over the values of `obj`, as its table would have held them."""
    return Reader(source, {key: _value(getattr(obj, attr)) for attr, key in fields}, prefix, spec)


def _read(reader, fields):
    for _, key in fields:
        getattr(reader, READ[reader.spec[key].kind])(key)


def _check_bsdf(source, m):
    """A material's BSDF fields read back under their keys (bsdfs.py), as its type's table would hold them."""
    own = {}
    for p in bsdfs.BY_NAME[m.bsdf].parameters:
        if p.key is not None and len(p.fields) == 1:
            own.setdefault(p.fields[0], p.key)  # alpha, not alpha_u: the first key of a field
    declared = {field: own.get(field) or bsdfs.declaring(field)[0] for field in BSDF_FIELDS}
    # one key of each name: a principled's own eta (its principled_eta), else a conductor's (the field eta) where
    # principled_eta is None, as it is on every other type
    mine = {key.name: field for field, key in own.items()}
    declared = {field: key for field, key in declared.items() if mine.get(key.name, field) == field
                and not (field == "principled_eta" and getattr(m, field) is None)}
    r = Reader(source, {key.name: _value(getattr(m, field)) for field, key in declared.items()
                        if getattr(m, field) is not None}, f"materials.{m.name}.")
    r.spec = {key.name: key for key in declared.values()}
    for key in declared.values():
        if key.name in r.table:
            getattr(r, READ[key.kind])(key.name)


def _check_wrapper(source, m, count):
    """A blend's or mask's materials and weight."""
    prefix = f"materials.{m.name}."
    wanted = 2 if m.bsdf == "blendbsdf" else 1
    if not isinstance(m.blend, tuple) or len(m.blend) != wanted:
        raise InputError(source, prefix + "blend", m.blend, f"must be a tuple of {wanted} material indices")
    for index in m.blend:
        _index(source, prefix + "blend", index, count)
    key = "weight" if m.bsdf == "blendbsdf" else "opacity"
    r = Reader(source, {key: _value(m.weight)}, prefix, bsdfs.table_name(m.bsdf))
    r.number(key)


def _check_sides(source, m, i, materials):
    """A material's back side: none, or another two-sided material without a back of its own."""
    prefix = f"materials.{m.name}."
    if not isinstance(m.two_sided, bool):
        raise InputError(source, prefix + "two_sided", m.two_sided, TRUE_OR_FALSE)
    if m.back != -1:
        _index(source, prefix + "back", m.back, len(materials))
        other = materials[m.back]
        if m.back == i or other.back != -1 or not other.two_sided:
            raise InputError(source, prefix + "back", m.back, "must be another two-sided material without a back "
                             "of its own")


def _check_maps(source, m, textures):
    """A material's textured parameters: (slot, TextureLookup) pairs of known slots, lookups of known kinds and
    modes, images in the scene's textures, to_uv six finite numbers."""
    prefix = f"materials.{m.name}.maps"
    for entry in m.maps:
        if not (isinstance(entry, tuple) and len(entry) == 2 and entry[0] in structs.MAP_SLOTS
                and isinstance(entry[1], TextureLookup)):
            raise InputError(source, prefix, entry, f"must be (slot, TextureLookup) pairs, slot one of "
                             f"{', '.join(structs.MAP_SLOTS)}")
        lookup = entry[1]
        if lookup.kind not in structs.LOOKUPS or lookup.wrap not in structs.WRAP_MODES or (
                lookup.filter is not None and lookup.filter not in structs.FILTERS):
            raise InputError(source, prefix, lookup, "unknown kind, wrap or filter")
        if lookup.kind == "bitmap":
            _index(source, prefix + ".texture", lookup.texture, textures)
        to_uv = np.asarray(lookup.to_uv, np.float64)
        colours = np.asarray([lookup.colour0, lookup.colour1], np.float64)
        if to_uv.shape != (6,) or not np.all(np.abs(to_uv) <= FLOAT32_MAX) or colours.shape != (2, 3) or not (
                np.all(colours >= 0) and np.all(colours <= FLOAT32_MAX)):
            raise InputError(source, prefix, lookup, LOOKUP_VALUES)


LOOKUP_VALUES = "to_uv must be 6 finite numbers, the colours 3 numbers >= 0"


def check_value(source, table, key, value):
    """`value` checked as key `key` of keys.py's table `table` is in a scene file, named `key` alone (render()'s
    options that override a scene's value: render.py); returns it."""
    reader = Reader(source, {key: value}, "", table)
    getattr(reader, READ[reader.spec[key].kind])(key)
    return value


def _typed(source, prefix, obj, cls):
    if not isinstance(obj, cls):
        Reader(source, {}, prefix).fail("", type(obj).__name__, f"must be a raytrace.scene.{cls.__name__}")


def _check_environment_map(source, scene):
    """The envmap emitter as the scene file's reader would have made it (scene_file._environment)."""
    m = scene.environment_map
    _typed(source, "environment", m, EnvironmentMap)
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
    digest = fingerprint(scene)  # one digest: check_model reads the scene, never changes it
    if scene.checked != digest:
        check_model(scene, source)
        scene.checked = digest


def check_model(scene, source="render()"):
    """Raise InputError at the first value of `scene` a scene file could not have held, or the first rule of
    rules.py it breaks."""
    top = Reader(source, {"ambient": _value(scene.ambient)}, "")
    top.vector("ambient")
    film = ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height", "rfilter", "sample_border",
            *RFILTER_KEYS.get(scene.rfilter, ()))
    image = Reader(source, {key: getattr(scene, key) for key in IMAGE + film if getattr(scene, key) is not None},
                   "image.", "image")
    render = Reader(source, {key: getattr(scene, key) for key in RENDER}, "render.", "render")
    _read(image, [(None, key) for key in IMAGE])
    read_film(image)
    _read(render, [(None, key) for key in RENDER])
    if scene.environment is not None:
        Reader(source, {"radiance": _value(np.asarray(scene.environment, np.float64))}, "environment.",
               "environment").vector("radiance")
    if scene.environment_map is not None:
        _check_environment_map(source, scene)

    _typed(source, "camera.", scene.camera, Camera)
    own = CAMERA_KEYS.get(scene.camera.kind, ())  # the type's own keys; the model holds defaults of the others'
    camera = Reader(source, {key: _value(getattr(scene.camera, attr)) for attr, key in CAMERA
                             if (key in own or key not in OWN_CAMERA_KEYS) and getattr(scene.camera, attr) is not None
                             and not (key == "far_clip" and getattr(scene.camera, attr) == np.inf)}, "camera.",
                    "camera")
    read_camera(camera)

    materials = []
    if not scene.materials:
        top.fail("materials", [], "must hold one or more materials")
    for i, m in enumerate(scene.materials):
        r = _reader(source, f"materials.{m.name}.", "materials.NAME", m, MATERIAL)
        r.table.update(texture=m.colour_map, height_map=m.height_map)  # what ranges.py names in its errors
        _read(r, MATERIAL)
        if m.bsdf in WRAPPERS:
            _check_wrapper(source, m, len(scene.materials))
        else:
            _check_bsdf(source, m)
        for key in ("colour_map", "normal_map", "height_map"):
            if getattr(m, key) != -1:
                _index(source, f"materials.{m.name}.{key}", getattr(m, key), len(scene.textures))
        _check_sides(source, m, i, scene.materials)
        _check_maps(source, m, len(scene.textures))
        materials.append(r)

    emission = "radiance" if scene.shading in RADIOMETRIC else "colour"
    spec = LIGHTS_SPEC if scene.shading in RADIOMETRIC else "lights[]"
    shapes, lights = [], []
    for i, light in enumerate(scene.lights):
        _typed(source, f"lights[{i}].", light, Light)
        r = _reader(source, f"lights[{i}].", spec, light, RECTANGLE + [("colour", emission)])
        _read(r, RECTANGLE + [("colour", emission)])
        check_frame(r)
        if light.material != -1:
            _index(source, f"lights[{i}].material", light.material, len(scene.materials))
        lights.append(r)

    kinds = [("rectangles", Rectangle, 'shapes[] type = "rectangle"', RECTANGLE),
             ("triangles", Triangle, 'shapes[] type = "triangle"', [("vertices", "vertices")]),
             ("ellipsoids", Ellipsoid, 'shapes[] type = "ellipsoid"', [("center", "center"), ("axes", "axes"),
                                                                        ("flip_normals", "flip_normals")]),
             ("disks", Disk, 'shapes[] type = "disk"', [("to_world", "to_world"), ("flip_normals", "flip_normals")]),
             ("cylinders", Cylinder, 'shapes[] type = "cylinder"',
              [("to_world", "to_world"), ("p0", "p0"), ("p1", "p1"), ("radius", "radius"),
               ("flip_normals", "flip_normals")])]
    for name, cls, spec, fields in kinds:
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
            elif cls is Ellipsoid:
                check_axes(r, np.asarray(shape.axes, np.float64))
            else:
                check_affine_shape(r, shape)
            shapes.append((r, shape))
    for i, shape in enumerate(scene.meshes):
        prefix = f"meshes[{i}]."
        _typed(source, prefix, shape, MeshShape)
        _index(source, prefix + "material", shape.material, len(scene.materials))
        r = Reader(source, {}, prefix)
        for attr in ("vertices", "normals", "uvs"):
            values = getattr(shape.mesh, attr)
            if values is not None and not np.all(np.abs(values) <= ranges.FLOAT32_MAX):  # also NaN
                r.fail(f"mesh.{attr}", None, FINITE_VALUES)
        faces = shape.mesh.faces
        if faces.size and (faces.min() < 0 or faces.max() >= len(shape.mesh.vertices)):
            r.fail("mesh.faces", None, f"must index the {len(shape.mesh.vertices)} vertices")
        shapes.append((Reader(source, {"scale": None}, prefix), shape))
    _check_emitters(source, scene)
    _check_delta_lights(source, scene)
    _check_instances(source, scene)
    rules.check(scene, rules.Places(top, render, camera, materials, lights, shapes))


FINITE_VALUES = "must hold finite float32 numbers"  # a mesh's normals and uvs, the world's or a group's


def _check_instances(source, scene):
    """Scene.groups and Scene.instances as scene_file.py builds them: groups of one or more meshes of finite
    float32 vertices and valid faces, instances naming a group, under an invertible affine map of finite
    float32 values."""
    for i, group in enumerate(scene.groups):
        _typed(source, f"groups[{i}].", group, ShapeGroup)
        r = Reader(source, {}, f"groups.{group.name}.")
        if not group.meshes:
            r.fail("shapes", [], "must hold one or more meshes")
        for k, shape in enumerate(group.meshes):
            _typed(source, f"groups.{group.name}.shapes[{k}].", shape, MeshShape)
            _index(source, f"groups.{group.name}.shapes[{k}].material", shape.material, len(scene.materials))
            faces, vertices = shape.mesh.faces, shape.mesh.vertices
            if not np.all(np.abs(vertices) <= ranges.FLOAT32_MAX) or not faces.size or faces.min() < 0 \
                    or faces.max() >= len(vertices):
                r.fail(f"shapes[{k}].mesh", None, "must hold finite float32 vertices and faces that index them")
            for attr in ("normals", "uvs"):
                values = getattr(shape.mesh, attr)
                if values is not None and not np.all(np.abs(values) <= ranges.FLOAT32_MAX):  # also NaN
                    r.fail(f"shapes[{k}].mesh.{attr}", None, FINITE_VALUES)
            if scene.materials[shape.material].emitter >= 0:
                r.fail(f"shapes[{k}].material", shape.material, "is an emitting shape's own: a group's meshes emit "
                       "nothing (as Mitsuba's shapegroup)")
    for i, inst in enumerate(scene.instances):
        _typed(source, f"instances[{i}].", inst, Instance)
        _index(source, f"instances[{i}].group", inst.group, len(scene.groups))
        m = np.asarray(inst.to_world, np.float64)
        if m.shape != (4, 4) or not np.all(np.abs(m) <= ranges.FLOAT32_MAX) or not np.array_equal(m[3], [0, 0, 0, 1]) \
                or not abs(np.linalg.det(m[:3, :3])) > 0:
            Reader(source, {}, f"instances[{i}].").fail("to_world", _value(m), "must be an invertible affine 4 x 4 "
                                                        "matrix of finite float32 numbers, last row 0 0 0 1")


def _check_emitters(source, scene):
    """Scene.emitters as scene_file.py builds them: each names a material of its own, which names it back and
    which one shape holds (a rectangle, a sphere, a disk or a cylinder, or a mesh's triangles), no light; its
    radiance a scene file's."""
    for i, e in enumerate(scene.emitters):
        prefix = f"emitters[{i}]."
        if isinstance(e, DELTA):
            continue
        _typed(source, prefix, e, ShapeEmitter)
        _index(source, prefix + "material", e.material, len(scene.materials))
        Reader(source, {"radiance": _value(np.asarray(e.radiance, np.float64))}, prefix, "shapes[]").vector("radiance")
        if scene.materials[e.material].emitter != i:
            Reader(source, {}, prefix).fail("material", e.material, f"must be a material of its own, whose emitter "
                                            f"is {i}, not {scene.materials[e.material].emitter}")
        holders = [(kind, k) for kind in ("rectangles", "ellipsoids", "disks", "cylinders", "triangles", "meshes")
                   for k, shape in enumerate(getattr(scene, kind)) if shape.material == e.material]
        kinds = {kind for kind, _ in holders}
        single = kinds & {"rectangles", "ellipsoids", "disks", "cylinders"}
        if not holders or (single and len(holders) > 1):
            Reader(source, {}, prefix).fail("material", e.material, "must be the material of one shape (a mesh's "
                                            f"triangles count as one), not of {len(holders)}: "
                                            f"{', '.join(f'{kind}[{k}]' for kind, k in holders[:4])}")
        if any(light.material == e.material for light in scene.lights):
            Reader(source, {}, prefix).fail("material", e.material, "is an emitting shape's own: no light may "
                                            "reflect with it")
    for j, m in enumerate(scene.materials):
        if m.emitter != -1:
            _index(source, f"materials.{m.name}.emitter", m.emitter, len(scene.emitters))
            if scene.emitters[m.emitter].material != j:
                Reader(source, {}, f"materials.{m.name}.").fail("emitter", m.emitter, "names an emitter of another "
                                                                "material")



DELTA = (PointEmitter, SpotEmitter, DirectionalEmitter, ProjectorEmitter)
# (the model's attribute, the key it was read from) of each delta light (delta_lights.py), by its table's type
DELTA_FIELDS = {PointEmitter: ("point", [("position", "position"), ("intensity", "intensity")]),
                SpotEmitter: ("spot", [("to_world", "to_world"), ("intensity", "intensity"),
                                       ("cutoff_angle", "cutoff_angle"), ("beam", "beam_width")]),
                DirectionalEmitter: ("directional", [("direction", "direction"), ("irradiance", "irradiance")]),
                ProjectorEmitter: ("projector", [("to_world", "to_world"), ("irradiance", "irradiance"),
                                                 ("scale", "scale"), ("fov", "fov")])}


def _check_delta_lights(source, scene):
    """The delta lights of Scene.emitters (delta_lights.py), named by their place among them, as the scene file's
    [[emitters]] tables: their values read back under their keys, to_world affine (and invertible where the light
    has a frame), beam_width within cutoff_angle, their images lookups of the scene's textures."""
    k = 0
    for e in scene.emitters:
        if isinstance(e, ShapeEmitter):
            continue
        prefix = f"emitters[{k}]."
        k += 1
        if not isinstance(e, DELTA):
            Reader(source, {}, prefix).fail("", type(e).__name__, "must be a raytrace.scene.ShapeEmitter, "
                                            "PointEmitter, SpotEmitter, DirectionalEmitter or ProjectorEmitter")
        kind, fields = DELTA_FIELDS[type(e)]
        r = _reader(source, prefix, f'emitters[] type = "{kind}"', e, fields)
        _read(r, fields)
        if kind in ("spot", "projector"):
            delta_lights.to_world(r)
        texture = getattr(e, "texture", None)
        if kind == "spot":
            delta_lights.check_spot(r, e.cutoff_angle, e.beam_width, texture is not None)
        if kind == "projector" and not (isinstance(e.aspect, (int, float)) and 0 < e.aspect <= ranges.FLOAT32_MAX):
            r.fail("aspect", _value(e.aspect), "must be a finite number > 0: the image's width over its height")
        if texture is not None:
            key = "texture" if kind == "spot" else "irradiance"
            if not isinstance(texture, TextureLookup) or texture.kind not in ("bitmap", "checkerboard"):
                r.fail(key, texture, "must be a raytrace.scene.TextureLookup of kind bitmap or checkerboard")
            if texture.kind == "bitmap":
                _index(source, prefix + key + ".texture", texture.texture, len(scene.textures))
            if texture.wrap not in structs.WRAP_MODES or (texture.filter is not None
                                                            and texture.filter not in structs.FILTERS):
                r.fail(key, texture, "unknown wrap or filter")
            to_uv = np.asarray(texture.to_uv, np.float64)
            colours = np.asarray([texture.colour0, texture.colour1], np.float64)
            if to_uv.shape != (6,) or not np.all(np.abs(to_uv) <= FLOAT32_MAX) or colours.shape != (2, 3) or not (
                    np.all(colours >= 0) and np.all(colours <= FLOAT32_MAX)):
                r.fail(key, texture, LOOKUP_VALUES)
