#!/usr/bin/env python3
"""Judge raytrace against Mitsuba 3 per pixel on one Mitsuba XML scene (a developer rig, not a dependency of
raytrace): the same file rendered by both, raytrace by `raytrace.load_file`, Mitsuba by `mi.load_file`, and
the two images compared by devtools/judge.py's Z-test, each value's difference against its noise.

Install Mitsuba (a venv of its own; its llvm variants need Debian's libLLVM 19):
  apt-get install -y libllvm19
  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba numpy
Run from the repository's root, in raytrace's venv (Mitsuba runs in a subprocess, with --mitsuba-python):
  python -m devtools.peers.xml_check SCENE.xml [--spp N] [--ref-spp M] [--chunks K] [--out DIR]
                                     [--define name=value ...] [--write-reference [--mitsuba-only] | --use-reference]

Mitsuba renders SCENE.xml with variant llvm_ad_rgb in K renders of M / K samples, seeds 0 .. K-1
(`mi.render(scene, seed=i, spp=M // K)`): the mean of their means, and the variance of that mean, the
spread of the K means over K (var(means, ddof=1) / K, K - 1 degrees of freedom). raytrace renders it the same
way, in --rt-chunks renders (default K) of N / that many samples, seeds seed x chunks + i: a render's own
variance estimate (image.variance) is the square of one half-difference, one degree of freedom, too few
for a per-pixel test (z would be a Cauchy variate). A --define name=value (repeatable) sets the XML's $name
on both sides: Mitsuba's load_file takes it as a keyword argument, raytrace's in its `defines`.

--write-reference also writes Mitsuba's mean and variance as the committed reference next to the scene,
scenes/mitsuba/references/STEM.npz (compressed; float32 `mean` and `var`, H x W x 3, the variance of the
mean; int `spp` (the total, M) and `chunks` (K), whose K - 1 is the variance's degrees of freedom), and a
STEM.json record of how it was made: Mitsuba's version and variant, spp, chunks, seeds, defines, the command
line, the machine (lscpu's model name), the date, raytrace's commit (git rev-parse HEAD) and the seconds.
--use-reference judges against that reference instead of running Mitsuba, as judge_against_reference()
does: what the tests call on each scene of the corpus, with no Mitsuba installed. --mitsuba-only (with
--write-reference) writes the reference and stops: raytrace is not imported, rendered or judged, for a scene
of a plugin raytrace does not read yet (tests/test_mitsuba_corpus.py's PENDING); it prints Mitsuba's settings
and seconds as one JSON line.

Prints one JSON line (the verdict, devtools.judge.Verdict.as_dict(), with the settings and seconds of both
renderers) and writes DIR/STEM.json (the same) and DIR/STEM.png (raytrace | Mitsuba | the |z| map, the
failing values red, the other pixels of a failing tile orange). Exit status 0 where the image passes, 1
where it fails, 2 on an error.

Only numpy and the standard library are imported at the top: Mitsuba's Python runs this file as a script
(--mitsuba-child) for its half."""
import argparse
import datetime
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent.parent
MITSUBA_PYTHON = "/tmp/mts/bin/python"
LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
VARIANT = "llvm_ad_rgb"
CHUNKS = 16


class ChunkedMean:
    """The mean of K images and the variance of that mean, var(images, ddof=1) / K, by Welford's update in
    float64 (K images never held at once). K equal images give a variance of exactly 0."""

    def __init__(self):
        self.k, self.mean, self.m2 = 0, None, None

    def add(self, image):
        x = np.asarray(image, dtype=np.float64)
        self.k += 1
        if self.mean is None:
            self.mean, self.m2 = x.copy(), np.zeros_like(x)
            return
        delta = x - self.mean
        self.mean += delta / self.k
        self.m2 += delta * (x - self.mean)

    def variance_of_mean(self):
        if self.k < 2:
            raise ValueError("the variance of a mean of chunks needs two chunks or more")
        return self.m2 / (self.k - 1) / self.k


