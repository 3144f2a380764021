"""Fuzzing the command line's promise to users with Hypothesis.

The contract: every input to `raytrace render` ends in one of two ways.

- Exit status 0, and an image file of the requested size that reads back (OpenImageIO) with only finite
  values; nothing else is left in the directory (but the `--stats-json` file asked for, whose
  `extra.nonfinite_values` is 0, as the README promises).
- Exit status 2, and exactly one line on stderr, `raytrace: error: SOURCE: KEY = VALUE: problem`, where
  SOURCE says where the bad value came from: the scene file's path, a mesh file it names, `command line`
  or `environment`; no file is left behind (no output, no `.raytrace-*` temporary file).

Anything else is a failure: another exit status, an exception escaping `raytrace.cli.main`, a traceback on
stderr, a second line beside the error (a note, a Python warning: warnings are shown as the command line
would print them), a line naming the wrong source, a file left behind, an image of the wrong size or with
NaN or infinite values.

What is fuzzed, each example in a fresh temporary directory (the CLI runs in this process, so the kernel
variants are built once; stderr is captured at the file-descriptor level, where C libraries write):

- scene files built from the real grammar (raytrace/scene/scene_file.py: camera, image, render, ambient,
  materials with colour, shininess, texture, normal_map, height_map, uv_scale, uv_offset and wrap, lights,
  rectangles, triangles, inline, file and generated meshes with their transforms, ellipsoids), valid ones
  and ones mutated with hostile values (NaN, inf, 1e39, 3e38, denormals, 0, negative numbers, huge counts,
  wrong types, arrays of the wrong length, missing and extra keys), written by a TOML writer of our own
  (tomllib only reads) that spells NaN and infinity as TOML's `nan` and `inf`;
- scene files that are not valid TOML at all (truncated, binary, not UTF-8, deeply nested);
- command lines: render's options with hostile values, and random output names and extensions;
- texture and mesh files with random bytes, truncated or corrupted copies, odd but well-formed images
  (every channel count and pixel type, NaN texels, extreme sizes) and hostile OBJ and PLY files;
- the environment: RAYTRACE_LANES, RAYTRACE_TARGET and POCL_CACHE_DIR in this process; POCL_DEVICES,
  OCL_ICD_VENDORS and OCL_ICD_FILENAMES, which the OpenCL loader reads once, in a few child processes.

Images are tiny (at most 16 x 16 unless the fuzzed value is the size itself), so an example takes
milliseconds once its kernel variant is built.

Running it:

    python -m pytest tests/test_fuzz.py
        # the CI budget: a fixed (derandomised) set of about 950 examples, under a minute on two cores
        # (two with an empty PoCL kernel cache: about 100 kernel variants get built); a failing example is
        # printed as generated (RAYTRACE_FUZZ_SHRINK=1: shrunk first, minutes more)
    RAYTRACE_FUZZ_EXAMPLES=3000 python -m pytest tests/test_fuzz.py
        # a long run: that many examples per test, random ones (not derandomised), each failure shrunk
    RAYTRACE_FUZZ_SURVEY=failures.jsonl RAYTRACE_FUZZ_EXAMPLES=3000 python -m pytest tests/test_fuzz.py
        # a survey: every failing example is appended to the file (kind, argv, scene, stderr, traceback) and
        # the run goes on instead of stopping and shrinking; the tests then pass, so use it to list bugs only

A failing example is printed with its scene file's text, its other files and its command line.
"""
import contextlib
import copy
import dataclasses
import json
import math
import os
import re
import signal
import struct
import subprocess
import sys
import tempfile
import tomllib
import traceback
import warnings
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from hypothesis import HealthCheck, Phase, assume, example, given, note, settings
from hypothesis import strategies as st

from raytrace import cli

ROOT = Path(__file__).resolve().parent.parent
ASSETS = ROOT / "assets"

# --- budget -------------------------------------------------------------------------------------------

LONG_RUN = int(os.environ.get("RAYTRACE_FUZZ_EXAMPLES", "0") or 0)
SHRINK = bool(LONG_RUN or os.environ.get("RAYTRACE_FUZZ_SHRINK"))
SURVEY = os.environ.get("RAYTRACE_FUZZ_SURVEY")
EXAMPLE_SECONDS = 120  # one example that takes longer than this is a failure of its own (a hang)


