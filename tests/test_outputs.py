"""Output files (raytrace/outputs.py) as a user meets them, with real files, real mounts and real limits:
every output is checked (and its temporary file made) before the work, written through a temporary file
in its own directory, renamed into place at the end with the others, and on any failure nothing is left:
no output, no temporary, no directory made for them. Bad output paths get one line naming the option and
the path the user gave, and exit status 2."""
import json
import os
import resource
import signal
import stat
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import CORNELL, ROOT, mount, run
from raytrace.errors import InputError
from raytrace.outputs import Outputs
from raytrace.image_file import write_image_file

SMALL = ["--width", 16, "--height", 16, "--spp", 1, "--light-samples", 1, "--no-progress"]


def one_error(r, *needles):
    """Exit status 2 and exactly one line on stderr, the error, holding every needle; no temporary named."""
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("raytrace: error: "), r.stderr
    assert "Traceback" not in r.stderr and ".raytrace-" not in r.stderr, r.stderr
    for needle in needles:
        assert str(needle) in r.stderr, r.stderr


def names(directory):
    return sorted(p.name for p in directory.iterdir())


def read(path):
    image = oiio.ImageInput.open(str(path))
    assert image is not None, oiio.geterror()
    spec, pixels = image.spec(), image.read_image(image.spec().format)
    image.close()
    return spec, pixels


@pytest.fixture
def readonly(tmp_path):
    """An empty directory no file can be made in: chmod 555 for a user, a read-only bind mount for root
    (who ignores permissions)."""
    directory = tmp_path / "ro"
    directory.mkdir()
    if os.geteuid() != 0:
        directory.chmod(0o555)
        yield directory
        directory.chmod(0o755)
        return
    mount("--bind", directory, directory)
    try:
        mount("-o", "remount,bind,ro", directory)
        yield directory
    finally:
        subprocess.run(["umount", str(directory)], check=True)


def file_size_limit(limit):
    """A preexec_fn: files of this process may grow to `limit` bytes, a write beyond fails with EFBIG
    (SIGXFSZ ignored): a full disk without privileges."""
    def limited():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return limited


# --- the API -------------------------------------------------------------------------------------------

def test_reserve_commit_and_discard(tmp_path):
    """A reserved output has its temporary beside it at once; commit renames it over the output, with the
    mode the output had; leaving without commit removes it, and a directory made for it."""
    old = tmp_path / "old.json"
    old.write_text("old")
    old.chmod(0o640)
    with Outputs() as outputs:
        tmp = outputs.reserve("--json", old)
        assert os.path.dirname(tmp) == str(tmp_path) and os.path.basename(tmp).startswith(".raytrace-")
        assert tmp.endswith(".json") and names(tmp_path) == sorted([os.path.basename(tmp), "old.json"])
        with open(tmp, "w") as f:
            f.write("new")
        outputs.commit()
    assert names(tmp_path) == ["old.json"] and old.read_text() == "new"
    assert stat.S_IMODE(old.stat().st_mode) == 0o640
    with pytest.raises(RuntimeError), Outputs() as outputs:
        outputs.make_directory("--out", tmp_path / "a" / "b")
        outputs.reserve("--out", tmp_path / "a" / "b" / "x.png")
        outputs.reserve("-o", tmp_path / "y.png")
        raise RuntimeError("the work failed")
    assert names(tmp_path) == ["old.json"] and old.read_text() == "new"


def test_reserve_refuses(tmp_path):
    """Each refusal names the option and the path as given."""
    (tmp_path / "dir").mkdir()
    cases = {str(tmp_path / "dir"): "is a directory", str(tmp_path / "no" / "x.png"): "directory does not exist",
             "/dev/null": "not a regular file", str(tmp_path / "x.png") + "/": "names a directory", str(tmp_path / ("n" * 300 + ".png")): "file name is longer"}
    for path, problem in cases.items():
        with pytest.raises(InputError, match=problem) as e, Outputs() as outputs:
            outputs.reserve("-o", path)
        assert (e.value.source, e.value.key, e.value.value) == ("command line", "-o", path)
    with pytest.raises(InputError, match="input of this run") as e, Outputs(inputs=[CORNELL]) as outputs:
        outputs.reserve("--json", os.path.relpath(CORNELL))
    with pytest.raises(InputError, match="another output") as e, Outputs() as outputs:
        outputs.reserve("-o", tmp_path / "x.exr")
        outputs.reserve("--stats-json", tmp_path / "dir" / ".." / "x.exr")
    assert e.value.key == "--stats-json"
    assert names(tmp_path) == ["dir"]


