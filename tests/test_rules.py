"""The rules between a scene's values (raytrace/scene/rules.py) have one owner and run on the final model: a
bad combination is refused with the same line whether it comes from a scene file, a dict, a parameter edit,
render()'s options (on this process or a Dask cluster) or the command line's. Only the source differs (the
file, load_dict(), parameters(...)); the key, the value and the problem are the same, to the character.

Each rule's text is written once in raytrace/ (an AST scan below), so a rule cannot be stated twice and drift."""
import ast
import re
import tomllib
from collections import defaultdict

import pytest

import raytrace
from helpers import ROOT, run

CORNELL_PATH = ROOT / "scenes" / "cornell_path.toml"
CORNELL_DIRECT = ROOT / "scenes" / "cornell_direct.toml"
CORNELL = ROOT / "scenes" / "cornell.toml"
CONDUCTOR = "yellow = { type = \"conductor\" }"


def _path_scene_text():
    """scenes/cornell_path.toml with its yellow material a mirror: a scene only the path model renders."""
    text = CORNELL_PATH.read_text()
    assert text.count("yellow = { colour = [1.0, 0.93, 0.6] }") == 1
    return text.replace("yellow = { colour = [1.0, 0.93, 0.6] }", CONDUCTOR)


def _direct_with_ambient_text():
    text = CORNELL_DIRECT.read_text()
    assert "\nambient" not in text
    return "ambient = [0.1, 0.1, 0.1]\n" + text


