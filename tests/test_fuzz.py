"""Fuzzing the command line's and the Python API's promises to users with Hypothesis.

The contract: every input to `raytrace render` ends in one of two ways.

- Exit status 0, and an image file of the requested size that reads back (OpenImageIO) with only finite
  values; nothing else is left in the directory (but the `--stats-json` file asked for, whose
  `extra.nonfinite_values` is 0, as docs/cli.md promises).
- Exit status 2, and exactly one line on stderr, `raytrace: error: SOURCE: KEY = VALUE: problem`, where
  SOURCE says where the bad value came from: the scene file's path, a mesh file it names, `command line`
  or `environment`; no file is left behind (no output, no `.raytrace-*` temporary file).

Anything else is a failure: another exit status, an exception escaping `raytrace.cli.main`, a traceback on
stderr, a second line beside the error (a note, a Python warning: warnings are shown as the command line
would print them), a line naming the wrong source, a file left behind, an image of the wrong size or with
NaN or infinite values; and, whatever the exit status, an input changed (the scene file, a texture, a mesh
file, the environment map, a link to one: each byte for byte as before the run). An output that names an
input (`-o`, `--stats-json`, `bench --json`; itself, by another spelling or through a link) must be refused.

The Python API's contract (devtools/fuzz/api.py): `raytrace.load_dict` and the edits of
`raytrace.parameters(scene)` return, or raise `raytrace.InputError` whose text is one line naming the source;
a KeyError only where the Mapping protocol promises one (`params[name]` for a name that is no place in the
scene); no Python warning but FeaturesChanged; an `update()` that refuses leaves the scene as it was (its
fingerprint and its source) and `discard()` gives a scene that renders; a scene accepted renders (8 x 8, 1
sample) with nothing zeroed, and `update()` gives the scene `load_dict` makes of the edited source.

What is fuzzed, each example in a fresh temporary directory (the CLI runs in this process, so the kernel
variants are built once; stderr is captured at the file-descriptor level, where C libraries write):

- scene files built from the real grammar (raytrace/scene/scene_file.py: camera, image, render, ambient,
  materials with colour, shininess, texture, normal_map, height_map, uv_scale, uv_offset and wrap, lights,
  rectangles, triangles and ellipsoids placed by transform keys or not, inline, file and generated meshes with
  their transforms, disks and cylinders under sheared, scaled and mirrored to_world matrices with p0, p1, radius
  and flip_normals; in the Phong and the direct model, there with black emitting shapes), valid ones
  and ones mutated with hostile values (NaN, inf, 1e39, 3e38, denormals, 0, negative numbers, huge counts,
  wrong types, arrays of the wrong length, missing and extra keys), written by a TOML writer of our own
  (tomllib only reads) that spells NaN and infinity as TOML's `nan` and `inf`;
- scene files that are not valid TOML at all (truncated, binary, not UTF-8, deeply nested);
- command lines: render's options with hostile values, and random output names and extensions;
- texture and mesh files with random bytes, truncated or corrupted copies, odd but well-formed images
  (every channel count and pixel type, NaN texels, extreme sizes) and hostile OBJ and PLY files;
- the environment: RAYTRACE_LANES, RAYTRACE_TARGET and POCL_CACHE_DIR in this process; POCL_DEVICES,
  OCL_ICD_VENDORS and OCL_ICD_FILENAMES, which the OpenCL loader reads once, in a few child processes;
- path-model scenes (BSDF materials with parameters anywhere in their ranges, constant and envmap
  environments, light radiance, emitting shapes black or reflecting, disks and cylinders, max_depth), their environment maps real EXR, HDR, TIFF or PNG images or
  hostile files, some with hostile values, in this process and in a few child `python -m raytrace render`;
- outputs that alias an input: `render -o`, `--stats-json` and `bench --json` naming the scene, its texture,
  mesh or environment map, spelt through ./, sub/.., an absolute path, a symbolic or a hard link;
- the Python API: load_dict on generated dicts, damaged (wrong types, keys that are not strings, deep and
  self-referencing nesting, numpy values, objects no TOML holds, unknown keys), and parameter edits (set, get
  and del of names made from the scene's own, well- or ill-formed, with such values, then update()).
- Mitsuba 3 scenes (devtools/fuzz/mitsuba.py): XML built from the grammar of the plugins raytrace renders (with
  $parameters, includes, <path>, aliases, version 0.6 names), mutated (bad numbers, out-of-range values, hostile
  transforms, wrong tags and attributes, ids missing or twice, refs to nothing, includes of missing files and of
  themselves, nesting thousands deep, unsupported plugins with and without --ignore-unsupported, -D to hostile
  values), its text damaged, its meshes hostile files: through load_file, `render` (in this process and in a
  child) and `convert` to TOML, which must render the XML's bits; and its dict form, damaged, through load_dict.
  Their errors name `file:line`; a bug found and open is set aside by mitsuba.OPEN_BUGS, its input an xfail
  example here.

Images are tiny (at most 16 x 16 unless the fuzzed value is the size itself), so an example takes
milliseconds once its kernel variant is built.

Running it:

    python -m pytest tests/test_fuzz.py
        # the CI budget: a fixed (derandomised) set of about 1500 examples, a little over a minute on two cores
        # (two with an empty PoCL kernel cache: about 100 kernel variants get built); a failing example is
        # printed as generated (RAYTRACE_FUZZ_SHRINK=1: shrunk first, minutes more)
    RAYTRACE_FUZZ_EXAMPLES=3000 python -m pytest tests/test_fuzz.py
        # a long run: that many examples per test, random ones (not derandomised), each failure shrunk
    RAYTRACE_FUZZ_SURVEY=failures.jsonl RAYTRACE_FUZZ_EXAMPLES=3000 python -m pytest tests/test_fuzz.py
        # a survey: every failing example is appended to the file (kind, argv, scene, stderr, traceback) and
        # the run goes on instead of stopping and shrinking; the tests then pass, so use it to list bugs only

A failing example is printed with its scene file's text, its other files and its command line (the API's:
its dict, damages and edits).

The parts are in devtools/fuzz/ (like the stability suite, a tool that verifies the renderer; the TOML writer is
the package's own, raytrace/scene/toml_writer.py): scenes.py, files.py, commands.py, contract.py (the budget, the command line run in this process and the
contract checked), api.py (the API's damaged dicts, edits and contract) and mitsuba.py (Mitsuba's XML and dict
form); here, the tests and the inputs of the failures the suite has found, kept as @example.
"""
import copy
import dataclasses
import math
import os
import subprocess
import sys
import tempfile
import tomllib
import warnings
from pathlib import Path

