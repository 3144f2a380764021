"""Reading OBJ and PLY (raytrace.meshes): polygons triangulated, each face corner keeping the position,
uv and normal the file gives it, degenerate faces dropped and counted, bad files refused with an
InputError that names the file; and area-weighted vertex normals."""
import math
import struct

import numpy as np
import pytest

import raytrace
from raytrace.errors import InputError
from raytrace.scene.mesh_file import load_mesh
from raytrace.scene import meshes
from raytrace.scene.meshes import vertex_normals

# A small OBJ: a quad, a convex pentagon and a triangle (mixed sizes: trimesh's slow path), in two
# usemtl groups, with comments, a vertex used with two different uvs (a seam) and two degenerate faces.
POSITIONS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2.5, 0.7, 0), (2, 1.2, 0), (0, 0, 1)]
UVS = [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.25), (0.75, 0.5)]
NORMALS = [(0, 0, 1), (0, -1, 0)]
FACES = [  # (v, vt, vn) per corner, 1-based as in the file
    [(1, 1, 1), (2, 2, 1), (3, 3, 1), (4, 4, 1)],
    [(2, 2, 1), (5, 5, 1), (6, 6, 1), (7, 3, 1), (3, 3, 1)],
    [(1, 5, 2), (2, 6, 2), (8, 4, 2)],
]
DEGENERATE = [[(1, 1, 1), (2, 2, 1), (1, 1, 1)], [(1, 1, 1), (2, 2, 1), (5, 5, 1)]]  # repeated; collinear


def obj_text(faces):
    lines = ["# exported by hand", "mtllib missing.mtl", "o thing"]
    lines += [f"v {x} {y} {z}" for x, y, z in POSITIONS] + ["# texture coordinates"]
    lines += [f"vt {u} {v}" for u, v in UVS] + [f"vn {x} {y} {z}" for x, y, z in NORMALS]
    for k, face in enumerate(faces):
        lines += ["usemtl a" if k == 0 else "usemtl b" if k == 2 else "# next face"]
        lines.append("f " + " ".join("/".join(map(str, corner)) for corner in face))
    return "\n".join(lines) + "\n"


def corners_of(mesh):
    """The mesh's triangles as sorted tuples of (position, uv, normal) corners, each triangle rotated to
    start at its smallest corner (rotation keeps the winding), so vertex numbering and face order do
    not matter but attributes, triangles and windings do."""
    def attributes(i):
        parts = [mesh.vertices[i]] + [a[i] for a in (mesh.uvs, mesh.normals) if a is not None]
        return tuple(np.round(np.concatenate(parts), 6).tolist())
    triangles = []
    for face in mesh.faces:
        c = [attributes(i) for i in face]
        k = c.index(min(c))
        triangles.append(tuple(c[k:] + c[:k]))
    return sorted(triangles)


def expected_corners(faces, with_uvs=True, with_normals=True):
    """The same, from 1-based (v, vt, vn) faces, fan-triangulated from each face's first corner."""
    def attributes(v, t, n):
        parts = [POSITIONS[v - 1]] + ([UVS[t - 1]] if with_uvs else []) + ([NORMALS[n - 1]] if with_normals else [])
        return tuple(np.round(np.concatenate(parts).astype(float), 6).tolist())
    triangles = []
    for face in faces:
        for i in range(1, len(face) - 1):
            c = [attributes(*face[j]) for j in (0, i, i + 1)]
            k = c.index(min(c))
            triangles.append(tuple(c[k:] + c[:k]))
    return sorted(triangles)


def test_obj_polygons_seams_and_degenerates(tmp_path):
    """2 + 3 + 1 triangles from a quad, a pentagon and a triangle, two degenerate faces dropped, and every
    corner with the uv and normal of its own v/vt/vn triple: merged vertices would lose the seam
    vertex's second uv, trimesh.load would recompute the normals (making them all +z here, not the
    -y of the third face), and a wrong fan or winding changes the corner tuples."""
    path = tmp_path / "thing.obj"
    path.write_text(obj_text(FACES + DEGENERATE))
    mesh, dropped = load_mesh(path)
    assert (len(mesh.faces), dropped) == (6, 2)
    assert corners_of(mesh) == expected_corners(FACES)


