"""Denoising (raytrace/denoise.py): Intel Open Image Denoise, run for real through pyoidn (the `denoise` extra,
in the `test` extra too), on renders of the path model's Cornell box; and the one line a missing pyoidn gives.

What a real run must show: a render at 4 spp, denoised with its albedo and shading-normal AOVs, is closer to
a 1024-spp reference than the noisy render, by DENOISED_GAIN. The RMSE is converge --clamp's, of the images
clamped to [0, 1] (what a display shows, and the measure of the converge records of this scene): unclamped,
the light's edge pixels (radiance 18, three orders above the walls') outweigh the whole room, and a
denoiser that moves one of them by a fraction of the light's radiance moves the figure more than all the noise
it removed (measured: 64 x 64 at 16 spp, OIDN without AOVs halves the clamped RMSE and raises the linear one
from 0.036 to 0.080, every one of its eight largest errors on the light's edge). benchmarks/denoise.py gives
both, at the scenes' own size, for the record.

The gain: at 4 spp the noisy image's clamped RMSE is 0.041 (measured at 64 x 64), the reference's own about
16 times smaller (1024 / 4 samples: error falls as one over the root of the samples), so a denoiser's gain
can be read up to about 16; OIDN's measured 2.8 here (0.0146; 3.2 without the AOVs at this small size, where
the AOVs' own edges are a large share of the pixels; at the scene's 256 x 256, 4.7: benchmarks/denoise.py).
DENOISED_GAIN = 2 is below what was measured by a margin no change of OIDN's weights for the same inputs is
likely to eat (the render and OIDN are deterministic: the same figure every run on a machine), and far above
a filter that does nothing (1) or only blurs (a 3 x 3 box filter over the noisy image measured 0.55: worse).

Mutations tried, each failing a test here: the denoiser skipped (its output the noisy beauty: the gain, the
AOVs), OIDN's LDR mode (hdr=False: the light's radiance), the albedo and normal not passed to the filter (the
AOVs), require() returning instead of raising (the missing extra), the noisy layer left out of the command
line's EXR, both the input's and the output's NaN/Inf cleaning removed (the output's finiteness; either alone
is covered by the other, by design).
"""
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
from helpers import ROOT
from raytrace.commands import child_env
from raytrace.commands.converge import REFERENCE_SEED_OFFSET, clamped_rmse
from raytrace.denoise import AUX, NOISY, denoise

CORNELL_BOX = ROOT / "scenes" / "cornell_box.toml"
SIZE = dict(width=64, height=64, progress=False)
REFERENCE_SPP = 1024
DENOISED_GAIN = 2.0
MISSING = ('raytrace: error: environment: render --denoise: needs the denoise extra (pyoidn missing): pip install '
           '"raytrace[denoise]", or -e ".[denoise]" in a checkout')


@pytest.fixture(scope="module")
def scene():
    return raytrace.load_file(CORNELL_BOX)


@pytest.fixture(scope="module")
def reference(scene):
    image, _ = raytrace.render(scene, spp=REFERENCE_SPP, sampler="sobol", light_sampler="sobol",
                               seed=REFERENCE_SEED_OFFSET, **SIZE)
    return np.asarray(image)


@pytest.fixture(scope="module")
def noisy(scene):
    image, _ = raytrace.render(scene, spp=4, aov=[name for name, _ in AUX.values()], **SIZE)
    return image


def test_a_denoised_render_is_closer_to_the_reference(noisy, reference):
    denoised = denoise(noisy)
    before, after = clamped_rmse(noisy, reference), clamped_rmse(denoised, reference)
    assert after * DENOISED_GAIN < before, (before, after)


def test_the_radiance_is_kept_beyond_one(noisy, reference):
    """HDR: the light's pixels (radiance about 18) keep their level, as OIDN's LDR mode, which takes [0, 1],
    would not (it clips them to 1). Their mean within 10% of the reference's: the light's interior is uniform
    and its edge pixels few, so the noisy render's mean there is measured within 0.06%, the denoised one's
    within 0.3%."""
    light = reference.max(axis=-1) > 10.0
    ratio = denoise(noisy)[light].mean() / reference[light].mean()
    assert abs(ratio - 1) < 0.1, ratio


def test_the_aovs_are_used(noisy):
    """The albedo and normal reach OIDN: its image with them differs from its image of the beauty alone."""
    assert not np.array_equal(denoise(noisy), denoise(np.asarray(noisy)))


def test_render_denoises_when_asked(scene, noisy):
    """render(denoise=True) is the render then denoise(): the same image, the AOVs it asked for on its own,
    the noisy beauty kept, and the metadata saying how."""
    image, _ = raytrace.render(scene, spp=4, denoise=True, **SIZE)
    assert np.array_equal(image.aovs[NOISY], noisy)
    assert np.array_equal(image, denoise(noisy))
    assert {name for name, _ in AUX.values()} <= set(image.aovs)
    assert image.metadata["denoised"].startswith("Intel Open Image Denoise 2.")


