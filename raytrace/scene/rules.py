"""The rules that hold between a scene's values, each stated here and nowhere else.

A key's own type, default and range are keys.py's, checked by the reader of its table (scene_file.Reader). What
holds between values is here: between keys of one table (a camera's look_at apart from its position, a rough
interface's two indices of refraction apart), between a value and the shading model (a mirror is the path
model's, an ambient term the Phong model's), between a sample pattern and its count, and the float32 ranges of
the scene as a whole (ranges.py). They run once on the final model, whatever made it:

- a scene file, a dict or a string (scene_file.parse_scene), and so a parameter edit (parameters.py re-reads
  the edited table);
- a model changed in Python, behind the reader's checks (model_check.py reads its values back first);
- render()'s and the command line's overrides (width, height, spp, light_samples, sampler, light_sampler,
  shading, max_depth), which render.py applies to the model before the model is checked.

Each rule fails through the reader of the table its value lives in (a Places), which names the source and the
key as the scene file spells it: the same bad combination gives the same line from every entry, e.g.
`materials.gold.type = 'conductor': is the path model's: only with shading = "path", not "phong"`.
"""
from dataclasses import dataclass, field

import numpy as np

from . import bsdfs, meshes, ranges, texture_lookups
from .. import samplers
from .model import RADIOMETRIC, RR_DEPTH, Ellipsoid, MeshShape, ShapeEmitter, Triangle, normalize
from ..numerics import FLOAT32_MAX


@dataclass
class Places:
    """The readers (scene_file.Reader) that name each part of a scene: the top-level table (ambient,
    environment), the render and camera tables, the materials and the lights (in the model's order), and the
    shapes as (reader, shape) pairs."""
    top: object
    render: object
    camera: object
    materials: list
    lights: list
    shapes: list = field(default_factory=list)


def value(x):
    """A model value as a scene file would show it: numpy arrays and scalars as Python lists and numbers."""
    return x.tolist() if isinstance(x, np.ndarray) else x.item() if isinstance(x, np.generic) else x


def _path_only(reader, key, shown, shading):
    """What only the path model renders (a BSDF other than diffuse, a bounded depth, a light that reflects), in a
    scene of another shading model."""
    if shading != "path":
        reader.fail(key, value(shown), f'is the path model\'s: only with shading = "path", not "{shading}"')


def _radiometric_only(reader, key, shown, shading):
    """An emitter other than [[lights]] (an emitting shape, a delta light) in a scene of the Phong model."""
    if shading not in RADIOMETRIC:
        reader.fail(key, value(shown), f'is the radiometric models\' (shading = "direct" or "path"), not '
                    f'"{shading}": the Phong model\'s lights are [[lights]]')


def _shading(scene, places):
    """The values that belong to one shading model."""
    if scene.shading in RADIOMETRIC and np.any(scene.ambient):
        places.top.fail("ambient", value(scene.ambient),
                        f'is the Phong model\'s: shading = "{scene.shading}" has no ambient term')
    if scene.max_depth != -1:
        _path_only(places.render, "max_depth", scene.max_depth, scene.shading)
    if scene.rr_depth != RR_DEPTH:
        _path_only(places.render, "rr_depth", scene.rr_depth, scene.shading)
    if scene.hide_emitters and scene.shading not in RADIOMETRIC:
        places.render.fail("hide_emitters", True, 'hides the radiometric models\' emitters: only with shading = '
                           f'"direct" or "path", not "{scene.shading}"')
    if scene.bsdf_samples != 0 and scene.shading != "direct":
        places.render.fail("bsdf_samples", scene.bsdf_samples, 'is the direct model\'s: only with shading = '
                           f'"direct", not "{scene.shading}" (the path model samples its BSDFs at every vertex)')
    if scene.environment is not None and scene.environment_map is not None:
        places.top.fail("environment", value(scene.environment), "a constant radiance and an envmap cannot both be set")
    if scene.environment is not None or scene.environment_map is not None:
        shown = scene.environment if scene.environment is not None else scene.environment_map.path
        _radiometric_only(places.top, "environment", shown, scene.shading)
    elif not scene.lights and not scene.emitters:  # the environment, the radiometric models', is the only other
        places.top.fail("lights", [], "must hold one or more lights: only a scene with an [environment], "
                        "[[emitters]] or a shape with radiance (shading = \"direct\" or \"path\") needs none")
    for material, reader in zip(scene.materials, places.materials):
        if material.bsdf != "diffuse":
            _path_only(reader, "type", material.bsdf, scene.shading)
    for light, reader in zip(scene.lights, places.lights):
        if light.material != -1:
            _path_only(reader, "material", scene.materials[light.material].name, scene.shading)
    for reader, shape in places.shapes:
        _shape_emitter(scene, reader, shape)
    _emitting_areas(scene, places)
    delta = [e for e in scene.emitters if not isinstance(e, ShapeEmitter)]
    if delta and scene.shading not in RADIOMETRIC:  # (the delta lights are named by their place among them)
        kind = type(delta[0]).__name__.removesuffix("Emitter").lower()
        _radiometric_only(places.top, "emitters[0].type", kind, scene.shading)


