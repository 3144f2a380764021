"""Path regeneration (kernels/render.cl's render_paths): in the path model a lane whose path ends starts its
pixel's next sample at once, while the packet's other lanes go on with theirs. Each lane still takes its own
samples, in the same order, with the same numbers (per-lane dimension counters, kernels/samplers.cl), so the
image, the error estimate's half sums and the ray counts equal, to the bit, those of the build that traces
one sample at a time in every lane (-DPATH_REGENERATION=0, trace_path per sample), at every lane width. Bit
equality is the right tolerance: the two loops do the same float operations on every lane's samples in the
same order, and the closest hit of a lane's ray does not depend on the other lanes' rays (a packet's
traversal opens a superset of each lane's nodes and tests each primitive by the same arithmetic)."""
import dataclasses

import numpy as np
import pytest

import raytrace
from raytrace.renderer.program import Features
from helpers import ROOT, needs_a_cpu_device

pytestmark = needs_a_cpu_device


@dataclasses.dataclass(frozen=True)
class OneSampleAtATime(Features):
    """The renderer's build for a scene, with the path model's lanes taking one sample per step."""

    def options(self):
        return [*super().options(), "-DPATH_REGENERATION=0"]


# (scene, render options): max_depth 8 with Russian roulette, unbounded depth, the BSDFs and the
# environment map; passes whose lanes hold 4, 8 and 16 samples of one pixel (tile.h's group 16), and 3
# samples of each of 4 pixels (12 spp: group 4) with table samplers.
CASES = {
    "cornell_box": ("cornell_box.toml", dict(spp=64)),
    "cornell_path_unbounded": ("cornell_path.toml", dict(spp=128, max_depth=-1)),
    "materials": ("materials.toml", dict(spp=256, texture_filter="bilinear")),
    "tables_group4": ("cornell_box.toml", dict(spp=12, sampler="random", light_sampler="halton")),
}


@pytest.mark.parametrize("case", CASES)
def test_regenerated_paths_give_the_same_bits(lanes, case):
    name, options = CASES[case]
    scene = raytrace.load_file(ROOT / "scenes" / name)
    options = dict(width=24, height=20, light_samples=1, progress=False, **options)
    features = Features.of(scene, lanes)
    image, stats = raytrace.render(scene, features=features, **options)
    one_at_a_time = OneSampleAtATime(**vars(features))
    reference, reference_stats = raytrace.render(scene, features=one_at_a_time, **options)
    assert "-DPATH_REGENERATION=0" in reference_stats.build_options
    np.testing.assert_array_equal(np.asarray(image), np.asarray(reference))
    np.testing.assert_array_equal(image.variance, reference.variance)
    assert stats.rays == reference_stats.rays
    assert np.asarray(image).mean() > 0.01
