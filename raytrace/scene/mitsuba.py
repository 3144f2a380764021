"""Mitsuba 3 scenes: its dict form (from `load_dict`, or from its XML through mitsuba_xml.py) turned into raytrace's
scene table (docs/scene-format.md), which scene_file.py then reads and checks as it reads a TOML file. Mitsuba 3's
plugin reference is the specification of the names, parameters, defaults and conventions.

Each plugin raytrace renders is declared once in PLUGINS: its parameters, Mitsuba's defaults, and the key of
scene/keys.py each one becomes (whose type, range and doc the manual's table of the plugin shows). What has no
place in raytrace's model is refused with one line naming the file, line, plugin and what is supported, or with
`ignore_unsupported` left out with one warning per kind. A value the table's reader refuses is reported at the
XML element (or dict entry) it came from: `origins` maps each key of the table back to it.
"""
import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import aovs as aov_types
from ..errors import InputError, did_you_mean, printable
from . import bsdfs, mesh_file, spectra
from .mitsuba_xml import WHERE, Where
from .delta_lights import FOV_OR_FOCAL_LENGTH
from .keys import MAX_GENERATED_TRIANGLES
from .model import LOOKUPS, fingerprint
from .transform import AFFINE

# Mitsuba's samplers, and raytrace's pattern that takes the place of each: the same estimate (every sampler is
# unbiased), with raytrace's own stratification. independent is uniform random; stratified, multijitter and
# orthogonal stratify the pixel, as raytrace's jittered grid does (a square count: Mitsuba's stratified rounds up
# to one, and so does this); ldsampler is a low-discrepancy sequence, raytrace's Owen-scrambled Sobol.
SAMPLER_PATTERNS = {"independent": "random", "stratified": "jittered", "multijitter": "jittered",
                    "orthogonal": "jittered", "ldsampler": "sobol"}
SPECTRUM_PLUGINS = {"d65": ("scale", 1.0), "uniform": ("value", 1.0), "srgb": ("color", None)}  # their parameter
# the scene table's keys that name files
FILE_KEYS = ("shapes[].file", "environment.filename", "materials.NAME.PARAMETER.filename",
             "emitters[].PARAMETER.filename")
DEFAULT_DIFFUSE = 0.5  # the BSDF Mitsuba gives a shape that names none: diffuse, reflectance 0.5
DELTA_EMITTERS = ("point", "spot", "directional", "projector")  # [[emitters]] (delta_lights.py)
FOCAL_LENGTH_FORM = 'must be of the form "<x>mm", x > 0'


@dataclass(frozen=True)
class Param:
    """A parameter of a Mitsuba plugin: Mitsuba's default (None: required, or derived), the raytrace key it
    becomes ("table key", as in keys.py's TABLES; "" where it changes nothing raytrace computes), and a note."""
    name: str
    default: object
    key: str = ""
    note: str = ""


@dataclass(frozen=True)
class Plugin:
    category: str
    doc: str
    params: tuple = ()
    only_default: tuple = ()  # (name, Mitsuba's default) of parameters raytrace takes at that value only

    def names(self):
        return [p.name for p in self.params] + [name for name, _ in self.only_default]


def _bsdf_plugin(bsdf):
    """The Plugin of a BSDF's declaration (bsdfs.py): each parameter with Mitsuba's default and the scene table's
    key it becomes ("materials.NAME colour" for a reflectance, its type's table's key for the others)."""
    def key(p):
        if not p.fields:
            return ""
        return "materials.NAME colour" if p.table_key == "colour" else f"{bsdf.table} {p.table_key}"
    return Plugin("bsdf", f"{bsdf.title}; [its page](bsdfs.md#{bsdf.name})",
                  tuple(Param(p.name, p.mitsuba_default, key(p), p.note) for p in bsdf.parameters
                        if p.name not in dict(bsdf.only_default)), bsdf.only_default)