def _emitting_areas(scene, places):
    """An emitting mesh has an area in float32, the precision its triangles are stored and sampled in
    (emitters.cl chooses them by area): triangles valid in float64 may all round to lines far from the origin."""
    areas, first = {}, {}
    for reader, shape in places.shapes:
        material = scene.materials[shape.material]
        if material.emitter < 0 or not isinstance(shape, (Triangle, MeshShape)):
            continue
        v = (np.asarray(shape.vertices, np.float32)[None] if isinstance(shape, Triangle)
             else np.asarray(shape.mesh.vertices, np.float32)[shape.mesh.faces]).astype(np.float64)
        area = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum()
        areas[material.emitter] = areas.get(material.emitter, 0.0) + area
        first.setdefault(material.emitter, reader)
    for emitter, area in areas.items():
        if not area > 0:
            first[emitter].fail("radiance", value(scene.emitters[emitter].radiance), "the emitting shape has no "
                                "area once its corners are rounded to float32 (it is too small for where it is)")


def _shape_emitter(scene, reader, shape):
    """An emitting shape (ShapeEmitter): a radiometric model's, black in the direct model (as its lights are),
    and among ellipsoids a sphere, which emitters.cl samples by the cone it subtends."""
    material = scene.materials[shape.material]
    if material.emitter < 0:
        return
    emitter = scene.emitters[material.emitter]
    _radiometric_only(reader, "radiance", emitter.radiance, scene.shading)
    if emitter.reflects:
        _path_only(reader, "material", material.name, scene.shading)
    if isinstance(shape, Ellipsoid):
        gram = shape.axes @ shape.axes.T
        if not np.allclose(gram, np.mean(np.diag(gram)) * np.eye(3), rtol=0, atol=1e-6 * np.max(np.diag(gram))):
            reader.fail("axes", value(shape.axes), "an emitting ellipsoid must be a sphere (three orthogonal axes "
                        "of one length): area lights are sampled by the cone a sphere subtends")


def _bsdfs(scene, places):
    """A rough interface refracts only between different indices (bsdfs.py's declarations say which)."""
    for material, reader in zip(scene.materials, places.materials):
        if material.bsdf in bsdfs.BY_NAME and bsdfs.BY_NAME[material.bsdf].distinct_iors and material.int_ior == material.ext_ior:
            reader.fail("int_ior", value(material.int_ior), f'must differ from ext_ior for type = "{material.bsdf}" '
                        "(Mitsuba's rule for its rough interfaces: at equal indices the half-vector of refraction "
                        "vanishes)")
        if material.bsdf == "principled" and None not in (material.principled_eta, material.principled_specular):
            reader.fail("eta", value(material.principled_eta), "not with specular, which sets it (Mitsuba's rule: "
                        "eta = 2 / (1 - sqrt(0.08 specular)) - 1); give one or the other")


def _patterns(scene, render):
    """Each pattern takes the sample count it is given (the grids a square), and a radiometric model's light
    samples are not one fixed point."""
    for key, count in (("sampler", "spp"), ("light_sampler", "light_samples")):
        problem = samplers.count_problem(getattr(scene, key), getattr(scene, count))
        if problem:
            render.fail(key, getattr(scene, key), f"{problem}, not {count} = {getattr(scene, count)}")
    problem = samplers.light_problem(scene.light_sampler, scene.light_samples, scene.shading)
    if problem:
        render.fail("light_sampler", scene.light_sampler, problem)


