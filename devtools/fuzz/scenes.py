"""Hypothesis strategies for scenes: valid scenes from the real grammar (SceneExample: a table and the files
it refers to), the same mutated with hostile values, scene texts that are no TOML, and valid scenes whose
texture or mesh files are replaced by hostile ones (from files.py), path-model scenes whose values lie
anywhere in their keys' ranges (for the path model's range rules, tests/test_path_ranges.py), the same with
their environment maps written as real or hostile image files and hostile values, and a scene that reads a file
of every kind (for outputs that alias an input). Direct and path scenes hold delta lights ([[emitters]]) now and then."""
import copy
import dataclasses
import math
import os

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st

from raytrace import aovs as aov_types
from raytrace.numerics import FLOAT32_MAX, FLOAT32_TINY
from raytrace.renderer.packing import SMOOTH_ALPHA  # below it a rough conductor or glass renders smooth
from raytrace.scene.bsdfs import BY_NAME
from raytrace.scene.keys import FOV_AXES
from raytrace.scene.model import BSDFS, DELTA_EMITTERS, DISTRIBUTIONS
from raytrace.scene.named_materials import CONDUCTORS, IORS
from raytrace.scene.toml_writer import to_toml

from .files import TETRAHEDRON, TETRAHEDRON_FACES, AssetCopy, ImageFile, finite, hostile_files, valid_images, \
    valid_mesh_files, vectors


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
    kind = draw(st.sampled_from(["perspective", "perspective", "thinlens", "orthographic"]))
    if kind != "perspective" or draw(st.booleans()):
        camera["type"] = kind
    if kind == "thinlens":
        camera.update(aperture_radius=draw(finite(0.001, 0.3)), focus_distance=draw(finite(0.5, 6.0)))
    elif kind == "orthographic":
        del camera["fov"]
        camera["size"] = [draw(finite(0.5, 4.0)), draw(finite(0.5, 4.0))]
    if draw(st.booleans()):
        camera["near_clip"] = draw(finite(0.0, 1.0))
    if draw(st.booleans()):
        camera["far_clip"] = draw(finite(2.0, 20.0))
    return camera


@st.composite
def images(draw):
    """The image table: the film, in a quarter of them a crop window of it, and any reconstruction filter."""
    image = {"width": draw(st.integers(1, 16)), "height": draw(st.integers(1, 16))}
    if draw(st.integers(0, 3)) == 0:
        x, y = draw(st.integers(0, image["width"] - 1)), draw(st.integers(0, image["height"] - 1))
        image.update(crop_offset_x=x, crop_offset_y=y, crop_width=draw(st.integers(1, image["width"] - x)),
                     crop_height=draw(st.integers(1, image["height"] - y)))
    rfilter = draw(st.sampled_from(["box", "box", "tent", "gaussian", "mitchell", "lanczos"]))
    if rfilter != "box" or draw(st.booleans()):
        image["rfilter"] = rfilter
    parameters = {"tent": {"rfilter_radius": finite(0.25, 3.0)}, "gaussian": {"rfilter_stddev": finite(0.1, 1.5)},
                  "mitchell": {"rfilter_b": finite(0.0, 1.0), "rfilter_c": finite(0.0, 1.0)},
                  "lanczos": {"rfilter_lobes": st.integers(1, 5)}}.get(rfilter, {})
    for key, values in parameters.items():
        if draw(st.booleans()):
            image[key] = draw(values)
    if draw(st.integers(0, 3)) == 0:
        image["sample_border"] = draw(st.booleans())
    return image


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
    if draw(st.booleans()):
        render["light_selection"] = draw(st.sampled_from(["power", "uniform"]))
    return render


@st.composite
def lights(draw):
    normal, tangent = draw(frames([AXIS_FRAMES[1]]))
    return {"center": [draw(finite(-0.5, 0.5)), draw(finite(-0.5, 0.5)), draw(finite(1.5, 2.5))],
            "size": draw(vectors(2, 0.1, 1.0)),
            "normal": normal, "tangent": tangent, "colour": draw(vectors(3, 0.0, 2.0))}


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
def rigid_transforms(draw):
    """A rectangle's transform keys: some of a uniform scale (a mirror now and then), rotate and translate, or
    their matrix (a non-uniform scale would shear a tilted rectangle, which is refused)."""
    transform = draw(mesh_transforms())
    if "matrix" in transform:
        m = np.array(transform["matrix"])
        m[:3, :3] *= np.cbrt(abs(np.linalg.det(m[:3, :3]))) / np.linalg.norm(m[:3, :3], axis=0)
        return {"matrix": m.tolist()}
    if isinstance(transform.get("scale"), list):
        transform["scale"] = transform["scale"][0]
    return transform


