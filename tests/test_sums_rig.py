"""`python -m benchmarks.sums` (benchmarks/sums.py): a scene rendered with its sums on the device and on the
host, in turns, in one process. Its renders must really take both ways (the stats say where the sums added
up), the turns alternate, and bad input is one line before any measuring."""
import json

from helpers import CORNELL, run
from benchmarks import sums

TINY = ["--width", 16, "--height", 16, "--spp", 4, "--light-samples", 1]


def test_both_ways_in_alternating_turns(monkeypatch):
    """Each turn renders both ways, every other turn host first; the rows' medians are of those renders."""
    ways = []
    real = sums.render

    def spy(scene, **kwargs):
        image, stats = real(scene, **kwargs)
        ways.append((kwargs["accumulate"], stats.extra["sums"]))
        return image, stats

    monkeypatch.setattr(sums, "render", spy)
    [row] = sums.sums_both_ways([CORNELL], repeat=3, width=16, height=16, spp=4, light_samples=1,
                                device="cpu")
    assert [w for w, _ in ways] == ["device", "host", "device", "host", "host", "device", "device", "host"]
    assert all(asked == used for asked, used in ways)
    assert row["repeat"] == 3 and row["paired_wall_ratio"] > 0
    assert row["device_wall_seconds"] >= row["device_kernel_seconds"] > 0


def test_the_command_writes_its_rows(tmp_path):
    out = tmp_path / "sums.json"
    result = run(CORNELL, *TINY, "--repeat", 1, "--device", "cpu", "--json", out, module="benchmarks.sums")
    assert result.returncode == 0, result.stderr
    [row] = json.loads(out.read_text())["rows"]
    assert row["scene"] == CORNELL and "x" in result.stdout


def test_bad_input_is_one_line():
    result = run(CORNELL, "--repeat", 0, module="benchmarks.sums")
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0
    assert "--repeat = 0" in result.stderr
