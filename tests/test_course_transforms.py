"""The transform keys (scale, rotate, translate, matrix) on the course's shapes and lights (keys.TRANSFORM,
scene_file.py, transform.py): a shape given with a transform is the same shape as one written out already
transformed, its errors are the mesh's, and an edit cannot bypass them.

Mutations tried, each failing this module (then undone):
- placed_rectangle's normal without sign(det L): the mirrored rectangles' normals turn (test_rectangles).
- placed_triangle without the reversed order under a mirror: the mirrored triangles' packed normals turn
  (test_triangles).
- placed_ellipsoid mapping the axes by axes @ L instead of axes @ L^T (test_ellipsoids).
- SHEAR_ROUNDINGS = 1e12 (every transform a rectangle's): test_shear_is_refused; SHEAR_ROUNDINGS = 0:
  test_rectangles and test_wide_condition_is_a_rectangle refuse exact rectangles.
- Placed.fail naming the geometry key, not the transform (test_placed_checks_name_the_transform).
- the lights' readers not Placed in parse_scene (test_placed_checks_name_the_transform, the light's row).
- no check_triangle of the placed triangle (test_placed_checks_name_the_transform, the flattened triangle).
- _placement ignoring the keys of a light (test_lights, test_render_matches_pretransformed).
"""
import numpy as np
import pytest

import raytrace
from raytrace.errors import InputError
from raytrace.renderer import geometry, packing
from raytrace.scene import load_dict
from raytrace.scene.transform import BARYCENTRIC_UV, mesh_matrix

CAMERA = {"position": [0.0, -4.0, 1.0], "look_at": [0.0, 0.0, 0.5], "up": [0.0, 0.0, 1.0], "fov": 50.0}
LIGHT = {"center": [0.0, 0.0, 2.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0], "tangent": [1.0, 0.0, 0.0],
         "colour": [1.0, 1.0, 1.0]}


def scene(shapes=(), lights=(LIGHT,)):
    return {"camera": dict(CAMERA), "image": {"width": 16, "height": 16}, "materials": {"white": {"colour": [0.7] * 3}},
            "lights": [dict(light) for light in lights], "shapes": [{**s, "material": "white"} for s in shapes]}