from hypothesis import assume, event, example, given, note
from hypothesis import strategies as st

import raytrace
from raytrace import cli
from raytrace.commands import child_env
from raytrace.scene.model import fingerprint
from devtools.fuzz.api import Damage, DamagedDict, Edit, SceneChangedByRefusal, UpdateDisagreesWithLoad, Value, \
    check_refusal, checked_call, costly, damages, edits, render_tiny, strings_in
from devtools.fuzz.commands import ENVIRONMENT_VALUES, LOADER_VALUES, CommandLine, aliasing_command_lines, \
    command_lines, environments, parsed_int
from devtools.fuzz import mitsuba
from devtools.fuzz.contract import EXAMPLE_SECONDS, Outcome, ValidInputRefused, budget, check, \
    files_in, fuzz_scene, mesh_sources, outside, read_image, run_child, run_cli, snapshot, working_directory, \
    write_example
from devtools.fuzz.files import TextFile
from devtools.fuzz.scenes import SMALL_SCENE, DamagedText, SceneExample, broken_scene_texts, hostile_scenes, \
    path_scenes, path_scenes_with_files, scenes_with_every_input, scenes_with_hostile_files, texture_filters, \
    valid_scenes
from raytrace.scene.toml_writer import to_toml

from helpers import same_tables


# --- the failures the suite has found, kept as explicit examples -------------------------------------

def small_scene(files=(), **changes):
    """SMALL_SCENE with `changes`: section=value replaces a table, section__key=value one key in it."""
    table = copy.deepcopy(SMALL_SCENE)
    for name, value in changes.items():
        section, _, key = name.partition("__")
        if key:
            table[section][key] = value
        else:
            table[section] = value
    return SceneExample(table, tuple(files))


DEGENERATE_FACE_MESH = TextFile("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\n")  # a note: 1 dropped
MESH_WITH_A_NOTE = small_scene([DEGENERATE_FACE_MESH], shapes=[
    *SMALL_SCENE["shapes"], {"type": "mesh", "file": "tri.obj", "material": "white"}])


