"""Mitsuba 3's XML and dict form (raytrace/scene/mitsuba_xml.py, raytrace/scene/mitsuba.py): every element and
its errors, each error naming file:line; the translation of each plugin's parameters against an independent
float64 computation (scipy's rotations, the pinhole camera's geometry); `convert` and the command line.

Tolerances: transforms and camera angles are computed in float64 on both sides by different formulas, so
they agree to a few ulps of their magnitude (1e-12 allows for the trigonometric functions); values written in
the XML must come through exactly. Whether the renders match Mitsuba's is tests/test_mitsuba_corpus.py's
question."""
import math
import subprocess
import sys
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import raytrace
from raytrace.errors import InputError, UnsupportedWarning
from raytrace.scene import mitsuba_xml

from helpers import ROOT

BOX = """<scene version="3.0.0">
    <default name="spp" value="4"/>
    <integrator type="path"><integer name="max_depth" value="$depth"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="12"/><integer name="height" value="8"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>
    <shape type="rectangle" id="light">
        <transform name="to_world"><scale x="0.25" y="0.25"/><rotate x="1" angle="90"/><translate y="0.99"/></transform>
        <ref id="white"/>
        <emitter type="area"><rgb name="radiance" value="10, 9, 8"/></emitter>
    </shape>
    <shape type="rectangle"><transform name="to_world"><translate z="-1"/></transform><ref id="white"/></shape>
    EXTRA
</scene>
"""


def scene_text(extra="", **defaults):
    text = BOX.replace("EXTRA", extra)
    for name, value in defaults.items():
        text = text.replace('<default name="spp"', f'<default name="{name}" value="{value}"/>\n    <default name="spp"')
    return text