def parse_defines(pairs):
    """{name: value} from ["name=value", ...] (values as strings, as -D gives them)."""
    defines = {}
    for pair in pairs or ():
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise ValueError(f"--define {pair!r}: expected name=value")
        defines[name] = value
    return defines


def split_spp(spp, chunks, what):
    if chunks < 2 or spp % chunks:
        raise ValueError(f"{what}: {spp} samples in {chunks} chunks: need 2 chunks or more, dividing the samples")
    return spp // chunks


# --- Mitsuba's half: run by Mitsuba's Python -------------------------------------------------------------------

def mitsuba_child(argv):
    """In Mitsuba's Python: render the scene in chunks and write the npz (mean, var, spp, chunks, version,
    variant, seconds)."""
    ap = argparse.ArgumentParser(prog="xml_check.py --mitsuba-child")
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--chunks", type=int, required=True)
    ap.add_argument("--variant", default=VARIANT)
    ap.add_argument("--define", action="append", default=[])
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    per_chunk = split_spp(a.spp, a.chunks, "--ref-spp")
    import mitsuba as mi
    mi.set_variant(a.variant)
    t = time.perf_counter()
    scene = mi.load_file(a.scene, **parse_defines(a.define))
    load_s, t = time.perf_counter() - t, time.perf_counter()
    acc, first_s = ChunkedMean(), None
    for seed in range(a.chunks):
        image = np.array(mi.render(scene, seed=seed, spp=per_chunk))
        acc.add(image[..., :3])  # an rgba film's alpha dropped
        if first_s is None:
            first_s = time.perf_counter() - t  # with the kernels' compilation
    render_s = time.perf_counter() - t
    np.savez(a.out, mean=acc.mean, var=acc.variance_of_mean(), spp=a.spp, chunks=a.chunks,
             version=mi.__version__, variant=a.variant, load_s=load_s, first_chunk_s=first_s, render_s=render_s)


def run_mitsuba(scene, spp, chunks, defines=None, python=MITSUBA_PYTHON, variant=VARIANT):
    """Mitsuba's half in a subprocess of `python`: {mean, var (float64 H x W x 3), spp, chunks, version, variant,
    load_s, first_chunk_s, render_s, wall_s}. Its output goes to this process's stderr."""
    env = dict(os.environ)
    env.setdefault("DRJIT_LIBLLVM_PATH", LIBLLVM)
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, "mitsuba.npz")
        command = [python, str(Path(__file__).resolve()), "--mitsuba-child", str(scene), "--spp", str(spp),
                   "--chunks", str(chunks), "--variant", variant, "--out", out]
        command += [f"--define={k}={v}" for k, v in (defines or {}).items()]
        t = time.perf_counter()
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        wall_s = time.perf_counter() - t
        sys.stderr.write(done.stdout + done.stderr)
        if done.returncode != 0:
            raise RuntimeError(f"Mitsuba's half failed (status {done.returncode}): {shlex.join(command)}")
        with np.load(out) as data:
            result = {k: data[k] if data[k].ndim else data[k].item() for k in data.files}
    result["wall_s"] = wall_s
    return result


# --- raytrace's half --------------------------------------------------------------------------------------------

def load_raytrace(scene, defines=None):
    import raytrace
    return raytrace.load_file(str(scene), defines=defines) if defines else raytrace.load_file(str(scene))


def render_raytrace(scene, spp, chunks=CHUNKS, seed=0, defines=None):
    """(mean, variance of the mean (float64 H x W x 3), {spp, chunks, seeds, load_s, first_chunk_s, render_s}):
    raytrace's render of the scene file in `chunks` renders of spp / chunks samples, seeds seed x chunks + i."""
    import raytrace
    per_chunk = split_spp(spp, chunks, "--spp")
    t = time.perf_counter()
    model = load_raytrace(scene, defines)
    load_s, t = time.perf_counter() - t, time.perf_counter()
    acc, first_s = ChunkedMean(), None
    seeds = [seed * chunks + i for i in range(chunks)]
    for s in seeds:
        image, _ = raytrace.render(model, spp=per_chunk, seed=s)
        acc.add(image)
        if first_s is None:
            first_s = time.perf_counter() - t
    render_s = time.perf_counter() - t
    return acc.mean, acc.variance_of_mean(), {"spp": spp, "chunks": chunks, "seeds": [seeds[0], seeds[-1]],
                                              "load_s": load_s, "first_chunk_s": first_s, "render_s": render_s}


