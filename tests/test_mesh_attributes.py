"""Mitsuba's `mesh_attribute` texture (issue 58) and the mesh attributes Mitsuba 3.9.1's PLY reader makes
(raytrace/scene/ply_file.py's element_attributes and attribute_groups, ported from its find_other_fields): vertex
colours ("vertex_color") and face colours ("face_color") read from ASCII and binary files, r, g, b or red, green,
blue, floats as they are and integer codes over their largest code; the other properties grouped and named as
Mitsuba groups them ("vertex_<prefix>", "face_<prefix>", of one or three values), checked against a table read
from the real Mitsuba; a face attribute constant over its face, and each triangle of a fanned polygon carrying its
polygon's value through every reader's path and every face dropped on the way; the kernel's lookup (material.cl's
lookup_at) interpolating the values over the triangle hit, in the BVH's order of triangles, against a float64
interpolation at the same hit; and the rules: a material that reads an attribute a shape lacks, of a size its
parameter does not take, or with values that are not finite or below 0, or for a bump map or a principled weight,
is refused in one line.

The rendered check: a flat sheet facing the camera under a constant sky of radiance 1, diffuse with the attribute
as its reflectance, max_depth 2, one sample at each pixel's centre. Its radiance is the albedo rho times the
sky: the light sample and the BSDF sample are both cosine-distributed about the normal (path_tracing.cl samples a
constant environment so), each weighted 1/2 by MIS, and each unoccluded sample gives rho exactly, so the pixel is
rho at the hit, with no noise. Tolerance 1e-5: the interpolation's three float32 products and sums (about 6 U of
values below 1, U = 2^-24 ~ 6e-8), the barycentrics' own rounding at the hit (a few U relative, times the colour's
change across a triangle, below 1; none for a face attribute, whose three corners are equal), and the estimator's
products (rho L w / p with cosines that cancel to a few U): all below 1e-6; 1e-5 leaves room for the hit point's
error along the ray (ray.h's bound, ~1e-6 of the distance 3, moving the point by < 1e-5 of a triangle's width
0.4). Mutation-checked: the barycentrics swapped (b1 <-> b2 in lookup_at) fails by 0.2; the attribute table in
the scene's order instead of the BVH's (geometry.in_leaf_order leaving the attributes unsorted) fails at both lane
widths tested (the sheet's 32 triangles get a BVH at each). Mutations of this change, each confirmed to fail a
test here: a face attribute indexed as a vertex one (Mesh.corner_values) fails the rendered face colours;
fan_polygons keeping its grouping by size (no reordering to the file's order) and read_ply giving each polygon
one row (values not repeated over its triangles) fail test_fanned_polygons_keep_their_face_values;
kept_faces keeping every row fails it too, and _mesh_shape's attributes left unfiltered fails
test_faces_dropped_by_the_scenes_transform_take_their_values; attribute_groups without the extra field passed
over after a prefix met before, or without the rgba scheme's "_color", fails the grouping table; integer colours
taken as codes fails the face colours' test; rules' size check left out lets the alpha, rgba and normal map
cases through; geometry.triangle_soup packing an unread rgba attribute fails
test_an_unread_rgba_mesh_beside_a_reading_one.
"""
import struct

import numpy as np
import pytest

import raytrace
from helpers import at_lane_ends
from raytrace.scene.mesh_file import load_mesh
from raytrace.scene.ply_file import attribute_groups

N = 5  # vertices per side of the sheet


def sheet(n=N):
    """(vertices, colours, triangles) of a flat sheet over [-1, 1]^2 at z = 0, facing +z, colours varying in both
    directions (every channel distinct)."""
    xs, ys = np.meshgrid(np.linspace(-1.0, 1.0, n), np.linspace(-1.0, 1.0, n))
    x, y = xs.ravel(), ys.ravel()
    vertices = np.stack([x, y, np.zeros_like(x)], 1)
    colours = np.stack([0.1 + 0.4 * (x + 1), 0.2 + 0.3 * (y + 1), 0.9 - 0.2 * (x + 1) * (y + 1) / 2], 1)
    quads = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i) for j in range(n - 1)
             for i in range(n - 1)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return vertices, colours, triangles


