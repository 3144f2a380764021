"""A work-item's share of a launch (kernels/tile.h): which pixels and which of their samples its lanes hold,
against the host's mirror (raytrace/structs.py's samples_at_once and tile_shape), by which the host sizes its
launch grid."""
import numpy as np
import pyopencl as cl
import pytest

from raytrace import structs
from raytrace.renderer.program import build
from helpers import run_int_kernel, values_kernel

TILE = """
#include "tile.h"
/* Every lane's pixel (x, y), sample and group, four ints per lane, work-items in row-major order. */
__kernel void tile(int row0, int n_samples, __global int *out)
{
    Tile t = work_item_tile(row0, n_samples);
    int x[LANES], y[LANES], s[LANES];
    VSTORE(t.x, x);
    VSTORE(t.y, y);
    VSTORE(t.sample, s);
    int item = (int)(get_global_id(1) * get_global_size(0) + get_global_id(0));
    for (int k = 0; k < LANES; ++k) {
        __global int *o = out + 4 * (item * LANES + k);
        o[0] = x[k], o[1] = y[k], o[2] = s[k], o[3] = t.group;
    }
}
"""
COUNTS = range(0, 41)


@pytest.mark.parametrize("lanes", structs.LANE_WIDTHS)
def test_samples_at_once_and_tile_rows_match_device(cl_env, lanes):
    """The kernel's group and tile rows for every sample count from 0 to 40 against the host's; the group is
    the largest power of two that divides the count, at most LANES (1 for a count of 0, which no launch has)."""
    expressions = [f"samples_at_once({n})" for n in COUNTS] + [f"tile_rows(LANES / samples_at_once({n}))"
                                                               for n in COUNTS]
    values = run_int_kernel(cl_env, f'#include "tile.h"\n{values_kernel(expressions)}', len(expressions),
                            [f"-DLANES={lanes}"])
    groups, rows = values[:len(COUNTS)], values[len(COUNTS):]
    assert groups == [structs.samples_at_once(lanes, n) for n in COUNTS]
    assert rows == [structs.tile_shape(lanes, n)[1] for n in COUNTS]
    for n, group in zip(COUNTS[1:], groups[1:]):
        assert n % group == 0 and group <= lanes and (n // group % 2 == 1 or group == lanes)


@pytest.mark.parametrize("lanes", structs.LANE_WIDTHS)
@pytest.mark.parametrize("n_samples", [1, 2, 3, 4, 6, 8, 12, 16, 32])
def test_every_pixel_sample_of_a_band_has_one_lane(cl_env, lanes, n_samples):
    """A launch of the host's grid (tile_shape) over a 10 x 7 band from row 5 gives every pixel of the band
    each sample 0..group-1 in exactly one lane (the kernel loop adds group to reach every sample of the launch),
    lanes past the band's edges aside; a tile's pixels are neighbours (4 x 4 at most) and as nearly square
    as their count allows. It fails if the host's grid and the kernel's tiles disagree (pixels missed or
    rendered twice), or if a pixel's samples are not all in one work-item."""
    width, height, row0 = 10, 7, 5
    columns, rows = structs.tile_shape(lanes, n_samples)
    group = structs.samples_at_once(lanes, n_samples)
    assert columns * rows * group == lanes and columns in (rows, 2 * rows)
    grid = (-(-width // columns), -(-height // rows))
    context, queue = cl_env
    program, _ = build(context, f'#include "types.h"\n{TILE}', [f"-DLANES={lanes}"])
    out = np.zeros(grid[0] * grid[1] * lanes * 4, np.int32)
    buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "tile")(queue, grid, None, np.int32(row0), np.int32(n_samples), buf)
    cl.enqueue_copy(queue, out, buf)
    lane = out.reshape(grid[1], grid[0], lanes, 4)
    assert (lane[..., 3] == group).all()
    x, y, s = lane[..., 0], lane[..., 1], lane[..., 2]
    inside = (x < width) & (y < row0 + height)
    seen = np.zeros((height, width, group), int)
    np.add.at(seen, (y[inside] - row0, x[inside], s[inside]), 1)
    assert (seen == 1).all()
    # each work-item's lanes: the pixels of one columns x rows block
    j, i = np.mgrid[:grid[1], :grid[0]]
    assert (x // columns == i[..., None]).all() and ((y - row0) // rows == j[..., None]).all()
