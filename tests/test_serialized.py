"""Mitsuba's .serialized meshes (raytrace/scene/serialized_file.py): files written here by a writer of our own (struct
and zlib, following the format's documentation in Mitsuba 3's src/shapes/serialized.cpp, independent of the reader
and of devtools/corpus_meshes.py's writer) read back exactly, every shape of a file by its shape_index; the
fixtures of tests/data/serialized/ (devtools/peers/mitsuba_serialized.py) read as Mitsuba 3.9.1 read them; the
XML's serialized shape and its face_normals; and every kind of bad file refused with one line naming the file,
the part and the value.

Tolerances. Positions, faces, uvs and colours are compared exactly: the reader widens float32 to float64 (exact) and
Mitsuba narrows float64 to float32, which astype(float32) repeats bit for bit. Normals: Mitsuba normalises the
file's in float32 (a squared norm, a reciprocal square root and a product: each component within a few float32
ulps, 2^-24 ~ 6e-8 each), raytrace in float64, so they agree within 4 ulps, 2.4e-7 (measured: 1.0e-7). Normals
Mitsuba computes (angle-weighted, in float32) against meshes.angle_weighted_normals in float64: each vertex sums at
most 8 faces' unit normals times their angles (arccos-like unit_angle, a few ulps each), then normalises:
within 2e-6 (measured: 9.7e-8 on the fixtures, 1.2e-7 on scenes/mitsuba/meshes/spheres.serialized).

Mutations tried on serialized_file.py, each failing this file (1 to 36 of its 55 tests): the v3 dictionary
read as uint64 offsets (fixtures v3_*, shape 1); uvs read after the colours (round trip with both); float64
chosen by 0x1000 (round trip, fixtures); the v4 name not skipped (every v4 file); `shape_index >= count` made
`>` (the out-of-range case: reads the dictionary as a shape); the one-byte-more limit dropped (the too-long
case passes); the end-of-stream (checksum) test dropped (the no-checksum case); the shape header's check
dropped (the other-version case); the offset bound dropped (the offset case: struct error, not an InputError).
"""
import struct
import zlib

import numpy as np
import pytest

import raytrace
from helpers import ROOT
from raytrace.errors import InputError
from raytrace.scene.mesh_file import load_mesh
from raytrace.scene.meshes import angle_weighted_normals
from raytrace.scene.serialized_file import read_serialized

FIXTURES = ROOT / "tests" / "data" / "serialized"
FIXTURE_SHAPES = {"v4_single": 2, "v4_double": 2, "v3_single": 2, "v3_double": 2}


def shape_bytes(version, flags, name, vertices, triangles, *arrays, fmt=None, trailer=b""):
    """One shape: the uncompressed header, then a zlib stream of the flags, name (v4), counts, the arrays (each
    value packed one by one) and the uint32 indices; `trailer` appended inside the stream."""
    fmt = fmt or ("d" if flags & 0x2000 else "f")
    body = struct.pack("<I", flags) + (name.encode() + b"\x00" if version == 4 else b"")
    body += struct.pack("<QQ", len(vertices), len(triangles))
    for array in (vertices, *arrays):
        body += b"".join(struct.pack(f"<{fmt}", float(x)) for row in array for x in row)
    body += b"".join(struct.pack("<I", i) for t in triangles for i in t) + trailer
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def file_bytes(version, shapes):
    """Shapes (shape_bytes), then each one's offset (uint64 in v4, uint32 in v3) and their count."""
    out, offsets = b"", []
    for shape in shapes:
        offsets.append(len(out))
        out += shape
    return out + b"".join(struct.pack("<Q" if version == 4 else "<I", o) for o in offsets) + struct.pack(
        "<I", len(shapes))


TETRA = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
TETRA_FACES = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]


def shape_data(k):
    """Shape k's own numbers (none exact in float32 but the tetrahedron's corners: the precision shows)."""
    rng = np.random.default_rng(k)
    vertices = np.array(TETRA) * (1.1 + k) + rng.normal(size=3) / 3
    return (vertices, TETRA_FACES, rng.normal(size=(4, 3)), rng.uniform(size=(4, 2)), rng.uniform(size=(4, 3)))


@pytest.mark.parametrize("version", [3, 4])
@pytest.mark.parametrize("double", [False, True])
@pytest.mark.parametrize("parts", [(), ("normals",), ("uvs",), ("colours",), ("normals", "uvs", "colours"),
                                   ("uvs", "colours")])
