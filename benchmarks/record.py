"""A measurement record from a `bench --json` or `converge --json` file: `python -m benchmarks.record JSON
--command "..."`.

The record (benchmarks/results/DATE-MACHINE-bench.json or -converge.json, the format docs/performance.md
describes) keeps the machine, the date, this checkout's commit, the command that made the file and its
headline figures. For bench: per scene the nominal rate, the time against the first scene (of the fastest
renders and paired) and the rate against the scalar kernel; with a peer, the first scene against it. For
converge: each pattern's RMSE at a quarter of its most samples and at its most, that last render's time,
and with a peer our time to reach each of the peer's patterns' last RMSE against its time. The performance
page shows the newest record of each command on each machine kind.
"""
import argparse
import datetime
import json
import re
import subprocess
import sys
from pathlib import Path

from raytrace.errors import InputError

RESULTS = Path(__file__).resolve().parent / "results"


def machine_kind(info):
    """A machine's kind from bench's machine facts: its CPU and cores, how the kernel runs on it."""
    return f"{info['cpu']} ({info['cpu_level']}, {info['cpu_count']} cores, {info['target']})"


def figures(results):
    """The headline figures of bench's results, as the record's rows."""
    rows = []
    for k, scene in enumerate(results["scenes"]):
        name = Path(scene["scene"]).stem
        rows.append({"what": f"{name} nominal rate", "value": round(scene["nominal_mrays_per_s"], 1),
                     "unit": "Mrays/s"})
        if k:
            rows += [{"what": f"{name} x the first scene's time", "value": round(scene["time_ratio_to_first"], 3),
                      "unit": "x"},
                     {"what": f"{name} x the first scene's time, paired",
                      "value": round(scene["paired_time_ratio_to_first"], 3), "unit": "x"}]
        rows.append({"what": f"{name} rate against the scalar kernel", "value": round(scene["ratio_to_scalar"], 2),
                     "unit": "x"})
    if "ratio_to_peer" in results:
        first = Path(results["scenes"][0]["scene"]).stem
        rows.append({"what": f"{first} against the peer, best against best", "value":
                     round(results["ratio_to_peer"], 2), "unit": "x"})
    return rows


def converge_figures(results):
    """The headline figures of converge's results: each pattern's RMSE at a quarter of its most samples and at
    its most, that last render's time, the race at each RMSE both sides reached (our best pattern's time against
    the peer's best's), and the race against the peer's patterns' last renders."""
    rows = []
    for name in dict.fromkeys(r["sampler"] for r in results["rows"]):
        renders = {r["spp"]: r for r in results["rows"] if r["sampler"] == name}
        last = renders[max(renders)]
        for spp in sorted({max(renders) // 4, max(renders)} & set(renders)):
            rows.append({"what": f"{name} RMSE at {spp} spp", "value": float(f"{renders[spp]['rmse']:.4g}"),
                         "unit": "RMSE"})
        rows.append({"what": f"{name} seconds at {last['spp']} spp", "value": round(last["seconds"], 3), "unit": "s"})
    for t in results.get("race") or []:
        if t["ratio"] is not None:
            rows.append({"what": f"our time to RMSE {t['rmse']:g}, against the peer's", "value": round(t["ratio"], 3),
                         "unit": "x"})
    for t in results.get("race_finals") or []:
        if t["ratio"] is not None:
            rows.append({"what": f"our time to {t['peer']}'s RMSE at {t['spp']} spp, against its time",
                         "value": round(t["ratio"], 3), "unit": "x"})
    return rows


def commit():
    done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parent)
    return done.stdout.strip() or "unknown"


def record(bench_json, command, machine=None, date=None):
    """The record of a bench --json file, made by `command` (a dict, as the JSON file holds it)."""
    try:
        results = json.loads(Path(bench_json).read_text())
        kind = machine or machine_kind(results["machine"])
        rows = converge_figures(results) if "race_finals" in results else figures(results)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(bench_json, "file", str(bench_json), f"is no bench or converge --json file: {e}") from None
    if not command.startswith("python -m "):
        raise InputError("command line", "--command", command, "must be the python -m command that measured it")
    return {"machine": kind, "date": date or datetime.date.today().isoformat(), "commit": commit(),
            "command": command, "figures": rows}


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m benchmarks.record", description=__doc__.split("\n")[0])
    p.add_argument("bench_json", help="the file `python -m raytrace bench --json` or `converge --json` wrote")
    p.add_argument("--command", required=True, help="the command that wrote it, as the page should show it")
    p.add_argument("--machine", help="the machine kind, the table it goes in (default: from the file)")
    p.add_argument("--out", type=Path, default=RESULTS, help="the folder of records (default: benchmarks/results)")
    args = p.parse_args(argv)
    rec = record(args.bench_json, args.command, args.machine)
    slug = re.sub(r"[^a-z0-9]+", "-", rec["machine"].lower()).strip("-")[:40]
    kind = "converge" if rec["command"].startswith("python -m raytrace converge") else "bench"
    path = args.out / f"{rec['date']}-{slug}-{kind}.json"
    path.write_text(json.dumps(rec, indent=1) + "\n")
    print(path)


if __name__ == "__main__":
    from benchmarks import run_rig
    sys.exit(run_rig("benchmarks.record", main))
