"""The files a fuzz example writes beside its scene, and the strategies that make them: data classes that
each know how to write themselves into an example's directory, valid textures and meshes (OBJ, PLY) for
valid scenes, and hostile ones: damaged, truncated or odd images, lying OBJ and PLY files, directories."""
import dataclasses
import math
import os
import re
import struct
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from hypothesis import strategies as st

from . import ROOT

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


def finite(low, high):
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def vectors(n, low, high):
    return st.lists(finite(low, high), min_size=n, max_size=n)


# --- valid textures and meshes -------------------------------------------------------------------------

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


# Ways real programs write the same mesh (issue 43's dialects; tests/meshes/ holds one file of each): each a
# function of the file's text or bytes, applied to a valid file, which must still render.
OBJ_DIALECTS = {
    "crlf": lambda t: t.replace("\n", "\r\n"),
    "indented": lambda t: "".join(("\t" if k % 2 else "  ") + line for k, line in enumerate(t.splitlines(True))),
    "tabs": lambda t: t.replace(" ", "\t"),
    "trailing comments": lambda t: re.sub(r"(?<=\S)(\r?\n)", r" # note\1", t),
    "header": lambda t: "# exported\nmtllib scene.mtl\no mesh\ng part\nusemtl gold\ns 1\n" + t,
}
PLY_DIALECTS = {
    "byte-order mark": lambda b: b"\xef\xbb\xbf" + b,
    "ply with a space": lambda b: b.replace(b"ply\n", b"ply \n", 1),
    "format 1": lambda b: re.sub(rb"(format \w+) 1\.0", rb"\1 1", b, count=1),
    "keywordless comment": lambda b: re.sub(rb"(format [^\r\n]*\r?\n)", rb"\1Created by Blender3D 247\nobj_info scan\n",
                                            b, count=1),
    "crlf header": lambda b: b[:b.index(b"end_header")].replace(b"\n", b"\r\n") + b[b.index(b"end_header"):],
}


@st.composite
def valid_mesh_files(draw, name):
    """A valid mesh file, perhaps in one or two of the dialects real programs write."""
    if draw(st.booleans()):
        text = draw(valid_obj_texts())
        for dialect in draw(st.lists(st.sampled_from(sorted(OBJ_DIALECTS)), max_size=2, unique=True)):
            text = OBJ_DIALECTS[dialect](text)
        return TextFile(name + ".obj", text)
    jitter = draw(vectors(12, -0.05, 0.05))
    vertices = [[c + jitter[3 * i + k] for k, c in enumerate(v)] for i, v in enumerate(TETRAHEDRON)]
    normals = [[0.0, 0.0, 1.0]] * 4 if draw(st.booleans()) else None
    data = ply_bytes(vertices, TETRAHEDRON_FACES, draw(st.booleans()), normals)
    for dialect in draw(st.lists(st.sampled_from(sorted(PLY_DIALECTS)), max_size=2, unique=True)):
        data = PLY_DIALECTS[dialect](data)
    return BytesFile(name + ".ply", data)


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
