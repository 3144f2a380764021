"""The Hypothesis strategies of the fuzz suite and the files they produce: valid scenes from the real grammar,
the same mutated with hostile values, scene texts that are no TOML, hostile texture and mesh files, hostile
command lines and environments. Each file type knows how to write itself into an example's directory."""
import copy
import dataclasses
import math
import os
import struct
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from hypothesis import assume
from hypothesis import strategies as st

from fuzz_toml import to_toml
from helpers import ROOT

ASSETS = ROOT / "assets"

# --- the files beside a scene --------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class ImageFile:
    """A small image written by OpenImageIO in `format` (an extension), whatever its name says: `values`
    repeated over height x width x channels, stored as `pixel_type` (integers scale [0, 1] to their range)."""
    name: str
    format: str
    width: int
    height: int
    channels: int
    pixel_type: str  # uint8, uint16, half, float
    values: tuple

    def pixels(self):
        count = self.width * self.height * self.channels
        v = np.resize(np.array(self.values, np.float64), count).reshape(self.height, self.width, self.channels)
        if self.pixel_type in ("uint8", "uint16"):
            top = 255 if self.pixel_type == "uint8" else 65535
            return np.round(np.clip(np.nan_to_num(v), 0, 1) * top).astype(self.pixel_type)
        with np.errstate(over="ignore"):
            return v.astype(np.float32)

    def data(self):
        """The file's bytes (empty if OpenImageIO cannot write this format so)."""
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "image" + self.format)
            out = oiio.ImageOutput.create(path)
            if out is not None:
                spec = oiio.ImageSpec(self.width, self.height, self.channels, oiio.TypeDesc(self.pixel_type))
                if out.open(path, spec):
                    out.write_image(self.pixels())
                out.close()
                out.geterror()
            oiio.geterror()
            return Path(path).read_bytes() if os.path.isfile(path) else b""

    def write(self, directory):
        (directory / self.name).write_bytes(self.data())


@dataclasses.dataclass(frozen=True)
class BytesFile:
    name: str
    data: bytes

    def write(self, directory):
        (directory / self.name).write_bytes(self.data)


@dataclasses.dataclass(frozen=True)
class TextFile:
    name: str
    text: str

    def write(self, directory):
        (directory / self.name).write_bytes(self.text.encode("utf-8", "surrogateescape"))


@dataclasses.dataclass(frozen=True)
class AssetCopy:
    """The first `length` bytes of a file in assets/ (None: all of it)."""
    name: str
    asset: str
    length: int | None = None

    def write(self, directory):
        (directory / self.name).write_bytes((ASSETS / self.asset).read_bytes()[:self.length])


@dataclasses.dataclass(frozen=True)
class DamagedFile:
    """Another file's bytes cut at `length` (None: not cut) with some bytes overwritten."""
    name: str
    original: ImageFile
    length: int | None
    patches: tuple  # (offset, byte) pairs, offsets taken modulo the length

    def write(self, directory):
        data = bytearray(self.original.data())[:self.length]
        for offset, byte in self.patches:
            if data:
                data[offset % len(data)] = byte
        (directory / self.name).write_bytes(bytes(data))


@dataclasses.dataclass(frozen=True)
class Directory:
    name: str

    def write(self, directory):
        (directory / self.name).mkdir()


@dataclasses.dataclass
class SceneExample:
    """A scene table and the files it refers to."""
    table: dict
    files: tuple = ()

    def text(self):
        return to_toml(self.table)


SMALL_SCENE = {  # a ceiling light over a floor, 4 x 3 pixels
    "camera": {"position": [0.0, -3.0, 1.0], "look_at": [0.0, 0.0, 0.5], "up": [0.0, 0.0, 1.0], "fov": 45.0},
    "image": {"width": 4, "height": 3},
    "materials": {"white": {"colour": [0.7, 0.7, 0.7]}},
    "lights": [{"center": [0.0, 0.0, 2.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0]}],
    "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [2.0, 2.0], "normal": [0.0, 0.0, 1.0],
                "tangent": [1.0, 0.0, 0.0], "material": "white"}],
}


# --- valid scenes, from the real grammar ---------------------------------------------------------------

def finite(low, high):
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def vectors(n, low, high):
    return st.lists(finite(low, high), min_size=n, max_size=n)


AXIS_FRAMES = [([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]), ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0]),
               ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]), ([-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
               ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0]), ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0])]
SAMPLERS = ("center", "grid", "rotated-grid-cw", "rotated-grid-ccw", "random", "jittered", "halton", "sobol")
SAMPLE_COUNTS = {"center": [1], "grid": [1, 4, 9], "rotated-grid-cw": [1, 4], "rotated-grid-ccw": [1, 4]}


@st.composite
def frames(draw, normals=AXIS_FRAMES):
    """(normal, tangent): an axis-aligned pair tilted a little; never parallel."""
    normal, tangent = draw(st.sampled_from(normals))
    jitter = draw(vectors(6, -0.3, 0.3))
    return [a + b for a, b in zip(normal, jitter[:3])], [a + b for a, b in zip(tangent, jitter[3:])]


