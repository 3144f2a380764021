"""Scene files: the TOML format and its validation, read into the scene model (model.py).

Every check names the file, the key and the value (InputError), so a user can fix a scene in one go.
"""
import copy
import dataclasses
import types
import datetime
import math
import os
import re
from collections.abc import Mapping
import tomllib
import warnings
from pathlib import Path

import numpy as np

from . import bsdfs, delta_lights, environment_map, keys, mesh_file, meshes, meshgen, mitsuba, mitsuba_xml, named_materials, ranges, \
    rules, texture_lookups
from ..errors import InputError, UnsupportedWarning, check_path, did_you_mean
from .. import aovs as aov_types, samplers
from .model import (RADIOMETRIC, WRAPPERS, Camera, Cylinder, Disk, fingerprint, Ellipsoid, EnvironmentMap, Light, Material, MeshShape, Rectangle, Scene,
                    ShapeEmitter, ShapeGroup, Instance,
                    Triangle, normalize)
from .textures import TextureCache
from .transform import AFFINE, mesh_matrix, placed_ellipsoid, placed_rectangle, placed_triangle, rectangle_shear

LIGHTS_SPEC = "lights[] (direct, path)"  # keys.py's table of a radiometric model's lights

FLOAT32_TINY, FLOAT32_MAX = float(np.finfo(np.float32).tiny), float(np.finfo(np.float32).max)


