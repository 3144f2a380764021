"""Scene files: the course's scene as the course gives it, and every kind of bad input named precisely."""
import tomllib
import warnings

import numpy as np
import pytest

from helpers import ROOT
from raytrace.errors import InputError
from raytrace.scene import load_file, parse_scene

CORNELL = ROOT / "scenes" / "cornell.toml"


def test_cornell_is_the_course_scene(cornell):
    assert (cornell.width, cornell.height) == (512, 512)
    np.testing.assert_array_equal(cornell.camera.position, [0, -3, 1.3])
    assert cornell.camera.fov_deg == 45
    assert len(cornell.rectangles) == 5 and len(cornell.triangles) == 4 and len(cornell.ellipsoids) == 1
    colours = {m.name: m.colour.tolist() for m in cornell.materials}
    assert colours["red"] == [0.8, 0, 0] and colours["yellow"] == [1, 0.93, 0.6]
    left = cornell.rectangles[2]
    np.testing.assert_array_equal(left.center, [-1, 0, 1])
    assert cornell.materials[left.material].name == "red"
    np.testing.assert_array_equal(cornell.triangles[3].vertices, [[-1, 0.2, 0.2], [-0.5, -0.3774, 1], [0, 0.2, 0.2]])
    np.testing.assert_array_equal(cornell.ellipsoids[0].axes, [[0.3, 0.1, 0], [-0.1, 0.3, 0], [0, 0, 0.4]])


def broken(edit):
    table = tomllib.loads(CORNELL.read_text())
    edit(table)
    with pytest.raises(InputError) as info:
        parse_scene(table, "broken.toml")
    return info.value, str(info.value)


@pytest.mark.parametrize("edit,key,value", [
    (lambda t: t["camera"].update(positon=[0, 0, 0]), "camera.positon", [0, 0, 0]),
    (lambda t: t["camera"].update(position=[0, 0]), "camera.position", [0, 0]),
    (lambda t: t["shapes"][6].update(axes=[[1, 0, 0], [0, 1, 0], [1, 1, 0]]), "shapes[6].axes",
     [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]),
    (lambda t: t["shapes"][0].update(size=[0, 2]), "shapes[0].size", [0.0, 2.0]),
    (lambda t: t["shapes"][1].update(material="gold"), "shapes[1].material", "gold"),
    (lambda t: t["shapes"][2].update(type="sphere"), "shapes[2].type", "sphere"),
    (lambda t: t["shapes"][5].update(faces=[[0, 1, 7]]), "shapes[5].faces[0]", [0, 1, 7]),
    (lambda t: t["image"].update(width=0), "image.width", 0),
    (lambda t: t["materials"]["red"].update(colour=[1, "x", 0]), "materials.red.colour", [1, "x", 0]),
    (lambda t: t["shapes"][3].update(tangent=[-1, 0, 0]), "shapes[3].tangent", [-1.0, 0.0, 0.0]),
    (lambda t: t["lights"][0].update(colour=[1, 1, -1]), "lights[0].colour", [1, 1, -1]),
    (lambda t: t.update(fog=1), "fog", 1),
])
def test_bad_keys_are_named(edit, key, value):
    error, text = broken(edit)
    assert (error.source, error.key, error.value) == ("broken.toml", key, value)
    assert "\n" not in text and text.startswith(f"broken.toml: {key} = ")


def test_missing_and_broken_files(tmp_path):
    with pytest.raises(InputError, match="nope.toml: file"):
        load_file(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera\nposition = 1")
    with pytest.raises(InputError, match="bad.toml:1:8: toml: "):
        load_file(bad)


@pytest.mark.parametrize("entry, key, value", [
    ({"uv_scale": [0.0, 1.0]}, "uv_scale", [0.0, 1.0]),
    ({"uv_scale": [-2.0, 1.0]}, "uv_scale", [-2.0, 1.0]),
    ({"uv_scale": [1.0, 1e39]}, "uv_scale", [1.0, 1e39]),
    ({"uv_scale": [1e-39, 1.0]}, "uv_scale", [1e-39, 1.0]),
    ({"uv_offset": [-1e39, 0.0]}, "uv_offset", [-1e39, 0.0]),
    ({"height_map": "../assets/textures/bricks_height.png", "height_scale": -0.1}, "height_scale", -0.1),
    ({"height_scale": 0.1}, "height_scale", 0.1),
    ({"height_map": "../assets/textures/bricks_height.png"}, "height_map", "../assets/textures/bricks_height.png"),
    ({"wrap": "tile"}, "wrap", "tile"),
    ({"uv_offset": [0.0]}, "uv_offset", [0.0]),
    ({"texture": 7}, "texture", 7),
])
def test_bad_texture_keys_are_named(entry, key, value):
    table = tomllib.loads(CORNELL.read_text())
    table["materials"]["red"].update(entry)
    with pytest.raises(InputError) as info:
        parse_scene(table, str(CORNELL))
    assert (info.value.source, info.value.key, info.value.value) == (str(CORNELL), f"materials.red.{key}", value)


def test_texture_files_resolve_from_the_scene_and_missing_ones_are_named(tmp_path):
    """Paths are relative to the scene file, wherever the process runs; a missing file names the scene,
    the key and the path it looked for."""
    table = tomllib.loads(CORNELL.read_text())
    table["materials"]["red"]["texture"] = "../assets/textures/grid.png"
    scene = parse_scene(table, str(CORNELL))
    assert len(scene.textures) == 1 and scene.materials[1].colour_map == 0
    table["materials"]["red"]["texture"] = "nowhere.png"
    with pytest.raises(InputError) as info:
        parse_scene(table, str(tmp_path / "s.toml"))
    assert info.value.key == "materials.red.texture" and info.value.value == str(tmp_path / "nowhere.png")
    assert "cannot read the image" in str(info.value)


def test_textured_scenes_load(tmp_path):
    """Every shipped scene loads; a texture used by several materials in one role is read once."""
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        scene = load_file(path)
        assert len({(t.path, t.role) for t in scene.textures}) == len(scene.textures)
    textured = load_file(ROOT / "scenes" / "textured_cornell.toml")
    assert len(textured.textures) == 5  # bricks colour, normal, height; stones colour, height


def test_found_by_the_fuzz_suite(tmp_path):
    """Four kinds of input tests/test_fuzz.py found ending in a traceback or two lines: a file name or a TOML
    key holding a newline (now escaped, the error one line), an integer beyond float64 (TypeError in
    isfinite), arrays nested thousands deep (tomllib's RecursionError), and a normal of [1e-200, 0, 0], whose
    length underflowed in float64 (a numpy warning, then NaN)."""
    named = tmp_path / "a\nb.toml"
    error = str(InputError(named, "camera.a\nb", None, "unknown key"))
    assert "\n" not in error and "a\\nb.toml: camera.a\\nb: unknown key" in error
    table = tomllib.loads(CORNELL.read_text())
    table["camera"]["position"] = [0, 10 ** 400, 1]
    with pytest.raises(InputError, match="camera.position.*beyond float32"):
        parse_scene(table, "big.toml")
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 100000 + "]" * 100000 + "\n")
    with pytest.raises(InputError, match="nested too deeply"):
        load_file(deep)
    table = tomllib.loads(CORNELL.read_text())
    table["lights"][0]["normal"] = [0.0, 0.0, -1e-200]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = parse_scene(table, "tiny.toml")
    np.testing.assert_array_equal(scene.lights[0].normal, [0, 0, -1])


