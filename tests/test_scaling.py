"""bench --scaling (raytrace/commands/scaling.py): the paired growth's turns, on real renders."""
import statistics

import pytest

from raytrace.scene import load_file
from raytrace.commands import bench, scaling
from helpers import CORNELL


def test_paired_growth_alternates_and_takes_the_median(monkeypatch):
    """paired_growth renders one of each mesh a turn (after one untimed render of each), the smaller first in
    even turns and the larger first in odd ones, and returns the median over turns of the larger's per-ray
    seconds over the smaller's, here recomputed from the renders it made (recorded as they happen). It fails
    if the order does not alternate (the machine's drift within a turn would then fall on one side only), if
    a ratio is inverted, or if the mean is taken instead of the median."""
    low, high = (scaling.mesh_room(load_file(CORNELL), n) for n in (100, 1000))
    seen, real = [], bench.render

    def recording(scene, **kwargs):
        result = real(scene, **kwargs)
        seen.append((scene, result[1]))
        return result

    monkeypatch.setattr(bench, "render", recording)
    result = scaling.paired_growth(low, high, turns=5)
    assert [scene is high for scene, _ in seen] == [False, True] + [False, True, True, False] * 2 + [False, True]
    per_ray = lambda stats: stats.render_seconds / stats.rays  # noqa: E731
    turns = [dict((id(scene), per_ray(stats)) for scene, stats in seen[k:k + 2]) for k in range(2, len(seen), 2)]
    # equal up to rounding: in_turns divides seconds, then scales by the ray counts
    assert result == pytest.approx(statistics.median(t[id(high)] / t[id(low)] for t in turns), rel=1e-12)
