"""Meshes in scenes: `type = "mesh"` with a file or a generator, its transform and smooth normals (raytrace/
scene.py), packed for the kernel (raytrace/structs.py) and rendered through the BVH; bad mesh input through
the command line."""
import dataclasses
import gc

import numpy as np
import pytest

import raytrace
from helpers import ROOT
from raytrace.scene import meshgen
from raytrace.renderer.program import Features
from raytrace.scene.meshes import Mesh
from raytrace.scene import MeshShape, load_file
from raytrace.renderer.geometry import triangle_soup
from helpers import run

HEADER = (ROOT / "scenes" / "cornell.toml").read_text().split("[[shapes]]")[0]
OBJ = """# a unit square as one quad, with uvs and normals, and a triangle beside it
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
f 1/1/1 2/2/1 3/3/1 4/4/1
f 2/2/1 5/2/1 3/3/1
"""


def scene_with(tmp_path, shape):
    (tmp_path / "m.obj").write_text(OBJ)
    path = tmp_path / "s.toml"
    path.write_text(HEADER + "[[shapes]]\n" + shape)
    return path


def test_file_and_transform(tmp_path):
    """scale, then rotate, then translate, applied to the file's vertices (a quad becomes two triangles);
    the same as the equivalent 4 x 4 matrix; normals by the inverse transpose, so a non-uniform scale keeps
    them perpendicular to the surface."""
    shape = ('type = "mesh"\nfile = "m.obj"\nscale = [2.0, 3.0, 1.0]\nrotate = { axis = [0.0, 0.0, 1.0], '
             'degrees = 90.0 }\ntranslate = [0.5, 0.0, 1.0]\nsmooth = true\nmaterial = "white"\n')
    scene = load_file(scene_with(tmp_path, shape))
    (mesh,) = scene.meshes
    assert len(mesh.mesh.faces) == 3 and scene.triangle_count == len(scene.triangles) + 3
    expect = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]]) * [2, 3, 1]
    expect = expect @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]]).T + [0.5, 0, 1]
    np.testing.assert_allclose(mesh.mesh.vertices, expect, atol=1e-12)
    np.testing.assert_allclose(mesh.mesh.normals, np.tile([0, 0, 1.0], (5, 1)), atol=1e-12)
    np.testing.assert_allclose(mesh.mesh.uvs[:4], [[0, 0], [1, 0], [1, 1], [0, 1]])
    matrix = np.array([[0, -3, 0, 0.5], [2, 0, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1.0]])
    rows = ", ".join(f"[{', '.join(map(str, r))}]" for r in matrix)
    same = load_file(scene_with(tmp_path, f'type = "mesh"\nfile = "m.obj"\nmatrix = [{rows}]\nmaterial = "white"\n'))
    np.testing.assert_allclose(same.meshes[0].mesh.vertices, expect, atol=1e-12)
    # a sheared mesh: normals stay perpendicular to the transformed faces
    sheared = load_file(scene_with(tmp_path, 'type = "mesh"\nfile = "m.obj"\nmatrix = [[1, 0, 0.7, 0], [0, 1, 0, 0], '
                                              '[0.4, 0, 1, 0], [0, 0, 0, 1]]\nsmooth = true\nmaterial = "white"\n'))
    m = sheared.meshes[0].mesh
    edges = m.vertices[m.faces[:, 1]] - m.vertices[m.faces[:, 0]]
    np.testing.assert_allclose(np.sum(edges * m.normals[m.faces[:, 0]], axis=1), 0, atol=1e-12)


def test_generated_mesh_and_features(tmp_path):
    shape = 'type = "mesh"\ngenerate = { shape = "sphere", triangles = 500 }\nsmooth = true\nmaterial = "white"\n'
    scene = load_file(scene_with(tmp_path, shape))
    assert abs(scene.triangle_count - 500) <= 23
    features = Features.of(scene, 8)
    assert features.bvh and features.smooth_normals and features.triangles
    soup = triangle_soup(scene)
    assert soup.v.shape == (scene.triangle_count, 3, 3) and soup.normals.shape == soup.v.shape


