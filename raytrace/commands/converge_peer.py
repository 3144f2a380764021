"""Another renderer's sample patterns in `converge`'s study (`--peer TEMPLATE`), against the same reference,
and the time each side needs to reach an error.

TEMPLATE is a shell command with the placeholders {sampler}, {spp} and {out}: it renders the scene at the
study's size with that sampler and pixel sample count, writes a linear EXR to {out}, and prints as its last
line a JSON object whose `median_s` is the render's own time (without loading the scene or compiling), as
`converge` times its own renders (their passes alone), and may say its `spp`, the count it took (Mitsuba's
ldsampler rounds 1 up to 4: that render then counts once). Mitsuba 3's script beside this project's peers
does that with --sampler, --spp and --out. The peer's patterns are measured at 1, 4, 16, ... samples
(squares and powers of two, which every Mitsuba sampler takes)."""
import re
import shlex
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import bench

PEER_SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler")


def check_template(template):
    for field in ("{sampler}", "{spp}", "{out}"):
        if field not in template:
            raise InputError("command line", "--peer", template, f"needs the placeholder {field}")


def fill(template, sampler, spp, out):
    """The template's command for one render: its placeholders {sampler}, {spp} and {out} filled in (quoted
    for the shell), every other brace left as it is (an awk program, a shell's ${VAR})."""
    values = {"{sampler}": shlex.quote(sampler), "{spp}": str(spp), "{out}": shlex.quote(str(out))}
    return re.sub(r"\{sampler\}|\{spp\}|\{out\}", lambda m: values[m.group(0)], template)


def run_peer(template, sampler, spp, out):
    """The peer's render: (seconds, its JSON); InputError naming --peer when it fails (bench.run_peer)."""
    facts = bench.run_peer(fill(template, sampler, spp, out), "median_s")
    return float(facts["median_s"]), facts


def peer_rows(template, names, max_spp, reference, box, error, flip, read_image):
    """One row per (peer sampler, sample count), named "peer:SAMPLER", in converge's row format (rmse by
    `error`, flip by `flip`; no estimated_rmse: the peer does not estimate its error)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="converge-peer-") as tmp:
        for name in names:
            spp = 1
            while spp <= max_spp:
                out = Path(tmp) / f"{name}-{spp}.exr"
                seconds, facts = run_peer(template, name, spp, out)
                took, spp = facts.get("spp", spp), spp * 4
                if rows and rows[-1]["sampler"] == f"peer:{name}" and rows[-1]["spp"] == took:
                    continue  # rounded up to the count measured before (Mitsuba's ldsampler: 1 to 4)
                try:
                    image = read_image(out)
                except InputError as e:  # about the peer's file, not the user's --reference
                    raise InputError("command line", "--peer", template, f"the image of its {name} render at "
                                     f"{took} spp: {e.problem}") from None
                rows.append({"sampler": f"peer:{name}", "spp": took, "seconds": seconds,
                             "rmse": error(image, reference),
                             "estimated_rmse": None, "flip": flip(image, reference), "crop": image[box],
                             "crop_rmse": error(image[box], reference[box])})
    return rows


def time_to_reach(rows, level):
    """The least time any of `rows` takes to reach RMSE `level`, interpolated log-log between a pattern's
    measured renders (None where none reaches it)."""
    best = None
    for name in dict.fromkeys(r["sampler"] for r in rows):
        points = sorted((r["seconds"], r["rmse"]) for r in rows if r["sampler"] == name and r["seconds"] > 0)
        for (t0, e0), (t1, e1) in zip(points, points[1:]):
            if e0 > level >= e1 and e1 > 0:
                t = float(np.exp(np.interp(np.log(level), [np.log(e1), np.log(e0)], [np.log(t1), np.log(t0)])))
                best = t if best is None else min(best, t)
                break
        else:
            if points and points[0][1] <= level:
                best = points[0][0] if best is None else min(best, points[0][0])
    return best


def race_finals(rows):
    """For each of the peer's patterns, its render with the most samples: its RMSE, its time, our least time
    to the same RMSE and the ratio (ours / theirs), so that "our time to reach the error of the peer's
    multijitter at 256 spp" is one line."""
    ours = [r for r in rows if not r["sampler"].startswith("peer:")]
    table = []
    for name in dict.fromkeys(r["sampler"] for r in rows if r["sampler"].startswith("peer:")):
        last = max((r for r in rows if r["sampler"] == name), key=lambda r: r["spp"])
        a = time_to_reach(ours, last["rmse"])
        table.append({"peer": name, "spp": last["spp"], "rmse": last["rmse"], "peer_s": last["seconds"],
                      "ours_s": a, "ratio": None if a is None or last["seconds"] <= 0 else a / last["seconds"]})
    return table


def race(rows, levels):
    """For each RMSE level: our best time, the peer's best time, and their ratio (ours / theirs)."""
    ours = [r for r in rows if not r["sampler"].startswith("peer:")]
    theirs = [r for r in rows if r["sampler"].startswith("peer:")]
    table = []
    for level in levels:
        a, b = time_to_reach(ours, level), time_to_reach(theirs, level)
        table.append({"rmse": level, "ours_s": a, "peer_s": b, "ratio": None if a is None or b is None else a / b})
    return table