def test_the_output_is_finite_and_non_negative():
    """NaN, Inf and negative values in (a kernel bug's) input never reach the output."""
    beauty = np.full((16, 16, 3), 0.5, np.float32)
    beauty[3, 4] = [np.nan, np.inf, -1.0]
    albedo = np.full_like(beauty, 2.0)
    albedo[5, 5] = np.nan
    out = denoise(beauty, albedo, np.full_like(beauty, -3.0))
    assert out.shape == beauty.shape and out.dtype == np.float32
    assert np.isfinite(out).all() and (out >= 0).all()


@pytest.mark.parametrize("arguments, key", [
    ((np.zeros((4, 4, 2)),), "beauty.shape"),
    ((np.zeros((4, 4, 3)), np.zeros((4, 5, 3))), "albedo.shape"),
    ((np.zeros((4, 4, 3)), None, np.zeros((4, 4, 3))), "normal"),
])
def test_bad_arrays_are_one_line(arguments, key):
    with pytest.raises(raytrace.InputError, match=rf"^denoise\(\): {key}"):
        denoise(*arguments)


def missing_pyoidn(*argv, timeout=120):
    """`python -m raytrace ARGV` in a process where `import pyoidn` fails, as where the extra is not installed."""
    code = ("import sys; sys.modules['pyoidn'] = None\n"
            "from raytrace.cli import main\nsys.exit(main(sys.argv[1:]))")
    return subprocess.run([sys.executable, "-c", code, *map(str, argv)], capture_output=True, text=True,
                          env=child_env(), timeout=timeout)


def test_a_missing_extra_is_one_line_before_any_work(tmp_path):
    """Without pyoidn, `render --denoise` names the extra in one line, exit status 2, and writes nothing;
    before any work: the render asked (16384 x 16384 at 65536 spp) would take days, or be refused for its
    memory in another line."""
    out = tmp_path / "out.exr"
    r = missing_pyoidn("render", CORNELL_BOX, "--denoise", "--width", 16384, "--height", 16384, "--spp", 65536,
                       "-o", out)
    assert (r.returncode, r.stderr) == (2, MISSING + "\n")
    assert list(tmp_path.iterdir()) == []


def test_the_exr_keeps_the_noisy_beauty_and_the_aovs(tmp_path):
    """render --denoise -o x.exr: R, G, B the denoised image, the noisy one and the AOVs beside it."""
    out = tmp_path / "out.exr"
    r = subprocess.run([sys.executable, "-m", "raytrace", "render", str(CORNELL_BOX), "--denoise", "--width", "32",
                        "--height", "32", "--spp", "4", "-o", str(out)], capture_output=True, text=True,
                       env=child_env())
    assert r.returncode == 0, r.stderr
    buf = oiio.ImageBuf(str(out))
    names = list(buf.spec().channelnames)
    assert names[:3] == ["R", "G", "B"]
    assert {f"{NOISY}.R", f"{NOISY}.G", f"{NOISY}.B"} <= set(names)
    assert buf.spec().getattribute("raytrace:denoised").startswith("Intel Open Image Denoise")
    pixels = buf.get_pixels(oiio.FLOAT)
    beauty, kept = pixels[..., :3], pixels[..., [names.index(f"{NOISY}.{c}") for c in "RGB"]]
    albedo, normal = (pixels[..., [names.index(f"{name}.{c}") for c in components]]
                      for name, components in (("albedo", "RGB"), ("normal", "XYZ")))
    assert np.array_equal(denoise(kept, albedo, normal), beauty)


def test_a_denoised_image_is_not_denoised_again(noisy):
    """The denoised Image's metadata keeps the noisy image's estimated RMSE as noisy_estimated_rmse (the
    denoised image has no estimate of its own), and denoise() refuses, in one line, an Image denoised already
    (its AOV "noisy", the render's noisy beauty, would become the once-denoised image) or one with an AOV named
    "noisy" of its own (overwritten). Mutations: estimated_rmse kept as it was; either refusal left out: each
    fails here."""
    denoised = denoise(noisy)
    assert "estimated_rmse" not in denoised.metadata
    assert denoised.metadata["noisy_estimated_rmse"] == noisy.metadata["estimated_rmse"] > 0
    with pytest.raises(raytrace.InputError, match=r"^denoise\(\): beauty: is denoised already") as e:
        denoise(denoised)
    named = raytrace.Image.of(np.asarray(noisy), aovs={**noisy.aovs, NOISY: np.asarray(noisy)})
    with pytest.raises(raytrace.InputError, match=rf"^denoise\(\): beauty: has an AOV named '{NOISY}'") as f:
        denoise(named)
    assert "\n" not in str(e.value) + str(f.value)