def test_write_image_file_reports_a_failed_write(tmp_path):
    """An image the writer cannot finish (a full disk, here a file-size limit in a child) raises OSError,
    never a silent success: OIIO's PNG writer says so only through has_error."""
    code = ("import numpy as np, sys; from raytrace.image_file import write_image_file\n"
            "try:\n    write_image_file(sys.argv[1], np.random.default_rng(1).random((256, 256, 3)))\n"
            "except OSError as e:\n    print('OSError', e.strerror)")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "x.png")], capture_output=True, text=True,
                       cwd=ROOT, preexec_fn=file_size_limit(16384))
    assert r.stdout.startswith("OSError"), (r.stdout, r.stderr)


# --- 5, 6: assets, all or nothing ---------------------------------------------------------------------

@pytest.mark.parametrize("seed", [-1, 2**32])
def test_assets_seed_out_of_range(tmp_path, seed):
    out = tmp_path / "textures"
    one_error(run("assets", "--out", out, "--seed", seed), f"command line: --seed = {seed}")
    assert names(tmp_path) == []


def test_assets_past_a_file_size_limit_leaves_nothing(tmp_path):
    """A limit the 16-bit height maps pass: one line naming --out; the old grid.png is untouched, no other
    file (the textures are all replaced or none is)."""
    out = tmp_path / "textures"
    out.mkdir()
    (out / "grid.png").write_text("old")
    r = run("assets", "--out", out, preexec_fn=file_size_limit(65536), restore_signals=False)
    one_error(r, f"command line: --out = '{out}'", "bricks_height.png")
    assert names(out) == ["grid.png"] and (out / "grid.png").read_text() == "old"
    r = run("assets", "--out", out / "new", preexec_fn=file_size_limit(65536), restore_signals=False)
    one_error(r, f"command line: --out = '{out / 'new'}'")
    assert names(out) == ["grid.png"]  # the directory it made is gone too


def test_assets_onto_a_full_disk_leaves_nothing(tmp_path):
    """A 64 KiB tmpfs (root only: skipped where mount is not permitted)."""
    out = tmp_path / "full"
    out.mkdir()
    mount("-t", "tmpfs", "-o", "size=64k", "tmpfs", out)
    try:
        one_error(run("assets", "--out", out), f"command line: --out = '{out}'")
        assert names(out) == []
    finally:
        subprocess.run(["umount", str(out)], check=True)


@pytest.mark.parametrize("ext", [".exr", ".png", ".tif"])
def test_render_onto_a_full_disk_leaves_nothing(tmp_path, ext):
    """A 64 KiB tmpfs (root only). Not with a file-size limit: PoCL's LLVM writes files of its own at the
    kernel's first launch and aborts the process when it cannot."""
    out = tmp_path / "full"
    out.mkdir()
    mount("-t", "tmpfs", "-o", "size=64k", "tmpfs", out)
    try:
        r = run("render", CORNELL, "-o", out / ("x" + ext), "--stats-json", out / "s.json", "--width", 1024,
                "--height", 1024, "--spp", 1, "--light-samples", 1, "--no-progress")
        one_error(r, f"command line: -o = '{out / ('x' + ext)}': cannot write: ")
        assert names(out) == []
    finally:
        subprocess.run(["umount", str(out)], check=True)


# --- 7, 8: what an output may be ------------------------------------------------------------------------

def test_unwritable_stats_json_leaves_no_image(tmp_path, readonly):
    r = run("render", CORNELL, "-o", tmp_path / "x.png", "--stats-json", readonly / "s.json", *SMALL)
    one_error(r, f"command line: --stats-json = '{readonly / 's.json'}'")
    assert names(tmp_path) == ["ro"] and names(readonly) == []


def test_stats_json_naming_a_directory(tmp_path):
    (tmp_path / "d").mkdir()
    r = run("render", CORNELL, "-o", tmp_path / "x.png", "--stats-json", tmp_path / "d", *SMALL)
    one_error(r, f"command line: --stats-json = '{tmp_path / 'd'}': is a directory")
    assert names(tmp_path) == ["d"] and names(tmp_path / "d") == []


