"""`python -m raytrace converge`: real renders on PoCL at 32 x 32, the files it writes read back with
OpenImageIO and the csv module, and bad input answered with one line, exit status 2 and no converge.csv."""
import csv
import io
import json
import math

import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import ROOT, run
from raytrace import cli
from raytrace.commands.converge import COLUMNS, converge, fitted_slope, light_pattern, sample_counts
from raytrace.image_file import write_image

CORNELL = ROOT / "scenes" / "cornell.toml"
SAMPLERS = ("random", "sobol", "grid", "center")
SIZE = ("--width", "32", "--height", "32", "--light-samples", "4")
EXPECTED = [("random", n) for n in (1, 2, 4, 8, 16)] + [("sobol", n) for n in (1, 2, 4, 8, 16)] + \
           [("grid", 1), ("grid", 4), ("grid", 16), ("center", 1)]


def read_csv(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def read_image(path):
    buf = oiio.ImageBuf(str(path))
    assert buf.read(0, 0, True, oiio.FLOAT) and not buf.has_error, buf.geterror()
    return buf.spec(), buf.get_pixels(oiio.FLOAT)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """One run on scene 0 at 32 x 32, 4 light samples, up to 16 spp, a 256-spp reference rendered."""
    out_dir = tmp_path_factory.mktemp("converge")
    text = io.StringIO()
    result = converge(CORNELL, SAMPLERS, 16, out_dir, width=32, height=32, light_samples=4, reference_spp=256,
                      out=text)
    return out_dir, result, text.getvalue()


def test_csv_rows(measured):
    """One row per (pattern, count): powers of 2 up to 16, powers of 4 for grid, 1 for center. Times and
    errors are finite and positive; FLIP's mean is in (0, 1); a one-pass render has no error estimate.
    16 times the samples cut random's error by about 4 (independent samples, measured 0.098 -> 0.022) and
    sobol's by more (measured 0.092 -> 0.0076): a factor 2 leaves room for the noise of 1024 pixels. The
    grid's one point is the pixel centre, with the same light grid as center: the same image, the same
    rmse to the last bit."""
    out_dir, result, _ = measured
    columns, rows = read_csv(out_dir / "converge.csv")
    assert tuple(columns) == COLUMNS
    assert [(r["sampler"], int(r["spp"])) for r in rows] == EXPECTED
    for r in rows:
        assert 0 < float(r["seconds"]) < 60 and 0 < float(r["rmse"]) < 1 and 0 < float(r["flip"]) < 1
        assert (r["estimated_rmse"] == "") == (r["spp"] == "1")
        assert r["estimated_rmse"] == "" or 0 < float(r["estimated_rmse"]) < 1
    rmse = {(r["sampler"], int(r["spp"])): float(r["rmse"]) for r in rows}
    for name in ("random", "sobol"):
        assert rmse[name, 16] < rmse[name, 1] / 2, name
    assert rmse["grid", 1] == rmse["center", 1]
    assert [(r["sampler"], r["spp"]) for r in result["rows"]] == EXPECTED


def test_files_and_table(measured):
    """The plot and the montage are PNGs of a readable size (the montage: reference + 4 patterns in 4
    columns of crops enlarged to about 256 pixels); the reference EXR is 32 x 32 linear floats carrying its
    samples and its estimated error, the same as reference.json; stdout holds the table and the paths."""
    out_dir, result, text = measured
    spec, _ = read_image(out_dir / "converge.png")
    assert spec.width >= 400 and spec.height >= 300
    spec, _ = read_image(out_dir / "montage.png")
    assert spec.width >= 4 * 200 and spec.height >= 2 * 200
    spec, pixels = read_image(out_dir / "reference.exr")
    assert (spec.width, spec.height, spec.nchannels) == (32, 32, 3) and np.all(np.isfinite(pixels))
    facts = json.loads((out_dir / "reference.json").read_text())
    assert facts["spp"] == spec.getattribute("raytrace:spp") == 256
    assert math.isclose(facts["estimated_rmse"], spec.getattribute("raytrace:estimated_rmse"), rel_tol=1e-6)
    assert 0 < facts["estimated_rmse"] < min(float(r["rmse"]) for r in result["rows"])
    lines = text.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split() == list(COLUMNS))
    assert [tuple(line.split()[:2]) for line in lines[header + 1:header + 1 + len(EXPECTED)]] == \
           [(name, str(n)) for name, n in EXPECTED]
    for path in result["paths"]:
        assert f"wrote {path}" in text and path.is_file()
    assert [p["sampler"] for p in result["montage"]] == list(SAMPLERS)
    assert result["montage"][-1]["spp"] == 1 and all(p["spp"] >= 1 for p in result["montage"])