@st.composite
def cameras(draw):
    camera = {"position": [draw(finite(-0.5, 0.5)), draw(finite(-4.0, -2.0)), draw(finite(0.5, 2.0))],
              "look_at": [draw(finite(-0.3, 0.3)), 0.0, draw(finite(0.5, 1.5))],
              "up": [0.0, 0.0, 1.0], "fov": draw(finite(20.0, 100.0))}
    if draw(st.booleans()):
        camera["focal_length"] = draw(finite(0.1, 3.0))
    return camera


@st.composite
def render_tables(draw):
    render = {}
    for sampler_key, count_key in (("sampler", "spp"), ("light_sampler", "light_samples")):
        sampler = draw(st.sampled_from(SAMPLERS))
        count = draw(st.sampled_from(SAMPLE_COUNTS.get(sampler, [1, 2, 3, 4, 5, 8])))
        if sampler != "grid" or draw(st.booleans()):
            render[sampler_key] = sampler
        if count != 1 or draw(st.booleans()):
            render[count_key] = count
    return render


@st.composite
def lights(draw):
    normal, tangent = draw(frames([AXIS_FRAMES[1]]))
    return {"center": [draw(finite(-0.5, 0.5)), draw(finite(-0.5, 0.5)), draw(finite(1.5, 2.5))],
            "size": draw(vectors(2, 0.1, 1.0)),
            "normal": normal, "tangent": tangent, "colour": draw(vectors(3, 0.0, 2.0))}


TEXTURE_FORMATS = {  # extension: (channel counts, pixel types) OpenImageIO writes
    ".png": ([1, 2, 3, 4], ["uint8", "uint16"]), ".exr": ([1, 2, 3, 4], ["half", "float"]),
    ".tif": ([1, 3, 4], ["uint8", "uint16", "float"]), ".jpg": ([1, 3], ["uint8"]), ".hdr": ([3], ["float"]),
}


@st.composite
def valid_images(draw, name, role):
    ext = draw(st.sampled_from(sorted(TEXTURE_FORMATS)))
    channels, types = TEXTURE_FORMATS[ext]
    if role == "normal":
        channels = [c for c in channels if c >= 3]
    width, height = draw(st.integers(1, 8)), draw(st.integers(1, 8))
    values = tuple(draw(st.lists(finite(0.0, 1.0), min_size=1, max_size=6)))
    return ImageFile(name + ext, ext, width, height, draw(st.sampled_from(channels)), draw(st.sampled_from(types)),
                     values)


@st.composite
def materials(draw, name, files):
    """A material table; the textures it names are added to `files`."""
    material = {}
    if draw(st.booleans()):
        material["colour"] = draw(vectors(3, 0.0, 1.0))
    if draw(st.booleans()):
        material["shininess"] = draw(finite(0.5, 200.0))
    maps = draw(st.sets(st.sampled_from(["texture", "normal_map", "height_map"])))
    if "colour" not in material and "texture" not in maps:
        material["colour"] = draw(vectors(3, 0.0, 1.0))
    for key in sorted(maps):
        role = {"texture": "colour", "normal_map": "normal", "height_map": "height"}[key]
        if draw(st.booleans()):
            image = draw(valid_images(f"{name}_{key}", role))
        else:
            image = AssetCopy(f"{name}_{key}.png", "textures/grid.png")
        files.append(image)
        material[key] = image.name
    if "height_map" in maps:
        material["height_scale"] = draw(finite(0.0, 0.1))
    if draw(st.booleans()):
        material["uv_scale"] = draw(vectors(2, 0.1, 10.0))
    if draw(st.booleans()):
        material["uv_offset"] = draw(vectors(2, -5.0, 5.0))
    if draw(st.booleans()):
        material["wrap"] = draw(st.sampled_from(["repeat", "clamp", "mirror"]))
    return material


TETRAHEDRON = [[-1.0, 0.2, 0.2], [-0.5, -0.65, 0.2], [0.0, 0.2, 0.2], [-0.5, -0.3774, 1.0]]
TETRAHEDRON_FACES = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]


@st.composite
def valid_obj_texts(draw):
    """A tetrahedron in OBJ, with or without texture coordinates and normals, and perhaps a degenerate face
    (which the renderer drops with a note)."""
    jitter = draw(vectors(12, -0.05, 0.05))
    lines = [f"v {x + jitter[3 * i]} {y + jitter[3 * i + 1]} {z + jitter[3 * i + 2]}"
             for i, (x, y, z) in enumerate(TETRAHEDRON)]
    uv, normals = draw(st.booleans()), draw(st.booleans())
    if uv:
        lines += ["vt 0 0", "vt 1 0", "vt 0 1", "vt 1 1"]
    if normals:
        lines += ["vn 0 0 1", "vn 0 1 0", "vn 1 0 0", "vn 0 0 -1"]
    faces = TETRAHEDRON_FACES + ([[0, 0, 1]] if draw(st.booleans()) else [])
    if draw(st.booleans()):
        faces = faces + [[0, 1, 2, 3]]  # a quad: fanned into two triangles
    corner = "{0}/{0}/{0}" if uv and normals else "{0}/{0}" if uv else "{0}//{0}" if normals else "{0}"
    for face in faces:
        lines.append("f " + " ".join(corner.format(k + 1) for k in face))
    return "\n".join(lines) + "\n"


