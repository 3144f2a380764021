"""benchmarks/record.py: a real, tiny bench run of two scenes beside a stand-in peer, turned into a measurement
record by the rig's command line. The record is one the performance page takes (helpers.py's check, as test_docs.py runs it), and its
figures are the bench file's own values, scene by scene."""
import json
import sys

import pytest

from helpers import CORNELL, FAKE_PEER, ROOT, assert_record_well_formed, run

TINY = ["--width", 16, "--height", 16, "--spp", 1, "--light-samples", 1, "--repeat", 1]
COMMAND = "python -m raytrace bench scenes/cornell.toml scenes/grid_floor.toml --json bench.json"


@pytest.fixture(scope="module")
def bench_json(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "bench.json"
    peer = "echo '{\"mrays_per_s\": 0.5}'"
    r = run("bench", CORNELL, ROOT / "scenes" / "grid_floor.toml", *TINY, "--json", out, "--peer", peer, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return out


def test_a_record_of_a_bench_run(bench_json, tmp_path):
    r = run(bench_json, "--command", COMMAND, "--out", tmp_path, module="benchmarks.record", cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (path,) = tmp_path.iterdir()
    assert r.stdout.strip() == str(path) and path.name.endswith("-bench.json")
    assert_record_well_formed(path)
    record, bench = json.loads(path.read_text()), json.loads(bench_json.read_text())
    assert record["command"] == COMMAND and bench["machine"]["cpu"] in record["machine"]
    figures = {f["what"]: f["value"] for f in record["figures"]}
    first, second = bench["scenes"]
    assert figures["cornell nominal rate"] == round(first["nominal_mrays_per_s"], 1)
    assert figures["grid_floor x the first scene's time"] == round(second["time_ratio_to_first"], 3)
    assert figures["grid_floor rate against the scalar kernel"] == round(second["ratio_to_scalar"], 2)
    assert figures["cornell against the peer, best against best"] == round(bench["ratio_to_peer"], 2)
    assert "cornell x the first scene's time" not in figures  # the first scene is the unit


@pytest.mark.parametrize("case", ["not json", "no command"])
def test_bad_input_is_one_line(bench_json, tmp_path, case):
    source = tmp_path / "x.json"
    source.write_text("{" if case == "not json" else bench_json.read_text())
    command = COMMAND if case == "not json" else "bench it"
    r = run(source, "--command", command, "--out", tmp_path, module="benchmarks.record", cwd=ROOT)
    assert r.returncode == 2 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1
    named = f"{source}: file = '{source}'" if case == "not json" else "command line: --command = 'bench it'"
    assert r.stderr.startswith(f"benchmarks.record: error: {named}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json"]


def test_a_record_of_a_converge_run(tmp_path):
    """converge --json (a tiny study beside a stand-in peer) turned into a record: each pattern's last render
    and the race against each of the peer's patterns, the values converge computed."""
    script = tmp_path / "peer.py"
    script.write_text(FAKE_PEER)
    out = tmp_path / "converge.json"
    r = run("converge", CORNELL, "--samplers", "random,sobol", "--max-spp", 4, "--width", 8, "--height", 8,
            "--light-samples", 1, "--reference-spp", 16, "--out", tmp_path / "study", "--json", out,
            "--peer", f"{sys.executable} {script} {{sampler}} {{spp}} {{out}}", "--peer-samplers", "independent",
            cwd=ROOT)
    assert r.returncode == 0, r.stderr
    study = json.loads(out.read_text())
    assert study["machine"]["cpu_count"] and [t["peer"] for t in study["race_finals"]] == ["peer:independent"]
    records = tmp_path / "records"
    records.mkdir()
    command = "python -m raytrace converge scenes/cornell.toml --samplers random,sobol --json converge.json"
    r = run(out, "--command", command, "--out", records, module="benchmarks.record", cwd=ROOT)
    assert r.returncode == 0, r.stderr
    (path,) = records.iterdir()
    assert path.name.endswith("-converge.json")
    assert_record_well_formed(path)
    figures = {f["what"]: f["value"] for f in json.loads(path.read_text())["figures"]}
    last = [row for row in study["rows"] if row["sampler"] == "sobol"][-1]
    assert figures["sobol RMSE at 4 spp"] == float(f"{last['rmse']:.4g}")
    for level in study["race"]:
        assert figures.get(f"our time to RMSE {level['rmse']:g}, against the peer's") == \
            (None if level["ratio"] is None else round(level["ratio"], 3))
    final = study["race_finals"][0]
    if final["ratio"] is not None:
        assert figures[f"our time to peer:independent's RMSE at {final['spp']} spp, against its time"] == \
            round(final["ratio"], 3)


def test_converge_figures_of_a_race_both_sides_ran():
    """A converge result made by hand, whose race the tiny study above cannot give (its levels go
    unreached): a level both sides reached becomes a row, one neither reached none, and the race against
    the peer's last render a row of its own; each pattern's RMSE at a quarter of its most samples and at
    its most (4 significant digits), and that render's seconds."""
    from benchmarks.record import converge_figures
    rows = [{"sampler": "sobol", "spp": spp, "seconds": 0.01 * spp, "rmse": 0.1 / spp ** 0.5} for spp in (1, 4, 16)]
    results = {"rows": rows,
               "race": [{"rmse": 0.05, "ratio": 0.81234}, {"rmse": 0.001, "ratio": None}],
               "race_finals": [{"peer": "peer:independent", "spp": 16, "ratio": 0.39012},
                               {"peer": "peer:multijitter", "spp": 16, "ratio": None}]}
    assert converge_figures(results) == [
        {"what": "sobol RMSE at 4 spp", "value": 0.05, "unit": "RMSE"},
        {"what": "sobol RMSE at 16 spp", "value": 0.025, "unit": "RMSE"},
        {"what": "sobol seconds at 16 spp", "value": 0.16, "unit": "s"},
        {"what": "our time to RMSE 0.05, against the peer's", "value": 0.812, "unit": "x"},
        {"what": "our time to peer:independent's RMSE at 16 spp, against its time", "value": 0.39, "unit": "x"}]