def write(tmp_path, text, name="scene.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def load(tmp_path, extra="", defines=None, **kw):
    return raytrace.load_file(write(tmp_path, scene_text(extra)), {"depth": 3, **(defines or {})}, **kw)


def error_of(tmp_path, text, defines=None, name="scene.xml"):
    with pytest.raises(InputError) as info:
        raytrace.load_file(write(tmp_path, text, name), {"depth": 3, **(defines or {})})
    return info.value


def line_of(text, fragment):
    return text[:text.index(fragment)].count("\n") + 1


# --- the XML elements ----------------------------------------------------------------------------------------

def test_properties_come_through_exactly(tmp_path):
    node = mitsuba_xml.read(write(tmp_path, """<scene version="3.0.0"><bsdf type="x" id="b">
        <float name="f" value="-1.5e-3"/><integer name="i" value=" -7 "/><boolean name="b" value="TRUE"/>
        <string name="s" value="a b"/><point name="p" value="1 2 3"/><vector name="v" x="4" y="5" z="6"/>
        <rgb name="c" value="0.1, 0.2, 0.3"/><rgb name="g" value="0.5"/><spectrum name="u" value="0.25"/>
        <spectrum name="l" value="400:0.1, 500:0.2 600:0.3"/></bsdf></scene>"""))
    b = node["b"]
    assert (b["f"], b["i"], b["b"], b["s"], b["p"], b["v"]) == (-1.5e-3, -7, True, "a b", [1, 2, 3], [4, 5, 6])
    assert b["c"] == {"type": "rgb", "value": [0.1, 0.2, 0.3]} and b["g"]["value"] == [0.5] * 3
    assert b["u"] == {"type": "spectrum", "value": 0.25}
    assert b["l"]["value"] == [(400, 0.1), (500, 0.2), (600, 0.3)]
    assert b[mitsuba_xml.WHERE].of("v").endswith("scene.xml:3")


def test_transforms_compose_in_mitsubas_order(tmp_path):
    """Each element acts after those before it: scale, then rotate, then translate, then the matrix."""
    node = mitsuba_xml.read(write(tmp_path, """<scene version="3.0.0"><shape type="rectangle" id="r">
        <transform name="to_world"><scale value="2"/><scale x="1" y="3"/><rotate x="0.6" z="0.8" angle="30"/>
        <translate x="1" y="-2" z="0.5"/><matrix value="0 -1 0 0 1 0 0 0 0 0 1 0 0 0 0 1"/>
        <matrix value="1 0 0 0 1 0 0 0 2"/></transform></shape></scene>"""))
    scale = np.diag([2.0, 6.0, 2.0, 1.0])
    rotate = np.eye(4)
    rotate[:3, :3] = Rotation.from_rotvec(np.radians(30) * np.array([0.6, 0, 0.8])).as_matrix()
    translate = np.eye(4)
    translate[:3, 3] = [1, -2, 0.5]
    turn = np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    stretch = np.diag([1, 1, 2, 1.0])
    expected = stretch @ turn @ translate @ rotate @ scale
    assert np.allclose(node["r"]["to_world"], expected, rtol=0, atol=1e-12)


def test_a_rotation_axis_is_taken_as_it_is(tmp_path):
    """Mitsuba does not normalise a rotation's axis (3.9.1: rotate z = 2 by 90 degrees gives [[0, -2, 0], [2, 0,
    0], [0, 0, 4]], read off mi.ScalarTransform4d().rotate), and neither does raytrace."""
    node = mitsuba_xml.read(write(tmp_path, """<scene version="3.0.0"><shape type="rectangle" id="r">
        <transform name="to_world"><rotate z="2" angle="90"/></transform></shape></scene>"""))
    assert np.allclose(node["r"]["to_world"][:3, :3], [[0, -2, 0], [2, 0, 0], [0, 0, 4]], rtol=0, atol=1e-15)


def test_lookat_is_mitsubas_frame(tmp_path):
    """Columns left, up, direction, origin: x = up x direction, and up is made orthogonal to the view."""
    node = mitsuba_xml.read(write(tmp_path, """<scene version="3.0.0"><sensor type="perspective" id="s">
        <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0.5"/></transform>
        </sensor></scene>"""))
    m = node["s"]["to_world"]
    assert np.allclose(m[:3, 3], [1, 2, 3]) and np.allclose(m[:3, 2], [0, 0, -1], atol=1e-12)
    assert np.allclose(m[:3, 1], [0, 1, 0], atol=1e-12) and np.allclose(m[:3, 0], [-1, 0, 0], atol=1e-12)


def test_parameters_defaults_and_escapes(tmp_path):
    """-D beats <default>; a longer name is replaced before its prefix; \\$ is a dollar sign."""
    text = """<scene version="3.0.0"><default name="a" value="1"/><default name="ab" value="2"/>
        <bsdf type="x" id="b"><string name="s" value="$a-$ab-\\$a"/><string name="t" value="$c"/></bsdf></scene>"""
    node = mitsuba_xml.read(write(tmp_path, text), {"c": "3", "a": "9"})
    assert node["b"]["s"] == "9-2-$a" and node["b"]["t"] == "3"
    with pytest.raises(InputError, match=r"scene.xml:2: <string> value = '\$c': undefined parameter \$c"):
        mitsuba_xml.read(write(tmp_path, text))


def test_include_path_ref_and_alias(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "bsdfs.xml").write_text("""<scene version="3.0.0">
        <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5"/></bsdf></scene>""")
    (tmp_path / "parts" / "film.xml").write_text("""<film type="hdrfilm"><integer name="width" value="5"/></film>""")
    node = mitsuba_xml.read(write(tmp_path, """<scene version="3.0.0"><include filename="parts/bsdfs.xml"/>
        <alias id="grey" as="gray"/><sensor type="perspective" id="s"><include filename="parts/film.xml"/></sensor>
        <shape type="rectangle" id="r"><ref id="gray"/></shape></scene>"""))
    assert node["grey"]["reflectance"]["value"] == [0.5] * 3
    assert node["s"]["_arg_0"]["width"] == 5 and node["r"]["_arg_0"] == {
        "type": "ref", "id": "gray", mitsuba_xml.WHERE: node["r"]["_arg_0"][mitsuba_xml.WHERE]}
    assert node["grey"][mitsuba_xml.WHERE].at.endswith("bsdfs.xml:2")


def test_version_0_6_names_are_upgraded(tmp_path):
    node = mitsuba_xml.read(write(tmp_path, """<scene version="0.6.0"><integrator type="path" id="i">
        <integer name="maxDepth" value="4"/></integrator><bsdf type="dielectric" id="d"><float name="intIOR"
        value="1.3"/></bsdf><bsdf type="diffuse" id="f"><rgb name="diffuseReflectance" value="0.2"/></bsdf>
        </scene>"""))
    assert node["i"]["max_depth"] == 4 and node["d"]["int_ior"] == 1.3 and "reflectance" in node["f"]


@pytest.mark.parametrize("text, where, message", [
    ('<scene version="3.0.0"><float name="x" value="1"></scene>', ":1:", "mismatched tag: not well-formed XML"),
    ('<!DOCTYPE s [<!ENTITY a "b">]><scene version="3.0.0"/>', ":1", "a DOCTYPE or entity declaration"),
    ('<scene version="3.0.0">\n<bsdf type="x"><blob name="y"/></bsdf></scene>', ":2", "<blob>: an element"),
    ('<scene version="3.0.0">\n<float name="x" value="1" unit="m"/></scene>', ":2", "<float> unit = 'm': is no "),
    ('<scene version="3.0.0">\n<bsdf type="x"><float name="x" value="one"/></bsdf></scene>', ":2", "could not parse"),
    ('<scene version="3.0.0">\n<bsdf type="x"><float name="x" value="nan"/></bsdf></scene>', ":2", "must be finite"),
    ('<scene version="3.0.0">\n<bsdf type="x"><boolean name="x" value="yes"/></bsdf></scene>', ":2", '"true" or'),
    ('<scene version="3.0.0">\n<bsdf type="x"><rgb name="x" value="1 2"/></bsdf></scene>', ":2", "1 or 3 numbers"),
    ('<scene version="3.0.0">\n<bsdf type="x"><integer name="x" value="1.5"/></bsdf></scene>', ":2", "an integer"),
    ('<scene version="3.0.0">\n<bsdf type="x"><float value="1"/></bsdf></scene>', ":2", "<float> name: missing"),
    ('<scene version="3.0.0">\n<ref id="nothing"/></scene>', ":2", "no object with this id"),
    ('<scene version="3.0.0">\n<bsdf type="x" id="a"/><bsdf type="x" id="a"/></scene>', ":2", "duplicate id"),
    ('<scene version="3.0.0">\n<include filename="none.xml"/></scene>', ":2", "No such file"),
    ('<scene version="3.0.0">\n<include filename="scene.xml"/></scene>', "", "nested more than 32"),
    ('<scene>\n</scene>', ":1", "<scene> version: missing"),
    ('<scene version="3.0.0"><shape type="r"><transform name="to_world">\n<rotate angle="3"/></transform></shape>'
     '</scene>', ":2", "cannot be zero"),
    ('<scene version="3.0.0"><shape type="r"><transform name="to_world">\n<matrix value="1 2 3"/></transform>'
     '</shape></scene>', ":2", "9 or 16 numbers"),
    ('<scene version="3.0.0"><shape type="r"><transform name="to_world">\n<lookat origin="0 0 0" target="0 0 0"/>'
     '</transform></shape></scene>', ":2", "invalid"),
])
def test_bad_xml_is_one_line_with_its_line(tmp_path, text, where, message):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as info:
        mitsuba_xml.read(path)
    line = str(info.value)
    assert "\n" not in line and f"scene.xml{where}" in line and message in line, line


# --- the plugins ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("integrator, render", [
    ('<integrator type="direct"/>', {"light_samples": 1, "bsdf_samples": 1}),
    ('<integrator type="direct"><integer name="shading_samples" value="3"/></integrator>',
     {"light_samples": 3, "bsdf_samples": 3}),
    ('<integrator type="direct"><integer name="emitter_samples" value="2"/><integer name="bsdf_samples" value="0"/>'
     '<boolean name="hide_emitters" value="true"/></integrator>',
     {"light_samples": 2, "bsdf_samples": 0, "hide_emitters": True}),
    ('<integrator type="direct"><integer name="bsdf_samples" value="4"/></integrator>',
     {"light_samples": 1, "bsdf_samples": 4}),
    ('<integrator type="path"><integer name="rr_depth" value="1"/><boolean name="hide_emitters" value="true"/>'
     '</integrator>', {"rr_depth": 1, "hide_emitters": True}),
])
def test_integrator_parameters(tmp_path, integrator, render):
    """Mitsuba's direct integrator with its defaults (1 emitter and 1 BSDF sample), shading_samples setting both,
    each given alone or both, and hide_emitters; the path integrator's rr_depth and hide_emitters: each becomes
    its render key (the light's BSDF, which the direct model leaves out, ignored)."""
    text = BOX.replace('<integrator type="path"><integer name="max_depth" value="$depth"/></integrator>', integrator)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsupportedWarning)
        scene = raytrace.load_file(write(tmp_path, text), ignore_unsupported=True)
    t = scene.source["render"]
    assert {k: t[k] for k in render} == render
    for key, value in render.items():
        assert getattr(scene, key) == value


