#!/usr/bin/env python3
"""Mitsuba 3's own values of its `principled` BSDF, recorded for tests/test_bsdf_principled.py, which checks the
float64 reference tests/principled_reference.py against them (a developer rig, not a dependency of raytrace;
devtools/peers/mitsuba_bsdf.py's companion, with its inputs and fields); with --thin, of its `principledthin`
for tests/test_bsdf_principledthin.py and tests/principledthin_reference.py (THIN_CASES; wo uniform on the sphere,
the sheet being the same from both sides).

Record, from the repository's root, with Mitsuba's python (the scalar_rgb variant needs no LLVM; writes
tests/data/mitsuba_principled_values.npz and its record tests/data/mitsuba_principled_values.json, with --thin
tests/data/mitsuba_principledthin_values.npz and .json):
  /tmp/mts/bin/python devtools/peers/mitsuba_principled.py [--thin]

Each case is a plugin dict given to mi.load_dict (variant scalar_rgb, float32; the principled bare, not in
twosided, so that its inside is Mitsuba's), and per point (mitsuba_bsdf.py's FIELDS): wo the viewer's direction
(Mitsuba's si.wi, si.sh_frame the identity), wi a direction uniform on the sphere, eval and pdf there, and a
sample from (u1, u2) with eval and pdf at its direction. wo: 7/8 on the upper hemisphere (an eighth of those
within 1e-2 of the horizon) and 1/8 below it; uniform on the sphere for the cases with spec_trans."""
import argparse
import datetime
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mitsuba_bsdf  # noqa: E402  (a sibling module: this rig records as a script)

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "data" / "mitsuba_principled_values.npz"
THIN_FIXTURE = ROOT / "tests" / "data" / "mitsuba_principledthin_values.npz"
POINTS = 256
RED = {"type": "rgb", "value": [0.8, 0.2, 0.1]}
BLUE = {"type": "rgb", "value": [0.2, 0.5, 0.8]}

# (name, plugin dict): each lobe alone and mixed, the extremes of roughness, metal, glass and eta below 1, flatness.
CASES = [
    ("default", {"type": "principled"}),
    ("diffuse rough sheen tinted", {"type": "principled", "base_color": RED, "roughness": 1.0, "sheen": 1.0,
                                    "sheen_tint": 0.7}),
    ("metallic 1 roughness 0.2", {"type": "principled", "base_color": {"type": "rgb", "value": [0.95, 0.64, 0.54]},
                                  "metallic": 1.0, "roughness": 0.2}),
    ("glossy dielectric spec_tint", {"type": "principled", "base_color": BLUE, "roughness": 0.05,
                                     "specular": 0.8, "spec_tint": 0.6}),
    ("clearcoat gloss 0.9", {"type": "principled", "base_color": BLUE, "roughness": 0.7, "clearcoat": 1.0,
                             "clearcoat_gloss": 0.9, "clearcoat_sampling_rate": 2.0}),
    ("anisotropic 0.8 metallic 0.5", {"type": "principled", "base_color": RED, "roughness": 0.4,
                                      "anisotropic": 0.8, "metallic": 0.5}),
    ("glass spec_trans 1 eta 1.5", {"type": "principled", "base_color": {"type": "rgb", "value": [0.9, 0.9, 0.8]},
                                    "roughness": 0.3, "spec_trans": 1.0, "eta": 1.5}),
    ("spec_trans 0.6 eta 0.8 mixed", {"type": "principled", "base_color": BLUE, "roughness": 0.5,
                                      "spec_trans": 0.6, "eta": 0.8, "metallic": 0.2, "clearcoat": 0.5,
                                      "sheen": 0.5, "anisotropic": 0.4}),
    ("roughness 0 spec_trans 0.5", {"type": "principled", "base_color": RED, "roughness": 0.0, "spec_trans": 0.5,
                                    "specular": 0.3}),
    ("everything, rates", {"type": "principled", "base_color": RED, "roughness": 0.8, "anisotropic": 0.3,
                           "metallic": 0.3, "spec_trans": 0.3, "specular": 0.6, "spec_tint": 0.4, "sheen": 0.6,
                           "sheen_tint": 0.3, "clearcoat": 0.7, "clearcoat_gloss": 0.4,
                           "main_specular_sampling_rate": 0.5, "clearcoat_sampling_rate": 0.3,
                           "diffuse_reflectance_sampling_rate": 2.0}),
    # flatness (the fake subsurface): all of it, half at roughness 0 (Fss90 = 0) with a sheen, and among the other
    # lobes with transmission (last, so that the cases above keep their inputs)
    ("flatness 1 roughness 0.8", {"type": "principled", "base_color": RED, "roughness": 0.8, "flatness": 1.0}),
    ("flatness 0.5 roughness 0 sheen", {"type": "principled", "base_color": BLUE, "roughness": 0.0,
                                        "flatness": 0.5, "sheen": 0.4, "specular": 0.3}),
    ("flatness 0.7 mixed", {"type": "principled", "base_color": RED, "roughness": 0.6, "flatness": 0.7,
                            "metallic": 0.3, "spec_trans": 0.4, "clearcoat": 0.5, "anisotropic": 0.3}),
]

