"""raytrace's scenes written as Mitsuba 3 XML (raytrace/scene/mitsuba_writer.py), read back by raytrace's own
Mitsuba reader (raytrace/scene/mitsuba_xml.py, mitsuba.py): CI has no Mitsuba, and the reader follows Mitsuba's
plugin reference, so a scene that comes back as the model it was written from was written as Mitsuba reads it.

Each round trip compares the two models, then renders both.

The models. Every number is written by repr(), which reads back as the same float64, so what the reader takes
as written (positions, colours, radiances, indices of refraction, alpha, sizes of the image, counts, the seed)
must come back equal, bit for bit. What it computes comes back within a few float64 roundings: the camera's
basis (look_at's normalisations, a cross product), the fov (fov_axis y through tan and atan), a rectangle's size,
normal and tangent (the lengths of the to_world matrix's columns, their cross product, normalised), an
envmap's frame: each step rounds by at most 2^-53 relative, a handful of steps on unit vectors, so 1e-14 (about
45 ulps of 1) bounds them with a wide margin and is still far below anything a float32 kernel resolves. A sphere
comes back as radius times the identity from axes that may be rotated: the quadric axes^T axes is compared,
within 1e-14 of radius^2. Meshes raytrace holds itself go through a PLY file of float32 positions: they come back
as exactly the float32 rounding of the original (the rounding the kernel's structs apply when a model is packed,
so nothing the renderer sees moves), their normals within 1e-6 (float32's 2^-24, then normalised again). A mesh
file under its transform comes back exactly: the same file, the same float64 matrix, the same arithmetic. So do
disks and cylinders (their to_world, p0, p1 and radius written by repr() and read as written), and each emitting
shape's emitter: its radiance, whether it reflects (a black BSDF, read back as none, where it does not) and the
material it copies. The camera's type, aperture and focus distance, the film's crop window and its filter with
its parameters come back as written; an orthographic view's size through its to_world's scale (column lengths:
1e-14); a clip plane as written, or none where a pinhole's cuts nothing, or Mitsuba's default (which the writer
keeps only where it cuts nothing) where the model had none.

The images. Both are rendered with the same options and seed, so the same sample patterns; the scenes' own
samplers round-trip (sobol -> ldsampler -> sobol at a power of two; the sampler test checks each mapping), and
the direct model's light sampler, which the reader always makes random (Mitsuba's emitter samples are
independent of the pixel's), is given to both renders. They still need not be equal: triangles come back as a
mesh (another code path in the kernel) and a rectangle's normal may come back with the sign
of a zero component flipped by the cross product (the tangent frame's branch follows it), so single paths
differ while the estimate does not. They are compared in 4 x 4 pixel blocks: the difference of two blocks'
sums against 5 standard deviations estimated from both images' per-pixel variances (1024 samples a block; 108
block-channels; a chance of about 6e-5 over all of them for a normal difference, less for correlated renders,
which these are: the worst block over ten seeds was at 2.9). A writer error is a systematic difference: an
inline mesh written without face_normals (its flat triangles shaded smooth) put the worst block at 15, 44 and
130 standard deviations in the Cornell box, scene 0 and scene 0 in the direct model. Per pixel the variance of
64 samples is itself too noisy to divide by. The materials scene (spheres, rectangles whose normals keep their
zeros' signs) renders bit for bit the same, which is checked as such.
"""
import dataclasses
import math
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import raytrace
from raytrace.errors import UnsupportedWarning
from raytrace.numerics import f32
from raytrace.scene.model import fingerprint
from raytrace.scene.mitsuba import FAR_CLIP, NEAR_CLIP
from raytrace.scene.mitsuba_writer import to_xml

from helpers import ROOT

SCENES = ROOT / "scenes"
ELLIPSOID = "axes = [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.0, 0.0, 0.4]]"
C, S = 0.3 * math.cos(0.3), 0.3 * math.sin(0.3)
SPHERE = f"axes = [[{C!r}, {S!r}, 0.0], [{-S!r}, {C!r}, 0.0], [0.0, 0.0, 0.3]]"  # a sphere, turned 0.3 rad
FLOOR_TEXTURE = '{ texture = "../assets/textures/grid.png", uv_scale = [4.0, 4.0] }'
DIRECT_LIGHT_BSDF = "a light's bsdf with the direct integrator"  # the reader's warning, with ignore_unsupported
OCTAHEDRON = "".join(f"v {x} {y} {z}\n" for x, y, z in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1),
                                                      (0, 0, -1))) + \
    "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n"