AOV_INTEGRATOR = ('<integrator type="aov">\n<string name="aovs" value="AOVS"/>\n'
                  '<integrator type="direct" name="my_image"><integer name="emitter_samples" value="2"/>'
                  '</integrator>\n</integrator>')


AOVS_PARAM = 'name="aovs"'


def test_the_aov_integrator(tmp_path):
    """Mitsuba's aov integrator: its `aovs` become render.aovs (the AOVs' names and types), the integrator inside
    sets the shading as a bare one does; a type raytrace does not compute is refused in one line at the XML's
    line, or left out with one warning under ignore_unsupported; a misspelt type is refused at that line with
    the nearest. Mutations, each failing here: the inner integrator not read (its shading set, its parameters
    ignored: light_samples 1), an unsupported type passed on to parse (its message, not the unsupported one)."""
    base = BOX.replace('<integrator type="path"><integer name="max_depth" value="$depth"/></integrator>',
                       AOV_INTEGRATOR)
    text = base.replace("AOVS", "dd.y:depth,nn:sh_normal,s:shape_index,albedo")
    scene = raytrace.load_file(write(tmp_path, text), ignore_unsupported=True)
    assert scene.aovs == (("dd.y", "depth"), ("nn", "sh_normal"), ("s", "shape_index"), ("albedo", "albedo"))
    assert (scene.shading, scene.light_samples) == ("direct", 2)
    text = base.replace("AOVS", "dd.y:depth,p:prim_index")
    error = error_of(tmp_path, text)
    assert "prim_index" in str(error) and "--ignore-unsupported" in str(error) and "\n" not in str(error)
    assert f"scene.xml:{line_of(text, AOVS_PARAM)}" in str(error)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = raytrace.load_file(write(tmp_path, text), ignore_unsupported=True)
    assert scene.aovs == (("dd.y", "depth"),)
    assert [str(w.message) for w in caught if "prim_index" in str(w.message)] != []
    text = base.replace("AOVS", "a:albdo")
    error = error_of(tmp_path, text)
    assert "did you mean 'albedo'" in str(error) and f"scene.xml:{line_of(text, AOVS_PARAM)}" in str(error)


def test_shading_samples_not_with_either_count(tmp_path):
    """Mitsuba refuses shading_samples beside emitter_samples or bsdf_samples, and so does raytrace, at the
    parameter."""
    text = BOX.replace('<integrator type="path"><integer name="max_depth" value="$depth"/></integrator>',
                       '<integrator type="direct"><integer name="shading_samples" value="2"/>\n'
                       '<integer name="bsdf_samples" value="1"/></integrator>')
    error = error_of(tmp_path, text)
    assert "shading_samples" in str(error) and "not with emitter_samples or bsdf_samples" in str(error)
    assert f"scene.xml:{line_of(text, 'shading_samples')}" in str(error)


def test_a_box_translates_into_raytraces_table(tmp_path):
    scene = load(tmp_path, defines={"spp": 9})
    t = scene.source
    assert t["render"] == {"shading": "path", "max_depth": 3, "spp": 9, "sampler": "random", "seed": 0}
    assert t["image"] == {"width": 12, "height": 8, "rfilter": "box"} and scene.camera.fov_deg == 40
    light = scene.lights[0]
    assert np.allclose(light.normal, [0, -1, 0], atol=1e-15) and np.allclose(light.size, [0.5, 0.5])
    assert np.allclose(light.center, [0, 0.99, 0]) and list(light.colour) == [10, 9, 8]
    assert t["materials"]["white"] == {"type": "diffuse", "colour": [0.7] * 3}
    assert t["lights"][0]["material"] == "white"


def test_an_emitter_on_another_shape_is_a_shape_with_radiance(tmp_path):
    """An area emitter on a sphere or a cube is that shape with a radiance (kernels/emitters.cl): black without a
    BSDF or with a black one (Mitsuba's default for an emitting shape), else reflecting by its BSDF; a
    rectangle's stays a rectangular light."""
    scene = load(tmp_path, """
        <shape type="sphere"><float name="radius" value="0.2"/><emitter type="area"><rgb name="radiance"
            value="1, 2, 3"/></emitter></shape>
        <shape type="cube"><transform name="to_world"><scale value="0.1"/></transform><ref id="white"/>
            <emitter type="area"/></shape>""")
    sphere, cube = scene.source["shapes"][-2:]
    assert sphere["type"] == "ellipsoid" and sphere["radiance"] == [1, 2, 3] and "material" not in sphere
    assert cube["type"] == "mesh" and cube["radiance"] == [1.0] * 3 and cube["material"] == "white"
    assert len(scene.lights) == 1 and len(scene.emitters) == 2
    assert [e.reflects for e in scene.emitters] == [False, True]