@st.composite
def affine_matrices(draw):
    """A disk's or cylinder's to_world: a rotation of a sheared, non-uniformly scaled (now and then mirrored)
    frame, translated; its columns within a factor of about 50 of each other, so never near singular."""
    signed = st.tuples(finite(0.1, 1.0), st.sampled_from([1.0, 1.0, -1.0])).map(lambda p: p[0] * p[1])
    shear = np.eye(3)
    shear[np.triu_indices(3, 1)] = draw(vectors(3, -0.5, 0.5))
    axis = draw(vectors(3, -1.0, 1.0).filter(lambda a: np.linalg.norm(a) > 0.1))
    m = np.eye(4)
    m[:3, :3] = rotation_matrix(axis, draw(finite(-360.0, 360.0))) @ shear @ np.diag(
        draw(st.lists(signed, min_size=3, max_size=3)))
    m[:3, 3] = draw(vectors(3, -1.0, 1.0))
    return m.tolist()


@st.composite
def analytic_shapes(draw, kind):
    """A disk's or a cylinder's own keys: to_world or not, flip_normals or not, a cylinder's p0, p1 (an axis of
    0.1 at least) and radius each given or not."""
    shape = {"type": kind}
    if draw(st.sampled_from([True, True, False])):
        shape["to_world"] = draw(affine_matrices())
    if draw(st.booleans()):
        shape["flip_normals"] = draw(st.booleans())
    if kind == "cylinder":
        p0, p1 = [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]
        if draw(st.booleans()):
            p0 = shape["p0"] = draw(vectors(3, -0.5, 0.5))
        if draw(st.booleans()):
            p1 = shape["p1"] = draw(vectors(3, -0.5, 0.5))
        assume(np.linalg.norm(np.subtract(p1, p0)) > 0.1)
        if draw(st.booleans()):
            shape["radius"] = draw(finite(0.05, 1.0))
    return shape


def emitting(draw, shape, reflecting=True, radiances=finite(0.0, 4.0)):
    """`shape` with a radiance now and then (the direct and path models), black (its material dropped) or, where
    `reflecting`, reflecting by its material."""
    if draw(st.sampled_from([False, True, False])):
        shape["radiance"] = draw(number_or_vector(radiances))
        if not reflecting or draw(st.booleans()):
            shape.pop("material", None)
    return shape


@st.composite
def delta_lights(draw, intensities=finite(0.0, 4.0)):
    """One [[emitters]] table (the radiometric models'): a point, spot, directional or projector light, each
    optional key given or not, to_world any affine map (a spot's, a projector's) or a translation (a point's),
    a spot's or projector's image a checkerboard now and then."""
    kind = draw(st.sampled_from(DELTA_EMITTERS))
    light = {"type": kind}
    checker = {"type": "checkerboard", "color0": draw(number_or_vector(finite(0.0, 2.0)))}
    if kind == "point":
        if draw(st.booleans()):
            light["position"] = draw(vectors(3, -1.0, 2.0))
        elif draw(st.booleans()):
            t = draw(vectors(3, -1.0, 2.0))
            light["to_world"] = [[1.0, 0.0, 0.0, t[0]], [0.0, 1.0, 0.0, t[1]], [0.0, 0.0, 1.0, t[2]],
                                 [0.0, 0.0, 0.0, 1.0]]
    elif kind == "directional":
        if draw(st.booleans()):
            light["direction"] = draw(vectors(3, -1.0, 1.0).filter(lambda a: np.linalg.norm(a) > 0.1))
        elif draw(st.booleans()):
            light["to_world"] = draw(affine_matrices())
    elif draw(st.sampled_from([True, True, False])):
        light["to_world"] = draw(affine_matrices())
    key = {"point": "intensity", "spot": "intensity", "directional": "irradiance", "projector": "irradiance"}[kind]
    if draw(st.booleans()):
        light[key] = draw(number_or_vector(intensities))
    if kind == "spot":
        if draw(st.booleans()):
            light["cutoff_angle"] = draw(finite(1.0, 89.0))
        if draw(st.booleans()):
            light["beam_width"] = draw(finite(0.0, light.get("cutoff_angle", 20.0)))
        if draw(st.booleans()):
            light["texture"] = checker
    if kind == "projector":
        if draw(st.booleans()):
            light["irradiance"] = checker
        if draw(st.booleans()):
            light["scale"] = draw(finite(0.0, 4.0))
        if draw(st.booleans()):
            light["fov"] = draw(finite(1.0, 170.0))
            if draw(st.booleans()):
                light["fov_axis"] = draw(st.sampled_from(FOV_AXES))
        elif draw(st.booleans()):
            light["focal_length"] = draw(finite(5.0, 200.0))
    return light