def ply_bytes(vertices, faces, binary=True, normals=None):
    names = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else [])
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {len(vertices)}",
              *(f"property float {n}" for n in names), f"element face {len(faces)}",
              "property list uchar int vertex_indices", "end_header"]
    rows = [list(v) + (list(normals[i]) if normals is not None else []) for i, v in enumerate(vertices)]
    if not binary:
        body = [" ".join(repr(float(x)) for x in row) for row in rows]
        body += [" ".join(map(str, [len(f), *f])) for f in faces]
        return ("\n".join(header + body) + "\n").encode()
    data = b"".join(struct.pack(f"<{len(row)}f", *row) for row in rows)
    data += b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)
    return ("\n".join(header) + "\n").encode() + data


@st.composite
def valid_mesh_files(draw, name):
    if draw(st.booleans()):
        return TextFile(name + ".obj", draw(valid_obj_texts()))
    jitter = draw(vectors(12, -0.05, 0.05))
    vertices = [[c + jitter[3 * i + k] for k, c in enumerate(v)] for i, v in enumerate(TETRAHEDRON)]
    normals = [[0.0, 0.0, 1.0]] * 4 if draw(st.booleans()) else None
    return BytesFile(name + ".ply", ply_bytes(vertices, TETRAHEDRON_FACES, draw(st.booleans()), normals))


def rotation_matrix(axis, degrees):
    a = np.array(axis, np.float64) / np.linalg.norm(axis)
    t = math.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


@st.composite
def mesh_transforms(draw):
    """Some of scale, rotate and translate, or a matrix."""
    signed = st.tuples(finite(0.05, 0.5), st.sampled_from([1.0, -1.0])).map(lambda p: p[0] * p[1])
    scale = draw(st.one_of(finite(0.05, 0.5), st.lists(signed, min_size=3, max_size=3)))  # negative: a mirror
    axis = draw(vectors(3, -1.0, 1.0).filter(lambda a: np.linalg.norm(a) > 0.1))
    degrees, translate = draw(finite(-360.0, 360.0)), draw(vectors(3, -1.0, 1.0))
    if draw(st.booleans()):
        m = np.eye(4)
        m[:3, :3] = rotation_matrix(axis, degrees) @ np.diag(np.broadcast_to(scale, 3))
        m[:3, 3] = translate
        return {"matrix": m.tolist()}
    transform = {}
    if draw(st.booleans()):
        transform["scale"] = scale
    if draw(st.booleans()):
        transform["rotate"] = {"axis": axis, "degrees": degrees}
    if draw(st.booleans()):
        transform["translate"] = translate
    return transform


@st.composite
def shapes(draw, material_names, files):
    """One [[shapes]] table of any type; mesh files it names are added to `files`."""
    kind = draw(st.sampled_from(["rectangle", "triangle", "inline mesh", "mesh file", "generated mesh",
                                 "ellipsoid"]))
    shape = {"type": "mesh" if "mesh" in kind else kind, "material": draw(st.sampled_from(material_names))}
    if kind == "rectangle":
        normal, tangent = draw(frames())
        shape.update(center=draw(vectors(3, -1.0, 1.0)), size=draw(vectors(2, 0.1, 3.0)), normal=normal,
                     tangent=tangent)
    elif kind == "triangle":
        v0 = draw(vectors(3, -1.0, 1.0))
        e1, e2 = draw(frames())
        a, b = draw(finite(0.2, 1.0)), draw(finite(0.2, 1.0))
        shape["vertices"] = [v0, [p + a * d for p, d in zip(v0, e1)], [p + b * d for p, d in zip(v0, e2)]]
        if draw(st.booleans()):
            shape["uv"] = draw(st.lists(vectors(2, -2.0, 2.0), min_size=3, max_size=3))
    elif kind == "inline mesh":
        jitter = draw(vectors(12, -0.05, 0.05))
        shape["vertices"] = [[c + jitter[3 * i + k] for k, c in enumerate(v)] for i, v in enumerate(TETRAHEDRON)]
        shape["faces"] = draw(st.lists(st.sampled_from(TETRAHEDRON_FACES), min_size=1, max_size=4, unique_by=tuple))
    elif kind == "ellipsoid":
        axes = np.diag(draw(vectors(3, 0.1, 0.6))) + np.array(draw(vectors(9, -0.05, 0.05))).reshape(3, 3)
        shape.update(center=draw(vectors(3, -1.0, 1.0)), axes=axes.tolist())
    else:
        if kind == "mesh file":
            mesh = draw(valid_mesh_files(f"mesh{len(files)}"))
            files.append(mesh)
            shape["file"] = mesh.name
        else:
            shape["generate"] = {"shape": draw(st.sampled_from(["sphere", "torus", "terrain"])),
                                 "triangles": draw(st.integers(2, 300))}
        shape.update(draw(mesh_transforms()))
        if draw(st.booleans()):
            shape["smooth"] = draw(st.booleans())
    return shape