def write_ply(path, vertices, colours, triangles, binary=False, names=("r", "g", "b"), kind="float"):
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
              f"element vertex {len(vertices)}", "property float x", "property float y", "property float z",
              *[f"property {kind} {name}" for name in names], f"element face {len(triangles)}",
              "property list uchar int vertex_indices", "end_header"]
    if binary:
        rows = np.zeros(len(vertices), [("p", "<f4", (3,)), ("c", "<f4" if kind == "float" else "u1", (3,))])
        rows["p"], rows["c"] = vertices, colours
        faces = np.zeros(len(triangles), [("n", "u1"), ("i", "<i4", (3,))])
        faces["n"], faces["i"] = 3, triangles
        path.write_bytes(("\n".join(header) + "\n").encode() + rows.tobytes() + faces.tobytes())
        return path
    fmt = (lambda c: f"{c:.9g}") if kind == "float" else (lambda c: str(int(c)))
    lines = header + [" ".join([*(f"{p:.9g}" for p in v), *(fmt(c) for c in col)])
                      for v, col in zip(vertices, colours)]
    path.write_text("\n".join(lines + ["3 " + " ".join(map(str, t)) for t in triangles]) + "\n")
    return path


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("names", [("r", "g", "b"), ("red", "green", "blue")])
def test_ply_vertex_colours_are_read(tmp_path, binary, names):
    """Float colours as they are (float32 in the file); 8-bit codes over 255."""
    vertices, colours, triangles = sheet()
    mesh, _ = load_mesh(write_ply(tmp_path / "f.ply", vertices, colours, triangles, binary, names))
    np.testing.assert_allclose(mesh.attributes["vertex_color"], colours.astype(np.float32), rtol=0, atol=1e-8)
    codes = np.round(colours * 255)
    mesh, _ = load_mesh(write_ply(tmp_path / "u.ply", vertices, codes, triangles, binary, names, kind="uchar"))
    np.testing.assert_allclose(mesh.attributes["vertex_color"], codes / 255, rtol=0, atol=1e-12)


def test_negative_colours_and_meshes_without_them(tmp_path):
    """A negative colour loads (no material may read it), and is refused where one reads it, naming the file's
    row; a file without colour properties has no attributes."""
    vertices, colours, triangles = sheet()
    colours[3, 1] = -0.25
    ply = write_ply(tmp_path / "neg.ply", vertices, colours, triangles)
    assert load_mesh(ply)[0].attributes["vertex_color"][3, 1] == -0.25
    with pytest.raises(raytrace.InputError) as e:
        raytrace.load_dict(scene(ply))
    assert e.value.key == "shapes[0].file" and "vertex_color[3] = " in str(e.value) and "below 0" in str(e.value)
    plain = tmp_path / "plain.ply"
    plain.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                     "3 0 1 2\n")
    assert load_mesh(plain)[0].attributes == {}


def scene(ply, reflectance=None, shape=None):
    return {"camera": {"position": [0.0, 0.0, 3.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0], "fov": 30.0,
                       "focal_length": 1.0},
            "image": {"width": 24, "height": 24}, "lights": [],
            "render": {"shading": "path", "max_depth": 2, "spp": 1, "sampler": "center"},
            "environment": {"type": "constant", "radiance": [1.0, 1.0, 1.0]},
            "materials": {"m": {"type": "diffuse", "reflectance": reflectance or {
                "type": "mesh_attribute", "name": "vertex_color"}}},
            "shapes": [shape or {"type": "mesh", "file": str(ply), "material": "m"}]}


def reference(width, height, fov, vertices, colours, triangles):
    """Float64: each pixel centre's ray from (0, 0, 3) down -z meets z = 0; the vertex colours interpolated over
    the triangle containing the point (NaN outside the sheet, or within 1e-6 of a triangle's edge)."""
    return corner_reference(width, height, fov, vertices, triangles, colours[triangles])


