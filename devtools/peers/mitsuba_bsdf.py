#!/usr/bin/env python3
"""Mitsuba 3's own BSDF values, recorded for tests/test_bsdf_reference.py, and their comparison with the float64
references of tests/bsdf_reference.py (a developer rig, not a dependency of raytrace).

Install (a venv of its own; the scalar_rgb variant needs no LLVM):
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba==3.9.1 numpy
Record, from the repository's root, with Mitsuba's python (writes the full set, 4096 points per case, to
--out, and the first --fixture-points of each case to tests/data/mitsuba_bsdf_values.npz with its record
tests/data/mitsuba_bsdf_values.json):
  /tmp/mts/bin/python devtools/peers/mitsuba_bsdf.py record --out /tmp/mitsuba_bsdf_full.npz
Compare, with the repository's python (numpy and scipy; prints the largest errors per case and BSDF):
  python devtools/peers/mitsuba_bsdf.py compare /tmp/mitsuba_bsdf_full.npz

Each case is a plugin dict given to mi.load_dict (variant scalar_rgb, float32), and per point:
  wo        the viewer's direction (Mitsuba's si.wi; si.sh_frame the identity frame), float32;
  wi        a direction uniform on the sphere; eval and pdf: bsdf.eval / bsdf.pdf(ctx, si, wi);
  u1, u2    random numbers; s_wi, s_pdf, s_weight, s_component: what bsdf.sample(ctx, si, u1, u2) returned
            (bs.wo, bs.pdf, the weight, bs.sampled_component), s_eval, s_pdf_eval: eval and pdf at bs.wo
            (directions in the lobe, which uniform wi miss when alpha is small).
The directions wo: uniform on the sphere for the two-sided dielectrics; for the others 7/8 on the upper
hemisphere (an eighth of those within 1e-2 of the horizon) and 1/8 below it. Every input is float32 so that
Mitsuba and the reference see the same numbers.
"""
import argparse
import datetime
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "data" / "mitsuba_bsdf_values.npz"
RECORD = FIXTURE.with_suffix(".json")
POINTS = 4096
FIXTURE_POINTS = 96
RGB_D = {"type": "rgb", "value": [0.2, 0.5, 0.8]}
GOLD_ETA = {"type": "rgb", "value": [0.1431, 0.3749, 1.4425]}
GOLD_K = {"type": "rgb", "value": [3.9831, 2.3857, 1.6032]}