@st.composite
def valid_scenes(draw, max_shapes=4, min_files=0):
    """A small scene that must render: every table of the grammar, optional keys present or not; images
    1..16 pixels a side, a few samples."""
    files = []
    table = {"camera": draw(cameras()),
             "image": {"width": draw(st.integers(1, 16)), "height": draw(st.integers(1, 16))}}
    if draw(st.booleans()):
        table["render"] = draw(render_tables())
    if draw(st.booleans()):
        table["ambient"] = draw(vectors(3, 0.0, 0.3))
    names = [f"m{i}" for i in range(draw(st.integers(1, 3)))]
    table["materials"] = {name: draw(materials(name, files)) for name in names}
    table["lights"] = draw(st.lists(lights(), min_size=1, max_size=2))
    table["shapes"] = draw(st.lists(shapes(names, files), max_size=max_shapes))
    if not table["shapes"] and draw(st.booleans()):
        del table["shapes"]
    assume(len(files) >= min_files)
    return SceneExample(table, tuple(files))


def texture_filters():
    return st.sampled_from(["trilinear", "nearest", "bilinear", "anisotropic"])


# --- hostile values and mutations ----------------------------------------------------------------------

SPECIAL_FLOATS = (math.nan, math.inf, -math.inf, 1e39, -1e39, 3e38, -3e38, 3.4028234663852886e38,
                  3.4028235677973366e38, 1e-45, -1e-45, 1e-39, 1.1754943508222875e-38, 0.0, -0.0, 5e-324, 1e-300,
                  1e300, 1.7976931348623157e308, 1e30, 1e31, -1.0, -0.5, 1e-7, 179.99999999999997, 180.0, 4e9)
SPECIAL_INTS = (0, -1, 1, 2, 3, 5, 7, 16384, 16385, 32768, 32769, 65536, 65537, 2**31 - 1, 2**31, 2**32,
                2**63 - 1, -2**63, 2**64, 10**30, 50_000_000, 50_000_001)