FOV_A_GENERATOR = (Damage("value", 0, value=Value("odd", odd="generator"), at=("camera", "fov")),)
INDEX_INTO_A_TABLE = (Edit("set", "given", 0, "camera[1]", Value("plain", 5)),)  # camera is a table, not an array
FOV_A_MAPPING_PROXY = (Edit("set", "given", 0, "camera.fov", Value("odd", odd="mapping proxy")),
                       Edit("get", "given", 0, "camera.fov", None))


def plain_command(*options):
    """`render scene.toml -o out.png` with these (option, value) pairs."""
    return CommandLine("scene.toml", "out.png", [(o, v, False) for o, v in options], ["--no-progress"])


# --- the tests -----------------------------------------------------------------------------------------

@budget(60)
@given(table=st.one_of(valid_scenes().map(lambda e: e.table), hostile_scenes().map(lambda e: e.table)))
def test_toml_writer_round_trips(table):
    """Our writer's text reads back (tomllib) as the table written, NaN, infinities and 1e39 included."""
    assert same_tables(tomllib.loads(to_toml(table)), table)


@budget(40)
@given(texture_filter=texture_filters(), example=valid_scenes())
def test_valid_scenes_render(texture_filter, example):
    """Scenes of the grammar with valid values render: exit status 0 and a finite image of their size."""
    fuzz_scene(cli.main, example.text().encode(), example.files, example.table, True, texture_filter)


@budget(300)
@given(example=hostile_scenes())
@example(example=small_scene(camera__position=[2**64, -3.0, 1.0]))  # a TypeError in np.isfinite
@example(example=small_scene(camera__up=[0.0, 0.0, 1e-300]))  # numpy warnings, a NaN camera, a black image
@example(example=small_scene(camera__fov=math.nan, camera__up=[0.0, 0.0, 5e-324]))  # warnings and the error
@example(example=small_scene(camera={**SMALL_SCENE["camera"], "a\nb": 1}))  # a key's newline: two lines
@example(example=small_scene(materials={"a\nb": {"colour": [1.0, -1.0, 0.0]}}))
def test_hostile_scene_files(example):
    """Valid scenes with hostile values: an image, or one line naming the scene file (or its mesh file)."""
    fuzz_scene(cli.main, example.text().encode(), example.files, example.table)


@budget(60)
@given(scene=broken_scene_texts())
@example(scene=(DamagedText("nested arrays", small_scene().text().encode(), 1000, b""), ()))  # RecursionError
def test_broken_scene_texts(scene):
    """Scene files that are not TOML tables at all: one line naming the scene file."""
    damaged, files = scene
    fuzz_scene(cli.main, damaged.data(), files, None)


@budget(200)
@given(texture_filter=texture_filters(), example=scenes_with_hostile_files())
def test_hostile_texture_and_mesh_files(texture_filter, example):
    """Textures and meshes with random, truncated, damaged or odd contents: an image, or one line naming
    the scene file (textures) or the mesh file."""
    fuzz_scene(cli.main, example.text().encode(), example.files, example.table, False, texture_filter)


@budget(250)
@given(command=command_lines(), example=valid_scenes(max_shapes=1))  # the command first: see hostile_scenes
@example(command=plain_command(("--seed", "4294967295")), example=small_scene())  # OpenImageIO's bad_cast
@example(command=plain_command(("--device", "0:0:0")), example=small_scene())  # a ValueError unpacking P:D
@example(command=dataclasses.replace(plain_command(), scene="a\nb.toml"), example=small_scene())  # two lines
@example(command=plain_command(("--spp", "5")), example=MESH_WITH_A_NOTE)  # the mesh's note, then the error
def test_hostile_command_lines(command, example):
    """render's options with hostile values and odd output names: an image of the size asked for (the scene's crop
    window where the size asked for is its film's, or none is), or one line naming the command line (or the scene file, when the scene argument names no readable scene)."""
    table = example.table
    width = parsed_int(command.value("--width")) if command.value("--width") is not None \
        else table["image"]["width"]
    height = parsed_int(command.value("--height")) if command.value("--height") is not None \
        else table["image"]["height"]
    spp = parsed_int(command.value("--spp")) or table.get("render", {}).get("spp", 1)
    ls = parsed_int(command.value("--light-samples")) or table.get("render", {}).get("light_samples", 1)
    image = table["image"]
    if (width, height) == (image["width"], image["height"]):  # the film's crop window, where the size is the film's
        x, y = image.get("crop_offset_x", 0), image.get("crop_offset_y", 0)
        width, height = image.get("crop_width", width - x), image.get("crop_height", height - y)
    if None not in (width, height) and 0 < width <= 16384 and 0 < height <= 16384 and 0 < spp <= 65536 \
            and 0 < ls <= 65536:
        time_limit_given = command.value("--time-limit") is not None
        assume(width * height <= 1 << 18 and (time_limit_given or width * height * spp * (1 + ls * 2) <= 5e7))
    argv = command.argv()
    note(f"scene.toml:\n{example.text()}")
    note(f"files: {example.files!r}"[:3000])
    note(f"argv: {argv}")
    stats = next((f.split("=", 1)[1] for f in reversed(command.flags) if f.startswith("--stats-json=")), None)
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        write_example(directory, example.text().encode(), example.files)
        (directory / "sub").mkdir()
        (directory / "taken.png").mkdir()
        (directory / "taken.exr").mkdir()
        inputs = snapshot(directory)
        outcome = run_cli(cli.main, argv, directory)
        sources = ["command line", command.scene, str(Path(command.scene))] + mesh_sources(table, command.scene)
        check(outcome, directory, command.output, (width, height) if None not in (width, height) else None,
              sources, stats or None, example_text=example.text(), inputs=inputs)


