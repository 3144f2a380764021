"""The command line as a user runs it: real files written and read back with OpenImageIO, and bad input
answered with one line, exit status 2 and no output file."""
import json

import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import CORNELL, ROOT, SESSION_DEVICE, needs_a_cpu_device, run
from raytrace.image_file import encode_8bit
from raytrace.render import render_progressive

def read(path):
    """Spec and pixels in the file's own format (ImageBuf.get_pixels(UNKNOWN) crashes in OIIO 3.2.2)."""
    image = oiio.ImageInput.open(str(path))
    assert image is not None, oiio.geterror()
    spec = image.spec()
    pixels = image.read_image(spec.format)
    image.close()
    return spec, pixels


def test_render_png_exr_and_stats(tmp_path, cornell):
    size = ["--width", 40, "--height", 32, "--spp", 4, "--light-samples", 4]
    png, exr, stats = tmp_path / "c.png", tmp_path / "c.exr", tmp_path / "s.json"
    assert run("render", CORNELL, "-o", png, *size, "--stats-json", stats).returncode == 0
    r = run("render", CORNELL, "-o", exr, *size)
    assert r.returncode == 0, r.stderr
    spec, pixels = read(exr)
    assert (spec.width, spec.height, spec.nchannels) == (40, 32, 6) and pixels.dtype == np.float32
    assert list(spec.channelnames) == ["R", "G", "B", "variance.R", "variance.G", "variance.B"]
    assert spec.getattribute("raytrace:spp") == 4 and spec.getattribute("raytrace:light_samples") == 4
    assert spec.getattribute("raytrace:sampler") == "grid" and spec.getattribute("raytrace:device") == SESSION_DEVICE
    assert spec.getattribute("raytrace:seconds") > 0
    image, variance, _ = render_progressive(cornell, width=40, height=32, spp=4, light_samples=4)
    np.testing.assert_array_equal(pixels[..., :3], image)       # EXR keeps the linear floats as they are
    np.testing.assert_array_equal(pixels[..., 3:], variance)
    assert spec.getattribute("raytrace:estimated_rmse") == pytest.approx(np.sqrt(np.mean(variance)), rel=1e-5)
    spec8, pixels8 = read(png)
    assert spec8.format == oiio.UINT8
    np.testing.assert_array_equal(pixels8, encode_8bit(image))
    data = json.loads(stats.read_text())
    for key in ("render_seconds", "build_seconds", "rays", "mrays_per_s", "device", "build_options",
                "estimated_rmse", "passes", "stopped_by"):
        assert key in data
    assert [h["samples"] for h in data["history"]] == [4] and data["history"][-1]["estimated_rmse"] > 0
    assert data["rays"] > 40 * 32 * 4 and "-DHAS_ELLIPSOIDS=1" in data["build_options"]


def test_8bit_encoding():
    """ceil(255 x^(1/2.2)) of docs/model.md, image files, clamped."""
    x = np.array([-1.0, 0.0, 1e-7, 0.5, 1.0, 3.0])
    np.testing.assert_array_equal(encode_8bit(x), [0, 0, 1, 187, 255, 255])


