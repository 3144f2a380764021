"""Mitsuba's `mesh_attribute` texture (issue 58): a PLY file's vertex colours (raytrace/scene/ply_file.py's
vertex_attributes, Mitsuba's "vertex_color") read from ASCII and binary files, r, g, b or red, green, blue, floats
as they are and integer codes over their largest code; the kernel's lookup (material.cl's lookup_at) interpolating
them over the triangle hit, in the BVH's order of triangles, against a float64 interpolation at the same hit; and
the rules: a material that reads the attribute on a shape without it, or for a parameter of one number, is refused
in one line.

The rendered check: a flat sheet facing the camera under a constant sky of radiance 1, diffuse with the vertex
colours as its reflectance, max_depth 2, one sample at each pixel's centre. Its radiance is the albedo rho times the
sky: the light sample and the BSDF sample are both cosine-distributed about the normal (path_tracing.cl samples a
constant environment so), each weighted 1/2 by MIS, and each unoccluded sample gives rho exactly, so the pixel is
rho at the hit, with no noise. Tolerance 1e-5: the interpolation's three float32 products and sums (about 6 U of
values below 1, U = 2^-24 ~ 6e-8), the barycentrics' own rounding at the hit (a few U relative, times the colour's
change across a triangle, below 1), and the estimator's products (rho L w / p with cosines that cancel to a few U):
all below 1e-6; 1e-5 leaves room for the hit point's error along the ray (ray.h's bound, ~1e-6 of the distance
3, moving the point by < 1e-5 of a triangle's width 0.4). Mutation-checked: the barycentrics swapped (b1 <-> b2 in
lookup_at) fails by 0.2; the attribute table in the scene's order instead of the BVH's (geometry.in_leaf_order
leaving the attributes unsorted) fails at both lane widths tested (the sheet's 32 triangles get a BVH at each).
"""
import numpy as np
import pytest

import raytrace
from helpers import at_lane_ends
from raytrace.scene.mesh_file import load_mesh

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
    vertices, colours, triangles = sheet()
    colours[3, 1] = -0.25
    with pytest.raises(raytrace.InputError) as e:
        load_mesh(write_ply(tmp_path / "neg.ply", vertices, colours, triangles))
    assert e.value.key == "vertex_color[3]" and "must be >= 0" in str(e.value)
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
    """Float64: each pixel centre's ray from (0, 0, 3) down -z meets z = 0; the colours interpolated over the
    triangle containing the point (NaN outside the sheet, or within 1e-6 of a triangle's edge)."""
    image = np.full((height, width, 3), np.nan)
    half = np.tan(np.radians(fov) / 2)
    for j in range(height):
        for i in range(width):
            x = (2 * (i + 0.5) / width - 1) * half * width / height * 3.0
            y = (1 - 2 * (j + 0.5) / height) * half * 3.0
            for a, b, c in triangles:
                p0, p1, p2 = vertices[a][:2], vertices[b][:2], vertices[c][:2]
                m = np.column_stack([p1 - p0, p2 - p0])
                b1, b2 = np.linalg.solve(m, np.array([x, y]) - p0)
                if b1 > 1e-6 and b2 > 1e-6 and 1 - b1 - b2 > 1e-6:
                    image[j, i] = (1 - b1 - b2) * colours[a] + b1 * colours[b] + b2 * colours[c]
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
    """A mesh_attribute material on a rectangle, on a mesh without the attribute, or for a float parameter:
    one line naming the key and the value."""
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
    table = scene(ply)
    table["materials"]["m"] = {"type": "roughconductor", "alpha": {"type": "mesh_attribute", "name": "vertex_color"}}
    with pytest.raises(raytrace.InputError) as e:
        raytrace.load_dict(table)
    assert e.value.key == "materials.m.alpha.name" and "three channels" in str(e.value)