@pytest.mark.parametrize("axis", ["x", "y", "diagonal", "smaller", "larger"])
@pytest.mark.parametrize("size", [(12, 8), (8, 12)])
def test_fov_axis_is_the_image_planes_extent(tmp_path, axis, size):
    """The vertical fov raytrace renders spans, at unit distance, the image plane whose extent along `axis` the
    given fov spans (the pinhole's geometry, not Mitsuba's formula)."""
    text = scene_text().replace('"fov_axis" value="y"', f'"fov_axis" value="{axis}"').replace(
        'name="width" value="12"', f'name="width" value="{size[0]}"').replace(
        'name="height" value="8"', f'name="height" value="{size[1]}"')
    scene = raytrace.load_file(write(tmp_path, text), {"depth": 2})
    half_h = math.tan(math.radians(scene.camera.fov_deg) / 2)
    half_w = half_h * size[0] / size[1]
    resolved = {"smaller": "y" if size[0] > size[1] else "x", "larger": "x" if size[0] > size[1] else "y"}
    extent = {"x": half_w, "y": half_h, "diagonal": math.hypot(half_w, half_h)}[resolved.get(axis, axis)]
    assert extent == pytest.approx(math.tan(math.radians(40) / 2), rel=1e-12)


def test_focal_length_is_a_35mm_films_diagonal(tmp_path):
    text = scene_text().replace('<float name="fov" value="40"/>', '<string name="focal_length" value="35mm"/>')
    scene = raytrace.load_file(write(tmp_path, text), {"depth": 2})
    half_h = math.tan(math.radians(scene.camera.fov_deg) / 2)
    assert math.hypot(half_h * 12 / 8, half_h) == pytest.approx(math.hypot(36, 24) / 2 / 35, rel=1e-12)


def test_bsdfs_and_their_named_values(tmp_path):
    scene = load(tmp_path, """
        <shape type="rectangle"><bsdf type="dielectric"><string name="int_ior" value="water"/></bsdf></shape>
        <shape type="rectangle"><bsdf type="twosided"><bsdf type="roughconductor"><string name="material" value="Au"/>
            <string name="distribution" value="ggx"/><float name="alpha" value="0.3"/></bsdf></bsdf></shape>
        <shape type="rectangle"><bsdf type="twosided"><bsdf type="conductor"/></bsdf></shape>""")
    from raytrace.scene import named_materials
    kinds = {m.bsdf: m for m in scene.materials}
    assert kinds["dielectric"].int_ior == named_materials.IORS["water"]
    assert kinds["dielectric"].ext_ior == named_materials.IORS["air"]
    assert np.allclose(kinds["roughconductor"].eta, named_materials.CONDUCTORS["Au"][0])
    assert kinds["roughconductor"].alpha == 0.3 and tuple(kinds["conductor"].eta) == (0, 0, 0)


SHAPE_OF = '<shape type="rectangle"><transform name="to_world"><translate z="-0.{i}"/></transform>{bsdf}</shape>'
NEW_BSDFS = {  # (the bsdf element, the scene table's material it becomes)
    "thin": ('<bsdf type="thindielectric" id="thin"><string name="int_ior" value="Water"/>'
             '<float name="ext_ior" value="1.1"/><rgb name="specular_reflectance" value="0.9"/>'
             '<rgb name="specular_transmittance" value="0.9"/></bsdf>',
             {"type": "thindielectric", "colour": [0.9] * 3, "int_ior": "Water", "ext_ior": 1.1}),
    "frosted": ('<bsdf type="roughdielectric" id="frosted"><string name="distribution" value="GGX"/>'
                '<float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/>'
                '<boolean name="sample_visible" value="false"/></bsdf>',
                {"type": "roughdielectric", "colour": [1.0] * 3, "int_ior": "bk7", "ext_ior": "air",
                 "distribution": "ggx", "alpha_u": 0.05, "alpha_v": 0.3}),
    "shiny": ('<bsdf type="twosided" id="shiny"><bsdf type="plastic"><rgb name="diffuse_reflectance" '
              'value="0.1, 0.27, 0.36"/><float name="int_ior" value="1.9"/><boolean name="nonlinear" value="true"/>'
              '<rgb name="specular_reflectance" value="1, 0.5, 0.25"/></bsdf></bsdf>',
              {"type": "plastic", "colour": [0.1, 0.27, 0.36], "nonlinear": True, "int_ior": 1.9, "ext_ior": "air",
               "specular_reflectance": [1.0, 0.5, 0.25]}),
    "matte": ('<bsdf type="twosided" id="matte"><bsdf type="roughplastic"/></bsdf>',
              {"type": "roughplastic", "colour": [0.5] * 3, "nonlinear": False, "int_ior": "polypropylene",
               "ext_ior": "air", "specular_reflectance": [1.0] * 3, "distribution": "beckmann", "alpha": 0.1}),
    "brushed": ('<bsdf type="twosided" id="brushed"><bsdf type="roughconductor"><string name="material" value="Al"/>'
                '<float name="alpha_u" value="0.4"/><float name="alpha_v" value="0.05"/></bsdf></bsdf>',
                {"type": "roughconductor", "colour": [1.0] * 3, "material": "Al", "distribution": "beckmann",
                 "alpha_u": 0.4, "alpha_v": 0.05}),
    "mirror": ('<bsdf type="twosided" id="mirror"><bsdf type="conductor"><string name="material" value="none"/>'
               '<rgb name="k" value="2"/></bsdf></bsdf>',
               {"type": "conductor", "colour": [1.0] * 3, "eta": [0.0] * 3, "k": [2.0] * 3, "material": "none"}),
}


def test_each_bsdf_becomes_its_table_with_mitsubas_names_and_defaults(tmp_path):
    """thindielectric, roughdielectric, plastic, roughplastic and the conductors' new parameters as the scene
    table's keys (bsdfs.py): each given value under the key of its name (a reflectance as colour), Mitsuba's
    defaults written where raytrace's format has others (a distribution: Beckmann), named media and metals kept
    as names, which the scene file's reader resolves, in any case as Mitsuba does."""
    from raytrace.scene import named_materials
    extra = "".join(SHAPE_OF.format(i=i + 1, bsdf=bsdf) for i, (bsdf, _) in enumerate(NEW_BSDFS.values()))
    scene = load(tmp_path, extra)
    for name, (_, table) in NEW_BSDFS.items():
        assert scene.source["materials"][name] == table, name
    m = {material.name: material for material in scene.materials}
    assert (m["thin"].int_ior, m["thin"].ext_ior) == (named_materials.IORS["water"], 1.1)
    assert (m["frosted"].alpha, m["frosted"].alpha_v, m["frosted"].distribution) == (0.05, 0.3, "ggx")
    assert (m["shiny"].specular, m["shiny"].nonlinear, m["shiny"].int_ior) == ((1.0, 0.5, 0.25), True, 1.9)
    assert (m["matte"].int_ior, m["matte"].ext_ior, m["matte"].alpha, m["matte"].distribution) == (
        1.49, 1.000277, 0.1, "beckmann")
    assert (m["brushed"].eta, m["brushed"].k) == named_materials.CONDUCTORS["Al"]
    assert (m["mirror"].eta, m["mirror"].k) == ((0.0,) * 3, (2.0,) * 3)  # Mitsuba's eta 0 beside a given k