# --- the reference ----------------------------------------------------------------------------------------------

def reference_path(scene):
    """Where the committed reference of a scene file lives: references/STEM.npz beside it."""
    scene = Path(scene)
    return scene.parent / "references" / (scene.stem + ".npz")


def _lscpu_model():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or platform.machine()
    return next((line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name")),
                platform.machine())


def _commit():
    done = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else None


def write_reference(scene, mts, defines, argv, path=None):
    """Write Mitsuba's result `mts` (run_mitsuba's) as the scene's reference npz and its json record; returns
    the npz's path."""
    path = Path(path) if path else reference_path(scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, mean=mts["mean"].astype(np.float32), var=mts["var"].astype(np.float32),
                        spp=np.int64(mts["spp"]), chunks=np.int64(mts["chunks"]))
    record = {"scene": _relative(scene), "mitsuba_version": mts["version"], "variant": mts["variant"],
              "spp": int(mts["spp"]), "chunks": int(mts["chunks"]), "seeds": [0, int(mts["chunks"]) - 1],
              "defines": defines or {}, "width": int(mts["mean"].shape[1]), "height": int(mts["mean"].shape[0]),
              "command": shlex.join(argv), "machine": _lscpu_model(), "cores": os.cpu_count(),
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "raytrace_commit": _commit(),
              "seconds": {k: round(float(mts[k]), 3) for k in ("load_s", "first_chunk_s", "render_s", "wall_s")}}
    path.with_suffix(".json").write_text(json.dumps(record, indent=2) + "\n")
    return path


def load_reference(path):
    """{mean, var (float64), spp, chunks, defines} of a reference npz (and its json record's defines)."""
    path = Path(path)
    with np.load(path) as data:
        ref = {"mean": data["mean"].astype(np.float64), "var": data["var"].astype(np.float64),
               "spp": int(data["spp"]), "chunks": int(data["chunks"])}
    record = path.with_suffix(".json")
    ref["defines"] = json.loads(record.read_text()).get("defines", {}) if record.is_file() else {}
    return ref


def _relative(path):
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def _shapes_match(mean, ref, scene):
    if mean.shape != ref.shape:
        raise ValueError(f"{scene}: raytrace's image is {mean.shape}, the reference's {ref.shape}")


def judge_against_reference(scene_path, spp, seed=0, *, chunks=CHUNKS, reference=None, alpha=0.01,
                            pass_fraction=0.9975):
    """Render the scene file with raytrace (spp samples in `chunks` renders, render_raytrace) and judge it
    against its committed reference (default reference_path(scene_path); rendered with the defines its json
    record names): the devtools.judge Verdict. No Mitsuba needed."""
    from devtools.judge import judge
    ref = load_reference(reference or reference_path(scene_path))
    mean, var, _ = render_raytrace(scene_path, spp, chunks, seed, ref["defines"])
    _shapes_match(mean, ref["mean"], scene_path)
    return judge(mean, var, ref["mean"], ref["var"], alpha, pass_fraction, dof=chunks - 1,
                 ref_dof=ref["chunks"] - 1)


# --- the command ------------------------------------------------------------------------------------------------

def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(prog="python -m devtools.peers.xml_check", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="a Mitsuba 3 XML scene file")
    ap.add_argument("--spp", type=int, default=256, help="raytrace's samples per pixel (default 256)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="Mitsuba's samples per pixel (default 4096)")
    ap.add_argument("--chunks", type=int, default=CHUNKS, help=f"Mitsuba's renders (default {CHUNKS})")
    ap.add_argument("--rt-chunks", type=int, help="raytrace's renders (default: --chunks)")
    ap.add_argument("--seed", type=int, default=0, help="raytrace's seeds are seed x chunks + i (default 0)")
    ap.add_argument("--define", action="append", default=[], metavar="NAME=VALUE",
                    help="the XML's $NAME, on both sides (repeatable)")
    ap.add_argument("--out", default="xml_check", help="the folder of STEM.png and STEM.json (default xml_check)")
    ap.add_argument("--alpha", type=float, default=0.01)
    ap.add_argument("--pass-fraction", type=float, default=0.9975)
    ap.add_argument("--mitsuba-python", default=MITSUBA_PYTHON)
    ap.add_argument("--variant", default=VARIANT)
    source = ap.add_mutually_exclusive_group()
    source.add_argument("--write-reference", action="store_true",
                        help="also write Mitsuba's result as references/STEM.npz and .json beside the scene")
    source.add_argument("--use-reference", action="store_true",
                        help="judge against references/STEM.npz instead of running Mitsuba")
    ap.add_argument("--mitsuba-only", action="store_true",
                    help="with --write-reference: write it, and neither render nor judge raytrace")
    a = ap.parse_args(argv)
    if a.mitsuba_only and not a.write_reference:
        ap.error("--mitsuba-only needs --write-reference")
    errors = (ValueError, RuntimeError, OSError)
    if not a.mitsuba_only:  # raytrace is not imported where it neither renders nor is judged
        import raytrace
        from devtools.judge import judge, side_by_side
        errors += (raytrace.InputError,)
    scene = Path(a.scene)
    rt_chunks = a.rt_chunks or a.chunks
    try:
        defines = parse_defines(a.define)
        split_spp(a.spp, rt_chunks, "--spp")
        if a.use_reference:
            ref = load_reference(reference_path(scene))
            defines = defines or ref["defines"]
            mitsuba = {"source": str(_relative(reference_path(scene))), "spp": ref["spp"], "chunks": ref["chunks"]}
        else:
            split_spp(a.ref_spp, a.chunks, "--ref-spp")
            ref = run_mitsuba(scene, a.ref_spp, a.chunks, defines, a.mitsuba_python, a.variant)
            mitsuba = {"source": "render", **{k: ref[k] for k in ("spp", "chunks", "version", "variant")},
                       **{k: round(float(ref[k]), 3) for k in ("load_s", "first_chunk_s", "render_s", "wall_s")}}
            if a.write_reference:
                mitsuba["reference"] = _relative(write_reference(scene, ref, defines,
                                                                 ["python", "-m", "devtools.peers.xml_check", *argv]))
            if a.mitsuba_only:
                print(json.dumps({"scene": _relative(scene), "defines": defines, "mitsuba": mitsuba}))
                return 0
        mean, var, rt = render_raytrace(scene, a.spp, rt_chunks, a.seed, defines)
        _shapes_match(mean, ref["mean"], scene)
    except errors as e:
        print(f"xml_check: error: {e}", file=sys.stderr)
        return 2
    verdict = judge(mean, var, ref["mean"], ref["var"], a.alpha, a.pass_fraction, dof=rt_chunks - 1,
                    ref_dof=ref["chunks"] - 1)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    side_by_side(mean, ref["mean"], verdict.z, out / (scene.stem + ".png"), verdict.threshold,
                 flagged=verdict.failing_tiles())
    record = {"scene": _relative(scene), "verdict": verdict.as_dict(), "defines": defines,
              "raytrace": {k: round(v, 3) if isinstance(v, float) else v for k, v in rt.items()},
              "mitsuba": mitsuba, "png": str(out / (scene.stem + ".png"))}
    (out / (scene.stem + ".json")).write_text(json.dumps(record, indent=2) + "\n")
    print(json.dumps(record))
    return 0 if verdict.passed else 1


if __name__ == "__main__":
    if sys.argv[1:2] == ["--mitsuba-child"]:
        mitsuba_child(sys.argv[2:])
    else:
        sys.exit(main())
