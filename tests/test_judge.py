"""devtools/judge.py's Z-test, measured on synthetic images whose truth is known: how often it fails two
unbiased images (its false-failure rate, against the binomial bound its argument allows), whether it catches
a 2% bias at realistic noise, and its zero-variance rule; and the plumbing of devtools/peers/xml_check.py
(the chunked mean, the reference file, judge_against_reference on a TOML scene against a fake reference, and
Mitsuba's half where /tmp/mts holds Mitsuba).

Mutations that these tests catch (each tried by hand on devtools/judge.py):
- the threshold without Sidak's correction (norm.isf(alpha / 2) = 2.58): 1% of an unbiased image's values
  fail, more than the 0.25% allowed: test_unbiased_images_pass fails, all 200 trials failing;
- t mapped as if the variances were exact (dof ignored): some value of 12,288 exceeds the threshold in 99
  of 200 trials, beyond the bound of 8: test_estimated_variances_keep_the_rate fails;
- no tiles (tiles=()): the 2% bias in a tenth of the image is not caught: test_a_regional_bias_is_caught fails;
- no rounding allowance: test_zero_variance_values fails on the light's values rounded in float32."""
import json
import math
import os
import shutil

import numpy as np
import OpenImageIO as oiio
import pytest
from scipy import stats

from devtools.judge import judge, side_by_side, sidak_threshold, z_scores
from devtools.peers import xml_check
from helpers import ROOT

H = W = 64
K = 16  # chunks per side, as xml_check's default
TRIALS = 200


def chunked(rng, truth, rel):
    """(mean, variance of the mean) of K chunk means of `truth` with normal noise: the mean's standard deviation
    `rel` of the truth (each chunk's sqrt(K) times that), the variance from the chunks' spread, K - 1 degrees of
    freedom."""
    chunks = truth + rng.normal(size=(K,) + truth.shape) * (rel * math.sqrt(K)) * truth
    return chunks.mean(axis=0), chunks.var(axis=0, ddof=1) / K


def binomial_bound(p, n=TRIALS, tail=1e-3):
    """The count of n trials, each failing with probability p, that is exceeded with probability below
    `tail`."""
    return int(stats.binom.isf(tail, n, p))


def test_the_threshold_is_sidaks():
    """For N = 64 x 64 x 3 at 1%: alpha_1 = 1 - 0.99^(1/N) = 8.18e-7, two-sided: 4.931; the chance that any
    of N independent normal values exceeds it is 1%."""
    n = H * W * 3
    t = sidak_threshold(n)
    assert t == pytest.approx(4.93105, abs=1e-4)
    assert 1 - (1 - 2 * stats.norm.sf(t)) ** n == pytest.approx(0.01, rel=1e-6)


def test_unbiased_images_pass():
    """The false-failure rate with exact variances: 200 pairs of unbiased 64 x 64 x 3 images (the truth uniform
    in [0.1, 2], noise 5% and 2% of it). Some value exceeds the threshold with probability alpha = 1% per
    image: at most 8 of 200 (the binomial bound, exceeded with probability 1e-3; measured: 1). The image fails
    only with 31 values or more beyond it (0.25% of 12,288) when 0.01 are expected, and the tiles' scales at
    1e-4 each: failures at most binomial_bound(3e-4) = 2 of 200 (measured: 0)."""
    rng = np.random.default_rng(1)
    exceeded = failed = 0
    for _ in range(TRIALS):
        truth = rng.uniform(0.1, 2.0, (H, W, 3))
        mean, ref = truth * (1 + 0.05 * rng.normal(size=truth.shape)), truth * (1 + 0.02 * rng.normal(size=truth.shape))
        v = judge(mean, (0.05 * truth) ** 2, ref, (0.02 * truth) ** 2)
        exceeded += v.failures > 0
        failed += not v.passed
    assert exceeded <= binomial_bound(0.01) == 8
    assert failed <= binomial_bound(3e-4) == 2