def test_the_new_bsdfs_convert_to_toml_as_the_same_model(tmp_path):
    """XML -> TOML -> model equals XML -> model: the TOML is the table the reader makes, names and all."""
    import tomllib

    from raytrace.scene import parse_scene
    from raytrace.scene.model import fingerprint
    from raytrace.scene.scene_file import load_mitsuba_file
    from raytrace.scene.toml_writer import scene_toml
    extra = "".join(SHAPE_OF.format(i=i + 1, bsdf=bsdf) for i, (bsdf, _) in enumerate(NEW_BSDFS.values()))
    scene, translation = load_mitsuba_file(write(tmp_path, scene_text(extra)), {"depth": 3})
    back = parse_scene(tomllib.loads(scene_toml(translation.table)), str(tmp_path / "scene.toml"))
    assert fingerprint(back.materials) == fingerprint(scene.materials)


@pytest.mark.parametrize("bsdf, param, message", [
    ('<bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/></bsdf>', "alpha_u",
     "must be given with alpha_v"),
    ('<bsdf type="roughconductor"><float name="alpha" value="0.1"/><float name="alpha_u" value="0.1"/>'
     '<float name="alpha_v" value="0.2"/></bsdf>', "alpha_u", "sets the same value as alpha"),
    ('<bsdf type="roughdielectric"><float name="int_ior" value="1.2"/><float name="ext_ior" value="1.2"/></bsdf>',
     "int_ior", 'must differ from ext_ior for type = "roughdielectric"'),
    ('<bsdf type="roughplastic"><string name="distribution" value="phong"/></bsdf>', "distribution",
     "must be one of: ggx, beckmann"),
    ('<bsdf type="roughplastic"><float name="alpha" value="1.5"/></bsdf>', "alpha", "must be > 0 and <= 1"),
    ('<bsdf type="plastic"><string name="int_ior" value="watr"/></bsdf>', "int_ior", "did you mean 'water'?"),
    ('<bsdf type="plastic"><string name="nonlinear" value="true"/></bsdf>', "nonlinear", "must be a boolean"),
    ('<bsdf type="roughconductor"><string name="sample_visible" value="no"/></bsdf>', "sample_visible",
     "must be a boolean"),
    ('<bsdf type="conductor"><string name="material" value="Au"/><rgb name="eta" value="1"/></bsdf>', "material",
     "sets the same value as eta"),
    ('<bsdf type="conductor"><string name="material" value="Gold"/></bsdf>', "material", "must be one of: Ag,"),
    ('<bsdf type="roughplastic"><float name="alpha_u" value="0.1"/></bsdf>', "alpha_u",
     "is no parameter of Mitsuba's roughplastic bsdf"),
])
def test_a_bad_bsdf_value_is_named_at_its_xml_line(tmp_path, bsdf, param, message):
    """The scene file's reader refuses it (or the translator, for what has no key), named at the XML line of the
    parameter it came from."""
    lines = bsdf.replace("><", ">\n<")  # a parameter a line
    text = scene_text(f'<shape type="rectangle">\n{lines}\n</shape>')
    error = error_of(tmp_path, text)
    line = line_of(text, f'name="{param}"')
    assert error.source.endswith(f"scene.xml:{line}") and message in str(error), str(error)


def test_the_one_sided_bsdfs_are_one_sided_outside_twosided(tmp_path):
    """Mitsuba's diffuse, conductors and plastics scatter from the front only: bare, each becomes a one-sided
    material (two_sided = false, black from behind), without a warning; its glass, smooth, thin or rough, has two
    sides in both renderers; inside twosided, every BSDF is two-sided; a twosided of two BSDFs gives the first
    the second as its back."""
    extra = "".join(SHAPE_OF.format(i=i + 1, bsdf=f'<bsdf type="{kind}"/>') for i, kind in enumerate(
        ["plastic", "roughplastic", "thindielectric", "roughdielectric", "dielectric"]))
    extra += SHAPE_OF.format(i=6, bsdf='<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>')
    extra += SHAPE_OF.format(i=7, bsdf='<bsdf type="twosided" id="pair"><bsdf type="diffuse"/>'
                             '<bsdf type="conductor"/></bsdf>')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load(tmp_path, extra)
    assert not [w for w in caught if "twosided" in str(w.message)]
    sides = {m.bsdf: m.two_sided for m in scene.materials if m.back == -1 and m.name != "pair"}
    assert sides["plastic"] is sides["roughplastic"] is False
    assert sides["thindielectric"] and sides["roughdielectric"] and sides["dielectric"]
    pair = next(m for m in scene.materials if m.name == "pair")
    assert (pair.bsdf, pair.two_sided, scene.materials[pair.back].bsdf) == ("diffuse", True, "conductor")
    assert scene.materials[pair.back].two_sided and scene.materials[pair.back].back == -1


def test_a_glass_of_two_colours_is_unsupported(tmp_path):
    for kind in ("thindielectric", "roughdielectric"):
        text = scene_text(f'<shape type="rectangle"><bsdf type="{kind}"><rgb name="specular_transmittance" '
                          'value="0.5"/></bsdf></shape>')
        error = error_of(tmp_path, text)
        assert f"{kind} transmittance unlike its reflectance" in str(error)