EXTRAS = """
[materials.metal]
type = "conductor"
eta = [0.0, 0.2, 1.0]
k = [0.0, 3.0, 2.0]
colour = [0.9, 0.8, 0.7]

[[shapes]]
type = "triangle"
vertices = [[-0.9, 0.5, -0.9], [-0.5, 0.5, -0.9], [-0.7, 0.9, -0.85]]
material = "green"

[[shapes]]
type = "mesh"
generate = { shape = "sphere", triangles = 200 }
scale = 0.15
translate = [0.55, 0.45, 0.1]
smooth = true
material = "metal"

[[shapes]]
type = "mesh"
file = "octahedron.obj"
scale = [0.1, 0.2, 0.1]
rotate = { axis = [0.0, 1.0, 1.0], degrees = 30.0 }
translate = [-0.5, 0.5, 0.3]
material = "red"

[[shapes]]
type = "mesh"
file = "octahedron.obj"
matrix = [[-0.15, 0.0, 0.0, 0.5], [0.0, 0.15, 0.0, -0.2], [0.0, 0.0, 0.15, 0.6], [0.0, 0.0, 0.0, 1.0]]
smooth = true
material = "white"

[environment]
type = "constant"
radiance = [0.1, 0.2, 0.30000000000000004]
"""


def _variant(tmp_path, name, replacements=(), append=""):
    """scenes/NAME with each (old, new) replaced (old occurring once) and `append` added, written in tmp_path with
    its files under assets/ named by their absolute paths."""
    text = (SCENES / name).read_text()
    for old, new in replacements:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text.replace('"../assets/', f'"{ROOT / "assets"}/') + append)
    return path


def _written(scene, tmp_path):
    """The XML of `scene` and its extra files, written into tmp_path/out/: the XML's path."""
    out = tmp_path / "out" / "scene.xml"
    out.parent.mkdir(exist_ok=True)
    text, extra = to_xml(scene, out)
    out.write_text(text)
    for name, data in extra.items():
        assert "/" not in name and name.startswith("scene_mesh") and name.endswith(".ply")
        assert f'value="{name}"' in text
        (out.parent / name).write_bytes(data)
    return out


def _round_trip(toml, tmp_path, allowed_warnings=()):
    """(the TOML's scene, the scene its XML reads back as)."""
    scene = raytrace.load_file(toml)
    out = _written(scene, tmp_path)
    root = ET.parse(out).getroot()
    assert root.tag == "scene" and root.get("version") == "3.0.0"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        back = raytrace.load_file(out, ignore_unsupported=bool(allowed_warnings))
    for w in caught:
        assert issubclass(w.category, UnsupportedWarning) and any(a in str(w.message) for a in allowed_warnings), \
            w.message
    return scene, back


def _used(scene):
    """The names of the materials the XML writes: the shapes' and lights', an emitting shape's own copy standing
    for the material it copies (the black one of a shape that reflects nothing standing for none)."""
    shapes = scene.rectangles + scene.triangles + scene.ellipsoids + scene.disks + scene.cylinders + scene.meshes
    return {scene.materials[s.material].name for s in shapes if _reflects(scene, s.material)} | {
        scene.materials[light.material].name for light in scene.lights if light.material >= 0}


def _reflects(scene, index):
    material = scene.materials[index]
    return material.emitter < 0 or scene.emitters[material.emitter].reflects


def _material_key(scene, index):
    """What a shape's material must come back as: its name; an emitting shape's (its own material, named for its
    shape where it reflects nothing) its emitter's radiance, whether it reflects, and the name it copies."""
    material = scene.materials[index]
    if material.emitter < 0:
        return material.name
    emitter = scene.emitters[material.emitter]
    assert emitter.material == index
    return tuple(emitter.radiance.tolist()), emitter.reflects, material.name if emitter.reflects else None


def _close(a, b, atol=1e-14):
    np.testing.assert_allclose(np.asarray(b, np.float64), np.asarray(a, np.float64), rtol=0, atol=atol)


def _same_frame(r, s):
    assert np.array_equal(r.center, s.center)
    _close(r.size / r.size.max(), s.size / r.size.max())
    _close(r.normal, s.normal)
    _close(r.tangent, s.tangent)


def _expected_meshes(scene):
    """(corners (F x 3 x 3), normals or None, smooth, material (_material_key), exact) of each shape the XML writes as a mesh,
    in the scene file's order, as the reader gives them back: exact for a mesh file under a transform that does
    not mirror, else the float32 rounding of a PLY file."""
    expected, triangles, meshes = [], iter(scene.triangles), iter(scene.meshes)
    for table in scene.source.get("shapes", []):
        if table["type"] == "triangle" or (table["type"] == "mesh" and "vertices" in table):
            tris = [next(triangles) for _ in range(len(table.get("faces", [0])))]
            expected.append((f32([t.vertices for t in tris]), None, False, _material_key(scene, tris[0].material),
                             True))
        elif table["type"] == "mesh":
            m = next(meshes)
            mirrored = "matrix" in table and np.linalg.det(np.array(table["matrix"])[:3, :3]) < 0
            exact = "file" in table and not mirrored
            corners = m.mesh.vertices[m.mesh.faces]
            normals = m.mesh.normals if m.smooth else None
            expected.append((corners if exact else f32(corners), normals, m.smooth,
                             _material_key(scene, m.material), exact))
    return expected