def test_degenerate_is_relative_to_the_triangle_size(tmp_path):
    """Degenerate means twice the area at most 1e-9 of the longest edge squared (meshes.DEGENERATE), not an
    area of 0: a sliver 10^6 long and 10^-4 thick (ratio 1e-10) and one 1 long and 10^-12 thick are dropped,
    a well-shaped triangle of side 10^-6 (ratio 0.5) is kept."""
    path = tmp_path / "scales.obj"
    path.write_text("v 0 0 0\nv 1e6 0 0\nv 5e5 1e-4 0\nv 0 0 1\nv 1e-6 0 1\nv 0 1e-6 1\n"
                    "v 0 0 2\nv 1 0 2\nv 0.5 1e-12 2\nf 1 2 3\nf 4 5 6\nf 7 8 9\n")
    mesh, dropped = load_mesh(path)
    assert dropped == 2 and mesh.faces.tolist() == [[3, 4, 5]]


def test_obj_all_quads(tmp_path):
    """Faces of one size take trimesh's vectorised path, which leaves quads as quads: we fan them."""
    quads = [FACES[0], [(2, 2, 1), (5, 5, 1), (7, 3, 1), (3, 3, 1)]]
    path = tmp_path / "quads.obj"
    path.write_text(obj_text(quads))
    mesh, dropped = load_mesh(path)
    assert (len(mesh.faces), dropped) == (4, 0)
    assert corners_of(mesh) == expected_corners(quads)


def test_obj_without_uvs_or_normals_and_relative_indices(tmp_path):
    """Plain `f v v v` faces give no uvs and no normals (None, not zeros); negative indices count back
    from the vertices read so far, which trimesh gets right when all vertices come first."""
    path = tmp_path / "plain.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf -4 -3 -1\n")
    mesh, dropped = load_mesh(path)
    assert mesh.uvs is None and mesh.normals is None and dropped == 0
    assert sorted(map(tuple, mesh.vertices[mesh.faces].reshape(-1, 9).tolist())) == \
        sorted([(0, 0, 0, 0, 1, 0, 1, 0, 0), (0, 0, 0, 1, 0, 0, 0, 0, 1)])


PLY_HEADER = """ply
format {format} 1.0
comment two vertices share a position with different uvs; vertex 6 is unused
element vertex 7
property {real} x
property {real} y
property {real} z
property float nx
property float ny
property float nz
property float {u}
property float {v}
element face 3
property list uchar int vertex_indices
end_header
"""
PLY_VERTICES = [(0, 0, 0, 0, 0, 1, 0, 0), (1, 0, 0, 0, 0, 1, 1, 0), (1, 1, 0, 0, 0, 1, 1, 1),
                (0, 1, 0, 0, 0, 1, 0, 1), (1, 1, 0, 0, 0, 1, 0.5, 0.5), (2, 0.5, 0, 0.6, 0, 0.8, 0.25, 0.75),
                (5, 5, 5, 1, 0, 0, 0, 0)]
PLY_FACES = [[0, 1, 2, 3], [1, 5, 4], [0, 1, 0]]  # a quad, a triangle, a degenerate triangle


def check_ply(mesh, dropped):
    """The file's vertices in the file's order (no merging: vertices 2 and 4 share a position), with
    their normals and uvs, and 2 + 1 triangles with the file's winding, one dropped."""
    table = np.array(PLY_VERTICES)
    np.testing.assert_array_equal(mesh.vertices, table[:, :3])
    np.testing.assert_allclose(mesh.normals, table[:, 3:6], atol=1e-7)
    np.testing.assert_array_equal(mesh.uvs, table[:, 6:].astype(np.float32))
    assert dropped == 1
    assert sorted(tuple(np.roll(f, -np.argmin(f)).tolist()) for f in mesh.faces) == [(0, 1, 2), (0, 2, 3), (1, 5, 4)]


