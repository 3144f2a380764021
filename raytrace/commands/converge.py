"""Image error against run time for every sample pattern: `python -m raytrace converge SCENE ...`.

What is measured: for each pixel sample pattern, renders at 1, 2, 4, ... samples per pixel (1, 4, 16, ...
for the patterns that need square counts; one render for center), each timed by its passes alone
(RenderStats.wall_seconds: the kernel build is done by an untimed render first), and compared with a
reference image of the same scene, size and light samples:
- rmse: the root mean square difference over all pixels and channels of the linear images (with --clamp,
  of the images clamped to [0, 1]);
- estimated_rmse: what the render itself estimates from its two halves of passes (raytrace/renderer/progressive.py),
  always of linear values; the two columns side by side show how far the estimate is from the truth for
  each pattern. Clamping moves no two values further apart, so with --clamp it bounds the clamped error
  from above (it equals it where no value exceeds 1);
- flip: the mean FLIP error (Andersson et al., "FLIP: A Difference Evaluator for Alternating Images",
  HPG 2020) between the two images as the project's 8-bit files encode them, LDR, at FLIP's default 67
  pixels per degree.
The reference is rendered with Owen-scrambled Sobol points for pixels and lights under a seed of its own,
with at least 16 times the largest sample count, unless a file is given; its own estimated error is
stated, and drawn, because no render can be shown to be closer to the truth than that.

Written to the output directory: converge.csv (one row per render), converge.png (rmse against seconds,
log-log, one line per pattern with its fitted slope: -1/2 is the Monte Carlo rate), montage.png (the
same zoomed crop after about the same time for every pattern: its longest measured render within the
montage's time), and
reference.exr and reference.json when the reference is rendered here.

Needs matplotlib and flip_evaluator (the extra `analysis`), imported inside the functions that use them.
"""
import csv
import math
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from .. import samplers
from ..errors import POSITIVE_SECONDS, InputError
from ..numerics import is_integer, is_real, rmse
from ..outputs import Outputs, scene_inputs, write_json
from ..image_file import encode_8bit, write_image_file
from ..render import RenderOptions, render_progressive, resolve
from ..scene.ranges import MAX_SAMPLES as MAX_SPP
from ..renderer.device import select_device
from ..scene import load_file
from . import bench
from .converge_peer import PEER_SAMPLERS, check_template, peer_rows, race, race_finals

CLI = "command line"
COLUMNS = ("sampler", "spp", "seconds", "rmse", "estimated_rmse", "flip")
REFERENCE_SEED_OFFSET = 1000003  # the reference's samples are independent of the ones it judges
MIN_MONTAGE_SECONDS = 0.05
MAX_REPEATS = 100
# The default crop, in fractions of the image (x, y, width, height): in scenes/cornell.toml, the lower right
# of the ellipsoid: its silhouette against the floor and the back wall, the penumbra of its shadow on the
# floor, and the corner where the floor meets the green wall.
DEFAULT_CROP = (0.70, 0.72, 0.18, 0.18)
OUTPUTS = ["converge.csv", "converge.png", "montage.png"]
RACE_LEVELS = (0.05, 0.02, 0.01, 0.005, 0.002, 0.001)  # RMSE levels at which --peer's times are set beside ours
REFERENCE_OUTPUTS = ["reference.exr", "reference.json"]  # when the reference is rendered here


def check_samplers(names):
    """The pattern names, each once, in their order; InputError for an unknown one or none."""
    names = list(dict.fromkeys(names))
    for name in names:
        if name not in samplers.SAMPLERS:
            raise InputError(CLI, "--samplers", name, samplers.count_problem(name, 1))
    if not names:
        raise InputError(CLI, "--samplers", "", "names no sampler")
    return names


def parse_crop(text):
    """"X,Y,W,H" in fractions of the image size, as a tuple of floats."""
    try:
        crop = tuple(float(v) for v in text.split(","))
    except ValueError:
        crop = ()
    if len(crop) != 4:
        raise InputError(CLI, "--crop", text, "must be X,Y,W,H: four fractions of the image size")
    return crop


def crop_box(crop, width, height):
    """The crop's pixel rows and columns as slices (at least one pixel each way)."""
    x, y, w, h = crop
    if not (0 <= x < 1 and 0 <= y < 1 and 0 < w and 0 < h and x + w <= 1 and y + h <= 1):
        raise InputError(CLI, "--crop", ",".join(map(str, crop)), "must lie in the image: 0 <= X, Y; 0 < W, H; "
                         "X + W <= 1; Y + H <= 1")
    x0, y0 = int(x * width), int(y * height)
    x1, y1 = max(x0 + 1, round((x + w) * width)), max(y0 + 1, round((y + h) * height))
    return slice(y0, y1), slice(x0, x1)


