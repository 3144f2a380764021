#!/usr/bin/env python3
"""Mitsuba 3's own conversions of spectra to RGB, recorded for tests/test_spectra.py (a developer rig, not a
dependency of raytrace): what raytrace/scene/spectra.py and raytrace/scene/named_materials.py must reproduce.

Install (a venv of its own; Mitsuba's llvm variants need Debian's libLLVM 19):
  apt-get install -y libllvm19
  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba numpy
Run from the repository's root (it writes tests/data/mitsuba_spectra.json):
  /tmp/mts/bin/python devtools/peers/mitsuba_spectra.py

Each case is a `<spectrum>` given to a plugin in Mitsuba's XML (a BSDF's reflectance, an emitter's radiance
or irradiance, a conductor's eta or k), the scene loaded by mi.load_string in every variant of --variants
(scalar_rgb and llvm_ad_rgb: the conversion is the scene loader's, so they must agree, and the script stops
if they do not), and the value read back with mi.traverse, as Mitsuba stores it (float32). Values are
written with repr, so Mitsuba parses the very doubles the JSON holds. The named materials are read the same
way: every name of dielectric's int_ior (the list Mitsuba's own error message gives for an unknown name, each
read back as the eta of that material against vacuum) and every conductor preset (the files of Mitsuba's
data/ior folder, and "none"), as the eta and k textures the rgb variants make of them; the spectra of two
(Au and Cu, PRESETS) are copied whole, so that a test can integrate them itself.
"""
import argparse
import datetime
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import mitsuba as mi

import machine

OUT = Path(__file__).resolve().parents[2] / "tests" / "data" / "mitsuba_spectra.json"
PRESETS = ("Au", "Cu")

# Where a case's spectrum goes, "plugin.parameter": (the plugin's kind, the role to_rgb is given).
PLUGINS = {"diffuse.reflectance": ("bsdf", "reflectance"), "area.radiance": ("emitter", "emission"),
           "constant.radiance": ("emitter", "emission"), "directional.irradiance": ("emitter", "emission"),
           "conductor.eta": ("bsdf", "unbounded"), "roughconductor.k": ("bsdf", "unbounded")}


def smooth(lo, hi, step, f):
    return [[float(w), float(f(w))] for w in np.arange(lo, hi + step / 2, step)]


def cases():
    """(name, plugin, spectrum, .spd text or None): every path of the conversion, its edges included."""
    rng = np.random.default_rng(7)
    ripple = lambda w: 0.5 + 0.4 * np.sin(w / 23.0)  # noqa: E731
    irregular = np.cumsum(rng.uniform(0.3, 17.0, 60)) + 352.0
    noisy = [[float(w), float(v)] for w, v in zip(irregular, rng.uniform(0.0, 1.0, 60))]
    flat = [[360.0, 1.0], [830.0, 1.0]]
    green = [[500.0, 0.0], [525.0, 1.0], [550.0, 0.0]]  # narrow band: beyond sRGB's gamut, r and b < 0
    spd = "# wavelength value\n\n400 0.1\n450\t0.7  # a comment\n+500 .25\n600 9e-1\n700 3E-1\n"
    return [
        ("uniform reflectance", "diffuse.reflectance", 0.5, None),
        ("uniform reflectance above 1 (kept)", "diffuse.reflectance", 1.5, None),
        ("uniform radiance", "area.radiance", 0.1, None),
        ("uniform radiance 3", "constant.radiance", 3.0, None),
        ("uniform irradiance", "directional.irradiance", 2.5, None),
        ("uniform eta", "conductor.eta", 0.2, None),
        ("flat reflectance", "diffuse.reflectance", flat, None),
        ("flat radiance", "area.radiance", flat, None),
        ("flat eta", "conductor.eta", flat, None),
        ("three pairs", "diffuse.reflectance", [[400.0, 0.1], [500.0, 0.9], [700.0, 0.3]], None),
        ("81 pairs, 380-780 nm", "diffuse.reflectance", smooth(380, 780, 5, ripple), None),
        ("81 pairs as radiance", "constant.radiance", smooth(380, 780, 5, lambda w: 10 * ripple(w)), None),
        ("60 irregular pairs", "diffuse.reflectance", noisy, None),
        ("60 irregular pairs as radiance", "area.radiance", noisy, None),
        ("partly outside 360-830", "diffuse.reflectance", [[300.0, 0.2], [450.0, 0.8], [900.0, 0.4]], None),
        ("partly outside, radiance", "area.radiance", [[200.0, 5.0], [600.0, 1.0], [1000.0, 2.0]], None),
        ("ends inside 360-830", "diffuse.reflectance", [[412.3, 0.6], [655.55, 0.4]], None),
        ("wholly outside", "diffuse.reflectance", [[900.0, 1.0], [1000.0, 1.0]], None),
        ("green out of gamut, clamped to [0, 1]", "diffuse.reflectance", green, None),
        ("bright green out of gamut", "diffuse.reflectance", [[w, 4 * v] for w, v in green], None),
        ("green radiance, clamped at 0", "area.radiance", [[w, 40 * v] for w, v in green], None),
        ("green eta, clamped at 0", "conductor.eta", [[w, 3 * v] for w, v in green], None),
        ("k spectrum", "roughconductor.k", smooth(360, 830, 47, lambda w: 1 + w / 200), None),
        ("negative radiance list", "constant.radiance", [[400.0, -1.0], [700.0, -2.0]], None),
        ("spd reflectance", "diffuse.reflectance", None, spd),
        ("spd radiance", "area.radiance", None, spd),
    ]