def test_spectrum_plugins_as_mitsubas_rgb_variants_take_them(tmp_path):
    """d65 (times its scale), uniform and srgb as Mitsuba 3.9.1's scalar_rgb holds them (mi.traverse: d65 of
    scale 2 is 2, uniform 2 is 2, srgb (0.5, 0.2, 0.1) is itself, as radiance and as reflectance alike); the
    spectral plugins its rgb variants refuse to render are refused."""
    scene = load(tmp_path, """<shape type="rectangle"><transform name="to_world"><translate z="-0.5"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><spectrum type="srgb" name="reflectance">
        <rgb name="color" value="0.5, 0.2, 0.1"/></spectrum></bsdf></bsdf>
        <emitter type="area"><spectrum type="d65" name="radiance"><float name="scale" value="2"/></spectrum>
        </emitter></shape>
        <shape type="rectangle"><transform name="to_world"><translate z="-0.9"/></transform>
        <emitter type="area"><spectrum type="uniform" name="radiance"><float name="value" value="3"/></spectrum>
        </emitter></shape>""")
    assert [list(light.colour) for light in scene.lights[1:]] == [[2, 2, 2], [3, 3, 3]]
    assert list(scene.materials[scene.lights[1].material].colour) == [0.5, 0.2, 0.1]
    error = error_of(tmp_path, scene_text('<shape type="rectangle"><emitter type="area"><spectrum type="blackbody" '
                                          'name="radiance"><float name="temperature" value="3000"/></spectrum>'
                                          '</emitter></shape>'))
    assert "rgb variants do not render either" in str(error)


@pytest.mark.parametrize("faces, normal", [("f 1 4 3\nf 1 3 2", [0, 1, 0]), ("f 1 2 3\nf 1 3 4", [0, -1, 0])])
def test_a_quad_mesh_light_becomes_a_rectangle(tmp_path, faces, normal):
    """Its front is the faces' counter-clockwise side: (v4 - v1) x (v3 - v1) = (0, 4, 0) for 1 4 3."""
    (tmp_path / "quad.obj").write_text(f"v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n{faces}\n")
    scene = load(tmp_path, """<shape type="obj"><string name="filename" value="quad.obj"/>
        <transform name="to_world"><scale value="0.5"/><translate y="1"/></transform>
        <emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>""")
    light = scene.lights[1]
    assert np.allclose(light.center, [0, 1, 0]) and np.allclose(sorted(light.size), [1, 1])
    assert np.allclose(light.normal, normal)


def test_a_sheared_rectangle_is_two_triangles(tmp_path):
    scene = load(tmp_path, """<shape type="rectangle"><transform name="to_world">
        <matrix value="1 0.5 0 0  0 1 0 0  0 0 1 -0.5  0 0 0 1"/></transform></shape>""")
    corners = np.array([t.vertices for t in scene.triangles]).reshape(-1, 3)
    assert np.allclose(sorted(map(tuple, np.unique(corners, axis=0))),
                       sorted([(-1.5, -1, -0.5), (0.5, -1, -0.5), (1.5, 1, -0.5), (-0.5, 1, -0.5)]))


@pytest.mark.parametrize("extra, where, message", [
    ('<shape type="linearcurve"/>', "shape linearcurve",
     "not supported (raytrace renders: rectangle, obj, ply, serialized, cube, sphere, disk, cylinder, shapegroup, "
     "instance)"),
    ('<shape type="rectangle"><bsdf type="pplastic"/></shape>', "bsdf pplastic", "raytrace renders: diffuse"),
    ('<emitter type="directionalarea"/>', "emitter directionalarea", "raytrace renders: area"),
])
def test_what_is_not_supported_is_one_line_or_a_warning(tmp_path, extra, where, message):
    text = scene_text(f"\n{extra}")
    error = error_of(tmp_path, text)
    line = str(error)
    assert line.startswith(f"{tmp_path / 'scene.xml'}:{text.count(chr(10)) - 1}: {where}: ") and message in line
    assert "--ignore-unsupported" in str(error)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raytrace.load_file(tmp_path / "scene.xml", {"depth": 3}, ignore_unsupported=True)
    assert [str(w.message).split(": ")[1] for w in caught if w.category is UnsupportedWarning] == [where]


def test_a_bad_value_is_named_at_its_xml_line(tmp_path):
    text = scene_text('<shape type="rectangle"><bsdf type="diffuse">\n<rgb name="reflectance" value="-1"/>'
                      '</bsdf></shape>')
    error = error_of(tmp_path, text)
    line = line_of(text, 'value="-1"')
    assert error.source.endswith(f"scene.xml:{line}") and error.key == "reflectance"
    assert error.value == [-1.0, -1.0, -1.0]


def test_an_unknown_parameter_gets_the_closest_name(tmp_path):
    text = scene_text('<shape type="rectangle"><bsdf type="diffuse">\n<rgb name="reflectence" value="1"/></bsdf>'
                      '</shape>')
    assert "did you mean 'reflectance'?" in str(error_of(tmp_path, text))


def test_clip_planes_are_kept_where_they_cut_geometry(tmp_path):
    """A plane that cuts geometry in view (nearer than the near plane, farther than the far one) is the camera's;
    one that cuts nothing is dropped (a ray from the eye renders the TOML's bits); geometry behind the eye (a wall
    at z = 9, the camera at z = 4 looking to -z) is not cut."""
    text = scene_text().replace('<float name="fov" value="40"/>', '<float name="fov" value="40"/><float '
                                'name="far_clip" value="4.5"/>')
    camera = raytrace.load_file(write(tmp_path, text), {"depth": 3}).camera
    assert (camera.near_clip, camera.far_clip) == (0.0, 4.5)
    near = scene_text('<shape type="rectangle"><transform name="to_world"><scale value="0.1"/><translate '
                      'x="0.05" y="0.05" z="3.99"/></transform></shape>')
    scene = raytrace.load_file(write(tmp_path, near), {"depth": 3})
    assert (scene.camera.near_clip, scene.camera.far_clip) == (0.01, math.inf)
    assert scene.source["camera"]["near_clip"] == 0.01 and "far_clip" not in scene.source["camera"]
    (tmp_path / "quad.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n")
    mesh = near.replace('<shape type="rectangle"><transform', '<shape type="obj"><string name="filename" '
                        'value="quad.obj"/><transform')  # the same, as triangles: their exact distance
    assert raytrace.load_file(write(tmp_path, mesh), {"depth": 3}).camera.near_clip == 0.01
    text = near.replace('z="3.99"', 'z="3.98"')  # 0.02 away: beyond the near plane's ball (0.0108)
    assert raytrace.load_file(write(tmp_path, text), {"depth": 3}).camera.near_clip == 0.0
    wall = load(tmp_path, '<shape type="rectangle"><transform name="to_world"><translate z="9"/></transform></shape>')
    assert (wall.camera.near_clip, wall.camera.far_clip) == (0.0, math.inf)