def test_estimated_variances_keep_the_rate():
    """Variances from K = 16 chunks on each side, their degrees of freedom given: the same rates as exact ones
    (some value beyond the threshold: at most 8 of 200; measured: 4; no image failing). Taken as exact instead,
    the t variates' heavier tails put some value beyond it in 99 of 200 images, far beyond the bound, though
    the 0.25% margin still passes every image."""
    rng = np.random.default_rng(2)
    exceeded = exceeded_as_exact = failed = failed_as_exact = 0
    for _ in range(TRIALS):
        truth = rng.uniform(0.1, 2.0, (H, W, 3))
        (mean, var), (ref, ref_var) = chunked(rng, truth, 0.03), chunked(rng, truth, 0.015)
        v = judge(mean, var, ref, ref_var, dof=K - 1, ref_dof=K - 1)
        exact = judge(mean, var, ref, ref_var)
        exceeded, failed = exceeded + (v.failures > 0), failed + (not v.passed)
        exceeded_as_exact += exact.failures > 0
        failed_as_exact += not exact.passed
    assert exceeded <= binomial_bound(0.01)
    assert failed <= binomial_bound(3e-4)
    assert exceeded_as_exact > 4 * binomial_bound(0.01)  # the mapping matters
    assert failed_as_exact == 0


def biased_trials(bias, rel=0.03, ref_rel=0.007, trials=20, seed=3):
    """Verdicts of `trials` images whose truth is multiplied by `bias` (H x W x 3), at noise `rel` of the truth
    (raytrace) and `ref_rel` (the reference), variances from K chunks."""
    rng = np.random.default_rng(seed)
    verdicts = []
    for _ in range(trials):
        truth = rng.uniform(0.1, 2.0, (H, W, 3))
        (mean, var), (ref, ref_var) = chunked(rng, truth * bias, rel), chunked(rng, truth, ref_rel)
        verdicts.append(judge(mean, var, ref, ref_var, dof=K - 1, ref_dof=K - 1))
    return verdicts


def test_a_regional_bias_is_caught():
    """A 2% bias over a 26 x 16 block (10.2% of the pixels, not aligned to the tiles) at realistic noise: each
    value's mean 3% of the value, the reference's 0.7% (on a small Cornell box of rectangles at 64 x 64,
    Mitsuba's 4096 samples left a median 0.68% of each value, raytrace's 256 1.7%: 3% is the harder case).
    Under one standard deviation per value: the pixels' test cannot see it, the 16-pixel tiles do (their
    noise 3% / 16), in every one of 20 trials."""
    bias = np.ones((H, W, 3))
    bias[5:31, 37:53] = 1.02
    verdicts = biased_trials(bias)
    assert all(not v.passed for v in verdicts)
    assert all(not next(s for s in v.tiles if s.tile == 16).passed for v in verdicts)
    assert sum(v.failures > v.allowed for v in verdicts) == 0  # the pixels alone: blind to it


def test_a_bias_in_one_channel_is_caught():
    """Red 2% too bright everywhere (a colour conversion's error), the same noise: caught in every trial, and
    the verdict's bias names the channel: +2% in red, green and blue within 0.3%."""
    bias = np.ones((H, W, 3))
    bias[..., 0] = 1.02
    verdicts = biased_trials(bias, seed=4)
    assert all(not v.passed for v in verdicts)
    for v in verdicts:
        assert v.bias[0] == pytest.approx(0.02, abs=0.003)
        assert max(abs(b) for b in v.bias[1:]) < 0.003
        assert v.bias_z[0] > 10 and max(abs(b) for b in v.bias_z[1:]) < 5


def test_a_strong_local_bias_fails_pixels():
    """A 30% bias over 10 x 10 pixels at 1% noise: those values fail one by one (the pixels' test), and the worst
    pixel is among them."""
    rng = np.random.default_rng(5)
    truth = rng.uniform(0.1, 2.0, (H, W, 3))
    biased = truth.copy()
    biased[20:30, 40:50] *= 1.3
    (mean, var), (ref, ref_var) = chunked(rng, biased, 0.01), chunked(rng, truth, 0.01)
    v = judge(mean, var, ref, ref_var, dof=K - 1, ref_dof=K - 1)
    assert not v.passed and v.failures > 250
    assert 20 <= v.worst_pixel[0] < 30 and 40 <= v.worst_pixel[1] < 50