def budget(ci_examples):
    """Hypothesis settings: `ci_examples` derandomised examples, or RAYTRACE_FUZZ_EXAMPLES random ones.
    Failures are shrunk only in a long run or with RAYTRACE_FUZZ_SHRINK=1: shrinking one takes a minute or
    more (every step a render), which the CI budget has not got."""
    phases = [Phase.explicit, Phase.reuse, Phase.generate] + ([Phase.shrink, Phase.explain] if SHRINK else [])
    return settings(max_examples=LONG_RUN or ci_examples, deadline=None, derandomize=not LONG_RUN, database=None,
                    phases=phases, print_blob=bool(LONG_RUN), report_multiple_bugs=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                           HealthCheck.data_too_large, HealthCheck.large_base_example])


# --- a TOML writer that can spell nan and inf ----------------------------------------------------------

BARE_KEY = re.compile(r"[A-Za-z0-9_-]+\Z")


def toml_string(text):
    escaped = []
    for ch in text:
        if ch in '"\\':
            escaped.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            escaped.append(f"\\u{ord(ch):04x}")
        else:
            escaped.append(ch)
    return '"' + "".join(escaped) + '"'


def toml_key(key):
    return key if BARE_KEY.match(key) else toml_string(key)


def toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)  # always has a '.' or an exponent: 1e+39 stays a float
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(map(toml_value, value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {value!r}")


def to_toml(table):
    """The table as TOML text, every value inline (one line per top-level key)."""
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in table.items())


def same_tables(a, b):
    """Equality that counts NaN equal to NaN and tells 1 from 1.0 and -0.0 from 0.0."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same_tables(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same_tables(x, y) for x, y in zip(a, b))
    return a == b


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


@dataclasses.dataclass(frozen=True)
class Directory:
    name: str

    def write(self, directory):
        (directory / self.name).mkdir()


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


# --- running the command line in this process ----------------------------------------------------------

class ExampleTimedOut(BaseException):
    """One example ran longer than EXAMPLE_SECONDS (a BaseException, so `except Exception` cannot eat it)."""


@contextlib.contextmanager
def time_limit(seconds):
    def expired(signum, frame):
        raise ExampleTimedOut(f"the example ran for more than {seconds} s")
    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def captured_stderr():
    """fd 2 and sys.stderr both into one temporary file (C libraries write to the fd, Python to sys.stderr);
    yields a list that holds the text afterwards."""
    sys.stderr.flush()
    saved_fd, saved_stream, text = os.dup(2), sys.stderr, []
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        sys.stderr = stream = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False, buffering=1)
        try:
            yield text
        finally:
            stream.close()  # flushed; fd 2 stays open
            sys.stderr = saved_stream
            os.dup2(saved_fd, 2)
            os.close(saved_fd)
            f.seek(0)
            text.append(f.read().decode("utf-8", "backslashreplace"))


@contextlib.contextmanager
def working_directory(path):
    previous = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(previous)


@contextlib.contextmanager
def environment(changes):
    saved = {k: os.environ.get(k) for k in changes}
    os.environ.update(changes)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def files_in(directory):
    """Every file under `directory`, as paths relative to it."""
    return {os.path.relpath(os.path.join(d, f), directory) for d, _, names in os.walk(directory) for f in names}


@dataclasses.dataclass
class Outcome:
    argv: list
    rc: object          # the exit status, or "SystemExit(...)" when argparse exits
    stderr: str         # fd 2's bytes, then the Python warnings the CLI would print
    error: BaseException | None  # an exception that escaped main
    new_files: set
    warnings: list = dataclasses.field(default_factory=list)  # the Python warnings among stderr's lines


def run_cli(argv, directory, env=None):
    before = files_in(directory)
    rc, error = None, None
    with captured_stderr() as stderr, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # a command line shows each warning once, and runs once
        for hidden in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
            warnings.simplefilter("ignore", hidden)  # as Python's default filters do outside __main__
        with working_directory(directory), environment(env or {}):
            try:
                with time_limit(EXAMPLE_SECONDS):
                    rc = cli.main(list(argv))
            except SystemExit as e:
                rc = f"SystemExit({e.code!r})"
            except (Exception, ExampleTimedOut) as e:
                error = e
    shown = [warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line) for w in caught]
    return Outcome(list(argv), rc, stderr[0] + "".join(shown), error, files_in(directory) - before, shown)


def read_image(path):
    """(spec, pixels) in the file's own format, as tests/test_cli.py reads them."""
    image = oiio.ImageInput.open(str(path))
    if image is None:
        return None, oiio.geterror()
    spec = image.spec()
    pixels = image.read_image(spec.format)
    image.close()
    return spec, pixels


# --- the contract --------------------------------------------------------------------------------------
# One exception type per way of breaking it, so that Hypothesis reports (and shrinks) each kind apart.

class ContractBroken(AssertionError):
    pass


class WrongExitStatus(ContractBroken):
    pass


class NotOneLine(ContractBroken):
    pass


class WrongErrorLine(ContractBroken):
    pass


class FilesLeftBehind(ContractBroken):
    pass


class BadImage(ContractBroken):
    pass


class StrayFiles(ContractBroken):
    pass


class TracebackOnStderr(ContractBroken):
    pass


class WarningOnStderr(ContractBroken):
    """A Python warning (numpy's overflow, division by zero, ...) printed by a render that succeeded: a sign
    of a value that went through unchecked, and noise in the user's terminal."""


class NonFiniteValuesCounted(ContractBroken):
    pass


class ValidInputRefused(ContractBroken):
    pass


def broken(kind, outcome, message, example_text=None):
    """Raise `kind`, or in a survey record it and go on."""
    if SURVEY:
        record = {"kind": kind.__name__, "message": message, "argv": outcome.argv, "rc": outcome.rc,
                  "stderr": outcome.stderr[-3000:], "scene": example_text}
        with open(SURVEY, "a") as f:
            f.write(json.dumps(record, default=repr) + "\n")
        return
    raise kind(f"{message}\nargv: {outcome.argv}\nexit status: {outcome.rc!r}\nstderr:\n{outcome.stderr}")


class EscapedException(ContractBroken):
    """An exception escaped main; a subclass per exception type and place it was raised (see escaped)."""


_escaped_kinds = {}


def raised_at(e):
    """file:line of the deepest frame in the raytrace package (else the deepest frame) of e's traceback."""
    frames = traceback.extract_tb(e.__traceback__)
    ours = [f for f in frames if f"{os.sep}raytrace{os.sep}" in f.filename] or frames
    return f"{os.path.relpath(ours[-1].filename, ROOT)}:{ours[-1].lineno}" if ours else "?"


def escaped(outcome, example_text=None):
    """An exception escaped main: raised again as an EscapedException subclass named after it and made once
    per (type, place raised), so that Hypothesis tells them apart and replays each the same way (a
    RecursionError's deepest frame moves), with the end of the original traceback in the message."""
    e, where = outcome.error, raised_at(outcome.error)
    tail = "".join(traceback.format_exception(e, limit=-12))[-4000:]
    message = f"{type(e).__name__} escaped raytrace.cli.main, raised at {where}: {str(e)[:300]}"
    if SURVEY:
        record = {"kind": "EscapedException", "message": message, "argv": outcome.argv, "rc": None,
                  "stderr": outcome.stderr[-3000:], "scene": example_text, "traceback": tail}
        with open(SURVEY, "a") as f:
            f.write(json.dumps(record, default=repr) + "\n")
        return
    kind = _escaped_kinds.setdefault((type(e), where), type(f"Escaped{type(e).__name__}", (EscapedException,), {}))
    raise kind(f"{message}\nargv: {outcome.argv}\n{tail}") from None


def check(outcome, directory, output, size, sources, stats=None, must_render=False, example_text=None):
    """The contract for one run. `output`: the image path asked for (relative to `directory`); `size`:
    (width, height) it must have, None if not known; `sources`: what an error line may name first;
    `stats`: the --stats-json path asked for, if any."""
    if outcome.error is not None:
        return escaped(outcome, example_text)
    if outcome.rc == 0:
        check_rendered(outcome, directory, output, size, stats, example_text)
    elif outcome.rc == 2:
        if must_render:
            broken(ValidInputRefused, outcome, "a valid scene was refused", example_text)
        check_refused(outcome, sources, example_text)
    else:
        broken(WrongExitStatus, outcome, f"exit status {outcome.rc!r}", example_text)


def check_rendered(outcome, directory, output, size, stats, example_text):
    if "Traceback" in outcome.stderr:
        broken(TracebackOnStderr, outcome, "a traceback on stderr with exit status 0", example_text)
    if outcome.warnings:
        broken(WarningOnStderr, outcome, f"Python warnings on stderr with exit status 0: {outcome.warnings[0]}",
               example_text)
    output = os.path.normpath(output)
    expected = {output, os.path.normpath(stats)} if stats else {output}
    if outcome.new_files - expected:
        broken(StrayFiles, outcome, f"files left besides the image: {sorted(outcome.new_files - expected)}",
               example_text)
    path = directory / output
    if not path.is_file():
        return broken(BadImage, outcome, "exit status 0 but no image file", example_text)
    spec, pixels = read_image(path)
    if spec is None:
        return broken(BadImage, outcome, f"the image does not read back: {pixels}", example_text)
    if size is not None and (spec.width, spec.height) != tuple(size):
        broken(BadImage, outcome, f"image is {spec.width} x {spec.height}, not {size[0]} x {size[1]}", example_text)
    if pixels is None or (np.asarray(pixels).dtype.kind == "f" and not np.isfinite(pixels).all()):
        broken(BadImage, outcome, "the image holds NaN or infinite values (or no pixels)", example_text)
    if stats:
        data = json.loads((directory / stats).read_text())
        if data.get("extra", {}).get("nonfinite_values", 0) != 0:
            broken(NonFiniteValuesCounted, outcome, f"the kernel produced {data['extra']['nonfinite_values']} NaN "
                   f"or infinite values (zeroed before writing; the README says always 0)", example_text)


def check_refused(outcome, sources, example_text):
    text = outcome.stderr
    if text.count("\n") != 1 or not text.endswith("\n"):
        broken(NotOneLine, outcome, f"{text.count(chr(10))} lines on stderr, not one", example_text)
    line = text.split("\n")[0]
    if "Traceback" in text:
        broken(TracebackOnStderr, outcome, "a traceback on stderr", example_text)
    prefix = "raytrace: error: "
    if not line.startswith(prefix):
        broken(WrongErrorLine, outcome, f"the line does not start with {prefix!r}", example_text)
    elif not any(line[len(prefix):].startswith(f"{shown}: ") for source in sources
                 for shown in (source, repr(source)[1:-1])):  # control characters may be shown escaped
        broken(WrongErrorLine, outcome, f"the line names none of {sorted(sources)} as the source", example_text)
    if outcome.new_files:
        broken(FilesLeftBehind, outcome, f"exit status 2 but files left: {sorted(outcome.new_files)}", example_text)


# --- running one example -------------------------------------------------------------------------------

def write_example(directory, scene_bytes, files):
    (directory / "scene.toml").write_bytes(scene_bytes)
    for f in files:
        if not (directory / f.name).exists() and "/" not in f.name and f.name not in ("", ".", ".."):
            f.write(directory)


def mesh_sources(table, scene_path="scene.toml"):
    """What an error from a mesh file names first: each `file` of the shapes, beside the scene file."""
    names = []
    shapes = table.get("shapes") if isinstance(table, dict) else None
    for shape in shapes if isinstance(shapes, list) else []:
        if isinstance(shape, dict) and isinstance(shape.get("file"), str):
            names.append(str(Path(scene_path).parent / shape["file"]))
    return names


def plain_int(table, *path, default=None):
    try:
        value = node_at(table, path)
    except (KeyError, IndexError, TypeError):
        return default
    return value if type(value) is int else None


def cost_flags(table):
    """A time limit for scenes whose samples make for a long render (they are valid, and only slow)."""
    width, height = plain_int(table, "image", "width"), plain_int(table, "image", "height")
    spp, ls = plain_int(table, "render", "spp", default=1), plain_int(table, "render", "light_samples", default=1)
    n_lights = len(table["lights"]) if isinstance(table.get("lights"), list) else 1
    if None in (width, height, spp, ls):
        return []
    assume(width * height <= 1 << 20 and width * height * (1 + ls * n_lights) <= 3e7)
    for path in node_paths(table):
        if path and path[-1] == "triangles":
            value = node_at(table, path)
            assume(not isinstance(value, int) or value <= 200_000)
    return ["--time-limit", "1"] if width * height * spp * (1 + ls * n_lights) > 2e6 else []


def fuzz_scene(scene_bytes, files, table, must_render=False, texture_filter="trilinear"):
    """Render `scene_bytes` (beside `files`) with a valid command line; `table` is the scene as written (None
    when the bytes are not TOML we wrote)."""
    text = scene_bytes.decode("utf-8", "backslashreplace")
    note(f"scene.toml:\n{text[:3000]}" + (f"... ({len(text)} characters)" if len(text) > 3000 else ""))
    note(f"files: {files!r}"[:3000])
    ext = ".exr" if len(scene_bytes) % 2 else ".png"
    flags = cost_flags(table) if table is not None else []
    stats = "stats.json"
    argv = ["render", "scene.toml", "-o", "out" + ext, "--no-progress", "--stats-json", stats,
            "--texture-filter", texture_filter, *flags]
    size = None
    if table is not None:
        width, height = plain_int(table, "image", "width"), plain_int(table, "image", "height")
        size = (width, height) if width is not None and height is not None else None
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        write_example(directory, scene_bytes, files)
        outcome = run_cli(argv, directory)
        sources = ["scene.toml"] + (mesh_sources(table) if table is not None else [])
        check(outcome, directory, "out" + ext, size, sources, stats, must_render, f"{text}\n# files: {files!r}")


def texture_filters():
    return st.sampled_from(["trilinear", "nearest", "bilinear", "anisotropic"])


# --- the failures the suite has found, kept as explicit examples -------------------------------------

def small_scene(files=(), **changes):
    """SMALL_SCENE with `changes`: section=value replaces a table, section__key=value one key in it."""
    table = copy.deepcopy(SMALL_SCENE)
    for name, value in changes.items():
        section, _, key = name.partition("__")
        if key:
            table[section][key] = value
        else:
            table[section] = value
    return SceneExample(table, tuple(files))


DEGENERATE_FACE_MESH = TextFile("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\n")  # a note: 1 dropped
MESH_WITH_A_NOTE = small_scene([DEGENERATE_FACE_MESH], shapes=[
    *SMALL_SCENE["shapes"], {"type": "mesh", "file": "tri.obj", "material": "white"}])


def plain_command(*options):
    """`render scene.toml -o out.png` with these (option, value) pairs."""
    return CommandLine("scene.toml", "out.png", [(o, v, False) for o, v in options], ["--no-progress"])


# --- the tests -----------------------------------------------------------------------------------------

@budget(60)
@given(table=st.one_of(valid_scenes().map(lambda e: e.table), hostile_scenes().map(lambda e: e.table)))
def test_toml_writer_round_trips(table):
    """Our writer's text reads back (tomllib) as the table written, NaN, infinities and 1e39 included."""
    assert same_tables(tomllib.loads(to_toml(table)), table)


@budget(40)
@given(texture_filter=texture_filters(), example=valid_scenes())
def test_valid_scenes_render(texture_filter, example):
    """Scenes of the grammar with valid values render: exit status 0 and a finite image of their size."""
    fuzz_scene(example.text().encode(), example.files, example.table, True, texture_filter)


@budget(300)
@given(example=hostile_scenes())
@example(example=small_scene(camera__position=[2**64, -3.0, 1.0]))  # a TypeError in np.isfinite
@example(example=small_scene(camera__up=[0.0, 0.0, 1e-300]))  # numpy warnings, a NaN camera, a black image
@example(example=small_scene(camera__fov=math.nan, camera__up=[0.0, 0.0, 5e-324]))  # warnings and the error
@example(example=small_scene(camera={**SMALL_SCENE["camera"], "a\nb": 1}))  # a key's newline: two lines
@example(example=small_scene(materials={"a\nb": {"colour": [1.0, -1.0, 0.0]}}))
def test_hostile_scene_files(example):
    """Valid scenes with hostile values: an image, or one line naming the scene file (or its mesh file)."""
    fuzz_scene(example.text().encode(), example.files, example.table)


@budget(60)
@given(scene=broken_scene_texts())
@example(scene=(DamagedText("nested arrays", small_scene().text().encode(), 1000, b""), ()))  # RecursionError
def test_broken_scene_texts(scene):
    """Scene files that are not TOML tables at all: one line naming the scene file."""
    damaged, files = scene
    fuzz_scene(damaged.data(), files, None)


@budget(200)
@given(texture_filter=texture_filters(), example=scenes_with_hostile_files())
def test_hostile_texture_and_mesh_files(texture_filter, example):
    """Textures and meshes with random, truncated, damaged or odd contents: an image, or one line naming
    the scene file (textures) or the mesh file."""
    fuzz_scene(example.text().encode(), example.files, example.table, False, texture_filter)


@budget(250)
@given(command=command_lines(), example=valid_scenes(max_shapes=1))  # the command first: see hostile_scenes
@example(command=plain_command(("--seed", "4294967295")), example=small_scene())  # OpenImageIO's bad_cast
@example(command=plain_command(("--device", "0:0:0")), example=small_scene())  # a ValueError unpacking P:D
@example(command=dataclasses.replace(plain_command(), scene="a\nb.toml"), example=small_scene())  # two lines
@example(command=plain_command(("--spp", "5")), example=MESH_WITH_A_NOTE)  # the mesh's note, then the error
def test_hostile_command_lines(command, example):
    """render's options with hostile values and odd output names: an image of the size asked for, or one line
    naming the command line (or the scene file, when the scene argument names no readable scene)."""
    table = example.table
    width = parsed_int(command.value("--width")) if command.value("--width") is not None \
        else table["image"]["width"]
    height = parsed_int(command.value("--height")) if command.value("--height") is not None \
        else table["image"]["height"]
    spp = parsed_int(command.value("--spp")) or table.get("render", {}).get("spp", 1)
    ls = parsed_int(command.value("--light-samples")) or table.get("render", {}).get("light_samples", 1)
    if None not in (width, height) and 0 < width <= 16384 and 0 < height <= 16384 and 0 < spp <= 65536 \
            and 0 < ls <= 65536:
        time_limit_given = command.value("--time-limit") is not None
        assume(width * height <= 1 << 18 and (time_limit_given or width * height * spp * (1 + ls * 2) <= 5e7))
    argv = command.argv()
    note(f"scene.toml:\n{example.text()}")
    note(f"files: {example.files!r}"[:3000])
    note(f"argv: {argv}")
    stats = next((f.split("=", 1)[1] for f in reversed(command.flags) if f.startswith("--stats-json=")), None)
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        write_example(directory, example.text().encode(), example.files)
        (directory / "sub").mkdir()
        (directory / "taken.png").mkdir()
        (directory / "taken.exr").mkdir()
        outcome = run_cli(argv, directory)
        sources = ["command line", command.scene, str(Path(command.scene))] + mesh_sources(table, command.scene)
        check(outcome, directory, command.output, (width, height) if None not in (width, height) else None,
              sources, stats or None, example_text=example.text())


def outside(directory, outcome, env):
    """The outcome without the new files under POCL_CACHE_DIR, where PoCL was asked to keep its cache."""
    cache = env.get("POCL_CACHE_DIR")
    if cache:
        cache = os.path.relpath(os.path.abspath(os.path.join(directory, cache)), directory)
        outcome.new_files = {f for f in outcome.new_files if not f.startswith(cache + os.sep)}
    return outcome


@budget(40)
@given(env=environments(ENVIRONMENT_VALUES))
def test_hostile_environment(env):
    """RAYTRACE_LANES, RAYTRACE_TARGET and POCL_CACHE_DIR: an image, or one line naming the environment. One
    small scene, as each target and lane width builds the kernel anew."""
    note(f"environment: {env!r}")
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        (directory / "scene.toml").write_text(to_toml(SMALL_SCENE))
        outcome = run_cli(["render", "scene.toml", "-o", "out.exr", "--no-progress"], directory, env)
        check(outside(directory, outcome, env), directory, "out.exr", (4, 3), ["environment"])


@budget(6)
@given(env=environments(LOADER_VALUES))
def test_hostile_environment_in_a_child(env):
    """The variables the OpenCL loader and PoCL read once per process, in a child `python -m raytrace render`:
    an image, or one line naming the environment."""
    note(f"environment: {env!r}")
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        (directory / "scene.toml").write_text(to_toml(SMALL_SCENE))
        argv = ["render", "scene.toml", "-o", "out.png", "--no-progress"]
        r = subprocess.run([sys.executable, "-m", "raytrace", *argv], cwd=directory, capture_output=True,
                           env={**os.environ, "PYTHONPATH": str(ROOT), **env}, timeout=EXAMPLE_SECONDS)
        new = files_in(directory) - {"scene.toml"}
        outcome = Outcome(argv, r.returncode, r.stderr.decode("utf-8", "backslashreplace"), None, new)
        check(outside(directory, outcome, env), directory, "out.png", (4, 3), ["environment"])
