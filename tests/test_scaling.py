"""bench --scaling (raytrace/tools/scaling.py): the paired growth's turns, on real renders."""
import statistics

from raytrace.scene import load_scene
from raytrace.tools import scaling
from helpers import CORNELL


def test_paired_growth_alternates_and_takes_the_median(monkeypatch):
    """paired_growth renders one of each mesh a turn, the smaller first in even turns and the larger first in
    odd ones, and returns the median over turns of the larger's per-ray seconds over the smaller's, here
    recomputed from the renders it made (recorded as they happen). It fails if the order does not alternate
    (the machine's drift within a turn would then fall on one side only), if a ratio is inverted, or if the
    mean is taken instead of the median."""
    low, high = (scaling.mesh_room(load_scene(CORNELL), n) for n in (100, 1000))
    seen, real = [], scaling.per_ray_seconds

    def recording(scene, options):
        seen.append((scene, real(scene, options)))
        return seen[-1][1]

    monkeypatch.setattr(scaling, "per_ray_seconds", recording)
    result = scaling.paired_growth(low, high, turns=5)
    assert [scene is high for scene, _ in seen] == [False, True, True, False] * 2 + [False, True]
    turns = [dict((id(scene), s) for scene, s in seen[k:k + 2]) for k in range(0, len(seen), 2)]
    assert result == statistics.median(t[id(high)] / t[id(low)] for t in turns)