@budget(40)
@given(env=environments(ENVIRONMENT_VALUES))
def test_hostile_environment(env):
    """RAYTRACE_LANES, RAYTRACE_TARGET and POCL_CACHE_DIR: an image, or one line naming the environment. One
    small scene, as each target and lane width builds the kernel anew."""
    note(f"environment: {env!r}")
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        (directory / "scene.toml").write_text(to_toml(SMALL_SCENE))
        outcome = run_cli(cli.main, ["render", "scene.toml", "-o", "out.exr", "--no-progress"], directory, env)
        check(outside(directory, outcome, env), directory, "out.exr", (4, 3), ["environment"])


@budget(6)
@given(env=environments(LOADER_VALUES))
def test_hostile_environment_in_a_child(env):
    """The variables the OpenCL loader and PoCL read once per process, in a child `python -m raytrace render`:
    an image, or one line naming the environment."""
    note(f"environment: {env!r}")
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        (directory / "scene.toml").write_text(to_toml(SMALL_SCENE))
        argv = ["render", "scene.toml", "-o", "out.png", "--no-progress"]
        r = subprocess.run([sys.executable, "-m", "raytrace", *argv], cwd=directory, capture_output=True,
                           env=child_env(**env), timeout=EXAMPLE_SECONDS)
        new = files_in(directory) - {"scene.toml"}
        outcome = Outcome(argv, r.returncode, r.stderr.decode("utf-8", "backslashreplace"), None, new)
        check(outside(directory, outcome, env), directory, "out.png", (4, 3), ["environment"])


# --- path materials and environment maps on the command line ---------------------------------------------

@budget(60)
@given(example=path_scenes_with_files())
def test_path_scenes_and_environment_maps(example):
    """Path-model scenes of every BSDF, their values anywhere in their ranges, their environment maps real EXR,
    HDR, TIFF or PNG images or hostile files, some with hostile values: an image with nothing zeroed
    (extra.nonfinite_values 0, no NaN or infinity in the file), or one line naming the scene file; no input
    changed."""
    fuzz_scene(cli.main, example.text().encode(), example.files, example.table)


@budget(8)
@given(example=path_scenes_with_files())
def test_path_scenes_and_environment_maps_in_a_child(example):
    """The same in a child `python -m raytrace render`, the command line as the user runs it."""
    fuzz_scene(None, example.text().encode(), example.files, example.table, child_env=child_env())


# --- the Python API: generated dicts and parameter edits ---------------------------------------------------

@budget(80)
@given(example=st.one_of(valid_scenes(max_shapes=2), path_scenes()), damaged=damages())
@example(example=small_scene(), damaged=FOV_A_GENERATOR)  # a TypeError: copy.deepcopy cannot copy it
def test_generated_dicts(example, damaged):
    """raytrace.load_dict on generated scene dicts, damaged: wrong types, keys that are not strings, deep and
    self-referencing nesting, numpy values, objects no TOML holds, unknown keys. A Scene, which renders (8 x 8,
    1 sample) with nothing zeroed, or InputError, one line naming load_dict() (or a mesh file); nothing else."""
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, working_directory(d):
        write_example(Path(d), example.text().encode(), example.files)
        inputs = snapshot(Path(d))
        table = DamagedDict(example.table, damaged).build()
        assume(not costly(table))
        scene, error = checked_call("load_dict()", lambda: raytrace.load_dict(table))
        event("refused" if error is not None else "loaded and rendered")
        if error is not None:
            note(f"refused: {error}")
            check_refusal("load_dict()", error, ["load_dict()", *strings_in(table)])
        else:
            render_tiny("load_dict()", scene)
        assert snapshot(Path(d)) == inputs, "load_dict() or render() changed a file"