# (name, plugin dict). The names say what each case is for.
CASES = [
    ("diffuse rgb", {"type": "diffuse", "reflectance": RGB_D}),
    ("conductor default mirror", {"type": "conductor"}),
    ("conductor gold rgb", {"type": "conductor", "eta": GOLD_ETA, "k": GOLD_K,
                            "specular_reflectance": {"type": "rgb", "value": [0.9, 0.8, 0.7]}}),
    ("roughconductor beckmann 0.001", {"type": "roughconductor", "distribution": "beckmann", "alpha": 0.001,
                                       "eta": 1.3, "k": 3.1}),
    ("roughconductor beckmann 0.1", {"type": "roughconductor", "alpha": 0.1, "eta": GOLD_ETA, "k": GOLD_K}),
    ("roughconductor ggx 0.3", {"type": "roughconductor", "distribution": "ggx", "alpha": 0.3, "eta": 0.2,
                                "k": 3.9, "specular_reflectance": {"type": "rgb", "value": [1.0, 0.5, 0.25]}}),
    ("roughconductor ggx 1", {"type": "roughconductor", "distribution": "ggx", "alpha": 1.0}),
    ("roughconductor ggx aniso 0.05 0.4", {"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.05,
                                           "alpha_v": 0.4, "eta": GOLD_ETA, "k": GOLD_K}),
    ("roughconductor beckmann aniso 0.3 0.08", {"type": "roughconductor", "distribution": "beckmann",
                                                "alpha_u": 0.3, "alpha_v": 0.08, "eta": 1.1, "k": 2.0}),
    ("roughconductor ggx 0.2 not visible", {"type": "roughconductor", "distribution": "ggx", "alpha": 0.2,
                                            "sample_visible": False, "eta": 0.5, "k": 2.5}),
    ("roughconductor beckmann aniso not visible", {"type": "roughconductor", "distribution": "beckmann",
                                                   "alpha_u": 0.15, "alpha_v": 0.5, "sample_visible": False}),
    ("dielectric 1.5", {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    ("dielectric 1/1.33 rgb", {"type": "dielectric", "int_ior": 1.0, "ext_ior": 1.33,
                               "specular_reflectance": {"type": "rgb", "value": [0.9, 0.6, 0.3]},
                               "specular_transmittance": RGB_D}),
    ("thindielectric default", {"type": "thindielectric"}),
    ("thindielectric 1/1.5", {"type": "thindielectric", "int_ior": 1.0, "ext_ior": 1.5,
                              "specular_transmittance": RGB_D}),
    ("roughdielectric beckmann 0.001", {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.001,
                                        "int_ior": 1.5, "ext_ior": 1.0}),
    ("roughdielectric beckmann 0.1", {"type": "roughdielectric", "alpha": 0.1}),
    ("roughdielectric ggx 0.3", {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.3,
                                 "int_ior": 1.5, "ext_ior": 1.0}),
    ("roughdielectric ggx 1", {"type": "roughdielectric", "distribution": "ggx", "alpha": 1.0,
                               "int_ior": 2.4, "ext_ior": 1.0}),
    ("roughdielectric ggx aniso 0.05 0.3", {"type": "roughdielectric", "distribution": "ggx", "alpha_u": 0.05,
                                            "alpha_v": 0.3, "int_ior": 1.33, "ext_ior": 1.0,
                                            "specular_transmittance": RGB_D}),
    ("roughdielectric ggx 0.2 int < ext", {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.2,
                                           "int_ior": 1.0, "ext_ior": 1.5}),
    ("roughdielectric beckmann 0.3 not visible", {"type": "roughdielectric", "distribution": "beckmann",
                                                  "alpha": 0.3, "sample_visible": False, "int_ior": 1.5,
                                                  "ext_ior": 1.0}),
    ("plastic default", {"type": "plastic"}),
    ("plastic rgb nonlinear", {"type": "plastic", "diffuse_reflectance": RGB_D, "nonlinear": True,
                               "int_ior": 1.6, "ext_ior": 1.0}),
    ("plastic int < ext", {"type": "plastic", "diffuse_reflectance": 0.7, "int_ior": 1.0, "ext_ior": 1.33,
                           "specular_reflectance": 0.8}),
    ("roughplastic default", {"type": "roughplastic"}),
    ("roughplastic ggx 0.001", {"type": "roughplastic", "distribution": "ggx", "alpha": 0.001,
                                "diffuse_reflectance": RGB_D}),
    ("roughplastic ggx 1 nonlinear", {"type": "roughplastic", "distribution": "ggx", "alpha": 1.0,
                                      "diffuse_reflectance": RGB_D, "nonlinear": True}),
    ("roughplastic beckmann 0.5 int < ext", {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.5,
                                             "int_ior": 1.0, "ext_ior": 1.4, "diffuse_reflectance": 0.9}),
    ("roughplastic ggx 0.3 not visible", {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
                                          "sample_visible": False, "diffuse_reflectance": RGB_D,
                                          "specular_reflectance": 0.6, "int_ior": 1.9, "ext_ior": 1.0}),
]
TWO_SIDED = ("dielectric", "thindielectric", "roughdielectric")
FIELDS = ("wo", "wi", "eval", "pdf", "u1", "u2", "s_wi", "s_pdf", "s_weight", "s_component", "s_eval",
          "s_pdf_eval")


def sphere(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def inputs(rng, plugin, n):
    """(wo, wi, u1, u2), float32: see the module's docstring."""
    wo = sphere(rng, n)
    if plugin not in TWO_SIDED:
        wo[:, 2] = np.abs(wo[:, 2])
        graze = np.arange(n) % 8 == 3
        wo[graze, 2] = rng.uniform(1e-4, 1e-2, graze.sum())
        wo[np.arange(n) % 8 == 7, 2] *= -1
        wo[graze, :2] *= (np.sqrt(1 - wo[graze, 2] ** 2) / np.linalg.norm(wo[graze, :2], axis=1))[:, None]
    wi = sphere(rng, n)
    u = rng.uniform(0, 1, (n, 3))
    f = np.float32
    return wo.astype(f), wi.astype(f), u[:, 0].astype(f), u[:, 1:].astype(f)


def record_case(mi, plugin, wo, wi, u1, u2):
    """Mitsuba's values at the points: the dict of FIELDS (float32; s_component int8)."""
    bsdf = mi.load_dict(plugin)
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    n = len(wo)
    out = {k: np.zeros((n, 3) if k in ("eval", "s_wi", "s_weight", "s_eval") else n, np.float32)
           for k in FIELDS[2:] if k not in ("u1", "u2")}
    out["s_component"] = np.zeros(n, np.int8)
    for i in range(n):
        si.wi = mi.Vector3f(*map(float, wo[i]))
        d = mi.Vector3f(*map(float, wi[i]))
        out["eval"][i] = np.array(bsdf.eval(ctx, si, d))
        out["pdf"][i] = float(bsdf.pdf(ctx, si, d))
        bs, weight = bsdf.sample(ctx, si, float(u1[i]), mi.Point2f(*map(float, u2[i])))
        out["s_wi"][i] = np.array(bs.wo)
        out["s_pdf"][i] = float(bs.pdf)
        out["s_weight"][i] = np.array(weight)
        out["s_component"][i] = int(bs.sampled_component)
        out["s_eval"][i] = np.array(bsdf.eval(ctx, si, bs.wo))
        out["s_pdf_eval"][i] = float(bsdf.pdf(ctx, si, bs.wo))
    return {"wo": wo, "wi": wi, "u1": u1, "u2": u2, **out}


def save(path, cases, points):
    """One npz: "cases" (JSON of the names and plugin dicts) and per case i the arrays "i/field", each cut to
    the first `points` points."""
    arrays = {"cases": np.array(json.dumps([{"name": n, "plugin": p} for n, p, _ in cases]))}
    for i, (_, _, values) in enumerate(cases):
        arrays.update({f"{i}/{k}": v[:points] for k, v in values.items()})
    np.savez_compressed(path, **arrays)


def load(path):
    """[(name, plugin, {field: array})] from a file save() wrote."""
    with np.load(path) as f:
        meta = json.loads(str(f["cases"]))
        return [(c["name"], c["plugin"], {k: f[f"{i}/{k}"] for k in FIELDS}) for i, c in enumerate(meta)]


def record(args):
    import drjit
    import machine  # a sibling module: this rig records as a script
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(args.seed)
    cases = []
    start = time.time()
    for name, plugin in CASES:
        values = record_case(mi, plugin, *inputs(rng, plugin["type"], args.points))
        cases.append((name, plugin, values))
        print(f"{name}: {args.points} points, {time.time() - start:.0f} s", flush=True)
    save(args.out, cases, args.points)
    save(args.fixture, cases, args.fixture_points)
    rec = {"mitsuba": mi.__version__, "drjit": drjit.__version__, "variant": mi.variant(),
           "mode": "TransportMode.Radiance (BSDFContext())", "points": args.fixture_points,
           "points_recorded": args.points, "seed": args.seed, "cases": len(cases),
           "command": " ".join([sys.executable, "devtools/peers/mitsuba_bsdf.py"] + sys.argv[1:]),
           "machine": machine.described(),
           "date": datetime.date.today().isoformat()}
    Path(args.fixture).with_suffix(".json").write_text(json.dumps(rec, indent=1) + "\n")
    print(f"{args.out}: {len(cases)} cases x {args.points}; {args.fixture}: x {args.fixture_points} "
          f"({Path(args.fixture).stat().st_size // 1024} KiB)")


def compare(args):
    """Each case's largest relative error per quantity (values above 1e-6 of the quantity's largest; the sampled
    direction's largest absolute error), the largest error / tolerance, and the largest per BSDF."""
    sys.path.insert(0, str(ROOT / "tests"))
    import bsdf_reference as ref
    columns = ("eval", "pdf", "s_eval", "s_pdf_eval", "s_pdf", "s_weight")
    worst = {}
    print(f"{'case':42s} {'n':>5s} " + " ".join(f"{k:>10s}" for k in columns + ("s_wi abs", "err/tol"))
          + "  over  flips")
    for name, plugin, values in load(args.npz):
        errors = ref.mitsuba_errors(plugin, values, seed=args.seed)
        flips = errors.pop("components")
        row = [errors[k]["max_rel"] for k in columns] + [float(errors["s_wi"]["err"].max(initial=0)),
                                                          max(float(e["excess"].max(initial=0)) for e in errors.values())]
        over = sum(int(np.sum(e["excess"] > 1)) for e in errors.values())
        print(f"{name:42s} {len(values['wo']):5d} " + " ".join(f"{v:10.2e}" for v in row)
              + f" {over:5d} {flips['flips']:3d}{'' if flips['flips_explained'] else ' unexplained'}")
        w = worst.setdefault(plugin["type"], [0.0] * len(row))
        worst[plugin["type"]] = [max(a, b) for a, b in zip(w, row)]
    print("\nlargest per BSDF")
    for plugin, w in worst.items():
        print(f"{plugin:16s} " + " ".join(f"{k}={v:.1e}" for k, v in zip(columns + ("s_wi_abs", "err/tol"), w)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="mode", required=True)
    r = sub.add_parser("record", help="with Mitsuba's python: record Mitsuba's values")
    r.add_argument("--out", default="/tmp/mitsuba_bsdf_full.npz")
    r.add_argument("--points", type=int, default=POINTS)
    r.add_argument("--fixture", default=str(FIXTURE))
    r.add_argument("--fixture-points", type=int, default=FIXTURE_POINTS)
    r.add_argument("--seed", type=int, default=20260807)
    c = sub.add_parser("compare", help="with numpy and scipy: compare a recording with the reference")
    c.add_argument("npz", nargs="?", default=str(FIXTURE))
    c.add_argument("--seed", type=int, default=0, help="of the tolerances' random draws")
    args = ap.parse_args()
    record(args) if args.mode == "record" else compare(args)


if __name__ == "__main__":
    main()