def corner_reference(width, height, fov, vertices, triangles, corners):
    """reference's image of values given at each triangle's corners (F, 3, 3)."""
    image = np.full((height, width, 3), np.nan)
    half = np.tan(np.radians(fov) / 2)
    for j in range(height):
        for i in range(width):
            x = (2 * (i + 0.5) / width - 1) * half * width / height * 3.0
            y = (1 - 2 * (j + 0.5) / height) * half * 3.0
            for (a, b, c), (c0, c1, c2) in zip(triangles, corners):
                p0, p1, p2 = vertices[a][:2], vertices[b][:2], vertices[c][:2]
                m = np.column_stack([p1 - p0, p2 - p0])
                b1, b2 = np.linalg.solve(m, np.array([x, y]) - p0)
                if b1 > 1e-6 and b2 > 1e-6 and 1 - b1 - b2 > 1e-6:
                    image[j, i] = (1 - b1 - b2) * c0 + b1 * c1 + b2 * c2
    return image


@at_lane_ends
def test_rendered_vertex_colours_are_interpolated(tmp_path, lanes):
    """The rendered sheet equals the float64 interpolation of its vertex colours at each pixel centre's hit (the
    module's docstring argues the tolerance), at every lane width (with a BVH, which reorders the triangles)."""
    vertices, colours, triangles = sheet()
    ply = write_ply(tmp_path / "sheet.ply", vertices, colours.astype(np.float32).astype(np.float64), triangles)
    image, _ = raytrace.render(raytrace.load_dict(scene(ply)), lanes=lanes)
    want = reference(24, 24, 30.0, vertices, colours.astype(np.float32).astype(np.float64), triangles)
    inside = ~np.isnan(want[..., 0])
    assert inside.sum() > 300
    np.testing.assert_allclose(image[inside], want[inside], rtol=0, atol=1e-5)


def test_refusals(tmp_path):
    """A mesh_attribute material on a rectangle, or on a mesh without the attribute: one line naming the key and
    the value."""
    vertices, colours, triangles = sheet()
    ply = write_ply(tmp_path / "sheet.ply", vertices, colours, triangles)
    plain = write_ply(tmp_path / "plain.ply", vertices, colours, triangles, names=("u", "v", "w"))
    rectangle = {"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [2.0, 2.0], "normal": [0.0, 0.0, 1.0],
                 "tangent": [1.0, 0.0, 0.0], "material": "m"}
    for shape, key in ((rectangle, "shapes[0].material"), ({"type": "mesh", "file": str(plain), "material": "m"},
                                                           "shapes[0].material")):
        with pytest.raises(raytrace.InputError) as e:
            raytrace.load_dict(scene(ply, shape=shape))
        assert e.value.key == key and e.value.value == "m" and "vertex_color" in str(e.value), str(e.value)
        assert "\n" not in str(e.value)


# -- face attributes and Mitsuba's other attributes ----------------------------------------------------------------

CODES = {"float": "f", "double": "d", "uchar": "B", "ushort": "H", "short": "h", "char": "b", "int": "i"}


def write_polygons(path, vertices, polygons, vertex=(), face=(), binary=False):
    """A PLY file of polygons of any sizes with extra properties: vertex and face are [(type, name, values)], one
    value per vertex or per polygon, written after x, y, z and after the index list."""
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {len(vertices)}",
              "property float x", "property float y", "property float z", *[f"property {t} {n}" for t, n, _ in vertex],
              f"element face {len(polygons)}", "property list uchar int vertex_indices",
              *[f"property {t} {n}" for t, n, _ in face], "end_header"]
    text = lambda kind, x: f"{x:.9g}" if CODES[kind] in "fd" else str(int(x))  # noqa: E731
    pack = lambda kind, x: struct.pack("<" + CODES[kind], x if CODES[kind] in "fd" else int(x))  # noqa: E731
    if binary:
        body = b"".join(struct.pack("<3f", *v) + b"".join(pack(t, values[i]) for t, _, values in vertex)
                        for i, v in enumerate(vertices))
        body += b"".join(struct.pack(f"<B{len(p)}i", len(p), *p) + b"".join(pack(t, values[j]) for t, _, values in face)
                         for j, p in enumerate(polygons))
        path.write_bytes(("\n".join(header) + "\n").encode() + body)
        return path
    lines = [" ".join([*(f"{x:.9g}" for x in v), *(text(t, values[i]) for t, _, values in vertex)])
             for i, v in enumerate(vertices)]
    lines += [" ".join([str(len(p)), *map(str, p), *(text(t, values[j]) for t, _, values in face)])
              for j, p in enumerate(polygons)]
    path.write_text("\n".join(header + lines) + "\n")
    return path