@st.composite
def shapes(draw, material_names, files):
    """One [[shapes]] table of any type, the course's shapes placed by transform keys or not (a rectangle's
    without a shear); mesh files it names are added to `files`."""
    kind = draw(st.sampled_from(["rectangle", "triangle", "inline mesh", "mesh file", "generated mesh",
                                 "ellipsoid", "disk", "cylinder"]))
    shape = {"type": "mesh" if "mesh" in kind else kind, "material": draw(st.sampled_from(material_names))}
    if kind in ("triangle", "ellipsoid") and draw(st.booleans()):
        shape.update(draw(mesh_transforms()))
    if kind == "rectangle":
        normal, tangent = draw(frames())
        shape.update(center=draw(vectors(3, -1.0, 1.0)), size=draw(vectors(2, 0.1, 3.0)), normal=normal,
                     tangent=tangent)
        if draw(st.booleans()):
            shape.update(draw(rigid_transforms()))
    elif kind in ("disk", "cylinder"):
        shape.update(draw(analytic_shapes(kind)))
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
    1..16 pixels a side, a few samples; in a quarter of them the direct model, some shapes black emitters, perhaps
    BSDF samples and hidden emitters."""
    files = []
    table = {"camera": draw(cameras()), "image": draw(images())}
    if draw(st.booleans()):
        table["render"] = draw(render_tables())
    if draw(st.booleans()):
        table["ambient"] = draw(vectors(3, 0.0, 0.3))
    names = [f"m{i}" for i in range(draw(st.integers(1, 3)))]
    table["materials"] = {name: draw(materials(name, files)) for name in names}
    table["lights"] = draw(st.lists(lights(), min_size=1, max_size=2))
    table["shapes"] = draw(st.lists(shapes(names, files), max_size=max_shapes))
    if draw(st.sampled_from(["phong", "phong", "phong", "direct"])) == "direct":
        # the direct model: lights of a radiance, black emitting shapes, light samples that are no point light
        render = table.setdefault("render", {})
        render.update(shading="direct", light_sampler=draw(st.sampled_from(["random", "jittered", "halton",
                                                                            "sobol"])))
        if draw(st.booleans()):  # BSDF samples besides the lights', and the emitters hidden from the camera
            render.update(bsdf_samples=draw(st.integers(0, 3)), hide_emitters=draw(st.booleans()))
        table.pop("ambient", None)
        for light in table["lights"]:
            light["radiance"] = light.pop("colour")
        for shape in table["shapes"]:
            if shape["type"] != "ellipsoid":  # a sphere's only, and these are not
                emitting(draw, shape, reflecting=False)
        table["emitters"] = draw(st.lists(delta_lights(), max_size=2))
        if table["emitters"] and draw(st.booleans()):  # delta lights alone
            del table["lights"]
    if not table["shapes"] and draw(st.booleans()):
        del table["shapes"]
    assume(len(files) >= min_files)
    return SceneExample(table, tuple(files))


# --- path scenes with values anywhere in their ranges --------------------------------------------------

EDGES = (0.0, 1e-45, FLOAT32_TINY, 2.0**-63, 1e-3, 0.5, 0.95, 1.0, 1.5, 2.0**31, 2.0**32, 2.0**63,
         1e15, 1e20, 1e25, FLOAT32_MAX)


def magnitudes(low=0.0, high=FLOAT32_MAX):
    """A number in [low, high] from anywhere in float32's range: its edges and powers of two of any exponent
    (a float drawn uniformly would almost never be below 1e30)."""
    powers = st.floats(-149.0, 127.99).map(lambda e: 2.0 ** e)
    return st.one_of(st.sampled_from(EDGES), powers, finite(0.0, 1.0)).filter(lambda x: low <= x <= high)


def number_or_vector(values):
    return st.one_of(values, st.lists(values, min_size=3, max_size=3))


# Every BSDF's keys the generator below draws, by type (tests/test_path_ranges.py checks them against the
# declarations, raytrace/scene/bsdfs.py, so that a BSDF or a parameter declared later is not left unfuzzed).
REFLECTANCE_NAMES = {"diffuse": "reflectance", "conductor": "specular_reflectance",
                     "roughconductor": "specular_reflectance", "plastic": "diffuse_reflectance",
                     "roughplastic": "diffuse_reflectance", "principled": "base_color",
                     "principledthin": "base_color"}
CONDUCTOR_KEYS = ("eta", "k", "material", "specular_reflectance")
ROUGH_KEYS = ("distribution", "alpha", "alpha_u", "alpha_v")
IOR_KEYS = ("int_ior", "ext_ior")
PLASTIC_KEYS = ("diffuse_reflectance", "nonlinear", *IOR_KEYS, "specular_reflectance")
PATH_KEYS = {"diffuse": ("reflectance",), "conductor": CONDUCTOR_KEYS, "dielectric": IOR_KEYS,
             "roughconductor": CONDUCTOR_KEYS + ROUGH_KEYS, "thindielectric": IOR_KEYS,
             "roughdielectric": IOR_KEYS + ROUGH_KEYS, "plastic": PLASTIC_KEYS,
             "roughplastic": PLASTIC_KEYS + ROUGH_KEYS[:2]}
PRINCIPLED_WEIGHTS = ("roughness", "anisotropic", "metallic", "spec_trans", "specular", "spec_tint", "sheen",
                      "sheen_tint", "flatness", "clearcoat", "clearcoat_gloss")
PRINCIPLED_RATES = ("diffuse_reflectance_sampling_rate", "main_specular_sampling_rate", "clearcoat_sampling_rate")
PATH_KEYS["principled"] = ("base_color", *PRINCIPLED_WEIGHTS, "eta", *PRINCIPLED_RATES)
THIN_WEIGHTS = ("roughness", "anisotropic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "flatness")
THIN_RATES = ("diffuse_reflectance_sampling_rate", "specular_reflectance_sampling_rate",
              "specular_transmittance_sampling_rate", "diffuse_transmittance_sampling_rate")
PATH_KEYS["principledthin"] = ("base_color", *THIN_WEIGHTS, "eta", "diff_trans", *THIN_RATES)
PATH_KEYS["null"] = ()  # no parameters
ANISOTROPIC = ("roughconductor", "roughdielectric")

ALPHA_EDGES = (1.0, 0.999, 0.5, 0.1, 0.01, 2e-3, SMOOTH_ALPHA * (1 + 2.0**-20), SMOOTH_ALPHA,
               SMOOTH_ALPHA * (1 - 2.0**-20), 9e-4, 5e-4, 1e-4, 1e-5, 1e-7, 2.0**-63, 2.0**-64, 2.0**-75, 1e-30,
               FLOAT32_TINY, 1e-45)


def alphas():
    """A roughness anywhere in (0, 1]: the tested range 1e-3 .. 1, the effectively smooth region below
    SMOOTH_ALPHA (to float32's smallest), and its edges."""
    return st.one_of(st.sampled_from(ALPHA_EDGES), finite(SMOOTH_ALPHA, 1.0),
                     st.floats(-149.0, 0.0).map(lambda e: 2.0 ** e), magnitudes(1e-45, 1.0))


def reflectances(scalar=True):
    """A colour anywhere in its range: black, in [0, 1], or anywhere in float32's; three numbers, or with
    `scalar` (Mitsuba's names of it take one) one."""
    triples = st.one_of(st.sampled_from([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), vectors(3, 0.0, 1.0),
                        st.lists(magnitudes(), min_size=3, max_size=3))
    return st.one_of(triples, st.sampled_from([0.0, 1.0]), magnitudes()) if scalar else triples


IOR_NEAR = (2.0**-23, 2.0**-20, 1e-6, 1e-4, 1e-3, 1e-2)


@st.composite
def ior_pairs(draw, distinct):
    """(int_ior, ext_ior), each a number, a named medium (in any case) or None (the key left out): anywhere in
    (0, float32's max], int_ior above or below ext_ior, near it (within float32's step), equal to it (for the
    BSDFs that take equal indices: `distinct` False) or far from it."""
    names = st.tuples(st.sampled_from(sorted(IORS)), st.sampled_from([str, str.upper, str.title])).map(
        lambda t: t[1](t[0]))
    plausible = st.one_of(finite(1.0, 3.0), st.sampled_from([1.0, 1.5, 2.419, 4.0]))
    kind = draw(st.sampled_from(["anywhere", "plausible", "named", "near", "below", "far", "equal"]))
    if kind == "anywhere":
        pair = [draw(st.one_of(st.none(), magnitudes(1e-45), plausible, names)) for _ in range(2)]
    elif kind == "plausible":
        pair = [draw(st.one_of(st.none(), plausible)) for _ in range(2)]
    elif kind == "named":
        pair = [draw(st.one_of(st.none(), names)) for _ in range(2)]
    elif kind == "equal":
        value = draw(st.one_of(plausible, names, magnitudes(1e-45)))
        pair = [value, value]
    else:
        ext = draw(st.one_of(plausible, finite(0.1, 10.0)))
        if kind == "near":
            step = draw(st.sampled_from(IOR_NEAR)) * draw(st.sampled_from([1.0, -1.0]))
            inside = float(np.float32(ext * (1 + step)))
        elif kind == "below":
            inside = ext * draw(finite(0.05, 0.999))
        else:  # far: a ratio up to 2^16, the most rule 5 takes (R^2 <= 2^32)
            inside = ext * 2.0 ** (draw(finite(1.0, 17.0)) * draw(st.sampled_from([1.0, -1.0])))
        pair = [inside, ext]
        if draw(st.booleans()):
            pair.reverse()
    if distinct and pair[0] is not None and pair[0] == pair[1] and draw(st.booleans()):
        pair[1] = None  # equal indices are refused here: now and then the default instead
    return pair


@st.composite
def path_materials(draw):
    """A material of the path model of any BSDF (raytrace/scene/bsdfs.py's), each of its keys (PATH_KEYS)
    given or not, anywhere in its accepted range: reflectances black to float32's largest (by `colour` or the
    type's own name), eta and k anywhere or a named metal, alpha from 1 to float32's smallest (the effectively
    smooth region below SMOOTH_ALPHA included) or alpha_u != alpha_v, GGX or Beckmann, indices of refraction
    anywhere, above and below each other, near and far, numbers or named media, nonlinear or not, a coat's
    specular_reflectance 0 to anywhere; a principled's weights 0 to 1 (and their edges), its eta anywhere
    (beside specular or not), its sampling rates 0 to 1024; a principledthin's weights, diff_trans 0 to 2, eta
    2^-16 to 2^16 and beyond, its rates 2^-10 to 1024. Values beyond the rules between them are left to the checks."""
    bsdf = draw(st.sampled_from(BSDFS))
    material = {"type": bsdf} if bsdf != "diffuse" or draw(st.booleans()) else {}
    if bsdf in REFLECTANCE_NAMES and draw(st.booleans()):
        material[REFLECTANCE_NAMES[bsdf]] = draw(reflectances())
    elif bsdf == "diffuse" or draw(st.booleans()):
        material["colour"] = draw(reflectances(scalar=False))
    if bsdf in ("conductor", "roughconductor"):
        if draw(st.booleans()):
            material["material"] = draw(st.sampled_from(sorted(CONDUCTORS)))
        else:
            for key in ("eta", "k"):
                if draw(st.booleans()):
                    material[key] = draw(number_or_vector(st.one_of(magnitudes(), finite(0.0, 5.0))))
    if bsdf in PATH_KEYS and "distribution" in PATH_KEYS[bsdf]:
        if draw(st.booleans()):
            material["distribution"] = draw(st.sampled_from(DISTRIBUTIONS))
        if bsdf in ANISOTROPIC and draw(st.booleans()):
            material["alpha_u"] = draw(alphas())
            material["alpha_v"] = draw(alphas())
        elif draw(st.sampled_from([True, True, False])):
            material["alpha"] = draw(alphas())
    if "int_ior" in PATH_KEYS.get(bsdf, ()):
        for key, value in zip(IOR_KEYS, draw(ior_pairs(BY_NAME[bsdf].distinct_iors))):
            if value is not None:
                material[key] = value
    if bsdf in ("plastic", "roughplastic"):
        if draw(st.booleans()):
            material["nonlinear"] = draw(st.booleans())
        if draw(st.booleans()):
            material["specular_reflectance"] = draw(reflectances())
    if bsdf == "principled":
        for key in PRINCIPLED_WEIGHTS:  # their edges, one ulp within them, anywhere between
            if draw(st.booleans()):
                edges = st.sampled_from([0.0, 1.0, 2.0**-24, 1 - 2.0**-24])
                material[key] = draw(st.one_of(edges, finite(0.0, 1.0)))
        if draw(st.booleans()):  # near 1 (1.001 with transmission), below it, to rule 6's edges and beyond
            material["eta"] = draw(st.one_of(st.sampled_from([1.0, 1.001, 1 + 2.0**-23, 0.5, 2.0**-63, 2.0**63]),
                                             finite(0.2, 5.0), magnitudes(1e-45)))
        for key in PRINCIPLED_RATES:
            if draw(st.booleans()):
                material[key] = draw(st.one_of(st.sampled_from([0.0, 2.0**-10, 1.0, 1024.0]), finite(0.0, 1024.0)))
    if bsdf == "principledthin":
        for key in THIN_WEIGHTS:
            if draw(st.booleans()):
                material[key] = draw(st.one_of(st.sampled_from([0.0, 1.0, 2.0**-24, 1 - 2.0**-24]), finite(0.0, 1.0)))
        if draw(st.booleans()):
            material["diff_trans"] = draw(st.one_of(st.sampled_from([0.0, 1.0, 2.0, 2 - 2.0**-23]), finite(0.0, 2.0)))
        if draw(st.booleans()):  # 1 (no reflection), below it, to its bounds and beyond
            material["eta"] = draw(st.one_of(st.sampled_from([1.0, 0.5, 0.2, 2.0**-16, 2.0**16, 2.0**17]),
                                             finite(0.2, 5.0), magnitudes(1e-45)))
        for key in THIN_RATES:
            if draw(st.booleans()):
                material[key] = draw(st.one_of(st.sampled_from([2.0**-10, 1.0, 1024.0, 0.0]), finite(2.0**-10, 1024.0)))
    return material


def textures(draw, slot_is_float, files):
    """A texture's table (raytrace/scene/texture_lookups.py): a checkerboard of any colours or a bitmap of a 2 x 2
    image, raw or not, of any filter, wrap mode and to_uv (a bitmap's file is added to `files`)."""
    to_uv = [draw(vectors(3, -1e3, 1e3)), draw(vectors(3, -1e3, 1e3))]
    if draw(st.booleans()):
        colours = (finite(0.0, 1.0) if slot_is_float else number_or_vector(st.one_of(finite(0.0, 1.0), magnitudes())))
        return {"type": "checkerboard", "color0": draw(colours), "color1": draw(colours), "to_uv": to_uv}
    name = f"map{len(files)}.png"
    files.append(ImageFile(name, ".png", 2, 2, draw(st.sampled_from([1, 3])), "uint8",
                           tuple(draw(st.lists(finite(0.0, 1.0), min_size=1, max_size=4)))))
    return {"type": "bitmap", "filename": name, "raw": draw(st.booleans()), "to_uv": to_uv,
            "filter_type": draw(st.sampled_from(["nearest", "bilinear", "trilinear", "anisotropic"])),
            "wrap_mode": draw(st.sampled_from(["repeat", "mirror", "clamp"]))}


TEXTURED_KEYS = {"colour": False, "reflectance": False, "specular_reflectance": False, "diffuse_reflectance": False,
                 "alpha": True, "alpha_u": True, "alpha_v": True}


@st.composite
def wrapped_and_textured(draw, materials, shapes):
    """Issue 58's keys on the materials drawn (changed in place): a texture for some textured parameters (and a
    normalmap or bumpmap), one-sided materials and back sides, and blends and masks of them, now and then nested,
    which the shapes then use. Returns the image files the textures name."""
    files = []
    names = list(materials)
    for name in names:
        material = materials[name]
        kind = material.get("type", "diffuse")
        for key, is_float in TEXTURED_KEYS.items():
            if key in material and draw(st.integers(0, 3)) == 0 and not (kind == "roughplastic" and key == "alpha"):
                material[key] = textures(draw, is_float, files)
        if draw(st.integers(0, 5)) == 0:
            material[draw(st.sampled_from(["normalmap", "bumpmap"]))] = textures(draw, True, files)
            if draw(st.booleans()) and "bumpmap" in material:
                material["bump_scale"] = draw(st.one_of(magnitudes(1e-45), finite(1e-3, 10.0)))
            if draw(st.booleans()):
                material["mirrored_maps"] = draw(st.booleans())
        if BY_NAME[kind].front_only and draw(st.integers(0, 3)) == 0:
            material["two_sided"] = False
    for i in range(draw(st.integers(0, 3))):
        kind, name = draw(st.sampled_from(["blendbsdf", "mask"])), f"w{i}"
        weight = textures(draw, True, files) if draw(st.booleans()) else draw(finite(0.0, 1.0))
        inner = draw(st.sampled_from(names))
        materials[name] = ({"type": "blendbsdf", "weight": weight, "bsdfs": [inner, draw(st.sampled_from(names))]}
                           if kind == "blendbsdf" else {"type": "mask", "opacity": weight, "bsdf": inner})
        names.append(name)
    for shape in shapes:
        if draw(st.booleans()):
            shape["material"] = draw(st.sampled_from(names))
    if len(names) > 1 and draw(st.integers(0, 3)) == 0:
        front, back = draw(st.sampled_from(names)), draw(st.sampled_from(names))
        if front != back and "back" not in materials[back] and materials[back].get("two_sided", True):
            materials[front]["back"] = back
    return tuple(files)


@st.composite
def path_scenes(draw):
    """SMALL_SCENE in the path model, 8 x 8: a floor, a sphere and a triangle, perhaps a disk and a cylinder under
    any to_world, of up to three materials of any BSDF (the first perhaps with a float colour map), some of them
    emitting any radiance (black, or reflecting by their material), a light of any radiance (reflecting by a
    material or not), an environment (none, constant or an envmap) of any radiance or scale and texels, any max_depth,
    perhaps an rr_depth and hidden emitters, 1 to 4 pixel and light samples. Most values lie anywhere
    in their keys' ranges, so that the rules between them (raytrace/scene/ranges.py) decide."""
    table = copy.deepcopy(SMALL_SCENE)
    table["image"] = {"width": 8, "height": 8}
    table["render"] = {"shading": "path", "sampler": "sobol", "light_sampler": "sobol",
                       "spp": draw(st.integers(1, 4)), "light_samples": draw(st.integers(1, 4)),
                       "max_depth": draw(st.one_of(st.just(-1), st.integers(0, 8), st.integers(0, 1024)))}
    if draw(st.booleans()):  # Russian roulette from any vertex; the emitters hidden from the camera
        table["render"].update(rr_depth=draw(st.one_of(st.integers(1, 8), st.just(2**31 - 1))),
                               hide_emitters=draw(st.booleans()))
    if draw(st.booleans()):  # AOVs beside the image (raytrace/aovs.py): short names and Mitsuba's name:type items
        table["render"]["aovs"] = ",".join(draw(st.lists(st.sampled_from(
            [*aov_types.SHORT, *(f"n{i}:{kind}" for i, kind in enumerate(aov_types.TYPES))]), unique=True,
            max_size=4)))
    names = [f"m{i}" for i in range(draw(st.integers(1, 3)))]
    table["materials"] = {name: draw(path_materials()) for name in names}
    light = table["lights"][0]
    del light["colour"]
    light["radiance"] = draw(number_or_vector(magnitudes()))
    if draw(st.booleans()):
        light["material"] = draw(st.sampled_from(names))
    pick = lambda: draw(st.sampled_from(names))  # noqa: E731
    table["shapes"] = [{**table["shapes"][0], "material": pick()},
                       {"type": "ellipsoid", "center": [0.0, 0.0, 0.6], "axes": [[0.4, 0, 0], [0, 0.4, 0], [0, 0, 0.4]],
                        "material": pick()},
                       {"type": "triangle", "vertices": [[-0.9, 0.3, 0.1], [-0.3, 0.3, 0.1], [-0.6, 0.3, 0.9]],
                        "material": pick()}]
    for kind in ("disk", "cylinder"):
        if draw(st.booleans()):
            table["shapes"].append({**draw(analytic_shapes(kind)), "material": pick()})
    for shape in table["shapes"]:  # emitting shapes of any radiance, black or reflecting (the sphere is one)
        emitting(draw, shape, radiances=st.one_of(finite(0.0, 4.0), magnitudes()))
    files = ()
    if draw(st.booleans()):  # a float colour map, its texels too anywhere in float32's range
        files += (ImageFile("colour.exr", ".exr", 2, 2, 3, "float",
                            tuple(draw(st.lists(magnitudes(), min_size=1, max_size=4)))),)
        table["materials"]["m0"]["texture"] = "colour.exr"
    files += draw(wrapped_and_textured(table["materials"], table["shapes"]))
    if draw(st.booleans()):
        table["emitters"] = draw(st.lists(delta_lights(st.one_of(finite(0.0, 4.0), magnitudes())), min_size=1,
                                          max_size=2))
    kind = draw(st.sampled_from(["none", "constant", "envmap"]))
    if kind == "constant":
        table["environment"] = {"type": "constant", "radiance": draw(number_or_vector(magnitudes()))}
    elif kind == "envmap":
        texels = tuple(draw(st.lists(magnitudes(), min_size=1, max_size=4)))
        files += (ImageFile("sky.exr", ".exr", 4, 2, 3, "float", texels),)
        table["environment"] = {"type": "envmap", "filename": "sky.exr"}
        if draw(st.booleans()):
            table["environment"]["scale"] = draw(magnitudes())
    return SceneExample(table, files)


ENVMAP_FORMATS = {".exr": ([3, 4, 1], ["float", "half"]), ".hdr": ([3], ["float"]),
                  ".tif": ([3, 1, 4], ["float", "uint16", "uint8"]), ".png": ([3, 1, 2, 4], ["uint8", "uint16"])}


@st.composite
def envmap_images(draw, stem="sky"):
    """An environment map written as a real image: mostly EXR and HDR (float radiance, texels anywhere in float32's
    range or in [0, 1]), some 8- and 16-bit ones (sRGB-decoded); 1 to 8 texels wide, 2 to 4 high, now and then
    1 (one row is refused)."""
    ext = draw(st.sampled_from([".exr", ".exr", ".hdr", ".hdr", ".tif", ".png"]))
    channels, types = ENVMAP_FORMATS[ext]
    values = st.one_of(magnitudes(), finite(0.0, 1.0))
    height = draw(st.sampled_from([2, 2, 3, 4, 1]))
    return ImageFile(stem + ext, ext, draw(st.integers(1, 8)), height, draw(st.sampled_from(channels)),
                     draw(st.sampled_from(types)), tuple(draw(st.lists(values, min_size=1, max_size=4))))


@st.composite
def path_scenes_with_files(draw):
    """path_scenes for the command line: its environment map written as a real EXR, HDR, TIFF or PNG image of any
    size and texels, or replaced by a hostile file (files.py's random, truncated, damaged or odd images,
    directories); the map placed by up and forward or not; and in a third of them one to three of hostile_scenes'
    Mutations (so a path material's or the environment's keys get NaN, wrong types, extreme factors...). The
    hostile parts are drawn first, for the reason given in hostile_scenes."""
    environment = draw(st.sampled_from(["as drawn", "envmap", "envmap", "hostile envmap"]))
    hostile = draw(hostile_files("sky.exr")) if environment == "hostile envmap" else None
    changes = draw(mutations()) if draw(st.sampled_from([False, False, True])) else []
    example = draw(path_scenes())
    table, files = copy.deepcopy(example.table), list(example.files)
    if environment != "as drawn":
        files = [f for f in files if f.name != "sky.exr"]
        image = hostile if hostile is not None else draw(envmap_images())
        files.append(image)
        table["environment"] = {"type": "envmap", "filename": image.name}
        if draw(st.booleans()):
            table["environment"]["scale"] = draw(st.one_of(magnitudes(), finite(0.0, 4.0)))
        if draw(st.booleans()):
            up, forward = draw(frames())
            table["environment"].update(up=up, forward=forward)
    for change in changes:
        change.apply(table)
    return SceneExample(table, tuple(files))


@st.composite
def scenes_with_every_input(draw):
    """(SceneExample, {role: file name}): a valid path-model scene that reads a file of each kind, a colour
    texture, a mesh file and an environment map (formats an output can or cannot be written in), for the outputs
    that alias an input (commands.aliasing_command_lines)."""
    table = copy.deepcopy(SMALL_SCENE)
    table["render"] = {"shading": "path", "max_depth": 3, "spp": 1}
    table["lights"][0]["radiance"] = table["lights"][0].pop("colour")
    texture = draw(st.sampled_from([AssetCopy("grid.png", "textures/grid.png"),
                                    ImageFile("wood.exr", ".exr", 2, 2, 3, "half", (0.2, 0.5)),
                                    ImageFile("wood.tif", ".tif", 2, 2, 3, "uint8", (0.5,))]))
    mesh = draw(valid_mesh_files("tetra"))
    sky = draw(st.sampled_from([AssetCopy("sky.exr", "textures/sky.exr"),
                                ImageFile("sky.hdr", ".hdr", 4, 2, 3, "float", (0.1, 0.3, 0.2)),
                                ImageFile("sky.png", ".png", 4, 2, 3, "uint8", (0.5,))]))
    table["materials"]["white"]["texture"] = texture.name
    table["shapes"].append({"type": "mesh", "file": mesh.name, "material": "white", "scale": 0.3})
    table["environment"] = {"type": "envmap", "filename": sky.name}
    roles = {"scene": "scene.toml", "texture": texture.name, "mesh": mesh.name, "environment map": sky.name}
    return SceneExample(table, (texture, mesh, sky)), roles


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


# --- valid scenes with hostile files -------------------------------------------------------------------

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