def test_ascii_ply(tmp_path):
    """texture_u / texture_v names, a quad beside a triangle, an unused vertex: trimesh's default
    texture fix would drop vertex 6 and leave 7 normals for 6 vertices; merging would join 2 and 4."""
    path = tmp_path / "ascii.ply"
    body = [" ".join(map(str, v)) for v in PLY_VERTICES] + [" ".join(map(str, [len(f)] + f)) for f in PLY_FACES]
    path.write_text(PLY_HEADER.format(format="ascii", real="float", u="texture_u", v="texture_v") + "\n".join(body))
    check_ply(*load_mesh(path))


def test_binary_ply(tmp_path):
    """Written here byte by byte (not by meshgen.write_ply): double positions, float normals and s, t
    uvs, faces of different sizes, so the face lists have no fixed record size."""
    path = tmp_path / "binary.ply"
    vertices = b"".join(struct.pack("<3d5f", *v) for v in PLY_VERTICES)
    faces = b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in PLY_FACES)
    header = PLY_HEADER.format(format="binary_little_endian", real="double", u="s", v="t")
    path.write_bytes(header.encode() + vertices + faces)
    check_ply(*load_mesh(path))


def test_unusable_file_normals_are_replaced(tmp_path):
    """A zero normal in the file (some exporters write them at creases) becomes the area-weighted
    normal; the others are the file's, normalised."""
    path = tmp_path / "zero.ply"
    vertices = [(0, 0, 0, 0, 0, 0), (1, 0, 0, 0, 0, 2), (0, 1, 0, 0, 0, 1)]
    header = PLY_HEADER.replace("element vertex 7", "element vertex 3").replace("element face 3", "element face 1")
    header = "\n".join(line for line in header.split("\n") if "{u}" not in line and "{v}" not in line)
    body = [" ".join(map(str, v)) for v in vertices] + ["3 0 1 2"]
    path.write_text(header.format(format="ascii", real="float") + "\n".join(body))
    mesh, _ = load_mesh(path)
    np.testing.assert_array_equal(mesh.normals, [[0, 0, 1]] * 3)
    tilted = tmp_path / "tilted.ply"  # not in z = 0: the replacement is the face's normal, not +z
    tilted.write_text(header.format(format="ascii", real="float") + "0 0 0 0 0 0\n1 0 0 0 0 2\n0 1 1 0 0 1\n3 0 1 2")
    np.testing.assert_allclose(load_mesh(tilted)[0].normals[0], [0, -0.5**0.5, 0.5**0.5], rtol=1e-15)


def test_vertex_normals_weight_by_area_and_position():
    """Position 0 is shared by a triangle of area 2 facing +z and one of area 1/2 facing -y (through a
    second vertex at the same position, as a uv seam would split it): the sum of the unnormalised face
    normals (lengths 4 and 1) gives (0, -1, 4) / sqrt(17) at both vertices; vertices of one face take
    its normal; a vertex without faces gets zero. Weighting by angle or by face would give other
    directions at position 0; summing by index would give +z and -y there."""
    vertices = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [1, 0, 0], [0, 0, 1], [9, 9, 9], [0, 0, 0]])
    normals = vertex_normals(vertices, np.array([[0, 1, 2], [6, 3, 4]]))
    np.testing.assert_allclose(normals[[0, 6]], [np.array([0, -1, 4]) / np.sqrt(17)] * 2, rtol=1e-15)
    np.testing.assert_array_equal(normals[1:6], [[0, 0, 1], [0, 0, 1], [0, -1, 0], [0, -1, 0], [0, 0, 0]])