def test_zero_variance_values():
    """Values of zero variance on both sides (a light seen directly, black) pass where they agree to float32
    rounding: the mean of 256 float32 copies of the light's radiance summed in float32 against the value
    itself (off by up to ~1e-6 of it), 0 against 0. One off by 1e-4 of the value fails with an infinite z,
    and so does 0 against 1e-6."""
    rng = np.random.default_rng(6)
    truth = rng.uniform(0.1, 2.0, (H, W, 3))
    (mean, var), (ref, ref_var) = chunked(rng, truth, 0.01), chunked(rng, truth, 0.01)
    light = np.float32([17.3, 12.1, 4.7])
    summed = np.add.accumulate(np.repeat(light[None], 256, axis=0), axis=0, dtype=np.float32)[-1] / np.float32(256)
    assert np.any(summed != light)  # float32 rounding to allow for
    mean[:4, :4], ref[:4, :4], var[:4, :4], ref_var[:4, :4] = summed, light, 0, 0
    mean[-4:, -4:], ref[-4:, -4:], var[-4:, -4:], ref_var[-4:, -4:] = 0, 0, 0, 0
    v = judge(mean, var, ref, ref_var, dof=K - 1, ref_dof=K - 1)
    assert v.passed and np.all(v.z[:4, :4] == 0) and np.all(v.z[-4:, -4:] == 0)
    mean[0, 0, 1] = light[1] * (1 + 1e-4)
    mean[-1, -1, 2] = 1e-6
    v = judge(mean, var, ref, ref_var, dof=K - 1, ref_dof=K - 1)
    assert v.failures == 2 and math.isinf(v.worst_z)
    assert {(0, 0, 1), (H - 1, W - 1, 2)} == {tuple(int(i) for i in p) for p in np.argwhere(np.isinf(v.z))}
    assert v.passed  # two failing values of 12,288 are within the margin; the tiles allow the same rounding


def test_nonfinite_values_fail():
    """A NaN or an infinite value fails (z = inf), never passes by comparing false."""
    mean, ref = np.ones((8, 8, 3)), np.ones((8, 8, 3))
    var = np.full((8, 8, 3), 1e-4)
    mean[1, 2, 0], mean[3, 4, 1] = np.nan, np.inf
    z = z_scores(mean, var, ref, var)
    assert np.isinf(z[1, 2, 0]) and np.isinf(z[3, 4, 1]) and np.count_nonzero(z) == 2


def test_tiles_sum_partial_edges():
    """A tile z is the sums' (mean - ref) / sqrt(var + ref_var) per channel, the last tile of a row and of a
    column smaller (10 pixels in tiles of 4: 4, 4, 2)."""
    rng = np.random.default_rng(7)
    mean, ref = rng.uniform(0.5, 1.0, (10, 10, 3)), rng.uniform(0.5, 1.0, (10, 10, 3))
    var, ref_var = np.full((10, 10, 3), 0.01), np.full((10, 10, 3), 0.02)
    z = z_scores(mean, var, ref, ref_var, tile=4)
    assert z.shape == (3, 3, 3)
    corner = slice(8, 10)
    expected = (mean[corner, corner, 1] - ref[corner, corner, 1]).sum() / math.sqrt(4 * 0.03)
    assert z[2, 2, 1] == pytest.approx(expected)
    whole = z_scores(mean, var, ref, ref_var, tile=None)
    assert whole[0, 0, 0] == pytest.approx((mean[..., 0] - ref[..., 0]).sum() / math.sqrt(100 * 0.03))