def test_written_shapes_read_back_exactly(version, double, parts):
    """Three shapes in one file, each read by its shape_index: positions, faces, normals, uvs and colours as written
    (float32 values as float32 rounds them), None where the file has none."""
    flags = (0x2000 if double else 0x1000) | sum(bit for part, bit in (("normals", 1), ("uvs", 2), ("colours", 8))
                                                 if part in parts)
    data = [shape_data(k) for k in range(3)]
    blob = file_bytes(version, [shape_bytes(version, flags, f"shape {k}", v, t, *[a for part, a in zip(
        ("normals", "uvs", "colours"), (n, uv, c)) if part in parts]) for k, (v, t, n, uv, c) in enumerate(data)])
    real = np.float64 if double else np.float32
    for k, (v, t, n, uv, c) in enumerate(data):
        vertices, faces, normals, uvs, attributes = read_serialized("x.serialized", blob, k)
        assert np.array_equal(vertices, v.astype(real)) and vertices.dtype == np.float64
        assert np.array_equal(faces, t)
        for part, got, want in (("normals", normals, n), ("uvs", uvs, uv),
                                ("colours", attributes.get("vertex_color"), c)):
            assert (got is None) if part not in parts else np.array_equal(got, want.astype(real))


def test_load_mesh_reads_a_serialized_file(tmp_path):
    """load_mesh dispatches by extension, passes shape_index, and checks as for OBJ and PLY (unit normals)."""
    v, t, n, _, c = shape_data(1)
    path = tmp_path / "two.SERIALIZED"
    path.write_bytes(file_bytes(4, [shape_bytes(4, 0x1000, "a", *shape_data(0)[:2]),
                                    shape_bytes(4, 0x1009, "b", v, t, n, c)]))
    mesh, dropped = load_mesh(path, shape_index=1)
    assert dropped == 0 and np.array_equal(mesh.vertices, v.astype(np.float32))
    assert np.allclose(mesh.normals, n / np.linalg.norm(n, axis=1, keepdims=True), rtol=0, atol=1e-7)
    assert np.array_equal(mesh.attributes["vertex_color"], c.astype(np.float32)) and mesh.uvs is None
    assert load_mesh(path)[0].normals is None


@pytest.mark.parametrize("name", sorted(FIXTURE_SHAPES))
def test_fixtures_read_as_mitsuba_reads_them(name):
    """Each shape of the fixtures as Mitsuba 3.9.1 read it: positions, faces and uvs equal, the file's normals, or
    where it has none Mitsuba's angle-weighted ones, within the tolerances the docstring argues."""
    expected = np.load(FIXTURES / f"{name}.npz")
    for k in range(FIXTURE_SHAPES[name]):
        mesh, dropped = load_mesh(FIXTURES / f"{name}.serialized", shape_index=k)
        assert dropped == 0
        assert np.array_equal(mesh.vertices.astype(np.float32), expected[f"{k}_positions"])
        assert np.array_equal(mesh.faces, expected[f"{k}_faces"])
        if f"{k}_uvs" in expected:
            assert np.array_equal(mesh.uvs.astype(np.float32), expected[f"{k}_uvs"])
        else:
            assert mesh.uvs is None
        if mesh.normals is not None:
            assert np.abs(mesh.normals - expected[f"{k}_normals"]).max() < 2.4e-7
        else:
            computed = angle_weighted_normals(mesh.vertices, mesh.faces)
            assert np.abs(computed - expected[f"{k}_normals"]).max() < 2e-6


XML = """<scene version="3.0.0">
    <sensor type="perspective"><transform name="to_world"><lookat origin="0, -5, 1" target="0, 0, 0" up="0, 0, 1"/>
    </transform><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
    <rfilter type="box"/></film></sensor>
    <emitter type="constant"/>
    <shape type="serialized"><string name="filename" value="{file}"/><integer name="shape_index" value="{index}"/>
        <boolean name="face_normals" value="{flat}"/></shape>
</scene>"""


@pytest.mark.parametrize("index", [0, 1])
@pytest.mark.parametrize("flat", ["true", "false"])
def test_xml_serialized_shape_follows_face_normals(tmp_path, index, flat):
    """The XML's serialized shape: face_normals = true renders flat; false, with the file's normals where it has
    them (shape 0 of v3_single), else with Mitsuba's angle-weighted normals (shape 1), as Mitsuba shades it."""
    xml = tmp_path / "scene.xml"
    xml.write_text(XML.format(file=FIXTURES / "v3_single.serialized", index=index, flat=flat))
    (shape,) = raytrace.load_file(xml).meshes
    expected = np.load(FIXTURES / "v3_single.npz")
    assert shape.smooth == (flat == "false")
    assert np.array_equal(shape.mesh.vertices.astype(np.float32), expected[f"{index}_positions"])
    if shape.smooth:
        assert np.abs(shape.mesh.normals - expected[f"{index}_normals"]).max() < 2e-6