WRONG_TYPES = ("", "x", "nan", "inf", "1.0", "grid", "repeat", "sphere", "m0", "\n", "a\nb", "é", "\x00",
               "../", "/dev/null", "a\nb.obj", "x.ply", "scene.toml", "/", True, False, {}, {"x": 1}, [], [1.0],
               [1.0, 2.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0, 4.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
               ["a", "b", "c"], [True, False, True], [math.nan, math.nan, math.nan], [[]], [{}], [0, 0, 0], [1, 1],
               [0.0, 0.0], [1e39, 0.0, 0.0], [3e38, 3e38, 3e38], [1e-45, 1e-45])
EXTRA_KEYS = ("zoom", "color", "Colour", "colour ", "", " ", "type", "file", "generate", "a\nb", "é", "\x00",
              "fov", "center", "size", "normal", "materials", "smooth", "matrix", "spp", "width")
FACTORS = (1e-45, 1e-39, 1e-30, 1e30, 1e38, 1e39, -1.0, 0.0, 1e300, 1e-300, 3.0, 1e15, 1e18, 2.0**60, 2.0**-60,
           1e-15, 1 + 2.0**-40)


def hostile_values():
    """A value to put where another was: special floats and integers, wrong types, anything."""
    return st.one_of(st.sampled_from(SPECIAL_FLOATS), st.sampled_from(SPECIAL_INTS),
                     st.sampled_from(WRONG_TYPES).map(copy.deepcopy), st.floats(), st.integers(),
                     st.text(max_size=10), st.lists(st.sampled_from(SPECIAL_FLOATS), max_size=4))


def node_paths(node, prefix=()):
    """Every path (keys and indices) into a table, the root's () included."""
    yield prefix
    if isinstance(node, dict):
        for key, value in node.items():
            yield from node_paths(value, prefix + (key,))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from node_paths(value, prefix + (i,))


def node_at(table, path):
    for key in path:
        table = table[key]
    return table


def scaled(value, factor):
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return value * factor
    if isinstance(value, list):
        return [scaled(v, factor) for v in value]
    if isinstance(value, dict):
        return {k: scaled(v, factor) for k, v in value.items()}
    return value


def retyped(value):
    """The same value in another type: 8 -> 8.0, 8.0 -> 8, numbers -> strings, true -> 1."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int):
        return float(value)
    if isinstance(value, float):
        return int(value) if math.isfinite(value) and value == int(value) else str(value)
    if isinstance(value, list):
        return {str(i): v for i, v in enumerate(value)}
    if isinstance(value, dict):
        return list(value.values())
    return [value]


@dataclasses.dataclass(frozen=True)
class Mutation:
    """One change to a scene table: `where` picks the node (an index into all its paths, modulo their number),
    `op` says what is done to it, with `value`, `key`, `factor`, `count` or `other` (a second index, of the
    node whose value an alias copies)."""
    where: int
    op: str  # replace, scale, retype, alias, delete, extra key, rename key, resize
    value: object
    key: str
    factor: float
    count: int
    other: int

    def apply(self, table):
        paths = [*list(node_paths(table))[1:], ()]
        path = paths[self.where % len(paths)]
        node = node_at(table, path)
        parent = node_at(table, path[:-1]) if path else None
        value = copy.deepcopy(self.value)
        if self.op == "extra key" and isinstance(node, dict):
            node[self.key] = value
        elif self.op == "resize" and isinstance(node, list):
            node[:] = [copy.deepcopy(node[i % len(node)]) for i in range(self.count)] if node else [0.0] * self.count
        elif not path:
            table[self.key] = value
        elif self.op == "delete":
            del parent[path[-1]]
        elif self.op == "rename key" and isinstance(parent, dict):
            parent[self.key] = parent.pop(path[-1])
        elif self.op == "scale":
            parent[path[-1]] = scaled(node, self.factor)
        elif self.op == "retype":
            parent[path[-1]] = retyped(node)
        elif self.op == "alias":  # the value of another node of the same shape: tangent = normal, v1 = v0, ...
            alike = [p for p in paths if p and p != path and same_shape(node_at(table, p), node)]
            if alike:
                parent[path[-1]] = copy.deepcopy(node_at(table, alike[self.other % len(alike)]))
        else:
            parent[path[-1]] = value


def same_shape(a, b):
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_shape(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and not isinstance(a, dict)


def mutations():
    """One to three Mutations: a value replaced by a hostile one, scaled by an extreme factor, retyped or
    made a copy of another of the same shape; a key deleted, renamed or an extra one added; an array cut
    short or grown to a huge count."""
    return st.lists(st.builds(Mutation, st.sampled_from(range(1009)),
                              st.sampled_from(["replace", "replace", "replace", "scale", "scale", "retype", "alias",
                                               "alias", "delete", "extra key", "rename key", "resize"]),
                              hostile_values(), st.sampled_from(EXTRA_KEYS), st.sampled_from(FACTORS),
                              st.sampled_from([0, 1, 2, 4, 33, 65, 200]), st.sampled_from(range(1013))),
                    min_size=1, max_size=3)


@st.composite
def hostile_scenes(draw):
    """A valid scene mutated with hostile values (its files kept). The mutations are drawn first: Hypothesis
    makes the draws after a whole scene mostly copies of an earlier example's, or zeros."""
    changes = draw(mutations())
    example = draw(valid_scenes())
    table = copy.deepcopy(example.table)
    for change in changes:
        change.apply(table)
    return SceneExample(table, example.files)


@dataclasses.dataclass(frozen=True)
class DamagedText:
    """A scene file's text damaged so that it is no longer a TOML table we wrote: `kind` says how, `at` where
    (or how deep), `extra` with what."""
    kind: str
    text: bytes
    at: int
    extra: bytes

    def data(self):
        if self.kind == "truncated":
            return self.text[:self.at]
        if self.kind == "random bytes":
            return self.extra
        if self.kind == "nested arrays":
            return self.text + b"x = " + b"[" * self.at + b"]" * self.at + b"\n"
        if self.kind == "nested tables":
            return self.text + b"x = " + b"{a = " * self.at + b"1" + b"}" * self.at + b"\n"
        if self.kind == "byte order mark":
            return "\ufeff".encode() + self.text
        if self.kind == "inserted bytes":
            return self.text[:self.at] + self.extra + self.text[self.at:]
        if self.kind == "duplicate table":
            return self.text + b"[camera]\nfov = 40.0\n"
        if self.kind == "carriage returns":
            return self.text.replace(b"\n", b"\r")
        return b""


@st.composite
def broken_scene_texts(draw):
    """(DamagedText, files): a valid scene's text truncated, replaced by random bytes, nested deeply, made
    invalid UTF-8 or otherwise no TOML."""
    kind = draw(st.sampled_from(["truncated", "random bytes", "nested arrays", "nested tables", "byte order mark",
                                 "inserted bytes", "duplicate table", "carriage returns", "empty"]))
    example = draw(valid_scenes(max_shapes=2))
    text = example.text().encode()
    at, extra = 0, b""
    if kind in ("truncated", "inserted bytes"):
        at = draw(st.integers(0, len(text)))
    if kind in ("nested arrays", "nested tables"):
        at = draw(st.sampled_from([10, 500, 1000, 5000, 100000]))
    if kind == "random bytes":
        extra = draw(st.binary(max_size=200))
    if kind == "inserted bytes":
        extra = draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x80", b"\x00", b"\x7f", b"\r"]))
    return DamagedText(kind, text, at, extra), example.files


# --- hostile texture and mesh files --------------------------------------------------------------------

MAGIC = (b"", b"\x89PNG\r\n\x1a\n", b"v/1\x01\x02\x00\x00\x00", b"#?RADIANCE\n", b"II*\x00", b"MM\x00*",
         b"\xff\xd8\xff\xe0", b"BM", b"ply\nformat binary_little_endian 1.0\n", b"ply\nformat ascii 1.0\n",
         b"v 0 0 0\n")
ODD_VALUES = (math.nan, math.inf, -math.inf, -1.0, -0.0, 0.0, 1.0, 1e39, 65504.0, 65520.0, 1e-45, 3e38, 0.5)


@st.composite
def odd_images(draw, name):
    """Well-formed images that are hard to use: any channel count and pixel type, NaN, negative or huge
    texels, 1-pixel and very long thin images."""
    ext = draw(st.sampled_from([".png", ".exr", ".tif", ".hdr", ".jpg", ".bmp", ".tga"]))
    width, height = draw(st.sampled_from([(1, 1), (1, 2), (2, 1), (3, 5), (1, 2048), (2048, 1), (16, 16),
                                          (1023, 3)]))
    return ImageFile(name + ext, ext, width, height, draw(st.integers(1, 6)),
                     draw(st.sampled_from(["uint8", "uint16", "half", "float"])),
                     tuple(draw(st.lists(st.sampled_from(ODD_VALUES), min_size=1, max_size=4))))


OBJ_NUMBERS = ("0", "1", "-1", "0.5", "1e39", "-1e39", "3e38", "nan", "inf", "-inf", "1e-45", "x", "", "1,5",
               "0x10", "1e400")
OBJ_INDICES = ("1", "2", "3", "4", "0", "-1", "-4", "-5", "5", "99999999999999999999", "1/1", "1//1", "1/1/1",
               "2/2/2", "1/", "x", "1.5", "/", "-0")


@st.composite
def hostile_obj_texts(draw):
    lines = []
    for _ in range(draw(st.integers(0, 5))):
        kind = draw(st.sampled_from(["v", "v", "vt", "vn", "f", "f", "junk"]))
        if kind == "f":
            lines.append("f " + " ".join(draw(st.lists(st.sampled_from(OBJ_INDICES), min_size=0, max_size=5))))
        elif kind == "junk":
            lines.append(draw(st.sampled_from(["o a", "g", "usemtl x", "mtllib none.mtl", "s 1", "#", "", "l 1 2",
                                               "p 1", "vp 1 2", "\x00", "f", "v"])))
        else:
            n = {"v": 3, "vt": 2, "vn": 3}[kind]
            numbers = draw(st.lists(st.sampled_from(OBJ_NUMBERS), min_size=n - 1, max_size=n + 1))
            lines.append(" ".join([kind, *numbers]))
    base = draw(valid_obj_texts())
    return draw(st.sampled_from([base, ""])) + "\n".join(lines) + draw(st.sampled_from(["", "\n", "\r\n"]))


PLY_PROPERTY_TYPES = ("char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "float64",
                      "long", "")


@st.composite
def hostile_ply_bytes(draw):
    """PLY files whose headers lie (counts, types) or whose data is hostile."""
    binary = draw(st.booleans())
    vertices = draw(st.lists(st.lists(st.sampled_from(ODD_VALUES + (0.0, 1.0, 0.2)), min_size=3, max_size=3),
                             max_size=5))
    faces = draw(st.lists(st.lists(st.integers(-2, 6), min_size=0, max_size=5), max_size=4))
    declared_vertices = draw(st.sampled_from([len(vertices), len(vertices) + 1, max(0, len(vertices) - 1), 0,
                                              2**31 - 1, 2**32 + 3, -1]))
    declared_faces = draw(st.sampled_from([len(faces), len(faces) + 1, 0, 2**31 - 1, -1]))
    coordinate_type = draw(st.sampled_from(PLY_PROPERTY_TYPES))
    count_type, index_type = draw(st.sampled_from(PLY_PROPERTY_TYPES)), draw(st.sampled_from(PLY_PROPERTY_TYPES))
    if draw(st.booleans()):
        coordinate_type, count_type, index_type = "float", "uchar", "int"
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
              f"element vertex {declared_vertices}", *(f"property {coordinate_type} {n}" for n in "xyz"),
              f"element face {declared_faces}", f"property list {count_type} {index_type} vertex_indices",
              "end_header"]
    if not binary:
        body = [" ".join(repr(x) for x in v) for v in vertices] + [" ".join(map(str, [len(f), *f])) for f in faces]
        return ("\n".join(header + body) + "\n").encode()
    with np.errstate(over="ignore"):
        data = np.array(vertices, "<f4").tobytes()  # 1e39 becomes inf
    data += b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)
    return ("\n".join(header) + "\n").encode() + data