def test_given_reference(measured, tmp_path, capsys, monkeypatch):
    """The written reference.exr, given back through the command line, gives the same rows but the
    times: every render is deterministic for a fixed seed and the EXR keeps the float32 image exactly.
    No reference is rendered or written this time, and timing each render twice (--repeats) changes only
    the seconds: two renders a row, after the one untimed render that builds the kernel."""
    from raytrace.commands import converge as module
    calls, real = [], module.render_progressive
    monkeypatch.setattr(module, "render_progressive", lambda scene, **kw: calls.append(kw) or real(scene, **kw))
    out_dir, _, _ = measured
    out = tmp_path / "again"
    assert cli.main(["converge", str(CORNELL), "--samplers", ",".join(SAMPLERS), "--max-spp", "16", *SIZE,
                     "--reference", str(out_dir / "reference.exr"), "--montage-seconds", "0.05",
                     "--repeats", "2", "--out", str(out)]) == 0
    assert "reference.exr" in capsys.readouterr().out
    _, first = read_csv(out_dir / "converge.csv")
    _, again = read_csv(out / "converge.csv")
    drop = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]  # noqa: E731
    assert drop(again) == drop(first)
    assert calls[0]["sampler"] == "center" and len(calls) == 1 + 2 * len(again)
    assert sorted(p.name for p in out.iterdir()) == ["converge.csv", "converge.png", "montage.png"]


def test_light_pattern_fallback_said_once(tmp_path, capsys):
    """2 light samples are no square: grid's light falls back to sobol, said once for its three renders."""
    assert cli.main(["converge", str(CORNELL), "--samplers", "grid", "--max-spp", "16", "--width", "8",
                     "--height", "8", "--light-samples", "2", "--reference-spp", "16", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("the light uses sobol") == 1
    assert [(r["sampler"], r["spp"]) for r in read_csv(tmp_path / "converge.csv")[1]] == \
           [("grid", "1"), ("grid", "4"), ("grid", "16")]


def test_device_reaches_every_render(tmp_path, monkeypatch):
    """--device is every render's, the reference's included: each call of render_progressive gets it."""
    from raytrace.commands import converge as module
    devices, real = [], module.render_progressive
    monkeypatch.setattr(module, "render_progressive",
                        lambda scene, **kw: devices.append(kw.get("device")) or real(scene, **kw))
    assert cli.main(["converge", str(CORNELL), "--samplers", "random", "--max-spp", "2", "--width", "8",
                     "--height", "8", "--light-samples", "1", "--reference-spp", "4", "--device", "cpu",
                     "--out", str(tmp_path)]) == 0
    assert len(devices) >= 3 and set(devices) == {"cpu"}


def test_counts_lights_and_slope():
    """The measured counts per pattern, the light pattern each pixel pattern brings, and the slope of
    exact power laws (the 1-spp row, off the line here, is left out of the fit)."""
    assert sample_counts("random", 64) == [1, 2, 4, 8, 16, 32, 64]
    assert sample_counts("rotated-grid-ccw", 63) == [1, 4, 16]
    assert sample_counts("center", 64) == sample_counts("halton", 1) == [1]
    assert light_pattern("center", 16) == ("grid", None) and light_pattern("halton", 3) == ("halton", None)
    assert light_pattern("center", 3)[0] == light_pattern("rotated-grid-cw", 8)[0] == "sobol"
    assert light_pattern("grid", 1) == ("grid", None)  # the Phong model's point light
    light, note = light_pattern("grid", 1, "direct")  # in the direct model a biased one: refused by render()
    assert light == "sobol" and "light's centre" in note
    rows = [{"spp": 1, "seconds": 1.0, "rmse": 1.0}] + [{"spp": n, "seconds": n, "rmse": n ** -0.5} for n in (2, 4, 8)]
    assert math.isclose(fitted_slope(rows), -0.5)
    assert fitted_slope(rows[:2]) is None


@pytest.mark.parametrize("args,needle", [
    (["--samplers", "random,fancy"], "command line: --samplers = 'fancy'"),
    (["--max-spp", "0"], "command line: --max-spp = 0"),
    (["--max-spp", "65537"], "command line: --max-spp = 65537"),
    (["--repeats", "0"], "command line: --repeats = 0"),
    (["--reference", "{tmp}/missing.exr"], "command line: --reference = '{tmp}/missing.exr'"),
    (["--reference", "{tmp}/small.exr"], "command line: --reference = '{tmp}/small.exr'"),
    (["--crop", "0.9,0.9,0.2,0.2"], "command line: --crop = '0.9,0.9,0.2,0.2'"),
    (["--crop", "a,b"], "command line: --crop = 'a,b'"),
    (["--montage-seconds", "0"], "command line: --montage-seconds = 0"),
    (["--out", "{tmp}/file"], "command line: --out = '{tmp}/file'"),
    (["--device", "no such device"], "command line: --device = 'no such device'"),
])
def test_bad_input(tmp_path, capsys, monkeypatch, args, needle):
    """Each bad value is found before anything renders (a render here is an error of its own): exit 2, one
    stderr line naming the key and the value, no traceback, no converge.csv (the output directory is not
    even made)."""
    from raytrace.commands import converge as module

    def render_progressive(scene, **kw):
        raise AssertionError("rendered before the input was checked")

    monkeypatch.setattr(module, "render_progressive", render_progressive)
    write_image(tmp_path / "small.exr", np.zeros((16, 16, 3), np.float32))
    (tmp_path / "file").write_text("")
    base = {"--samplers": "random", "--max-spp": "4", "--out": str(tmp_path / "out")}
    for key, value in zip(args[::2], args[1::2]):
        base[key] = value.format(tmp=tmp_path)
    argv = ["converge", str(CORNELL), *SIZE, *[item for pair in base.items() for item in pair]]
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert needle.format(tmp=tmp_path) in captured.err, captured.err
    assert not (tmp_path / "out").exists()


# --- issue 55, item 7: a reference no render could be; an all-black scene ------------------------------

def dark_scene(tmp_path):
    """Scene 0 with no ambient term and a black light: every render of it is 0, exactly."""
    scene = tmp_path / "dark.toml"
    scene.write_text(CORNELL.read_text().replace("ambient = [0.1, 0.1, 0.1]", "ambient = [0.0, 0.0, 0.0]")
                     .replace("colour = [1.0, 1.0, 1.0]", "colour = [0.0, 0.0, 0.0]"))
    return scene


def reference_file(path, pixels, **attributes):
    """An EXR of `pixels` carrying `attributes` as raytrace:NAME, written with OpenImageIO itself (write_image
    would refuse some of them)."""
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.FLOAT)
    for name, value in attributes.items():
        spec.attribute(f"raytrace:{name}", value)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(pixels, np.float32)) and out.close()
    return path


