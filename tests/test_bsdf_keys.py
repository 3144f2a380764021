"""The BSDFs' keys in a scene file, as raytrace/scene/bsdfs.py declares them: each key read into its Material field,
defaulted (Mitsuba's defaults, per type), range-checked in one line naming the file, the key and the value;
Mitsuba's names beside raytrace's own (not both); named media and metals; the rough interfaces' distinct indices;
and a material built in Python checked the same way (model_check.py). Reading only: nothing here renders (the
rendering of each BSDF is its kernel tests' matter)."""
import dataclasses
import re

import numpy as np
import pytest

import raytrace
from raytrace.errors import InputError
from raytrace.renderer.program import Features
from raytrace.scene import bsdfs, model, named_materials, parse_scene
from raytrace.scene.keys import TABLES
from raytrace.scene.model_check import check_model

SOURCE = "scene.toml"


def scene(material, shading="path"):
    """A small scene of the shading model whose one shape has `material` (a table) as material "m"."""
    light = {"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0]}
    light.update({"colour": [1, 1, 1]} if shading == "phong" else {"radiance": 1.0})
    return {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "render": {"shading": shading}, "lights": [light],
            "materials": {"m": material},
            "shapes": [{"type": "rectangle", "center": [0, 0, 0], "size": [2, 2], "normal": [0, 0, 1],
                        "tangent": [1, 0, 0], "material": "m"}]}


def material(table, shading="path"):
    return parse_scene(scene(table, shading), SOURCE).materials[0]


def error(table, shading="path"):
    with pytest.raises(InputError) as info:
        parse_scene(scene(table, shading), SOURCE)
    line = str(info.value)
    assert "\n" not in line and line.startswith(f"{SOURCE}: materials.m."), line
    return line[len(f"{SOURCE}: materials.m."):]


def test_each_key_sets_its_field():
    """Every BSDF key of the scene file, given, lands in the Material field its declaration names."""
    m = material({"type": "roughconductor", "eta": [0.2, 0.9, 1.1], "k": 3.0, "specular_reflectance": 0.8,
                  "distribution": "beckmann", "alpha_u": 0.05, "alpha_v": 0.4})
    assert (m.bsdf, m.eta, m.k, m.distribution, m.alpha, m.alpha_v) == (
        "roughconductor", (0.2, 0.9, 1.1), (3.0, 3.0, 3.0), "beckmann", 0.05, 0.4)
    assert m.colour.tolist() == [0.8] * 3
    m = material({"type": "roughdielectric", "int_ior": 1.33, "ext_ior": 1.1, "alpha": 0.2, "distribution": "ggx"})
    assert (m.bsdf, m.int_ior, m.ext_ior, m.alpha, m.alpha_v, m.distribution) == (
        "roughdielectric", 1.33, 1.1, 0.2, None, "ggx")
    m = material({"type": "thindielectric", "int_ior": 1.7, "colour": [0.9, 1.0, 0.9]})
    assert (m.bsdf, m.int_ior, m.ext_ior, m.colour.tolist()) == ("thindielectric", 1.7, 1.000277, [0.9, 1.0, 0.9])
    m = material({"type": "plastic", "diffuse_reflectance": [0.1, 0.27, 0.36], "specular_reflectance": [1, 0.5, 0.25],
                  "nonlinear": True, "int_ior": 1.9, "ext_ior": 1.2})
    assert (m.bsdf, m.colour.tolist(), m.specular, m.nonlinear, m.int_ior, m.ext_ior) == (
        "plastic", [0.1, 0.27, 0.36], (1.0, 0.5, 0.25), True, 1.9, 1.2)
    m = material({"type": "roughplastic", "colour": [0.5, 0.2, 0.1], "alpha": 0.3, "distribution": "beckmann"})
    assert (m.bsdf, m.colour.tolist(), m.alpha, m.distribution) == ("roughplastic", [0.5, 0.2, 0.1], 0.3, "beckmann")
    assert material({"type": "diffuse", "reflectance": 0.25}).colour.tolist() == [0.25] * 3


@pytest.mark.parametrize("kind, expected", [
    ("plastic", dict(colour=[0.5] * 3, int_ior=1.49, ext_ior=1.000277, specular=(1.0, 1.0, 1.0), nonlinear=False)),
    ("roughplastic", dict(colour=[0.5] * 3, int_ior=1.49, ext_ior=1.000277, specular=(1.0, 1.0, 1.0),
                          nonlinear=False, alpha=0.1, alpha_v=None, distribution="ggx")),
    ("thindielectric", dict(colour=[1.0] * 3, int_ior=1.5046, ext_ior=1.000277)),
    ("roughdielectric", dict(colour=[1.0] * 3, int_ior=1.5046, ext_ior=1.000277, alpha=0.1, alpha_v=None,
                             distribution="ggx")),
    ("roughconductor", dict(colour=[1.0] * 3, eta=(0.0, 0.0, 0.0), k=(0.0, 0.0, 0.0), alpha=0.1, alpha_v=None,
                            distribution="ggx")),
])
def test_a_type_alone_takes_its_defaults(kind, expected):
    """Mitsuba's defaults per type: polypropylene in air for the plastics (a diffuse base of 0.5), BK7 in air for
    the glass, alpha 0.1; the distribution GGX, the scene file's default (Mitsuba's Beckmann is what its XML
    reader writes)."""
    m = material({"type": kind})
    for field, value in expected.items():
        got = getattr(m, field)
        assert (got.tolist() if isinstance(got, np.ndarray) else got) == value, field
    assert named_materials.IORS["polypropylene"] == 1.49 and named_materials.IORS["bk7"] == 1.5046


@pytest.mark.parametrize("table, line", [
    ({"type": "roughconductor", "alpha": 0.0}, "alpha = 0.0: must be > 0 and <= 1"),
    ({"type": "roughdielectric", "alpha": 1.5}, "alpha = 1.5: must be > 0 and <= 1"),
    ({"type": "roughplastic", "alpha": -0.1}, "alpha = -0.1: must be > 0 and <= 1"),
    ({"type": "roughconductor", "alpha_u": 0.2, "alpha_v": 2.0}, "alpha_v = 2.0: must be > 0 and <= 1"),
    ({"type": "roughdielectric", "alpha_u": 0.0, "alpha_v": 0.2}, "alpha_u = 0.0: must be > 0 and <= 1"),
    ({"type": "roughconductor", "distribution": "Beckmann"},
     "distribution = 'Beckmann': must be one of: ggx, beckmann; did you mean 'beckmann'?"),
    ({"type": "plastic", "nonlinear": 1}, "nonlinear = 1: must be true or false"),
    ({"type": "plastic", "int_ior": 0.0}, "int_ior = 0.0: must be > 0 and <= inf"),
    ({"type": "thindielectric", "ext_ior": -1.0}, "ext_ior = -1.0: must be > 0 and <= inf"),
    ({"type": "roughplastic", "int_ior": "glas"}, "int_ior = 'glas': must be a number or one of Mitsuba's names: "),
    ({"type": "plastic", "specular_reflectance": [1.0, -1.0, 1.0]},
     "specular_reflectance = [1.0, -1.0, 1.0]: must be a list of 3 finite numbers >= 0"),
    ({"type": "plastic", "diffuse_reflectance": -0.5}, "diffuse_reflectance = -0.5: must be >= 0"),
    ({"type": "conductor", "material": "gold"}, "material = 'gold': must be one of: Ag, Al,"),
    ({"type": "conductor", "material": "Auu"}, "did you mean 'Au'?"),
    ({"type": "plastic", "eta": 1.5}, 'eta = 1.5: is not a parameter of type = "plastic"'),
    ({"type": "roughplastic", "alpha_u": 0.1, "alpha_v": 0.1}, 'alpha_u = 0.1: is not a parameter of type = '
                                                               '"roughplastic"'),
    ({"type": "dielectric", "specular_reflectance": 1.0}, "specular_reflectance = 1.0: is not a parameter of type ="),
    ({"type": "diffuse", "distribution": "ggx"}, 'distribution = \'ggx\': is not a parameter of type = "diffuse"'),
])
def test_each_bad_value_is_one_line(table, line):
    assert line in error(table)


def test_the_range_of_a_number_or_a_name():
    """int_ior and ext_ior take a number in their range or one of Mitsuba's named media, in any case (Mitsuba
    lowercases the name), as the number it stands for."""
    for name, ior in named_materials.IORS.items():
        assert material({"type": "dielectric", "int_ior": name.upper()}).int_ior == ior
    assert material({"type": "plastic", "ext_ior": "Water"}).ext_ior == 1.333
    assert "did you mean 'water'?" in error({"type": "dielectric", "int_ior": "watter"})
    assert "int_ior = [1.5]: must be a finite number" in error({"type": "dielectric", "int_ior": [1.5]})


@pytest.mark.parametrize("table, line", [
    ({"type": "diffuse", "colour": [0.5] * 3, "reflectance": 0.5},
     "reflectance = 0.5: sets the same value as colour: give one or the other"),
    ({"type": "conductor", "colour": [1.0] * 3, "specular_reflectance": 0.5},
     "specular_reflectance = 0.5: sets the same value as colour"),
    ({"type": "plastic", "colour": [1.0] * 3, "diffuse_reflectance": 0.5},
     "diffuse_reflectance = 0.5: sets the same value as colour"),
    ({"type": "roughconductor", "alpha": 0.1, "alpha_u": 0.2, "alpha_v": 0.3},
     "alpha_u = 0.2: sets the same value as alpha: give one or the other"),
    ({"type": "roughconductor", "eta": 0.2, "material": "Au"}, "material = 'Au': sets the same value as eta"),
    ({"type": "conductor", "k": 3.0, "material": "Cu"}, "material = 'Cu': sets the same value as k"),
    ({"type": "roughdielectric", "alpha_u": 0.2}, "alpha_u = 0.2: must be given with alpha_v"),
    ({"type": "roughconductor", "alpha": 0.1, "alpha_v": 0.2}, "alpha_v = 0.2: must be given with alpha_u"),
])
def test_two_names_of_one_value_are_an_error(table, line):
    """Mitsuba's name beside raytrace's own, a metal beside eta or k, alpha beside alpha_u: one line naming the
    second; alpha_u and alpha_v go together, as Mitsuba requires."""
    assert error(table).startswith(line)


def test_mitsubas_names_and_raytraces_give_the_same_material():
    pairs = [({"type": "diffuse", "colour": [0.2, 0.3, 0.4]}, {"type": "diffuse", "reflectance": [0.2, 0.3, 0.4]}),
             ({"type": "conductor", "colour": [0.9] * 3}, {"type": "conductor", "specular_reflectance": 0.9}),
             ({"type": "plastic", "colour": [0.3] * 3}, {"type": "plastic", "diffuse_reflectance": 0.3}),
             ({"type": "roughconductor", "alpha": 0.3}, {"type": "roughconductor", "alpha_u": 0.3, "alpha_v": 0.3}),
             ({"type": "conductor"}, {"type": "conductor", "material": "none"}),
             ({"type": "conductor", "eta": 0.5}, {"type": "conductor", "eta": 0.5, "material": "none"})]
    for ours, theirs in pairs:
        a, b = (dataclasses.replace(material(table), name="x") for table in (ours, theirs))
        assert model.fingerprint(a) == model.fingerprint(b), (ours, theirs)
    assert material({"type": "roughconductor", "alpha_u": 0.3, "alpha_v": 0.3}).alpha_v is None  # isotropic


@pytest.mark.parametrize("metal", ["Au", "Ag", "Cu", "Al", "Cr", "CuO_palik"])
def test_a_named_metal_is_mitsubas_rgb(metal):
    for kind in ("conductor", "roughconductor"):
        m = material({"type": kind, "material": metal})
        assert (m.eta, m.k) == named_materials.CONDUCTORS[metal]


def test_rough_interfaces_need_two_indices():
    """roughdielectric and roughplastic refuse int_ior = ext_ior (Mitsuba's rule: rules.py), the smooth ones take
    it; the same line from the scene file and from a material built in Python."""
    line = ("int_ior = 1.2: must differ from ext_ior for type = \"roughdielectric\" (Mitsuba's rule for its rough "
            "interfaces: at equal indices the half-vector of refraction vanishes)")
    assert error({"type": "roughdielectric", "int_ior": 1.2, "ext_ior": 1.2}) == line
    assert 'for type = "roughplastic"' in error({"type": "roughplastic", "int_ior": "air", "ext_ior": "AIR"})
    for kind in ("dielectric", "thindielectric", "plastic"):
        assert material({"type": kind, "int_ior": 1.2, "ext_ior": 1.2}).int_ior == 1.2
    loaded = parse_scene(scene({"type": "roughdielectric", "int_ior": 1.5, "ext_ior": 1.2}), SOURCE)
    loaded.materials[0] = dataclasses.replace(loaded.materials[0], int_ior=1.2)
    with pytest.raises(InputError) as info:
        check_model(loaded, SOURCE)
    assert str(info.value) == f"{SOURCE}: materials.m.{line}"


@pytest.mark.parametrize("change, line", [
    (dict(alpha_v=2.0), "materials.m.alpha_v = 2.0: must be > 0 and <= 1"),
    (dict(alpha=0.0), "materials.m.alpha = 0.0: must be > 0 and <= 1"),
    (dict(distribution="blinn"), "materials.m.distribution = 'blinn': must be one of: ggx, beckmann"),
    (dict(specular=(1.0, -1.0, 0.0)), "materials.m.specular_reflectance = (1.0, -1.0, 0.0): must be a list of 3"),
    (dict(nonlinear="yes"), "materials.m.nonlinear = 'yes': must be true or false"),
    (dict(int_ior=-1.0), "materials.m.int_ior = -1.0: must be > 0"),
    (dict(bsdf="glass"), "materials.m.type = 'glass': must be one of: diffuse,"),
])
def test_a_material_built_in_python_is_checked_as_a_files(change, line):
    """model_check.py reads each BSDF field back under its key (the material's type's, else the first type's that
    declares it): the line a scene file would give."""
    loaded = parse_scene(scene({"type": "roughplastic"}), SOURCE)
    loaded.materials[0] = dataclasses.replace(loaded.materials[0], **change)
    with pytest.raises(InputError) as info:
        check_model(loaded, SOURCE)
    assert str(info.value).startswith(f"{SOURCE}: {line}"), str(info.value)


def test_other_models_take_diffuse_only():
    """rules.py's rule, as it was: a BSDF other than diffuse is the path model's (the kernel side decides about
    direct)."""
    for kind in bsdfs.BY_NAME:
        if kind != "diffuse":
            assert error({"type": kind}, "direct") == (f"type = '{kind}': is the path model's: only with shading = "
                                                       "\"path\", not \"direct\"")
    assert material({"reflectance": [0.5] * 3}, "phong").colour.tolist() == [0.5] * 3
    assert error({"shininess": 8.0}, "phong") == "colour: missing"


def test_each_declarations_example_loads():
    """The example table of each BSDF's section of docs/bsdfs.md is a valid material of that type."""
    import tomllib
    for bsdf in bsdfs.DECLARED:
        table = tomllib.loads(bsdf.example)
        assert material(table).bsdf == bsdf.name


def test_the_declarations_are_whole():
    """Each BSDF of model.BSDFS declared once, in the kernel's numbering; its keys in keys.py's table of its type
    (the scene format's), each parameter setting Material fields that exist; the kernel features distinct, the
    built ones fields of the renderer's Features; the front-only ones Mitsuba's one-sided plugins."""
    assert tuple(bsdfs.BY_NAME) == model.BSDFS == model.BSDFS[:4] + (
        "thindielectric", "roughdielectric", "plastic", "roughplastic", "null", "principled", "principledthin")
    fields = {f.name for f in dataclasses.fields(model.Material)}
    for bsdf in bsdfs.DECLARED:
        assert TABLES[bsdf.table] == bsdf.keys()
        for p in bsdf.parameters:
            assert set(p.fields) <= fields, (bsdf.name, p.name)
            assert p.key is None or p.key.name == p.name
            assert re.fullmatch(r"[a-z_]+", p.name)
    features = [bsdf.feature for bsdf in bsdfs.DECLARED if bsdf.feature]
    assert len(features) == len(set(features)) == len(bsdfs.DECLARED) - 1
    assert {"conductors", "dielectrics", "rough_conductors"} <= {f.name for f in dataclasses.fields(Features)}
    assert [bsdf.name for bsdf in bsdfs.DECLARED if not bsdf.front_only] == [
        "dielectric", "thindielectric", "roughdielectric", "null", "principled", "principledthin"]


def test_the_same_line_from_a_file_a_string_and_a_dict(tmp_path):
    """A bad BSDF key is named the same way from every entry."""
    import tomllib

    from raytrace.scene.toml_writer import scene_toml
    table = scene({"type": "roughplastic", "alpha": 2.0})
    path = tmp_path / "s.toml"
    path.write_text(scene_toml(table))
    lines = set()
    for call in (lambda: raytrace.load_file(path), lambda: raytrace.load_string(path.read_text()),
                 lambda: raytrace.load_dict(tomllib.loads(path.read_text()))):
        with pytest.raises(InputError) as info:
            call()
        lines.add(str(info.value).split(": ", 1)[1])
    assert lines == {"materials.m.alpha = 2.0: must be > 0 and <= 1"}