def rgb_properties(kind, names, colours):
    return [(kind, name, colours[:, k]) for k, name in enumerate(names)]


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("names", [("r", "g", "b"), ("red", "green", "blue")])
def test_ply_face_colours_are_read(tmp_path, binary, names):
    """A face element's r, g, b (or red, green, blue) are "face_color", a row per triangle: float ones as the file
    holds them (float32), 8-bit codes over 255, as vertex colours (the tolerances: float32's values are exact in
    float64; code / 255 is one division, 1e-12 leaves its rounding)."""
    vertices, _, triangles = sheet()
    colours = np.random.default_rng(3).uniform(0.05, 0.95, (len(triangles), 3))
    mesh, _ = load_mesh(write_polygons(tmp_path / "f.ply", vertices, triangles,
                                       face=rgb_properties("float", names, colours), binary=binary))
    assert set(mesh.attributes) == {"face_color"}
    np.testing.assert_allclose(mesh.attributes["face_color"], colours.astype(np.float32), rtol=0, atol=1e-8)
    codes = np.round(colours * 255)
    mesh, _ = load_mesh(write_polygons(tmp_path / "u.ply", vertices, triangles,
                                       face=rgb_properties("uchar", names, codes), binary=binary))
    np.testing.assert_allclose(mesh.attributes["face_color"], codes / 255, rtol=0, atol=1e-12)


# Triangles, quads and a pentagon, one degenerate triangle (a repeated index) and one of two indices among them:
# each reader's path (ascii mixed sizes: trimesh's ragged lists; binary mixed: ours, record by record; binary
# quads only: trimesh's fixed-size records) must give each triangle its own polygon's value, in the file's order.
POLYGON_VERTICES = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0], [3, 0.5, 0]])
MIXED = [(0, 1, 2, 3), (1, 4, 5), (0, 0, 1), (1, 4, 6, 5, 2), (4, 6), (2, 5, 6)]
QUADS = [(0, 1, 2, 3), (1, 4, 5, 2), (4, 6, 5, 3)]


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("polygons", [MIXED, QUADS], ids=["mixed", "quads"])
def test_fanned_polygons_keep_their_face_values(tmp_path, binary, polygons):
    """Each triangle of a fanned polygon carries that polygon's face values (face_color from uchar codes, a 1-dim
    face_weight from weight_0), and the degenerate triangle dropped on load (mesh_file._checked) takes its row with
    it: every triangle's corners are its polygon's, found by the value it carries."""
    colours = np.arange(3 * len(polygons)).reshape(-1, 3) * 10 + 5
    weights = np.arange(len(polygons)) + 0.25
    ply = write_polygons(tmp_path / "p.ply", POLYGON_VERTICES, polygons, binary=binary,
                         face=[*rgb_properties("uchar", ("r", "g", "b"), colours), ("float", "weight_0", weights)])
    mesh, dropped = load_mesh(ply)
    assert dropped == (1 if polygons is MIXED else 0)
    fanned = [(p[0], p[i], p[i + 1]) for p in polygons for i in range(1, len(p) - 1) if len(set(p)) == len(p)]
    assert mesh.faces.tolist() == [list(t) for t in fanned]
    which = np.round(mesh.attributes["face_weight"][:, 0] - 0.25).astype(int)
    for triangle, polygon in zip(mesh.faces, which):
        assert set(triangle) <= set(polygons[polygon])
    np.testing.assert_array_equal(mesh.attributes["face_color"] * 255, colours[which].astype(np.float64))