@pytest.mark.parametrize("args,needle", [
    (["--spp", "-1"], "command line: --spp = -1"),
    (["--width", "0"], "command line: --width = 0"),
    (["--sampler", "fancy"], "command line: --sampler = 'fancy'"),
    (["--spp", "5"], "render.sampler = 'grid': the grid sampler needs a square number (1, 4, 9, 16, ...), not spp = 5"),
    (["--spp", "abc"], "command line: --spp = 'abc'"),
    (["--light-samples", "0"], "command line: --light-samples = 0"),
    (["--device", "no-such-device"], "command line: --device = 'no-such-device'"),
    (["--texture-filter", "cubic"], "command line: --texture-filter = 'cubic'"),
    (["--light-sampler", "fancy"], "command line: --light-sampler = 'fancy'"),
    (["--light-sampler", "center", "--light-samples", "4"], "render.light_sampler = 'center': the center sampler takes "
                                                            "exactly one sample, not light_samples = 4"),
    (["--sampler", "rotated-grid-cw", "--spp", "8"], "render.sampler = 'rotated-grid-cw': the rotated-grid-cw sampler needs "
                                                      "a square number (1, 4, 9, 16, ...), not spp = 8"),
    (["--time-limit", "0"], "command line: --time-limit = 0"),
    (["--time-limit", "nan"], "command line: --time-limit = nan"),
    (["--target-error", "-1"], "command line: --target-error = -1"),
    (["--target-error", "inf"], "command line: --target-error = inf"),
    (["--seed", "-1"], "command line: --seed = -1"),
    (["--seed", str(2**32)], f"command line: --seed = {2**32}"),
])
def test_bad_command_line(tmp_path, args, needle):
    out = tmp_path / "x.png"
    r = run("render", CORNELL, "-o", out, "--width", 16, "--height", 16, *args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_bad_scene_files(tmp_path):
    cases = {
        "missing.toml": None,
        "broken.toml": "[camera\n",
        "wrongkey.toml": open(CORNELL).read().replace("fov = 45.0", "fov = 45.0\nzoom = 2"),
        "singular.toml": open(CORNELL).read().replace("[0.0, 0.0, 0.4]]", "[0.0, 0.0, 0.0]]"),
        "badvector.toml": open(CORNELL).read().replace("look_at = [0.0, 0.0, 1.0]", "look_at = [0.0, 1.0]"),
        "badsampler.toml": open(CORNELL).read().replace('sampler = "grid"', 'sampler = "fancy"'),
        "badcount.toml": open(CORNELL).read().replace('sampler = "grid"', 'sampler = "grid"\nlight_sampler = '
                                                      '"center"'),
    }
    expected = {"missing.toml": "file", "broken.toml": "toml", "wrongkey.toml": "camera.zoom = 2",
                "singular.toml": "shapes[6].axes", "badvector.toml": "camera.look_at = [0.0, 1.0]",
                "badsampler.toml": "render.sampler = 'fancy'", "badcount.toml": "render.light_sampler = 'center'"}
    for name, text in cases.items():
        scene = tmp_path / name
        if text is not None:
            scene.write_text(text)
        out = tmp_path / "out" / "x.png"
        out.parent.mkdir(exist_ok=True)
        r = run("render", scene, "-o", out)
        assert r.returncode == 2, name
        assert r.stderr.count("\n") == 1 and name in r.stderr and expected[name] in r.stderr, r.stderr
        assert list(out.parent.iterdir()) == []


def test_bad_output(tmp_path):
    """An image format we do not write, a directory that does not exist: one line naming -o and the path,
    exit 2, nothing written (the checks of the whole line: the temporary path itself holds "-o")."""
    for path, problem in ((tmp_path / "x.gif", "unsupported extension (have: .bmp, "),
                          (tmp_path / "no" / "dir" / "x.png", "its directory does not exist")):
        r = run("render", CORNELL, "-o", path)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert r.stderr.startswith(f"raytrace: error: command line: -o = '{path}': {problem}"), r.stderr
        assert list(tmp_path.iterdir()) == []


def test_bad_texture_files(tmp_path):
    """A missing texture, a file that is no image, a normal map with one channel: one line naming the
    scene, the material's key and the texture's path; exit 2; nothing written."""
    grey = tmp_path / "grey.png"
    out = oiio.ImageOutput.create(str(grey))
    assert out.open(str(grey), oiio.ImageSpec(4, 4, 1, "uint8")) and out.write_image(np.zeros((4, 4, 1), np.uint8))
    out.close()
    (tmp_path / "junk.png").write_text("not a png")
    text = open(CORNELL).read()
    for value, key in (("missing.png", "texture"), ("junk.png", "texture"), ("grey.png", "normal_map")):
        scene = tmp_path / f"{key}.toml"
        scene.write_text(text.replace('red = { colour = [0.8, 0.0, 0.0] }',
                                      f'red = {{ colour = [0.8, 0.0, 0.0], {key} = "{value}" }}'))
        (tmp_path / "out").mkdir(exist_ok=True)
        r = run("render", scene, "-o", tmp_path / "out" / "x.png")
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
        assert f"materials.red.{key} = '{tmp_path / value}'" in r.stderr and str(scene) in r.stderr, r.stderr
        assert list((tmp_path / "out").iterdir()) == []


def test_textured_render_and_filters(tmp_path):
    """Each filter renders the textured scene through the command line, records itself in the file, and
    changes the image (the grid floor's far lines)."""
    scene = ROOT / "scenes" / "grid_floor.toml"
    images = {}
    for f in ("nearest", "trilinear"):
        r = run("render", scene, "-o", tmp_path / f"{f}.exr", "--width", 32, "--height", 32, "--spp", 1,
                "--sampler", "center", "--light-samples", 1, "--texture-filter", f)
        assert r.returncode == 0, r.stderr
        spec, images[f] = read(tmp_path / f"{f}.exr")
        assert spec.getattribute("raytrace:texture_filter") == f
    assert np.abs(images["nearest"] - images["trilinear"]).max() > 0.05


def test_assets_are_reproducible(tmp_path):
    """`python -m raytrace assets` writes the committed textures again, byte for byte."""
    r = run("assets", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    committed = sorted((ROOT / "assets" / "textures").iterdir())
    assert [p.name for p in committed] == sorted(p.name for p in tmp_path.iterdir())
    for path in committed:
        assert (tmp_path / path.name).read_bytes() == path.read_bytes(), path.name


def test_stability_table_json_and_exit_status(tmp_path):
    """`stability` prints one table row per JSON row, with its verdict, and exits with 1 exactly when a row
    fails (tests/stability/ holds each row to its verdict)."""
    r = run("stability", "--lanes", 8, "--json", tmp_path / "s.json")
    data = json.loads((tmp_path / "s.json").read_text())
    verdicts = [row["verdict"] for row in data["rows"]]
    assert r.returncode == (1 if "FAIL" in verdicts else 0), r.stderr
    lines = r.stdout.splitlines()
    assert "LANES=8" in lines[0] and lines[1].split()[:3] == ["case", "measured", "max"]
    assert len(lines) == len(data["rows"]) + 3 and data["lanes"] == 8
    for line, row in zip(lines[2:], data["rows"]):
        assert line.startswith(row["case"]) and row["measured"] in line and row["verdict"] in line


@pytest.mark.parametrize("fails", [False, True])
def test_stability_exits_with_1_exactly_when_a_row_fails(tmp_path, monkeypatch, fails):
    """The table's cases replaced by two of our own, in process: one row that passes and one that fails or
    is a known limit within its bound. Exit status 1 with the failing row, 0 without it; the JSON file
    holds both rows either way."""
    from raytrace import cli
    from raytrace.commands.stability import table
    from raytrace.commands.stability.common import Row

    def within(env):
        return [Row("a value within its bound", 1e-7, "", 1e-6, "one rounding")]

    def limit(env):  # a known limit holds its bound too; beyond it, it fails
        return [Row("a value at a stated limit", 1e-5 if fails else 1e-7, "", 1e-6, "a limit", known_limit=True)]

    monkeypatch.setattr(table, "CASES", [within, limit])
    status = cli.main(["stability", "--lanes", "8", "--json", str(tmp_path / "s.json")])
    verdicts = [row["verdict"] for row in json.loads((tmp_path / "s.json").read_text())["rows"]]
    assert (status, verdicts) == ((1, ["pass", "FAIL"]) if fails else (0, ["pass", "known limit"]))


@pytest.mark.parametrize("args,needle", [
    (["--lanes", "3"], "command line: --lanes = '3'"),
    (["--lanes", "x"], "command line: --lanes = 'x'"),
    (["--json", "no/such/dir/s.json"], "command line: --json = 'no/such/dir/s.json'"),
])
def test_stability_bad_command_line(tmp_path, args, needle):
    r = run("stability", *args, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert r.stdout == "" and list(tmp_path.iterdir()) == []


@needs_a_cpu_device
def test_device_by_type():
    """--device cpu picks a CPU device (PoCL here); --device gpu a GPU, or one line naming --device and the
    devices there are when there is none (this machine)."""
    import pyopencl as cl
    from raytrace.renderer.device import select_device
    from raytrace.errors import InputError
    assert select_device("cpu").type & cl.device_type.CPU
    try:
        assert select_device("GPU").type & cl.device_type.GPU
    except InputError as e:
        assert "render(): device = 'GPU': no GPU device (have: " in str(e)


def test_the_largest_seed_is_written_into_the_exr(tmp_path):
    """Found by the fuzz suite: --seed 4294967295 (2^32 - 1, accepted) ended in OpenImageIO's std::bad_cast,
    an int attribute being int32; a larger one goes in as its decimal string."""
    out = tmp_path / "s.exr"
    r = run("render", CORNELL, "-o", out, "--width", 4, "--height", 4, "--spp", 1, "--light-samples", 1,
            "--seed", 2**32 - 1)
    assert r.returncode == 0, r.stderr
    assert int(read(out)[0].getattribute("raytrace:seed")) == 2**32 - 1


@pytest.mark.parametrize("spec,problem", [("99999999999999999999:1:7:9", "matches no device"),  # found by the fuzz
                                          ("99999999999999999999:1", "no such platform:device index"),  # suite
                                          ("0:7", "no such platform:device index")])
def test_device_specs_that_name_no_device(tmp_path, spec, problem):
    r = run("render", CORNELL, "-o", tmp_path / "d.png", "--width", 4, "--height", 4, f"--device={spec}")
    assert r.returncode == 2 and r.stderr == f"raytrace: error: command line: --device = '{spec}': {problem}" + (
        r.stderr.split(problem, 1)[1]) and r.stderr.count("\n") == 1 and not list(tmp_path.iterdir()), r.stderr


def test_a_bare_command_and_an_unknown_option_are_one_line():
    """A bare `raytrace` said `command line: raytrace: the following arguments are required` (the prefix twice);
    `--samples 16` said `unrecognized arguments`: now the missing argument is the key, and an unknown option gets
    the option meant (Mitsuba's and pbrt's names for the sample count included)."""
    r = run()
    assert (r.returncode, r.stderr) == (2, "raytrace: error: command line: command: is required (one of: render, "
                                           "bench, assets, converge, compile, convert, stability)\n")
    r = run("render", CORNELL, "-o", "x.png", "--samples", 16)
    assert (r.returncode, r.stderr) == (2, "raytrace: error: command line: --samples: is no render option or "
                                           "argument; did you mean '--spp'?\n")
    r = run("render", CORNELL, "-o", "x.png", "--light-sampels=4")
    assert r.stderr.endswith("; did you mean '--light-samples'?\n")
    r = run("rendr", CORNELL)
    assert r.returncode == 2 and r.stderr.endswith("; did you mean 'render'?\n")


def test_version_and_help():
    """No --version; the top-level help's description ended mid-sentence (the module docstring's first line)."""
    r = run("--version")
    assert r.returncode == 0 and r.stdout.startswith("raytrace ")
    r = run("--help")
    description = r.stdout.split("\n\n")[1].replace("\n", " ")
    assert description.startswith("A ray tracer whose") and description.endswith("against float64.")


def test_compile_writes_what_the_compiler_made(tmp_path):
    """compile wrote its binary nowhere: -o writes it (PTX text here, whose header names its target), and the
    help lists every target, the CPU levels included."""
    out = tmp_path / "kernel.ptx"
    r = run("compile", CORNELL, "--target", "nvptx", "-o", out)
    assert r.returncode == 0 and r.stdout.rstrip().endswith(f"-> {out}"), r.stderr
    text = out.read_text()
    assert ".target sm_" in text and f"{len(text.encode())} bytes" in r.stdout
    help_text = run("compile", "--help").stdout
    assert "x86-64-v3" in help_text and "amdgcn" in help_text
    before = open(CORNELL, "rb").read()
    r = run("compile", CORNELL, "--target", "nvptx", "-o", CORNELL)  # an input is never an output
    assert r.returncode == 2 and r.stderr.startswith("raytrace: error: command line: -o = ")
    assert open(CORNELL, "rb").read() == before


def test_converge_without_its_extra_is_refused_before_any_work(monkeypatch, tmp_path, capsys):
    """A plain `pip install .` then `converge` rendered 15 s and died with ModuleNotFoundError: flip_evaluator.
    A missing module of the analysis extra is now one line naming the extra, before any render."""
    import importlib.util
    from raytrace import cli
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "flip_evaluator" else real(
        name, *a))
    status = cli.main(["converge", CORNELL, "--samplers", "sobol", "--max-spp", "4", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2 and err == ("raytrace: error: environment: converge: needs the analysis extra (flip_evaluator "
                                   "missing): pip install \"raytrace[analysis]\", or -e \".[analysis]\" in a "
                                   "checkout\n")
    assert not (tmp_path / "o").exists()


def test_the_summary_says_where_the_sample_count_came_from(tmp_path):
    """The line a render ends with names the count's source: the scene's, --spp, the default, or the target."""
    out = tmp_path / "x.png"
    r = run("render", CORNELL, "-o", out, "--width", 8, "--height", 8, "--light-samples", 1)
    assert r.returncode == 0 and "16 spp (grid; the scene's spp)" in r.stderr, r.stderr
    r = run("render", CORNELL, "-o", out, "--width", 8, "--height", 8, "--light-samples", 1, "--spp", 4)
    assert "4 spp (grid; --spp)" in r.stderr
    r = run("render", CORNELL, "-o", out, "--width", 64, "--height", 64, "--light-samples", 4, "--sampler", "sobol",
            "--target-error", 0.05)
    assert "spp (sobol; until --target-error, at most 65536)" in r.stderr and "stopped by target-error" in r.stderr


def test_a_stability_row_that_measured_nan_is_null_in_its_json(tmp_path, monkeypatch):
    """stability --json wrote with its own json.dumps, where only two fields were kept finite: it goes through
    outputs.write_json as every command's JSON does, so a NaN anywhere is null (and fails the row)."""
    from raytrace import cli
    from raytrace.commands.stability import table
    from raytrace.commands.stability.common import Row
    monkeypatch.setattr(table, "CASES", [lambda env: [Row("not a number", float("nan"), "", float("inf"), "none")]])
    assert cli.main(["stability", "--lanes", "8", "--json", str(tmp_path / "s.json")]) == 1
    text = (tmp_path / "s.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    [row] = json.loads(text)["rows"]
    assert (row["error"], row["bound"], row["verdict"]) == (None, None, "FAIL")