def _check_range(value, key, low, high):
    if value is not None and not low <= value <= high:
        raise InputError(CLI, key, value, f"must be in [{low}, {high}]")


def sample_counts(name, max_spp):
    """The pixel sample counts a pattern is measured at: powers of 2 (of 4 where it needs squares) up to
    max_spp; center only at 1."""
    step = 4 if name in samplers.SQUARE_ONLY else 2
    counts = [1]
    while name != "center" and counts[-1] * step <= max_spp:
        counts.append(counts[-1] * step)
    return counts


def light_pattern(name, light_samples, shading="phong"):
    """(light pattern, or None) for the pixel pattern `name`: the same pattern (grid for center, which
    takes one sample only), else sobol where the light-sample count does not suit it, or where the shading
    model refuses it (one point of a course's pattern in the direct model); the note to print."""
    light = "grid" if name == "center" else name
    problem = samplers.count_problem(light, light_samples) or samplers.light_problem(light, light_samples, shading)
    if problem is None:
        return light, None
    return "sobol", f"{name}: {light_samples} light samples do not suit {light} ({problem}); the light uses sobol"


def read_reference(path, width, height, radiance=True):
    """The first three channels of a linear float image file (EXR, HDR), which must be width x height; and its
    facts: the file, and the sample count and estimated RMSE a render writes into it (None where absent).
    Refused with one line: a value that is NaN or Inf, and with `radiance` (a --reference: what the renders are
    judged against) one below 0 (radiance is never negative: no render makes one) and a sample count or
    estimated RMSE in the file that no render writes. An image of zeros is taken: it is what a render of an
    all-black scene is, exactly (tests/test_progressive.py), and so the right reference for one."""
    if Path(path).suffix.lower() not in (".exr", ".hdr"):
        raise InputError(CLI, "--reference", str(path), "must be a linear float image (.exr or .hdr): an 8-bit "
                         "or 16-bit file holds gamma-encoded values, which are no radiance to compare against")
    buf = oiio.ImageBuf(str(path))
    if not buf.read(0, 0, True, oiio.FLOAT) or buf.has_error:
        raise InputError(CLI, "--reference", str(path), f"cannot read: {buf.geterror().splitlines()[0]}")
    spec = buf.spec()
    if (spec.width, spec.height) != (width, height) or spec.nchannels < 3:
        raise InputError(CLI, "--reference", str(path), f"is {spec.width} x {spec.height} with {spec.nchannels} "
                         f"channels; the renders are {width} x {height} x 3")
    image = buf.get_pixels(oiio.FLOAT)[:, :, :3]
    if not np.all(np.isfinite(image)):
        raise InputError(CLI, "--reference", str(path), "holds NaN or Inf")
    facts = {"file": str(path), "spp": spec.getattribute("raytrace:spp"),
             "estimated_rmse": spec.getattribute("raytrace:estimated_rmse")}
    if radiance:
        negative = int(np.count_nonzero(image < 0))
        if negative:
            raise InputError(CLI, "--reference", str(path), f"holds {negative} negative value"
                             f"{'s' * (negative != 1)} of {image.size} (the least {float(image.min()):.4g}): "
                             "radiance is never negative, so no render makes it")
        _check_fact(path, "raytrace:spp", facts["spp"], lambda v: is_integer(v) and 1 <= v <= MAX_SPP,
                    f"must be a sample count in [1, {MAX_SPP}]")
        _check_fact(path, "raytrace:estimated_rmse", facts["estimated_rmse"],
                    lambda v: is_real(v) and 0 <= v < math.inf, "must be a finite number >= 0")
    return image, facts


def _check_fact(path, key, value, check, problem):
    """A render's attribute in a --reference file, absent (None) or as a render writes it."""
    if value is not None and not check(value):
        raise InputError(str(path), key, value, problem + " (as raytrace writes it), or absent")


def render_reference(scene, spp, seed, common):
    """Render the reference (sobol pixels and lights, its own seed); returns (image, its facts, the
    metadata of reference.exr)."""
    image, _, stats = render_progressive(scene, spp=spp, sampler="sobol", light_sampler="sobol", seed=seed, **common)
    facts = {"spp": stats.spp, "seconds": stats.wall_seconds, "estimated_rmse": stats.estimated_rmse,
             "sampler": "sobol", "light_sampler": "sobol", "seed": seed}
    metadata = {"spp": stats.spp, "sampler": "sobol", "light_sampler": "sobol", "seed": seed,
                "light_samples": stats.light_samples, "seconds": float(stats.wall_seconds)}
    if stats.estimated_rmse is not None:
        metadata["estimated_rmse"] = float(stats.estimated_rmse)
    return image, facts, metadata