def rgb(params, key):
    """A texture's value as Mitsuba stores it, 3 floats (a uniform texture holds one)."""
    got = [float(x) for x in np.atleast_1d(np.array(params[key], np.float64)).ravel()]
    return got * 3 if len(got) == 1 else got


def spectra(folder):
    rows = []
    for name, plugin, spectrum, spd in cases():
        (kind, role), (plugin_type, parameter) = PLUGINS[plugin], plugin.split(".")
        if spd is not None:
            path = Path(folder) / f"case{len(rows)}.spd"
            path.write_text(spd)
            attribute = f'filename="{path}"'
        else:
            text = repr(spectrum) if isinstance(spectrum, float) else ", ".join(f"{w!r}:{v!r}" for w, v in spectrum)
            attribute = f'value="{text}"'
        xml = (f'<{kind} version="3.0.0" type="{plugin_type}"><spectrum name="{parameter}" {attribute}/>'
               f'</{kind}>')
        row = {"name": name, "plugin": plugin, "role": role,
               "rgb": rgb(mi.traverse(mi.load_string(xml)), f"{parameter}.value")}
        rows.append({**row, **({"spd": spd} if spd is not None else {"spectrum": spectrum})})
    return rows


def ior_names():
    """The names dielectric's int_ior accepts, from Mitsuba's own error message for one it does not."""
    try:
        mi.load_dict({"type": "dielectric", "int_ior": "no such material"})
    except RuntimeError as e:
        return [n.strip() for n in str(e).split("Valid choices are:")[1].split(",")]
    raise SystemExit("Mitsuba accepted an unknown IOR name")


def named():
    iors = {}
    for name in ior_names():
        params = mi.traverse(mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"}))
        iors[name] = float(params["eta"])
    folder = Path(mi.__file__).parent / "data" / "ior"
    presets = sorted({p.name.split(".")[0] for p in folder.glob("*.eta.spd")}) + ["none"]
    conductors = {}
    for name in presets:
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        conductors[name] = [rgb(params, "eta.value"), rgb(params, "k.value")]
    spd = {name: {part: (folder / f"{name}.{part}.spd").read_text() for part in ("eta", "k")} for name in PRESETS}
    return {"ior": iors, "conductors": conductors, "preset_spd": spd}


def dumped(doc):
    """The JSON text with one case, IOR or preset a line: a diff shows what changed."""
    def block(key, value):
        if isinstance(value, list):
            return f'"{key}": [\n' + ",\n".join("  " + json.dumps(v) for v in value) + "\n ]"
        return f'"{key}": {{\n' + ",\n".join(f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in value.items()) + "\n }"
    return "{\n" + ",\n".join(" " + block(key, value) for key, value in doc.items()) + "\n}\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", nargs="+", default=["scalar_rgb", "llvm_ad_rgb"])
    ap.add_argument("--out", default=str(OUT))
    args = ap.parse_args()
    results = []
    with tempfile.TemporaryDirectory() as folder:
        for variant in args.variants:
            mi.set_variant(variant)
            mi.set_log_level(mi.LogLevel.Error)  # the clamping warnings are expected
            results.append({"cases": spectra(folder), **named()})
    for variant, other in zip(args.variants[1:], results[1:]):
        if other != results[0]:
            raise SystemExit(f"{variant} and {args.variants[0]} disagree")
    import drjit
    record = {"mitsuba": mi.__version__, "drjit": drjit.__version__, "variants": args.variants,
              "command": " ".join([sys.executable, "devtools/peers/mitsuba_spectra.py"] + sys.argv[1:]),
              "machine": machine.described(),
              "date": datetime.date.today().isoformat()}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(dumped({"record": record, **results[0]}))
    print(f"{args.out}: {len(results[0]['cases'])} spectra, {len(results[0]['ior'])} IOR names, "
          f"{len(results[0]['conductors'])} conductor presets")


if __name__ == "__main__":
    main()