def test_faces_dropped_by_the_scenes_transform_take_their_values(tmp_path):
    """A sliver that keeps its area in the file but loses it once moved to y = 1 and stored in float32
    (scene_file._transformed_faces drops it): the face attribute's rows follow the faces kept."""
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 2e-9, 0], [0, 1, 0]])
    ply = write_polygons(tmp_path / "s.ply", vertices, [(0, 1, 2), (0, 1, 3)],
                         face=rgb_properties("float", "rgb", np.array([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]])))
    assert load_mesh(ply)[1] == 0
    table = scene(ply, {"type": "mesh_attribute", "name": "face_color"},
                  {"type": "mesh", "file": str(ply), "material": "m", "translate": [0.0, 1.0, 0.0]})
    mesh = raytrace.load_dict(table).meshes[0].mesh
    assert mesh.faces.tolist() == [[0, 1, 3]]
    np.testing.assert_allclose(mesh.attributes["face_color"], [[0.4, 0.5, 0.6]], rtol=0, atol=1e-7)


# Header property lists and the attributes Mitsuba 3.9.1 makes of them ({name: properties}), each read from the
# real Mitsuba (mi.traverse of its ply shape) when this table was written; attribute_groups was also run against
# it on 4500 random lists of these names (names, sizes and values all agreed; integer values within 1e-5, Mitsuba's
# float32 sRGB decoding), but for files Mitsuba refuses for renaming two uv properties onto one.
GROUPS = [
    ("vertex", ["weight"], {}),  # no postfix: ignored
    ("vertex", ["weight_x"], {"vertex_weight": ["weight_x"]}),
    ("face", ["weight_1", "w_r", "uv_x", "uv_y", "c_1", "c_2", "c_3"],
     {"face_weight": ["weight_1"], "face_w_color": ["w_r"], "face_c": ["c_1", "c_2", "c_3"]}),  # uv: 2 values
    ("vertex", ["r", "g", "b", "alpha", "nx", "ny", "nz", "k_0", "k_1", "k_2"],
     {"vertex_color": ["r", "g", "b"], "vertex_k": ["k_0", "k_1", "k_2"]}),  # alpha goes with red, green, blue only
    ("face", ["red", "green", "blue", "alpha"], {"face_color": ["red", "green", "blue", "alpha"]}),
    ("vertex", ["c_r", "c_g", "c_b", "q_x", "q_y", "q_z", "q_w", "t_0"],
     {"vertex_c_color": ["c_r", "c_g", "c_b"], "vertex_t": ["t_0"]}),  # q: 4 values
    ("vertex", ["a_x", "b_x"], {"vertex_a": ["a_x"], "vertex_b": ["b_x"]}),
    ("vertex", ["my_attr_x", "my_attr_y", "my_attr_z"], {"vertex_my_attr": ["my_attr_x", "my_attr_y", "my_attr_z"]}),
    ("vertex", ["texture_u", "texture_v", "k_0"], {"vertex_k": ["k_0"]}),
    ("vertex", ["a_xx", "b_0"], {"vertex_b": ["b_0"]}),
    # Mitsuba's slips: after a_z out of sequence, b_0 is passed over and c_0 counted as a second value (dropped);
    # after a_y (a prefix met before), c_0 is passed over
    ("vertex", ["a_x", "a_z", "a_y", "b_0", "c_0"], {}),
    ("vertex", ["a_x", "b_0", "a_y", "c_0", "d_0"], {"vertex_a": ["a_x"], "vertex_b": ["b_0"], "vertex_d": ["d_0"]}),
]


@pytest.mark.parametrize("element, names, want", GROUPS)
def test_attributes_are_grouped_as_mitsuba_groups_them(element, names, want):
    assert dict(attribute_groups(element, [["float", name] for name in names])) == want