@st.composite
def hostile_files(draw, name):
    """A file to stand where `name` (a texture or mesh the scene names) was: random bytes behind a magic
    number, a truncated or damaged copy of a real file, an odd image, a hostile OBJ or PLY, or a directory."""
    stem, ext = os.path.splitext(name)
    kind = draw(st.sampled_from(["random bytes", "truncated asset", "damaged image", "odd image", "obj", "ply",
                                 "empty", "directory"]))
    if kind == "random bytes":
        return BytesFile(name, draw(st.sampled_from(MAGIC)) + draw(st.binary(max_size=300)))
    if kind == "truncated asset":
        asset = draw(st.sampled_from(["textures/grid.png", "textures/stones_normal.png", "torus.ply"]))
        return AssetCopy(name, asset, draw(st.integers(0, 60000)))
    if kind == "damaged image":
        image = draw(valid_images(stem, "normal"))
        patches = tuple(draw(st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), max_size=4)))
        return DamagedFile(name, image, draw(st.one_of(st.none(), st.integers(0, 400))), patches)
    if kind == "odd image":
        return draw(odd_images(stem))  # written in its own format, whatever the name says
    if kind == "obj":
        return TextFile(name, draw(hostile_obj_texts()))
    if kind == "ply":
        return BytesFile(name, draw(hostile_ply_bytes()))
    if kind == "directory":
        return Directory(name)
    return BytesFile(name, b"")