def assert_same_model(scene, back, light_sampler=None, k=None):
    """`back`, read from the XML of `scene`, is `scene` within the tolerances of the module's docstring.
    light_sampler: the one the reader gives (the direct model's); k: {material: its k as written (eta = k = 0
    channels as eta 0, k 1)}."""
    camera = back.camera
    assert np.array_equal(camera.position, scene.camera.position)
    for u, v in zip(scene.camera.basis(), camera.basis()):
        _close(u, v)
    if scene.camera.fov_deg is None:  # orthographic: its view's size through the to_world's scale
        assert camera.fov_deg is None
        _close(camera.size, scene.camera.size)
    else:
        assert camera.fov_deg == pytest.approx(scene.camera.fov_deg, rel=1e-13)
    for name in ("kind", "aperture_radius", "focus_distance"):
        assert getattr(camera, name) == getattr(scene.camera, name), name
    for name, default, mitsuba in (("near_clip", 0.0, NEAR_CLIP), ("far_clip", math.inf, FAR_CLIP)):
        # as written, or none where idle (a pinhole's); a camera without one gets Mitsuba's, which cuts nothing
        allowed = (getattr(scene.camera, name), default) + ((mitsuba,) if getattr(scene.camera, name) == default
                                                            else ())
        assert getattr(camera, name) in allowed, name
    for name in ("width", "height", "spp", "sampler", "seed", "shading", "max_depth", "light_samples", "rr_depth",
                 "hide_emitters", "bsdf_samples", "crop_offset_x", "crop_offset_y", "crop_width", "crop_height",
                 "rfilter", "rfilter_radius", "rfilter_stddev", "rfilter_b", "rfilter_c", "rfilter_lobes",
                 "sample_border"):
        assert getattr(back, name) == getattr(scene, name), name
    assert back.light_sampler == (light_sampler or scene.light_sampler)

    materials = {m.name: m for m in back.materials if m.emitter < 0}
    copies = {m.name: m for m in back.materials if m.emitter >= 0 and back.emitters[m.emitter].reflects}
    for m in scene.materials:
        if m.emitter >= 0 and scene.emitters[m.emitter].reflects:  # a copy: the same BSDF, its emitter its own
            b = copies[m.name]
            assert fingerprint(dataclasses.replace(b, emitter=-1)) == fingerprint(dataclasses.replace(m, emitter=-1))
            continue
        if m.emitter >= 0:  # an emitting shape's black material: compared by _material_key
            assert np.array_equal(m.colour, [0.0, 0.0, 0.0]) and m.bsdf == "diffuse"
            continue
        if m.name not in _used(scene):
            assert m.name not in materials
            continue
        b = materials[m.name]
        assert (b.bsdf, b.eta, b.k, b.alpha, b.int_ior, b.ext_ior) == \
            (m.bsdf, m.eta, (k or {}).get(m.name, m.k), m.alpha, m.int_ior, m.ext_ior), m.name
        assert (b.alpha_v, b.distribution, b.specular, b.nonlinear) == \
            (m.alpha_v, m.distribution, m.specular, m.nonlinear), m.name
        assert np.array_equal(b.colour, m.colour), m.name

    assert len(back.lights) == len(scene.lights)
    for light, b in zip(scene.lights, back.lights):
        _same_frame(light, b)
        assert np.array_equal(b.colour, light.colour)
        if light.material >= 0:
            assert back.materials[b.material].name == scene.materials[light.material].name
        else:  # raytrace's light without a material: written as a black diffuse one, read back as none
            assert b.material == -1

    assert len(back.rectangles) == len(scene.rectangles)
    for r, b in zip(scene.rectangles, back.rectangles):
        _same_frame(r, b)
        assert _material_key(back, b.material) == _material_key(scene, r.material)

    assert len(back.ellipsoids) == len(scene.ellipsoids)
    for e, b in zip(scene.ellipsoids, back.ellipsoids):
        assert np.array_equal(b.center, e.center)
        quadric = e.axes.T @ e.axes
        _close(quadric, b.axes.T @ b.axes, atol=1e-14 * quadric.max())
        assert _material_key(back, b.material) == _material_key(scene, e.material)

    for group in ("disks", "cylinders"):  # written as Mitsuba's own, every value by repr(): exact
        assert len(getattr(back, group)) == len(getattr(scene, group)), group
        for d, b in zip(getattr(scene, group), getattr(back, group)):
            assert np.array_equal(b.to_world, d.to_world) and b.flip_normals == d.flip_normals
            if group == "cylinders":
                assert np.array_equal(b.p0, d.p0) and np.array_equal(b.p1, d.p1) and b.radius == d.radius
            assert _material_key(back, b.material) == _material_key(scene, d.material)
    assert len(back.emitters) == len(scene.emitters)

    assert back.triangles == []
    expected = _expected_meshes(scene)
    assert len(back.meshes) == len(expected)
    for (corners, normals, smooth, material, exact), b in zip(expected, back.meshes):
        assert np.array_equal(b.mesh.vertices[b.mesh.faces], corners)
        assert b.smooth == smooth and _material_key(back, b.material) == material
        if smooth and not exact:
            _close(normals, b.mesh.normals, atol=1e-6)

    if scene.environment is None:
        assert back.environment is None
    else:
        assert np.array_equal(back.environment, scene.environment)
    if scene.environment_map is None:
        assert back.environment_map is None
    else:
        envmap, b = scene.environment_map, back.environment_map
        assert b.path == envmap.path and b.scale == envmap.scale and np.array_equal(b.texels, envmap.texels)
        for u, v in zip(envmap.frame(), b.frame()):
            _close(u, v)