@budget(60)
@given(example=st.one_of(valid_scenes(max_shapes=2), path_scenes()), staged=edits())
@example(example=small_scene(), staged=INDEX_INTO_A_TABLE)  # a TypeError from update()
@example(example=small_scene(), staged=FOV_A_MAPPING_PROXY)  # a TypeError from params[name] and update()
def test_parameter_edits(example, staged):
    """raytrace.parameters(scene): set, get and del of names made from the scene's own (well- or ill-formed),
    values of any kind, then update(). Only InputError (one line), or a KeyError from params[name] for a name
    that has no place in the scene; an update() that refuses leaves the scene as it was (its fingerprint and
    source) and discard() gives a scene that renders; one that succeeds gives the scene load_dict makes of the
    edited source, and it renders (8 x 8, 1 sample) with nothing zeroed."""
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, working_directory(d):
        write_example(Path(d), example.text().encode(), example.files)
        scene, error = checked_call("load_dict()", lambda: raytrace.load_dict(example.table))
        assume(error is None)  # path_scenes' beyond the bounds of rule 5
        params = raytrace.parameters(scene)
        names, sources = list(params), ["parameters(load_dict())", *strings_in(example.table)]
        for edit in staged:
            name = edit.name(names)
            if edit.op == "get":
                note(f"params[{name!r}]")
                checked_call(f"params[{name!r}]", lambda name=name: params[name], (KeyError,))
            elif edit.op == "del":
                note(f"del params[{name!r}]")
                checked_call(f"del params[{name!r}]", lambda name=name: params.__delitem__(name), (KeyError,))
            else:
                value = edit.value.make(edit.current(params, name), copy.deepcopy(scene.source))
                assume(not costly(value, name if isinstance(name, str) else ""))
                note(f"params[{name!r}] = {edit.value}")
                sources += strings_in(value)
                _, error = checked_call(f"params[{name!r}] = ...",
                                        lambda name=name, value=value: params.__setitem__(name, value), (KeyError,))
                if isinstance(error, raytrace.InputError):
                    check_refusal(f"params[{name!r}] = ...", error, sources)
        checked_call("list(params)", lambda: (list(params), len(params), repr(params)))
        before, source, revision = fingerprint(scene), copy.deepcopy(scene.source), scene.revision
        changed, error = checked_call("update()", params.update)
        event("update() refused" if error is not None else "updated" if changed else "nothing staged")
        if error is None:
            note(f"updated: {sorted(changed)}")
            render_tiny("update()", scene)
            reloaded, error = checked_call("load_dict(scene.source)", lambda: raytrace.load_dict(scene.source))
            if error is not None or fingerprint(reloaded) != fingerprint(scene):
                raise UpdateDisagreesWithLoad(f"update() made a scene load_dict does not make of its source: {error}")
        else:
            note(f"refused: {error}")
            check_refusal("update()", error, sources)
            if fingerprint(scene) != before or not same_tables(scene.source, source) or scene.revision != revision:
                raise SceneChangedByRefusal(f"update() refused ({error}) but changed the scene")
            params.discard()
            changed, error = checked_call("update() after discard()", params.update)
            assert error is None and changed == set(), (changed, error)
            render_tiny("update() refused, then discard()", scene)


# --- outputs that alias inputs -----------------------------------------------------------------------------

@budget(40)
@given(scene=scenes_with_every_input(), command=aliasing_command_lines())
def test_outputs_that_alias_inputs(scene, command):
    """`render -o`, `--stats-json` and `bench --json` naming one of the run's inputs (the scene file, its
    texture, its mesh file or its environment map), spelt as given, through ./ or sub/.., absolutely, or through
    a symbolic link (to a link, from another directory) or a hard link: exit status 2 and one line naming the
    command line, no file left, and every input (links included) byte for byte as it was."""
    example, roles = scene
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        write_example(directory, example.text().encode(), example.files)
        (directory / "sub").mkdir()
        for link, target, hard in command.links(roles):
            if hard:
                os.link(directory / target, directory / link)
            else:
                os.symlink(target, directory / link)
        argv = command.argv(roles, d)
        note(f"argv: {argv}")
        inputs = snapshot(directory)
        outcome = run_cli(cli.main, argv, directory)
        check(outcome, directory, None, None, ["command line"], example_text=example.text(), inputs=inputs,
              must_refuse=True)