def one_pixel(value):
    pixels = np.full((8, 8, 3), 0.25, np.float32)
    pixels[3, 5, 1] = value
    return pixels


@pytest.mark.parametrize("pixels, attributes, needle", [
    (np.full((8, 8, 3), -0.5), {}, "--reference = '{ref}': holds 192 negative values of 192 (the least -0.5)"),
    (one_pixel(-1e-3), {}, "--reference = '{ref}': holds 1 negative value of 192 (the least -0.001)"),
    (one_pixel(np.inf), {}, "--reference = '{ref}': holds NaN or Inf"),
    (one_pixel(0.5), {"estimated_rmse": float("nan")}, "{ref}: raytrace:estimated_rmse = nan: must be a finite"),
    (one_pixel(0.5), {"estimated_rmse": -1.0}, "{ref}: raytrace:estimated_rmse = -1.0: must be a finite"),
    (one_pixel(0.5), {"spp": "many"}, "{ref}: raytrace:spp = 'many': must be a sample count in [1, 65536]"),
    (one_pixel(0.5), {"spp": 0}, "{ref}: raytrace:spp = 0: must be a sample count"),
], ids=["all-negative", "one-negative", "inf", "rmse-nan", "rmse-negative", "spp-text", "spp-zero"])
def test_a_reference_no_render_could_be(tmp_path, pixels, attributes, needle):
    """Radiance is never negative, so no render makes a negative value (an all-negative EXR was taken and
    compared); nor a sample count or an estimated error that is no number. One line, exit status 2, before
    any render (nothing on stdout, where the reference's line comes first), no output directory."""
    ref = reference_file(tmp_path / "ref.exr", pixels, **attributes)
    r = run("converge", CORNELL, "--samplers", "random", "--max-spp", 2, "--width", 8, "--height", 8,
            "--light-samples", 1, "--reference", ref, "--out", tmp_path / "out")
    assert r.returncode == 2 and r.stdout == "", (r.stdout, r.stderr)
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert needle.format(ref=ref) in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


def test_an_all_black_scene_draws_without_warnings(tmp_path):
    """Every RMSE is 0, the reference's own estimate too: nothing can go on log axes. matplotlib warned on
    stderr ("Data has no positive values, and therefore cannot be log-scaled", twice); now stderr is empty,
    stdout says the renders equal the reference, and converge.png is drawn. An all-zero --reference is taken:
    it is what a render of this scene is."""
    scene = dark_scene(tmp_path)
    argv = ("--samplers", "random,sobol", "--max-spp", 4, "--width", 8, "--height", 8, "--light-samples", 1)
    r = run("converge", scene, *argv, "--reference-spp", 16, "--out", tmp_path / "rendered")
    assert r.returncode == 0, r.stderr
    assert "Warning" not in r.stderr and r.stderr == "", r.stderr
    assert "note: 6 of 6 renders equal the reference (RMSE 0)" in r.stdout
    spec, _ = read_image(tmp_path / "rendered" / "converge.png")
    assert spec.width > 400
    assert np.all(read_image(tmp_path / "rendered" / "reference.exr")[1] == 0)
    zeros = reference_file(tmp_path / "zeros.exr", np.zeros((8, 8, 3)))
    r = run("converge", scene, *argv, "--reference", zeros, "--out", tmp_path / "given")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert [float(row["rmse"]) for row in read_csv(tmp_path / "given" / "converge.csv")[1]] == [0.0] * 6