def assert_same_images(scene, back, exact=False):
    """Both rendered alike (24 x 24, 64 samples, seed 5) agree block by block within 5 standard deviations."""
    options = {"width": 24, "height": 24, "spp": 64, "seed": 5, "light_sampler": scene.light_sampler,
               "progress": False}
    a, _ = raytrace.render(scene, **options)
    b, _ = raytrace.render(back, **options)
    if exact:
        assert np.array_equal(a, b)

    def blocks(x):
        return np.asarray(x, np.float64).reshape(6, 4, 6, 4, 3).sum(axis=(1, 3))
    difference, variance = blocks(a) - blocks(b), blocks(a.variance) + blocks(b.variance)
    bound = 5 * np.sqrt(variance) + 1e-5 * np.abs(blocks(a))  # 1e-5: float32 sums, where nothing varies
    assert (np.abs(difference) <= bound).all(), np.max(np.abs(difference) / np.maximum(bound, 1e-30))


def test_cornell_box(tmp_path):
    """Mitsuba's own Cornell box: its light reflecting with a material, two boxes written as meshes (PLY)."""
    scene, back = _round_trip(SCENES / "cornell_box.toml", tmp_path)
    assert_same_model(scene, back)
    assert_same_images(scene, back)


@pytest.mark.parametrize("name", ["cornell_path.toml", "mesh_path.toml"])
def test_path_scenes_with_a_sphere(tmp_path, name):
    """Scene 0 in the path model, its ellipsoid a turned sphere: a light without a material (black in the XML),
    an inline mesh as PLY, and in mesh_path.toml the torus file under scale, rotate and translate."""
    scene, back = _round_trip(_variant(tmp_path, name, [(ELLIPSOID, SPHERE)]), tmp_path)
    assert_same_model(scene, back)
    assert_same_images(scene, back)


def test_materials_and_an_envmap(tmp_path):
    """materials.toml, its floor plain: a perfect mirror (Mitsuba's conductor of no eta and k), rough gold,
    glass (unwrapped), spheres and the sky as an envmap turned so that its top looks along +z. The same model
    renders the same image, bit for bit."""
    toml = _variant(tmp_path, "materials.toml", [(FLOOR_TEXTURE, "{ colour = [0.5, 0.5, 0.5] }")])
    scene, back = _round_trip(toml, tmp_path)
    assert_same_model(scene, back)
    assert_same_images(scene, back, exact=True)


CAMERAS = [('[camera]\ntype = "thinlens"\naperture_radius = 0.05\nfocus_distance = 3.5\nnear_clip = 0.5\n'
            'far_clip = 9.0', '[image]\ncrop_offset_x = 3\ncrop_offset_y = 5\ncrop_width = 11\ncrop_height = 9\n'
            'rfilter = "gaussian"\nrfilter_stddev = 0.4'),
           ('[camera]\ntype = "orthographic"\nsize = [2.5, 1.5]\nfar_clip = 8.0', '[image]\nrfilter = "mitchell"\n'
            'rfilter_b = 0.25\nrfilter_c = 0.4'),
           ('[camera]\nnear_clip = 0.25', '[image]\nrfilter = "tent"\nrfilter_radius = 1.25\nsample_border = true'),
           ('[camera]', '[image]\nrfilter = "lanczos"\nrfilter_lobes = 2\ncrop_offset_y = 4')]


@pytest.mark.parametrize("camera, image", CAMERAS, ids=["thinlens", "orthographic", "clipped", "lanczos"])
def test_cameras_clip_planes_crops_and_filters(tmp_path, camera, image):
    """The camera types with their keys and clip planes (a pinhole's near plane that cuts nothing comes back as
    none), a crop window and each filter with its parameters, written as Mitsuba's sensor, hdrfilm and rfilter
    and read back as the same model; rendered alike (at 24 x 24: the whole film of that size)."""
    replacements = [("[camera]", camera), ("[image]", image), (ELLIPSOID, SPHERE)]
    if "orthographic" in camera:
        replacements.append(("fov = 45.0            # vertical, degrees\n", ""))
    scene, back = _round_trip(_variant(tmp_path, "cornell_path.toml", replacements), tmp_path)
    assert_same_model(scene, back)
    assert_same_images(scene, back)


@pytest.mark.parametrize("render", ["", "bsdf_samples = 2\nhide_emitters = true\n"])
def test_direct_model(tmp_path, render):
    """cornell_direct.toml (its ellipsoid a sphere): the direct integrator with emitter_samples and bsdf_samples
    (0 by raytrace's default, written all the same: Mitsuba's is 1), and with 2 BSDF samples and the emitters
    hidden. The XML gives its light a black BSDF, which raytrace's reader leaves out, with a warning, under
    ignore_unsupported. Writing no bsdf_samples where it is 0 fails the first case (seen)."""
    toml = _variant(tmp_path, "cornell_direct.toml", [(ELLIPSOID, SPHERE), ("light_samples = 16\n",
                                                                             "light_samples = 16\n" + render)])
    scene, back = _round_trip(toml, tmp_path, allowed_warnings=(DIRECT_LIGHT_BSDF,))
    assert_same_model(scene, back)
    assert_same_images(scene, back)