V3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
PLY_ASCII = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
BAD_FILES = {
    "no_faces.obj": V3,
    "only_degenerate.obj": V3 + "v 2 0 0\nf 1 2 4\nf 1 1 2\n",
    "nan.obj": V3.replace("v 0 1 0", "v 0 nan 0") + "f 1 2 3\n",
    "index_out_of_range.obj": V3 + "f 1 2 4\n",
    "index_zero.obj": V3 + "f 0 1 2\n",
    "vt_out_of_range.obj": V3 + "vt 0 0\nf 1/1 2/2 3/1\n",
    "vn_out_of_range.obj": V3 + "vn 0 0 1\nf 1//1 2//1 3//2\n",
    "two_coordinates.obj": "v 0 0\nv 1 0\nv 0 1\nf 1 2 3\n",
    "relative_after_faces.obj": V3 + "f -3 -2 -1\n" + V3 + "f -3 -2 -1\n",
    "garbage.obj": bytes(range(256)) * 4,
    "no_faces.ply": PLY_ASCII.replace("element face 1\nproperty list uchar int vertex_indices\n", "") +
    "0 0 0\n1 0 0\n0 1 0\n",
    "inf.ply": PLY_ASCII + "0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n",
    "index_out_of_range.ply": PLY_ASCII + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
    "negative_index.ply": PLY_ASCII + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
    "garbage.ply": bytes(range(256)) * 4,
    "text.ply": "this is not a mesh\n",
    "truncated_binary.ply": PLY_ASCII.replace("ascii", "binary_little_endian").encode() + bytes(40),
    "truncated.ply": PLY_ASCII + "0 0 0\n1 0 0\n",
    "mesh.stl": V3 + "f 1 2 3\n",
}


@pytest.mark.parametrize("name", BAD_FILES)
def test_bad_files_name_the_file(tmp_path, name):
    """Each is refused by an InputError whose source is the file and whose text is one line (what the
    CLI prints before exiting with 2), never by another exception and never by a silently wrong mesh:
    index 0, references to missing vt/vn, and negative indices after more vertices are the cases that
    trimesh alone reads without complaint."""
    path = tmp_path / name
    content = BAD_FILES[name]
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(InputError) as info:
        load_mesh(path)
    assert info.value.source == str(path) and "\n" not in str(info.value)


def test_missing_file(tmp_path):
    """An OSError from reading becomes the same one-line InputError, not a traceback."""
    with pytest.raises(InputError) as info:
        load_mesh(tmp_path / "nope.obj")
    assert info.value.source == str(tmp_path / "nope.obj")


PLY_BINARY = PLY_ASCII.replace("ascii", "binary_little_endian").encode()
TRIANGLE = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2)
PLY_NORMALS = PLY_ASCII.replace("property float z\n", "property float z\nproperty float nx\nproperty float ny\n"
                                "property float nz\n")
PRECISE = {  # file: (content, what the one line must say)
    "far_beyond_float32.obj": (V3.replace("v 1 0 0", "v 1e39 0 0") + "f 1 2 3\n", ("line 2", "1e39", "float32")),
    "beyond_coordinate_limit.obj": (V3.replace("v 1 0 0", "v 1e20 0 0") + "f 1 2 3\n", ("line 2", "1e20", "1.153e+18")),
    "inf_normal.obj": (V3 + "vn 0 0 inf\nf 1//1 2//1 3//1\n", ("line 4", "inf is not a finite number")),
    "nan_uv.obj": (V3 + "vt NaN 0\nf 1/1 2/1 3/1\n", ("line 4", "NaN is not a finite number")),
    "huge_uv.obj": (V3 + "vt 0 1E+039\nf 1/1 2/1 3/1\n", ("line 4", "1E+039", "float32")),
    "missing_vertex.obj": (V3 + "f 1 2 3\nf 1 2 9\n", ("line 5", "vertex 9 does not exist", "3 vertices")),
    "not_a_number.obj": (V3.replace("v 1 0 0", "v 1 x 0") + "f 1 2 3\n", ("line 2", "'x' is not a number")),
    "double_beyond_float32.ply": (PLY_BINARY.replace(b"float", b"double") + struct.pack("<9d", 0, 0, 0, 1e39, 0, 0,
                                  0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2), ("vertices[1]", "1e+39", "float32")),
    "nan_normal.ply": (PLY_NORMALS + "0 0 0 0 0 1\n1 0 0 0 0 nan\n0 1 0 0 0 1\n3 0 1 2\n",
                       ("normals[1]", "not a finite number")),
    "header_cut.ply": (PLY_ASCII[:60], ("truncated", "end_header")),
    "body_cut.ply": (PLY_BINARY + TRIANGLE[:30], ("truncated", "at least 37 bytes", "30 bytes follow")),
    "absurd_count.ply": (PLY_ASCII.replace("vertex 3", "vertex 999999999999") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                         ("truncated", "element vertex 999999999999")),
    "absurd_binary_count.ply": (PLY_BINARY.replace(b"vertex 3", b"vertex 999999999999") + TRIANGLE,
                                ("truncated", "element vertex 999999999999")),
    "list_beyond_end.ply": (PLY_BINARY.replace(b"uchar int", b"uint int") + TRIANGLE[:36] +
                            struct.pack("<I3i", 4_000_000_000, 0, 1, 2), ("truncated", "element face")),
    "property_typo.ply": (PLY_ASCII.replace("property float y", "pr0perty float y") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                          ("vertex", "line 5 'pr0perty float y' was taken as a comment")),
    "unknown_format.ply": (PLY_ASCII.replace("ascii", "binary_middle_endian"), ("line 2", "must be 'format")),
}


