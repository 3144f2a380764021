#!/usr/bin/env python3
"""Judge raytrace's AOVs against Mitsuba 3's `aov` integrator on one scene file (a developer rig; the reference
is devtools/peers/aov_reference.py's, scenes/mitsuba/references/channels/STEM.npz): raytrace renders the scene
(its aovs, Mitsuba's `<integrator type="aov">`) at the reference's samples per pixel, and each AOV is compared
value by value on the pixels whose 3 x 3 neighbourhood lies on one surface, within a bound on the difference
of two pixel means (tolerance()). tests/test_aov_mitsuba.py runs judge(); the command also writes one PNG per
AOV (raytrace | Mitsuba | |difference| / tolerance):

  python -m devtools.peers.aov_check scenes/mitsuba/aov.xml [--seed S] [--out DIR]

The interior: a pixel whose 3 x 3 neighbourhood (itself and its 8 neighbours) has one integral shape_index in
raytrace's image and one in Mitsuba's. A pixel mean is integral where all its samples met one shape (a
mixture's mean lies between two numbers; that nine mixtures all land on integers is not a case to plan for),
so the whole neighbourhood's footprint lies on that shape. shape_index itself is compared through the map
between the numberings (raytrace's SHAPE_ORDER, Mitsuba's scene->shapes() order): over the interior pixels
each of raytrace's numbers meets exactly one of Mitsuba's and each of Mitsuba's one of raytrace's."""
import argparse
import json
import math
from pathlib import Path

import numpy as np

ALPHA = 1e-4  # the chance that a correct raytrace fails the scene's test (all AOVs, all values together)


def reference_path(scene):
    scene = Path(scene)
    return scene.parent / "references" / "channels" / (scene.stem + ".npz")


def load_reference(path):
    """{aovs: ((name, type), ...), spp, chunks, means: {name: H x W x C float64}, vars: {...}}."""
    from raytrace import aovs as aov_types
    with np.load(path) as data:
        pairs = aov_types.parse(str(data["aovs"]), str(path), "aovs")
        return {"aovs": pairs, "spp": int(data["spp"]), "chunks": int(data["chunks"]),
                "means": {n: data[n].astype(np.float64) for n, _ in pairs},
                "vars": {n: data[n + ".var"].astype(np.float64) for n, _ in pairs}}


def render_ours(scene, spp, seed=0):
    """raytrace's AOVs of the scene file at spp samples per pixel: {name: H x W x C float64}."""
    import raytrace
    image, _ = raytrace.render(raytrace.load_file(str(scene)), spp=spp, seed=seed)
    return {n: np.asarray(a, np.float64) for n, a in image.aovs.items()}