def flip_error(image, reference):
    """Mean LDR FLIP between the two images as the project's 8-bit files encode them."""
    import flip_evaluator as flip
    _, mean_error, _ = flip.evaluate(encode_8bit(reference) / 255.0, encode_8bit(image) / 255.0, "LDR")
    return float(mean_error)


def clamped_rmse(image, reference):
    """RMSE of the images clamped to [0, 1], as 8-bit files show them: where two renderers' images differ
    mostly in pixels far above 1 (a light's edge), what a viewer sees of them."""
    return rmse(np.clip(image, 0.0, 1.0), np.clip(reference, 0.0, 1.0))


def measure(scene, names, max_spp, reference, common, box, out, error=rmse, repeats=1):
    """One row per (pattern, sample count), each with the crop of its image (dropped from the CSV); its
    seconds the median of `repeats` renders (the same seed: the same image)."""
    rows = []
    for name in names:
        light, note = light_pattern(name, common["light_samples"], scene.shading)
        if note:
            print(note, file=out)
        for spp in sample_counts(name, max_spp):
            seconds = []
            for _ in range(repeats):
                image, _, stats = render_progressive(scene, spp=spp, sampler=name, light_sampler=light, **common)
                seconds.append(stats.wall_seconds)
            rows.append({"sampler": name, "spp": spp, "seconds": float(np.median(seconds)),
                         "rmse": error(image, reference), "estimated_rmse": stats.estimated_rmse,
                         "flip": flip_error(image, reference), "crop": image[box],
                         "crop_rmse": error(image[box], reference[box])})
    return rows


def write_csv(rows, path):
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows({**row, "estimated_rmse": "" if row["estimated_rmse"] is None else row["estimated_rmse"]}
                         for row in rows)


def fitted_slope(rows):
    """Least-squares slope of log rmse against log seconds over the rows with spp >= 2; None for fewer
    than two of them."""
    points = [(r["seconds"], r["rmse"]) for r in rows if r["spp"] >= 2 and r["seconds"] > 0 and r["rmse"] > 0]
    if len(points) < 2:
        return None
    x, y = np.log(np.array(points)).T
    return float(np.polyfit(x, y, 1)[0])


def _pyplot():
    """matplotlib.pyplot drawing off screen (Agg), whatever the machine's display."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_convergence(rows, names, reference_facts, title, path, values="linear"):
    """RMSE against seconds, log-log, one line per pattern. An RMSE of 0 (a render equal to the reference: every
    render of an all-black scene) has no place on a log axis: those points are left out, each pattern's label
    says how many, and with no positive RMSE at all the axes are linear and say why (matplotlib warned of
    "no positive values" on stderr, twice, and drew empty log axes)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=100)
    drawn = False
    for name in names:
        mine = [r for r in rows if r["sampler"] == name]
        shown = [r for r in mine if r["seconds"] > 0 and r["rmse"] > 0]
        slope = fitted_slope(mine)
        label = name if slope is None else f"{name} (slope {slope:.2f})"
        if len(shown) < len(mine):
            label += f" ({len(mine) - len(shown)} with RMSE 0 not drawn)"
        ax.plot([r["seconds"] for r in shown], [r["rmse"] for r in shown], marker="o", label=label,
                ls="--" if name.startswith("peer:") else "-")
        drawn = drawn or bool(shown)
    bound = reference_facts["estimated_rmse"]
    if bound is not None and bound > 0:
        note = "" if values == "linear" else " of linear values\n(a bound on the clamped one)"
        ax.axhline(bound, color="black", ls="--", lw=1,
                   label=f"the reference's own estimated RMSE{note}, {bound:.2e}\n"
                         "(two halves of passes: an overestimate for sobol)")
    if drawn:
        ax.set_xscale("log")
        ax.set_yscale("log")
    else:
        ax.text(0.5, 0.5, "every render's RMSE is 0: each equals the reference\n(nothing to draw on log axes)",
                ha="center", va="center", transform=ax.transAxes)
        ax.set_xticks([])
        ax.set_yticks([])
    ax.set_xlabel("seconds (the render's passes; kernel build excluded)")
    ax.set_ylabel(f"RMSE against the reference ({values})")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