_TRANSFORM = Param("to_world", "identity", "", "placement")
PLUGINS = {
    **{bsdf.name: _bsdf_plugin(bsdf) for bsdf in bsdfs.DECLARED},
    "twosided": Plugin("bsdf", "the BSDF inside on both sides (Mitsuba's other BSDFs but glass are black from "
                       "behind: materials.NAME two_sided), or two: the front's and the back's", (
                           Param("bsdf", None, "materials.NAME back", "one BSDF, or two: the second is the back's"),)),
    "blendbsdf": Plugin("bsdf", "a blend of two BSDFs", (
        Param("weight", None, 'materials.NAME type = "blendbsdf" weight', "a number or a texture"),
        Param("bsdf", None, 'materials.NAME type = "blendbsdf" bsdfs', "two BSDFs, in order"))),
    "mask": Plugin("bsdf", "a BSDF where opacity says, elsewhere light passing through (null)", (
        Param("opacity", 0.5, 'materials.NAME type = "mask" opacity', "a number or a texture"),
        Param("bsdf", None, 'materials.NAME type = "mask" bsdf', "one BSDF"))),
    "normalmap": Plugin("bsdf", "a BSDF whose shading normal a texture of normals tilts", (
        Param("normalmap", None, "materials.NAME normalmap", "a texture, raw"),
        Param("bsdf", None, "materials.NAME normalmap", "one BSDF: each material inside takes the map")),
        only_default=(("flip_invalid_normals", True), ("use_shadowing_function", True))),
    "bumpmap": Plugin("bsdf", "a BSDF whose shading normal the gradient of a texture of heights tilts", (
        Param("scale", 1.0, "materials.NAME bump_scale"),
        Param("texture", None, "materials.NAME bumpmap", "one texture, of any name"),
        Param("bsdf", None, "materials.NAME bumpmap", "one BSDF: each material inside takes the map")),
        only_default=(("flip_invalid_normals", True), ("use_shadowing_function", True))),
    "bitmap": Plugin("texture", "an image texture", (
        Param("filename", None, "texture filename"), Param("raw", False, "texture raw"),
        Param("filter_type", "bilinear", "texture filter_type"), Param("wrap_mode", "repeat", "texture wrap_mode"),
        Param("to_uv", "identity", "texture to_uv", "its 2D part (x, y and the translation)"),
        Param("accel", True, "", "no effect"))),
    "mesh_attribute": Plugin("texture", "a mesh's attribute: a PLY file's vertex or face properties, as Mitsuba's "
                             "PLY reader groups and names them", (
        Param("name", None, "texture name", "vertex_color, face_color, vertex_PREFIX or face_PREFIX"),
        Param("scale", 1.0, "texture scale"))),
    "checkerboard": Plugin("texture", "two colours in alternate squares", (
        Param("color0", 0.4, "texture color0", "a number or an rgb"), Param("color1", 0.2, "texture color1"),
        Param("to_uv", "identity", "texture to_uv", "its 2D part (x, y and the translation)"))),
    "rectangle": Plugin("shape", "[-1, 1]^2 in the plane z = 0, normal +z, under to_world", (
        _TRANSFORM, Param("flip_normals", False, "shapes[] normal", "turns the front side"),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "lights[]", "an area emitter"))),
    "obj": Plugin("shape", "a Wavefront OBJ mesh", (
        Param("filename", None, 'shapes[] type = "mesh", from a file or generated file'),
        _TRANSFORM, Param("face_normals", False, 'shapes[] type = "mesh", from a file or generated smooth',
                          "false: smooth (smooth = true)"),
        Param("flip_tex_coords", True, 'shapes[] type = "mesh", from a file or generated flip_tex_coords'),
        Param("flip_normals", False, 'shapes[] type = "mesh", from a file or generated flip_normals'),
        Param("bsdf", "diffuse", "shapes[] material"),
        Param("emitter", None, "shapes[] radiance", "an area emitter (a mesh that is one planar rectangle: lights[])"))),
    "ply": Plugin("shape", "a PLY mesh (ascii or binary)", (
        Param("filename", None, 'shapes[] type = "mesh", from a file or generated file'),
        Param("flip_tex_coords", False, 'shapes[] type = "mesh", from a file or generated flip_tex_coords'),
        _TRANSFORM, Param("face_normals", False, 'shapes[] type = "mesh", from a file or generated smooth',
                          "false: smooth (smooth = true)"),
        Param("flip_normals", False, 'shapes[] type = "mesh", from a file or generated flip_normals'),
        Param("bsdf", "diffuse", "shapes[] material"),
        Param("emitter", None, "shapes[] radiance", "an area emitter (a mesh that is one planar rectangle: lights[])"))),
    "serialized": Plugin("shape", "one shape of a Mitsuba serialized mesh file", (
        Param("filename", None, 'shapes[] type = "mesh", from a file or generated file'),
        Param("shape_index", 0, 'shapes[] type = "mesh", from a file or generated shape_index'),
        _TRANSFORM, Param("face_normals", False, 'shapes[] type = "mesh", from a file or generated smooth',
                          "false: smooth (smooth = true)"),
        Param("flip_normals", False, 'shapes[] type = "mesh", from a file or generated flip_normals'),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "shapes[] radiance", "an area emitter"))),
    "cube": Plugin("shape", "[-1, 1]^3 as Mitsuba's mesh of 12 triangles, each face's uv over [0, 1]^2, under "
                   "to_world", (
        _TRANSFORM, Param("flip_normals", False, 'shapes[] type = "mesh" faces', "turns the faces inside out"),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "shapes[] radiance", "an area emitter"))),
    "sphere": Plugin("shape", "a sphere (raytrace's ellipsoid)", (
        Param("center", (0.0, 0.0, 0.0), 'shapes[] type = "ellipsoid" center'),
        Param("radius", 1.0, 'shapes[] type = "ellipsoid" axes'), _TRANSFORM,
        Param("flip_normals", False, 'shapes[] type = "ellipsoid" flip_normals', "turns the front inwards"),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "shapes[] radiance", "an area emitter"))),
    "disk": Plugin("shape", "the unit disk in z = 0, normal +z, under to_world", (
        Param("to_world", "identity", 'shapes[] type = "disk" to_world'),
        Param("flip_normals", False, 'shapes[] type = "disk" flip_normals'),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "shapes[] radiance", "an area emitter"))),
    "cylinder": Plugin("shape", "an open tube (no caps) around p0 -> p1, under to_world", (
        Param("p0", (0.0, 0.0, 0.0), 'shapes[] type = "cylinder" p0'),
        Param("p1", (0.0, 0.0, 1.0), 'shapes[] type = "cylinder" p1'),
        Param("radius", 1.0, 'shapes[] type = "cylinder" radius'),
        Param("to_world", "identity", 'shapes[] type = "cylinder" to_world'),
        Param("flip_normals", False, 'shapes[] type = "cylinder" flip_normals'),
        Param("bsdf", "diffuse", "shapes[] material"), Param("emitter", None, "shapes[] radiance", "an area emitter"))),
    "shapegroup": Plugin("shape", "shapes that instances place; not rendered itself: its meshes a group, kept once",
                         (Param("shape", None, "groups.NAME shapes", "one or more, each with its own bsdf (no emitter, "
                                "shapegroup or instance, as in Mitsuba); its other shapes copied per instance"),)),
    "instance": Plugin("shape", "a shapegroup placed by to_world: its meshes' group instanced (a two-level BVH), its "
                       "other shapes copied", (
        Param("shapegroup", None, 'shapes[] type = "instance" group', "one, by reference"),
        Param("to_world", "identity", 'shapes[] type = "instance" matrix', "composed with each shape's own (a "
              "sphere's must stay uniform)"))),
    "area": Plugin("emitter", "light emitted from a shape's front side", (
        Param("radiance", 1.0, "lights[] (direct, path) radiance", "an RGB colour or a spectrum (on a shape other "
              "than a rectangle: shapes[] radiance)"),)),
    "constant": Plugin("emitter", "light from every direction", (
        Param("radiance", 1.0, "environment radiance"),)),
    "envmap": Plugin("emitter", "an equirectangular image of radiance around the scene", (
        Param("filename", None, "environment filename"), Param("scale", 1.0, "environment scale"),
        Param("to_world", "identity", "environment up", "a rotation: its y and z columns are up and forward"),
        Param("mis_compensation", False, "", "noise only"))),
    "point": Plugin("emitter", "light from a point, the same intensity every way", (
        Param("position", "to_world's origin", 'emitters[] type = "point" position', "a point; not with to_world"),
        Param("to_world", "identity", 'emitters[] type = "point" to_world', "its origin the position"),
        Param("intensity", 1.0, 'emitters[] type = "point" intensity', "an RGB colour or a spectrum"))),
    "spot": Plugin("emitter", "a cone of light along to_world's +z, falling off linearly in the angle", (
        Param("to_world", "identity", 'emitters[] type = "spot" to_world', "a lookat: origin, target, up"),
        Param("intensity", 1.0, 'emitters[] type = "spot" intensity', "an RGB colour or a spectrum"),
        Param("cutoff_angle", 20.0, 'emitters[] type = "spot" cutoff_angle'),
        Param("beam_width", "3/4 cutoff_angle", 'emitters[] type = "spot" beam_width'),
        Param("texture", None, 'emitters[] type = "spot" texture', "a bitmap or a checkerboard projected over the "
              "cone"))),
    "directional": Plugin("emitter", "light from beyond the scene along one direction (the sun)", (
        Param("irradiance", 1.0, 'emitters[] type = "directional" irradiance', "an RGB colour or a spectrum"),
        Param("direction", "to_world's +z", 'emitters[] type = "directional" direction', "not with to_world"),
        Param("to_world", "identity", 'emitters[] type = "directional" to_world'))),
    "projector": Plugin("emitter", "a perspective camera in reverse: an image projected along to_world's +z", (
        Param("irradiance", 1.0, 'emitters[] type = "projector" irradiance', "a colour, or a bitmap or checkerboard"),
        Param("scale", 1.0, 'emitters[] type = "projector" scale'),
        Param("to_world", "identity", 'emitters[] type = "projector" to_world', "a lookat: origin, target, up"),
        Param("fov", "focal_length's", 'emitters[] type = "projector" fov', "degrees along fov_axis"),
        Param("fov_axis", "x", 'emitters[] type = "projector" fov_axis', "x, y, diagonal, smaller or larger"),
        Param("focal_length", "50mm", 'emitters[] type = "projector" focal_length', "instead of fov: a 35 mm "
              "film's focal length"))),
    "thinlens": Plugin("sensor", "a thin lens camera: depth of field", (
        Param("to_world", "identity", "camera position", "rigid (no scale): the lens's centre, its "
              "local +z the view, +y up"),
        Param("aperture_radius", None, "camera aperture_radius"),
        Param("focus_distance", "far_clip", "camera focus_distance"),
        Param("fov", "focal_length's", "camera fov", "degrees along fov_axis"),
        Param("fov_axis", "x", "camera fov", "x, y, diagonal, smaller or larger"),
        Param("focal_length", "50mm", "camera fov", "instead of fov: a 35 mm film's focal length"),
        Param("near_clip", 0.01, "camera near_clip"), Param("far_clip", 10000.0, "camera far_clip"),
        Param("film", "hdrfilm", "image"), Param("sampler", "independent", "render"))),
    "orthographic": Plugin("sensor", "parallel rays", (
        Param("to_world", "identity", "camera size", "a rotation and translation after a "
              "scale of x and y: the view spans [-sx, sx] x [-sy, sy] height / width"),
        Param("near_clip", 0.01, "camera near_clip"), Param("far_clip", 10000.0, "camera far_clip"),
        Param("film", "hdrfilm", "image"), Param("sampler", "independent", "render"))),
    "perspective": Plugin("sensor", "a pinhole camera", (
        Param("to_world", "identity", "camera position", "rigid (no scale): the eye, its local +z the view, +y up"),
        Param("fov", "focal_length's", "camera fov", "degrees along fov_axis"),
        Param("fov_axis", "x", "camera fov", "x, y, diagonal, smaller or larger"),
        Param("focal_length", "50mm", "camera fov", "instead of fov: a 35 mm film's focal length"),
        Param("near_clip", 0.01, "camera near_clip", "dropped where it cuts nothing"),
        Param("far_clip", 10000.0, "camera far_clip", "dropped where it cuts nothing"),
        Param("film", "hdrfilm", "image"), Param("sampler", "independent", "render")),
        only_default=(("principal_point_offset_x", 0.0), ("principal_point_offset_y", 0.0))),
    "hdrfilm": Plugin("film", "the image", (
        Param("width", 768, "image width"), Param("height", 576, "image height"),
        Param("rfilter", "gaussian", "image rfilter", "importance-sampled (docs/model.md, film)"),
        Param("file_format", "openexr", "", "the output's extension decides"),
        Param("pixel_format", "rgb", "", "rgb, or rgba (raytrace writes RGB)"),
        Param("component_format", "float16", "", "the output decides"),
        Param("sample_border", False, "image sample_border"),
        Param("crop_offset_x", 0, "image crop_offset_x"), Param("crop_offset_y", 0, "image crop_offset_y"),
        Param("crop_width", "width", "image crop_width"), Param("crop_height", "height", "image crop_height"))),
    "box": Plugin("rfilter", "each pixel the average of its own samples", ()),
    "tent": Plugin("rfilter", "a tent", (Param("radius", 1.0, "image rfilter_radius"),)),
    "gaussian": Plugin("rfilter", "a Gaussian cut off at 4 standard deviations", (
        Param("stddev", 0.5, "image rfilter_stddev"),)),
    "mitchell": Plugin("rfilter", "Mitchell and Netravali's cubic, radius 2", (
        Param("B", 1 / 3, "image rfilter_b"), Param("C", 1 / 3, "image rfilter_c"))),
    "lanczos": Plugin("rfilter", "a windowed sinc", (Param("lobes", 3, "image rfilter_lobes"),)),
    "path": Plugin("integrator", "path tracing", (
        Param("max_depth", -1, "render max_depth"), Param("rr_depth", 5, "render rr_depth"),
        Param("hide_emitters", False, "render hide_emitters"))),
    "direct": Plugin("integrator", "direct lighting", (
        Param("shading_samples", 1, "render light_samples", "emitter_samples' and bsdf_samples' default"),
        Param("emitter_samples", 1, "render light_samples", "each of one emitting shape or delta light chosen by "
              "power; each [[lights]] rectangle takes as many of its own"),
        Param("bsdf_samples", 1, "render bsdf_samples"),
        Param("hide_emitters", False, "render hide_emitters"))),
    "moment": Plugin("integrator", "a wrapper: raytrace renders the integrator inside", (
        Param("integrator", None, "", "one integrator"),)),
    "aov": Plugin("integrator", "AOVs beside the image of the integrator inside, which raytrace renders", (
        Param("aovs", None, "render aovs", "name:type items; types albedo, depth, position, uv, geo_normal, "
              "sh_normal, shape_index (not dp_du, dp_dv, duv_dx, duv_dy, prim_index)"),
        Param("integrator", None, "", "one integrator, as a bare one would render"))),
    "independent": Plugin("sampler", "uniform random samples: raytrace's random", (
        Param("sample_count", 4, "render spp"), Param("seed", 0, "render seed"))),
    "stratified": Plugin("sampler", "a jittered grid: raytrace's jittered", (
        Param("sample_count", 4, "render spp", "rounded up to a square"), Param("seed", 0, "render seed")),
        only_default=(("jitter", True),)),
    "multijitter": Plugin("sampler", "correlated multi-jittered samples: raytrace's jittered", (
        Param("sample_count", 4, "render spp", "rounded up to a square"), Param("seed", 0, "render seed")),
        only_default=(("jitter", True),)),
    "orthogonal": Plugin("sampler", "orthogonal arrays: raytrace's jittered", (
        Param("sample_count", 4, "render spp", "rounded up to a square"), Param("seed", 0, "render seed"),
        Param("strength", 2, "", "no effect")), only_default=(("jitter", True),)),
    "ldsampler": Plugin("sampler", "a low-discrepancy sequence: raytrace's Owen-scrambled Sobol", (
        Param("sample_count", 4, "render spp", "rounded up to a power of two"), Param("seed", 0, "render seed"))),
}
SENSORS = ("perspective", "thinlens", "orthographic")
NEAR_CLIP, FAR_CLIP = 0.01, 1e4  # Mitsuba's clip planes' defaults
# each rfilter's parameters: (Mitsuba's name, the image table's key, an integer)
RFILTER_PARAMETERS = {"tent": (("radius", "rfilter_radius", False),),
                      "gaussian": (("stddev", "rfilter_stddev", False),),
                      "mitchell": (("B", "rfilter_b", False), ("C", "rfilter_c", False)),
                      "lanczos": (("lobes", "rfilter_lobes", True),)}
CATEGORIES = ("integrator", "sensor", "film", "rfilter", "sampler", "shape", "bsdf", "emitter", "texture")


MESH_SHAPES = ("obj", "ply", "serialized", "cube")  # the shapes a shapegroup keeps once (raytrace's groups)


def supported(category):
    return [name for name, p in PLUGINS.items() if p.category == category]


@dataclass
class Translation:
    """raytrace's scene table of a Mitsuba scene, where each of its keys came from ({key path: (where, the
    Mitsuba parameter)}), and the warnings of what was left out."""
    table: dict
    origins: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    files: mesh_file.MeshCache = field(default_factory=mesh_file.MeshCache)  # mesh files read, for the reader