RENAMED_EXTENSIONS = (".png", ".exr", ".hdr", ".tif", ".jpg", ".obj", ".ply", ".OBJ", ".PLY", ".stl", ".txt", "")


@st.composite
def scenes_with_hostile_files(draw):
    """A valid scene naming textures or meshes, the first of whose files are replaced by hostile ones (under
    the same name, or under a new name with another extension, which the scene then names). The hostile
    files are drawn first, for the reason given in hostile_scenes."""
    replacements = draw(st.lists(st.tuples(hostile_files("placeholder"),
                                           st.one_of(st.none(), st.sampled_from(RENAMED_EXTENSIONS))),
                                 min_size=1, max_size=3))
    example = draw(valid_scenes(max_shapes=3, min_files=1))
    table, files = copy.deepcopy(example.table), list(example.files)
    for i, (hostile, ext) in enumerate(replacements[:len(files)]):
        name = files[i].name
        if ext is not None:
            new = os.path.splitext(name)[0] + "_x" + ext
            rename_references(table, name, new)
            name = new
        files[i] = dataclasses.replace(hostile, name=name)
    return SceneExample(table, tuple(files))


def rename_references(node, old, new):
    for key, value in (node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()):
        if value == old:
            node[key] = new
        else:
            rename_references(value, old, new)


# --- hostile command lines -----------------------------------------------------------------------------

HOSTILE_NUMBERS = ("0", "-1", "1", "2", "4", "5", "9", "16", "17", "65536", "65537", "16384", "16385",
                   "2147483648", "4294967295", "4294967296", "99999999999999999999", "1.5", "1e3", "8.0", "nan", "inf",
                   "-inf", "1e-300", "1e308", "1e-320", "-0", "-0.0", "", " ", "0x10", "1_0", "٨", "８", "+4", " 4 ",
                   "−1", "None")
HOSTILE_WORDS = ("", " ", "grid", "center", "sobol", "halton", "random", "rotated-grid-cw", "GRID", "grid ",
                 "trilinear", "nearest", "anisotropic", "none", "é", "a\nb", "-", "--", "cpu", "gpu", "CPU", "0:0",
                 "0:1", "1:0", "0:0:0", "0:0:", ":", "0:", ":0", "-1:0", "00:00", "٠:٠", "99999999999999999999:0",
                 "pthread", "Portable", "accelerator", "custom", "all")
NUMERIC_OPTIONS = ("--width", "--height", "--spp", "--light-samples", "--seed", "--time-limit", "--target-error")
TEXT_OPTIONS = ("--sampler", "--light-sampler", "--texture-filter", "--device")
VALID_OPTION_VALUES = {
    "--width": st.integers(1, 16).map(str), "--height": st.integers(1, 16).map(str),
    "--spp": st.sampled_from(["1", "4", "9"]), "--light-samples": st.sampled_from(["1", "4"]),
    "--sampler": st.sampled_from(SAMPLERS), "--light-sampler": st.sampled_from(SAMPLERS),
    "--texture-filter": st.sampled_from(["nearest", "bilinear", "trilinear", "anisotropic"]),
    "--seed": st.integers(0, 2**32 - 1).map(str), "--time-limit": st.sampled_from(["0.001", "1", "60", "1e9"]),
    "--target-error": st.sampled_from(["1e-9", "0.01", "1", "1e30"]),
    "--device": st.sampled_from(["cpu", "CPU", "0:0", "Portable", "pthread"]),
}
OUTPUT_EXTENSIONS = (".png", ".exr", ".jpg", ".jpeg", ".bmp", ".tga", ".tif", ".tiff", ".hdr", ".PNG", ".Exr",
                     ".gif", ".webp", ".ppm", ".toml", "", ".", ".png.", ".exr.tmp")
OUTPUT_STEMS = ("out", "ü", "a b", ".hidden", "sub/out", "missing/out", "taken", "-", "a\nb", "x" * 300, "scene")


def device_specs():
    """--device values shaped like its "P:D" indices, with too many or too few parts, signs, odd digits."""
    digits = st.sampled_from(["0", "1", "7", "٠", "00", "99999999999999999999"])
    parts = st.one_of(digits, st.sampled_from(["", "-1", " 0", "x"]))
    return st.one_of(st.sampled_from([2, 3, 4]).flatmap(lambda n: st.lists(digits, min_size=n, max_size=n)),
                     st.lists(parts, min_size=1, max_size=4)).map(":".join)


