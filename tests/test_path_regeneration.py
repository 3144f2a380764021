"""Path regeneration (kernels/render.cl's render_paths): in the path model a lane whose path ends starts its
pixel's next sample at once, while the packet's other lanes go on with theirs. Each lane still takes its own
samples, in the same order, with the same numbers (per-lane dimension counters, kernels/samplers.cl), so the
image, the error estimate's half sums and the ray counts equal, to the bit, those of a render that traces one
sample at a time in every lane, at every lane width: ONE_AT_A_TIME, a render kernel of this test's own that
replaces render.cl's (the renderer builds it from a kernels/ directory of its own, Features.kernels, as
benchmarks/baseline.py does) and calls path_tracing.cl's trace_path for each sample, with render.cl's tiles,
pixel keys, camera rays, sums and stores. Bit equality is the right tolerance: the two loops do the same float
operations on every lane's samples in the same order, and the closest hit of a lane's ray does not depend on
the other lanes' rays (a packet's traversal opens a superset of each lane's nodes and tests each primitive by
the same arithmetic). A reference that starts each lane at the next sample index fails every case (seen)."""
import dataclasses
import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

import raytrace
from raytrace.renderer.device import context_for, select_device
from raytrace.renderer.program import Features, kernel_dir, render_program
from helpers import ROOT, needs_a_cpu_device

pytestmark = needs_a_cpu_device

# The path model's pixel samples one at a time in every lane: render.cl's kernel, renamed, and in its place one
# whose loop is render_samples' with trace_path as the shading (group samples of each pixel at a step).
ONE_AT_A_TIME = """
#define render regenerating_render
#include "RENDER_CL"
#undef render

__kernel void render(SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const uint2 *pixel_samples,
                     __global const uint2 *light_samples, int sample0, int n_samples, int n_first, int row0,
                     int row1, __global float *out)
{
    const Scene scene = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    const Tile tile = work_item_tile(row0, n_samples);
    const vint active = (tile.x < params->width) & (tile.y < row1), all = (vint)(-1) != 0;
    if (!ANY(active))
        return;
    vuint key = pixel_key(AS_VUINT(tile.y * params->width + tile.x), params->seed);
    Sums sums = {0};
    for (int first = sample0; first < sample0 + n_samples; first += tile.group) {
        PixelSample ps = start_pixel_sample(key, first + tile.sample);
        vfloat tmax, weight; /* the box filter's weight: 1 */
        Ray ray = camera_ray(&scene, tile, &ps, pixel_samples, all, &tmax, &weight);
        Hit hit = closest_hit(&scene, ray, tmax);
        ShadingPoint sp = shading_point(&scene, ts, ray, hit);
        vec3 value = trace_path(&scene, ts, ray, hit, sp, light_samples, &ps, &sums.rays, 0);
        add_samples(&sums, value, all, ps.index, sample0 + n_first, n_first);
    }
    store_sums(&scene, tile, active, &sums, n_samples, n_first, row0, row1, out);
}
"""


@pytest.fixture(scope="session")
def one_at_a_time():
    """A kernels/ directory holding ONE_AT_A_TIME as its render.cl, which includes the checkout's render.cl
    (and through it every other kernel file) by its absolute path. Its name is the source's hash, so that
    PoCL's cache of built programs finds it again in the next session; written whole under a temporary name
    and renamed, so that two pytest workers may write it at once."""
    source = ONE_AT_A_TIME.replace("RENDER_CL", str(kernel_dir() / "render.cl"))
    digest = hashlib.sha256(source.encode()).hexdigest()[:16]
    directory = Path(tempfile.gettempdir()) / f"raytrace-one-at-a-time-{digest}"
    directory.mkdir(exist_ok=True)
    partial = directory / f"render.{os.getpid()}.tmp"
    partial.write_text(source)
    os.replace(partial, directory / "render.cl")
    return str(directory)


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
def test_regenerated_paths_give_the_same_bits(lanes, case, one_at_a_time):
    name, options = CASES[case]
    scene = raytrace.load_file(ROOT / "scenes" / name)
    options = dict(width=24, height=20, light_samples=1, progress=False, **options)
    features = Features.of(scene, lanes)
    image, stats = raytrace.render(scene, features=features, **options)
    one_by_one = dataclasses.replace(features, kernels=one_at_a_time)
    reference, reference_stats = raytrace.render(scene, features=one_by_one, **options)
    program, _ = render_program(context_for(select_device(None))[0], one_by_one)  # the one the render built
    assert "regenerating_render" in program.get_info(cl.program_info.KERNEL_NAMES).split(";")
    np.testing.assert_array_equal(np.asarray(image), np.asarray(reference))
    np.testing.assert_array_equal(image.variance, reference.variance)
    assert stats.rays == reference_stats.rays
    assert np.asarray(image).mean() > 0.01