def neighbourhood(a, reduce):
    """reduce (np.max or np.min) over each pixel's 3 x 3 neighbourhood (edges: the pixels there are)."""
    padded = np.pad(a, [(1, 1), (1, 1)] + [(0, 0)] * (a.ndim - 2), mode="edge")
    h, w = a.shape[:2]
    stack = [padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    return reduce(np.stack(stack), axis=0)


def interior(shape_ours, shape_theirs):
    """H x W bool: the pixels whose neighbourhood has one integral, nonzero shape_index on both sides (edge
    pixels, whose neighbourhood is cut, are left out)."""
    mask = np.ones(shape_ours.shape[:2], bool)
    for s in (shape_ours[..., 0], shape_theirs[..., 0]):
        mask &= (s == np.round(s)) & (s > 0)
        mask &= neighbourhood(s, np.max) == neighbourhood(s, np.min)
    mask[0, :] = mask[-1, :] = mask[:, 0] = mask[:, -1] = False
    return mask


def shape_map(shape_ours, shape_theirs, mask):
    """{raytrace's number: Mitsuba's} over the masked pixels, and the numbers of either side that meet two of
    the other's ([] each where the map is one-to-one)."""
    pairs = {(int(a), int(b)) for a, b in zip(shape_ours[..., 0][mask], shape_theirs[..., 0][mask])}
    ours, theirs = {}, {}
    for a, b in pairs:
        ours.setdefault(a, set()).add(b)
        theirs.setdefault(b, set()).add(a)
    bad = sorted(a for a, s in ours.items() if len(s) > 1), sorted(b for b, s in theirs.items() if len(s) > 1)
    return {a: min(s) for a, s in ours.items()}, bad


def tolerance(ours, theirs, spp, count, alpha=ALPHA):
    """H x W x C: the bound on |ours - theirs| per value that a correct pair of renders exceeds anywhere among
    `count` values with probability at most alpha (tests/test_aov_mitsuba.py argues it):
    R sqrt(ln(2 count / alpha) / spp) + 2 (spp + 64) 2^-24 m, with R the channel's range over the
    neighbourhood (both sides' means) and m the AOV's largest magnitude there (any channel, both sides)."""
    lo = np.minimum(neighbourhood(ours, np.min), neighbourhood(theirs, np.min))
    hi = np.maximum(neighbourhood(ours, np.max), neighbourhood(theirs, np.max))
    magnitude = np.maximum(neighbourhood(np.abs(ours), np.max), neighbourhood(np.abs(theirs), np.max))
    magnitude = np.max(magnitude, axis=-1, keepdims=True)
    noise = (hi - lo) * math.sqrt(math.log(2 * count / alpha) / spp)
    return noise + 2 * (spp + 64) * 2.0 ** -24 * magnitude


def judge(scene, seed=0, reference=None, ours=None):
    """Per AOV of the reference: {name: {type, values, failing, worst (|diff|), worst_ratio (|diff| / tol),
    at (row, col, channel) of the worst ratio}}, with the shape map and its breaks under "shape_map", and
    everything the PNGs need under "arrays" (ours, theirs, tol, mask)."""
    ref = load_reference(reference or reference_path(scene))
    ours = ours if ours is not None else render_ours(scene, ref["spp"], seed)
    kinds = dict(ref["aovs"])
    shape = next(n for n, k in ref["aovs"] if k == "shape_index")
    mask = interior(ours[shape], ref["means"][shape])
    mapping, breaks = shape_map(ours[shape], ref["means"][shape], mask)
    count = int(mask.sum()) * sum(ref["means"][n].shape[-1] for n in kinds)
    out = {"interior_pixels": int(mask.sum()), "shape_map": {"map": mapping, "breaks": breaks}, "arrays": {}}
    for name, kind in ref["aovs"]:
        mine, theirs = ours[name], ref["means"][name]
        if kind == "shape_index":  # raytrace's numbers as Mitsuba's
            mine = np.vectorize(lambda v: mapping.get(int(v), -1) if v == round(v) else v, otypes=[float])(mine)
        tol = tolerance(mine, theirs, ref["spp"], count)
        diff = np.abs(mine - theirs)
        ratio = np.where(mask[..., None], diff / tol, 0.0)
        at = np.unravel_index(np.argmax(ratio), ratio.shape)
        out[name] = {"type": kind, "values": int(mask.sum()) * mine.shape[-1],
                     "failing": int(np.sum(ratio > 1)), "worst": float(np.max(np.where(mask[..., None], diff, 0))),
                     "worst_ratio": float(ratio[at]), "at": [int(i) for i in at],
                     "ours": float(mine[at]), "mitsuba": float(theirs[at]), "tol": float(tol[at])}
        out["arrays"][name] = (mine, theirs, tol, mask)
    return out


# --- pictures ---------------------------------------------------------------------------------------------------

def _false_colour(a, kind, lo, hi):
    """H x W x 3 in [0, 1]: normals as n / 2 + 1/2, the others scaled from [lo, hi] per channel; a single
    channel as grey, two as (u, v, 0); shape_index by a fixed palette."""
    if kind in ("sh_normal", "geo_normal"):
        return np.clip(a * 0.5 + 0.5, 0, 1)
    if kind == "shape_index":
        palette = np.array([[0, 0, 0], [0.9, 0.3, 0.2], [0.2, 0.7, 0.3], [0.2, 0.4, 0.9], [0.9, 0.8, 0.2],
                            [0.7, 0.3, 0.8], [0.2, 0.8, 0.8], [0.9, 0.5, 0.1], [0.6, 0.6, 0.6]])
        index = np.clip(np.round(a[..., 0]).astype(int), 0, len(palette) - 1)
        mixed = a[..., 0] != np.round(a[..., 0])
        return np.where(mixed[..., None], 1.0, palette[index])
    x = np.clip((a - lo) / np.where(hi > lo, hi - lo, 1), 0, 1)
    if x.shape[-1] == 1:
        return np.repeat(x, 3, axis=-1)
    if x.shape[-1] == 2:
        return np.concatenate([x, np.zeros_like(x[..., :1])], axis=-1)
    return x


def write_png(path, name, kind, mine, theirs, tol, mask):
    """PNG of raytrace | Mitsuba | the interior's max |diff| / tol (grey to white at 1, red above, blue outside
    the interior), enlarged to at least 256 rows."""
    import OpenImageIO as oiio
    both = np.concatenate([mine, theirs])
    lo = np.min(both, axis=(0, 1)) if kind != "albedo" else np.zeros(3)
    hi = np.max(both, axis=(0, 1)) if kind != "albedo" else np.ones(3)
    level = np.max(np.abs(mine - theirs) / tol, axis=-1)
    grey = np.clip(level, 0, 1)[..., None] * np.ones(3)
    grey = np.where((level > 1)[..., None], [1.0, 0, 0], grey)
    grey = np.where(mask[..., None], grey, [0.1, 0.1, 0.3])
    panels = [_false_colour(mine, kind, lo, hi), _false_colour(theirs, kind, lo, hi), grey]
    scale = max(1, math.ceil(256 / mine.shape[0]))
    gap = np.full((mine.shape[0], 1, 3), 0.25)
    pixels = np.concatenate([panels[0], gap, panels[1], gap, panels[2]], axis=1)
    pixels = np.repeat(np.repeat(pixels, scale, axis=0), scale, axis=1)
    pixels = np.ascontiguousarray(np.round(255 * pixels).astype(np.uint8))
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.UINT8)):
        raise OSError(f"aov_check: cannot write {path}: {oiio.geterror()}")
    out.write_image(pixels)
    out.close()


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.peers.aov_check", description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="a Mitsuba 3 XML scene whose integrator is aov, with a reference")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="aov_check", help="the folder of the PNGs (default aov_check)")
    a = ap.parse_args(argv)
    result = judge(a.scene, a.seed)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, (mine, theirs, tol, mask) in result.pop("arrays").items():
        write_png(out / f"{Path(a.scene).stem}_{name}.png", name, result[name]["type"], mine, theirs, tol, mask)
    print(json.dumps(result, indent=1, default=str))
    return 0 if all(v["failing"] == 0 for k, v in result.items() if isinstance(v, dict) and "failing" in v) \
        and not any(result["shape_map"]["breaks"]) else 1


if __name__ == "__main__":
    raise SystemExit(main())