GREEN = {"type": "rgb", "value": [0.3, 0.6, 0.2]}
# principledthin's: each lobe alone and mixed, flatness, diff_trans at 1 and 2, eta below 1 and at 1, roughness 0,
# anisotropic, the four rates.
THIN_CASES = [
    ("thin default", {"type": "principledthin"}),
    ("thin diffuse sheen tinted flatness", {"type": "principledthin", "base_color": RED, "roughness": 0.9,
                                            "sheen": 1.0, "sheen_tint": 0.6, "flatness": 0.7}),
    ("thin diff_trans 1", {"type": "principledthin", "base_color": GREEN, "roughness": 0.4, "diff_trans": 1.0}),
    ("thin diff_trans 2 flatness 1", {"type": "principledthin", "base_color": GREEN, "diff_trans": 2.0,
                                      "flatness": 1.0}),
    ("thin spec_trans 1 eta 1.5", {"type": "principledthin", "base_color": {"type": "rgb", "value": [0.9, 0.9, 0.8]},
                                   "roughness": 0.3, "spec_trans": 1.0}),
    ("thin spec_trans 0.7 eta 0.8 spec_tint", {"type": "principledthin", "base_color": BLUE, "roughness": 0.5,
                                               "spec_trans": 0.7, "eta": 0.8, "spec_tint": 0.5}),
    ("thin anisotropic 0.8 spec_trans 0.5", {"type": "principledthin", "base_color": RED, "roughness": 0.6,
                                             "anisotropic": 0.8, "spec_trans": 0.5, "eta": 1.33, "diff_trans": 0.6}),
    ("thin roughness 0 spec_trans 0.4", {"type": "principledthin", "base_color": RED, "roughness": 0.0,
                                         "spec_trans": 0.4, "eta": 2.0}),
    ("thin eta 1 spec_trans 0.8", {"type": "principledthin", "base_color": GREEN, "roughness": 0.35,
                                   "spec_trans": 0.8, "eta": 1.0, "diff_trans": 0.5}),
    ("thin everything, rates", {"type": "principledthin", "base_color": BLUE, "roughness": 0.7, "anisotropic": 0.3,
                                "spec_trans": 0.4, "eta": 1.45, "spec_tint": 0.3, "sheen": 0.6, "sheen_tint": 0.4,
                                "flatness": 0.5, "diff_trans": 1.3, "diffuse_reflectance_sampling_rate": 2.0,
                                "specular_reflectance_sampling_rate": 0.5,
                                "specular_transmittance_sampling_rate": 3.0,
                                "diffuse_transmittance_sampling_rate": 0.25}),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=POINTS)
    ap.add_argument("--thin", action="store_true", help="principledthin's cases (THIN_CASES)")
    ap.add_argument("--out", default=None, help="default: the fixture of the cases recorded")
    ap.add_argument("--seed", type=int, default=20261129)
    args = ap.parse_args()
    args.out = args.out or str(THIN_FIXTURE if args.thin else FIXTURE)
    import drjit
    import machine
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(args.seed)
    cases, start = [], time.time()
    for name, plugin in THIN_CASES if args.thin else CASES:
        two_sided = "dielectric" if plugin.get("spec_trans", 0) or args.thin else "principled"  # wo: the sphere
        values = mitsuba_bsdf.record_case(mi, plugin, *mitsuba_bsdf.inputs(rng, two_sided, args.points))
        cases.append((name, plugin, values))
        print(f"{name}: {args.points} points, {time.time() - start:.0f} s", flush=True)
    mitsuba_bsdf.save(args.out, cases, args.points)
    rec = {"mitsuba": mi.__version__, "drjit": drjit.__version__, "variant": mi.variant(),
           "mode": "TransportMode.Radiance (BSDFContext())", "points": args.points, "seed": args.seed,
           "cases": len(cases), "command": " ".join([sys.executable, "devtools/peers/mitsuba_principled.py"]
                                                    + sys.argv[1:]),
           "machine": machine.described(), "date": datetime.date.today().isoformat()}
    Path(args.out).with_suffix(".json").write_text(json.dumps(rec, indent=1) + "\n")
    print(f"{args.out}: {len(cases)} cases x {args.points} ({Path(args.out).stat().st_size // 1024} KiB)")


if __name__ == "__main__":
    main()
