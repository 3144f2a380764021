#!/usr/bin/env python3
"""Mitsuba 3's own tables of its roughplastic plugin (the coat's transmittance t(mu) at 64 cosines and the
internal reflectance R_int, roughplastic.cpp's parameters_changed), read back through the plugin itself, for
tests/test_bsdf_roughplastic.py's check of raytrace/scene/rough_transmittance.py (a developer rig, not a
dependency of raytrace).

Install (a venv of its own; the scalar_rgb variant needs no LLVM):
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba==3.9.1 numpy
Record, from the repository's root (writes tests/data/roughplastic_mitsuba_tables.npz and its record .json):
  /tmp/mts/bin/python devtools/peers/mitsuba_roughplastic_tables.py

The plugin keeps both values private (traverse() shows alpha, eta and the reflectances only), so they are read
from its eval: with specular_reflectance 0 only the diffuse term is left,
  eval(wo = mu_j, wi = normal) = d / (1 - R) / (pi eta^2) * t(mu_j) t(1)     (nonlinear = false)
                              = d / (1 - d R) / (pi eta^2) * t(mu_j) t(1)   (nonlinear = true),
with mu_j = max(1e-6, j / 63) in float32: the plugin's lerp_gather there (at mu = 0 the plugin gives 0, so entry 0
is read at mu = 1e-6, 6.3e-5 of the way to entry 1); the test compares it with the same interpolation. Two plugins
with nonlinear = true and d = 1 and d = 1/4 give R from the ratio of their evals at mu = 1, q = E(1) / (4 E(1/4))
= (1 - R / 4) / (1 - R): R = (q - 1) / (q - 1/4); then t(1)^2 = E(1) pi eta^2 (1 - R) and t(mu_j) = E_j / (E(1) /
t(1)), eta the plugin's float32 int_ior / ext_ior. (mi.eval_reflectance is bound in Python, but its argument,
a Vector<DynamicArray<float>, 3>, has no Python type to build it from in 3.9.1's scalar_rgb; eval_transmittance
is not bound.)
"""
import datetime
import json
import platform
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "tests" / "data" / "roughplastic_mitsuba_tables.npz"
RECORD = FIXTURE.with_suffix(".json")
RES = 64
# (distribution, alpha, int_ior, ext_ior): both distributions, alpha from 1e-3 to 1, the relative index above
# and below 1, and scenes/mitsuba/roughplastic.xml's materials (polypropylene 1.49 in air 1.000277).
CASES = [(d, a, 1.49, 1.000277) for d in ("ggx", "beckmann") for a in (0.001, 0.05, 0.3, 0.8, 1.0)] + [
    (d, a, 1.0, 1.4) for d in ("ggx", "beckmann") for a in (0.01, 0.3, 1.0)] + [
    ("ggx", 0.2, 2.4, 1.0), ("beckmann", 0.2, 1.1, 1.0), ("ggx", 0.1, 1.0, 1.05)]


def main():
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")

    def plugin(case, d, nonlinear):
        distribution, alpha, int_ior, ext_ior = case
        return mi.load_dict({"type": "roughplastic", "distribution": distribution, "alpha": alpha,
                             "int_ior": int_ior, "ext_ior": ext_ior, "nonlinear": nonlinear,
                             "diffuse_reflectance": {"type": "rgb", "value": [d, d, d]},
                             "specular_reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}})

    def evals(bsdf, mus):
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        out = []
        for mu in mus:
            mu = float(np.float32(mu))
            si.wi = mi.Vector3f(float(np.sqrt(max(0.0, 1.0 - mu * mu))), 0.0, mu)
            out.append(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(0, 0, 1))[0])
        return np.array(out, np.float64)

    mu = np.linspace(0, 1, RES, dtype=np.float32)
    tables, r_int = [], []
    for case in CASES:
        eta = float(np.float32(case[2]) / np.float32(case[3]))
        e1 = evals(plugin(case, 1.0, True), [1.0])[0]
        e4 = evals(plugin(case, 0.25, True), [1.0])[0]
        q = e1 / (4.0 * e4)
        r = (q - 1.0) / (q - 0.25)
        t1 = np.sqrt(e1 * np.pi * eta * eta * (1.0 - r))
        e = evals(plugin(case, 1.0, True), np.maximum(mu, np.float32(1e-6)))
        table = e / (e1 / t1)
        tables.append(table)
        r_int.append(r)
        print(case, "R", r, "t", table[[1, 32, 63]])
    np.savez(FIXTURE, distribution=np.array([c[0] for c in CASES]), alpha=np.array([c[1] for c in CASES]),
             int_ior=np.array([c[2] for c in CASES]), ext_ior=np.array([c[3] for c in CASES]),
             transmittance=np.array(tables), r_int=np.array(r_int))
    RECORD.write_text(json.dumps({
        "made_by": "devtools/peers/mitsuba_roughplastic_tables.py (its docstring says how the values are read)",
        "mitsuba": mi.__version__, "variant": "scalar_rgb", "python": platform.python_version(),
        "machine": platform.machine(), "date": datetime.date.today().isoformat(),
        "cases": "(distribution, alpha, int_ior, ext_ior) per row: distribution, alpha, int_ior, ext_ior",
        "transmittance": "(cases, 64): lerp_gather(t, mu_j), mu_j = max(1e-6, j / 63) in float32, read from the plugin's eval",
        "r_int": "the plugin's m_internal_reflectance, solved from two nonlinear plugins' evals"},
        indent=2) + "\n")


if __name__ == "__main__":
    main()