def _camera(camera, reader):
    """A view direction, and an up direction off it."""
    view = np.asarray(camera.look_at, np.float64) - np.asarray(camera.position, np.float64)
    if not np.any(view):
        reader.fail("look_at", value(camera.look_at), "must differ from camera.position")
    if np.linalg.norm(np.cross(normalize(view), normalize(np.asarray(camera.ref_up, np.float64)))) < 1e-6:
        reader.fail("up", value(camera.ref_up), "must not be parallel to the view direction")


def _read_attributes(scene, index, seen=()):
    """{(slot, name)} of the mesh attributes material `index` reads, through its wrappers (blends, masks, its back
    side), and the parameter (map slot) each textures."""
    m = scene.materials[index]
    reads = {(slot, lookup.attribute) for slot, lookup in m.maps if lookup.kind == "mesh_attribute"}
    for other in (*m.blend, m.back):
        if other >= 0 and other not in seen:
            reads |= _read_attributes(scene, other, (*seen, index))
    return reads


# The sizes of attribute a parameter takes, as Mitsuba's texture evaluations do (src/render/mesh.cpp): eval_1 (a
# float parameter) one value, eval_3 (normalmap's normals) three, eval (a colour) three or one for all channels
_SIZES = {**{slot: (1,) for slot in texture_lookups.FLOAT_SLOTS}, "normal": (3,)}
_SIZE_WORDS = {(1,): "one value", (3,): "three values", (1, 3): "one value or three"}


def _mesh_attributes(scene, places):
    """A material that reads a mesh attribute (a mesh_attribute texture) is on meshes that have it only, as
    Mitsuba's shapes refuse an attribute they do not have; of a size its parameter takes (an rgba colour's four
    values are no reflectance: Mitsuba's eval throws in its scalar variants and gives 0 in its vectorised ones);
    with values the renderer can use: finite numbers within float32's range, and >= 0 (a colour's, a roughness's,
    a weight's)."""
    for reader, shape in places.shapes:
        if shape.material < 0:
            continue
        material = scene.materials[shape.material].name
        have = shape.mesh.attributes if hasattr(shape, "mesh") else {}
        for slot, name in sorted(_read_attributes(scene, shape.material)):
            reads = f"reads the mesh attribute {name}"
            if name not in have:
                reader.fail("material", material, f"{reads}, which this shape does not have")
            values, sizes = have[name], _SIZES.get(slot, (1, 3))
            if values.shape[1] not in sizes:
                reader.fail("material", material, f"{reads}, of {values.shape[1]} values a {name.split('_')[0]}, for "
                            f"its {slot}, which takes {_SIZE_WORDS[sizes]}")
            bad = ~((values >= 0) & (values <= FLOAT32_MAX)).all(axis=1)  # also NaN
            if bad.any():
                row = int(np.argmax(bad))
                value = next(v for v in values[row] if not 0 <= v <= FLOAT32_MAX)
                problem = meshes.value_problem(f"{value:g}", value, FLOAT32_MAX) or f"{value:g} is below 0"
                reader.fail("file", reader.raw("file"), f"its {name}[{row}] = {values[row].tolist()}: {problem}, "
                            f"where material {material} reads it (as finite numbers >= 0)")
    for light, reader in zip(scene.lights, places.lights):
        if light.material >= 0 and _read_attributes(scene, light.material):
            reader.fail("material", scene.materials[light.material].name, "reads a mesh attribute, which a light "
                        "(a rectangle) does not have")


def check(scene, places):
    """Raise InputError, through the reader of the value's table, at the first rule `scene` breaks."""
    _camera(scene.camera, places.camera)
    _shading(scene, places)
    _bsdfs(scene, places)
    _mesh_attributes(scene, places)
    _patterns(scene, places.render)
    located = [(places.camera, scene.camera), *zip(places.lights, scene.lights), *places.shapes]
    ranges.check_scene(scene, located, places.materials, places.lights, places.top)
