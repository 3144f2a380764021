"""benchmarks/against_reference.py: our render against another renderer's image (there, Mitsuba 3's).
Against our own render with the same options it finds no difference; against an image moved by a known
amount, exactly that amount; its side-by-side image is ours, the reference and 10x the difference."""
import json

import numpy as np

from helpers import ROOT
from raytrace import load_file, render
from raytrace.image_file import write_image_file
from benchmarks import against_reference

SCENE = ROOT / "scenes" / "cornell_direct.toml"
OPTIONS = ["--spp", "1", "--light-samples", "1"]


def test_against_itself_and_moved(tmp_path):
    ours, _ = render(load_file(SCENE), spp=1, light_samples=1, sampler="sobol", light_sampler="sobol")
    write_image_file(tmp_path / "same.exr", ours)
    against_reference.main([str(SCENE), str(tmp_path / "same.exr"), *OPTIONS, "--out", str(tmp_path / "a")])
    figures = json.loads((tmp_path / "a" / "against_reference.json").read_text())
    assert figures["rmse"] == 0 and figures["rmse_clamped"] == 0 and figures["max_abs_clamped"] == 0
    moved = np.clip(ours, 0, 1) * 0.5  # everything in [0, 1]: clamping changes nothing
    figures = against_reference.compare(np.clip(ours, 0, 1), moved)
    assert np.isclose(figures["rmse_clamped"], np.sqrt(np.mean((0.5 * np.clip(ours, 0, 1)) ** 2)))
    side = against_reference.side_by_side(ours, moved)
    assert side.shape == (ours.shape[0], 3 * ours.shape[1], 3)
    np.testing.assert_allclose(side[:, 2 * ours.shape[1]:], 10 * 0.5 * np.clip(ours, 0, 1), rtol=1e-6)
    assert (tmp_path / "a" / "side.png").stat().st_size > 1000 and (tmp_path / "a" / "ours.exr").exists()