def _error(text):
    with pytest.raises(InputError) as error:
        load_file_text(text)
    assert "\n" not in str(error.value)
    return str(error.value)


def load_file_text(text):
    from raytrace import load_string
    return load_string(text)


CORNELL_TEXT = (ROOT / "scenes" / "cornell.toml").read_text()


def test_a_toml_error_says_line_and_column(tmp_path):
    """A newcomer's syntax error read `toml = "...": is not valid TOML`: now file:line:column, as compilers
    write it."""
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera]\nposition = [0, 0\n")
    with pytest.raises(InputError) as error:
        load_file(bad)
    assert str(error.value) == f"{bad}:3:1: toml: Unclosed array: not valid TOML"
    bad.write_text("a = 1\nb = = 2\n")
    with pytest.raises(InputError, match=rf"^{bad}:2:5: toml: Invalid value: not valid TOML$"):
        load_file(bad)


def test_a_misspelt_key_or_name_gets_a_suggestion():
    """`color` for `colour`, `[[light]]` for `[[lights]]`, `fow`, `dielectirc`: the closest known name."""
    assert "unknown key, did you mean 'fov'?" in _error(CORNELL_TEXT.replace("fov = 45.0", "fow = 45.0"))
    lights = _error(CORNELL_TEXT.replace("[[lights]]", "[[light]]"))
    assert "unknown key, did you mean 'lights'?" in lights
    assert "unknown key, did you mean 'colour'?" in _error(CORNELL_TEXT.replace(
        "white = { colour", "white = { color", 1))
    path = (ROOT / "scenes" / "cornell_path.toml").read_text().replace(
        "yellow = { colour = [1.0, 0.93, 0.6] }", 'yellow = { type = "dielectirc" }')
    assert "roughplastic, null, principled, principledthin, blendbsdf, mask; did you mean 'dielectric'?" in _error(path)


def test_a_long_value_is_cut_in_the_line():
    """An unknown key holding a million-item list printed all of it (a 3 MB line): a value shows at most 80
    characters, both ends kept; a string, a file's path say, up to 400."""
    table = tomllib.loads(CORNELL_TEXT)
    table["camera"]["junk"] = list(range(10**6))
    with pytest.raises(InputError) as error:
        parse_scene(table, "s.toml")
    assert str(error.value).startswith("s.toml: camera.junk = [0, 1, 2, 3, ") and " ... " in str(error.value)
    assert len(str(error.value)) < 300 and error.value.value == list(range(10**6))  # the value itself is whole


def test_an_empty_file_name_names_no_file():
    """environment.filename = "" reported the scene's folder as the value (the folder joined with nothing)."""
    path = ROOT / "scenes" / "materials.toml"
    table = tomllib.loads(path.read_text())
    table["environment"]["filename"] = ""
    with pytest.raises(InputError) as error:
        parse_scene(table, str(path))
    assert str(error.value) == f"{path}: environment.filename = '': must name a file"


def test_a_missing_mesh_file_names_the_scene_and_the_shape(tmp_path):
    """A missing mesh file was named by itself alone (`nope.obj: file = ...`): like a texture, it is named by
    the scene file and its key; what is wrong inside a mesh file is still named by that file and its line."""
    scene = tmp_path / "s.toml"
    scene.write_text((ROOT / "scenes" / "mesh_cornell.toml").read_text().replace("../assets/torus.ply", "nope.obj"))
    with pytest.raises(InputError) as error:
        load_file(scene)
    assert str(error.value) == f"{scene}: shapes[7].file = '{tmp_path / 'nope.obj'}': No such file or directory"
