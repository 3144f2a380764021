"""The Python API (docs/python-api.md) as a script uses it: the three ways to load a scene, editing it by name,
rendering with an explicit signature, and the Image it returns.

The scene file's checks are one table (BAD_VALUES, each a value at a named place and the key and value the
error must name), replayed on every path into the kernel: a scene file, load_dict, a parameter edit and, where
the value has a place in the scene model, a scene changed in Python behind the checks' back (render() checks
it again). A new row covers all four."""
import dataclasses
import inspect
import json
import subprocess
import sys
import tomllib
import warnings

import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
from helpers import ROOT
from raytrace.cli import parser
from raytrace.options import RenderOptions, declared
from raytrace.parameters import FeaturesChanged
from raytrace.scene.toml_writer import to_toml

CORNELL = ROOT / "scenes" / "cornell.toml"
SMALL = dict(width=16, height=16, spp=4, light_samples=4, progress=False)
NAN = float("nan")

# (the value's name, the bad value, the key the error names, the value it names)
BAD_VALUES = [
    ("camera.positon", [0, 0, 0], "camera.positon", [0, 0, 0]),
    ("camera.position", [0, 0], "camera.position", [0, 0]),
    ("camera.position", [0, -1e39, 1], "camera.position", [0, -1e39, 1]),
    ("camera.position", [0, -2e18, 1], "camera.position", [0, -2e18, 1]),
    ("camera.fov", 180.0, "camera.fov", 180.0),
    ("camera.focal_length", 0.0, "camera.focal_length", 0.0),
    ("shapes[6].axes", [[1, 0, 0], [0, 1, 0], [1, 1, 0]], "shapes[6].axes", [[1, 0, 0], [0, 1, 0], [1, 1, 0]]),
    ("shapes[0].size", [0, 2], "shapes[0].size", [0, 2]),
    ("shapes[1].material", "gold", "shapes[1].material", "gold"),
    ("shapes[2].type", "sphere", "shapes[2].type", "sphere"),
    ("shapes[5].faces", [[0, 1, 7]], "shapes[5].faces[0]", [0, 1, 7]),
    ("shapes[5].vertices", [[-1e39, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "shapes[5].vertices",
     [-1e39, 0, 0]),
    ("image.width", 0, "image.width", 0),
    ("render.spp", 15, "render.sampler", "grid"),
    ("materials.red.colour", [1, "x", 0], "materials.red.colour", [1, "x", 0]),
    ("materials.red.shininess", -1.0, "materials.red.shininess", -1.0),
    ("materials.red.wrap", "tile", "materials.red.wrap", "tile"),
    ("materials.red.texture", "a\0b.png", "materials.red.texture", "a\0b.png"),
    ("shapes[3].tangent", [-1, 0, 0], "shapes[3].tangent", [-1, 0, 0]),
    ("lights[0].colour", [1, 1, -1], "lights[0].colour", [1, 1, -1]),
    ("lights[0].colour", [NAN, -1, 1], "lights[0].colour", [NAN, -1, 1]),
    ("lights[0].colour", [1e20, 1, 1], "lights[0].colour", [1e20, 1, 1]),
    ("lights[0].size", [1e39, 1], "lights[0].size", [1e39, 1]),
    ("ambient", [-0.1, 0, 0], "ambient", [-0.1, 0, 0]),
    ("fog", 1, "fog", 1),
]
IDS = [f"{name}={value}" for name, value, _, _ in BAD_VALUES]


def same(a, b):
    """Values equal as the error gives them (a NaN equal to a NaN)."""
    return json.dumps(a, allow_nan=True) == json.dumps(b, allow_nan=True) or np.array_equal(
        np.asarray(a, dtype=object), np.asarray(b, dtype=object))


def cornell_table():
    return tomllib.loads(CORNELL.read_text())


def edited_table(name, value):
    """Scene 0's table with `value` at `name` (a name raytrace.parameters takes)."""
    raytrace.parameters(raytrace.load_file(CORNELL))[name] = value  # KeyError if it names no place
    table = cornell_table()
    steps = [int(s) if s.isdigit() else s for s in name.replace("[", ".").replace("]", "").split(".")]
    node = table
    for step in steps[:-1]:
        node = node[step]
    node[steps[-1]] = value
    return table


def check_error(error, source, key, value):
    assert (error.source, error.key) == (source, key), str(error)
    assert same(error.value, value), (error.value, str(error))
    assert "\n" not in str(error)


@pytest.mark.parametrize("name, value, key, shown", BAD_VALUES, ids=IDS)
def test_a_bad_value_in_a_file(tmp_path, name, value, key, shown):
    """A real file (scene 0 names no texture or mesh file, so it may lie anywhere), written and read back."""
    path = tmp_path / "s.toml"
    path.write_text(to_toml(edited_table(name, value)))
    with pytest.raises(raytrace.InputError) as error:
        raytrace.load_file(path)
    check_error(error.value, str(path), key, shown)


@pytest.mark.parametrize("name, value, key, shown", BAD_VALUES, ids=IDS)
def test_a_bad_value_in_a_dict(name, value, key, shown):
    table = edited_table(name, value)
    with pytest.raises(raytrace.InputError) as error:
        raytrace.load_dict(table)
    check_error(error.value, "load_dict()", key, shown)


@pytest.mark.parametrize("name, value, key, shown", BAD_VALUES, ids=IDS)
def test_a_bad_value_as_a_parameter_edit(name, value, key, shown):
    """The edit is refused by update(), naming the value, and the scene is left as it was."""
    scene = raytrace.load_file(CORNELL)
    before = raytrace.scene.model.fingerprint(scene)
    params = raytrace.parameters(scene)
    params[name] = value
    with pytest.raises(raytrace.InputError) as error:
        params.update()
    check_error(error.value, f"parameters({CORNELL})", key, shown)
    assert raytrace.scene.model.fingerprint(scene) == before and scene.revision == 0


# Where a value of BAD_VALUES lives in the scene model: (the model's name, a function setting it on a scene).
MODEL = {
    "camera.position": ("camera.position", lambda s, v: setattr(s, "camera", dataclasses.replace(
        s.camera, position=np.array(v, float)))),
    "camera.fov": ("camera.fov", lambda s, v: setattr(s, "camera", dataclasses.replace(s.camera, fov_deg=v))),
    "camera.focal_length": ("camera.focal_length", lambda s, v: setattr(s, "camera", dataclasses.replace(
        s.camera, focal_length=v))),
    "materials.red.shininess": ("materials.red.shininess", lambda s, v: s.materials.__setitem__(
        1, dataclasses.replace(s.materials[1], shininess=v))),
    "materials.red.wrap": ("materials.red.wrap", lambda s, v: s.materials.__setitem__(
        1, dataclasses.replace(s.materials[1], wrap=v))),
    "lights[0].colour": ("lights[0].colour", lambda s, v: s.lights.__setitem__(
        0, dataclasses.replace(s.lights[0], colour=np.array(v, float)))),
    "lights[0].size": ("lights[0].size", lambda s, v: s.lights.__setitem__(
        0, dataclasses.replace(s.lights[0], size=np.array(v, float)))),
    "ambient": ("ambient", lambda s, v: setattr(s, "ambient", np.array(v, float))),
    "shapes[6].axes": ("ellipsoids[0].axes", lambda s, v: s.ellipsoids.__setitem__(
        0, dataclasses.replace(s.ellipsoids[0], axes=np.array(v, float)))),
    "shapes[0].size": ("rectangles[0].size", lambda s, v: s.rectangles.__setitem__(
        0, dataclasses.replace(s.rectangles[0], size=np.array(v, float)))),
}


@pytest.mark.parametrize("name, value, key, shown", [c for c in BAD_VALUES if c[0] in MODEL],
                         ids=[i for c, i in zip(BAD_VALUES, IDS) if c[0] in MODEL])
def test_a_bad_value_set_behind_the_checks_is_refused_by_render(name, value, key, shown):
    """A scene changed in Python (dataclasses.replace, an assignment) is checked again by render(), with the
    file's checks, before any work: the NaN light colour of the issue renders no negative pixel."""
    scene = raytrace.load_file(CORNELL)
    model_name, set_value = MODEL[name]
    set_value(scene, value)
    with pytest.raises(raytrace.InputError) as error:
        raytrace.render(scene, **SMALL)
    assert (error.value.source, error.value.key) == ("render()", model_name), str(error.value)


def test_every_model_place_is_exercised():
    assert set(MODEL) <= {name for name, _, _, _ in BAD_VALUES}


def test_the_three_loaders_give_the_same_scene():
    from raytrace.scene.model import fingerprint
    text = CORNELL.read_text()
    by_file = raytrace.load_file(CORNELL)
    by_dict = raytrace.load_dict(tomllib.loads(text))
    by_string = raytrace.load_string(text)
    assert fingerprint(by_file) == fingerprint(by_dict) == fingerprint(by_string)
    assert (by_dict.path, by_string.path) == ("load_dict()", "load_string()")
    with pytest.raises(raytrace.InputError, match=r"^load_string\(\):1:8: toml: "):
        raytrace.load_string("[camera")


def test_load_dict_takes_numpy_values():
    table = cornell_table()
    table["shapes"][6]["center"] = np.array([0.5, 0.4, 0.4])
    table["camera"]["fov"] = np.float32(45.0)
    table["image"]["width"] = np.int64(512)
    scene = raytrace.load_dict(table)
    assert scene.camera.fov_deg == 45.0 and scene.width == 512


def test_parameters_edit_and_render_again():
    """An edit is seen by the next render (the scene's packed tables are made anew): its image is that of the
    scene loaded with the edited value, to the bit; and a second render with no edit in between rebuilds
    nothing."""
    scene = raytrace.load_file(CORNELL)
    first = np.asarray(raytrace.render(scene, **SMALL)[0]).copy()
    params = raytrace.parameters(scene)
    assert params["lights[0].colour"] == [1.0, 1.0, 1.0] and "materials.red.colour" in params
    params["lights[0].colour"] = np.array([0.5, 0.5, 0.5])
    assert params["lights[0].colour"] == [0.5, 0.5, 0.5]  # staged
    assert scene.lights[0].colour.tolist() == [1.0, 1.0, 1.0]
    assert params.update() == {"lights[0].colour"} and scene.revision == 1
    second, stats = raytrace.render(scene, **SMALL)
    assert np.asarray(second).mean() < first.mean() and stats.build_seconds < 0.5
    text = open(CORNELL).read()  # the same scene with the edited value in its file: the same image, to the bit
    assert text.count("colour = [1.0, 1.0, 1.0]") == 1
    edited = raytrace.load_string(text.replace("colour = [1.0, 1.0, 1.0]", "colour = [0.5, 0.5, 0.5]"))
    np.testing.assert_array_equal(np.asarray(second), np.asarray(raytrace.render(edited, **SMALL)[0]))
    assert raytrace.render(scene, **SMALL)[1].build_seconds == 0  # the program is kept
    with pytest.raises(KeyError):
        params["lights[3].colour"] = [1, 1, 1]  # no such light
    with pytest.raises(KeyError):
        params["camera..fov"]


def test_an_edit_that_changes_the_kernel_says_so():
    scene = raytrace.load_file(CORNELL)
    params = raytrace.parameters(scene)
    params["materials.white.texture"] = "../assets/textures/bricks_colour.png"
    with pytest.warns(FeaturesChanged, match="colour_maps on"):
        params.update()
    params["materials.white.shininess"] = 20.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        params.update()  # no feature changed: no warning


def test_a_scene_built_without_a_source_has_no_parameters():
    scene = raytrace.load_file(CORNELL)
    scene.source = None
    with pytest.raises(raytrace.InputError, match="was not read by load_file"):
        raytrace.parameters(scene)


def test_render_takes_the_declared_options_explicitly():
    """render()'s keyword arguments are raytrace/options.py's declarations, name for name and default for
    default, in order, each documented in its docstring; no **kwargs hides one."""
    signature = inspect.signature(raytrace.render)
    params = list(signature.parameters.values())[1:]
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params)
    assert [(p.name, p.default) for p in params] == [(name, default) for name, default, *_ in declared()]
    for name, *_ in declared():
        assert f"\n        {name}: " in raytrace.render.__doc__, name


def test_the_command_line_offers_the_declared_options():
    """render, bench and converge take the options marked for the command line, with their defaults."""
    commands = next(a for a in parser()._actions if a.dest == "command").choices
    cli = {name: default for name, default, _, on_cli, _, _ in declared() if on_cli}
    for command in ("render", "bench"):
        options = {a.dest: a.default for a in commands[command]._actions if a.option_strings}
        for name, default in cli.items():
            assert name in options, (command, name)
            if command == "render":
                assert options[name] == default, (command, name)


@pytest.mark.parametrize("keyword, value, problem", [
    ("spp", 0, "[1, 65536]"), ("width", 0, "[1, 16384]"), ("seed", -1, "[0, 4294967295]"),
    ("texture_filter", "cubic", "unknown filter"), ("shading", "toon", "phong, direct"),
    ("time_limit", "soon", "positive number"), ("scheduler", "nowhere", "local:N or tcp://host:port")])
def test_errors_from_python_name_the_keyword(keyword, value, problem):
    scene = raytrace.load_file(CORNELL)
    with pytest.raises(raytrace.InputError) as error:
        raytrace.render(scene, **{**SMALL, keyword: value})
    assert str(error.value).startswith(f"render(): {keyword} = {value!r}: ") and problem in str(error.value)


def test_the_image_is_an_array_that_writes_itself(tmp_path):
    """image.write gives the command line's files: an EXR with the variance channels and the metadata, a PNG
    in the course's 8-bit encoding; np.asarray shares its memory; Jupyter gets a PNG."""
    scene = raytrace.load_file(CORNELL)
    image, stats = raytrace.render(scene, **SMALL)
    assert isinstance(image, np.ndarray) and image.shape == (16, 16, 3) and image.dtype == np.float32
    assert np.shares_memory(np.asarray(image), image) and image.stats is stats
    image.write(tmp_path / "x.exr")
    exr = oiio.ImageInput.open(str(tmp_path / "x.exr"))
    spec, pixels = exr.spec(), exr.read_image("float")
    exr.close()
    assert spec.channelnames == ("R", "G", "B", "variance.R", "variance.G", "variance.B")
    np.testing.assert_array_equal(pixels[..., :3], image)
    np.testing.assert_array_equal(pixels[..., 3:], image.variance)
    assert spec.getattribute("raytrace:spp") == 4 and spec.getattribute("raytrace:scene") == str(CORNELL)
    image.write(tmp_path / "x.png")
    png = oiio.ImageInput.open(str(tmp_path / "x.png"))
    codes = png.read_image("uint8")
    png.close()
    expected = np.ceil(255 * np.clip(np.asarray(image), 0, 1) ** (1 / 2.2) - 1e-9)
    np.testing.assert_array_equal(codes, expected)
    assert image._repr_png_().startswith(b"\x89PNG")
    with pytest.raises(raytrace.InputError, match=r"^Image.write\(\): path = .*unsupported extension"):
        image.write(tmp_path / "x.gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.exr", "x.png"]


UNGUARDED = """
import raytrace
scene = raytrace.load_file({scene!r})
raytrace.render(scene, width=8, height=8, spp=1, light_samples=1, scheduler="local:1")
"""


def test_a_script_without_the_main_guard_gets_one_line(tmp_path):
    """Dask's local workers run the script again from the top: unguarded, it would start workers of its own.
    The script ends with one line saying so, naming the line, and no traceback from the workers."""
    script = tmp_path / "script.py"
    script.write_text(UNGUARDED.format(scene=str(CORNELL)))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("raytrace.errors.InputError: render(): scheduler = 'local:1': starts worker processes")
    assert f"{script} again from the top, whose line 4" in last and "Nanny" not in r.stderr


def test_a_guarded_script_renders_on_local_workers(tmp_path):
    script = tmp_path / "script.py"
    body = UNGUARDED.format(scene=str(CORNELL)).strip().splitlines()
    script.write_text("\n".join([body[0], 'if __name__ == "__main__":', *("    " + line for line in body[1:]),
                                 '    print("rendered")']) + "\n")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "rendered", r.stderr[-2000:]


def test_every_public_name_is_documented():
    for name in raytrace.__all__:
        obj = getattr(raytrace, name)
        assert inspect.getdoc(obj) and len(inspect.getdoc(obj)) > 40, name


def test_the_manuals_example_session_runs(tmp_path):
    """docs/example.py, shown on the API page, as a user runs it from the checkout."""
    r = subprocess.run([sys.executable, str(ROOT / "docs" / "example.py"), str(tmp_path)], capture_output=True,
                       text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[2] == "changed: ['lights[0].colour', 'materials.yellow.shininess']"
    assert lines[3].startswith("refused: parameters(scenes/cornell.toml): lights[0].colour = [nan, -1.0, 1.0]")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["after.exr", "before.png"]


def _one_line(call):
    """The InputError `call` raises, checked to be one line."""
    with pytest.raises(raytrace.InputError) as error:
        call()
    assert "\n" not in str(error.value)
    return error.value


def test_a_dict_that_no_scene_file_could_be_is_one_line():
    """Found (issue 55, item 5): a key that is not a string (TypeError), a dict that holds itself or nests
    deeper than any scene (RecursionError). Each is now an InputError naming the place."""
    table = cornell_table()
    table["camera"][3] = 1.0
    error = _one_line(lambda: raytrace.load_dict(table))
    assert (error.source, error.key, error.value) == ("load_dict()", "camera", 3)
    table = cornell_table()
    table["camera"]["itself"] = table["camera"]
    assert "nested more than 32 deep" in str(_one_line(lambda: raytrace.load_dict(table)))
    deep = inner = []
    for _ in range(5000):
        inner.append([])
        inner = inner[0]
    table = cornell_table()
    table["ambient"] = deep
    assert str(_one_line(lambda: raytrace.load_dict(table))).startswith("load_dict(): ambient[0][0]")
    assert str(_one_line(lambda: raytrace.load_dict([1]))) == \
        "load_dict(): table = 'list': must be a dict laid out as a scene file"


def test_no_scene_is_one_line():
    """Found (item 5): render(None), parameters(None) and load_file(None) raised AttributeError or TypeError."""
    assert str(_one_line(lambda: raytrace.render(None))) == ("render(): scene = 'NoneType': must be a "
                                                            "raytrace.scene.Scene, from load_file, load_dict or "
                                                            "load_string")
    assert str(_one_line(lambda: raytrace.parameters(None))).startswith("parameters(): scene = 'NoneType': ")
    assert str(_one_line(lambda: raytrace.load_file(None))).startswith("load_file(): path = 'NoneType': ")


def test_a_path_no_file_can_have_is_one_line():
    """Found in review: a NUL in the name, or a PathLike giving bytes, raised ValueError or TypeError."""
    class BytesPath:
        def __fspath__(self):
            return b"scene.toml"

    assert "holds a NUL character" in str(_one_line(lambda: raytrace.load_file("a\0b.toml")))
    assert "must be a str or os.PathLike path" in str(_one_line(lambda: raytrace.load_file(BytesPath())))


@pytest.mark.parametrize("lanes", [3, 2.0, True, "8"])
def test_a_lane_width_the_kernel_does_not_take_is_one_line(lanes):
    """Found (item 5): render(scene, lanes=3) ended in OpenCL's multi-line build log."""
    scene = raytrace.load_file(CORNELL)
    error = _one_line(lambda: raytrace.render(scene, lanes=lanes, **SMALL))
    assert str(error) == f"render(): lanes = {lanes!r}: must be one of 1, 4, 8, 16"


def test_an_edit_with_no_place_is_one_line_and_discarded():
    """Found (item 5): params["lights[5]"] = ... then update() raised IndexError, and every later update() again
    (the edit stayed staged); del params["camera"] then an edit of camera.fov raised KeyError. An index past
    the next element is now refused when it is set; an edit whose place another edit removed is one line at
    update(), the scene unchanged; discard() drops the staged edits, and the next edit applies."""
    scene = raytrace.load_file(CORNELL)
    before = raytrace.scene.model.fingerprint(scene)
    params = raytrace.parameters(scene)
    with pytest.raises(KeyError, match=r"lights has 1 elements; an edit may add lights\[1\]"):
        params["lights[5]"] = {"center": [0.0, 0.0, 1.0]}
    del params["camera"]
    params["camera.fov"] = 40.0
    error = _one_line(params.update)
    assert (error.key, error.value) == ("camera.fov", 40.0) and "discard()" in error.problem
    _one_line(params.update)  # still staged: refused again, the scene as it was
    assert raytrace.scene.model.fingerprint(scene) == before
    params.discard()
    params["camera.fov"] = 40.0
    assert params.update() == {"camera.fov"} and scene.camera.fov_deg == 40.0


def test_a_keyword_render_does_not_take_names_the_one_meant():
    """A newcomer's render(samples=16), and a misspelt keyword: the TypeError says which option was meant
    (Mitsuba's sample_count and pbrt's pixelsamples too), and render()'s signature is still its own."""
    scene = raytrace.load_file(CORNELL)
    for given, meant in (("samples", "spp"), ("sample_count", "spp"), ("light_sampels", "light_samples"),
                         ("sead", "seed")):
        with pytest.raises(TypeError, match=f"unexpected keyword argument '{given}'; did you mean '{meant}'"):
            raytrace.render(scene, **{given: 16})
    assert "spp" in inspect.signature(raytrace.render).parameters


def test_the_package_shows_its_api():
    """dir(raytrace) showed os, sys, signal and the submodules; print(scene) dumped every vertex."""
    assert dir(raytrace) == sorted(raytrace.__all__)
    scene = raytrace.load_file(ROOT / "scenes" / "mesh_cornell.toml")
    assert repr(scene) == ("Scene('" + str(ROOT / "scenes" / "mesh_cornell.toml") + "': 512x512, phong, 1 light, "
                           "6 materials, 5 rectangles, 1 ellipsoid, 100108 triangles, 0 textures)")


def test_values_no_toml_file_holds():
    """Found by the fuzz suite's dicts and edits: a generator as a value raised TypeError from deepcopy; an
    index into a table (params["camera[1]"]) one from the key check. Any Mapping reads as a table."""
    import types
    table = cornell_table()
    table["camera"]["fov"] = (x for x in [45.0])
    error = _one_line(lambda: raytrace.load_dict(table))
    assert (error.key, error.value) == ("camera.fov", "generator")
    table = cornell_table()
    table["camera"] = types.MappingProxyType(table["camera"])
    assert raytrace.load_dict(table).camera.fov_deg == 45.0
    params = raytrace.parameters(raytrace.load_file(CORNELL))
    with pytest.raises(raytrace.InputError) as refused:
        params["camera.fov"] = types.MappingProxyType({"a": 1}).values()
    assert (refused.value.source, refused.value.key, refused.value.value) == (
        f"parameters({CORNELL})", "camera.fov", "dict_values")
    with pytest.raises(KeyError):
        params["camera[1]"] = 5