class _Translator:
    def __init__(self, source, folder, ignore_unsupported):
        self.source, self.folder, self.ignore = source, Path(folder), ignore_unsupported
        self.table = {"materials": {}, "lights": [], "shapes": []}
        self.out = Translation(self.table)
        self.ids = {}
        self.materials = {}  # id(BSDF dict) -> material name
        self.warned = set()
        self.search = []
        self.groups = {}  # id(shapegroup dict) -> [(path, shape dict)]
        self.group_names = {}  # id(shapegroup dict) -> the name of its meshes' group in the scene table

    # -- where things came from, and errors naming it
    def where(self, node, path):
        w = node.get(WHERE) if isinstance(node, dict) else None
        return w if isinstance(w, Where) else Where(self.source)  # a caller's dict: the key names the entry

    def fail(self, at, key, value, problem):
        raise InputError(at, key, value, problem)

    def unsupported(self, at, what, problem):
        if not self.ignore:
            self.fail(at, what, None, problem + " (--ignore-unsupported renders the rest)")
        if what not in self.warned:
            self.warned.add(what)
            self.out.warnings.append(printable(f"{at}: {what}: {problem}: left out"))

    def origin(self, key, node, path, param):
        self.out.origins[key] = (self.where(node, path).of(param), param)

    # -- values
    def resolve(self, value, path):
        if _type(value) == "ref":
            ref = value.get("id")
            if ref not in self.ids:
                self.fail(self.where(value, path).at, f"{path}.id" if path else "id", ref,
                          f"no object with this id{did_you_mean(ref, self.ids)}")
            return self.ids[ref]
        return value

    def params(self, node, path, name):
        """{parameter: value} of plugin `node` (of type `name`), refusing a parameter it does not take."""
        plugin = PLUGINS[name]
        where = self.where(node, path)
        given = {k: v for k, v in node.items() if k not in ("type", "id", WHERE)}
        only_default = dict(plugin.only_default)
        for key in given:
            if key in only_default and given[key] != only_default[key]:
                self.unsupported(where.of(key), f"{plugin.category} {name}: {key}", f"{key} other than Mitsuba's "
                                 f"default ({only_default[key]}) is not supported")
            elif key not in plugin.names() and not _is_object(given[key]):
                self.not_a_parameter(where.of(key), f"{name}.{key}", given[key], f"{name} {plugin.category}",
                                     plugin.names())
        return {k: v for k, v in given.items() if k not in only_default}

    def number(self, value, node, path, param, integer=False):
        ok = (isinstance(value, int) if integer else isinstance(value, (int, float))) and not isinstance(value, bool)
        if not ok or (not integer and not math.isfinite(value)):
            self.fail(self.where(node, path).of(param), f"{path}.{param}" if path else param, _shown(value),
                      f"must be {'an integer' if integer else 'a finite number'}")
        return value

    def boolean(self, value, node, path, param):
        if not isinstance(value, bool):
            self.fail(self.where(node, path).of(param), f"{path}.{param}", _shown(value), "must be a boolean")
        return value

    def string(self, value, node, path, param, choices=None):
        if not isinstance(value, str):
            self.fail(self.where(node, path).of(param), f"{path}.{param}", _shown(value), "must be a string")
        if choices is not None and value not in choices:
            self.fail(self.where(node, path).of(param), f"{path}.{param}", value,
                      f"must be one of: {', '.join(choices)}{did_you_mean(value, choices, ';')}")
        return value

    def colour(self, value, node, path, param, emission=False, unbounded=False):
        """RGB of a Mitsuba colour: a number, an rgb or a spectrum (converted as Mitsuba's rgb variants do)."""
        at = self.where(node, path).of(param)
        value = self.resolve(value, path)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return [float(self.number(value, node, path, param))] * 3
        if _type(value) == "rgb":
            rgb = value.get("value")
            if isinstance(rgb, (int, float)) and not isinstance(rgb, bool):
                rgb = [rgb] * 3
            rgb = list(np.asarray(rgb, dtype=object).ravel()) if isinstance(rgb, (list, tuple, np.ndarray)) else rgb
            if not (isinstance(rgb, list) and len(rgb) == 3 and all(
                    isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in rgb)):
                self.fail(at, f"{path}.{param}", _shown(value.get("value")),
                          "an rgb value must be 1 or 3 finite numbers")
            return [float(c) for c in rgb]
        if _type(value) == "spectrum":
            try:
                if "filename" in value:
                    spectrum = spectra.read_spd(Path(value["filename"]))
                else:
                    spectrum = value.get("value")
                    if isinstance(spectrum, (list, tuple)):
                        spectrum = [tuple(float(x) for x in pair) for pair in spectrum]
                return list(spectra.to_rgb(spectrum, emission, unbounded))
            except (ValueError, TypeError) as e:
                self.fail(at, f"{path}.{param}", _shown(value.get("value", value.get("filename"))), str(e))
        if _type(value) in SPECTRUM_PLUGINS:
            return self.spectrum_plugin(value, node, path, param)
        if _type(value) in ("blackbody", "regular", "irregular"):
            self.fail(at, f"{path}.{param}", value["type"], "a spectral plugin that Mitsuba's rgb variants do not "
                      "render either (they refuse it when rendering): give an rgb or a wavelength:value spectrum")
        if isinstance(value, dict) and isinstance(value.get("type"), str):
            self.unsupported(at, f"texture {value['type']}", "a texture here is not supported (a number, rgb or "
                             "spectrum only)")
            return None
        self.fail(at, f"{path}.{param}", _shown(value), "must be a number, an rgb or a spectrum")

    def not_a_parameter(self, at, key, value, plugin, names):
        closest = did_you_mean(key.split('.')[-1], names)
        self.fail(at, key, _shown(value), f"is no parameter of Mitsuba's {plugin}{closest}"
                  f" (it takes: {', '.join(names) or 'none'})")

    def spectrum_plugin(self, value, node, path, param):
        """The RGB of the spectrum plugins Mitsuba's rgb variants render (read off mi.traverse in scalar_rgb):
        d65 is white times its scale, uniform its value, srgb its colour, each taken as it is."""
        name = value["type"]
        given = {k: v for k, v in value.items() if k not in ("type", "id", WHERE)}
        key, default = SPECTRUM_PLUGINS[name]
        for k in given:
            if k != key:
                self.not_a_parameter(self.where(value, path).of(k), f"{path}.{param}.{k}", given[k],
                                     f"{name} spectrum", [key])
        if name == "srgb":
            color = given.get(key, default)
            return self.colour(color if isinstance(color, dict) else {"type": "rgb", "value": color}, node, path, param)
        return [float(self.number(given.get(key, default), value, path, key))] * 3

    def matrix(self, value, node, path, param):
        """A to_world as a 4 x 4 float64 matrix: an array, nested lists, or an object with .matrix (Mitsuba's
        ScalarTransform4f)."""
        at = self.where(node, path).of(param)
        value = getattr(value, "matrix", value)
        try:
            m = np.asarray(value)
            m = m.astype(np.float64) if m.dtype.kind in "iuf" or (m.dtype.kind == "O" and m.size) else None
        except (TypeError, ValueError):
            m = None
        if m is None or m.shape != (4, 4) or not np.all(np.isfinite(m)) or not np.isfinite(np.linalg.det(m[:3, :3])):
            self.fail(at, f"{path}.{param}", _shown(value), "must be a 4 x 4 matrix of finite numbers")
        if not np.array_equal(m[3], [0, 0, 0, 1]) or not abs(np.linalg.det(m[:3, :3])) > 0:
            self.fail(at, f"{path}.{param}", m.tolist(), AFFINE)
        return m

    # -- the scene
    def scene(self, node):
        if _type(node) != "scene":
            self.fail(self.source, "type", _shown(node.get("type") if isinstance(node, dict) else node),
                      'a Mitsuba scene is a dict of type "scene"')
        if isinstance(node.get(WHERE), Where):
            self.search = node[WHERE].search
        self.collect_ids(node, "")
        if isinstance(node.get(WHERE), Where):
            for alias, ident in node[WHERE].aliases.items():
                self.ids.setdefault(alias, self.ids.get(ident))
        groups = {c: [] for c in CATEGORIES}
        for key, value in node.items():
            if key in ("type", "id", WHERE):
                continue
            value = self.resolve(value, key)
            category = self.category(value, key, node)
            if category:
                groups.setdefault(category, []).append((key, value))
        for category in ("film", "rfilter", "sampler", "texture"):
            for key, value in groups.get(category, []):
                if category == "texture":
                    continue  # textures given at the top level are used by reference
                self.fail(self.where(value, key).at, key, value["type"], f"a {category} belongs inside a "
                          f"{'film' if category == 'rfilter' else 'sensor'}")
        self.integrator(groups["integrator"])
        sensors = groups["sensor"]
        if not sensors:
            self.fail(self.source, "sensor", None, "missing: raytrace needs a perspective sensor (Mitsuba's default "
                      "camera is not supported)")
        if len(sensors) > 1:
            self.unsupported(self.where(sensors[1][1], sensors[1][0]).at, "a second sensor",
                             "raytrace renders one sensor")
        self.sensor(*sensors[0])
        self.check_instances(groups["shape"])
        for key, value in groups["shape"]:
            if value["type"] == "instance":
                self.instance(key, value)
            elif value["type"] != "shapegroup":  # a shapegroup is drawn where instances place it only
                self.shape(key, value)
        environments = [(key, value) for key, value in groups["emitter"] if value["type"] not in DELTA_EMITTERS]
        for i, (key, value) in enumerate(environments):
            if i:
                self.unsupported(self.where(value, key).at, "a second environment emitter",
                                 "raytrace takes one constant or envmap emitter")
            else:
                self.environment(key, value)
        for key, value in groups["emitter"]:
            if value["type"] in DELTA_EMITTERS:
                self.delta_light(key, value)
        if not self.table["lights"] and "environment" not in self.table and not self.table.get("emitters") and not any(
                "radiance" in shape for shape in self.table["shapes"]):
            self.fail(self.source, "emitter", None, "the scene has none that raytrace renders: an area emitter on a "
                      "shape, a constant, an envmap, a point, a spot, a directional or a projector")
        if not self.table["materials"]:  # raytrace's format names one at least; a scene of lights alone has none
            self.material(None, "")
        order = ("render", "camera", "image", "environment", "materials", "lights", "groups", "shapes", "emitters")
        self.out.table = {k: self.table[k] for k in order if k in self.table}
        return self.out

    def collect_ids(self, node, path):
        for key, value in node.items():
            if key in ("type", WHERE) or not isinstance(value, dict) or _type(value) == "ref":
                continue
            ident = value.get("id", key if path == "" else None)
            if isinstance(ident, str) and ident not in self.ids:
                self.ids[ident] = value
            self.collect_ids(value, f"{path}.{key}" if path else key)

    def category(self, value, path, parent):
        """The category of plugin dict `value` (None for what is not a plugin: at the top level, an error)."""
        at = self.where(value, path).at if isinstance(value, dict) else self.where(parent, "").of(path)
        if not isinstance(value, dict) or not isinstance(value.get("type"), str):
            self.fail(at, path, _shown(value), "must be a plugin: a dict with a type")
        name = value["type"]
        tag = value[WHERE].tag if isinstance(value.get(WHERE), Where) else ""
        if name in PLUGINS:
            category = PLUGINS[name].category
            if tag and tag != category:
                self.fail(at, f"<{tag}> type", name, f"is a {category}, not a {tag}")
            return category
        if name in ("rgb", "spectrum"):
            return "texture"
        category = tag or "plugin"
        have = supported(tag) if tag in CATEGORIES else sorted(PLUGINS)
        self.unsupported(at, f"{category} {name}", f"not supported (raytrace renders: {', '.join(have)})")
        return None

    def integrator(self, integrators):
        render = self.table.setdefault("render", {})
        render["shading"] = "path"  # Mitsuba's default integrator
        if not integrators:
            return
        key, node = integrators[0]
        if len(integrators) > 1:
            self.unsupported(self.where(integrators[1][1], integrators[1][0]).at, "a second integrator",
                             "raytrace renders with one")
        while node["type"] in ("moment", "aov"):
            wrapper = node["type"]
            params = self.params(node, key, wrapper)
            inner = [(k, v) for k, v, category in self.objects(params, key, node) if category == "integrator"]
            if wrapper == "aov":
                self.aovs(params, node, key)
                if len(inner) > 1:
                    self.unsupported(self.where(inner[1][1], inner[1][0]).at, "a second integrator in aov",
                                     "raytrace renders the image of one")
                if not inner:  # Mitsuba's image is then black; its AOVs stand alone
                    self.unsupported(self.where(node, key).at, "an aov integrator without one inside",
                                     "raytrace renders an image beside the AOVs (path tracing here)")
                    return
                key, node = inner[0]
                continue
            if len(inner) != 1:
                self.fail(self.where(node, key).at, f"{key}.integrator", len(inner), "moment must wrap one integrator")
            key, node = inner[0]
        name = node["type"]
        params = self.params(node, key, name)
        render["shading"] = name
        if name == "path":
            for param in ("max_depth", "rr_depth"):
                if param in params:
                    render[param] = self.number(params[param], node, key, param, integer=True)
                    self.origin(f"render.{param}", node, key, param)
        else:  # Mitsuba's direct: shading_samples sets both counts, and refuses to be given with either
            if "shading_samples" in params and ("emitter_samples" in params or "bsdf_samples" in params):
                self.fail(self.where(node, key).of("shading_samples"), f"{key}.shading_samples",
                          params["shading_samples"], "not with emitter_samples or bsdf_samples (as in Mitsuba)")
            for param, table_key in (("emitter_samples", "light_samples"), ("bsdf_samples", "bsdf_samples")):
                given = param if param in params else "shading_samples"
                render[table_key] = self.number(params.get(given, 1), node, key, given, integer=True)
                if given in params:
                    self.origin(f"render.{table_key}", node, key, given)
        if "hide_emitters" in params:
            render["hide_emitters"] = self.boolean(params["hide_emitters"], node, key, "hide_emitters")
            self.origin("render.hide_emitters", node, key, "hide_emitters")
        self.out.origins["render.shading"] = (self.where(node, key).at, f"integrator {name}")

    def aovs(self, params, node, key):
        """render.aovs from Mitsuba's aov integrator's `aovs` string: its items of types raytrace does not compute
        (aovs.UNSUPPORTED) refused, or left out with one warning under --ignore-unsupported."""
        if "aovs" not in params:
            self.fail(self.where(node, key).at, f"{key}.aovs", None, "missing (the aov integrator's name:type items)")
        value = self.string(params["aovs"], node, key, "aovs")
        at, kept = self.where(node, key).of("aovs"), []
        for item in value.split(","):
            kind = item.partition(":")[2].strip()
            if kind in aov_types.UNSUPPORTED:
                self.unsupported(at, f"integrator aov: {kind}", "raytrace does not compute this AOV type")
            else:
                kept.append(item)
        aov_types.parse(",".join(kept), at, f"{key}.aovs")  # refused here, on the XML's line
        self.table.setdefault("render", {})["aovs"] = ",".join(item.strip() for item in kept)
        self.origin("render.aovs", node, key, "aovs")

    def sensor(self, key, node):
        name = node["type"]
        if name not in SENSORS:
            self.unsupported(self.where(node, key).at, f"sensor {name}", "not supported (raytrace renders: "
                             f"{', '.join(SENSORS)})")
            return
        params = self.params(node, key, name)
        film, sampler = None, None
        for path, v, category in self.objects(params, key, node):
            if category == "film":
                film = (path, v)
            elif category == "sampler":
                sampler = (path, v)
            else:
                self.fail(self.where(v, path).at, path, v["type"], f"a {category} does not belong in a sensor")
        width, height = self.film(*film) if film else (768, 576)
        self.sampler(*sampler) if sampler else self.sampler(f"{key}.sampler", {"type": "independent"})
        m = self.matrix(params["to_world"], node, key, "to_world") if "to_world" in params else np.eye(4)
        linear = m[:3, :3]
        camera = self.table["camera"] = {"type": name}
        if name == "orthographic":  # the to_world's x and y scale set the view's extent (Mitsuba: x in [-1, 1])
            scale = np.linalg.norm(linear, axis=0)
            rotation = linear / np.where(scale > 0, scale, 1.0)
            rigid = np.allclose(rotation.T @ rotation, np.eye(3), rtol=0, atol=1e-5) and np.linalg.det(linear) > 0
            if not rigid or abs(scale[2] - 1) > 1e-5:
                self.fail(self.where(node, key).of("to_world"), f"{key}.to_world", m.tolist(),
                          "must be a rotation and translation after a scale of x and y only (the view's extent), "
                          "as Mitsuba's orthographic sensor takes it")
            linear = rotation
            camera["size"] = [2 * float(scale[0]), 2 * float(scale[1]) * height / width]
            self.origin("camera.size", node, key, "to_world")
        elif not np.allclose(linear.T @ linear, np.eye(3), rtol=0, atol=1e-5) or np.linalg.det(linear) < 0:
            self.fail(self.where(node, key).of("to_world"), f"{key}.to_world", m.tolist(),
                      "must be rigid: scale factors are not allowed in a camera's to_world (as in Mitsuba)")
        position, forward, up = m[:3, 3], linear[:, 2], linear[:, 1]
        camera.update({"position": position.tolist(), "look_at": (position + forward).tolist(), "up": up.tolist()})
        for k in ("position", "look_at", "up"):
            self.origin(f"camera.{k}", node, key, "to_world")
        if name != "orthographic":
            camera["fov"] = self.fov(params, node, key, width / height)
            self.origin("camera.fov", node, key, "fov" if "fov" in params else "focal_length")
        near = self.number(params.get("near_clip", NEAR_CLIP), node, key, "near_clip")
        far = self.number(params.get("far_clip", FAR_CLIP), node, key, "far_clip")
        if not 0 < near < far:
            self.fail(self.where(node, key).of("near_clip"), f"{key}.near_clip", near,
                      f"must be > 0 and below far_clip ({far})")
        camera["near_clip"], camera["far_clip"] = near, far
        self.origin("camera.near_clip", node, key, "near_clip")
        self.origin("camera.far_clip", node, key, "far_clip")
        if name == "thinlens":
            if "aperture_radius" not in params:
                self.fail(self.where(node, key).at, f"{key}.aperture_radius", None, "missing: a thinlens needs its "
                          "aperture_radius (as in Mitsuba)")
            camera["aperture_radius"] = self.number(params["aperture_radius"], node, key, "aperture_radius")
            camera["focus_distance"] = self.number(params.get("focus_distance", far), node, key, "focus_distance")
            for k in ("aperture_radius", "focus_distance"):
                self.origin(f"camera.{k}", node, key, k)

    def fov(self, params, node, key, aspect):
        """The vertical field of view of Mitsuba's fov, fov_axis or focal_length (Mitsuba's parse_fov)."""
        at = self.where(node, key)
        if "fov" in params and "focal_length" in params:
            self.fail(at.of("focal_length"), f"{key}.focal_length", params["focal_length"],
                      FOV_OR_FOCAL_LENGTH)
        if "fov" in params:
            fov = self.number(params["fov"], node, key, "fov")
            axis = self.string(params.get("fov_axis", "x"), node, key, "fov_axis",
                               ("x", "y", "diagonal", "smaller", "larger")).lower()
            if axis == "smaller":
                axis = "y" if aspect > 1 else "x"
            elif axis == "larger":
                axis = "x" if aspect > 1 else "y"
        else:
            text = str(params.get("focal_length", "50mm"))
            try:
                f = float(text[:-2] if text.endswith("mm") else text)
            except ValueError:
                f = math.nan
            if not f > 0 or not math.isfinite(f):
                self.fail(at.of("focal_length"), f"{key}.focal_length", text, FOCAL_LENGTH_FORM)
            fov, axis = 2 * math.degrees(math.atan(math.sqrt(36 * 36 + 24 * 24) / (2 * f))), "diagonal"
        if not 0 < fov < 180:
            self.fail(at.of("fov"), f"{key}.fov", fov, "must be in (0, 180) degrees")
        t = math.tan(math.radians(fov) / 2)
        half_width = {"x": t, "y": t * aspect, "diagonal": t / math.sqrt(1 + 1 / aspect ** 2)}[axis]
        return 2 * math.degrees(math.atan(half_width / aspect))

    def film(self, key, node):
        name = node["type"]
        if name != "hdrfilm":
            self.unsupported(self.where(node, key).at, f"film {name}", "not supported (raytrace renders: hdrfilm)")
        params = self.params(node, key, "hdrfilm") if name == "hdrfilm" else {}
        image = self.table["image"] = {}
        for side, default in (("width", 768), ("height", 576)):
            image[side] = self.number(params.get(side, default), node, key, side, integer=True)
            self.origin(f"image.{side}", node, key, side)
            if image[side] < 1:  # before the fov's aspect divides by it; the range is the image table's
                self.fail(self.where(node, key).of(side), side, image[side], "must be >= 1")
        for param, choices in (("pixel_format", ("rgb", "rgba")), ("component_format", ("float16", "float32")),
                               ("file_format", ("openexr", "exr", "rgbe", "pfm"))):
            if param in params:
                self.string(params[param], node, key, param, choices)
        for param in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
            if param in params:  # the image table's keys check the window against the film
                image[param] = self.number(params[param], node, key, param, integer=True)
                self.origin(f"image.{param}", node, key, param)
        if "sample_border" in params:
            image["sample_border"] = self.boolean(params["sample_border"], node, key, "sample_border")
            self.origin("image.sample_border", node, key, "sample_border")
        rfilters = [(path, v) for path, v, category in self.objects(params, key, node) if category == "rfilter"]
        path, rfilter = rfilters[0] if rfilters else (f"{key}.rfilter", None)
        kind = rfilter["type"] if rfilter else "gaussian"  # hdrfilm's default
        image["rfilter"] = kind
        if rfilter is not None:
            self.origin("image.rfilter", rfilter, path, "type")
            own = self.params(rfilter, path, kind)
            for param, table_key, integer in RFILTER_PARAMETERS.get(kind, ()):
                if param in own:
                    image[table_key] = self.number(own[param], rfilter, path, param, integer=integer)
                    self.origin(f"image.{table_key}", rfilter, path, param)
        return image["width"], image["height"]

    def objects(self, params, key, node):
        """(path, plugin dict, category) of each plugin nested in `params` (references resolved); a plugin of a
        category that does not belong in `node` is the caller's to refuse."""
        found = []
        for k, v in params.items():
            if _is_object(v):
                v = self.resolve(v, f"{key}.{k}")
                category = self.category(v, f"{key}.{k}", node)
                if category is not None:
                    found.append((f"{key}.{k}", v, category))
        return found

    def sampler(self, key, node):
        name = node["type"]
        if name not in SAMPLER_PATTERNS:
            self.unsupported(self.where(node, key).at, f"sampler {name}", "not supported (raytrace renders: "
                             f"{', '.join(SAMPLER_PATTERNS)})")
            name = "independent"
        params = self.params(node, key, name) if name == node["type"] else {}
        render = self.table.setdefault("render", {})
        count = self.number(params.get("sample_count", 4), node, key, "sample_count", integer=True)
        if count < 1:
            self.fail(self.where(node, key).of("sample_count"), f"{key}.sample_count", count, "must be >= 1")
        pattern = SAMPLER_PATTERNS[name]
        if pattern == "jittered":
            count = math.isqrt(count - 1) ** 2 + 2 * math.isqrt(count - 1) + 1 if count > 1 else 1
        elif pattern == "sobol":
            count = 1 << (count - 1).bit_length()
        render["spp"], render["sampler"] = count, pattern
        self.origin("render.spp", node, key, "sample_count")
        seed = self.number(params.get("seed", 0), node, key, "seed", integer=True)
        render["seed"] = seed
        self.origin("render.seed", node, key, "seed")

    # -- materials
    def material(self, node, path, two_sided=False, back=None, named=None, perturb=None):
        """The name of raytrace's material for BSDF `node` (None: Mitsuba's default diffuse), seen from both sides
        where `two_sided` (inside a twosided), with material `back` behind it (a twosided's second BSDF); named
        after its id, or the id of the twosided around it (`named`); `perturb`: a normalmap's or bumpmap's (its
        node, its key and texture table, its scale, whether a twosided is around it) around it, which each BSDF
        inside takes."""
        if node is None:
            name = "mitsuba_default"
            self.table["materials"].setdefault(name, {"type": "diffuse", "colour": [DEFAULT_DIFFUSE] * 3,
                                                      "two_sided": False})
            return name
        node = self.resolve(node, path)
        cached = (id(node), two_sided, back, perturb and id(perturb[0]))
        if cached in self.materials:
            return self.materials[cached]
        if self.category(node, path, node) != "bsdf":
            self.fail(self.where(node, path).at, path, node["type"], "must be a bsdf")
        kind = node["type"]
        params = self.params(node, path, kind)
        nested = [(p, v) for p, v, category in self.objects(
            {k: v for k, v in params.items() if _is_bsdf(self.resolve(v, path))}, path, node) if category == "bsdf"]
        own_id = node.get("id") if isinstance(node.get("id"), str) else named
        if kind == "twosided":
            if len(nested) not in (1, 2):
                self.fail(self.where(node, path).at, path, len(nested), "twosided must wrap one or two bsdfs")
            behind = self.material(nested[1][1], nested[1][0], True, None, None, perturb) if len(nested) == 2 else None
            name = self.material(nested[0][1], nested[0][0], True, behind if back is None else back, own_id, perturb)
            self.materials[cached] = name
            return name
        if kind in ("normalmap", "bumpmap"):
            if len(nested) != 1:
                self.fail(self.where(node, path).at, path, len(nested), f"{kind} must wrap one bsdf")
            textures = [(p, v) for p, v, category in self.objects(
                {k: v for k, v in params.items() if not _is_bsdf(self.resolve(v, path))}, path, node)
                if category == "texture"]
            if len(textures) != 1 or (kind == "normalmap" and "normalmap" not in params):
                self.fail(self.where(node, path).at, path, len(textures), f"{kind} takes one texture"
                          + (" named normalmap" if kind == "normalmap" else ""))
            if perturb is not None:
                self.unsupported(self.where(node, path).at, f"{kind} inside {perturb[1]}",
                                 "one map tilts a material's normal")
            scale = float(self.number(params.get("scale", 1.0), node, path, "scale"))
            # the map inside a twosided (two_sided already): its back sees the map's normal mirrored
            inner = (node, kind, self.texture(textures[0][1], textures[0][0]), scale, two_sided)
            name = self.material(nested[0][1], nested[0][0], two_sided, back, own_id, inner)
            self.materials[cached] = name
            return name
        name = own_id or f"bsdf_{len(self.table['materials'])}"
        while name in self.table["materials"]:
            name += "_"
        self.materials[cached] = name
        material = {"type": kind}
        self.table["materials"][name] = material  # its name taken before the BSDFs inside take theirs
        prefix = f"materials.{name}"

        def put(key, value, param):
            material[key] = value
            self.origin(f"{prefix}.{key}", node, path, param)

        if kind in ("blendbsdf", "mask"):
            wanted = 2 if kind == "blendbsdf" else 1
            if len(nested) != wanted:
                self.fail(self.where(node, path).at, path, len(nested), f"{kind} must wrap {wanted} bsdf"
                          f"{'s' * (wanted > 1)}")
            inner = [self.material(v, p, two_sided, None, None, perturb) for p, v in nested]
            weight = "weight" if kind == "blendbsdf" else "opacity"
            if kind == "blendbsdf" and weight not in params:
                self.fail(self.where(node, path).at, f"{path}.weight", None, "missing (blendbsdf's weight)")
            put(weight, self.float_or_texture(params.get(weight, 0.5), node, path, weight), weight)
            if kind == "blendbsdf":
                put("bsdfs", inner, "bsdf")
            else:
                put("bsdf", inner[0], "bsdf")
        else:
            self.bsdf_values(bsdfs.BY_NAME[kind], params, node, path, put)
            # an opaque principled (no spec_trans) is one-sided in Mitsuba, as its other reflecting BSDFs
            opaque = kind == "principled" and material.get("spec_trans", 0.0) == 0
            if not two_sided and (bsdfs.BY_NAME[kind].front_only or opaque):
                material["two_sided"] = False
            if perturb is not None:
                wrapper, key, texture, scale, inside_twosided = perturb
                put(key, texture, key if key == "normalmap" else "texture")
                if key == "bumpmap":
                    put("bump_scale", scale, "scale")
                if inside_twosided:
                    put("mirrored_maps", True, "bsdf")
        if back is not None:
            material["back"] = back
        return name

    def float_or_texture(self, value, node, path, param):
        """A float parameter's value: a number, or a texture's table."""
        value = self.resolve(value, path)
        if isinstance(value, dict) and _type(value) in LOOKUPS:
            return self.texture(value, f"{path}.{param}")
        return float(self.number(value, node, path, param))

    def texture(self, node, path):
        """The scene table's texture table (texture_lookups.py) of a Mitsuba bitmap or checkerboard: its to_uv's 2D
        part composed with the flip of t (raytrace's t runs up the image, Mitsuba's down it)."""
        kind = node["type"]
        params = self.params(node, path, kind)
        table = {"type": kind}
        if kind == "mesh_attribute":
            table["name"] = self.string(params.get("name"), node, path, "name")
            table["scale"] = float(self.number(params.get("scale", 1.0), node, path, "scale"))
            return table
        if "to_uv" in params:
            m = self.matrix(params["to_uv"], node, path, "to_uv")
            table["to_uv"] = [[m[0, 0], m[0, 1], m[0, 3]], [-m[1, 0], -m[1, 1], 1.0 - m[1, 3]]]
        else:
            table["to_uv"] = [[1.0, 0.0, 0.0], [0.0, -1.0, 1.0]]
        if kind == "bitmap":
            table["filename"] = self.path(self.string(params.get("filename"), node, path, "filename"))
            table["raw"] = self.boolean(params.get("raw", False), node, path, "raw")
            table["filter_type"] = self.string(params.get("filter_type", "bilinear"), node, path, "filter_type",
                                               ("nearest", "bilinear"))
            table["wrap_mode"] = self.string(params.get("wrap_mode", "repeat"), node, path, "wrap_mode",
                                             ("repeat", "mirror", "clamp"))
            if "accel" in params:
                self.boolean(params["accel"], node, path, "accel")
        else:
            for key, default in (("color0", 0.4), ("color1", 0.2)):
                value = self.resolve(params.get(key, default), path)
                if isinstance(value, dict) and _type(value) in LOOKUPS:
                    self.unsupported(self.where(value, path).at, "a texture inside a checkerboard",
                                     "its colours must be numbers or rgb values")
                table[key] = self.colour(value, node, path, key)
        return table

    def bsdf_values(self, bsdf, params, node, path, put):
        """The scene table's values of a BSDF's Mitsuba parameters, as its declaration (bsdfs.py) names them: each
        given value, else Mitsuba's default, under the scene table's key for it; the scene file's reader then checks
        and resolves them as a TOML file's (named media and metals, Mitsuba's rules between alpha, alpha_u and
        alpha_v, and between eta, k and material)."""
        colours = [p for p in bsdf.parameters if p.fields == ("colour",)]
        textured = [p for p in bsdf.parameters if p.name in params and _type(self.resolve(params[p.name], path)) in
                    LOOKUPS]
        for p in textured:
            if p.key is None or bsdfs.texture_slot(bsdf, p.key.name) is None:
                self.fail(self.where(node, path).of(p.name), f"{path}.{p.name}", params[p.name]["type"],
                          f"raytrace's {bsdf.name} takes a value here, not a texture")
            put(p.table_key, self.texture(self.resolve(params[p.name], path), f"{path}.{p.name}"), p.name)
        original, params = params, {k: v for k, v in params.items() if k not in {p.name for p in textured}}
        if any(p.fields == ("colour",) for p in textured):
            colours = []
        values = [self.colour(params.get(p.name, p.mitsuba_default), node, path, p.name) for p in colours]
        if any(value != values[0] for value in values[1:]):
            self.unsupported(self.where(node, path).of(colours[-1].name), f"{bsdf.name} transmittance unlike its "
                             "reflectance", "raytrace's glass has one colour for both")
        if colours:
            put("colour", values[0] or self.colour(colours[0].mitsuba_default, node, path, colours[0].name),
                colours[0].name)
        conductor = "k" in bsdf.key_names()  # eta, k and material: a conductor's (principled's eta is a number)
        if conductor and ("material" in original or "eta" in original or "k" in original):
            self.string(params.get("material", "none"), node, path, "material")
            if "eta" in original or "k" in original:  # Mitsuba's defaults of either, given the other: eta 0, k 1
                for name, default in (("eta", 0.0), ("k", 1.0)):
                    if name not in {p.name for p in textured}:  # (a texture is put above)
                        put(name, self.colour(params.get(name, default), node, path, name, unbounded=True), name)
        for p in bsdf.parameters:
            if p.key is None and isinstance(p.mitsuba_default, bool) and p.name in params:  # sample_visible
                self.boolean(params[p.name], node, path, p.name)
            if p.key is None or p.fields == ("colour",) or (conductor and p.name in ("eta", "k")) or p in textured:
                continue
            if p.name not in params:
                if p.key.default is None or p.name == "material" or (
                        p.name == "alpha" and ("alpha_u" in original or "alpha_v" in original)):
                    continue  # none given: the scene file's default is Mitsuba's
                value = p.mitsuba_default
            else:
                value = self.resolve(params[p.name], path)
            kind = p.key.kind
            if kind == "number" or (kind == "number-or-name" and not isinstance(value, str)):
                value = self.number(value, node, path, p.name)
            elif kind == "string":
                value = self.string(value, node, path, p.name)
                value = value.lower() if p.name == "distribution" else value  # as Mitsuba reads it
            elif kind == "boolean":
                value = self.boolean(value, node, path, p.name)
            elif kind == "number-or-vector":
                value = self.colour(value, node, path, p.name)
            put(p.table_key, value, p.name)

    def warn(self, at, what, problem):
        if what not in self.warned:
            self.warned.add(what)
            self.out.warnings.append(printable(f"{at}: {what}: {problem}"))

    # -- shapes and their emitters
    def shape(self, key, node, outer=None):
        """Add shape `node` to the table; `outer`: (key, node, to_world) of the instance that places it (a
        shapegroup's shape), whose to_world goes before the shape's own."""
        name = node["type"]
        params = self.params(node, key, name)
        bsdf, emitter = None, None
        for path, v, category in self.objects(params, key, node):
            if category == "bsdf":
                bsdf = (path, v)
            elif category == "emitter":
                emitter = (path, v)
            elif v["type"] in ("shapegroup", "instance"):
                self.fail(self.where(v, path).at, path, v["type"], f"is not a parameter of a {name} shape (Mitsuba: "
                          "an instance places a shapegroup, and nothing else holds either)")
            else:
                self.unsupported(self.where(v, path).at, f"a {category} in a shape", "not supported")
        m = self.matrix(params["to_world"], node, key, "to_world") if "to_world" in params else np.eye(4)
        placed_by = (key, node) if outer is None else outer[:2]  # where a key made from the placement came from
        if outer is not None:
            m = outer[2] @ m
        radiance = None
        if emitter is not None:
            radiance = self.emission(emitter)
            if self.light(key, node, params, m, bsdf, emitter, radiance):
                return
        if radiance is None:
            material = self.material(bsdf[1] if bsdf else None, bsdf[0] if bsdf else f"{key}.bsdf")
        else:  # an emitting shape: its BSDF black by default (Mitsuba's shape.cpp), as the lights'
            material = self.emitter_material(bsdf)
        index = len(self.table["shapes"])
        prefix = f"shapes[{index}]"
        if name == "rectangle":
            frame = _rectangle(m, params.get("flip_normals", False))
            if frame is None:  # sheared: a parallelogram, two triangles
                corners = (m @ np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]]).T).T[:, :3]
                shape = {"type": "mesh", "vertices": corners.tolist(), "faces": [[0, 1, 2], [0, 2, 3]]}
            else:
                shape = {"type": "rectangle", **frame}
            for k in shape:
                self.origin(f"{prefix}.{k}", *placed_by, "to_world")
        elif name == "cube":
            vertices, faces, uv = _cube(m, self.boolean(params.get("flip_normals", False), node, key,
                                                        "flip_normals"))
            shape = {"type": "mesh", "vertices": vertices, "faces": faces, "uv": uv}
            for k in ("vertices", "faces", "uv"):
                self.origin(f"{prefix}.{k}", *placed_by, "to_world")
        elif name in ("obj", "ply", "serialized"):
            # face_normals: flat; else the file's normals, or Mitsuba's angle-weighted ones where it has none
            filename = self.string(params.get("filename"), node, key, "filename")
            smooth = not self.boolean(params.get("face_normals", False), node, key, "face_normals")
            flip = self.boolean(params.get("flip_tex_coords", name == "obj"), node, key, "flip_tex_coords")
            flip_normals = self.boolean(params.get("flip_normals", False), node, key, "flip_normals")
            shape = {"type": "mesh", "file": self.path(filename), "matrix": m.tolist(), "smooth": smooth,
                     **({"vertex_normals": "angle"} if smooth else {}), **({"flip_tex_coords": True} if flip else {}),
                     **({"flip_normals": True} if flip_normals else {})}
            if "shape_index" in params:  # Mitsuba's default is the TOML's: 0
                shape["shape_index"] = self.number(params["shape_index"], node, key, "shape_index", integer=True)
                self.origin(f"{prefix}.shape_index", node, key, "shape_index")
            self.origin(f"{prefix}.file", node, key, "filename")
            self.origin(f"{prefix}.matrix", *placed_by, "to_world")
        elif name in ("disk", "cylinder"):  # raytrace's own, with Mitsuba's parameters
            shape = {"type": name, "to_world": m.tolist()}
            self.origin(f"{prefix}.to_world", *placed_by, "to_world")
            if self.boolean(params.get("flip_normals", False), node, key, "flip_normals"):
                shape["flip_normals"] = True
                self.origin(f"{prefix}.flip_normals", node, key, "flip_normals")
            for k in ("p0", "p1", "radius") if name == "cylinder" else ():
                if k in params:
                    shape[k] = (self.number(params[k], node, key, k) if k == "radius"
                                else np.asarray(params[k], np.float64).tolist())
                    self.origin(f"{prefix}.{k}", node, key, k)
        else:  # sphere: an ellipsoid whose axes are to_world's columns times the radius
            center = np.asarray(params.get("center", (0.0, 0.0, 0.0)), np.float64)
            radius = self.number(params.get("radius", 1.0), node, key, "radius")
            if not _uniform(m):  # the instance's to_world where the sphere's own is uniform
                blamed = (key, node) if outer is None or not _uniform(m @ np.linalg.inv(outer[2])) else placed_by
                self.unsupported(self.where(blamed[1], blamed[0]).of("to_world"), "sphere with a non-uniform scale",
                                 "a sphere's to_world must be a rotation, a uniform scale and a translation (as "
                                 "Mitsuba's sphere takes it)")
                return
            # the axes negated: the same sphere, whose (u, v) are then Mitsuba's (phi / 2 pi, theta / pi), theta
            # from the pole +z, where an ellipsoid's own are (phi / 2 pi + 1/2, 1 - theta / pi)
            axes = -(m[:3, :3] * radius).T
            shape = {"type": "ellipsoid", "center": (m[:3, :3] @ center + m[:3, 3]).tolist(), "axes": axes.tolist()}
            self.origin(f"{prefix}.center", node, key, "center")
            self.origin(f"{prefix}.axes", node, key, "radius")
            if self.boolean(params.get("flip_normals", False), node, key, "flip_normals"):
                shape["flip_normals"] = True
                self.origin(f"{prefix}.flip_normals", node, key, "flip_normals")
        if material is not None:
            shape["material"] = material
        if radiance is not None:
            shape["radiance"] = radiance
            self.origin(f"{prefix}.radiance", emitter[1], emitter[0], "radiance")
        self.table["shapes"].append(shape)

    # -- instancing: each instance's shapegroup flattened into world-space shapes (Mitsuba's shapegroup.cpp and
    # instance.cpp give the rules; a two-level BVH would keep one copy)
    def group(self, key, node):
        """[(path, shape dict)] of shapegroup `node`, checked once as Mitsuba's ShapeGroup checks its children:
        shapes only, none of them a shapegroup, an instance or an emitting shape."""
        if id(node) in self.groups:
            return self.groups[id(node)]
        shapes = []
        for path, v, category in self.objects(self.params(node, key, "shapegroup"), key, node):
            at = self.where(v, path).at
            if category != "shape":
                self.fail(at, path, v["type"], f"a shapegroup holds shapes only, not a {category}")
            if v["type"] in ("shapegroup", "instance"):
                article = "an" if v["type"] == "instance" else "a"
                self.fail(at, path, v["type"], f"{article} {v['type']} inside a shapegroup is not allowed (Mitsuba: "
                          "nested instancing is not permitted)")
            emitters = [(p, e) for p, e, c in self.objects(self.params(v, path, v["type"]), path, v) if c == "emitter"]
            if emitters:
                self.fail(self.where(emitters[0][1], emitters[0][0]).at, emitters[0][0], emitters[0][1]["type"],
                          "an emitter on a shapegroup's shape is not allowed (Mitsuba does not instance emitters)")
            shapes.append((path, v))
        self.groups[id(node)] = shapes
        return shapes

    def instanced(self, key, node):
        """(shapegroup path, shapegroup dict, to_world) of instance `node`: Mitsuba's instance holds exactly one
        shapegroup (given by reference, or inline)."""
        params = self.params(node, key, "instance")
        inner = self.objects(params, key, node)
        at = self.where(node, key).at
        if not inner:
            self.fail(at, f"{key}.shapegroup", None, "missing: an instance places a shapegroup (<ref id=\"...\"/>)")
        for path, v, category in inner:
            if v["type"] != "shapegroup":
                self.fail(self.where(v, path).at, path, v["type"], "an instance holds a shapegroup only")
        if len(inner) > 1:
            self.fail(self.where(inner[1][1], inner[1][0]).at, inner[1][0], len(inner),
                      "an instance places one shapegroup")
        m = self.matrix(params["to_world"], node, key, "to_world") if "to_world" in params else np.eye(4)
        return inner[0][0], inner[0][1], m

    def check_instances(self, shapes):
        """Check every shapegroup, and that the scene's primitives stay within MAX_GENERATED_TRIANGLES (a file's
        triangles, a cube's 12, one for each analytic shape): a group's meshes are kept once (the kernel's
        two-level BVH), its other shapes copied per instance; 50 million primitives already take gigabytes."""
        total, count, counted = 0, 0, set()
        for key, node in shapes:
            if node["type"] == "shapegroup":
                self.group(key, node)
            if node["type"] != "instance":
                continue
            path, group, _ = self.instanced(key, node)
            count += 1  # a group's meshes are kept once; its other shapes are copied per instance
            total += sum(self.primitives(p, v) for p, v in self.group(path, group)
                         if v["type"] not in MESH_SHAPES or id(group) not in counted)
            counted.add(id(group))
            if total > MAX_GENERATED_TRIANGLES:
                self.fail(self.where(node, key).at, "instances", count, f"so many instances make {total:,} "
                          f"primitives, beyond {MAX_GENERATED_TRIANGLES:,} (a group's meshes count once, its other "
                          "shapes once per instance: raytrace copies them)")

    def primitives(self, key, node):
        """How many primitives shape `node` becomes (a mesh file read once, through the translation's cache)."""
        name = node["type"]
        if name in ("obj", "ply", "serialized"):
            params = self.params(node, key, name)
            filename = self.path(self.string(params.get("filename"), node, key, "filename"))
            index = self.number(params.get("shape_index", 0), node, key, "shape_index", integer=True)
            mesh, _ = self.out.files.load(Path(self.folder, filename), self.where(node, key).of("filename"),
                                          "filename", index)
            return len(mesh.faces)
        return {"cube": 12, "rectangle": 1, "sphere": 1, "disk": 1, "cylinder": 1}.get(name, 0)

    def instance(self, key, node):
        """An instance: its group's meshes kept once, as a raytrace group (the kernel's two-level BVH,
        kernels/instances.cl) that a shape of type "instance" places; its other shapes (spheres, disks, cylinders,
        rectangles: one primitive each) copied into the world under its to_world."""
        path, group, m = self.instanced(key, node)
        shapes = self.group(path, group)
        meshes = [(k, v) for k, v in shapes if v["type"] in MESH_SHAPES]
        if meshes:
            groups = self.table.setdefault("groups", {})
            name = self.group_names.setdefault(id(group), f"group{len(self.group_names)}")
            if name not in groups:  # its meshes, translated once into the group's space
                world, self.table["shapes"] = self.table["shapes"], []
                before = dict(self.out.origins)
                for shape_key, shape in meshes:
                    self.shape(shape_key, shape)
                groups[name], self.table["shapes"] = {"shapes": self.table["shapes"]}, world
                # the keys shape() recorded as the world's shapes[k] are the group's: put them there, and the
                # world's own back
                recorded = {k: v for k, v in self.out.origins.items() if before.get(k) is not v}
                self.out.origins = {**before, **{(f"groups.{name}.{k}" if k.startswith("shapes[") else k): v
                                                 for k, v in recorded.items()}}
            self.table["shapes"].append({"type": "instance", "group": name, "matrix": m.tolist()})
            self.origin(f"shapes[{len(self.table['shapes']) - 1}].matrix", node, key, "to_world")
        for shape_key, shape in shapes:
            if shape["type"] not in MESH_SHAPES:
                self.shape(shape_key, shape, (key, node, m))

    def path(self, filename):
        """A file as Mitsuba finds it (in the scene's folder, then in its <path> folders), relative to the scene's
        folder: the scene table's files are, as a scene file's are."""
        for base in (self.folder, *self.search):
            if Path(base, filename).exists():
                return os.path.relpath(Path(base, filename), self.folder) if base != self.folder else filename
        return filename

    def emission(self, emitter):
        """The radiance of a shape's `area` emitter (Mitsuba's default 1 where it gives none)."""
        path, em = emitter
        if em["type"] != "area":
            self.fail(self.where(em, path).at, path, em["type"], "a shape's emitter must be an area emitter")
        radiance = self.colour(self.params(em, path, "area").get("radiance", 1.0), em, path, "radiance", emission=True)
        return radiance if radiance is not None else [1.0] * 3

    def emitter_material(self, bsdf):
        """The material of an emitting shape or light: None (black, Mitsuba's default BSDF for a shape with an
        emitter, shape.cpp), or its BSDF's where that reflects, which only the path model renders."""
        if bsdf is None or self.black(bsdf[1], bsdf[0]):
            return None
        if self.table["render"]["shading"] != "path":
            self.unsupported(self.where(*reversed(bsdf)).at, "a light's bsdf with the direct integrator",
                             "raytrace's direct model: lights reflect nothing (a black diffuse only)")
            return None
        return self.material(bsdf[1], bsdf[0])

    def light(self, key, node, params, m, bsdf, emitter, radiance):
        """Map an emitting rectangle, or a mesh that is one planar rectangle, to a rectangular light (which
        light_sampling.cl samples with its culling and sweeps); False for every other emitting shape, which
        becomes a shape with a radiance (kernels/emitters.cl)."""
        name = node["type"]
        if name == "rectangle":
            frame = _rectangle(m, params.get("flip_normals", False))
        elif name in ("obj", "ply"):
            filename = self.path(self.string(params.get("filename"), node, key, "filename"))
            at = self.where(node, key).of("filename")
            mesh, _ = self.out.files.load(Path(self.folder, filename), at, "filename")  # read once (shape() again)
            vertices = mesh.vertices @ m[:3, :3].T + m[:3, 3]
            flip = self.boolean(params.get("flip_normals", False), node, key, "flip_normals")
            frame = _quad(vertices, mesh.faces[:, ::-1] if flip else mesh.faces)
        else:
            frame = None
        if frame is None:
            return False
        light = {**frame, "radiance": radiance}
        index = len(self.table["lights"])
        for k in frame:
            self.origin(f"lights[{index}].{k}", node, key, "to_world")
        self.origin(f"lights[{index}].radiance", emitter[1], emitter[0], "radiance")
        material = self.emitter_material(bsdf)
        if material is not None:
            light["material"] = material
        self.table["lights"].append(light)
        return True

    def black(self, node, path):
        """Whether BSDF `node` is a black diffuse one (twosided or not): what raytrace's direct model's lights are."""
        node = self.resolve(node, path)
        while _type(node) == "twosided":
            inner = self.objects(self.params(node, path, "twosided"), path, node)
            if len(inner) != 1:
                return False
            path, node = inner[0][0], inner[0][1]
        if _type(node) != "diffuse":
            return False
        reflectance = self.params(node, path, "diffuse").get("reflectance", DEFAULT_DIFFUSE)
        return self.colour(reflectance, node, path, "reflectance") == [0.0, 0.0, 0.0]

    def environment(self, key, node):
        name = node["type"]
        if name == "area":
            self.fail(self.where(node, key).at, key, name, "an area emitter belongs inside a shape")
        if name not in ("constant", "envmap"):
            self.unsupported(self.where(node, key).at, f"emitter {name}", "not supported (raytrace renders: area, "
                             "constant, envmap, point, spot, directional, projector)")
            return
        params = self.params(node, key, name)
        if name == "constant":
            env = {"type": "constant", "radiance": self.colour(params.get("radiance", 1.0), node, key, "radiance",
                                                               emission=True)}
            self.origin("environment.radiance", node, key, "radiance")
        else:
            filename = self.string(params.get("filename"), node, key, "filename")
            m = self.matrix(params["to_world"], node, key, "to_world") if "to_world" in params else np.eye(4)
            linear = m[:3, :3]
            if not np.allclose(linear.T @ linear, np.eye(3), rtol=0, atol=1e-5) or np.linalg.det(linear) < 0:
                self.fail(self.where(node, key).of("to_world"), f"{key}.to_world", m.tolist(),
                          "an envmap's to_world must be a rotation")
            env = {"type": "envmap", "filename": self.path(filename),
                   "scale": self.number(params.get("scale", 1.0), node, key, "scale"),
                   "up": linear[:, 1].tolist(), "forward": linear[:, 2].tolist()}
            for k, param in (("filename", "filename"), ("scale", "scale"), ("up", "to_world"), ("forward", "to_world")):
                self.origin(f"environment.{k}", node, key, param)
        self.table["environment"] = env

    def delta_light(self, key, node):
        """An [[emitters]] table (delta_lights.py) of Mitsuba's point, spot, directional or projector: its
        parameters under their own names, colours as RGB, textures as texture tables (their to_uv composed for a
        light's (u, v), whose v the scene format counts up from the image's bottom: delta_lights.py)."""
        name = node["type"]
        params = self.params(node, key, name)
        index = len(self.table.setdefault("emitters", []))
        light, prefix = {"type": name}, f"emitters[{index}]"
        for param, value in params.items():
            value = self.resolve(value, key)
            if param == "to_world":
                light[param] = self.matrix(value, node, key, param).tolist()
            elif param in ("position", "direction"):
                light[param] = value
            elif param in ("irradiance", "texture") and _type(value) in LOOKUPS:
                table = self.texture(value, f"{key}.{param}")
                (a, b, c), (d, e, f) = table["to_uv"]
                table["to_uv"] = [[a, -b, b + c], [d, -e, f + e]]  # of (u, 1 - v), not of (u, v)
                light[param] = table
            elif param in ("intensity", "irradiance"):
                light[param] = self.colour(value, node, key, param, emission=True)
            elif param in ("cutoff_angle", "beam_width", "scale", "fov"):
                light[param] = float(self.number(value, node, key, param))
            elif param == "fov_axis":
                light[param] = self.string(value, node, key, param).lower()
            elif param == "focal_length":
                text = str(value)
                try:
                    light[param] = float(text[:-2] if text.endswith("mm") else text)
                except ValueError:
                    self.fail(self.where(node, key).of(param), f"{key}.{param}", text, FOCAL_LENGTH_FORM)
            else:
                light[param] = value
            self.origin(f"{prefix}.{param}", node, key, param)
        self.origin(prefix, node, key, "type")
        self.table["emitters"].append(light)


