"""converge --peer (raytrace/commands/converge_peer.py): another renderer's patterns in the same study, against
the same reference, here a stand-in peer script that writes a known image; and the race table's
interpolation of the time to reach an error."""
import io
import sys

import numpy as np
import pytest

from helpers import CORNELL, FAKE_PEER
from raytrace.errors import InputError
from raytrace.commands.converge import clamped_rmse, converge, rmse
from raytrace.commands.converge_peer import race, race_finals, time_to_reach


def test_peer_rows_beside_ours(tmp_path):
    script = tmp_path / "peer.py"
    script.write_text(FAKE_PEER)
    text = io.StringIO()
    result = converge(CORNELL, ["random"], 16, tmp_path / "out", width=8, height=8, light_samples=1,
                      reference_spp=64, out=text, clamp=True, peer_samplers=["independent", "stratified"],
                      peer=f"{sys.executable} {script} {{sampler}} {{spp}} {{out}}")
    peer = [r for r in result["rows"] if r["sampler"].startswith("peer:")]
    assert [(r["sampler"], r["spp"], r["seconds"]) for r in peer] == [
        (f"peer:{s}", n, 0.01 * n) for s in ("independent", "stratified") for n in (4, 16)]
    assert all(r["rmse"] > 0 for r in peer) and peer[0]["rmse"] > peer[1]["rmse"]  # less noise with more spp
    # the stand-in takes at least 4 samples, as Mitsuba's ldsampler: its 1-sample render counts as 4, once
    assert [t["rmse"] for t in result["race"]] == [0.05, 0.02, 0.01, 0.005, 0.002, 0.001]
    assert "peer:stratified" in (tmp_path / "out" / "converge.csv").read_text()
    assert "its own estimated RMSE" in text.getvalue() and "(of linear values)" in text.getvalue()


def test_clamped_error_is_bounded_by_the_linear_one():
    """Why converge --clamp may draw the renders' estimates of linear error beside clamped errors: clamping to
    [0, 1] moves no two values further apart, so the clamped RMSE never exceeds the linear one; images with
    values above 1 (direct lighting's) and below 0 make it strictly smaller."""
    rng = np.random.default_rng(4)
    a, b = rng.uniform(-0.5, 3.0, (2, 16, 16, 3)).astype(np.float32)
    assert clamped_rmse(a, b) < rmse(a, b)
    c = np.clip(a, 0.0, 1.0)
    assert np.isclose(clamped_rmse(c, np.clip(b, 0.0, 1.0)), rmse(c, np.clip(b, 0.0, 1.0)))


@pytest.mark.parametrize("peer, message", [
    ("echo {sampler} {spp}", "needs the placeholder {out}"),
    ("echo {sampler} {spp} {out}", "no JSON object with a positive median_s"),
])
def test_bad_peers_are_one_line(tmp_path, peer, message):
    with pytest.raises(InputError, match="--peer") as e:
        converge(CORNELL, ["random"], 4, tmp_path / "out", width=8, height=8, light_samples=1, reference_spp=16,
                 out=io.StringIO(), peer=peer, peer_samplers=["independent"])
    assert message in str(e.value) and "\n" not in str(e.value)


def test_time_to_reach_interpolates_log_log():
    """Errors 0.04 at 1 s and 0.01 at 4 s: the slope is -1, so 0.02 is reached at 2 s; 0.04 at once; 0.005
    never; of two patterns the faster counts."""
    rows = [{"sampler": "a", "seconds": 1.0, "rmse": 0.04}, {"sampler": "a", "seconds": 4.0, "rmse": 0.01},
            {"sampler": "b", "seconds": 3.0, "rmse": 0.02}]
    assert np.isclose(time_to_reach(rows, 0.02), 2.0)
    assert time_to_reach(rows, 0.04) == 1.0 and time_to_reach(rows, 0.005) is None
    table = race(rows + [{"sampler": "peer:x", "seconds": 8.0, "rmse": 0.02}], [0.02])
    assert np.isclose(table[0]["ratio"], 2.0 / 8.0)


def test_race_against_each_peer_patterns_last_render():
    """race_finals: for each peer pattern its render with the most samples, and our time to its RMSE (the
    issue's "time to reach Mitsuba multijitter's 256-spp RMSE"); None where we never reach it."""
    rows = [{"sampler": "a", "seconds": 1.0, "rmse": 0.04, "spp": 1}, {"sampler": "a", "seconds": 4.0, "rmse": 0.01,
                                                                      "spp": 4},
            {"sampler": "peer:x", "seconds": 1.0, "rmse": 0.03, "spp": 4},
            {"sampler": "peer:x", "seconds": 8.0, "rmse": 0.02, "spp": 16},
            {"sampler": "peer:y", "seconds": 9.0, "rmse": 0.001, "spp": 16}]
    x, y = race_finals(rows)
    assert (x["peer"], x["spp"], x["rmse"], x["peer_s"]) == ("peer:x", 16, 0.02, 8.0)
    assert np.isclose(x["ours_s"], 2.0) and np.isclose(x["ratio"], 0.25)
    assert y["ours_s"] is None and y["ratio"] is None
