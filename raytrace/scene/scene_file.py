"""Scene files: the TOML format and its validation, read into the scene model (model.py).

Every check names the file, the key and the value (InputError), so a user can fix a scene in one go.
"""
import math
import tomllib
from pathlib import Path

import numpy as np

from . import mesh_file, meshes, meshgen, ranges
from ..errors import InputError
from .. import samplers
from ..structs import WRAP_MODES
from .model import (DEFAULT_SHININESS, SHADINGS, Camera, Ellipsoid, Light, Material, MeshShape, Rectangle, Scene, Triangle,
                    normalize)
from .textures import TextureCache
from .transform import mesh_matrix

SHAPE_KINDS = ("rectangle", "triangle", "mesh", "ellipsoid")
FLOAT32_TINY, FLOAT32_MAX = float(np.finfo(np.float32).tiny), float(np.finfo(np.float32).max)


class _Reader:
    """Typed access to one TOML table; every error names file, key path and value."""

    def __init__(self, path, table, prefix=""):
        self.path, self.table, self.prefix = path, table, prefix
        if not isinstance(table, dict):
            self.fail("", table, "must be a table")

    def fail(self, key, value, problem):
        raise InputError(self.path, self.prefix + key if key else self.prefix.rstrip("."), value, problem)

    def check_keys(self, allowed):
        for key in self.table:
            if key not in allowed:
                self.fail(key, self.table[key], f"unknown key (expected one of: {', '.join(allowed)})")

    def has(self, key):
        return key in self.table

    def raw(self, key, default=None):
        if key not in self.table:
            if default is None:
                self.fail(key, None, "missing")
            return default
        return self.table[key]

    def number(self, key, default=None, low=-math.inf, high=math.inf, open_low=False):
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, value, "must be a finite number")
        if ranges.float32_problem(value):
            self.fail(key, value, ranges.float32_problem(value))
        if value < low or value > high or (open_low and value == low):
            bound = f"> {low}" if open_low else f">= {low}"
            self.fail(key, value, f"must be {bound} and <= {high}")
        return float(value)

    def integer(self, key, default=None, low=1, high=ranges.MAX_SAMPLES):
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            self.fail(key, value, f"must be an integer in [{low}, {high}]")
        return value

    def string(self, key, default=None, choices=None):
        value = self.raw(key, default)
        if not isinstance(value, str) or (choices and value not in choices):
            self.fail(key, value, f"must be one of: {', '.join(choices)}" if choices else "must be a string")
        return value

    def vector(self, key, n, default=None, nonzero=False, low=-math.inf):
        value = self.raw(key, default)
        bound = f" >= {low}" if low > -math.inf else ""
        if not (isinstance(value, (list, tuple)) and len(value) == n
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
            self.fail(key, value, f"must be a list of {n} finite numbers{bound}")
        for x in value:
            if ranges.float32_problem(x):
                self.fail(key, value, ranges.float32_problem(x))
        if any(x < low for x in value):
            self.fail(key, value, f"must be a list of {n} finite numbers{bound}")
        v = np.array(value, dtype=np.float64)
        if nonzero and not np.any(v):
            self.fail(key, value, "must not be the zero vector")
        return v

    def vectors(self, key, n, count=None):
        value = self.raw(key)
        if not isinstance(value, list) or (count is not None and len(value) != count) or not value:
            self.fail(key, value, f"must be a list of {count or 'one or more'} vectors")
        return np.array([_Reader(self.path, {key: v}, self.prefix).vector(key, n) for v in value])

    def sub(self, key):
        return _Reader(self.path, self.raw(key), f"{self.prefix}{key}.")


def _frame(r, normal_key="normal", tangent_key="tangent"):
    """Unit normal and a tangent made orthogonal to it (Gram-Schmidt); refuses a tangent along the normal."""
    n = normalize(r.vector(normal_key, 3, nonzero=True))
    t_raw = r.vector(tangent_key, 3, nonzero=True)
    t = t_raw - np.dot(t_raw, n) * n
    if np.linalg.norm(t) < 1e-6 * np.linalg.norm(t_raw):
        r.fail(tangent_key, t_raw.tolist(), "must not be parallel to the normal")
    return n, normalize(t)


def _emission(r, key):
    """A light's colour (Phong) or radiance (direct, emitted from the side its normal points to): three
    numbers >= 0, or for radiance one, the same in every channel."""
    if key == "radiance" and isinstance(r.raw(key), (int, float)) and not isinstance(r.raw(key), bool):
        return np.full(3, r.number(key, low=0))
    return r.vector(key, 3, low=0)


def _rectangle_fields(r):
    size = r.vector("size", 2)
    if np.any(size <= 0):
        r.fail("size", size.tolist(), "both sides must be > 0")
    normal, tangent = _frame(r)
    return dict(center=r.vector("center", 3), size=size, normal=normal, tangent=tangent)


def _check_triangle(r, key, vertices):
    area2 = np.linalg.norm(np.cross(vertices[1] - vertices[0], vertices[2] - vertices[0]))
    scale = max(np.linalg.norm(vertices[1] - vertices[0]), np.linalg.norm(vertices[2] - vertices[0])) ** 2
    if not area2 > 1e-9 * scale:
        r.fail(key, vertices.tolist(), "degenerate triangle (zero area)")


def _load_shape(scene, r, material_index):
    """Add the shape of table `r` to `scene`; returns what it added (the triangles of an inline mesh)."""
    before = {kind: len(getattr(scene, kind)) for kind in ("rectangles", "triangles", "ellipsoids", "meshes")}
    _add_shape(scene, r, material_index)
    return [shape for kind, n in before.items() for shape in getattr(scene, kind)[n:]]


def _add_shape(scene, r, material_index):
    kind = r.string("type", choices=SHAPE_KINDS)
    common = {"type", "material"}
    name = r.string("material")
    if name not in material_index:
        r.fail("material", name, f"no such material (defined: {', '.join(material_index)})")
    m = material_index[name]
    if kind == "rectangle":
        r.check_keys(sorted(common | {"center", "size", "normal", "tangent"}))
        scene.rectangles.append(Rectangle(material=m, **_rectangle_fields(r)))
    elif kind == "triangle":
        r.check_keys(sorted(common | {"vertices", "uv"}))
        vertices = r.vectors("vertices", 3, count=3)
        _check_triangle(r, "vertices", vertices)
        uv = r.vectors("uv", 2, count=3) if r.has("uv") else None
        scene.triangles.append(Triangle(vertices, m, uv))
    elif kind == "mesh" and (r.has("file") or r.has("generate")):
        r.check_keys(sorted(common | MESH_KEYS))
        scene.meshes.append(_mesh_shape(r, m))
    elif kind == "mesh":
        r.check_keys(sorted(common | {"vertices", "faces"}))
        vertices = r.vectors("vertices", 3)
        faces = r.raw("faces")
        if not isinstance(faces, list) or not faces:
            r.fail("faces", faces, "must be a list of index triples")
        for i, face in enumerate(faces):
            if not (isinstance(face, list) and len(face) == 3 and all(
                    isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(vertices) for k in face)):
                r.fail(f"faces[{i}]", face, f"must be 3 vertex indices in [0, {len(vertices) - 1}]")
            _check_triangle(r, f"faces[{i}]", vertices[face])
            scene.triangles.append(Triangle(vertices[face], m))
    else:
        r.check_keys(sorted(common | {"center", "axes"}))
        axes = r.vectors("axes", 3, count=3)
        norms = np.prod(np.linalg.norm(axes, axis=1))
        if not abs(np.linalg.det(axes)) > 1e-6 * norms:
            r.fail("axes", axes.tolist(), "singular ellipsoid: the three axes must be linearly independent")
        scene.ellipsoids.append(Ellipsoid(r.vector("center", 3), axes, m))


MESH_KEYS = {"file", "generate", "scale", "rotate", "translate", "matrix", "smooth"}
GENERATORS = {"sphere": meshgen.sphere, "torus": meshgen.torus, "terrain": meshgen.terrain}


def _mesh_source(r):
    """(the untransformed Mesh, the number of degenerate faces dropped, where it came from): read from
    `file` (relative to the scene file) or made by `generate = { shape = ..., triangles = N }`."""
    if r.has("file") == r.has("generate"):
        r.fail("file", r.raw("file", r.raw("generate")), "give exactly one of file and generate")
    if r.has("file"):
        path = Path(r.path).parent / r.string("file")
        return (*mesh_file.load_mesh(path), str(path))
    g = r.sub("generate")
    g.check_keys(["shape", "triangles"])
    shape, triangles = g.string("shape", choices=GENERATORS), g.integer("triangles", low=2, high=50_000_000)
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
        m = r.vectors("matrix", 4, count=4)
        if not np.array_equal(m[3], [0, 0, 0, 1]) or not abs(np.linalg.det(m[:3, :3])) > 0:
            r.fail("matrix", m.tolist(), "must be affine (last row 0 0 0 1) and invertible")
        return m
    scale = r.raw("scale", 1.0)
    scale = np.full(3, r.number("scale", 1.0)) if isinstance(scale, (int, float)) else r.vector("scale", 3)
    if np.any(scale == 0):
        r.fail("scale", scale.tolist(), "must not be 0")
    axis, degrees = np.array([0.0, 0.0, 1.0]), 0.0
    if r.has("rotate"):
        rot = r.sub("rotate")
        rot.check_keys(["axis", "degrees"])
        axis, degrees = rot.vector("axis", 3, nonzero=True), rot.number("degrees")
    return mesh_matrix(scale, axis, degrees, r.vector("translate", 3, default=[0.0, 0.0, 0.0]))


def _transformed_faces(r, key, vertices, faces):
    """The faces that keep an area once the transformed vertices are stored in float32, and how many do not;
    a transform that leaves a vertex outside float32's range, or no face at all, is an error."""
    if not np.abs(vertices).max() <= ranges.COORDINATE_LIMIT:  # also NaN
        r.fail(key, r.raw(key), f"puts the mesh beyond {ranges.COORDINATE_LIMIT:.4g} (2^60) of the origin, "
               "outside the range float32 arithmetic allows")
    stored = vertices.astype(np.float32)
    degenerate = meshes.degenerate_faces(stored.astype(np.float64), faces)
    if degenerate.all():
        r.fail(key, r.raw(key), "leaves every face without area in float32")
    return faces[~degenerate], int(degenerate.sum())


def _mesh_shape(r, material):
    mesh, dropped, source = _mesh_source(r)
    m = _transform(r)
    vertices = mesh.vertices @ m[:3, :3].T + m[:3, 3]
    key = "matrix" if r.has("matrix") else "scale"
    faces, collapsed = _transformed_faces(r, key, vertices, mesh.faces)
    if np.linalg.det(m[:3, :3]) < 0:  # a mirror: keep the faces counter-clockwise seen from the front
        faces = faces[:, ::-1]
    smooth = r.raw("smooth", False)
    if not isinstance(smooth, bool):
        r.fail("smooth", smooth, "must be true or false")
    normals = None
    if smooth:  # normals transform by the inverse transpose
        normals = (mesh.normals @ np.linalg.inv(m[:3, :3]) if mesh.normals is not None
                   else meshes.vertex_normals(vertices, faces))
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    return MeshShape(meshes.Mesh(vertices, faces, normals, mesh.uvs), material, bool(smooth), dropped + collapsed,
                     source)


MATERIAL_KEYS = ["colour", "height_map", "height_scale", "normal_map", "shininess", "texture", "uv_offset",
                 "uv_scale", "wrap"]


def _material(r, name, textures):
    """A material table; texture paths are relative to the scene file and read here."""
    r.check_keys(MATERIAL_KEYS)
    maps = {}
    for key, role in (("texture", "colour"), ("normal_map", "normal"), ("height_map", "height")):
        if r.has(key):
            maps[key] = textures.index(r.string(key), role, r.path, r.prefix + key)
    if r.has("height_scale") != r.has("height_map"):
        given = "height_scale" if r.has("height_scale") else "height_map"
        r.fail(given, r.table[given], "height_map and height_scale go together")
    uv_scale = r.vector("uv_scale", 2, default=[1.0, 1.0])
    if not np.all((uv_scale >= FLOAT32_TINY) & (uv_scale <= FLOAT32_MAX)):
        r.fail("uv_scale", uv_scale.tolist(), f"both scales must lie in [{FLOAT32_TINY:.6g}, {FLOAT32_MAX:.6g}] "
               "(> 0 and a normal float32)")
    uv_offset = r.vector("uv_offset", 2, default=[0.0, 0.0])
    if not np.all(np.abs(uv_offset) <= FLOAT32_MAX):
        r.fail("uv_offset", uv_offset.tolist(), f"both offsets must lie within +-{FLOAT32_MAX:.6g} (float32)")
    colour = r.vector("colour", 3, default=[1.0, 1.0, 1.0] if "texture" in maps else None, low=0)
    return Material(name, colour, r.number("shininess", DEFAULT_SHININESS, low=0, open_low=True),
                    maps.get("texture", -1), maps.get("normal_map", -1), maps.get("height_map", -1),
                    r.number("height_scale", 0.0, low=0) if "height_map" in maps else 0.0,
                    tuple(uv_scale), tuple(uv_offset),
                    r.string("wrap", "repeat", choices=WRAP_MODES))


def parse_scene(table, path="<scene>"):
    """Build a Scene from a parsed TOML table; raises InputError on the first bad key."""
    r = _Reader(path, table)
    r.check_keys(["ambient", "camera", "image", "lights", "materials", "render", "shapes"])

    c = r.sub("camera")
    c.check_keys(["focal_length", "fov", "look_at", "position", "up"])
    position = c.vector("position", 3)
    look_at = c.vector("look_at", 3)
    ref_up = c.vector("up", 3, nonzero=True)
    if np.linalg.norm(look_at - position) == 0:
        c.fail("look_at", look_at.tolist(), "must differ from camera.position")
    if np.linalg.norm(np.cross(normalize(look_at - position), normalize(ref_up))) < 1e-6:
        c.fail("up", ref_up.tolist(), "must not be parallel to the view direction")
    camera = Camera(position, look_at, ref_up, c.number("fov", low=0, high=180, open_low=True),
                    c.number("focal_length", 1.0, low=0, open_low=True))
    if camera.fov_deg >= 180:
        c.fail("fov", camera.fov_deg, "must be < 180")

    img = r.sub("image")
    img.check_keys(["height", "width"])
    width, height = img.integer("width", high=ranges.MAX_IMAGE_SIDE), img.integer("height", high=ranges.MAX_IMAGE_SIDE)

    render = r.sub("render") if r.has("render") else _Reader(path, {}, "render.")
    render.check_keys(["light_sampler", "light_samples", "sampler", "shading", "spp"])
    shading = render.string("shading", "phong", choices=SHADINGS)
    if shading == "direct" and r.has("ambient"):
        r.fail("ambient", r.raw("ambient"), 'is the Phong model\'s: shading = "direct" has no ambient term')

    mats = r.raw("materials")
    if not isinstance(mats, dict) or not mats:
        r.fail("materials", mats, "must be a table of named materials")
    textures = TextureCache(Path(path).parent)
    materials, material_index, material_readers = [], {}, []
    for name in mats:
        material_index[name] = len(materials)
        material_readers.append(r.sub("materials").sub(name))
        materials.append(_material(material_readers[-1], name, textures))

    spp, light_samples = render.integer("spp", 1), render.integer("light_samples", 1)
    sampler, light_sampler = render.string("sampler", "grid"), render.string("light_sampler", "grid")
    for key, name, n in (("sampler", sampler, spp), ("light_sampler", light_sampler, light_samples)):
        problem = samplers.count_problem(name, n)
        if problem:
            render.fail(key, name, problem)
    scene = Scene(path, camera, width, height, r.vector("ambient", 3, default=[0, 0, 0], low=0), [],
                  materials, spp=spp, light_samples=light_samples, sampler=sampler, light_sampler=light_sampler,
                  textures=textures.textures, shading=shading)

    lights = r.raw("lights")
    if not isinstance(lights, list) or not lights:
        r.fail("lights", lights, "must be a non-empty array of [[lights]] tables")
    places, light_readers = [(c, camera)], []
    for i, light in enumerate(lights):
        lr = _Reader(path, light, f"lights[{i}].")
        emission = "radiance" if shading == "direct" else "colour"  # what the light's one colour means
        lr.check_keys(["center", emission, "normal", "size", "tangent"])
        scene.lights.append(Light(colour=_emission(lr, emission), **_rectangle_fields(lr)))
        places.append((lr, scene.lights[-1]))
        light_readers.append(lr)

    shapes = r.raw("shapes", [])
    if not isinstance(shapes, list):
        r.fail("shapes", shapes, "must be an array of [[shapes]] tables")
    for i, shape in enumerate(shapes):
        sr = _Reader(path, shape, f"shapes[{i}].")
        places.extend((sr, added) for added in _load_shape(scene, sr, material_index))
    ranges.check_scene(scene, places, material_readers, light_readers, r)
    return scene


def load_scene(path):
    """Read and validate a TOML scene file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise InputError(path, "file", str(path), e.strerror or "cannot be read") from None
    except UnicodeDecodeError:
        raise InputError(path, "file", str(path), "is not UTF-8 text") from None
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(path, "toml", str(e).split("\n")[0], "is not valid TOML") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise InputError(path, "toml", None, "arrays or tables nested too deeply") from None
    return parse_scene(table, str(path))