class Reader:
    """Typed access to one TOML table; every error names file, key path and value. Each key's type, default and
    range come from keys.py's declaration of the table (`spec`), the one the manual's table is made from."""

    def __init__(self, path, table, prefix="", spec=""):
        self.path, self.table, self.prefix, self.spec = path, table, prefix, keys.table(spec)
        if not isinstance(table, dict):
            self.fail("", table, "must be a table")

    def fail(self, key, value, problem):
        raise InputError(self.path, self.prefix + key if key else self.prefix.rstrip("."), value, problem)

    def check_keys(self, allowed=None):
        allowed = sorted(self.spec) if allowed is None else allowed
        for key in self.table:
            if key not in allowed:
                self.fail(key, self.table[key], f"unknown key{did_you_mean(key, allowed)} (expected one of: "
                          f"{', '.join(allowed)})")

    def has(self, key):
        return key in self.table

    def key(self, name, *kinds):
        """The declaration of key `name`, which must be of one of `kinds`."""
        key = self.spec[name]
        assert key.kind in kinds, (name, key.kind, kinds)
        return key

    def raw(self, key, default=None):
        if key not in self.table:
            if default is None:
                self.fail(key, None, "missing")
            return default
        return self.table[key]

    def _given(self, key):
        """The key's value, or its declared default; a missing required key is an error."""
        return self.raw(key.name, None if key.required else key.default)

    def number(self, name):
        key = self.key(name, "number", "number-or-vector", "number-or-name")
        value = self._given(key)
        low, high, open_low = key.low, key.high, key.open_low
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(name, value, "must be a finite number")
        if ranges.float32_problem(value):
            self.fail(name, value, ranges.float32_problem(value))
        if value < low or value > high or (open_low and value == low):
            bound = f"> {low}" if open_low else f">= {low}"
            self.fail(name, value, f"must be {bound} and <= {high}")
        if key.open_high and value == high:
            self.fail(name, value, f"must be < {high}")
        return float(value)

    def number_or_name(self, name):
        """A number in the key's range, or one of its names (in any case, as Mitsuba looks up its named media),
        as the number it stands for."""
        key = self.key(name, "number-or-name")
        value = self._given(key)
        if isinstance(value, str):
            named = dict(key.named)
            if value.lower() not in named:
                self.fail(name, value, f"must be a number or one of Mitsuba's names: {', '.join(named)}"
                          f"{did_you_mean(value.lower(), named, ';')}")
            return float(named[value.lower()])
        return self.number(name)

    def integer(self, name):
        key = self.key(name, "integer")
        value, low, high = self._given(key), int(key.low), int(key.high)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            self.fail(name, value, f"must be an integer in [{low}, {high}]")
        return value

    def string(self, name, choices=None):
        key = self.key(name, "string", "path")
        value, choices = self._given(key), key.choices if choices is None else choices
        if not isinstance(value, str) or (choices and value not in choices):
            self.fail(name, value, f"must be one of: {', '.join(choices)}{did_you_mean(value, choices, ';')}"
                      if choices else "must be a string")
        if key.kind == "path" and "\0" in value:  # no file system names a file so
            self.fail(name, value, "a file path cannot hold a NUL character")
        if key.kind == "path" and not value.strip():  # it would name the scene file's own folder
            self.fail(name, value, "must name a file")
        return value

    def boolean(self, name):
        value = self._given(self.key(name, "boolean"))
        if not isinstance(value, bool):
            self.fail(name, value, "must be true or false")
        return value

    def vector(self, name):
        key = self.key(name, "vector", "number-or-vector")
        return self._vector(name, self._given(key), key.length, key.nonzero, key.low)

    def _vector(self, name, value, n, nonzero=False, low=-math.inf):
        bound = f" >= {low}" if low > -math.inf else ""
        if not (isinstance(value, (list, tuple)) and len(value) == n
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
            self.fail(name, value, f"must be a list of {n} finite numbers{bound}")
        for x in value:
            if ranges.float32_problem(x):
                self.fail(name, value, ranges.float32_problem(x))
        if any(x < low for x in value):
            self.fail(name, value, f"must be a list of {n} finite numbers{bound}")
        v = np.array(value, dtype=np.float64)
        if nonzero and not np.any(v):
            self.fail(name, value, "must not be the zero vector")
        return v

    def vectors(self, name):
        key = self.key(name, "vectors")
        value, count = self.raw(name), key.count
        if not isinstance(value, list) or (count is not None and len(value) != count) or not value:
            self.fail(name, value, f"must be a list of {count or 'one or more'} vectors")
        return np.array([self._vector(name, v, key.length) for v in value])

    def sub(self, name):
        """The reader of the table under key `name`, declared in keys.TABLES under the same name."""
        self.key(name, "table")
        return Reader(self.path, self.raw(name), f"{self.prefix}{name}.", name)


def _frame(r, normal_key="normal", tangent_key="tangent"):
    """Unit normal and a tangent made orthogonal to it (Gram-Schmidt); refuses a tangent along the normal."""
    n = normalize(r.vector(normal_key))
    t_raw = r.vector(tangent_key)
    t = t_raw - np.dot(t_raw, n) * n
    if np.linalg.norm(t) < 1e-6 * np.linalg.norm(t_raw):
        r.fail(tangent_key, t_raw.tolist(), "must not be parallel to the normal")
    return n, normalize(t)


def check_frame(r):
    """The checks of a rectangle's or light's normal and tangent (model_check.py's use of _frame)."""
    _frame(r)


def _rgb(r, key):
    """A light's colour (Phong) or radiance (direct, emitted from the side its normal points to), or any
    other key declared number-or-vector: three numbers, or for such a key one, the same in every channel."""
    value = r.table.get(key, r.spec[key].default)
    if r.spec[key].kind == "number-or-vector" and isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.full(3, r.number(key))
    return r.vector(key)


def _rectangle_fields(r):
    """A rectangle's or light's center, size, normal and tangent, placed by its transform keys (if any)."""
    size = r.vector("size")
    if np.any(size <= 0):
        r.fail("size", size.tolist(), "both sides must be > 0")
    normal, tangent = _frame(r)
    center, m = r.vector("center"), _placement(r)
    if m is not None:
        cosine, tolerance = rectangle_shear(m, normal, tangent)
        if not cosine <= tolerance:
            key = transform_key(r)
            r.fail(key, r.raw(key), f"shears the rectangle: its sides would meet at "
                   f"{np.degrees(np.arccos(min(cosine, 1.0))):.9g} degrees, not 90 (a mesh of two triangles "
                   "takes a parallelogram)")
        center, size, normal, tangent = placed_rectangle(m, center, size, normal, tangent)
    return dict(center=center, size=size, normal=normal, tangent=tangent)


TRANSFORM_KEYS = tuple(key.name for key in keys.TRANSFORM)


def transform_key(r):
    """The key an error of a table's transform names: matrix, else the first of scale, rotate and translate
    given (scale where none is)."""
    return next((key for key in ("matrix", "scale", "rotate", "translate") if r.has(key)), "scale")


def _placement(r):
    """The 4 x 4 matrix of a course shape's transform keys, or None where it gives none: the shape is then
    as written, its values untouched by any arithmetic (an identity's would turn a -0.0 into 0.0)."""
    return _transform(r) if any(r.has(key) for key in TRANSFORM_KEYS) else None


class Placed(Reader):
    """The reader of a course shape that its transform keys placed: a check of the placed shape's geometry (a
    triangle's area, an ellipsoid's axes; rules.py's extents and sizes) fails naming the transform, as it was
    given, since that made the values checked."""
    GEOMETRY = ("center", "size", "normal", "tangent", "vertices", "axes")

    def __init__(self, r):
        vars(self).update(vars(r))
        self.by = transform_key(r)

    def fail(self, key, value, problem):
        if key in self.GEOMETRY:
            super().fail(self.by, self.raw(self.by), f"{problem} (the shape's {key} once transformed)")
        super().fail(key, value, problem)


def placed(r):
    """r, or its Placed reader where its table gives transform keys."""
    return Placed(r) if any(r.has(key) for key in TRANSFORM_KEYS) else r


def check_axes(r, axes):
    """An ellipsoid's axes span space."""
    if not abs(np.linalg.det(axes)) > 1e-6 * np.prod(np.linalg.norm(axes, axis=1)):
        r.fail("axes", axes.tolist(), "singular ellipsoid: the three axes must be linearly independent")


def affine_shape(r, kind, material):
    """The Disk or Cylinder of table `r` (its keys read with their defaults), checked by check_affine_shape."""
    to_world = r.vectors("to_world") if r.has("to_world") else np.eye(4)
    flip = r.boolean("flip_normals")
    if kind == "disk":
        shape = Disk(to_world, flip, material)
    else:
        shape = Cylinder(to_world, r.vector("p0"), r.vector("p1"), r.number("radius"), flip, material)
    check_affine_shape(r, shape)
    return shape


def check_affine_shape(r, shape):
    """A disk's or cylinder's to_world is affine and its map of the local unit shape (with the cylinder's p0,
    p1 and radius) invertible, within float32's range both ways; a cylinder's axis has a length."""
    m = np.asarray(shape.to_world, np.float64)
    if m.shape != (4, 4) or not np.array_equal(m[3], [0, 0, 0, 1]) or not abs(np.linalg.det(m[:3, :3])) > 0:
        r.fail("to_world", m.tolist(), AFFINE)
    if isinstance(shape, Cylinder) and not np.linalg.norm(np.subtract(shape.p1, shape.p0)) > 0:
        r.fail("p1", np.asarray(shape.p1).tolist(), "must differ from p0: the axis needs a length")
    local = shape.matrix
    linear = local[:3, :3]
    if not abs(np.linalg.det(linear)) > 1e-6 * np.prod(np.linalg.norm(linear, axis=0)):
        r.fail("to_world", m.tolist(), "singular: maps the shape onto a plane or a line (its axes must be "
               "linearly independent)")
    inverse = np.linalg.inv(linear)
    reach = np.abs(local[:3, 3]) + np.abs(linear).sum(axis=1)
    if not (reach.max() <= ranges.COORDINATE_LIMIT and np.abs(inverse).max() <= ranges.FLOAT32_MAX):  # also NaN
        r.fail("to_world", m.tolist(), f"puts the shape beyond {ranges.COORDINATE_LIMIT:.4g} (2^60) of the origin, "
               "or its inverse beyond float32's range")


def material_named(r, key, material_index, name=None):
    """The index of the material that key `key` names (or `name`, one of the names it lists)."""
    name = r.string(key) if name is None else name
    if not isinstance(name, str) or name not in material_index:
        r.fail(key, name, f"no such material (defined: {', '.join(material_index)})")
    return material_index[name]


def own_keys(r, kind, own, every):
    """Refuse the keys of `every` that a table of type `kind` does not take (it takes `own`)."""
    for key in every:
        if r.has(key) and key not in own:
            r.fail(key, r.raw(key), f'is not a parameter of type = "{kind}"')


def check_triangle(r, key, vertices):
    area2 = np.linalg.norm(np.cross(vertices[1] - vertices[0], vertices[2] - vertices[0]))
    scale = max(np.linalg.norm(vertices[1] - vertices[0]), np.linalg.norm(vertices[2] - vertices[0])) ** 2
    if not area2 > 1e-9 * scale:
        r.fail(key, vertices.tolist(), "degenerate triangle (zero area)")


def _load_shape(scene, r, material_index, files):
    """Add the shape of table `r` to `scene` (mesh files read through `files`, a mesh_file.MeshCache); returns
    what it added (the triangles of an inline mesh)."""
    before = {kind: len(getattr(scene, kind))
              for kind in ("rectangles", "triangles", "ellipsoids", "disks", "cylinders", "meshes")}
    _add_shape(scene, r, material_index, files)
    return [shape for kind, n in before.items() for shape in getattr(scene, kind)[n:]]


def _shape_material(scene, r, material_index):
    """The material index of shape table `r`: the one it names; for a shape with `radiance` (an area emitter) a
    material of its own, a copy of the one it names or a black one (none named), whose emitter is a new
    ShapeEmitter."""
    if not r.has("radiance"):
        return material_named(r, "material", material_index) if r.has("material") else r.raw("material")
    emitter, own = len(scene.emitters), len(scene.materials)
    if r.has("material"):
        named = scene.materials[material_named(r, "material", material_index)]
        material = dataclasses.replace(named, emitter=emitter)
    else:
        material = Material(name=f"{r.prefix}radiance", colour=np.zeros(3), emitter=emitter)
    scene.materials.append(material)
    scene.emitters.append(ShapeEmitter(own, _rgb(r, "radiance"), r.has("material")))
    return own


def _group_mesh(scene, r, material_index, files):
    """The MeshShape of a group's shape table `r` (type = "mesh", from a file, generated or inline), in the
    group's own space. A group holds no emitter (Mitsuba's rule for shapegroups)."""
    if r.string("type") != "mesh":
        r.fail("type", r.raw("type"), 'must be "mesh": a group holds meshes (place other shapes directly)')
    if r.has("radiance"):
        r.fail("radiance", r.raw("radiance"), "a group's shapes emit nothing (as Mitsuba's shapegroup)")
    scratch = types.SimpleNamespace(rectangles=[], triangles=[], ellipsoids=[], disks=[], cylinders=[], meshes=[],
                                    materials=scene.materials, emitters=scene.emitters)
    _add_shape(scratch, r, material_index, files)
    if scratch.meshes:
        return scratch.meshes[0]
    v = np.array([t.vertices for t in scratch.triangles], np.float64).reshape(-1, 3)
    uv = (np.array([t.uv for t in scratch.triangles], np.float64).reshape(-1, 2)
          if scratch.triangles[0].uv is not None else None)
    faces = np.arange(len(v), dtype=np.int32).reshape(-1, 3)
    return MeshShape(meshes.Mesh(v, faces, uvs=uv), scratch.triangles[0].material, source=r.prefix.rstrip("."))


def _groups(scene, r, material_index, files):
    """Scene.groups of the scene table's [groups.NAME] tables, and {name: index}."""
    tables, index = r.raw("groups", {}), {}  # keys.py declares its default: no groups
    if not isinstance(tables, dict):
        r.fail("groups", tables, "must be a table of named groups")
    for name, table in tables.items():
        gr = Reader(r.path, table, f"groups.{name}.", "groups.NAME")
        gr.check_keys()
        entries = gr.raw("shapes")
        if not isinstance(entries, list) or not entries:
            gr.fail("shapes", entries, 'must be an array of one or more [[shapes]] tables of type = "mesh"')
        index[name] = len(scene.groups)
        scene.groups.append(ShapeGroup(name, [
            _group_mesh(scene, Reader(r.path, e, f"groups.{name}.shapes[{i}].", "shapes[]"), material_index, files)
            for i, e in enumerate(entries)]))
    return index


def _instance(scene, r):
    """The Instance of shape table `r` (type = "instance"): its group, by name, under its transform keys."""
    r = Reader(r.path, r.table, r.prefix, 'shapes[] type = "instance"')
    r.spec = {**keys.table("shapes[]"), **r.spec}
    r.check_keys()
    for key in ("material", "radiance"):
        if r.has(key):
            r.fail(key, r.raw(key), "an instance's group's meshes have their own: give none")
    names = [g.name for g in scene.groups]
    name = r.string("group")
    if name not in names:
        r.fail("group", name, f"no such group (defined: {', '.join(names) or 'none'})")
    scene.instances.append(Instance(names.index(name), _transform(r)))


def _add_shape(scene, r, material_index, files):
    kind = r.string("type")
    if kind == "instance":
        return _instance(scene, r)
    m = _shape_material(scene, r, material_index)
    spec = {"mesh": 'shapes[] type = "mesh", from a file or generated'} if r.has("file") or r.has("generate") else {}
    r = Reader(r.path, r.table, r.prefix, spec.get(kind, f'shapes[] type = "{kind}"'))
    r.spec = {**keys.table("shapes[]"), **r.spec}
    r.check_keys()
    if kind == "rectangle":
        scene.rectangles.append(Rectangle(material=m, **_rectangle_fields(r)))
    elif kind == "triangle":
        vertices = r.vectors("vertices")
        check_triangle(r, "vertices", vertices)
        uv = r.vectors("uv") if r.has("uv") else None
        placement = _placement(r)
        if placement is not None:
            vertices, uv = placed_triangle(placement, vertices, uv)
            check_triangle(placed(r), "vertices", vertices)
        scene.triangles.append(Triangle(vertices, m, uv))
    elif kind == "disk":
        scene.disks.append(affine_shape(r, kind, m))
    elif kind == "cylinder":
        scene.cylinders.append(affine_shape(r, kind, m))
    elif kind == "mesh" and spec:
        scene.meshes.append(_mesh_shape(r, m, files))
    elif kind == "mesh":
        vertices = r.vectors("vertices")
        faces = r.raw("faces")
        uv = r.vectors("uv") if r.has("uv") else None
        if uv is not None and len(uv) != len(vertices):
            r.fail("uv", r.raw("uv"), f"must hold one pair per vertex ({len(vertices)}), not {len(uv)}")
        if not isinstance(faces, list) or not faces:
            r.fail("faces", faces, "must be a list of index triples")
        for i, face in enumerate(faces):
            if not (isinstance(face, list) and len(face) == 3 and all(
                    isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(vertices) for k in face)):
                r.fail(f"faces[{i}]", face, f"must be 3 vertex indices in [0, {len(vertices) - 1}]")
            check_triangle(r, f"faces[{i}]", vertices[face])
            scene.triangles.append(Triangle(vertices[face], m, None if uv is None else uv[face]))
    else:
        axes, center = r.vectors("axes"), r.vector("center")
        check_axes(r, axes)
        placement = _placement(r)
        if placement is not None:
            center, axes = placed_ellipsoid(placement, center, axes)
            check_axes(placed(r), axes)
        scene.ellipsoids.append(Ellipsoid(center, axes, m, r.boolean("flip_normals")))


GENERATORS = {"sphere": meshgen.sphere, "torus": meshgen.torus, "terrain": meshgen.terrain}


def _mesh_source(r, files):
    """(the untransformed Mesh, the number of degenerate faces dropped, where it came from): read from
    `file` (relative to the scene file) or made by `generate = { shape = ..., triangles = N }`."""
    if r.has("file") == r.has("generate"):
        r.fail("file", r.raw("file", r.raw("generate")), "give exactly one of file and generate")
    index = r.integer("shape_index")
    if index and not (r.has("file") and Path(r.string("file")).suffix.lower() == ".serialized"):
        r.fail("shape_index", index, "above 0 only with a .serialized file (OBJ and PLY files hold one mesh)")
    if r.has("file"):
        path = Path(r.path).parent / r.string("file")
        return (*files.load(path, r.path, r.prefix + "file", index), str(path))
    g = r.sub("generate")
    g.check_keys()
    shape, triangles = g.string("shape"), g.integer("triangles")
    try:
        return GENERATORS[shape](triangles), 0, f"generate {shape}"
    except MemoryError:
        g.fail("triangles", triangles, "out of memory generating the mesh")


def _transform(r):
    """4 x 4 matrix of `matrix`, or of scale, then rotate, then translate."""
    if r.has("matrix"):
        for key in ("scale", "rotate", "translate"):
            if r.has(key):
                r.fail(key, r.raw(key), "give either matrix or scale/rotate/translate")
        m = r.vectors("matrix")
        if not np.array_equal(m[3], [0, 0, 0, 1]) or not abs(np.linalg.det(m[:3, :3])) > 0:
            r.fail("matrix", m.tolist(), AFFINE)
        return m
    scale = r.raw("scale", 1.0)
    scale = np.full(3, r.number("scale")) if isinstance(scale, (int, float)) else r.vector("scale")
    if np.any(scale == 0):
        r.fail("scale", scale.tolist(), "must not be 0")
    axis, degrees = np.array([0.0, 0.0, 1.0]), 0.0
    if r.has("rotate"):
        rot = r.sub("rotate")
        rot.check_keys()
        axis, degrees = rot.vector("axis"), rot.number("degrees")
    return mesh_matrix(scale, axis, degrees, r.vector("translate"))


def _transformed_faces(r, key, vertices, faces):
    """The faces that keep an area once the transformed vertices are stored in float32, how many do not, and
    the mask of those kept; a transform that leaves a vertex outside float32's range, or no face at all, is an
    error."""
    if not np.abs(vertices).max() <= ranges.COORDINATE_LIMIT:  # also NaN
        r.fail(key, r.raw(key), f"puts the mesh beyond {ranges.COORDINATE_LIMIT:.4g} (2^60) of the origin, "
               "outside the range float32 arithmetic allows")
    stored = vertices.astype(np.float32)
    degenerate = meshes.degenerate_faces(stored.astype(np.float64), faces)
    if degenerate.all():
        r.fail(key, r.raw(key), "leaves every face without area in float32")
    return faces[~degenerate], int(degenerate.sum()), ~degenerate


def _mesh_shape(r, material, files):
    mesh, dropped, source = _mesh_source(r, files)
    m = _transform(r)
    vertices = mesh.vertices @ m[:3, :3].T + m[:3, 3]
    key = transform_key(r)
    faces, collapsed, kept = _transformed_faces(r, key, vertices, mesh.faces)
    flip = r.boolean("flip_normals")
    if (np.linalg.det(m[:3, :3]) < 0) != flip:  # a mirror keeps the faces counter-clockwise seen from the front,
        faces = faces[:, ::-1]                 # flip_normals turns them
    smooth = r.boolean("smooth")
    computed = r.string("vertex_normals")
    if r.has("vertex_normals") and not smooth:
        r.fail("vertex_normals", computed, "only with smooth = true")
    normals = None
    if smooth:  # normals transform by the inverse transpose
        computed = {"area": meshes.vertex_normals, "angle": meshes.angle_weighted_normals}[computed]
        normals = (mesh.normals @ np.linalg.inv(m[:3, :3]) * (-1.0 if flip else 1.0) if mesh.normals is not None
                   else computed(vertices, faces))
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    uvs = mesh.uvs
    if r.boolean("flip_tex_coords") and uvs is not None:  # Mitsuba's OBJ default: v -> 1 - v
        uvs = np.column_stack([uvs[:, 0], 1.0 - uvs[:, 1]])
    attributes = meshes.kept_faces(mesh.attributes, kept)  # a face attribute's rows follow the faces kept
    return MeshShape(meshes.Mesh(vertices, faces, normals, uvs, attributes), material, bool(smooth),
                     dropped + collapsed, source)


# How a BSDF parameter's key is read, by its declared kind (bsdfs.py)
_READ = {"number": Reader.number, "number-or-name": Reader.number_or_name, "string": Reader.string,
         "boolean": Reader.boolean, "number-or-vector": lambda r, name: tuple(_rgb(r, name).tolist())}


def _bsdf(r):
    """The material's BSDF fields: its type, and the parameters that type declares (bsdfs.py) only, each given by
    Mitsuba's name or by raytrace's own (colour, alpha; a conductor's material for its eta and k), not by both,
    else its declared default; `colour` where the type gives it (a name of it, or the type's own default)."""
    kind = r.string("type")
    bsdf = bsdfs.BY_NAME[kind]
    own_keys(r, kind, bsdf.key_names(), bsdfs.KEY_NAMES)
    own = Reader(r.path, r.table, r.prefix, bsdf.table)  # this type's keys, with their declared defaults
    given = {"colour": "colour"} if r.has("colour") else {}  # Material field -> the key that gave it
    for p in bsdf.parameters:
        if p.key is None or not r.has(p.key.name) or (p.key.name == "material" and r.raw("material") == "none"):
            continue  # material "none" is the default eta and k: Mitsuba takes it beside them
        for field in p.fields:
            if field in given:
                own.fail(p.key.name, r.raw(p.key.name), f"sets the same value as {given[field]}: give one or the "
                         "other")
            given[field] = p.key.name
    fields = {"bsdf": kind}
    for p in bsdf.parameters:
        if p.key is None or given.get(p.fields[0], p.key.name) != p.key.name:
            continue  # Mitsuba's scenes' own, or another key gave its value
        name = p.key.name
        if p.together and r.has(name) and not r.has(p.together):
            own.fail(name, r.raw(name), f"must be given with {p.together}")
        if name == "material":
            metal = own.string(name)
            if metal != "none":  # none: the perfect mirror, eta = k = 0 (the defaults)
                fields["eta"], fields["k"] = named_materials.CONDUCTORS[metal]
        elif p.fields == ("colour",):
            if r.has(name) or p.key.default is not None:
                fields["colour"] = _rgb(own, name) if r.has(name) else np.array(p.key.default, np.float64)
        elif r.has(name) or p.key.default is not None:
            fields[p.fields[0]] = _READ[p.key.kind](own, name)
    if fields.get("alpha_v") is not None and fields["alpha_v"] == fields.get("alpha"):
        fields["alpha_v"] = None  # alpha_u = alpha_v: isotropic, as alpha alone
    return fields


def _environment(e, base_dir):
    """(constant radiance, None) or (None, EnvironmentMap) from the [environment] table: each type takes its
    own keys only; the map's file is relative to the scene file."""
    e.check_keys()
    kind = e.string("type")
    own = {"constant": ("radiance",), "envmap": ("filename", "scale", "up", "forward")}[kind]
    own_keys(e, kind, own, ("radiance", "filename", "scale", "up", "forward"))
    if kind == "constant":
        return _rgb(e, "radiance"), None
    scale, up, forward = map_placement(e)
    texels = environment_map.load(base_dir / e.string("filename"), e.path, e.prefix + "filename")
    return None, EnvironmentMap(str((base_dir / e.string("filename")).resolve()), texels, scale, up, forward)


CAMERA_KEYS = {"perspective": ("fov",), "thinlens": ("fov", "aperture_radius", "focus_distance"),
               "orthographic": ("size",)}  # each type's own keys; the others take its position, clip planes
RFILTER_KEYS = {"box": (), "tent": ("rfilter_radius",), "gaussian": ("rfilter_stddev",),
                "mitchell": ("rfilter_b", "rfilter_c"), "lanczos": ("rfilter_lobes",)}


def read_camera(c):
    """The camera table (a scene file's, or model_check's of a model): each type takes its own keys, and needs
    them; the far clip plane beyond the near one."""
    kind = c.string("type")
    own_keys(c, kind, CAMERA_KEYS[kind], sorted({k for keys in CAMERA_KEYS.values() for k in keys}))
    for key in CAMERA_KEYS[kind]:
        c.raw(key)  # required: "missing"
    near = c.number("near_clip")
    far = c.number("far_clip") if c.has("far_clip") else math.inf
    if not far > near:
        c.fail("far_clip", far, f"must be above near_clip ({near})")
    size = c.vector("size") if kind == "orthographic" else None
    if size is not None and not np.all(size > 0):
        c.fail("size", size.tolist(), "must be > 0 in both")
    thin = kind == "thinlens"
    return Camera(c.vector("position"), c.vector("look_at"), c.vector("up"),
                  None if kind == "orthographic" else c.number("fov"), c.number("focal_length"), kind, near, far,
                  c.number("aperture_radius") if thin else 0.0, c.number("focus_distance") if thin else None, size)


def read_film(img):
    """The image table's crop window and reconstruction filter, as the Scene's fields of the keys' names: the
    window inside the film, each filter's own parameters only."""
    film = {key: img.integer(key) for key in ("crop_offset_x", "crop_offset_y")}
    for key, side, offset in (("crop_width", "width", "crop_offset_x"), ("crop_height", "height", "crop_offset_y")):
        extent = img.integer(side)
        if film[offset] >= extent:
            img.fail(offset, film[offset], f"must lie in the film ({side} {extent})")
        film[key] = img.integer(key) if img.has(key) else None
        if film[key] is not None and film[offset] + film[key] > extent:
            img.fail(key, film[key], f"must end in the film: {offset} + {key} <= {side} ({extent})")
    kind = img.string("rfilter")
    own_keys(img, kind, RFILTER_KEYS[kind], sorted({k for keys in RFILTER_KEYS.values() for k in keys}))
    film["rfilter"], film["sample_border"] = kind, img.boolean("sample_border")
    for key in RFILTER_KEYS[kind]:
        film[key] = img.integer(key) if key == "rfilter_lobes" else img.number(key)
    return film


def map_placement(e):
    """An envmap's scale, up and forward from its reader (a scene file's table, or model_check's of a model),
    forward not parallel to up."""
    up, forward = e.vector("up"), e.vector("forward")
    if np.linalg.norm(np.cross(normalize(up), normalize(forward))) < 1e-6:
        e.fail("forward", forward.tolist(), "must not be parallel to up")
    return e.number("scale"), up, forward


def _material(r, name, textures, names):
    """A material table; texture paths are relative to the scene file and read here; `names` ({name: index}) are
    the scene's materials, which blends, masks and back sides name."""
    r.check_keys(sorted(set(r.spec) | set(bsdfs.KEY_NAMES)))
    kind = r.string("type")
    # an opaque principled has a back (a textured spec_trans transmits, whatever its values: Mitsuba's flag)
    opaque = kind == "principled" and r.table.get("spec_trans", 0.0) == 0
    r, maps = _textured(r, kind, textures)
    sides = {"two_sided": r.boolean("two_sided")}
    if r.has("back"):
        sides["back"] = material_named(r, "back", names)
    if not sides["two_sided"] and kind in bsdfs.BY_NAME and not bsdfs.BY_NAME[kind].front_only and not opaque:
        r.fail("two_sided", False, f'type = "{kind}" scatters on both sides (it has no back to be black)')
    if kind in WRAPPERS:
        return _wrapper(r, name, kind, names, maps, sides)
    bsdf = _bsdf(r)
    course = {}
    for key, role in (("texture", "colour"), ("normal_map", "normal"), ("height_map", "height")):
        if r.has(key):
            course[key] = textures.index(r.string(key), role, r.path, r.prefix + key)
    if r.has("height_scale") != r.has("height_map"):
        given = "height_scale" if r.has("height_scale") else "height_map"
        r.fail(given, r.table[given], "height_map and height_scale go together")
    uv_scale, low, high = r.vector("uv_scale"), r.spec["uv_scale"].low, r.spec["uv_scale"].high
    if not np.all((uv_scale >= low) & (uv_scale <= high)):
        r.fail("uv_scale", uv_scale.tolist(), f"both scales must lie in [{low:.6g}, {high:.6g}] "
               "(> 0 and a normal float32)")
    uv_offset = r.vector("uv_offset")
    if not np.all(np.abs(uv_offset) <= FLOAT32_MAX):
        r.fail("uv_offset", uv_offset.tolist(), f"both offsets must lie within +-{FLOAT32_MAX:.6g} (float32)")
    colour = bsdf.pop("colour", None)
    if colour is None and "texture" not in course and not r.has("colour") and bsdf["bsdf"] == "diffuse":
        r.fail("colour", None, "missing")
    return Material(name, r.vector("colour") if colour is None else colour, r.number("shininess"),
                    course.get("texture", -1), course.get("normal_map", -1), course.get("height_map", -1),
                    r.number("height_scale") if "height_map" in course else 0.0,
                    tuple(uv_scale), tuple(uv_offset), r.string("wrap"), **bsdf, maps=tuple(maps),
                    bump_scale=r.number("bump_scale"), mirrored_maps=r.boolean("mirrored_maps"), **sides)


# Mitsuba's wrappers that tilt a BSDF's shading normal, as a material's keys, and their map slots
PERTURBING = {"normalmap": "normal", "bumpmap": "bump"}


def _textured(r, kind, textures):
    """(a reader of the material's table with each texture's table replaced by its mean, the maps: (slot,
    TextureLookup) pairs) of the parameters given as textures (texture_lookups.py); a texture where the
    parameter takes a value only is refused."""
    table, maps = dict(r.table), []
    for key, value in r.table.items():
        if key in PERTURBING and not texture_lookups.is_texture(value):
            r.fail(key, value, texture_lookups.TEXTURE_TABLE)
        if not texture_lookups.is_texture(value):
            continue
        if kind in WRAPPERS:
            slot = "weight" if key in ("weight", "opacity") else None
        elif key in PERTURBING:
            slot = PERTURBING[key]
        else:
            slot = "colour" if key == "colour" else bsdfs.texture_slot(bsdfs.BY_NAME[kind], key)
        if slot is None:
            r.fail(key, value, f'takes a value, not a texture, in type = "{kind}"')
        lookup, mean = texture_lookups.read(Reader(r.path, value, f"{r.prefix}{key}.", "texture"), slot, textures,
                                            _rgb, own_keys)
        maps.append((slot, lookup))
        if key == "alpha" and slot == "alpha":  # isotropic: the same roughness along v
            maps.append(("alpha_v", lookup))
        if key in PERTURBING:
            del table[key]
        else:
            table[key] = mean if isinstance(mean, float) else mean.tolist()
    if r.has("bump_scale") and not r.has("bumpmap"):
        r.fail("bump_scale", r.raw("bump_scale"), "only with bumpmap")
    if r.has("mirrored_maps") and not (r.has("normalmap") or r.has("bumpmap")):
        r.fail("mirrored_maps", r.raw("mirrored_maps"), "only with normalmap or bumpmap")
    coloured = [key for key, value in r.table.items() if texture_lookups.is_texture(value) and
                (key == "colour" or (kind not in WRAPPERS and key not in PERTURBING and
                                     bsdfs.texture_slot(bsdfs.BY_NAME[kind], key) == "colour"))]
    if coloured and r.has("texture"):  # the kernel would read the one, the range checks the other
        r.fail("texture", r.raw("texture"), f"not with a textured {coloured[0]}: one texture gives a material's "
               "colour")
    # Mitsuba's maps (both: its bumpmap around a normalmap) or the course's (both: the course's pair), not a mix
    mitsuba = [key for key in PERTURBING if r.has(key)]
    course = [key for key in ("normal_map", "height_map") if r.has(key)]
    if mitsuba and course:
        r.fail(course[0], r.raw(course[0]), f"not with {mitsuba[0]}: a material's normal is tilted by Mitsuba's "
               "maps or by the course's, not both")
    return Reader(r.path, table, r.prefix, "materials.NAME"), maps


def _wrapper(r, name, kind, names, maps, sides):
    """A blendbsdf's or a mask's material: the materials it wraps and its weight (a mask's opacity)."""
    own_keys(r, kind, [key.name for key in bsdfs.WRAPPER_KEYS[kind]], bsdfs.KEY_NAMES)
    # the materials it wraps have their own
    own_keys(r, kind, (), ("colour", "texture", "normal_map", "height_map", *PERTURBING, "bump_scale",
                           "mirrored_maps"))
    own = Reader(r.path, r.table, r.prefix, bsdfs.table_name(kind))
    if kind == "blendbsdf":
        given = own.raw("bsdfs")
        if not isinstance(given, list) or len(given) != 2:
            own.fail("bsdfs", given, "must be a list of two material names")
        wrapped = tuple(material_named(own, "bsdfs", names, value) for value in given)
        weight = own.number("weight")
    else:
        wrapped, weight = (material_named(own, "bsdf", names),), own.number("opacity")
    if names[name] in wrapped:
        own.fail("bsdfs" if kind == "blendbsdf" else "bsdf", own.raw("bsdfs" if kind == "blendbsdf" else "bsdf"),
                 "must not name the material itself")
    return Material(name, np.zeros(3), bsdf=kind, blend=wrapped, weight=weight, maps=tuple(maps), **sides)


def parse_scene(table, path="<scene>", files=None):
    """Build a Scene from a parsed TOML table; raises InputError on the first bad key. The scene keeps a copy
    of the table as its `source` (raytrace.parameters edits it). Mesh files are read through `files` (a
    mesh_file.MeshCache: the Mitsuba translation's, which read some already), each once."""
    source = copy.deepcopy(table)
    r = Reader(path, table)
    r.check_keys()

    c = r.sub("camera")
    c.check_keys()
    camera = read_camera(c)

    img = r.sub("image")
    img.check_keys()
    width, height = img.integer("width"), img.integer("height")
    film = read_film(img)

    render = r.sub("render") if r.has("render") else Reader(path, {}, "render.", "render")
    render.check_keys()
    shading = render.string("shading")
    max_depth = render.integer("max_depth")

    mats = r.raw("materials")
    if not isinstance(mats, dict) or not mats:
        r.fail("materials", mats, "must be a table of named materials")
    textures = TextureCache(Path(path).parent)
    materials, material_index, material_readers = [], {}, []
    every = {name: i for i, name in enumerate(mats)}  # what blends, masks and back sides may name
    for name in mats:
        material_index[name] = len(materials)
        material_readers.append(Reader(path, mats[name], f"materials.{name}.", "materials.NAME"))
        materials.append(_material(material_readers[-1], name, textures, every))

    sampler, light_sampler = (render.string(key) if render.has(key) else samplers.default_pattern(shading)
                              for key in ("sampler", "light_sampler"))
    spp = render.integer("spp") if render.has("spp") else samplers.default_count(sampler)
    light_samples = render.integer("light_samples")
    environment, environment_map = None, None
    if r.has("environment"):
        environment, environment_map = _environment(r.sub("environment"), Path(path).parent)
    scene = Scene(path, camera, width, height, r.vector("ambient"), [],
                  materials, spp=spp, light_samples=light_samples, sampler=sampler, light_sampler=light_sampler,
                  textures=textures.textures, shading=shading, max_depth=max_depth, environment=environment,
                  environment_map=environment_map, seed=render.integer("seed"), rr_depth=render.integer("rr_depth"),
                  hide_emitters=render.boolean("hide_emitters"), bsdf_samples=render.integer("bsdf_samples"),
                  light_selection=render.string("light_selection"),
                  aovs=aov_types.parse(render.string("aovs"), path, "render.aovs"), **film)

    lights = r.raw("lights", [])  # keys.py: none only where rules.py allows it
    if not isinstance(lights, list):  # none at all: rules.py says when that is allowed
        r.fail("lights", lights, "must be an array of [[lights]] tables")
    light_readers = []
    for i, light in enumerate(lights):
        lr = Reader(path, light, f"lights[{i}].", LIGHTS_SPEC if shading in RADIOMETRIC else "lights[]")
        emission = "radiance" if shading in RADIOMETRIC else "colour"  # what the light's one colour means
        lr.check_keys()
        material = material_named(lr, "material", material_index) if lr.has("material") else -1
        scene.lights.append(Light(colour=_rgb(lr, emission), material=material, **_rectangle_fields(lr)))
        light_readers.append(placed(lr))

    tables, shapes = r.raw("shapes", []), []  # keys.py declares its default: no shapes
    files = mesh_file.MeshCache() if files is None else files
    _groups(scene, r, material_index, files)
    if not isinstance(tables, list):
        r.fail("shapes", tables, "must be an array of [[shapes]] tables")
    for i, shape in enumerate(tables):
        sr = Reader(path, shape, f"shapes[{i}].", "shapes[]")
        shapes.extend((placed(sr), added) for added in _load_shape(scene, sr, material_index, files))
    emitters = r.raw("emitters", [])  # keys.py declares its default: none
    if not isinstance(emitters, list):
        r.fail("emitters", emitters, "must be an array of [[emitters]] tables")
    for i, emitter in enumerate(emitters):
        delta_lights.read(Reader(path, emitter, f"emitters[{i}].", "emitters[]"), scene, textures, _rgb, own_keys)
    rules.check(scene, rules.Places(r, render, c, material_readers, light_readers, shapes))
    scene.source, scene.checked = source, fingerprint(scene)
    return scene


def load_file(path, defines=None, ignore_unsupported=False):
    """Read and check a scene file: raytrace's TOML (docs/scene-format.md), or Mitsuba 3's XML (a name ending in
    .xml; docs/mitsuba.md), whose $name parameters `defines` gives ({name: value}, as -D name=value), and whose
    plugins raytrace does not render are refused unless `ignore_unsupported` (then each kind is left out with a
    warning). Texture and mesh paths are relative to the file's folder. Raises InputError naming the file (and
    line), the key and the value of the first bad entry."""
    if not isinstance(path, (str, os.PathLike)):
        raise InputError("load_file()", "path", type(path).__name__, "must be a str or os.PathLike naming a file")
    path = Path(check_path(path, "load_file()", "path"))  # a NUL, or a PathLike that gives bytes
    if path.suffix.lower() == ".xml":
        return load_mitsuba_file(path, defines, ignore_unsupported)[0]
    if defines:
        raise InputError("load_file()", "defines", defines, "only a Mitsuba XML scene (.xml) takes parameters")
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise InputError(path, "file", str(path), e.strerror or "cannot be read") from None
    except UnicodeDecodeError:
        raise InputError(path, "file", str(path), "is not UTF-8 text") from None
    return _parse_toml(text, str(path))


def load_string(text):
    """A scene from the text of a TOML scene file, through the same checks as load_file; texture and mesh
    paths are relative to the current directory, and errors name the source as load_string()."""
    if not isinstance(text, str):
        raise InputError("load_string()", "text", type(text).__name__, "must be a str holding TOML")
    return _parse_toml(text, "load_string()")


def load_dict(table, ignore_unsupported=False):
    """A scene from a dict laid out as a scene file's tables (docs/scene-format.md), or in Mitsuba 3's dict form
    ({"type": "scene", ...}, as mi.load_dict takes it; docs/mitsuba.md), through the same checks as load_file.
    Values may be numpy arrays and scalars; paths are relative to the current directory; errors name the source
    as load_dict() and the key by its path in the dict, e.g. shapes[3].center."""
    if not isinstance(table, dict):
        raise InputError("load_dict()", "table", type(table).__name__, "must be a dict laid out as a scene file")
    if isinstance(table.get("type"), str) and table["type"] == "scene":
        return _mitsuba(mitsuba_form(table), "load_dict()", Path(os.curdir), ignore_unsupported)[0]
    return parse_scene(plain(table), "load_dict()")


def load_mitsuba_file(path, defines=None, ignore_unsupported=False):
    """(Scene, mitsuba.Translation) of a Mitsuba 3 XML file: the scene, and the scene table it was read from
    (`python -m raytrace convert` writes that table as TOML)."""
    return _mitsuba(mitsuba_xml.read(path, _defines(defines)), str(path), Path(path).parent, ignore_unsupported)


def _defines(defines):
    if defines is None:
        return {}
    if not isinstance(defines, Mapping) or not all(isinstance(k, str) and k for k in defines):
        raise InputError("load_file()", "defines", defines, "must be a dict of parameter names and values")
    return {k: str(v) for k, v in defines.items()}


def mitsuba_form(value, where="", depth=0):
    """A copy of a Mitsuba dict-form scene: its dicts copied (with string keys), nesting no deeper than any
    scene's; other values as they are (mitsuba.py checks them where it reads them)."""
    if depth > MAX_NESTING:
        raise InputError("load_dict()", where, None, f"dicts nested more than {MAX_NESTING} deep (a dict that holds "
                         "itself?)")
    if isinstance(value, Mapping):
        for k in value:
            if not isinstance(k, str):
                raise InputError("load_dict()", where or "table", k, KEY_NOT_STRING)
        return {k: mitsuba_form(v, f"{where}.{k}" if where else k, depth + 1) for k, v in value.items()}
    if isinstance(value, list):
        return [mitsuba_form(v, f"{where}[{i}]", depth + 1) for i, v in enumerate(value)]
    return value


def _mitsuba(node, path, folder, ignore_unsupported):
    """The scene of a Mitsuba dict-form scene (from its XML or a dict): translated into a scene table, read and
    checked as a file's (errors named at the XML element or dict entry each value came from), its warnings
    issued as UnsupportedWarning; returns (Scene, mitsuba.Translation)."""
    translation = mitsuba.translate(node, path, folder, ignore_unsupported)
    for line in translation.warnings:
        warnings.warn(line, UnsupportedWarning, stacklevel=3)
    try:
        scene = parse_scene(translation.table, path, translation.files)
    except InputError as e:
        raise mitsuba.located(e, translation) from None
    return mitsuba.without_idle_clip_planes(scene, translation.table), translation


KEY_NOT_STRING = "a key must be a string, as in a scene file"
MAX_NESTING = 32  # tables and arrays within each other: a scene needs 4 (shapes[0].generate.triangles)
# What a TOML file's values are besides tables and arrays (a datetime is a date), and None, which a dict may hold
# where a key is meant as absent: the keys' readers refuse it where a value is required.
SCALARS = (str, int, float, bool, datetime.date, datetime.time, type(None))


def plain(value, source="load_dict()", where="", depth=0):
    """`value` with numpy arrays and scalars as Python lists and numbers, tuples as lists, dicts copied: what
    TOML would have given (any Mapping as a dict). A key that is not a string, nesting deeper than any scene's (a
    dict that holds itself), or a value no TOML file holds (a generator, an object) is an InputError naming
    `source` and the place (`where`)."""
    if depth > MAX_NESTING:
        raise InputError(source, where, None, f"tables or arrays nested more than {MAX_NESTING} deep (a dict or "
                         "list that holds itself?)")
    if isinstance(value, Mapping):
        for k in value:
            if not isinstance(k, str):
                raise InputError(source, where or "table", k, KEY_NOT_STRING)
        return {k: plain(v, source, f"{where}.{k}" if where else k, depth + 1) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v, source, f"{where}[{i}]", depth + 1) for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return plain(value.tolist(), source, where, depth)
    if isinstance(value, np.generic):
        value = value.item()
    if not isinstance(value, SCALARS):
        raise InputError(source, where or "table", type(value).__name__, "is no value a scene file can hold (a "
                         "table, an array, a string, a number or a boolean)")
    return value


def _parse_toml(text, path):
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        reason = str(e).split("\n")[0]
        at = re.search(r" \(at line (\d+), column (\d+)\)$", reason)
        if at:
            line, column = at.groups()
        else:  # "(at end of document)"
            line, column = text.count("\n") + 1, len(text.rsplit("\n", 1)[-1]) + 1
        reason = re.sub(r" \(at [^)]*\)$", "", reason)
        raise InputError(f"{path}:{line}:{column}", "toml", None, f"{reason}: not valid TOML") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise InputError(path, "toml", None, "arrays or tables nested too deeply") from None
    return parse_scene(table, path)