def _written(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _catch(call):
    with pytest.raises(raytrace.InputError) as error:
        call()
    return error.value


SMALL = dict(width=8, height=8, spp=1, light_samples=1)

# (the rule: the scene as written with the bad value; a scene it is valid in, with the option that breaks it;
# a scene and the parameter edit that breaks it; the line every entry gives)
CASES = {
    "a mirror outside the path model": (
        lambda: _path_scene_text().replace('shading = "path"', 'shading = "direct"'),
        _path_scene_text, dict(shading="direct"), (_path_scene_text, "render.shading", "direct"),
        "materials.yellow.type = 'conductor': is the path model's: only with shading = \"path\", not \"direct\""),
    "an ambient term outside the Phong model": (
        _direct_with_ambient_text, CORNELL.read_text, dict(shading="direct"),
        (CORNELL_DIRECT.read_text, "ambient", [0.1, 0.1, 0.1]),
        "ambient = [0.1, 0.1, 0.1]: is the Phong model's: shading = \"direct\" has no ambient term"),
    "a bounded depth outside the path model": (
        lambda: CORNELL_PATH.read_text().replace('shading = "path"', 'shading = "direct"\nmax_depth = 3'),
        CORNELL_DIRECT.read_text, dict(max_depth=3), (CORNELL_DIRECT.read_text, "render.max_depth", 3),
        "render.max_depth = 3: is the path model's: only with shading = \"path\", not \"direct\""),
}


def _line(error):
    """The error's line without its source."""
    text = str(error)
    assert text.startswith(error.source + ": "), text
    return text[len(error.source) + 2:]


@pytest.mark.parametrize("case", CASES)
def test_the_same_line_from_every_entry(tmp_path, case):
    bad, valid, option, edit, line = CASES[case]
    lines = {}
    path = _written(tmp_path, bad())
    lines["file"] = _line(_catch(lambda: raytrace.load_file(path)))
    lines["string"] = _line(_catch(lambda: raytrace.load_string(bad())))
    lines["dict"] = _line(_catch(lambda: raytrace.load_dict(tomllib.loads(bad()))))
    base, name, value = edit
    params = raytrace.parameters(raytrace.load_string(base()))
    params[name] = value
    error = _catch(params.update)
    assert error.source == "parameters(load_string())"
    lines["edit"] = _line(error)
    valid_path = _written(tmp_path, valid())
    scene = raytrace.load_file(valid_path)
    error = _catch(lambda: raytrace.render(scene, **SMALL, **option))
    assert error.source == str(valid_path)  # the scene's value is named where it was written
    lines["render()"] = _line(error)
    lines["render() on Dask"] = _line(_catch(lambda: raytrace.render(scene, **SMALL, **option, scheduler="local:1")))
    flags = [f"--{k.replace('_', '-')}={v}" for k, v in option.items()]
    r = run("render", valid_path, "-o", tmp_path / "out.png", *flags, "--width", 8, "--height", 8, "--spp", 1)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr == f"raytrace: error: {valid_path}: {line}\n"
    lines["command line"] = r.stderr.strip().split(f"{valid_path}: ", 1)[1]
    assert not (tmp_path / "out.png").exists()
    assert lines == {entry: line for entry in lines}


def test_a_shading_override_keeps_the_path_models_scene_whole(tmp_path):
    """The issue's case: `render scenes/materials.toml --shading phong` rendered without the mirror, the gold,
    the glass and the sky (exit 0) while the same shading in the file was refused. The override now meets the
    file's rules: the first the scene breaks under Phong, its depth."""
    out = tmp_path / "m.png"
    r = run("render", ROOT / "scenes" / "materials.toml", "--shading", "phong", "-o", out)
    assert r.returncode == 2 and not out.exists()
    assert r.stderr == (f"raytrace: error: {ROOT / 'scenes' / 'materials.toml'}: render.max_depth = 8: is the path "
                        "model's: only with shading = \"path\", not \"phong\"\n")


def test_an_override_the_scene_takes_renders_as_the_file_would(tmp_path):
    """shading = "direct" given as an option renders the image the scene gives with it in its file, to the bit."""
    scene = raytrace.load_file(CORNELL_PATH)
    image, _ = raytrace.render(scene, **SMALL, shading="direct")
    written = raytrace.load_string(CORNELL_PATH.read_text().replace('shading = "path"', 'shading = "direct"'))
    expected, _ = raytrace.render(written, **SMALL)
    assert (image == expected).all()


def test_a_sample_count_an_option_gives_meets_the_scenes_pattern():
    """The grids take a square number of pixel samples: spp = 15 as an option, on scene 0's grid, is refused
    naming the pattern and the count, as the file's [render] table with spp = 15 would be."""
    scene = raytrace.load_file(CORNELL)
    error = _catch(lambda: raytrace.render(scene, spp=15))
    in_file = _catch(lambda: raytrace.load_string(CORNELL.read_text().replace("spp = 16", "spp = 15")))
    assert "spp = 16" in CORNELL.read_text()
    assert _line(error) == _line(in_file) == ("render.sampler = 'grid': the grid sampler needs a square number "
                                              "(1, 4, 9, 16, ...), not spp = 15")


def test_an_options_own_range_is_the_keys():
    """An option that overrides a scene value is checked by its key's declaration (keys.py), named as the
    option: render(): spp = 0, and --spp on the command line."""
    scene = raytrace.load_file(CORNELL)
    assert str(_catch(lambda: raytrace.render(scene, spp=0))) == "render(): spp = 0: must be an integer in [1, 65536]"
    assert str(_catch(lambda: raytrace.render(scene, shading="flat"))) == \
        "render(): shading = 'flat': must be one of: phong, direct, path"


def _problem_texts(path):
    """(text, line) of every string literal of 20 characters or more in the problem of an error: the third and
    later arguments of fail(...) and InputError(...), f-strings' literal parts included."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name in ("fail", "InputError"):
                for arg in node.args[2:]:
                    for sub in ast.walk(arg):
                        if isinstance(sub, ast.Constant) and isinstance(sub.value, str) and len(sub.value) >= 20:
                            yield sub.value, sub.lineno


def test_each_error_text_is_written_once():
    """A rule stated twice drifts (the path model's rule was written 7 times, and one of its places was
    skipped by the command line's --shading). Fragments under 20 characters (", beyond the ") may repeat."""
    seen = defaultdict(list)
    for path in sorted((ROOT / "raytrace").rglob("*.py")):
        for text, line in _problem_texts(path):
            seen[text].append(f"{path.relative_to(ROOT)}:{line}")
    repeated = {text: places for text, places in seen.items() if len(places) > 1}
    assert not repeated, repeated
    assert len(seen) > 100  # the scan sees the package's errors


def test_the_scan_finds_a_repeated_text(tmp_path):
    """The scan above can fail: it sees one rule's text written at two places."""
    source = tmp_path / "scanned"
    source.write_text('r.fail("type", t, "is the path model\'s: only there")\n'
                      'raise InputError(s, "k", v, f"is the path model\'s: only there{x}")\n')
    texts = [text for text, _ in _problem_texts(source)]
    assert texts.count("is the path model's: only there") == 2


def test_rules_are_stated_in_rules_py_only():
    """The shading models' rules live in rules.py: no other module of raytrace/ writes their words."""
    words = re.compile(r"is the path model|is the Phong model")
    for path in sorted((ROOT / "raytrace").rglob("*.py")):
        if path.name != "rules.py":
            assert not words.search(path.read_text()), path