@pytest.mark.parametrize("name", PRECISE)
def test_bad_files_say_what_is_wrong(tmp_path, capfd, name):
    """Hostile values and broken structure, each refused by one line that names the file and says where and
    what (the OBJ line, the PLY vertex, what the PLY header declares against what the file holds), and
    nothing else on fd 2. Before these checks, 1e39 made every face "degenerate", a cut-off PLY header was
    "a face refers to a vertex that does not exist", `element vertex 999999999999` was allocated, and an
    inf normal was silently replaced."""
    path = tmp_path / name
    content, words = PRECISE[name]
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(InputError) as info:
        load_mesh(path)
    message = str(info.value)
    assert info.value.source == str(path) and "\n" not in message
    assert all(w in message for w in words), message
    assert capfd.readouterr().err == ""


def test_angle_weighted_normals_are_mitsubas():
    """meshes.angle_weighted_normals against a plain loop (math.acos of each corner's angle, float64): a cube of
    8 shared corners, its quads split along different diagonals, has the corner normals (+-1, +-1, +-1) / sqrt(3)
    (each face meets a corner in 90 degrees, whichever way it is split), where area weights would not give them;
    a vertex that a file splits keeps its own faces' normal (per index, not per position)."""
    corners = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for k, (a, b, c, d) in enumerate(quads)
                      for t in (((a, b, c), (a, c, d)) if k % 2 else ((a, b, d), (b, c, d)))])
    normals = meshes.angle_weighted_normals(corners, faces)
    assert np.allclose(normals, corners / np.sqrt(3), rtol=0, atol=1e-15)

    rng = np.random.default_rng(7)
    vertices = rng.normal(size=(30, 3))
    faces = np.array([rng.choice(30, 3, replace=False) for _ in range(60)])
    expected = np.zeros_like(vertices)
    for face in faces:
        p = vertices[face]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n /= np.linalg.norm(n)
        for k in range(3):
            a, b = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
            expected[face[k]] += n * math.acos(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b))
    used = np.linalg.norm(expected, axis=1) > 0
    expected[used] /= np.linalg.norm(expected[used], axis=1, keepdims=True)
    assert np.allclose(meshes.angle_weighted_normals(vertices, faces), expected, rtol=0, atol=1e-12)

    split = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    n = meshes.angle_weighted_normals(split, np.array([[0, 1, 2], [3, 4, 5]]))
    assert np.allclose(n[0], [0, 0, 1]) and np.allclose(n[3], [1, 0, 0])


def test_vertex_normals_only_with_smooth(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    table = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40},
             "image": {"width": 4, "height": 4}, "materials": {"w": {"colour": [1, 1, 1]}},
             "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                         "colour": [1, 1, 1]}],
             "shapes": [{"type": "mesh", "file": str(tmp_path / "tri.obj"), "material": "w",
                         "vertex_normals": "angle"}]}
    with pytest.raises(InputError, match=r"shapes\[0\].vertex_normals = 'angle': only with smooth = true"):
        raytrace.load_dict(table)
    table["shapes"][0]["smooth"] = True
    assert np.allclose(raytrace.load_dict(table).meshes[0].mesh.normals, [[0, 0, 1]] * 3)