# Mitsuba 3's cube (src/shapes/cube.cpp): 24 vertices, four per face, each face's (u, v) over [0, 1]^2, 12 triangles
# wound counter-clockwise seen from outside
CUBE_VERTICES = [(1, -1, -1), (1, -1, 1), (-1, -1, 1), (-1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, 1, 1), (1, 1, 1),
                 (1, -1, -1), (1, 1, -1), (1, 1, 1), (1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1), (-1, -1, 1),
                 (-1, -1, 1), (-1, 1, 1), (-1, 1, -1), (-1, -1, -1), (1, 1, -1), (1, -1, -1), (-1, -1, -1),
                 (-1, 1, -1)]
CUBE_UV = [(0, 1), (1, 1), (1, 0), (0, 0)] * 6
CUBE_FACES = [(0, 1, 2), (3, 0, 2), (4, 5, 6), (7, 4, 6), (8, 9, 10), (11, 8, 10), (12, 13, 14), (15, 12, 14),
              (16, 17, 18), (19, 16, 18), (20, 21, 22), (23, 20, 22)]


def _uniform(m):
    """Whether affine `m` is a rotation (or mirror), a uniform scale and a translation."""
    linear = m[:3, :3]
    scale = abs(np.linalg.det(linear)) ** (1 / 3)
    return np.allclose(linear.T @ linear, scale ** 2 * np.eye(3), rtol=0, atol=1e-6 * scale ** 2)