def test_attribute_values_and_the_files_mitsuba_refuses(tmp_path):
    """A generic attribute's values: floats as they are; uchar codes as they are and other integer types sRGB-
    decoded from code / largest code, as Mitsuba reads them (its values for codes 1, 11, 21 of ushort, measured,
    to 1e-5: its float32 decoding); integer colours code / largest code (our choice). And the two files Mitsuba's
    reader refuses over attributes: two groups named vertex_color, and a group whose slip names a property the
    file lacks (a_x, a_y, a_z after the slip of the first table)."""
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    codes = np.array([1, 11, 21])
    ply = write_polygons(tmp_path / "v.ply", vertices, [(0, 1, 2)], vertex=[
        ("uchar", "k_0", codes), ("ushort", "m_0", codes), ("double", "d_0", codes / 7), ("ushort", "c_r", codes)],
                         binary=True)
    attributes = load_mesh(ply)[0].attributes
    np.testing.assert_array_equal(attributes["vertex_k"][:, 0], codes)
    np.testing.assert_allclose(attributes["vertex_m"][:, 0], [1.1810388969e-06, 1.2991426956e-05, 2.4801815016e-05],
                               rtol=1e-5)
    np.testing.assert_array_equal(attributes["vertex_d"][:, 0], codes / 7)
    np.testing.assert_allclose(attributes["vertex_c_color"][:, 0], codes / 65535, rtol=1e-15)
    for names, key in ((["r", "g", "b", "color_x"], "vertex_color"), (["p_x", "p_z", "q_0", "a_x", "a_z"], "vertex_a")):
        ply = write_polygons(tmp_path / "bad.ply", vertices, [(0, 1, 2)],
                             vertex=[("float", name, [0.5] * 3) for name in names])
        with pytest.raises(raytrace.InputError) as e:
            load_mesh(ply)
        assert e.value.key == "vertex" and e.value.value == key and "Mitsuba" in str(e.value), str(e.value)


def quad_sheet(n=N):
    """(vertices, quads) of sheet()'s grid, each square one quad."""
    vertices, _, _ = sheet(n)
    return vertices, [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i) for j in range(n - 1)
                      for i in range(n - 1)]


@at_lane_ends
@pytest.mark.parametrize("kind", ["face_color", "vertex_weight"])
def test_rendered_face_colours_and_one_value_attributes(tmp_path, lanes, kind):
    """The rendered sheet (the module's docstring argues the tolerance) against float64 values: a quad sheet's
    face colours, each fanned quad's two triangles one colour, constant over them; a one-value vertex attribute
    (weight_x) as a reflectance, the same value in all three channels (Mitsuba's eval broadcasts it)."""
    vertices, quads = quad_sheet()
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    rng = np.random.default_rng(7)
    if kind == "face_color":
        colours = rng.uniform(0.05, 0.95, (len(quads), 3)).astype(np.float32).astype(np.float64)
        ply = write_polygons(tmp_path / "q.ply", vertices, quads, face=rgb_properties("float", "rgb", colours),
                             binary=True)
        corners = np.repeat(np.repeat(colours, 2, axis=0)[:, None], 3, axis=1)
    else:
        weights = rng.uniform(0.05, 0.95, len(vertices)).astype(np.float32).astype(np.float64)
        ply = write_polygons(tmp_path / "w.ply", vertices, quads, vertex=[("float", "weight_x", weights)],
                             binary=True)
        corners = np.repeat(weights[triangles][..., None], 3, axis=2)
    image, _ = raytrace.render(raytrace.load_dict(scene(ply, {"type": "mesh_attribute", "name": kind})), lanes=lanes)
    want = corner_reference(24, 24, 30.0, vertices, triangles, corners)
    inside = ~np.isnan(want[..., 0])
    assert inside.sum() > 300
    np.testing.assert_allclose(image[inside], want[inside], rtol=0, atol=1e-5)