def test_verdict_as_dict_is_strict_json():
    """as_dict() holds every field but the z maps, the tiles' scales as dicts, an infinite z as "inf"."""
    mean, ref = np.ones((8, 8, 3)), np.ones((8, 8, 3))
    zero = np.zeros((8, 8, 3))
    mean[0, 0, 0] = 2.0
    d = judge(mean, zero, ref, zero).as_dict()
    text = json.dumps(d, allow_nan=False)
    assert json.loads(text)["worst_z"] == "inf" and d["worst_pixel"] == [0, 0, 0] and d["failures"] == 1
    assert {"passed", "fraction", "threshold", "n", "bias", "bias_z", "tiles"} <= set(d) and "z" not in d
    assert [s["tile"] for s in d["tiles"]] == [4, 16, None]


def test_side_by_side_writes_three_panels(tmp_path):
    """The PNG: three panels of the image enlarged to 256 rows, the failing value's pixel red in the map, a
    failing tile's other pixels tinted orange."""
    rng = np.random.default_rng(8)
    ref = rng.uniform(0.2, 0.8, (32, 32, 3))
    var = np.full(ref.shape, 1e-4)
    mean = ref.copy()
    mean[3, 5, 0] += 1.0
    v = judge(mean, var, ref, var)
    path = tmp_path / "side.png"
    side_by_side(mean, ref, v.z, path, v.threshold, flagged=v.failing_tiles())
    buf = oiio.ImageBuf(str(path))
    assert (buf.spec().width, buf.spec().height, buf.spec().nchannels) == (3 * 256 + 2 * 8, 256, 3)
    pixels = (np.asarray(buf.get_pixels(oiio.FLOAT)) * 255).round()
    zmap = pixels[:, 2 * 256 + 2 * 8:]
    assert tuple(zmap[3 * 8 + 4, 5 * 8 + 4]) == (255, 0, 0)
    r, g, b = zmap[4, 4 * 8 + 4]  # pixel (0, 4): in the failing 4 x 4 tile, tinted orange
    assert r >= 127 and r > g + 40 > b + 80
    assert zmap[200, 200, 1] == zmap[200, 200, 2] < 255  # grey, far from the failure


# --- devtools/peers/xml_check.py ------------------------------------------------------------------------------

def test_chunked_mean_is_the_mean_and_its_variance():
    rng = np.random.default_rng(9)
    chunks = rng.normal(size=(7, 4, 5, 3))
    acc = xml_check.ChunkedMean()
    for c in chunks:
        acc.add(c)
    assert np.allclose(acc.mean, chunks.mean(axis=0))
    assert np.allclose(acc.variance_of_mean(), chunks.var(axis=0, ddof=1) / 7)
    same = xml_check.ChunkedMean()
    for _ in range(5):
        same.add(np.float32([[[17.3, 0.1, 2.0]]]))
    assert np.all(same.variance_of_mean() == 0) and same.mean[0, 0, 0] == np.float32(17.3)


def test_defines_and_chunks_are_checked():
    assert xml_check.parse_defines(["spp=16", "res=a=b"]) == {"spp": "16", "res": "a=b"}
    with pytest.raises(ValueError, match="name=value"):
        xml_check.parse_defines(["spp"])
    with pytest.raises(ValueError, match="dividing"):
        xml_check.split_spp(100, 16, "--spp")


def small_scene(tmp_path, size=16):
    """scenes/cornell_path.toml at size x size, in tmp_path."""
    text = (ROOT / "scenes" / "cornell_path.toml").read_text()
    text = text.replace("width = 512", f"width = {size}").replace("height = 512", f"height = {size}")
    path = tmp_path / "box.toml"
    path.write_text(text)
    return path