def _cube(m, flip):
    """(vertices, faces, uv) of Mitsuba's cube under the 4 x 4 matrix m, as a scene table's mesh. Its shading
    normals are to_world's normals of the faces, outwards; a triangle's front is its winding's, which a mirroring
    to_world turns: the faces are turned back then, and turned over where flip_normals turns Mitsuba's normals
    in."""
    vertices = (np.c_[np.array(CUBE_VERTICES, np.float64), np.ones(24)] @ m.T)[:, :3]
    inward = (np.linalg.det(m[:3, :3]) < 0) != bool(flip)
    faces = [[a, c, b] if inward else [a, b, c] for a, b, c in CUBE_FACES]
    return vertices.tolist(), faces, [list(map(float, t)) for t in CUBE_UV]


def _rectangle(m, flip):
    """raytrace's rectangle keys of Mitsuba's [-1, 1]^2 under affine `m`, or None where m shears it. The normal
    is Mitsuba's: +z under the inverse transpose, which for columns ex, ey is along ex x ey / det."""
    ex, ey = m[:3, 0], m[:3, 1]
    lx, ly = np.linalg.norm(ex), np.linalg.norm(ey)
    if not abs(np.dot(ex, ey)) <= 1e-6 * lx * ly:
        return None
    normal = np.cross(ex, ey) * np.sign(np.linalg.det(m[:3, :3]))
    normal = -normal if flip else normal
    normal = normal / np.linalg.norm(normal) + 0.0  # no -0.0: the kernel's frames test signs
    return {"center": m[:3, 3].tolist(), "size": [2 * float(lx), 2 * float(ly)], "normal": normal.tolist(),
            "tangent": (ex / lx + 0.0).tolist()}