def test_aovs_as_the_aov_integrator(tmp_path):
    """A scene's AOVs are written as Mitsuba's aov integrator around the one that renders the image, and read
    back as the same AOVs and shading. Writing no aov integrator fails it (seen)."""
    toml = _variant(tmp_path, "cornell_path.toml", [(ELLIPSOID, SPHERE), ('shading = "path"\n',
                                                                          'shading = "path"\n'
                                                                          'aovs = "albedo,dd.y:depth,shape"\n')])
    scene, back = _round_trip(toml, tmp_path)
    assert scene.aovs == back.aovs == (("albedo", "albedo"), ("dd.y", "depth"), ("shape", "shape_index"))
    assert (back.shading, back.max_depth) == (scene.shading, scene.max_depth)


def test_path_integrator_parameters(tmp_path):
    """cornell_path.toml (its ellipsoid a sphere) with rr_depth 2 and the emitters hidden: the path integrator
    writes both, and the XML reads back to the same model and images. Leaving rr_depth out fails it (seen)."""
    toml = _variant(tmp_path, "cornell_path.toml", [(ELLIPSOID, SPHERE), ('shading = "path"\n',
                                                                          'shading = "path"\nrr_depth = 2\n'
                                                                          "hide_emitters = true\n")])
    scene, back = _round_trip(toml, tmp_path)
    assert (scene.rr_depth, scene.hide_emitters) == (2, True)
    assert_same_model(scene, back)
    assert_same_images(scene, back)


def test_meshes_files_and_a_constant_environment(tmp_path):
    """The Cornell box with a triangle, a generated smooth sphere (PLY with normals), an OBJ file under scale,
    rotate and translate (named relative to the XML, under its to_world), the same file mirrored by a matrix (a
    PLY in world space: raytrace reverses the faces of a mirrored mesh, Mitsuba would not), a conductor with a
    perfect mirror's channel (eta 0, k 1 in the XML), and a constant environment seen through the open front."""
    (tmp_path / "octahedron.obj").write_text(OCTAHEDRON)
    scene, back = _round_trip(_variant(tmp_path, "cornell_box.toml", append=EXTRAS), tmp_path)
    assert_same_model(scene, back, k={"metal": (1.0, 3.0, 2.0)})
    text = (tmp_path / "out" / "scene.xml").read_text()
    assert text.count('value="../octahedron.obj"') == 1 and text.count('type="obj"') == 1
    assert sorted(p.name for p in (tmp_path / "out").glob("*.ply")) == [f"scene_mesh{i}.ply" for i in range(5)]
    assert_same_images(scene, back)


EVERY_BSDF = """
[materials.pane]
type = "thindielectric"
int_ior = "water"
colour = [0.9, 0.95, 1.0]

[materials.frosted]
type = "roughdielectric"
distribution = "beckmann"
alpha_u = 0.05
alpha_v = 0.3
int_ior = 1.0
ext_ior = 1.33

[materials.varnish]
type = "plastic"
diffuse_reflectance = [0.1, 0.27, 0.36]
specular_reflectance = [1.0, 0.5, 0.25]
nonlinear = true
int_ior = 1.9

[materials.matte]
type = "roughplastic"
distribution = "ggx"
alpha = 0.3
ext_ior = 1.1

[materials.brushed]
type = "roughconductor"
material = "Al"
alpha_u = 0.4
alpha_v = 0.05
colour = [0.9, 0.8, 0.7]

[materials.gold]
type = "roughconductor"
material = "Au"
distribution = "beckmann"
"""


def test_every_bsdf_and_its_parameters_round_trip(tmp_path):
    """Each BSDF with its parameters (anisotropic and Beckmann roughness, a plastic's coat, named media and
    metals) written as Mitsuba's plugin and read back as the same material, bit for bit; then the XML converted to
    TOML reads as the same model again (XML -> TOML -> XML keeps them). The models only: rendering these BSDFs is
    their kernel tests' matter."""
    import tomllib

    from raytrace.scene import parse_scene
    from raytrace.scene.scene_file import load_mitsuba_file
    from raytrace.scene.toml_writer import scene_toml
    names = ["pane", "frosted", "varnish", "matte", "brushed", "gold"]
    shapes = "".join(f'\n[[shapes]]\ntype = "rectangle"\ncenter = [0.0, 0.0, {0.1 * (i + 1)!r}]\nsize = [0.2, 0.2]\n'
                     f'normal = [0.0, 0.0, 1.0]\ntangent = [1.0, 0.0, 0.0]\nmaterial = "{name}"\n'
                     for i, name in enumerate(names))
    scene, back = _round_trip(_variant(tmp_path, "cornell_box.toml", append=EVERY_BSDF + shapes), tmp_path)
    assert_same_model(scene, back)
    bsdfs = {m.name: m.bsdf for m in back.materials}
    assert [bsdfs[name] for name in names] == ["thindielectric", "roughdielectric", "plastic", "roughplastic",
                                               "roughconductor", "roughconductor"]
    text = (tmp_path / "out" / "scene.xml").read_text()
    for fragment in ('<bsdf type="thindielectric" id="pane">', '<bsdf type="roughdielectric" id="frosted">',
                     '<float name="alpha_u" value="0.05" />', '<string name="distribution" value="beckmann" />',
                     '<boolean name="nonlinear" value="true" />', '<rgb name="diffuse_reflectance" value="0.1, 0.27, '
                     '0.36" />', '<rgb name="specular_reflectance" value="1.0, 0.5, 0.25" />'):
        assert fragment in text, fragment
    _, translation = load_mitsuba_file(tmp_path / "out" / "scene.xml")
    again = parse_scene(tomllib.loads(scene_toml(translation.table)), str(tmp_path / "out" / "scene.toml"))
    assert fingerprint(again.materials) == fingerprint(back.materials)