@pytest.mark.parametrize("shape, key", [
    ('type = "mesh"\nfile = "missing.obj"\nmaterial = "white"\n', "missing.obj"),
    ('type = "mesh"\nfile = "m.stl"\nmaterial = "white"\n', "m.stl"),
    ('type = "mesh"\nfile = "bad.obj"\nmaterial = "white"\n', "bad.obj"),
    ('type = "mesh"\nfile = "m.obj"\nscale = 0.0\nmaterial = "white"\n', "scale"),
    ('type = "mesh"\nfile = "m.obj"\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]\n'
     'material = "white"\n', "matrix"),
    ('type = "mesh"\nfile = "m.obj"\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n'
     'scale = 2.0\nmaterial = "white"\n', "scale"),
    ('type = "mesh"\ngenerate = { shape = "teapot", triangles = 100 }\nmaterial = "white"\n', "shape"),
    ('type = "mesh"\nfile = "m.obj"\nsmooth = "yes"\nmaterial = "white"\n', "smooth"),
])
def test_bad_mesh_input(tmp_path, shape, key):
    """One line naming the file and the key, exit status 2, no image."""
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv nan 1 0\nv 1 1 0\nf 1 2 3\n")
    out = tmp_path / "x.png"
    r = run("render", scene_with(tmp_path, shape), "-o", out, "--width", 8, "--height", 8)
    assert r.returncode == 2 and not out.exists()
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], r.stderr


def tessellated(ellipsoid, triangles, smooth):
    """The ellipsoid as a mesh: a UV sphere's vertices mapped onto it (exactly on the surface), with the
    ellipsoid's own normals there (the sphere's, by the inverse transpose)."""
    s = meshgen.sphere(triangles)
    normals = s.normals @ np.linalg.inv(ellipsoid.matrix)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    mesh = Mesh(ellipsoid.center + s.vertices @ ellipsoid.matrix.T, s.faces, normals, s.uvs)
    return MeshShape(mesh, ellipsoid.material, smooth)


def test_smooth_mesh_renders_like_the_ellipsoid(cornell):
    """Scene 0 with its ellipsoid replaced by a smooth mesh of 2 x 10^4 triangles (100 rows, 200 columns)
    renders as the analytic ellipsoid does. Vertices lie on the surface, so the silhouette and the shadows
    move by the chord's sagitta, R (1 - cos(pi / 200)) = 5e-5 units for R = 0.4, 0.002 pixels here: nothing.
    The interpolated normals are off by about (h / R)^2 / 8 with h / R = pi / 100: 1.2e-4 rad, which moves
    k L (n.l + (r.v)^16) by at most 17 times that, 2e-3, on the ~8% of the pixels the ellipsoid covers:
    RMSE <= sqrt(0.08) 2e-3 = 6e-4 (measured 3.0e-4). Flat shading of the same mesh is off by the facets'
    own angle, (h / R) / 2 = 1.6e-2 rad, and fails the bound (measured 9.8e-4); a mesh of 2000 triangles,
    ten times coarser, is farther off (measured 1.8e-3)."""
    options = dict(width=96, height=96, spp=4, light_samples=16, sampler="sobol", light_sampler="sobol",
                   progress=False)
    (ellipsoid,) = cornell.ellipsoids
    analytic = raytrace.render(cornell, **options)[0]
    rmse = {}
    for n, smooth in ((20_000, True), (20_000, False), (2_000, True)):
        scene = dataclasses.replace(cornell, ellipsoids=[], meshes=[tessellated(ellipsoid, n, smooth)])
        image, stats = raytrace.render(scene, **options)
        assert "-DHAS_BVH=1" in stats.build_options
        rmse[n, smooth] = float(np.sqrt(np.mean((image - analytic) ** 2)))
    assert rmse[20_000, True] <= 6e-4
    assert rmse[20_000, False] > 6e-4 and rmse[2_000, True] > 6e-4


def test_mesh_cornell_renders(tmp_path):
    """The shipped mesh scene: its PLY file read, every value finite, the mesh visible where scene 0 has
    floor (the torus stands in front of the ellipsoid)."""
    scene = load_file(ROOT / "scenes" / "mesh_cornell.toml")
    assert scene.meshes[0].mesh.faces.shape == (100_104, 3) and scene.meshes[0].smooth
    image, stats = raytrace.render(scene, width=48, height=48, spp=1, light_samples=4, progress=False)
    plain, _ = raytrace.render(load_file(ROOT / "scenes" / "cornell.toml"), width=48, height=48, spp=1,
                               light_samples=4, progress=False)
    assert np.all(np.isfinite(image)) and stats.extra["nonfinite_values"] == 0
    changed = np.abs(image - plain).max(axis=-1) > 0.05
    assert 0.03 < changed.mean() < 0.3