# --- Mitsuba 3 scenes: XML files, the command line, the dict form, convert -------------------------------------------

def bsdf(*children, **attrs):
    return mitsuba.el("bsdf", *children, **attrs)


# The failures found (devtools/fuzz/mitsuba.py's OPEN_BUGS, while they are open): each minimal input.
ALIAS = mitsuba.small_xml(bsdf(bsdf(type="diffuse"), type="twosided", id="white"),
                          mitsuba.el("alias", id="white", **{"as": "white_alias"}),
                          mitsuba.el("shape", mitsuba.el("ref", id="white_alias"), type="rectangle"), valid=True)
DEEP = mitsuba.small_xml(mitsuba.nest(bsdf(type="diffuse"), "bsdf", "twosided", 1000))  # a RecursionError
BOGUS_ENCODING = mitsuba.small_xml(damage=mitsuba.TextDamage("encoding", 0, b'encoding="bogus"'))  # a LookupError
UTF32 = mitsuba.small_xml(damage=mitsuba.TextDamage("encoding", 0, b'encoding="utf-32"'))  # a ValueError
NO_HEIGHT = mitsuba.small_xml(height="0")  # a ZeroDivisionError
HUGE_AXIS = mitsuba.small_xml(mitsuba.el("shape", mitsuba.Element("transform", (("name", "to_world"),), (
    mitsuba.el("rotate", x="1e200", y="1e200", z="1e200", angle="30"),)), type="rectangle"))  # numpy's overflow
TWO_LINE_WARNING = dataclasses.replace(mitsuba.small_xml(mitsuba.el("shape", type="a\nb")), ignore_unsupported=True)
HUGE_SCALE = mitsuba.DictExample(mitsuba.MitsubaScene(mitsuba.small_xml().root, (), (4, 3)), "array", (
    mitsuba.DictDamage("to_world", 6, "huge scale"),))  # the floor's to_world: numpy's overflow warning
COMPLEX_MATRIX = dataclasses.replace(HUGE_SCALE, damages=(  # the camera's to_world: numpy's ComplexWarning
    mitsuba.DictDamage("to_world", 0, "complex"),))
ARRAY_TYPE = dataclasses.replace(HUGE_SCALE, damages=(  # the sensor's type an empty numpy array: a ValueError
    Damage("value", 0, value=Value("numpy", numpy="empty"), at=("sensor_1", "type")),))
VOID_TYPE = dataclasses.replace(HUGE_SCALE, damages=(  # the sensor's type numpy's void: a TypeError
    Damage("value", 0, value=Value("odd", odd="numpy void"), at=("sensor_1", "type")),))
MASKED_RGB = mitsuba.DictExample(mitsuba.MitsubaScene(mitsuba.small_xml(mitsuba.el("shape", bsdf(mitsuba.prop(
    "rgb", "reflectance", "0.5, 0.5, 0.5"), type="diffuse"), type="rectangle")).root, (), (4, 3)), "array", (
    Damage("value", 0, value=Value("numpy", numpy="masked"), at=("shape_3", "bsdf_1", "reflectance", "value", 0)),))
REPORTED = (ALIAS, DEEP, BOGUS_ENCODING, UTF32, NO_HEIGHT, HUGE_AXIS, TWO_LINE_WARNING, HUGE_SCALE, COMPLEX_MATRIX,
            ARRAY_TYPE, VOID_TYPE, MASKED_RGB)


def reported(example):
    """Whether `example` is one of REPORTED (an explicit example: its failure is expected, and not set aside)."""
    return any(example is r for r in REPORTED)


def preloaded(example, directory):
    """The scene of `example` (written in `directory`) as load_file reads it, or None where it does not (the run
    itself tells how): what a render of it will cost."""
    with working_directory(directory), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return raytrace.load_file(mitsuba.SCENE, dict(example.defines) or None, example.ignore_unsupported)
        except Exception:  # noqa: BLE001 - the test that follows is the judge
            return None