SAMPLER_CASES = [  # (raytrace's sampler, spp, Mitsuba's sampler, the pattern and count read back, a comment)
    ("random", 5, "independent", "random", 5, None),
    ("jittered", 16, "stratified", "jittered", 16, None),
    ("jittered", 5, "stratified", "jittered", 9, "rounds its sample_count up to a square: 9"),
    ("sobol", 64, "ldsampler", "sobol", 64, None),
    ("sobol", 5, "ldsampler", "sobol", 8, "rounds its sample_count up to a power of two: 8"),
    ("halton", 16, "ldsampler", "sobol", 16, "halton sampler has no Mitsuba equivalent"),
    ("grid", 16, "stratified", "jittered", 16, "grid sampler has no Mitsuba equivalent"),
    ("rotated-grid-cw", 4, "stratified", "jittered", 4, "rotated-grid-cw sampler has no Mitsuba equivalent"),
    ("center", 1, "stratified", "jittered", 1, "center sampler has no Mitsuba equivalent"),
]


@pytest.mark.parametrize("case", SAMPLER_CASES, ids=lambda c: f"{c[0]}-{c[1]}")
def test_samplers(tmp_path, case):
    """Each pixel pattern as the Mitsuba sampler nearest it, its count as sample_count and the seed kept; what
    Mitsuba changes (its rounding of the count, a pattern it lacks) said in a comment beside it."""
    sampler, spp, kind, pattern, count, comment = case
    toml = _variant(tmp_path, "cornell_box.toml", [("spp = 64", f'spp = {spp}\nsampler = "{sampler}"\nseed = 77')])
    scene = raytrace.load_file(toml)
    out = _written(scene, tmp_path)
    element = ET.parse(out).getroot().find("sensor/sampler")
    assert element.get("type") == kind
    assert {e.get("name"): e.get("value") for e in element} == {"sample_count": str(spp), "seed": "77"}
    text = out.read_text()
    assert (comment in text) if comment else "<!-- Mitsuba" not in text and "no Mitsuba equivalent" not in text
    back = raytrace.load_file(out)
    assert (back.sampler, back.spp, back.seed) == (pattern, count, 77)


def _refusal(path, key):
    scene = raytrace.load_file(path)
    with pytest.raises(raytrace.InputError) as error:
        to_xml(scene, path.with_suffix(".xml"))  # nothing is written
    assert error.value.source == str(path) and error.value.key == key
    return error.value


def test_refuses_the_phong_model():
    error = _refusal(SCENES / "cornell.toml", "render.shading")
    assert error.value == "phong" and "Phong model has no Mitsuba 3 equivalent" in error.problem


def test_refuses_a_textured_material():
    error = _refusal(SCENES / "materials.toml", "materials.floor.texture")
    assert error.value == "../assets/textures/grid.png"


def test_refuses_an_ellipsoid_that_is_not_a_sphere():
    error = _refusal(SCENES / "cornell_path.toml", "shapes[6].axes")
    assert error.value == [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.0, 0.0, 0.4]]
    assert "Mitsuba's sphere takes no non-uniform scale" in error.problem


def test_writes_only_the_materials_something_uses(tmp_path):
    """An unused material is left out, textured or not: a texture is refused only where it would be rendered."""
    toml = _variant(tmp_path, "cornell_box.toml", append=f'\n[materials.unused]\ntexture = "{ROOT}/assets/'
                                                          'textures/grid.png"\n')
    root = ET.parse(_written(raytrace.load_file(toml), tmp_path)).getroot()
    assert sorted(b.get("id") for b in root.findall("bsdf")) == ["green", "red", "white"]


def test_a_name_that_is_no_plain_id(tmp_path):
    """A material's name that is not a plain id (a space, a dollar sign: Mitsuba's parameters) is written under
    an id of its own, the name in a comment."""
    toml = _variant(tmp_path, "cornell_box.toml", [("white = {", '"white $paint" = {')])
    toml.write_text(toml.read_text().replace('material = "white"', 'material = "white $paint"'))
    out = _written(raytrace.load_file(toml), tmp_path)
    assert "<!-- material 'white $paint' -->" in out.read_text()
    back = raytrace.load_file(out)
    assert [m.name for m in back.materials] == ["material0", "green", "red"]