def _quad(vertices, faces):
    """The rectangle a mesh of two triangles over four corners is, with its faces' normal (counter-clockwise
    winding, as Mitsuba's), or None. The corners may be off a rectangle by float32 rounding: 16 ulps of the largest
    coordinate, far below a pixel, and far above the rounding of a file's float32 values."""
    used = np.unique(faces)
    if len(faces) != 2 or len(used) != 4:
        return None
    v = vertices[used]
    normal = np.cross(vertices[faces[0][1]] - vertices[faces[0][0]], vertices[faces[0][2]] - vertices[faces[0][0]])
    if not np.linalg.norm(normal) > 0:
        return None
    normal = normal / np.linalg.norm(normal)
    center = v.mean(axis=0)
    tolerance = 16 * np.finfo(np.float32).eps * max(np.abs(vertices).max(), 1e-30)
    # the corners' diagonals: a rectangle's bisect each other and are equally long
    order = sorted(range(4), key=lambda i: np.linalg.norm(v[i] - v[0]))
    a, b, c, d = v[order[0]], v[order[1]], v[order[2]], v[order[3]]  # a's farthest is d, the opposite corner
    edge_u, edge_v = b - a, c - a
    if (abs(np.dot(edge_u, edge_v)) > tolerance * (np.linalg.norm(edge_u) + np.linalg.norm(edge_v))
            or np.abs(a + edge_u + edge_v - d).max() > tolerance
            or np.abs(np.dot(v - center, normal)).max() > tolerance):
        return None
    lu, lv = np.linalg.norm(edge_u), np.linalg.norm(edge_v)
    return {"center": center.tolist(), "size": [float(lu), float(lv)], "normal": normal.tolist(),
            "tangent": (edge_u / lu).tolist()}