def test_device_nodes_are_never_replaced(tmp_path):
    """A symbolic link to /dev/null as -o (any user), and a character device made here (root) as
    --stats-json: refused, the device still a device."""
    link = tmp_path / "null.png"
    link.symlink_to("/dev/null")
    one_error(run("render", CORNELL, "-o", link, *SMALL), f"command line: -o = '{link}'", "not a regular file")
    assert link.is_symlink() and stat.S_ISCHR(os.stat("/dev/null").st_mode)
    node = tmp_path / "full"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 7))
    except PermissionError:
        pytest.skip("mknod not permitted here")
    r = run("render", CORNELL, "-o", tmp_path / "x.png", "--stats-json", node, *SMALL)
    one_error(r, f"command line: --stats-json = '{node}'", "not a regular file")
    assert stat.S_ISCHR(node.lstat().st_mode) and names(tmp_path) == ["full", "null.png"]


def test_symlinked_output_writes_its_target(tmp_path):
    """The link stays a link; its target gets the image; one note says so."""
    (tmp_path / "real").mkdir()
    target, link = tmp_path / "real" / "t.png", tmp_path / "l.png"
    target.write_text("old")
    link.symlink_to(target)
    r = run("render", CORNELL, "-o", link, *SMALL)
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert read(target)[0].width == 16 and names(tmp_path / "real") == ["t.png"] and names(tmp_path) == ["l.png", "real"]
    assert f"raytrace: note: {link} is a symbolic link: wrote its target {target}" in r.stderr.splitlines()


# --- 9: outputs are neither inputs nor each other -------------------------------------------------------