def test_the_dict_form_loads_as_the_xml(tmp_path):
    xml = load(tmp_path)
    m = np.eye(4)
    m[:3, :3] = np.diag([0.25, 0.25, 1]) @ np.eye(3)
    light_to_world = mitsuba_xml.rotation([1, 0, 0], 90) @ np.diag([0.25, 0.25, 1, 1])
    light_to_world[1, 3] = 0.99
    back = np.eye(4)
    back[2, 3] = -1

    class Transform:  # as Mitsuba's ScalarTransform4f: a .matrix
        matrix = back

    white = {"type": "twosided", "id": "white", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb",
                                                                                          "value": [0.7] * 3}}}
    scene = raytrace.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": 40.0, "fov_axis": "y",
                   "to_world": mitsuba_xml.look_at(np.array([0, 0, 4.0]), np.zeros(3), np.array([0, 1.0, 0])),
                   "sampler": {"type": "independent", "sample_count": 4},
                   "film": {"type": "hdrfilm", "width": 12, "height": 8, "rfilter": {"type": "box"}}},
        "white": white,
        "light": {"type": "rectangle", "to_world": light_to_world, "bsdf": {"type": "ref", "id": "white"},
                  "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [10, 9, 8]}}},
        "back": {"type": "rectangle", "to_world": Transform(), "bsdf": {"type": "ref", "id": "white"}}})
    a, _ = raytrace.render(xml, spp=4, progress=False)
    b, _ = raytrace.render(scene, spp=4, progress=False)
    assert np.array_equal(a, b)
    with pytest.raises(InputError, match=r"^load_dict\(\): sensor.fov = 'wide': must be a finite number$"):
        raytrace.load_dict({"type": "scene", "sensor": {"type": "perspective", "fov": "wide"}})


# --- the command line ----------------------------------------------------------------------------------------

def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "raytrace", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


