#!/usr/bin/env python3
"""Mitsuba 3's AOVs of a scene whose integrator is Mitsuba's `aov` (src/integrators/aov.cpp): the reference
tests/test_aov_mitsuba.py judges raytrace's AOVs against (a developer rig, not a dependency of raytrace; the
beauty is the corpus's, devtools/peers/xml_check.py's).

Run it with Mitsuba's Python (install as xml_check.py's header says), from the repository's root:
  /tmp/mts/bin/python devtools/peers/aov_reference.py scenes/mitsuba/aov.xml [--spp 256] [--chunks 16]
                                                      [--variant scalar_rgb] [--out PATH.npz]

Mitsuba renders the scene in K renders of N / K samples, seeds 0 .. K-1 (`mi.render(scene, seed=i,
spp=N // K)`), and reads each render's film by channel name (film.bitmap(): the inner integrator's channels,
then each AOV's NAME.R ... in the `aovs` order). Written (default scenes/mitsuba/references/channels/STEM.npz,
compressed; a folder of its own, so that the corpus's references, one per scene, keep their names): per AOV
NAME the float32 H x W x C mean of the K means (`NAME`) and the variance of that mean (`NAME.var`:
var(means, ddof=1) / K), `aovs` (the integrator's aovs string, whose types say what each NAME holds), int
`spp` (N) and `chunks` (K); and STEM.json beside it (Mitsuba's version and variant, the spp, chunks, seeds,
the command line, the machine, the date, raytrace's commit, the seconds, as the corpus's records).

The variant is scalar_rgb by default: its shape_index numbers scene->shapes() from 1 (0: nothing hit), where
the JIT variants (llvm_*, cuda_*) write each shape's registry id reinterpreted as a float. Either way the
numbers are labels, compared through a one-to-one map between the two renderers' numberings."""
import argparse
import datetime
import json
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import xml_check  # its helpers: numpy and the standard library only, fine in Mitsuba's Python

VARIANT = "scalar_rgb"


def default_out(scene):
    scene = Path(scene)
    return scene.parent / "references" / "channels" / (scene.stem + ".npz")


def aov_names(film_channels, aovs):
    """{NAME: [the film's channel indices]} of each AOV of the `aovs` string, in its order, from the names of
    the film's channels (NAME.R, NAME.G, ...)."""
    out = {}
    for item in aovs.split(","):
        name = item.split(":")[0].strip()
        out[name] = [i for i, c in enumerate(film_channels) if c.rpartition(".")[0] == name]
        if not out[name]:
            raise SystemExit(f"aov_reference: the film has no channel of the AOV {name!r}: {film_channels}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="a Mitsuba 3 XML scene whose integrator is aov")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel in all (default 256)")
    ap.add_argument("--chunks", type=int, default=16, help="renders of spp / chunks each (default 16)")
    ap.add_argument("--variant", default=VARIANT, help=f"Mitsuba's variant (default {VARIANT})")
    ap.add_argument("--out", help="the npz written (default references/channels/STEM.npz beside the scene)")
    a = ap.parse_args()
    per_chunk = xml_check.split_spp(a.spp, a.chunks, "--spp")
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", xml_check.LIBLLVM)
    import mitsuba as mi
    mi.set_variant(a.variant)
    t = time.perf_counter()
    scene = mi.load_file(a.scene)
    load_s, t0 = time.perf_counter() - t, time.perf_counter()
    acc, first_s, channels = xml_check.ChunkedMean(), None, None
    for seed in range(a.chunks):
        mi.render(scene, seed=seed, spp=per_chunk)
        bitmap = scene.sensors()[0].film().bitmap()
        fields = bitmap.struct_()
        channels = [fields[i].name for i in range(len(fields))]
        acc.add(np.array(bitmap))
        if first_s is None:
            first_s = time.perf_counter() - t0
    render_s = time.perf_counter() - t0
    aovs = _aovs_string(a.scene)
    mean, var = acc.mean, acc.variance_of_mean()
    out = Path(a.out) if a.out else default_out(a.scene)
    out.parent.mkdir(parents=True, exist_ok=True)
    arrays = {}
    for name, at in aov_names(channels, aovs).items():
        arrays[name] = mean[..., at].astype(np.float32)
        arrays[name + ".var"] = var[..., at].astype(np.float32)
    np.savez_compressed(out, **arrays, aovs=np.str_(aovs), spp=np.int64(a.spp), chunks=np.int64(a.chunks))
    record = {"scene": xml_check._relative(a.scene), "mitsuba_version": mi.__version__, "variant": a.variant,
              "spp": a.spp, "chunks": a.chunks, "seeds": [0, a.chunks - 1], "aovs": aovs,
              "film_channels": channels, "width": int(mean.shape[1]), "height": int(mean.shape[0]),
              "command": shlex.join(["/tmp/mts/bin/python", "devtools/peers/aov_reference.py", *sys.argv[1:]]),
              "machine": xml_check._lscpu_model(), "cores": os.cpu_count(),
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "raytrace_commit": xml_check._commit(),
              "seconds": {"load_s": round(load_s, 3), "first_chunk_s": round(first_s, 3),
                          "render_s": round(render_s, 3)}}
    out.with_suffix(".json").write_text(json.dumps(record, indent=2) + "\n")
    print(json.dumps({"npz": str(out), **{k: record[k] for k in ("variant", "spp", "chunks", "seconds")}}))


def _aovs_string(scene):
    """The `aovs` string of the scene file's aov integrator (Mitsuba's plugin keeps it to itself)."""
    import xml.etree.ElementTree as ET
    for node in ET.parse(scene).getroot().iter("integrator"):
        if node.get("type") == "aov":
            for child in node.findall("string"):
                if child.get("name") == "aovs":
                    return child.get("value")
    raise SystemExit(f"aov_reference: {scene} has no aov integrator with an aovs string")


if __name__ == "__main__":
    main()