def render_xml(main, example, child=None):
    """`render scene.xml` with the example's -D and --ignore-unsupported, in this process through `main` or in a
    child with the environment `child`; mitsuba.check_run's contract."""
    example.note()
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, mitsuba.open_bugs(reported(example)):
        directory = Path(d)
        example.write(directory)
        scene = preloaded(example, directory)
        flags = []
        if scene is not None:  # valid, and costly only for the values (a width, a sample count) mutated so
            assume(scene.width * scene.height <= 1 << 16)
            flags = ["--time-limit", "1"] if mitsuba.render_cost(scene) > 2e6 else []
        ext = ".exr" if len(example.data()) % 2 else ".png"
        argv = ["render", mitsuba.SCENE, *example.flags(), "-o", "out" + ext, "--no-progress", "--stats-json",
                "stats.json", *flags]
        note(f"argv: {argv}")
        inputs = snapshot(directory)
        outcome = run_cli(main, argv, directory) if child is None else run_child(argv, directory, child)
        size = scene.crop[2:] if scene is not None else None  # the image is the film's crop window
        mitsuba.check_run(outcome, directory, "out" + ext, size, example.sources(), inputs, example.valid,
                          example.text(), "stats.json")


@budget(80)
@given(example=mitsuba.xml_examples(), spelling=st.sampled_from(["relative", "absolute", "path"]))
@example(example=ALIAS, spelling="relative")
@example(example=DEEP, spelling="relative")
@example(example=BOGUS_ENCODING, spelling="relative")
@example(example=UTF32, spelling="relative")
@example(example=NO_HEIGHT, spelling="relative")
@example(example=HUGE_AXIS, spelling="absolute")
@example(example=TWO_LINE_WARNING, spelling="relative")
def test_mitsuba_xml_files(example, spelling):
    """raytrace.load_file on Mitsuba XML scenes, valid (built from the grammar of the plugins raytrace renders, with
    $parameters, includes, <path> and aliases), mutated (bad numbers, out-of-range values, hostile transforms,
    wrong tags and attributes, ids missing or given twice, refs to nothing, includes of missing files and of
    themselves, nesting thousands deep, unsupported plugins), their text damaged, their meshes and environment
    maps hostile files: a Scene, which renders (8 x 8, 1 sample) with nothing zeroed, or an InputError, one line
    naming the file (and line) at fault; UnsupportedWarning the only warning, one line each. A valid scene loads."""
    example.note()
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, working_directory(d), \
            mitsuba.open_bugs(reported(example)):
        directory = Path(d)
        example.write(directory)
        inputs = snapshot(directory)
        path = {"relative": mitsuba.SCENE, "absolute": str(directory / mitsuba.SCENE), "path": Path(mitsuba.SCENE)}
        sources = ["load_file()", *example.sources(), *(str(directory / s) for s in example.sources())]
        scene, error = mitsuba.checked_load("load_file()", lambda: raytrace.load_file(
            path[spelling], dict(example.defines) or None, example.ignore_unsupported), sources)
        event("refused" if error is not None else "loaded and rendered")
        if error is not None:
            note(f"refused: {error}")
            if example.valid:
                raise ValidInputRefused(f"a valid scene was refused: {error}")
        else:
            render_tiny("load_file()", scene)
        assert snapshot(directory) == inputs, "load_file() or render() changed a file"


@budget(100)
@given(example=mitsuba.xml_examples())
@example(example=ALIAS)
@example(example=DEEP)
@example(example=BOGUS_ENCODING)
@example(example=UTF32)
@example(example=NO_HEIGHT)
@example(example=TWO_LINE_WARNING)
def test_mitsuba_xml_on_the_command_line(example):
    """`render scene.xml` with -D and --ignore-unsupported on the same scenes: an image of the film's size with
    nothing zeroed, or exit status 2 and one line naming the scene file (or a file it includes, a mesh, the command
    line), with its line where an element is at fault; a run that succeeds prints warnings that name their line."""
    render_xml(cli.main, example)


@budget(3)
@given(example=st.one_of(mitsuba.valid_xml_scenes(), mitsuba.hostile_xml_scenes()))
def test_mitsuba_xml_in_a_child(example):
    """The same in a child `python -m raytrace render`, the command line as the user runs it."""
    assume(all(s.isprintable() and "\x00" not in s for define in example.defines for s in define))
    render_xml(None, example, child_env())