def test_attribute_refusals(tmp_path):
    """What a material cannot read from a mesh, each one line naming the key and the value: a name Mitsuba's
    meshes never have; a bump map's or a principled weight's attribute; an attribute of a size the parameter does
    not take (three values for a roughness, an rgba colour's four for a reflectance, one for a normal map); values
    that are not finite or below 0, where a material reads them (the file's row named)."""
    vertices, quads = quad_sheet()
    weights, colours = np.linspace(0.1, 0.9, len(vertices)), np.full((len(vertices), 3), 0.5)
    ply = write_polygons(tmp_path / "a.ply", vertices, quads, vertex=[
        ("float", "weight_x", weights), *rgb_properties("float", ("red", "green", "blue", "alpha"), np.hstack(
            [colours, colours[:, :1]])), ("float", "bad_0", np.where(np.arange(len(vertices)) == 4, np.nan, 0.5)),
        ("float", "low_0", np.where(np.arange(len(vertices)) == 6, -0.25, 0.5))])
    attribute = lambda name: {"type": "mesh_attribute", "name": name}  # noqa: E731
    cases = [({"type": "diffuse", "reflectance": attribute("weight_x")}, "materials.m.reflectance.name", "weight_x",
              "must start with"),
             ({"type": "diffuse", "bumpmap": attribute("vertex_weight")}, "materials.m.bumpmap.type", "mesh_attribute",
              "gradient"),
             ({"type": "principled", "roughness": attribute("vertex_weight")}, "materials.m.roughness.type",
              "mesh_attribute", "by (u, v) only"),
             ({"type": "roughconductor", "alpha": attribute("vertex_color")}, "shapes[0].material", "m",
              "of 4 values a vertex, for its alpha, which takes one value"),
             ({"type": "diffuse", "reflectance": attribute("vertex_color")}, "shapes[0].material", "m",
              "which takes one value or three"),
             ({"type": "diffuse", "reflectance": 0.5, "normalmap": attribute("vertex_weight")}, "shapes[0].material",
              "m", "which takes three values"),
             ({"type": "diffuse", "reflectance": attribute("vertex_bad")}, "shapes[0].file", str(ply),
              "vertex_bad[4] = [nan]: nan is not a finite number"),
             ({"type": "roughconductor", "alpha": attribute("vertex_low")}, "shapes[0].file", str(ply),
              "vertex_low[6] = [-0.25]: -0.25 is below 0")]
    for material, key, value, words in cases:
        table = scene(ply)
        table["materials"]["m"] = material
        with pytest.raises(raytrace.InputError) as e:
            raytrace.load_dict(table)
        assert (e.value.key, e.value.value) == (key, value) and words in str(e.value), str(e.value)
        assert "\n" not in str(e.value)


def test_an_unread_rgba_mesh_beside_a_reading_one(tmp_path):
    """A mesh whose vertex_color has four values (MeshLab writes red, green, blue, alpha) under a plain material,
    beside a mesh whose material reads vertex_color (three values): the scene renders, each mesh as its own,
    the rgba values unread (they once broke the attribute table's packing with a numpy error)."""
    vertices, quads = quad_sheet()
    colours = np.full((len(vertices), 3), 0.5)
    rgba = write_polygons(tmp_path / "rgba.ply", vertices, quads, vertex=rgb_properties(
        "float", ("red", "green", "blue", "alpha"), np.hstack([colours, colours[:, :1]])))
    rgb = write_polygons(tmp_path / "rgb.ply", vertices, quads, vertex=rgb_properties(
        "float", ("red", "green", "blue"), colours))
    table = scene(rgb)
    table["materials"]["plain"] = {"type": "diffuse", "reflectance": 0.25}
    table["shapes"].append({"type": "mesh", "file": str(rgba), "material": "plain", "translate": [0.0, 0.0, -1.0]})
    image, stats = raytrace.render(raytrace.load_dict(table), lanes=1)
    assert stats.extra["nonfinite_values"] == 0 and np.asarray(image).max() > 0.4

