"""Running the cases and printing the table: run_case, format_row and report (`python -m raytrace stability`)."""
import dataclasses
import sys
import time


from ...outputs import write_json
from .cases import CASES
from .common import Env


# ---------------------------------------------------------------------------------------------------------
# The table

def run_case(env, case):
    """One case's rows, each named after the case."""
    rows = case(env)
    for row in rows:
        row.case = case.__name__
    return rows


COLUMNS = "{:<18} {:<84} {:>14} {:>14} {:>7}  {:<11}  {}"


def _amount(value, unit):
    return f"{value:.3g} {unit}".strip() if isinstance(value, float) else f"{value} {unit}".strip()


def format_row(row):
    error, bound = ("", "") if row.skipped else (_amount(row.error, row.unit), _amount(row.bound, row.unit))
    return COLUMNS.format(row.case, row.measured, error, bound, row.nonfinite, row.verdict, row.why)


def report(lanes, device=None, json_path=None, out=sys.stdout):
    """Every case at one lane width, printed row by row as the table; the rows also to `json_path` if given.
    Returns whether no row failed (every one passed, is a known limit or was skipped)."""
    env, start, rows = Env(lanes, device), time.perf_counter(), []
    device_name = env.probe.queue.device.name.strip()
    print(f"raytrace numerical stability: LANES={lanes}, {device_name}", file=out)
    print(COLUMNS.format("case", "measured", "max error", "bound", "NaN/Inf", "verdict", "the bound, argued"),
          file=out, flush=True)
    for case in CASES:
        for row in run_case(env, case):
            rows.append(row)
            print(format_row(row), file=out, flush=True)
    seconds = time.perf_counter() - start
    verdicts = [row.verdict for row in rows]
    counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("pass", "known limit", "skipped", "FAIL"))
    print(f"{len(rows)} rows: {counts}; {seconds:.1f} s", file=out)
    if json_path:  # through outputs.write_json, as every JSON file the commands write: no NaN, a non-finite null
        data = {"lanes": lanes, "device": device_name, "seconds": seconds,
                "rows": [{**dataclasses.asdict(row), "error": float(row.error), "bound": float(row.bound),
                          "verdict": row.verdict} for row in rows]}
        write_json(json_path, data)
    return "FAIL" not in verdicts
