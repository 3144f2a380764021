"""raytrace/tools/same_images.py's devices mode, which .ci/gpu runs to compare a GPU's render with PoCL's: the
same device at two lane widths is within the bound, and an image moved beyond it is reported."""
import json

import numpy as np

from raytrace.tools import same_images


def test_devices_within_the_bound(tmp_path):
    assert same_images.main(["devices", str(tmp_path), "--device", "cpu", "--lanes", "1"]) == 0
    result = json.loads((tmp_path / "devices.json").read_text())
    assert result["passed"] and result["figures"]["max"] <= result["bounds"]["max"]
    assert np.load(tmp_path / "cpu.npy").shape == (48, 48, 3)


def test_devices_beyond_the_bound_fail(tmp_path, monkeypatch):
    """A render 0.2 brighter everywhere (beyond the largest pixel bound, 2 (2/32 + 1e-4)) is reported."""
    real, calls = same_images.render, []

    def brighter_second(scene, **kwargs):  # the tool renders PoCL's image first, the other device's second
        image, stats = real(scene, **kwargs)
        calls.append(1)
        return image + (0.2 if len(calls) == 2 else 0.0), stats
    monkeypatch.setattr(same_images, "render", brighter_second)
    assert same_images.main(["devices", str(tmp_path), "--device", "cpu", "--lanes", "1"]) == 1
    assert not json.loads((tmp_path / "devices.json").read_text())["passed"]