def _type(value):
    """The plugin type of a dict-form value: its "type" where that is a string, else None (a caller's dict may
    hold anything there)."""
    kind = value.get("type") if isinstance(value, dict) else None
    return kind if isinstance(kind, str) else None


def _is_bsdf(value):
    """Whether a plugin's parameter is a BSDF nested in it (known, or given in a <bsdf> tag)."""
    if not _is_object(value) or not isinstance(value.get("type"), str):
        return False
    tag = value[WHERE].tag if isinstance(value.get(WHERE), Where) else ""
    return tag == "bsdf" or (value["type"] in PLUGINS and PLUGINS[value["type"]].category == "bsdf")


def _is_object(value):
    """A nested plugin or a reference (its name is free), not a value such as an rgb or a spectrum."""
    return isinstance(value, dict) and _type(value) not in ("rgb", "spectrum")


def _shown(value):
    if isinstance(value, dict):
        return {k: v for k, v in value.items() if k != WHERE}
    return value.tolist() if isinstance(value, np.ndarray) else value


def translate(node, source, folder, ignore_unsupported=False):
    """raytrace's scene table (a Translation) of Mitsuba dict-form scene `node`; files relative to `folder`;
    errors name `source` where no XML element is known. Overflows make infinities, which the table's reader
    refuses by name, not warnings."""
    with np.errstate(all="ignore"):
        return _Translator(source, folder, ignore_unsupported).scene(node)