def test_convert_to_toml_renders_the_same_bits(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "quad.obj").write_text("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\n")
    write(tmp_path, scene_text('<shape type="obj"><string name="filename" value="quad.obj"/><ref id="white"/>'
                               '</shape>'))
    r = run("convert", "scene.xml", "-D", "depth=4", "-o", "out/scene.toml", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert 'file = "../quad.obj"' in (tmp_path / "out" / "scene.toml").read_text()
    for args in (("scene.xml", "-D", "depth=4"), ("out/scene.toml",)):
        r = run("render", *args, "--spp", 4, "-o", f"{args[0]}.exr", "--no-progress", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    import OpenImageIO as oiio
    a, b = (oiio.ImageBuf(str(tmp_path / f"{name}.exr")).get_pixels() for name in ("scene.xml", "out/scene.toml"))
    assert a.shape == (8, 12, 6) and np.array_equal(a, b)


def test_bad_input_on_the_command_line_is_exit_2_and_no_file(tmp_path):
    write(tmp_path, scene_text('<shape type="linearcurve"/>'))
    cases = [(("-D", "depth"), "command line: -D = 'depth': must be NAME=VALUE"),
             ((), "scene.xml:3: <integer> value = '$depth': undefined parameter $depth"),
             (("-D", "depth=2"), "shape linearcurve: not supported")]
    for extra, message in cases:
        r = run("render", "scene.xml", *extra, "-o", "out.exr", cwd=tmp_path)
        assert r.returncode == 2 and message in r.stderr and r.stderr.count("\n") == 1, r.stderr
        assert not (tmp_path / "out.exr").exists()
    r = run("render", "scene.xml", "-D", "depth=2", "--ignore-unsupported", "--spp", 1, "-o", "out.exr",
            "--no-progress", cwd=tmp_path)
    assert r.returncode == 0 and "raytrace: warning:" in r.stderr and "shape linearcurve" in r.stderr
    assert (tmp_path / "out.exr").exists()



def test_convert_to_xml_and_its_refusals(tmp_path):
    """TOML -> XML through the command line: the XML loads to the TOML's model (raytrace/scene/mitsuba_writer.py
    is tested on its own in tests/test_mitsuba_writer.py); a wrong extension or a Phong scene is exit 2."""
    scenes = ROOT / "scenes"
    r = run("convert", scenes / "cornell_box.toml", "-o", tmp_path / "box.xml", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    xml, toml = raytrace.load_file(tmp_path / "box.xml"), raytrace.load_file(scenes / "cornell_box.toml")
    assert (xml.width, xml.height, xml.spp) == (toml.width, toml.height, toml.spp)
    assert np.allclose(xml.camera.position, toml.camera.position) and len(xml.lights) == len(toml.lights)
    for args, message in (((scenes / "cornell_box.toml", "-o", tmp_path / "box.toml"), "must end in .xml"),
                          ((scenes / "cornell.toml", "-o", tmp_path / "c.xml"), "Phong model has no Mitsuba 3")):
        r = run("convert", *args, cwd=tmp_path)
        assert r.returncode == 2 and message in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "c.xml").exists() and not (tmp_path / "box.toml").exists()


@pytest.mark.parametrize("matrix, flip, outward", [
    ("1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1", False, True),
    ("1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1", True, False),
    ("-0.5 0 0 0.2  0 0.3 0.1 0  0 0 0.4 0  0 0 0 1", False, True),  # mirrored (det < 0) and sheared
    ("-0.5 0 0 0.2  0 0.3 0.1 0  0 0 0.4 0  0 0 0 1", True, False)], ids=["plain", "flipped", "mirror", "both"])
def test_cube_is_mitsubas_mesh(tmp_path, matrix, flip, outward):
    """Mitsuba's cube (src/shapes/cube.cpp): 12 triangles of the 24 corners [-1, 1]^3 under to_world, each face's
    uv over [0, 1]^2 as Mitsuba's texcoords; every triangle's front (its winding's normal) points out of the cube
    (from its centre), also under a mirroring to_world, and in where flip_normals turns Mitsuba's normals. The
    corpus scene scenes/mitsuba/cube.xml judges the rendering (the uv's orientation, flip_normals) against
    Mitsuba."""
    extra = (f'<shape type="cube"><boolean name="flip_normals" value="{str(flip).lower()}"/>'
             f'<transform name="to_world"><matrix value="{matrix}"/></transform><ref id="white"/></shape>')
    scene = load(tmp_path, extra)
    m = np.array(matrix.split(), float).reshape(4, 4)
    triangles = scene.triangles[-12:]
    assert len(scene.triangles) == 12
    centre = m[:3, 3]
    corners = np.c_[np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float), np.ones(8)]
    np.testing.assert_allclose(sorted(map(tuple, np.unique(np.round(np.concatenate(
        [t.vertices for t in triangles]), 12), axis=0))), sorted(map(tuple, np.round((corners @ m.T)[:, :3], 12))))
    for t in triangles:
        v = np.asarray(t.vertices)
        normal = np.cross(v[1] - v[0], v[2] - v[0])
        assert (np.dot(normal, v.mean(axis=0) - centre) > 0) == outward
        assert sorted(map(tuple, np.asarray(t.uv).tolist())) in ([(0, 0), (0, 1), (1, 0)], [(0, 1), (1, 0), (1, 1)],
                                                                 [(0, 0), (1, 0), (1, 1)], [(0, 0), (0, 1), (1, 1)])


def test_inline_mesh_uv_must_match_the_vertices():
    """A scene file's inline mesh takes per-vertex uv (the cube's), one pair per vertex: another count is refused
    in one line; given, each triangle carries its corners' pairs."""
    table = {"camera": {"position": [0.0, -3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                        "fov": 40.0},
             "image": {"width": 4, "height": 4}, "render": {"shading": "path"},
             "environment": {"type": "constant", "radiance": 1.0}, "lights": [],
             "materials": {"m": {"colour": [0.5, 0.5, 0.5]}},
             "shapes": [{"type": "mesh", "material": "m", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]],
                         "faces": [[0, 1, 2]], "uv": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]}]}
    scene = raytrace.load_dict(table)
    np.testing.assert_array_equal(scene.triangles[0].uv, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    table["shapes"][0]["uv"] = [[0.0, 0.0], [1.0, 0.0]]
    with pytest.raises(InputError) as info:
        raytrace.load_dict(table)
    assert str(info.value) == ("load_dict(): shapes[0].uv = [[0.0, 0.0], [1.0, 0.0]]: must hold one pair per vertex "
                               "(3), not 2")


def test_flip_normals_turns_a_mesh_file_inside_out(tmp_path):
    """flip_normals on an obj or ply shape (Mitsuba's Mesh flip_normals): every triangle wound the other way, and
    a smooth mesh's normals turned, against the same file unflipped."""
    for kind, mesh in (("obj", "cube.obj"), ("ply", "torus.ply")):
        path = ROOT / "scenes" / "mitsuba" / "meshes" / mesh
        shapes = {flip: load(tmp_path, f'<shape type="{kind}"><string name="filename" value="{path}"/>'
                                       f'<boolean name="flip_normals" value="{str(flip).lower()}"/>'
                                       '<ref id="white"/></shape>').meshes[-1].mesh
                  for flip in (False, True)}
        np.testing.assert_array_equal(shapes[True].faces, shapes[False].faces[:, ::-1])
        if shapes[False].normals is not None:
            np.testing.assert_array_equal(shapes[True].normals, -shapes[False].normals)


DELTA_XML = """
<emitter type="point"><point name="position" x="0.1" y="0.2" z="1.5"/><rgb name="intensity" value="1, 2, 3"/>
</emitter>
<emitter type="spot">
    <transform name="to_world"><lookat origin="0, 0, 2" target="0, 0.5, 0" up="0, 1, 0"/></transform>
    <float name="cutoff_angle" value="30"/>
    <float name="beam_width" value="BEAM"/>
    <texture type="checkerboard" name="texture"/>
</emitter>
<emitter type="directional"><vector name="direction" x="0" y="0" z="-2"/><rgb name="irradiance" value="0.5"/></emitter>
<emitter type="projector">
    <transform name="to_world"><lookat origin="0, -1, 1" target="0, 0, 1" up="0, 0, 1"/></transform>
    <string name="focal_length" value="35mm"/>
</emitter>"""


def test_delta_lights_are_read_with_mitsubas_names_and_defaults(tmp_path):
    """Point, spot (a lookat, a checkerboard), directional and projector (a focal length) emitters become the
    scene's [[emitters]], beside the box's own light; a spot's beam wider than its cutoff is named at its line."""
    from raytrace.scene.model import DirectionalEmitter, PointEmitter, ProjectorEmitter, SpotEmitter
    text = scene_text(DELTA_XML.replace("BEAM", "20"))
    scene = raytrace.load_file(write(tmp_path, text), {"depth": 3})
    point, spot, sun, projector = [e for e in scene.emitters if not hasattr(e, "reflects")]
    assert isinstance(point, PointEmitter) and point.position.tolist() == [0.1, 0.2, 1.5]
    assert isinstance(spot, SpotEmitter) and spot.cutoff_angle == 30 and spot.beam_width == 20
    assert np.allclose(spot.to_world[:3, 2], np.array([0, 0.5, -2]) / np.linalg.norm([0, 0.5, -2]))
    assert spot.texture.kind == "checkerboard" and spot.texture.to_uv == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    assert isinstance(sun, DirectionalEmitter) and sun.direction.tolist() == [0.0, 0.0, -1.0]
    assert isinstance(projector, ProjectorEmitter)
    assert projector.fov == pytest.approx(2 * math.degrees(math.atan(math.hypot(36, 24) / 70 / math.sqrt(2))))
    text = scene_text(DELTA_XML.replace("BEAM", "31"))
    error = error_of(tmp_path, text)
    assert error.source.endswith(f"scene.xml:{line_of(text, 'beam_width')}") and "at most cutoff_angle" in str(error)
