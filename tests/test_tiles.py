"""Renders of any size (raytrace/render.py, kernels/render.cl): launches in bands of rows through a device
buffer of one band, the same image whatever the band height, and the up-front refusal of a render whose
host memory cannot be had."""
import resource

import numpy as np
import pytest

from raytrace.render import render_progressive
from raytrace.renderer import device_render
from raytrace.renderer.device_render import OUTPUT_PLANES
from helpers import CORNELL, SESSION_KIND, run

SIZE = dict(width=97, height=61, progress=False)  # odd sizes: 97 columns leave one pixel in the last lane group at every width
ROW_BYTES = OUTPUT_PLANES * 4 * SIZE["width"]     # one row of the kernel's output, float32 planes


def test_many_bands_give_the_one_band_image_bit_for_bit(cornell, lanes):
    """A budget of 5 rows cuts 61 rows into 12 bands of 5 and a last one of 1. Every pixel's samples depend
    on its absolute position only, so any band height must give the same bits. It fails if a band writes or
    is copied at the wrong offset (index not relative to row0, planes spaced by the image's height rather
    than the band's, the short last band read with the full band's layout), if a band is launched twice or
    not at all, if a work-item's tile of pixels (1, 2 or 4 rows, kernels/tile.h) that reaches past its band stores
    the rows beyond it, or if the prefix sum for the error estimate misses bands (the variance would differ:
    12 random samples in passes of 8 and 4 take the first pass's half-sums as the prefix of 4 samples, then the
    prefix of 8)."""
    options = dict(spp=12, sampler="random", light_samples=4, lanes=lanes, **SIZE)
    image, variance, stats = render_progressive(cornell, **options)
    banded_image, banded_variance, banded = render_progressive(cornell, max_band_bytes=5 * ROW_BYTES, **options)
    assert stats.extra["band_rows"] == 61 and banded.extra["band_rows"] == 5 and banded.passes == 2
    np.testing.assert_array_equal(banded_image, image)
    np.testing.assert_array_equal(banded_variance, variance)
    assert banded.rays == stats.rays and banded.estimated_rmse == stats.estimated_rmse


def test_a_launch_holds_bounded_work_on_a_cpu_and_a_whole_pass_on_a_gpu(cornell):
    """512 x 128 pixels at 16 x 16 samples, in one pass of 139,264 work units a row (512 x 16 x 17 rays): on a CPU
    device a launch holds at most WORK_PER_LAUNCH = 2^23 of them, bands of 60 rows, so that each stays short; on
    a GPU the whole pass is one launch (work_per_launch: bands of 60 rows left most of an H100 idle). It fails if
    either kind of device gets the other's plan, or if the bound is not what the docstrings measured."""
    _, _, stats = render_progressive(cornell, width=512, height=128, spp=16, light_samples=16, progress=False)
    assert stats.passes == 1
    assert stats.extra["band_rows"] == {"cpu": 60, "gpu": 128}[SESSION_KIND]


@pytest.mark.parametrize("shape", [(16, 8), (8, 4), (3, 5)])
def test_work_groups_of_any_shape_give_the_same_image(cornell, lanes, monkeypatch, shape):
    """Work-groups of `shape` (a GPU's 16 x 8, and shapes that divide neither 97 columns nor bands of 5 rows)
    on the session's device give the image of the runtime's own choice, bit for bit, over bands of 5 rows.
    The launch's grid is rounded up to whole groups (renderer/device_render.py: launch_grid), so groups reach
    past the band and the image. It fails if the grid is rounded down (pixels never rendered), not rounded at
    all (OpenCL 1.2 refuses the launch), or if the kernel stores what lies past its band or the image's width
    (the next band's rows or the next row's pixels overwritten)."""
    options = dict(spp=4, light_samples=4, lanes=lanes, max_band_bytes=5 * ROW_BYTES, **SIZE)
    monkeypatch.setattr(device_render, "work_group_shape", lambda device, kernel, lanes: None)
    image, _, stats = render_progressive(cornell, **options)
    monkeypatch.setattr(device_render, "work_group_shape", lambda device, kernel, lanes: shape)
    shaped, _, shaped_stats = render_progressive(cornell, **options)
    assert shaped_stats.extra["work_group"] == shape and stats.extra["work_group"] is None
    assert shaped_stats.extra["band_rows"] == 5
    np.testing.assert_array_equal(shaped, image)


@pytest.mark.parametrize("budget,rows", [(ROW_BYTES - 1, 1), (ROW_BYTES, 1), (3 * ROW_BYTES + 5, 3),
                                         (10**9, 61)])
def test_device_buffer_within_the_budget(cornell, budget, rows):
    """The device output buffer is as many whole rows as the budget holds (never more bytes than the
    budget), one row when the budget is smaller than a row (a launch cannot do less), at most the image.
    It fails if the band height ignores the budget or rounds up, or the buffer is sized for the image."""
    _, _, stats = render_progressive(cornell, spp=1, light_samples=1, max_band_bytes=budget, **SIZE)
    assert stats.extra["band_rows"] == rows
    assert stats.extra["device_output_bytes"] == rows * ROW_BYTES <= max(budget, ROW_BYTES)


def test_render_that_cannot_fit_in_memory_is_refused(tmp_path):
    """Under a 4 GiB address-space limit (ulimit -v), a 16384 x 16384 render, about 12.5 GiB of sums and
    images, is refused with one line naming --width/--height and the size, exit status 2 and no file. The
    unknown --device would be reported by the first device work: the memory error comes before it. It fails
    if the estimate misses the limit (the render would start, then die of a MemoryError), if the check
    comes after device work, or if the refusal is a traceback or leaves a file."""
    limit = 4 << 30
    out = tmp_path / "big.png"
    r = run("render", CORNELL, "-o", out, "--width", 16384, "--height", 16384, "--device", "no-such-device",
            preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (limit, limit)))
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "command line: --width/--height = '16384x16384': needs about" in r.stderr and "GiB" in r.stderr
    assert list(tmp_path.iterdir()) == []