def test_shape_index_only_with_a_serialized_file(tmp_path):
    """shape_index above 0 beside an OBJ file is refused, naming the scene file and the key."""
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = tmp_path / "s.toml"
    scene.write_text('[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\n'
                     '[image]\nwidth = 8\nheight = 8\n[[lights]]\ncenter = [0, 0, 3]\nsize = [1, 1]\n'
                     'normal = [0, 0, -1]\ntangent = [1, 0, 0]\ncolour = [1, 1, 1]\n'
                     '[materials.m]\ncolour = [0.5, 0.5, 0.5]\n'
                     '[[shapes]]\ntype = "mesh"\nfile = "m.obj"\nshape_index = 1\nmaterial = "m"\n')
    with pytest.raises(InputError, match=r"shapes\[0\]\.shape_index = 1: above 0 only with a \.serialized file"):
        raytrace.load_file(scene)


GOOD = shape_bytes(4, 0x1000, "good", TETRA, TETRA_FACES)
TWO = file_bytes(4, [GOOD, shape_bytes(4, 0x1000, "also", TETRA, TETRA_FACES)])
BODY = zlib.decompress(GOOD[4:])


def restream(body):
    return GOOD[:4] + zlib.compress(body)


def bad_index():
    return shape_bytes(4, 0x1000, "x", TETRA, [[0, 1, 4]])


def nan_vertex():
    return shape_bytes(4, 0x1000, "x", [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, float("nan"), 0.0]], [[0, 1, 2]])


BAD = {  # name: (file bytes, shape_index, what the line says)
    "empty": (b"", 0, r"file = 0: is cut off"),
    "truncated header": (GOOD[:3], 0, r"file = 3: is cut off"),
    "wrong id": (b"\x1d\x04" + GOOD[2:], 0, r"file format id = '0x041D': is not a Mitsuba \.serialized mesh"),
    "big endian": (b"\x04\x1c" + GOOD[2:], 0, r"file format id = '0x1C04'"),
    "bad version": (GOOD[:2] + b"\x05\x00" + GOOD[4:], 0, r"file version = 5: must be 3 or 4"),
    "corrupt zlib": (GOOD[:4] + b"\x78\x9c\xff\xff" + GOOD[8:], 0, r"shape 0: is not a valid zlib stream"),
    "truncated stream": (GOOD[:len(GOOD) // 2], 0, r"shape 0 = \d+: is cut off: its stream ends"),
    "truncated in header": (GOOD[:12], 0, r"shape 0 = \d+: is cut off: its stream ends inside the header"),
    "no checksum": (GOOD[:-4], 0, r"shape 0 = 121: is cut off: its stream ends \(or lacks its checksum\)"),
    "stream too long": (restream(BODY + b"\0"), 0, r"shape 0: holds more bytes than its counts .* need 121"),
    "counts too large": (restream(BODY[:9] + struct.pack("<Q", 2 ** 62) + BODY[17:]), 0,
                         r"shape 0 = 121: is cut off.*4611686018427387904 vertices"),
    "both precisions": (restream(struct.pack("<I", 0x3000) + BODY[4:]), 0,
                        r"shape 0 flags = '0x3000': set both single"),
    "no triangles": (restream(BODY[:17] + struct.pack("<Q", 0) + BODY[25:]), 0, r"triangle count = 0: the file"),
    "name without NUL": (restream(BODY[:4] + b"n" * 70000), 0, r"shape 0 name: runs past 65536 bytes"),
    "index out of range": (bad_index(), 0, r"faces\[0\] = \[0, 1, 4\]: indices must be in \[0, 3\]"),
    "NaN vertex": (nan_vertex(), 0, r"vertices\[2\] = \[0\.0, nan, 0\.0\]: nan is not a finite number"),
    "shape_index too large": (TWO, 2, r"shape_index = 2: is out of range: the file holds 2 shapes \(0 to 1\)"),
    "no dictionary": (GOOD[:6], 1, r"shape_index = 1: needs the end-of-file dictionary"),
    "count too large": (TWO[:-4] + struct.pack("<I", 1000), 1, r"shape count = 1000: is more than the file's"),
    "offset outside": (TWO[:-12] + struct.pack("<QI", 10 ** 6, 2), 1, r"shape 1 offset = 1000000: is outside"),
    "other version": (TWO[:len(GOOD) + 2] + b"\x03\x00" + TWO[len(GOOD) + 4:], 1,
                      r"shape 1 = \d+: starts a header of another version"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_files_are_one_line_errors(tmp_path, case):
    """Each bad file: one InputError, one line, naming the file, the part and the value; no partial mesh."""
    data, index, message = BAD[case]
    path = tmp_path / "bad.serialized"
    path.write_bytes(data)
    with pytest.raises(InputError, match=message) as e:
        load_mesh(path, shape_index=index)
    assert "\n" not in str(e.value) and str(e.value).startswith(str(path))