def test_a_scene_built_in_python(tmp_path):
    """A model without its table (source None) is written from the model: its triangles grouped by material."""
    scene = raytrace.load_file(SCENES / "cornell_box.toml")
    bare = dataclasses.replace(scene, source=None)
    back = raytrace.load_file(_written(bare, tmp_path))
    assert len(back.meshes) == 1 and len(back.rectangles) == len(scene.rectangles)
    mesh = back.meshes[0].mesh
    assert np.array_equal(mesh.vertices[mesh.faces], f32([t.vertices for t in scene.triangles]))


ANALYTIC_SCENE = """
[camera]
position = [0.0, 0.0, 3.9]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 39.3077

[image]
width = 24
height = 24

[render]
shading = "path"
max_depth = 4

[materials]
white = { colour = [0.8, 0.7, 0.6] }
green = { colour = [0.1, 0.4, 0.1] }
red = { type = "roughconductor", material = "Au", alpha = 0.2 }

[[lights]]
center = [0.0, 0.99, 0.0]
size = [0.5, 0.4]
normal = [0.0, -1.0, 0.0]
tangent = [1.0, 0.0, 0.0]
radiance = [10.0, 9.0, 8.0]

[[shapes]]            # the back wall, so that nothing shows the black sky
type = "rectangle"
center = [0.0, 0.0, -1.0]
size = [2.0, 2.0]
normal = [0.0, 0.0, 1.0]
tangent = [1.0, 0.0, 0.0]
material = "white"

[[shapes]]            # an emitting sphere that reflects
type = "ellipsoid"
center = [-0.5, -0.6, 0.3]
axes = [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, 0.25]]
material = "white"
radiance = [2.0, 1.0, 0.5]

[[shapes]]            # a disk under a non-uniform scale and a shear
type = "disk"
to_world = [[0.3, 0.1, 0.0, 0.4], [0.0, 0.2, 0.05, 0.3], [0.0, 0.0, 1.0, -0.5], [0.0, 0.0, 0.0, 1.0]]
material = "green"

[[shapes]]            # a cylinder of its own axis and radius, sheared, inside out
type = "cylinder"
p0 = [0.1, -0.2, 0.0]
p1 = [0.3, 0.5, 0.4]
radius = 0.7
to_world = [[0.3, 0.0, 0.1, -0.5], [0.0, 0.3, 0.0, 0.2], [0.05, 0.0, 0.3, -0.3], [0.0, 0.0, 0.0, 1.0]]
flip_normals = true
material = "red"

[[shapes]]            # an emitting disk, black, its normal turned towards the camera by flip_normals
type = "disk"
to_world = [[0.2, 0.0, 0.0, 0.5], [0.0, 0.2, 0.0, -0.6], [0.0, 0.0, -0.2, -0.8], [0.0, 0.0, 0.0, 1.0]]
flip_normals = true
radiance = 3.0

[[shapes]]            # an emitting cylinder that reflects, its axis along y
type = "cylinder"
radius = 0.1
to_world = [[1.0, 0.0, 0.0, 0.7], [0.0, 0.0, 0.8, -0.9], [0.0, -1.0, 0.0, 0.2], [0.0, 0.0, 0.0, 1.0]]
material = "white"
radiance = [0.5, 2.0, 1.0]
"""

EMITTING_MESHES = """
[[shapes]]            # an emitting inline mesh (no rectangle: the reader would make that a light), black
type = "mesh"
vertices = [[-0.9, 0.5, -0.9], [-0.5, 0.5, -0.9], [-0.7, 0.9, -0.85], [-0.7, 0.7, -0.5]]
faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]]
radiance = [1.0, 2.0, 3.0]

[[shapes]]            # an emitting mesh file under its transform, reflecting
type = "mesh"
file = "octahedron.obj"
scale = [0.1, 0.2, 0.1]
translate = [-0.5, 0.5, 0.3]
material = "red"
radiance = [0.4, 0.3, 0.2]

[[shapes]]            # an emitting generated mesh, smooth, black
type = "mesh"
generate = { shape = "sphere", triangles = 100 }
scale = 0.12
translate = [0.55, 0.45, 0.1]
smooth = true
radiance = 2.0
"""


def test_disks_cylinders_and_emitting_shapes(tmp_path):
    """Disks and cylinders (sheared, scaled non-uniformly, flip_normals, a cylinder's p0, p1 and radius) and
    emitting ones, an emitting sphere: each written as Mitsuba's shape with its area emitter inside, its BSDF the
    material it copies or the black one. They come back as the same model, exactly, and render the same image,
    bit for bit (the same shapes, the same float64 values packed the same way).

    Mutations tried, each failing this test: no emitter written (emitters count), the emitter's BSDF always the
    black one (reflects), to_world not written (to_world), p0 and p1 swapped (p0), flip_normals dropped, disks
    and cylinders left out of shapes() and of its list from the model (counts)."""
    toml = tmp_path / "analytic.toml"
    toml.write_text(ANALYTIC_SCENE)
    scene, back = _round_trip(toml, tmp_path)
    assert [(len(s.disks), len(s.cylinders), len(s.emitters)) for s in (scene, back)] == [(2, 2, 3)] * 2
    assert [e.reflects for e in scene.emitters] == [True, False, True]
    assert_same_model(scene, back)
    assert_same_images(scene, back, exact=True)