def located(error, translation):
    """A scene table's InputError, named at the XML element or dict entry its key came from."""
    key = str(error.key)
    for k in (key, key.split(".")[0]):  # the key itself, else its table's
        if k in translation.origins:
            at, param = translation.origins[k]
            return InputError(at, param, error.value, error.problem)
    return error


def _triangle_soups(scene):
    """The scene's triangles, and each mesh's, as N x 3 x 3 corner arrays."""
    soups = [np.array([t.vertices for t in scene.triangles])] if scene.triangles else []
    return soups + [m.mesh.vertices[m.mesh.faces] for m in scene.meshes]


def _boxes(scene):
    """The eight corners of a world box about each disk, cylinder and instance (8 x 3 arrays): bounds that
    contain them, for the clip planes' checks."""
    unit = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (0.0, 1.0)])
    boxes = [unit @ s.matrix[:3, :3].T + s.matrix[:3, 3] for s in scene.disks + scene.cylinders]
    for instance in scene.instances:
        lo, hi = instance.bounds(scene.groups[instance.group])
        boxes.append(np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]))
    return boxes


def view_depths(scene):
    """How far along the camera's view each primitive's extreme points lie: rectangles' and lights' corners,
    triangles' vertices, ellipsoids' extents along the view, the corners of boxes about the others
    (without_idle_clip_planes, and the planes mitsuba_writer.py writes)."""
    eye = scene.camera.position
    forward, _, _ = scene.camera.basis()
    depths = [np.empty(0)]
    for r in scene.rectangles + scene.lights:
        corners = [r.center + sx * r.size[0] / 2 * r.tangent + sy * r.size[1] / 2 * r.bitangent
                   for sx in (-1, 1) for sy in (-1, 1)]
        depths.append((np.array(corners) - eye) @ forward)
    depths += [((corners - eye) @ forward).ravel() for corners in _triangle_soups(scene)]
    for e in scene.ellipsoids:
        mid, reach = np.dot(e.center - eye, forward), np.linalg.norm(e.axes @ forward)
        depths.append(np.array([mid - reach, mid + reach]))
    depths += [(box - eye) @ forward for box in _boxes(scene)]
    return np.concatenate(depths)


def without_idle_clip_planes(scene, table):
    """Mitsuba's clip planes: a camera ray starts on the near plane and ends on the far one, so what lies in view
    nearer than near_clip, or farther than far_clip, along the view is cut; raytrace's camera clips so too. A
    pinhole's plane that cuts nothing is dropped (as the TOML's default, none), so that a scene renders bit for
    bit as its TOML does: the ray from the eye and the ray from the near plane are the same ray in exact
    arithmetic, not in float32. Near: the part of the view nearer than the near plane lies within a ball of
    radius near * |(tan(fov_x / 2), tan(fov_y / 2), 1)| about the eye, and no primitive may reach into it (the
    exact distance to rectangles and triangles; an ellipsoid's centre less its longest semi-axis). Far: no point
    of a primitive lies farther along the view (its corners; an ellipsoid's extent along the view). Disks,
    cylinders and instances are bounded by boxes (_boxes). A dropped plane leaves the scene's table and `table`
    (the translation's) too."""
    camera = scene.camera
    if camera.kind != "perspective" or (camera.near_clip == 0 and camera.far_clip == math.inf):
        return scene
    import trimesh  # the distance to triangles (a dependency already: the mesh readers)
    eye, near = camera.position, camera.near_clip
    tan_y = math.tan(math.radians(camera.fov_deg) / 2)
    ball = near * math.sqrt(1 + tan_y ** 2 * (1 + (scene.width / scene.height) ** 2))
    distances = [np.array([math.inf])]
    for r in scene.rectangles + scene.lights:  # the eye in the rectangle's frame, clamped to it
        d = eye - r.center
        u, v = np.dot(d, r.tangent), np.dot(d, r.bitangent)
        du, dv = max(abs(u) - r.size[0] / 2, 0.0), max(abs(v) - r.size[1] / 2, 0.0)
        distances.append(np.array([math.sqrt(np.dot(d, r.normal) ** 2 + du ** 2 + dv ** 2)]))
    for corners in _triangle_soups(scene):
        # the distance to a triangle's box bounds the distance to it: only triangles whose box reaches into the
        # ball need the exact distance (about 1 s per 10^6 triangles with trimesh; the boxes take 0.05 s)
        gap = np.maximum(np.maximum(corners.min(axis=1) - eye, eye - corners.max(axis=1)), 0.0)
        close = np.linalg.norm(gap, axis=1) < ball
        if close.any():
            closest = trimesh.triangles.closest_point(corners[close], np.broadcast_to(eye, (int(close.sum()), 3)))
            distances.append(np.linalg.norm(closest - eye, axis=1))
    for e in scene.ellipsoids:
        distances.append(np.array([np.linalg.norm(e.center - eye) - np.linalg.norm(e.axes, 2)]))
    for box in _boxes(scene):  # the distance to the box bounds the distance to what it holds
        lo, hi = box.min(axis=0), box.max(axis=0)
        distances.append(np.array([np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0))]))
    nearest, farthest = np.concatenate(distances).min(), view_depths(scene).max(initial=-math.inf)
    idle = {"near_clip": nearest >= ball, "far_clip": farthest <= camera.far_clip}
    if not any(idle.values()):
        return scene
    scene.camera = dataclasses.replace(camera, near_clip=0.0 if idle["near_clip"] else near,
                                       far_clip=math.inf if idle["far_clip"] else camera.far_clip,
                                       dropped_near_clip=near if idle["near_clip"] else 0.0)
    for key, dropped in idle.items():  # from the scene's table, and the translation's (convert writes it)
        for source in (scene.source, table):
            if dropped and source is not None:
                source["camera"].pop(key, None)
    scene.checked = fingerprint(scene)
    return scene