def test_output_naming_another_output(tmp_path):
    for stats in (tmp_path / "x.exr", tmp_path / "sub" / ".." / "x.exr"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        r = run("render", CORNELL, "-o", tmp_path / "x.exr", "--stats-json", stats, *SMALL)
        one_error(r, f"command line: --stats-json = '{stats}'", "another output (-o ")
        assert names(tmp_path) == ["sub"]


def test_output_naming_an_input(tmp_path):
    """The scene file, the scene under another name (a hard link), and a texture the scene reads."""
    scene = tmp_path / "scene.toml"
    (tmp_path / "tex.png").write_bytes((ROOT / "assets" / "textures" / "grid.png").read_bytes())
    scene.write_text(open(CORNELL).read().replace('red = { colour = [0.8, 0.0, 0.0] }',
                                                  'red = { colour = [0.8, 0.0, 0.0], texture = "tex.png" }'))
    os.link(scene, tmp_path / "hard.json")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    for option, path in (("--stats-json", scene), ("--stats-json", tmp_path / "hard.json"),
                         ("-o", tmp_path / "tex.png")):
        argv = ["-o", tmp_path / "x.png", "--stats-json", path] if option == "--stats-json" else ["-o", path]
        one_error(run("render", scene, *argv, *SMALL), f"command line: {option} = '{path}'", "input of this run")
        assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


# --- 10: TIFF -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("ext", [".tif", ".tiff"])
def test_tiff_written_and_read_back(tmp_path, ext):
    """16-bit with the course's curve, the same render as the EXR's floats; the metadata as JSON in the
    description (TIFF keeps no custom attributes)."""
    for out in ("x" + ext, "x.exr"):
        r = run("render", CORNELL, "-o", tmp_path / out, *SMALL)
        assert r.returncode == 0, r.stderr
    spec, pixels = read(tmp_path / ("x" + ext))
    _, floats = read(tmp_path / "x.exr")
    assert spec.format == oiio.UINT16 and spec.nchannels == 3
    np.testing.assert_array_equal(pixels, np.round(65535.0 * np.clip(floats[..., :3], 0, 1) ** (1 / 2.2)))
    metadata = json.loads(spec.getattribute("ImageDescription"))
    assert metadata["raytrace:spp"] == 1 and metadata["raytrace:sampler"] == "grid"
    assert names(tmp_path) == sorted(["x" + ext, "x.exr"])


def test_tiff_without_metadata(tmp_path):
    """No metadata at all (OIIO 3.2.2 failed here too: its empty Exif directory)."""
    write_image_file(tmp_path / "x.tif", np.full((4, 4, 3), 0.5, np.float32))
    assert read(tmp_path / "x.tif")[1].shape == (4, 4, 3)


# --- 15a, 16: errors name the option and the path the user gave; checked before the work --------------

@pytest.mark.parametrize("argv, option", [
    (["render", CORNELL, "-o", "{ro}/x.png", *SMALL], "-o = '{ro}/x.png'"),
    (["render", CORNELL, "-o", "{tmp}/x.png", "--stats-json", "{ro}/s.json", *SMALL], "--stats-json = '{ro}/s.json'"),
    (["assets", "--out", "{ro}"], "--out = '{ro}'"),
    (["assets", "--out", "{ro}/textures"], "--out = '{ro}/textures'"),
    (["bench", CORNELL, "--width", 16, "--height", 16, "--spp", 1, "--light-samples", 1, "--repeat", 1,
      "--json", "{ro}/b.json"], "--json = '{ro}/b.json'"),
    (["stability", "--lanes", 1, "--json", "{ro}/s.json"], "--json = '{ro}/s.json'"),
    (["converge", CORNELL, "--samplers", "random", "--max-spp", 1, "--width", 8, "--height", 8, "--out", "{ro}"],
     "--out = '{ro}'"),
], ids=["render-o", "stats-json", "assets", "assets-subdir", "bench-json", "stability-json", "converge-out"])
def test_read_only_directory(tmp_path, readonly, argv, option):
    """Refused before any work (nothing on stdout), the option and the user's path named, not the
    temporary file."""
    fill = lambda a: a.format(ro=readonly, tmp=tmp_path) if isinstance(a, str) else a  # noqa: E731
    r = run(*map(fill, argv), cwd=ROOT)
    one_error(r, "command line: " + fill(option))
    assert r.stdout == "" and names(readonly) == [] and names(tmp_path) == ["ro"]


@pytest.mark.parametrize("option", ["-o", "--stats-json"])
def test_render_refuses_a_read_only_directory_before_rendering(tmp_path, readonly, monkeypatch, capsys, option):
    """render in process, with a render made an error of its own: the read-only directory is refused first.
    (render prints nothing on stdout, so the test above cannot tell a refusal before the work from one
    after it.)"""
    import importlib
    from raytrace import cli

    def render_progressive(scene, **kw):
        raise AssertionError("rendered before the outputs were checked")

    monkeypatch.setattr(importlib.import_module("raytrace.render"), "render_progressive", render_progressive)
    refused = readonly / ("x.png" if option == "-o" else "s.json")
    argv = ["-o", refused] if option == "-o" else ["-o", tmp_path / "x.png", "--stats-json", refused]
    assert cli.main(["render", str(CORNELL), *map(str, argv), *map(str, SMALL)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"command line: {option} = '{refused}'" in err, err
    assert names(readonly) == [] and names(tmp_path) == ["ro"]


@pytest.mark.parametrize("option", ["-o", "--stats-json"])
def test_over_long_file_name(tmp_path, option):
    long = tmp_path / ("n" * 300 + (".png" if option == "-o" else ".json"))
    argv = ["-o", long] if option == "-o" else ["-o", tmp_path / "x.png", "--stats-json", long]
    one_error(run("render", CORNELL, *argv, *SMALL), f"command line: {option} = '{long}'", "file name is longer")
    assert names(tmp_path) == []


# --- issue 55, item 3: every file the scene reads is an input, its environment map too ---------------------

def envmap_scene(tmp_path):
    """scenes/materials.toml in tmp_path reading its own copy of the sky (sky.exr), and a link to that copy
    (link.exr); the floor's texture stays the checkout's."""
    (tmp_path / "sky.exr").write_bytes((ROOT / "assets" / "textures" / "sky.exr").read_bytes())
    (tmp_path / "link.exr").symlink_to("sky.exr")
    scene = tmp_path / "scene.toml"
    scene.write_text((ROOT / "scenes" / "materials.toml").read_text()
                     .replace('"../assets/textures/sky.exr"', '"sky.exr"')
                     .replace('"../assets/textures/grid.png"', f'"{ROOT / "assets" / "textures" / "grid.png"}"'))
    return scene


@pytest.mark.parametrize("command, option, name", [
    ("render", "-o", "sky.exr"), ("render", "-o", "link.exr"),
    ("render", "--stats-json", "sky.exr"), ("render", "--stats-json", "link.exr"),
    ("bench", "--json", "sky.exr"), ("bench", "--json", "link.exr"),
])
def test_output_naming_the_environment_map(tmp_path, command, option, name):
    """The environment map, named or through a link, is an input like a texture: refused with one line,
    exit 2, the map's bytes as they were, no file left. (It was left out of the inputs, and the render
    replaced the map.)"""
    scene = envmap_scene(tmp_path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    path = tmp_path / name
    if command == "render":
        argv = ["-o", path] if option == "-o" else ["-o", tmp_path / "x.png", "--stats-json", path]
        r = run("render", scene, *argv, *SMALL)
    else:
        r = run("bench", scene, "--width", 8, "--height", 8, "--spp", 1, "--repeat", 1, "--json", path)
    # the path's middle may be shortened in the line (raytrace.errors): its start and its name stay
    one_error(r, f"command line: {option} = '", f"{name}': is an input of this run ({tmp_path / 'sky.exr'})")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    assert (tmp_path / "link.exr").is_symlink()


def test_scene_inputs_lists_every_file_read(tmp_path):
    """The scene file, its textures, its meshes and its environment map."""
    from raytrace.outputs import scene_inputs
    from raytrace.scene import load_file
    scene = envmap_scene(tmp_path)
    assert scene_inputs(load_file(scene)) == [str(scene), str(ROOT / "assets" / "textures" / "grid.png"),
                                              str(tmp_path / "sky.exr")]


# --- issue 55, item 2: JSON never holds NaN or Infinity ------------------------------------------------

def strict_json(text):
    """json.loads refusing NaN, Infinity and -Infinity, which Python's json reads by default but JSON has not."""
    def refuse(word):
        raise ValueError(f"not JSON: {word}")
    return json.loads(text, parse_constant=refuse)


NONFINITE_RENDER = """
import importlib
import sys
from raytrace import cli
module = importlib.import_module("raytrace.render")  # the package's attribute `render` is the function
real = module.render_progressive
def render_progressive(scene, **kwargs):  # as a render whose sums held a NaN or an Inf would report it
    image, variance, stats = real(scene, **kwargs)
    stats.estimated_rmse, stats.estimated_relative_rmse = float("nan"), float("inf")
    stats.history[-1].update(estimated_rmse=float("nan"), estimated_relative_rmse=float("inf"))
    stats.extra["device_bytes"] = float("-inf")
    return image, variance, stats
module.render_progressive = render_progressive
sys.exit(cli.main(sys.argv[1:]))
"""


def test_stats_json_writes_nonfinite_numbers_as_null(tmp_path):
    """A render whose error estimate is not finite (its sums held a NaN or an Inf) wrote NaN and Infinity
    into --stats-json, which no strict JSON parser reads, and the NaN into the EXR's raytrace:estimated_rmse;
    now they are null (docs/cli.md), the attribute absent, the rest as it was."""
    r = subprocess.run([sys.executable, "-c", NONFINITE_RENDER, "render", str(CORNELL), "-o", str(tmp_path / "x.exr"),
                        "--stats-json", str(tmp_path / "s.json"), *map(str, SMALL)],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "s.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    stats = strict_json(text)
    assert stats["estimated_rmse"] is None and stats["estimated_relative_rmse"] is None
    assert stats["history"][-1]["estimated_rmse"] is None and stats["extra"]["device_bytes"] is None
    assert stats["spp"] == 1 and stats["width"] == 16 and stats["render_seconds"] > 0
    spec, pixels = read(tmp_path / "x.exr")  # the image's attributes leave the estimate out, as after one pass
    assert spec.getattribute("raytrace:estimated_rmse") is None and spec.getattribute("raytrace:spp") == 1
    assert np.isfinite(pixels).all()


def test_write_json_never_writes_nan(tmp_path):
    """write_json, every command's JSON writer: non-finite numbers (floats and numpy's) as null, numpy
    numbers and arrays as JSON's, and anything else JSON cannot hold an error, never a file that is not JSON."""
    from raytrace.outputs import write_json
    path = tmp_path / "x.json"
    write_json(path, {"a": float("nan"), "b": [1.5, float("inf"), np.float32(-np.inf)], "c": (np.int64(3),),
                      "d": np.array([0.5, np.nan]), "e": {"f": np.float64(2.0), "g": None, "h": "NaN"}})
    assert strict_json(path.read_text()) == {"a": None, "b": [1.5, None, None], "c": [3], "d": [0.5, None],
                                             "e": {"f": 2.0, "g": None, "h": "NaN"}}
    with pytest.raises(TypeError):
        write_json(path, {"a": object()})