@pytest.mark.parametrize("name", ["cornell_box.toml", "cornell_direct.toml"])
def test_emitting_meshes(tmp_path, name):
    """Meshes with a radiance (inline, a file under its transform, generated and smooth), in the path model
    reflecting or black, in the direct model black (a material beside radiance is the path model's only): each
    PLY or OBJ shape with its area emitter, read back as the same emitting mesh. Their images agree block by
    block (triangles come back as a mesh: another code path, so not bit for bit).

    Mutations tried, each failing: no emitter written, the emitter's BSDF always the black one."""
    (tmp_path / "octahedron.obj").write_text(OCTAHEDRON)
    extra = EMITTING_MESHES
    if name == "cornell_direct.toml":
        extra = extra.replace('material = "red"\nradiance', "radiance")
    replacements = [(ELLIPSOID, SPHERE)] if name == "cornell_direct.toml" else []
    allowed = (DIRECT_LIGHT_BSDF,) if name == "cornell_direct.toml" else ()
    scene, back = _round_trip(_variant(tmp_path, name, replacements, append=extra), tmp_path, allowed)
    assert len(back.emitters) == len(scene.emitters) == 3
    assert_same_model(scene, back)
    assert_same_images(scene, back)


def test_refuses_an_emitter_no_shape_carries(tmp_path):
    """An emitter whose material no shape has (a model built in Python) is refused, not dropped (mutation tried:
    no check_emitters, the XML written without the light)."""
    toml = tmp_path / "analytic.toml"
    toml.write_text(ANALYTIC_SCENE)
    scene = raytrace.load_file(toml)
    orphan = dataclasses.replace(scene, ellipsoids=[], source=None)
    with pytest.raises(raytrace.InputError) as error:
        to_xml(orphan, tmp_path / "out.xml")
    assert error.value.key == "emitters[0]" and error.value.value == [2.0, 1.0, 0.5]
    assert "no shape carries this emitter" in error.value.problem


DELTA_LIGHTS = """
[[emitters]]
type = "point"
position = [0.3, 0.5, 0.8]
intensity = [0.5, 0.4, 0.3]

[[emitters]]
type = "spot"
to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.5], [0.0, 0.0, -1.0, 2.0], [0.0, 0.0, 0.0, 1.0]]
intensity = [2.0, 1.5, 1.0]
cutoff_angle = 35.0
texture = { type = "checkerboard", color0 = [1.0, 0.5, 0.2], color1 = 0.1, to_uv = [[4.0, 0.5, 0.1], [0.0, 3.0, 0.2]] }

[[emitters]]
type = "directional"
direction = [0.2, -0.3, -1.0]
irradiance = [0.3, 0.3, 0.35]

[[emitters]]
type = "projector"
to_world = [[-1.0, 0.0, 0.0, 0.3], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 2.5], [0.0, 0.0, 0.0, 1.0]]
fov = 40.0
fov_axis = "y"
scale = 0.2
irradiance = { type = "bitmap", filename = "PROJECTED", filter_type = "nearest", wrap_mode = "clamp" }
"""


def test_delta_lights_round_trip(tmp_path):
    """Point, spot (a checkerboard with a to_uv of every term), directional and projector (a bitmap, fov along y)
    lights: each written as Mitsuba's emitter and read back as the same model, exactly but for the to_uv's terms
    (composed with the flip of v there and back: 1e-15) and the fov (through fov_axis's tangents: 1e-14), and the
    same image block by block.

    Mutations tried, each failing: the to_uv's flip left out of the writer (to_uv); the spot's default
    beam_width written as a number (the model's beam_width None)."""
    from helpers import ROOT
    toml = tmp_path / "delta.toml"
    projected = (ROOT / "assets" / "textures" / "grid.png").as_posix()
    toml.write_text(ANALYTIC_SCENE + DELTA_LIGHTS.replace("PROJECTED", projected))
    scene, back = _round_trip(toml, tmp_path)
    assert len(back.emitters) == len(scene.emitters) == 7
    for e, b in zip(scene.emitters[3:], back.emitters[3:]):
        assert type(b) is type(e)
        for name in e.__dataclass_fields__:
            x, y = getattr(e, name), getattr(b, name)
            if name == "texture" and x is not None:
                np.testing.assert_allclose(y.to_uv, x.to_uv, rtol=0, atol=1e-15)
                assert dataclasses.replace(y, to_uv=x.to_uv) == x
            elif name == "fov":
                assert y == pytest.approx(x, rel=1e-14)
            elif isinstance(x, np.ndarray):
                assert np.array_equal(x, y), name
            else:
                assert x == y, name
    assert_same_images(scene, back)
