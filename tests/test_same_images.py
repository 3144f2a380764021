"""devtools/same_images.py's devices mode, which .ci/gpu runs to compare a GPU's render with PoCL's: the
same device at two lane widths is within the bound, and an image moved beyond it is reported."""
import json

import numpy as np
import pytest

from helpers import needs_a_cpu_device
from devtools import same_images

pytestmark = needs_a_cpu_device  # PoCL's render is one side of every comparison


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


def test_devices_against_a_saved_cpu_image(tmp_path):
    """--cpu-image (a GPU machine without PoCL): the saved array stands in for PoCL's render; the same array
    moved by 0.2 fails, and one of another size is refused."""
    assert same_images.main(["devices", str(tmp_path / "a"), "--device", "cpu", "--lanes", "1"]) == 0
    saved = tmp_path / "a" / "cpu.npy"
    assert same_images.main(["devices", str(tmp_path / "b"), "--device", "cpu", "--cpu-image", str(saved)]) == 0
    assert json.loads((tmp_path / "b" / "devices.json").read_text())["cpu"].startswith(str(saved))
    np.save(tmp_path / "brighter.npy", np.load(saved) + 0.2)
    assert same_images.main(["devices", str(tmp_path / "c"), "--device", "cpu",
                             "--cpu-image", str(tmp_path / "brighter.npy")]) == 1
    np.save(tmp_path / "small.npy", np.load(saved)[:8])
    with pytest.raises(SystemExit, match="shape"):
        same_images.main(["devices", str(tmp_path / "d"), "--device", "cpu", "--cpu-image", str(tmp_path / "small.npy")])