def rotation(rng):
    """A uniformly random rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.sign(np.linalg.det(q))


def magnitudes(rng, n, low=0.1, high=10.0):
    """n factors with random signs, log-uniform in [low, high]."""
    return np.exp(rng.uniform(np.log(low), np.log(high), n)) * rng.choice([-1.0, 1.0], n)


def homogeneous(m, points):
    """The points (rows) mapped by the 4 x 4 matrix m in homogeneous coordinates (another route than
    transform.py's L x + T)."""
    p = np.c_[np.atleast_2d(points), np.ones(len(np.atleast_2d(points)))] @ m.T
    return p[:, :3]


def keys_matrix(table):
    """The matrix of a table's transform keys, as docs/scene-format.md states them: scale, then rotate, then
    translate, or the matrix."""
    if "matrix" in table:
        return np.array(table["matrix"], np.float64)
    scale = np.broadcast_to(np.array(table.get("scale", 1.0), np.float64), 3)
    rot = table.get("rotate", {"axis": [0.0, 0.0, 1.0], "degrees": 0.0})
    return mesh_matrix(scale, rot["axis"], rot["degrees"], table.get("translate", [0.0, 0.0, 0.0]))


def same_structs(a, b):
    """Packed structs equal to one float32 spacing of each field's largest value.

    Both come from float64 values of the same shape computed by different routes (transform.py's, and this
    module's, written out and read back); with the factors here within [0.1, 10] (kappa <= 1e4 for the
    rectangles' matrices, <= 1e2 otherwise) those agree within 64 eps kappa of the field's largest value
    (the normal's route; 8 eps for the others): below 1e-10 of it, far below float32's spacing of 2^-24. Two
    such values round to the same float32, or to neighbours where a rounding boundary lies between them."""
    assert a.dtype == b.dtype
    for name in a.dtype.names:
        if a[name].dtype.names:  # a struct within (a light's rectangle)
            same_structs(a[name], b[name])
            continue
        x, y = np.asarray(a[name], np.float64), np.asarray(b[name], np.float64)
        if a[name].dtype.kind != "f":
            np.testing.assert_array_equal(x, y, err_msg=name)
            continue
        ulp = np.spacing(np.float32(np.abs(y).max(initial=0.0)))
        np.testing.assert_array_less(np.abs(x - y), ulp * 1.0001 + 1e-300, err_msg=name)


def random_rectangle(rng):
    normal = rng.normal(size=3)
    tangent = np.cross(normal, rng.normal(size=3))
    return {"type": "rectangle", "center": rng.normal(size=3).tolist(), "size": magnitudes(rng, 2, 0.5, 2).__abs__()
            .tolist(), "normal": normal.tolist(), "tangent": tangent.tolist()}


def rectangle_transforms(rng, shape):
    """Transforms that keep `shape` a rectangle: a matrix Q2 D Q1^T (Q1 the rectangle's frame, D any signed
    diagonal: its sides stretched and mirrored, then turned anywhere), and keys: a uniform scale (of either
    sign), a rotation, a translation."""
    n = np.array(shape["normal"]) / np.linalg.norm(shape["normal"])
    t = np.array(shape["tangent"]) - np.dot(shape["tangent"], n) * n
    t /= np.linalg.norm(t)
    frame = np.column_stack([t, np.cross(n, t), n])
    m = np.eye(4)
    m[:3, :3] = rotation(rng) @ np.diag(magnitudes(rng, 3)) @ frame.T
    m[:3, 3] = rng.normal(size=3) * 3
    yield {"matrix": m.tolist()}
    yield {"scale": float(magnitudes(rng, 1)[0]), "rotate": {"axis": rng.normal(size=3).tolist(),
           "degrees": float(rng.uniform(-360, 360))}, "translate": (rng.normal(size=3) * 3).tolist()}


def expected_rectangle(shape, m):
    """The rectangle written out already placed: centre and sides mapped, the normal by L's inverse
    transpose (not transform.py's cross product), the tangent along the first side."""
    n = np.array(shape["normal"]) / np.linalg.norm(shape["normal"])
    t = np.array(shape["tangent"]) - np.dot(shape["tangent"], n) * n
    t /= np.linalg.norm(t)
    linear = m[:3, :3]
    sides = linear @ np.column_stack([t * shape["size"][0], np.cross(n, t) * shape["size"][1]])
    normal = np.linalg.inv(linear).T @ n
    out = {k: v for k, v in shape.items() if k not in ("scale", "rotate", "translate", "matrix")}
    return {**out, "center": homogeneous(m, shape["center"])[0].tolist(),
            "size": np.linalg.norm(sides, axis=0).tolist(), "normal": (normal / np.linalg.norm(normal)).tolist(), "tangent": sides[:, 0].tolist()}


def test_rectangles():
    """Random rectangles under random transforms (a third of the matrices mirroring) load as the same
    rectangles written out already transformed (packed structs within a float32 spacing: same_structs)."""
    rng = np.random.default_rng(59)
    mirrored = 0
    for _ in range(40):
        shape = random_rectangle(rng)
        for transform in rectangle_transforms(rng, shape):
            placed = {**shape, **transform}
            m = keys_matrix(placed)
            mirrored += np.linalg.det(m[:3, :3]) < 0
            got = load_dict(scene([placed])).rectangles
            want = load_dict(scene([expected_rectangle(shape, m)])).rectangles
            same_structs(packing.rectangle_structs(got), packing.rectangle_structs(want))
    assert mirrored >= 10


def test_lights():
    """A light takes the same keys: its transformed rectangle and colour are those of the light written out
    already transformed, in the Phong model's table and in the direct model's."""
    rng = np.random.default_rng(60)
    for shading, emission in (("phong", "colour"), ("direct", "radiance")):
        for _ in range(10):
            light = {**random_rectangle(rng), emission: [1.0, 0.5, 0.25]}
            del light["type"]
            for transform in rectangle_transforms(rng, light):
                placed = {**light, **transform}
                want_light = expected_rectangle(light, keys_matrix(placed))
                got, want = (load_dict({**scene([], [lt]), "render": {"shading": shading}}).lights
                             for lt in (placed, want_light))
                same_structs(packing.light_structs(got), packing.light_structs(want))


def test_triangles():
    """Random triangles under random affine maps (shears and mirrors too: a triangle's image is one), with and
    without uv, load as the triangles written out already transformed: the corners ordered so that the
    image of the front is the front (the packed normal along L's inverse transpose of the original normal,
    checked apart), each corner with its uv: the packed triangle, uv and uv-frame structs match."""
    rng = np.random.default_rng(61)
    mirrored = 0
    for k in range(60):
        vertices = rng.normal(size=(3, 3))
        uv = rng.uniform(size=(3, 2)) if k % 2 else None
        shape = {"type": "triangle", "vertices": vertices.tolist(), **({"uv": uv.tolist()} if uv is not None else {})}
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = rng.normal(size=(3, 3)) + 2 * np.eye(3), rng.normal(size=3)
        transform = {"matrix": m.tolist()} if k % 3 else {"scale": magnitudes(rng, 3).tolist(), "rotate": {
            "axis": rng.normal(size=3).tolist(), "degrees": float(rng.uniform(-360, 360))}}
        m = keys_matrix(transform)
        mirrored += np.linalg.det(m[:3, :3]) < 0
        world = homogeneous(m, vertices)
        front = np.linalg.inv(m[:3, :3]).T @ np.cross(vertices[1] - vertices[0], vertices[2] - vertices[0])
        order = [0, 1, 2] if np.dot(np.cross(world[1] - world[0], world[2] - world[0]), front) > 0 else [0, 2, 1]
        want_uv = (BARYCENTRIC_UV if uv is None else uv)[order]
        got = load_dict(scene([{**shape, **transform}])).triangles
        written = {"type": "triangle", "vertices": world[order].tolist(), "uv": want_uv.tolist()}
        want = load_dict(scene([written])).triangles
        same_structs(packing.triangle_structs(got), packing.triangle_structs(want))
        same_structs(packing.triangle_uv_structs(got), packing.triangle_uv_structs(want))
        normal = packing.triangle_structs(got)["normal"][0]
        assert np.dot(normal, front) > 0
    assert mirrored >= 10
    np.testing.assert_array_equal(BARYCENTRIC_UV, geometry.DEFAULT_UV)


def test_ellipsoids():
    """Random ellipsoids under random affine maps load as the ellipsoids written out already transformed
    (centre mapped, axes a, b, c mapped by L: packed structs within a float32 spacing), and points of the
    original's surface, mapped, lie on the image's (|W (M p - c')| = 1 within 1e-12: float64 on values of
    magnitude <= 1e3 through matrices of condition <= 1e4)."""
    rng = np.random.default_rng(62)
    for k in range(40):
        axes, center = rng.normal(size=(3, 3)) + 2 * np.eye(3), rng.normal(size=3)
        shape = {"type": "ellipsoid", "center": center.tolist(), "axes": axes.tolist()}
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = rng.normal(size=(3, 3)) + 2 * np.eye(3) * rng.choice([-1, 1]), rng.normal(size=3)
        transform = {"matrix": m.tolist()} if k % 2 else {"scale": magnitudes(rng, 3).tolist(),
                                                          "translate": rng.normal(size=3).tolist()}
        m = keys_matrix(transform)
        want_axes = (m[:3, :3] @ axes.T).T
        got = load_dict(scene([{**shape, **transform}])).ellipsoids
        want = load_dict(scene([{"type": "ellipsoid", "center": homogeneous(m, center)[0].tolist(),
                                 "axes": want_axes.tolist()}])).ellipsoids
        same_structs(packing.ellipsoid_structs(got), packing.ellipsoid_structs(want))
        x = rng.normal(size=(50, 3))
        x /= np.linalg.norm(x, axis=1, keepdims=True)
        mapped = homogeneous(m, center + x @ axes)
        unit = (mapped - got[0].center) @ np.linalg.inv(got[0].matrix).T
        np.testing.assert_allclose(np.linalg.norm(unit, axis=1), 1.0, atol=1e-12)


def test_wide_condition_is_a_rectangle():
    """A rectangle scaled 1e4 along one side and 1e-4 along the other (kappa 1e8), then turned, is still a
    rectangle: float64's rounding of its sides' cosine stays under 64 eps kappa (1.4e-6)."""
    rng = np.random.default_rng(63)
    for _ in range(20):
        angle = {"axis": rng.normal(size=3).tolist(), "degrees": float(rng.uniform(0, 360))}
        rect = {"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [1.0, 1.0], "normal": [0.0, 0.0, 1.0],
                "tangent": [1.0, 0.0, 0.0], "scale": [1e4, 1e-4, 1.0], "rotate": angle}
        r = load_dict(scene([rect])).rectangles[0]
        np.testing.assert_allclose(r.size, [1e4, 1e-4], rtol=1e-14)
        assert abs(np.dot(r.normal, r.tangent)) < 1e-15


def shape_tables():
    """One table of each course shape, and a light, as (place, table)."""
    return [("shapes", {"type": "rectangle", "center": [0, 0, 0], "size": [1, 1], "normal": [0, 0, 1],
                        "tangent": [1, 0, 0]}),
            ("shapes", {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}),
            ("shapes", {"type": "ellipsoid", "center": [0, 0, 0], "axes": [[1, 0, 0], [0.5, 1, 0], [0, 0, 1]]}),
            ("lights", dict(LIGHT))]


def load_with(place, table):
    t = scene([table]) if place == "shapes" else scene([], [table])
    return load_dict(t)


BAD = [  # (the transform keys, the key the error names, a word of its problem)
    ({"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]}, "matrix", "invertible"),
    ({"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]}, "matrix", "last row"),
    ({"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}, "matrix", "4 vectors"),
    ({"matrix": [[1, 0, 0, float("nan")], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "matrix", "finite"),
    ({"matrix": [[1, 0, 0, float("inf")], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "matrix", "finite"),
    ({"matrix": np.eye(4).tolist(), "scale": 2.0}, "scale", "either matrix"),
    ({"matrix": np.eye(4).tolist(), "translate": [1, 0, 0]}, "translate", "either matrix"),
    ({"scale": 0.0}, "scale", "must not be 0"),
    ({"scale": [1.0, float("nan"), 1.0]}, "scale", "finite"),
    ({"scale": 1e39}, "scale", "float32"),
    ({"translate": [0, float("inf"), 0]}, "translate", "finite"),
    ({"rotate": {"axis": [0, 0, 0], "degrees": 30}}, "rotate.axis", "zero vector"),
    ({"rotate": {"axis": [0, 0, 1], "degrees": float("nan")}}, "rotate.degrees", "finite"),
    ({"rotate": {"axis": [0, 0, 1]}}, "rotate.degrees", "missing"),
    ({"rotate": {"axis": [0, 0, 1], "degrees": 3, "angle": 3}}, "rotate.angle", "unknown key"),
]


@pytest.mark.parametrize("bad, key, problem", BAD, ids=[f"{k}-{p}" for _, k, p in BAD])
@pytest.mark.parametrize("place, table", shape_tables(), ids=["rectangle", "triangle", "ellipsoid", "light"])
def test_bad_transform(place, table, bad, key, problem):
    """Each bad transform is refused on every course shape and light as on a mesh: one line naming the
    source and the key (shapes[0].matrix, lights[0].scale), with the mesh's own words (one text in the
    source: tests/test_rules.py)."""
    with pytest.raises(InputError) as e:
        load_with(place, {**table, **bad})
    line = str(e.value)
    assert "\n" not in line and f"{place}[0].{key}" in line and problem in line, line
    assert line.startswith("load_dict()")


@pytest.mark.parametrize("place", ["shapes", "lights"])
def test_shear_is_refused(place):
    """A transform that shears a rectangle or light (a non-uniform scale after a turn: sides at 81 degrees;
    a matrix whose columns are 1e-9 off a right angle, far beyond float64's rounding, 64 eps kappa = 1.4e-14)
    is one line naming the key and saying so; turned the other way round (scale first) it is a rectangle."""
    table = shape_tables()[0][1] if place == "shapes" else dict(LIGHT)
    m = np.eye(4)
    m[:3, :3] = np.diag([3.0, 1.0, 1.0]) @ mesh_matrix(np.ones(3), [0, 0, 1], 30, np.zeros(3))[:3, :3]
    slight = np.eye(4)
    slight[0, 1] = 1e-9
    for matrix in (m, slight):
        with pytest.raises(InputError) as e:
            load_with(place, {**table, "matrix": matrix.tolist()})
        line = str(e.value)
        assert "\n" not in line and f"{place}[0].matrix" in line and "shears the rectangle" in line, line
    load_with(place, {**table, "scale": [3.0, 1.0, 1.0], "rotate": {"axis": [0, 0, 1], "degrees": 30}})


def test_placed_checks_name_the_transform():
    """The placed shape is checked as one written so (a triangle's area, an ellipsoid's axes, rule 3's
    sizes, rule 2's extents), and the error names the transform key that made it."""
    tables = dict(zip(["rectangle", "triangle", "ellipsoid", "light"], shape_tables()))
    cases = [("rectangle", {"scale": [1e-20, 1e-20, 1.0]}, "shapes[0].scale", "normal float32"),
             ("light", {"scale": [1e-20, 1e-20, 1.0]}, "lights[0].scale", "normal float32"),
             ("rectangle", {"translate": [2e18, 0, 0]}, "shapes[0].translate", "2^60"),
             ("light", {"translate": [2e18, 0, 0]}, "lights[0].translate", "2^60"),
             ("triangle", {"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
                           "scale": 1.0}, "shapes[0].scale", "either matrix"),
             ("triangle", {"scale": [1.0, 1e-12, 1.0]}, "shapes[0].scale", "degenerate triangle"),
             ("ellipsoid", {"scale": [1.0, 1e-13, 1.0]}, "shapes[0].scale", "singular ellipsoid"),
             ("ellipsoid", {"scale": 1e30}, "shapes[0].scale", "2^60")]
    for name, bad, key, problem in cases:
        place, table = tables[name]
        with pytest.raises(InputError) as e:
            load_with(place, {**table, **bad})
        line = str(e.value)
        assert f"{key} = " in line and problem in line and "\n" not in line, line


def test_edits_are_checked():
    """raytrace.parameters re-reads the edited table: an edited transform is placed, and a bad one refused
    with the scene left as it was."""
    table = scene([shape_tables()[0][1]])
    s = load_dict(table)
    params = raytrace.parameters(s)
    params["shapes[0].scale"] = 2.0
    params["shapes[0].translate"] = [0.0, 0.0, 0.5]
    params.update()
    np.testing.assert_array_equal(s.rectangles[0].size, [2.0, 2.0])
    np.testing.assert_array_equal(s.rectangles[0].center, [0.0, 0.0, 0.5])
    for name, value, problem in (("shapes[0].scale", 0.0, "must not be 0"),
                                 ("shapes[0].matrix", np.eye(4).tolist(), "either matrix"),
                                 ("lights[0].matrix", [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
                                  "shears the rectangle")):
        params.discard()
        params[name] = value
        with pytest.raises(InputError) as e:
            params.update()
        assert problem in str(e.value) and str(e.value).startswith("parameters("), str(e.value)
        np.testing.assert_array_equal(s.rectangles[0].size, [2.0, 2.0])


# The render test's transform: a quarter turn about z, a scale of 2 and a mirror through z = 0, then a move by
# dyadic amounts: every product and sum of it with the dyadic coordinates below is exact in float64, so the
# placed shapes are exactly the ones written out (below), whatever route computes them.
W = 48  # the render test's image side
MIRROR = [[0.0, -2.0, 0.0, 0.5], [2.0, 0.0, 0.0, -0.25], [0.0, 0.0, -2.0, 1.0], [0.0, 0.0, 0.0, 1.0]]


def test_render_matches_pretransformed():
    """A scene whose rectangles, triangle, ellipsoid and light are given with transform keys (MIRROR: a
    mirror, so the fronts and a triangle's order matter) renders bit for bit as the scene written out already
    transformed, in the direct model (the light's front side matters there). MIRROR keeps every value exact
    (dyadic), so the two scenes' packed structs are identical, and the kernel, given identical inputs, gives
    identical images. The image is not black (the light's placed front faces the shapes)."""
    m = np.array(MIRROR)
    local = [
        {"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [2.0, 2.0], "normal": [0.0, 0.0, 1.0],
         "tangent": [1.0, 0.0, 0.0]},
        {"type": "rectangle", "center": [0.0, 0.5, 0.5], "size": [2.0, 1.0], "normal": [0.0, -1.0, 0.0],
         "tangent": [1.0, 0.0, 0.0]},
        {"type": "triangle", "vertices": [[-0.5, 0.0, 0.25], [0.0, 0.0, 0.25], [-0.25, 0.0, 0.75]],
         "uv": [[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]]},
        {"type": "ellipsoid", "center": [0.375, -0.25, 0.25], "axes": [[0.25, 0.0, 0.0], [0.0, 0.125, 0.0],
                                                                       [0.0, 0.0, 0.25]]}]
    light = {"center": [0.0, -0.25, 0.875], "size": [0.5, 0.25], "normal": [0.0, 0.0, -1.0],
             "tangent": [0.0, 1.0, 0.0], "radiance": 4.0}
    world = [
        {"type": "rectangle", "center": [0.5, -0.25, 1.0], "size": [4.0, 4.0], "normal": [0.0, 0.0, -1.0],
         "tangent": [0.0, 1.0, 0.0]},
        {"type": "rectangle", "center": [-0.5, -0.25, 0.0], "size": [4.0, 2.0], "normal": [1.0, 0.0, 0.0],
         "tangent": [0.0, 1.0, 0.0]},
        {"type": "triangle", "vertices": [[0.5, -1.25, 0.5], [0.5, -0.75, -0.5], [0.5, -0.25, 0.5]],
         "uv": [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]]},
        {"type": "ellipsoid", "center": [1.0, 0.5, 0.5], "axes": [[0.0, 0.5, 0.0], [-0.25, 0.0, 0.0],
                                                                  [0.0, 0.0, -0.5]]}]
    world_light = {"center": [1.0, -0.25, -0.75], "size": [1.0, 0.5], "normal": [0.0, 0.0, 1.0],
                   "tangent": [-1.0, 0.0, 0.0], "radiance": 4.0}
    np.testing.assert_array_equal(homogeneous(m, [s["center"] for s in local if "center" in s]),
                                  [s["center"] for s in world if "center" in s])
    np.testing.assert_array_equal(homogeneous(m, local[2]["vertices"])[[0, 2, 1]], world[2]["vertices"])
    camera = {"position": [4.0, -0.25, 0.25], "look_at": [0.0, -0.25, 0.25], "up": [0.0, 0.0, 1.0], "fov": 60.0}
    images, structs = [], []
    for shapes, lt in (([{**s, "matrix": MIRROR} for s in local], {**light, "matrix": MIRROR}), (world, world_light)):
        table = {**scene(shapes, [lt]), "camera": camera, "render": {"shading": "direct"}}
        s = load_dict(table)
        structs.append([packing.rectangle_structs(s.rectangles), packing.triangle_structs(s.triangles),
                        packing.triangle_uv_structs(s.triangles), packing.ellipsoid_structs(s.ellipsoids),
                        packing.light_structs(s.lights)])
        images.append(raytrace.render(s, width=W, height=W, spp=4, light_samples=4, progress=False)[0])
    for a, b in zip(*structs):
        assert a.tobytes() == b.tobytes()
    a, b = (np.asarray(image) for image in images)
    assert a.mean() > 0.01
    np.testing.assert_array_equal(a, b)