def test_degenerate_faces_are_left_out_and_counted(tmp_path):
    """A face with a repeated index and a zero-area one are dropped at load, counted, and the render says
    so in one note; the rest of the file renders."""
    (tmp_path / "m.obj").write_text(OBJ + "f 1/1/1 1/1/1 2/2/1\nf 1/1/1 2/2/1 5/2/1\n")  # a repeated index; collinear
    path = tmp_path / "s.toml"
    path.write_text(HEADER + '[[shapes]]\ntype = "mesh"\nfile = "m.obj"\nmaterial = "white"\n')
    (mesh,) = load_file(path).meshes
    assert len(mesh.mesh.faces) == 3 and mesh.dropped == 2 and mesh.source.endswith("m.obj")
    out = tmp_path / "x.png"
    r = run("render", path, "-o", out, "--width", 8, "--height", 8, "--spp", 1, "--light-samples", 1)
    assert r.returncode == 0 and out.exists()
    notes = [line for line in r.stderr.splitlines() if line.startswith("raytrace: note:")]
    assert notes == [f"raytrace: note: {mesh.source}: 2 degenerate faces left out"]
    r = run("render", path, "-o", tmp_path / "y.png", "--spp", 2, "--sampler", "grid")  # found by the fuzz suite
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr  # the error alone: no note before it


def test_mirrored_smooth_mesh_renders_as_the_mirror_image(tmp_path):
    """scale = [-1, 1, 1] mirrors the mesh: faces are turned to stay counter-clockwise from the front, so the
    smooth normals stay on the viewer's side, and a sphere mirrored through its own centre plane renders as
    the unmirrored one (measured before the fix: differences up to 1.15, the sphere shaded from inside)."""
    shape = ('type = "mesh"\ngenerate = { shape = "sphere", triangles = 4000 }\nscale = [{s}, 0.4, 0.4]\n'
             'translate = [0.0, 0.2, 0.8]\nsmooth = true\nmaterial = "white"\n')
    images = []
    for s in ("0.4", "-0.4"):
        scene = load_file(scene_with(tmp_path, shape.replace("{s}", s)))
        images.append(raytrace.render(scene, width=48, height=48, spp=1, light_samples=4, progress=False)[0])
    # the scene is symmetric in x except the wall colours, which the sphere reflects only faintly
    assert np.abs(images[0] - images[1]).max() <= 0.05


def test_cancelling_normals_fall_back_to_the_face(tmp_path, cornell):
    """Two faces back to back on the same vertices: their area-weighted vertex normals cancel to zero, and
    the shading normal falls back to the facing geometric one instead of being 0 (which shaded the sheet
    black but for the ambient term)."""
    sheet = Mesh(np.array([[-0.5, 0.0, 0.5], [0.5, 0.0, 0.5], [0.0, 0.0, 1.2]]), np.array([[0, 1, 2], [0, 2, 1]]),
                 np.zeros((3, 3)), None)
    white = 0
    scene = dataclasses.replace(cornell, triangles=[], ellipsoids=[], meshes=[MeshShape(sheet, white, smooth=True)])
    flat = dataclasses.replace(scene, meshes=[MeshShape(sheet, white, smooth=False)])
    options = dict(width=32, height=32, spp=1, light_samples=4, progress=False)
    np.testing.assert_array_equal(raytrace.render(scene, **options)[0], raytrace.render(flat, **options)[0])


@pytest.mark.parametrize("scale", ["1e39", "1e-200"])
def test_transform_out_of_float32_range(tmp_path, scale):
    """A scale that takes the mesh beyond float32's range, or collapses every face in float32, is one line
    and exit status 2, not a traceback in the BVH or NaN normals."""
    path = scene_with(tmp_path, f'type = "mesh"\nfile = "m.obj"\nscale = {scale}\nmaterial = "white"\n')
    r = run("render", path, "-o", tmp_path / "x.png", "--width", 8, "--height", 8)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "scale" in lines[0], r.stderr


def test_every_live_scene_keeps_its_packed_geometry():
    """Two scenes packed in turns (bench renders its scenes in turns, bench --scaling pairs two meshes) are
    packed once each: the second time, each gets the very arrays of its first, and another variant of a scene
    (here every table but the BVH: features None) is packed anew. A scene's tables go with it. It fails if the
    cache holds one scene only (the first scene's tables would be packed again after the second's), if one
    variant's tables were handed to another, or if a dead scene's stayed."""
    from raytrace.renderer import scene_tables as cache
    from raytrace.commands.scaling import mesh_room
    a, b = (mesh_room(load_file(ROOT / "scenes" / "cornell.toml"), n) for n in (100, 1000))
    tables = lambda scene: cache.scene_tables(scene, features=Features.of(scene, 1))  # noqa: E731
    first = [tables(a), tables(b)]
    again = [tables(a), tables(b)]
    for t0, t1 in zip(first, again):
        assert all(t1[name] is t0[name] for name in ("triangles", "triangle_normals", "nodes", "prims"))
    assert cache.scene_tables(a)["triangles"] is not first[0]["triangles"]
    gc.collect()  # scenes that earlier tests left for the collector go now, not in the count below
    entries, gone = len(cache._GEOMETRY), id(b)
    del b, first, again
    gc.collect()
    assert len(cache._GEOMETRY) == entries - 1 and gone not in cache._GEOMETRY