def test_judge_against_reference_plumbing(tmp_path):
    """judge_against_reference on a TOML scene against a fake reference written as --write-reference writes one
    (raytrace's own render at other seeds as Mitsuba's): it passes; the reference 5% brighter fails. The
    record names the settings, the machine and the commit."""
    scene = small_scene(tmp_path)
    mean, var, _ = xml_check.render_raytrace(scene, 1024, chunks=16, seed=1000)
    fake = {"mean": mean, "var": var, "spp": 1024, "chunks": 16, "version": "fake", "variant": "raytrace",
            "load_s": 0.0, "first_chunk_s": 0.0, "render_s": 0.0, "wall_s": 0.0}
    path = xml_check.write_reference(scene, fake, {}, ["python", "-m", "devtools.peers.xml_check", str(scene)])
    assert path == tmp_path / "references" / "box.npz" == xml_check.reference_path(scene)
    with np.load(path) as data:
        assert data["mean"].dtype == data["var"].dtype == np.float32 and data["mean"].shape == (16, 16, 3)
        assert int(data["spp"]) == 1024 and int(data["chunks"]) == 16
    record = json.loads(path.with_suffix(".json").read_text())
    assert {"mitsuba_version", "variant", "spp", "chunks", "command", "machine", "date",
            "raytrace_commit"} <= set(record)
    verdict = xml_check.judge_against_reference(scene, 256, seed=0)
    assert verdict.passed and verdict.dof == verdict.ref_dof == 15, verdict.as_dict()
    fake["mean"] = mean * 1.05
    xml_check.write_reference(scene, fake, {}, [])
    assert not xml_check.judge_against_reference(scene, 256, seed=0).passed


def test_the_command_against_a_reference(tmp_path, capsys):
    """`xml_check SCENE --use-reference` prints one JSON line and writes the PNG and the JSON record; status 0
    where the image passes."""
    scene = small_scene(tmp_path)
    mean, var, _ = xml_check.render_raytrace(scene, 512, chunks=16, seed=2000)
    fake = {"mean": mean, "var": var, "spp": 512, "chunks": 16, "version": "fake", "variant": "raytrace",
            "load_s": 0.0, "first_chunk_s": 0.0, "render_s": 0.0, "wall_s": 0.0}
    xml_check.write_reference(scene, fake, {}, [])
    status = xml_check.main([str(scene), "--use-reference", "--spp", "128", "--out", str(tmp_path / "out")])
    line = json.loads(capsys.readouterr().out)
    assert status == 0 and line["verdict"]["passed"] and line["raytrace"]["chunks"] == 16
    assert (tmp_path / "out" / "box.png").is_file() and (tmp_path / "out" / "box.json").is_file()


BOX_XML = """<scene version="3.0.0">
    <default name="res" value="8"/>
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, -3, 1" target="0, 0, 1" up="0, 0, 1"/></transform>
        <sampler type="independent"/>
        <film type="hdrfilm">
            <integer name="width" value="$res"/><integer name="height" value="$res"/><rfilter type="box"/>
        </film>
    </sensor>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="3" y="3"/><rotate x="1" angle="90"/><translate y="1" z="1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="17, 12, 4"/></emitter>
    </shape>
</scene>
"""


@pytest.mark.skipif(not os.access(xml_check.MITSUBA_PYTHON, os.X_OK) or shutil.which("lscpu") is None,
                    reason="Mitsuba 3 is not installed at /tmp/mts (devtools/peers/xml_check.py says how)")
def test_mitsubas_half(tmp_path):
    """Mitsuba's subprocess on a tiny XML scene (a wall that is an area light, filling the upper pixels): a
    define passes through, the chunks give a mean and a variance of it, zero where a pixel sees only the
    light (exactly its radiance)."""
    scene = tmp_path / "wall.xml"
    scene.write_text(BOX_XML)
    out = xml_check.run_mitsuba(scene, 64, 4, {"res": "6"})
    assert out["mean"].shape == out["var"].shape == (6, 6, 3) and (out["spp"], out["chunks"]) == (64, 4)
    assert out["version"].startswith("3.") and out["variant"] == "llvm_ad_rgb"
    assert np.all(out["var"] >= 0) and np.all(out["var"][0] == 0) and np.allclose(out["mean"][0], [17, 12, 4])
    assert np.any(out["var"][-1] > 0)