def hostile_option_values(option):
    text = st.text(st.characters(blacklist_categories=["Cs"], blacklist_characters="\x00"), max_size=8)
    words = HOSTILE_NUMBERS if option in NUMERIC_OPTIONS else HOSTILE_WORDS
    shaped = device_specs() if option == "--device" else st.sampled_from(words)
    return st.one_of(st.sampled_from(words), shaped, st.sampled_from(HOSTILE_NUMBERS + HOSTILE_WORDS), text,
                     st.integers().map(str), st.floats().map(repr))


@dataclasses.dataclass
class CommandLine:
    scene: str
    output: str
    options: list  # (option, value, written as --option=value) in order; the last of an option counts
    flags: list

    def argv(self):
        argv = ["render", self.scene, "-o", self.output]
        for option, value, equals in self.options:
            argv += [f"{option}={value}"] if equals else [option, value]
        return argv + self.flags

    def value(self, option):
        values = [v for o, v, _ in self.options if o == option]
        return values[-1] if values else None


@st.composite
def command_lines(draw):
    """`render SCENE -o OUT` with valid values for some of render's options and a hostile one for one or two
    (one bad value at a time reaches further: the first is all the renderer reports); mostly a valid scene
    argument, output name and flags, sometimes hostile ones."""
    options = [(o, draw(VALID_OPTION_VALUES[o]), draw(st.booleans()))
               for o in draw(st.lists(st.sampled_from(NUMERIC_OPTIONS + TEXT_OPTIONS), max_size=3, unique=True))]
    hostile_count = draw(st.sampled_from([1, 1, 1, 0, 2]))
    for option in draw(st.lists(st.sampled_from(NUMERIC_OPTIONS + TEXT_OPTIONS), min_size=hostile_count,
                                max_size=hostile_count)):
        options.insert(draw(st.integers(0, len(options))),
                       (option, draw(hostile_option_values(option)), draw(st.booleans())))
    hostile = draw(st.integers(0, 9)) == 0
    scene = draw(st.sampled_from(["missing.toml", ".", "", "sub", "scene.toml/", "a\nb.toml", "x" * 300 + ".toml",
                                  "Scene.TOML"])) if hostile else "scene.toml"
    hostile = draw(st.integers(0, 4)) == 0
    output = (draw(st.sampled_from(OUTPUT_STEMS)) + draw(st.sampled_from(OUTPUT_EXTENSIONS)) if hostile
              else draw(st.sampled_from(["out.png", "out.exr", "out.hdr", "out.tif", "out.jpg"])))
    flags = draw(st.lists(st.sampled_from(["--no-progress", "--stats-json=stats.json", "--stats-json=sub",
                                           "--stats-json=missing/s.json", "--stats-json=", "--stats-json=taken.png",
                                           "--bogus", "extra.toml", "--no-progress=1"]),
                          max_size=2, unique=True)) if draw(st.integers(0, 3)) == 0 else ["--no-progress"]
    return CommandLine(scene, output, options, flags)


def parsed_int(text):
    """What argparse's type=int makes of `text`, or None."""
    try:
        return int(text)
    except (TypeError, ValueError):
        return None


# --- the environment -----------------------------------------------------------------------------------

def env_text():
    return st.text(st.characters(blacklist_categories=["Cs"], blacklist_characters="\x00"), max_size=6)


ENVIRONMENT_VALUES = {  # the variables the renderer reads in this process, and values to try
    "RAYTRACE_LANES": ("", "1", "4", "8", "16", "0", "2", "3", "-1", "32", "abc", "8.0", " 8", "٨", "１６",
                       "99999999999999999999", "1e1", "0x8", "8\n"),
    "RAYTRACE_TARGET": ("", "pocl", "x86-64-v2", "x86-64-v3", "x86-64-v4", "x86-64", "x86-64-v5", "generic",
                        "native", "znver3", "skylake-avx512", "X86-64-V3", " x86-64-v3", "x86-64-v3\n"),
    "POCL_CACHE_DIR": ("", "cache", "new/deeper/cache", "scene.toml", "scene.toml/cache", "/dev/null",
                       "/dev/null/cache", "/proc", "/proc/self/cache", "/nonexistent/cache", ".", "a\nb", "é"),
}
# Variables PoCL and the OpenCL loader read once, when a process first lists the platforms: tried in a
# child process.
LOADER_VALUES = {
    "POCL_DEVICES": ("", "pthread", "basic", "cuda", "none", "pthread pthread", "é"),
    "OCL_ICD_VENDORS": ("", "/nonexistent", "/dev/null", "."),
    "OCL_ICD_FILENAMES": ("", "/nonexistent.so", "/dev/null", "libnothing.so"),
}


def environments(values):
    """Some of the variables, each set to one of its values or to random text."""
    return st.dictionaries(st.sampled_from(sorted(values)), st.just(None), min_size=1).flatmap(
        lambda chosen: st.fixed_dictionaries({k: st.one_of(st.sampled_from(values[k]), env_text())
                                              for k in sorted(chosen)}))