def montage_seconds_default(rows):
    """A quarter of the longest render of random (of all patterns if random was not measured)."""
    pool = [r for r in rows if r["sampler"] == "random"] or rows
    return max(MIN_MONTAGE_SECONDS, max(r["seconds"] for r in pool) / 4)


def montage(names, rows, seconds):
    """Per pattern, its longest measured render within `seconds` (its first one if none is)."""
    panels = []
    for name in names:
        mine = [r for r in rows if r["sampler"] == name]
        within = [r for r in mine if r["seconds"] <= seconds]
        panels.append(max(within, key=lambda r: r["seconds"]) if within else mine[0])
    return panels


def draw_montage(panels, reference_crop, reference_facts, caption, path, cols=4, dpi=100):
    """The crops, enlarged by an integer factor with nearest-neighbour pixels, the reference first."""
    from .panels import figure_panels, save_figure, show_image
    _pyplot()  # the Agg backend, before the helpers import pyplot
    h, w = reference_crop.shape[:2]
    zoom = max(1, 256 // max(h, w))
    spp = reference_facts["spp"]
    shown = [(reference_crop, "reference\n" + (Path(reference_facts["file"]).name if spp is None else f"{spp} spp"))]
    shown += [(p["crop"], f"{p['sampler']}\n{p['spp']} spp, {p['seconds']:.2f} s, RMSE {p['crop_rmse']:.4f}")
              for p in panels]
    cols = min(cols, len(shown))
    n_rows = -(-len(shown) // cols)
    fig, rows = figure_panels(cols, [h * zoom] * n_rows, w * zoom, dpi, title_px=44, caption_px=48)
    axes = [ax for row in rows for ax in row]
    for ax, (crop, title) in zip(axes, shown):
        show_image(ax, crop, title)
    for ax in axes[len(shown):]:
        ax.set_axis_off()
    fig.text(0.5, 0.005, caption, ha="center", va="bottom", fontsize=9)
    save_figure(fig, path)


def print_table(rows, out):
    print(f"{'sampler':<17}{'spp':>6}{'seconds':>10}{'rmse':>11}{'estimated_rmse':>16}{'flip':>9}", file=out)
    for r in rows:
        estimated = "" if r["estimated_rmse"] is None else f"{r['estimated_rmse']:.3e}"
        print(f"{r['sampler']:<17}{r['spp']:>6}{r['seconds']:>10.4f}{r['rmse']:>11.3e}{estimated:>16}"
              f"{r['flip']:>9.4f}", file=out)


def write_outputs(outputs, files, rows, names, panels, reference, facts, box, title, seconds, metadata=None,
                  values="linear"):
    """converge.csv, converge.png and montage.png, and with `metadata` the rendered reference's
    reference.exr and reference.json, into their reserved temporaries `files` (by name) of `outputs`; the
    errors are of `values` (linear, or clamped to [0, 1])."""
    ys, xs = box
    caption = (f"{title}; the crop: pixels x {xs.start}..{xs.stop - 1}, y {ys.start}..{ys.stop - 1}.\nEach pattern's "
               f"longest measured render within {seconds:.3g} s; RMSE over the crop against the reference ({values}).")
    writers = {"converge.csv": lambda path: write_csv(rows, path),
               "converge.png": lambda path: plot_convergence(rows, names, facts, title, path, values),
               "montage.png": lambda path: draw_montage(panels, reference[box], facts, caption, path),
               "reference.exr": lambda path: write_image_file(path, reference, metadata),
               "reference.json": lambda path: write_json(path, facts)}
    for name, path in files.items():
        with outputs.writing(path):
            writers[name](path)


def _number(x):
    return "unknown" if x is None else f"{x:.3e}"


def converge(scene_path, samplers, max_spp, out_dir, reference=None, width=None, height=None, light_samples=None,
             seed=0, reference_spp=None, montage_seconds=None, crop=None, out=sys.stdout, scheduler=None,
             peer=None, peer_samplers=PEER_SAMPLERS, clamp=False, repeats=1, json_path=None, device=None):
    """Measure, write and print as the module says; returns {"rows": [...], "reference": {...},
    "montage": [...], "paths": [...]}. Every bad input raises InputError before anything is written."""
    names = check_samplers(samplers)
    if peer is not None:
        check_template(peer)
    error = clamped_rmse if clamp else rmse
    _check_range(max_spp, "--max-spp", 1, MAX_SPP)
    _check_range(reference_spp, "--reference-spp", 1, MAX_SPP)
    _check_range(repeats, "--repeats", 1, MAX_REPEATS)
    if montage_seconds is not None and not 0 < montage_seconds < math.inf:
        raise InputError(CLI, "--montage-seconds", montage_seconds, POSITIVE_SECONDS)
    select_device(device)  # a device that is not there: one line before anything is written
    scene = load_file(scene_path)
    width, height, _, light_samples, _, _ = resolve(scene, RenderOptions(
        width=width, height=height, spp=1, light_samples=light_samples, sampler="random", light_sampler="sobol",
        seed=seed))
    box = crop_box(DEFAULT_CROP if crop is None else crop, width, height)
    given = None if reference is None else read_reference(reference, width, height)
    names_out = OUTPUTS + ([] if given else REFERENCE_OUTPUTS)
    with Outputs(inputs=scene_inputs(scene) + ([] if reference is None else [reference])) as outputs:
        outputs.make_directory("--out", out_dir)
        files = {name: outputs.reserve("--out", Path(out_dir) / name, given=out_dir) for name in names_out}
        json_file = json_path and outputs.reserve("--json", json_path)
        common = dict(width=width, height=height, light_samples=light_samples, progress=False, scheduler=scheduler,
                      device=device)
        _, _, built = render_progressive(scene, spp=1, sampler="center", light_sampler="sobol", **common)  # untimed
        reference, facts, metadata = given + (None,) if given else render_reference(
            scene, reference_spp or min(MAX_SPP, 16 * max_spp), (seed + REFERENCE_SEED_OFFSET) % 2**32, common)
        print(f"reference: {facts.get('file', 'rendered')}, {facts['spp'] or '?'} spp, its own estimated RMSE "
              f"{_number(facts['estimated_rmse'])}" + (" (of linear values)" if clamp else ""), file=out)
        common["seed"] = seed
        rows = measure(scene, names, max_spp, reference, common, box, out, error, repeats)
        if peer is not None:
            rows += peer_rows(peer, peer_samplers, max_spp, reference, box, error, flip_error,
                              lambda path: read_reference(path, width, height, radiance=False)[0])
            names = names + [f"peer:{name}" for name in peer_samplers]
        seconds = montage_seconds or montage_seconds_default(rows)
        panels = montage(names, rows, seconds)
        write_outputs(outputs, files, rows, names, panels, reference, facts, box,
                      f"{Path(scene_path).name}: {width} x {height}, {light_samples} light samples", seconds,
                      metadata, "clamped to [0, 1]" if clamp else "linear")
        table = race(rows, RACE_LEVELS) if peer is not None else None
        finals = race_finals(rows) if peer is not None else None
        if json_file:
            with outputs.writing(json_file):
                write_json(json_file, {
                    "machine": bench.machine(built.device, built.extra.get("target")), "scene": str(scene_path),
                    "width": width, "height": height, "light_samples": light_samples, "clamp": clamp,
                    "repeats": repeats, "reference": facts, "rows": [{k: r[k] for k in COLUMNS} for r in rows],
                    "race": table, "race_finals": finals})
        outputs.commit()
    paths = [Path(out_dir) / name for name in names_out]
    print_table(rows, out)
    exact = sum(r["rmse"] == 0 for r in rows)
    if exact:
        print(f"note: {exact} of {len(rows)} renders equal the reference (RMSE 0): converge.png's log axes leave "
              f"{'it' if exact == 1 else 'them'} out", file=out)
    print(f"montage, {seconds:.3g} s each: " + ", ".join(f"{p['sampler']} {p['spp']} spp in {p['seconds']:.3f} s"
                                                       for p in panels), file=out)
    for t in table or []:
        print(f"RMSE {t['rmse']:g}: ours {_number(t['ours_s'])} s, the peer's {_number(t['peer_s'])} s, ratio "
              f"{_number(t['ratio'])}", file=out)
    for t in finals or []:
        print(f"{t['peer']} at {t['spp']} spp, RMSE {t['rmse']:.4g} in {_number(t['peer_s'])} s: ours in "
              f"{_number(t['ours_s'])} s, ratio {_number(t['ratio'])}", file=out)
    for path in paths:
        print(f"wrote {path}", file=out)
    return {"rows": [{k: r[k] for k in COLUMNS} for r in rows], "reference": facts, "montage_seconds": seconds,
            "race": table, "race_finals": finals,
            "montage": [{k: p[k] for k in ("sampler", "spp", "seconds", "crop_rmse")} for p in panels],
            "paths": paths}
