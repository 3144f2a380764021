"""The declarations of raytrace/scene/keys.py are what the scene reader enforces, key by key: the manual's table
of keys is generated from them (`python -m devtools.docs_tables`, checked by tests/test_docs.py), so each
declared bound, default and key list is checked here against the reader's real behaviour on a scene that has
every table. A bound declared but not
enforced, enforced but not declared, or a key accepted but not declared, fails one of these tests."""
import copy
import math

import numpy as np
import pytest

from helpers import ROOT
from raytrace.errors import InputError
from raytrace.scene import bsdfs, parse_scene
from raytrace.scene.keys import REQUIRED, TABLES
from raytrace.scene.ranges import MAX_IMAGE_SIDE
from raytrace.scene.scene_file import CAMERA_KEYS, RFILTER_KEYS
from raytrace.scene.model import DELTA_EMITTERS, fingerprint

SCENE_PATH = str(ROOT / "scenes" / "every_table.toml")  # textures are read relative to it (it need not exist)
RECTANGLE = {"center": [0.0, 0.0, 0.0], "size": [2.0, 2.0], "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0]}


def every_table():
    """A valid scene holding every table of keys.TABLES, each key given a value (Phong shading)."""
    return {
        "ambient": [0.1, 0.1, 0.1],
        "camera": {"position": [0.0, -3.0, 1.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0], "fov": 45.0,
                   "focal_length": 1.0},
        "image": {"width": 8, "height": 8},
        "render": {"spp": 4, "light_samples": 1, "sampler": "grid", "light_sampler": "random", "shading": "phong",
                   "aovs": "albedo,dd:depth"},
        "lights": [{"center": [0.0, 0.0, 1.9], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                    "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0]}],
        "materials": {"m": {"colour": [0.5, 0.5, 0.5], "shininess": 16.0,
                            "texture": "../assets/textures/bricks_colour.png",
                            "normal_map": "../assets/textures/bricks_normal.png",
                            "height_map": "../assets/textures/bricks_height.png", "height_scale": 0.01,
                            "uv_scale": [2.0, 2.0], "uv_offset": [0.0, 0.0], "wrap": "repeat"}},
        "shapes": [
            {"type": "rectangle", "material": "m", **RECTANGLE},
            {"type": "triangle", "material": "m", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
             "uv": [[0, 0], [1, 0], [0, 1]]},
            {"type": "mesh", "material": "m", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]},
            {"type": "mesh", "material": "m", "generate": {"shape": "sphere", "triangles": 20}, "scale": 0.5,
             "rotate": {"axis": [0, 0, 1], "degrees": 30.0}, "translate": [0.0, 0.0, 0.5], "smooth": True},
            {"type": "ellipsoid", "material": "m", "center": [0.0, 0.0, 0.5],
             "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]},
            {"type": "disk", "material": "m", "flip_normals": True,
             "to_world": [[0.3, 0, 0, 0], [0, 0.2, 0, 0.1], [0, 0, 1, 0.5], [0, 0, 0, 1]]},
            {"type": "cylinder", "material": "m", "p0": [0.0, 0.0, 0.1], "p1": [0.1, 0.0, 0.5], "radius": 0.2,
             "flip_normals": True, "to_world": [[1, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0.2], [0, 0, 0, 1]]},
            {"type": "instance", "group": "g", "scale": 0.5, "rotate": {"axis": [0, 0, 1], "degrees": 10.0},
             "translate": [0.2, 0.0, 0.3]}],
        "groups": {"g": {"shapes": [{"type": "mesh", "material": "m", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                                     "faces": [[0, 1, 2]]}]}}}


# Where each declared table sits in every_table(), and the prefix its errors carry.
PLACES = {"": ((), ""), "camera": (("camera",), "camera."), "image": (("image",), "image."),
          "render": (("render",), "render."), "lights[]": (("lights", 0), "lights[0]."),
          "materials.NAME": (("materials", "m"), "materials.m."),
          'shapes[] type = "rectangle"': (("shapes", 0), "shapes[0]."),
          'shapes[] type = "triangle"': (("shapes", 1), "shapes[1]."),
          'shapes[] type = "mesh"': (("shapes", 2), "shapes[2]."),
          'shapes[] type = "mesh", from a file or generated': (("shapes", 3), "shapes[3]."),
          "generate": (("shapes", 3, "generate"), "shapes[3].generate."),
          "rotate": (("shapes", 3, "rotate"), "shapes[3].rotate."),
          'shapes[] type = "ellipsoid"': (("shapes", 4), "shapes[4]."),
          'shapes[] type = "disk"': (("shapes", 5), "shapes[5]."),
          'shapes[] type = "cylinder"': (("shapes", 6), "shapes[6]."),
          'shapes[] type = "instance"': (("shapes", 7), "shapes[7]."),
          "groups.NAME": (("groups", "g"), "groups.g."),
          "shapes[]": (("shapes", 4), "shapes[4].")}
DIRECT = "lights[] (direct, path)"
ENVIRONMENT = "environment"
SHAPE = {'shapes[] type = "rectangle"', 'shapes[] type = "triangle"', 'shapes[] type = "mesh"',
         'shapes[] type = "mesh", from a file or generated', 'shapes[] type = "ellipsoid"', 'shapes[] type = "disk"',
         'shapes[] type = "cylinder"', 'shapes[] type = "instance"'}


# A material of each BSDF (the path model's), given every key of its type's table that one table can hold
# together (a conductor's material instead of eta and k, alpha_u and alpha_v instead of alpha, a principled's
# specular instead of eta: tests/test_bsdf_keys.py)
BSDF_TABLES = {bsdf.table: bsdf.name for bsdf in bsdfs.DECLARED}
EVERY_BSDF_KEY = {
    "diffuse": {"reflectance": [0.5, 0.4, 0.3]},
    "conductor": {"eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1], "specular_reflectance": [0.9, 0.8, 0.7]},
    "dielectric": {"int_ior": "water", "ext_ior": 1.0},
    "roughconductor": {"eta": 0.2, "k": [3.9, 2.4, 2.1], "specular_reflectance": 0.8, "distribution": "beckmann",
                       "alpha": 0.3},
    "thindielectric": {"int_ior": 1.5, "ext_ior": "AIR"},
    "roughdielectric": {"int_ior": "diamond", "ext_ior": 1.2, "distribution": "ggx", "alpha": 0.2},
    "plastic": {"diffuse_reflectance": [0.1, 0.27, 0.36], "nonlinear": True, "int_ior": 1.9, "ext_ior": "air",
                "specular_reflectance": 0.8},
    "roughplastic": {"diffuse_reflectance": 0.3, "nonlinear": True, "int_ior": "pet", "ext_ior": 1.1,
                     "specular_reflectance": [1.0, 0.9, 0.8], "distribution": "beckmann", "alpha": 0.1},
    "null": {},
    "principled": {"base_color": [0.8, 0.3, 0.2], "roughness": 0.3, "anisotropic": 0.2, "metallic": 0.1,
                   "spec_trans": 0.4, "specular": 0.6, "spec_tint": 0.3, "sheen": 0.5, "sheen_tint": 0.2,
                   "clearcoat": 0.7, "clearcoat_gloss": 0.8, "diffuse_reflectance_sampling_rate": 1.5,
                   "main_specular_sampling_rate": 0.5, "clearcoat_sampling_rate": 2.0},
    "principledthin": {"base_color": [0.3, 0.6, 0.2], "roughness": 0.4, "anisotropic": 0.3, "spec_trans": 0.2,
                       "eta": 1.33, "spec_tint": 0.1, "sheen": 0.5, "sheen_tint": 0.2, "flatness": 0.4,
                       "diff_trans": 1.1, "diffuse_reflectance_sampling_rate": 1.5,
                       "specular_reflectance_sampling_rate": 0.5, "specular_transmittance_sampling_rate": 2.0,
                       "diffuse_transmittance_sampling_rate": 0.75}}
# A blend and a mask of material "m", every key given; a textured reflectance (a bitmap, every key of its kind)
WRAPPER_TABLES = {bsdfs.table_name(name): name for name in bsdfs.WRAPPER_KEYS}
EVERY_WRAPPER_KEY = {"blendbsdf": {"weight": 0.3, "bsdfs": ["m", "m"]}, "mask": {"opacity": 0.7, "bsdf": "m"}}
# A delta light of each type ([[emitters]], the radiometric models'), every key it can hold together (a point's
# position, not its to_world; a projector's fov, not its focal_length; a spot's texture with its own tests)
EMITTER_TABLES = {f'emitters[] type = "{kind}"': kind for kind in DELTA_EMITTERS}
DOWN = [[1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 2.0], [0.0, 0.0, 0.0, 1.0]]
EVERY_EMITTER_KEY = {
    "point": {"position": [0.0, 0.0, 1.5], "intensity": [1.0, 2.0, 3.0]},
    "spot": {"to_world": DOWN, "intensity": 2.0, "cutoff_angle": 30.0, "beam_width": 20.0},
    "directional": {"direction": [0.0, 0.2, -1.0], "irradiance": [1.0, 0.9, 0.8]},
    "projector": {"to_world": DOWN, "irradiance": 0.5, "scale": 2.0, "fov": 40.0, "fov_axis": "y"}}
TEXTURE = "texture"
EVERY_TEXTURE_KEY = {"type": "bitmap", "filename": "../assets/textures/bricks_colour.png", "raw": False,
                     "filter_type": "nearest", "wrap_mode": "mirror", "to_uv": [[2.0, 0.0, 0.1], [0.0, 2.0, 0.2]]}


def radiometric(scene, shading):
    """every_table() turned to a radiometric model: no ambient term, the light's colour a radiance."""
    del scene["ambient"]
    scene["render"]["shading"] = shading
    light = scene["lights"][0]
    light["radiance"] = light.pop("colour")


def scene_with(table_name, key_name=None):
    """(the scene as a dict, the table `table_name` inside it, its error prefix); the environment is an envmap
    with every key of its own, or a constant one for the key `radiance`."""
    scene = every_table()
    if table_name == DIRECT:
        radiometric(scene, "direct")
        return scene, scene["lights"][0], "lights[0]."
    if table_name == ENVIRONMENT:  # the path model's table
        radiometric(scene, "path")
        scene["environment"] = ({"type": "constant", "radiance": [1.0, 1.0, 1.0]} if key_name == "radiance" else
                                {"type": "envmap", "filename": "../assets/textures/sky.exr", "scale": 1.0,
                                 "up": [0.0, 1.0, 0.0], "forward": [0.0, 0.0, 1.0]})
        return scene, scene["environment"], "environment."
    if table_name in BSDF_TABLES:  # the path model's material "b" of that type
        kind = BSDF_TABLES[table_name]
        radiometric(scene, "path")
        scene["materials"]["b"] = {"type": kind, **copy.deepcopy(EVERY_BSDF_KEY[kind])}
        return scene, scene["materials"]["b"], "materials.b."
    if table_name in WRAPPER_TABLES:
        kind = WRAPPER_TABLES[table_name]
        radiometric(scene, "path")
        scene["materials"]["b"] = {"type": kind, **copy.deepcopy(EVERY_WRAPPER_KEY[kind])}
        return scene, scene["materials"]["b"], "materials.b."
    if table_name in EMITTER_TABLES or table_name == "emitters[]":
        radiometric(scene, "direct")
        kind = EMITTER_TABLES.get(table_name, "point")
        scene["emitters"] = [{"type": kind, **copy.deepcopy(EVERY_EMITTER_KEY[kind])}]
        return scene, scene["emitters"][0], "emitters[0]."
    if table_name == TEXTURE:  # a bitmap, or for a mesh_attribute's own keys, one of those
        radiometric(scene, "path")
        texture = ({"type": "mesh_attribute", "name": "vertex_color", "scale": 0.5} if key_name in ("name", "scale")
                   else copy.deepcopy(EVERY_TEXTURE_KEY))
        scene["materials"]["b"] = {"type": "diffuse", "reflectance": texture}
        return scene, scene["materials"]["b"]["reflectance"], "materials.b.reflectance."
    where, prefix = PLACES[table_name]
    node = scene
    for step in where:
        node = node[step]
    if table_name == "camera":  # a type's own keys in a camera of that type
        own = {"aperture_radius": "thinlens", "focus_distance": "thinlens", "size": "orthographic"}
        if key_name in own:
            node.update(type=own[key_name], aperture_radius=0.1, focus_distance=3.0, size=[2.0, 2.0])
            for other in ("fov", "aperture_radius", "focus_distance", "size"):
                if other not in CAMERA_KEYS[own[key_name]]:
                    del node[other]
    if table_name == "image" and key_name is not None:
        if key_name.startswith("crop_"):  # a window anywhere in the largest film
            node.update(width=MAX_IMAGE_SIDE, height=MAX_IMAGE_SIDE)
        kind = [k for k, keys in RFILTER_KEYS.items() if key_name in keys]
        if kind:  # a filter's own keys with that filter
            node["rfilter"] = kind[0]
    return scene, node, prefix


def declared_keys(table_name):
    names = {key.name for key in TABLES[table_name]}
    if table_name == "materials.NAME" or table_name in BSDF_TABLES or table_name in WRAPPER_TABLES:
        return sorted({key.name for key in TABLES["materials.NAME"]} | set(bsdfs.KEY_NAMES))
    if table_name in EMITTER_TABLES:
        names |= {key.name for key in TABLES["emitters[]"]}
    return sorted(names | ({key.name for key in TABLES["shapes[]"]} if table_name in SHAPE else set()))


def test_every_declared_table_is_exercised():
    assert set(TABLES) == (set(PLACES) | {DIRECT, ENVIRONMENT, TEXTURE, "emitters[]"} | set(BSDF_TABLES)
                           | set(WRAPPER_TABLES) | set(EMITTER_TABLES))
    for table_name in EMITTER_TABLES:
        parse_scene(scene_with(table_name)[0], SCENE_PATH)
    parse_scene(every_table(), SCENE_PATH)
    for table_name in (TEXTURE, *WRAPPER_TABLES):
        parse_scene(scene_with(table_name)[0], SCENE_PATH)
    parse_scene(scene_with(DIRECT)[0], SCENE_PATH)
    parse_scene(scene_with(ENVIRONMENT)[0], SCENE_PATH)
    for table_name in BSDF_TABLES:
        parse_scene(scene_with(table_name)[0], SCENE_PATH)


@pytest.mark.parametrize("table_name", list(TABLES))
def test_the_declared_keys_are_the_accepted_keys(table_name):
    """An unknown key is refused with the declared list, in order: the list the manual prints."""
    if table_name in ("shapes[]", "emitters[]"):
        pytest.skip("shared by every shape (emitter) table, checked with each of them")
    scene, table, prefix = scene_with(table_name)
    table["no_such_key"] = 1
    with pytest.raises(InputError) as error:
        parse_scene(scene, SCENE_PATH)
    assert error.value.key == prefix + "no_such_key"
    assert error.value.problem == f"unknown key (expected one of: {', '.join(declared_keys(table_name))})"


def cases():
    """(table, key, value, accepted) at and beyond each declared bound of a number or integer key."""
    for table_name, keys in TABLES.items():
        for key in keys:
            if key.kind not in ("number", "integer"):
                continue
            step = 1 if key.kind == "integer" else None
            for bound, outward in ((key.low, -1), (key.high, 1)):
                if math.isinf(bound):
                    continue
                beyond = bound + outward * (step or max(abs(bound) * 1e-6, 1e-6))
                yield table_name, key, beyond, False
                open_end = key.open_low if outward < 0 else key.open_high
                yield table_name, key, int(bound) if step else float(bound), not open_end


@pytest.mark.parametrize("table_name, key, value, accepted", list(cases()),
                         ids=[f"{t}.{k.name}={v:g}" for t, k, v, _ in cases()])
def test_each_declared_bound_is_the_readers(table_name, key, value, accepted):
    """A value just beyond a declared bound is refused, naming the key and the value; the bound itself is
    accepted where the declaration closes the interval (a scene may still refuse it for a reason between keys,
    as a triangle count beyond the memory: those cases are skipped)."""
    scene, table, prefix = scene_with(table_name, key.name)
    if key.name == "triangles" and value > 1000:
        pytest.skip("a mesh this large is refused by the memory there is, not by the bound")
    if table_name == ENVIRONMENT and key.name == "scale" and accepted and value > 1:
        pytest.skip("a map this bright is refused by the path model's brightness (ranges.py's rule 5), not by the "
                    "bound")
    if key.name in ("aperture_radius", "focus_distance") and value > 1 and accepted:
        pytest.skip("a lens this large makes the scene's extent 2^60, whose ellipsoid is then refused (ranges.py's "
                    "rule 3), not by the bound")
    if key.name == "shape_index" and value > 0 and accepted:
        pytest.skip("a shape_index above 0 needs a .serialized file holding that many shapes, not only the bound")
    if table_name == 'emitters[] type = "spot"' and key.name == "beam_width" and value > table["cutoff_angle"]:
        pytest.skip("a beam this wide is refused by the rule between the two angles (beam_width <= cutoff_angle), "
                    "not by the bound")
    if table_name == 'emitters[] type = "projector"' and key.name == "scale" and accepted and value > 1:
        pytest.skip("a projector this bright is refused by the brightness rules (ranges.py), not by the bound")
    if table_name == 'emitters[] type = "projector"' and key.name == "focal_length":  # instead of fov
        del table["fov"], table["fov_axis"]
    if key.name in ("max_depth", "rr_depth"):  # the path model's keys
        radiometric(scene, "path")
    if key.name == "bsdf_samples":  # the direct model's
        radiometric(scene, "direct")
    if table_name in BSDF_TABLES:
        partner = bsdfs.BY_NAME[BSDF_TABLES[table_name]].parameter(key.name).together
        if partner:  # alpha_u and alpha_v, given together and instead of alpha
            del table["alpha"]
            table[partner] = 0.5
        if key.name == "eta" and "specular" in table:  # a principled's eta, instead of its specular
            del table["specular"]
    table[key.name] = value
    if accepted:
        parse_scene(scene, SCENE_PATH)
    else:
        with pytest.raises(InputError) as error:
            parse_scene(scene, SCENE_PATH)
        assert error.value.key == prefix + key.name and error.value.value == value


@pytest.mark.parametrize("table_name", list(TABLES))
def test_each_declared_default_is_the_readers(table_name):
    """A key left out takes its declared default (the parsed scene is the same as with the default written
    out), and a required key left out is refused as missing."""
    for key in TABLES[table_name]:
        scene, table, prefix = scene_with(table_name)
        if key.name not in table:
            continue
        del table[key.name]
        if key.required:
            with pytest.raises(InputError) as error:
                parse_scene(scene, SCENE_PATH)
            assert error.value.key in (prefix + key.name, prefix.rstrip(".")), key.name
            continue
        if key.default is None or key.kind in ("table", "tables", "named-tables"):
            continue  # an optional feature left out (a texture, a transform): nothing to compare
        without = parse_scene(copy.deepcopy(scene), SCENE_PATH)
        table[key.name] = list(key.default) if isinstance(key.default, tuple) else key.default
        with_default = parse_scene(scene, SCENE_PATH)
        assert repr(without) == repr(with_default), key.name
        if table_name in BSDF_TABLES:  # the material itself, every value of it
            assert fingerprint(without.materials) == fingerprint(with_default.materials), key.name


def test_the_default_table_declares_required_keys_as_required():
    assert all((key.default is REQUIRED) == key.required for keys in TABLES.values() for key in keys)
    assert np.isfinite([k.low for keys in TABLES.values() for k in keys if k.low > -math.inf]).all()