@budget(80)
@given(example=mitsuba.dict_examples())
@example(example=HUGE_SCALE)
@example(example=COMPLEX_MATRIX)
@example(example=ARRAY_TYPE)
@example(example=VOID_TYPE)
@example(example=MASKED_RGB)
def test_mitsuba_dict_form(example):
    """raytrace.load_dict on Mitsuba's dict form of valid scenes (transforms as numpy arrays, lists or objects with
    .matrix), damaged as the API's dicts are (numpy values, objects, itself, deep nesting) and in Mitsuba's ways (a
    plugin that is no dict, a type that is none, an odd to_world, refs to nothing): a Scene that renders with
    nothing zeroed, or InputError, one line naming load_dict() (or a mesh file). Undamaged, it loads as the XML of
    the same tree does, to the same scene table."""
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, working_directory(d), \
            mitsuba.open_bugs(reported(example)):
        directory = Path(d)
        for f in example.scene.files:
            f.write(directory)
        inputs = snapshot(directory)
        table = example.build()
        note(f"dict: {mitsuba.shown(table)}")
        sources = ["load_dict()", *strings_in(table)]
        scene, error = mitsuba.checked_load("load_dict()", lambda: raytrace.load_dict(
            table, ignore_unsupported=example.ignore_unsupported), sources)
        event("refused" if error is not None else "loaded and rendered")
        if error is not None:
            note(f"refused: {error}")
            if not example.damages:
                raise ValidInputRefused(f"the dict form of a valid scene was refused: {error}")
        else:
            render_tiny("load_dict()", scene)
        if not example.damages:
            (directory / mitsuba.SCENE).write_text(mitsuba.xml_text(example.scene.root))
            xml, error = mitsuba.checked_load("load_file()", lambda: raytrace.load_file(mitsuba.SCENE), [mitsuba.SCENE])
            if error is not None or not mitsuba.close_tables(xml.source, scene.source):
                raise mitsuba.XmlAndDictDisagree(f"the XML of the tree: {error or xml.source}\nits dict form: "
                                                 f"{scene.source}")
            (directory / mitsuba.SCENE).unlink()
        assert snapshot(directory) == inputs, "load_dict() or render() changed a file"


@budget(25)
@given(example=st.one_of(mitsuba.valid_xml_scenes(max_shapes=2), mitsuba.hostile_xml_scenes()),
       folder=st.sampled_from(["", "out/"]))
def test_mitsuba_convert_to_toml(example, folder):
    """`convert scene.xml -o x.toml`: the TOML file alone, with no NaN or infinity in it, or the refusal render
    gives the same scene (one line naming file:line, nothing written); the TOML renders to the same bits as the XML
    (and a scene that convert refuses, render refuses)."""
    example.note()
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d, mitsuba.open_bugs():
        directory = Path(d)
        example.write(directory)
        (directory / "out").mkdir(exist_ok=True)
        scene = preloaded(example, directory)
        if scene is not None:  # both are rendered whole (a time limit would make their passes differ)
            assume(scene.width * scene.height <= 4096 and mitsuba.render_cost(scene) <= 2e5)
        output = folder + "converted.toml"
        inputs = snapshot(directory)
        outcome = run_cli(cli.main, ["convert", mitsuba.SCENE, *example.flags(), "-o", output], directory)
        mitsuba.check_convert(outcome, directory, output, example.sources(), inputs, example.valid, example.text())
        xml = run_cli(cli.main, ["render", mitsuba.SCENE, *example.flags(), "-o", "xml.exr", "--no-progress"],
                      directory)
        if outcome.rc != 0:
            event("convert refused; so did render")
            if xml.error is not None or xml.rc != 2:
                raise mitsuba.ConvertedRendersDifferently(f"convert refused ({outcome.stderr.strip()}) a scene that "
                                                          f"render does not: exit status {xml.rc!r}, {xml.error!r}")
            return
        note(f"{output}:\n{(directory / output).read_text()}"[:4000])
        toml = run_cli(cli.main, ["render", output, "-o", "toml.exr", "--no-progress"], directory)
        if xml.error is not None or toml.error is not None or xml.rc != toml.rc:
            raise mitsuba.ConvertedRendersDifferently(f"the XML's render: {xml.rc!r} {xml.error!r} {xml.stderr}\n"
                                                      f"the TOML's: {toml.rc!r} {toml.error!r} {toml.stderr}")
        if xml.rc == 0:
            (_, a), (_, b) = read_image(directory / "xml.exr"), read_image(directory / "toml.exr")
            if a.shape != b.shape or a.tobytes() != b.tobytes():
                raise mitsuba.ConvertedRendersDifferently("the TOML renders other bits than the XML")
            event("converted; the TOML renders the XML's bits")
