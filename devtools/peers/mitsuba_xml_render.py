#!/usr/bin/env python3
"""Mitsuba 3 on any Mitsuba XML scene file, with the sampler and sample count asked: the measuring peer of
`converge --peer` for the scenes raytrace reads as Mitsuba does (scenes/mitsuba/; a developer rig, not a
dependency of raytrace).

Install (a venv of its own; Mitsuba's llvm variants need Debian's libLLVM 19):
  apt-get install -y libllvm19
  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
  python3 -m venv /tmp/mts && /tmp/mts/bin/pip install mitsuba numpy
Run from anywhere (the scene's relative paths are the scene file's), e.g. converge's peer on the Cornell box at
128 x 128, and a reference of 16 renders of 1024 samples:
  python -m raytrace converge scenes/mitsuba/cornell_box.xml --width 128 --height 128 ... \
      --peer "MTS/bin/python devtools/peers/mitsuba_xml_render.py scenes/mitsuba/cornell_box.xml -D res=128 \
              --sampler {sampler} --spp {spp} --out {out} --repeats 3"
  MTS/bin/python devtools/peers/mitsuba_xml_render.py scenes/mitsuba/cornell_box.xml -D res=128 \
      --sampler multijitter --spp 1024 --chunks 16 --out REFERENCE.exr

The file is read as mi.load_file reads it (Mitsuba's own parser: includes, $name defaults, -D name=value as
load_file's keyword arguments, the same transforms and instantiation), with one change made to the parsed
scene before it is instantiated: every sensor's sampler is replaced by --sampler with sample_count --spp and
nothing else (a sensor without one gets it), whatever the file says, because the sampler is what converge
measures. The film (its size, pixel filter, pixel format), the integrator and everything else are the file's;
--width and --height set the film's size where the file has no $res parameter to set it with -D. A `$spp`
in the file is not needed: the sampler is replaced whole (a -D spp=N of a file that uses it changes nothing).

The renders (mi.render, sensor 0): one untimed that compiles the kernels, then max(--repeats, --chunks) timed
ones under seeds --seed, --seed + 1, ... (default 0); median_s is their median time (the render and its
image's transfer to numpy; a new seed compiles nothing). The image written to --out (linear float EXR, the
film's first three channels: an rgba film's alpha is dropped) is the mean of the first --chunks of them: with
the default --chunks 1, the one render of the first seed, whose samples and time are the pair converge needs
(a mean of R renders would be R times the samples in one render's time). --chunks K makes a reference of
K x --spp samples; give it a --seed of its own (e.g. 1000), so that no render it judges shares its seeds.

--isa avx2 runs Mitsuba as an AVX2 CPU would, on an AVX-512 one (mitsuba_isa.py says how).

Prints one JSON line: median_s, spp (the samples per pixel of the image written: the sampler's own count,
which it may round (ldsampler to a power of two, stratified and multijitter to a square), times --chunks),
sampler, variant, and llvm_target (Dr.Jit's target CPU; null for other variants)."""
import argparse
import json
import os
import statistics
import time

import mitsuba as mi
import mitsuba_isa
import numpy as np


def parse_defines(pairs):
    """{name: value} from ["name=value", ...], as mi.load_file's keyword arguments (strings)."""
    defines = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise SystemExit(f"mitsuba_xml_render: -D {pair!r}: expected name=value")
        defines[name] = value
    return defines


def _references(props):
    """(property name, node index) of each child a node's properties refer to."""
    return [(name, value.index()) for name, value in props.items()
            if isinstance(value, mi.Properties.ResolvedReference)]


def load_scene(path, variant, sampler, spp, defines=None, width=None, height=None):
    """The scene file as mi.load_file loads it, every sensor's sampler replaced by `sampler` of `spp` samples
    and, where given, every sensor's film `width` and `height` set (the module's docstring)."""
    from mitsuba import parser
    config = parser.ParserConfig(variant)
    mi.file_resolver().prepend(os.path.dirname(os.path.abspath(path)))  # the file's relative paths
    state = parser.parse_file(config, path, **(defines or {}))
    nodes = state.nodes
    sensors = [k for k, node in enumerate(nodes) if node.type == mi.ObjectType.Sensor]
    if not sensors:
        raise SystemExit(f"mitsuba_xml_render: {path} declares no sensor (Mitsuba's default camera has no "
                         "sampler to set)")
    for k in sensors:
        sensor = nodes[k]
        children = {nodes[i].type: (name, i) for name, i in _references(sensor.props)}
        props = mi.Properties(sampler)
        props["sample_count"] = spp
        if mi.ObjectType.Sampler in children:
            node = nodes[children[mi.ObjectType.Sampler][1]]
            props.set_id(node.props.id())
            node.props = props
        else:
            node = parser.SceneNode()
            node.type, node.file_index, node.offset, node.props = (mi.ObjectType.Sampler, sensor.file_index,
                                                                    sensor.offset, props)
            nodes.append(node)
            taken = set(sensor.props.keys())
            name = next(f"_arg_{j}" for j in range(len(taken) + 1) if f"_arg_{j}" not in taken)
            sensor.props[name] = mi.Properties.ResolvedReference(len(nodes) - 1)
        if width or height:
            if mi.ObjectType.Film not in children:
                raise SystemExit(f"mitsuba_xml_render: --width/--height: a sensor of {path} has no film to size")
            film = nodes[children[mi.ObjectType.Film][1]].props
            if width:
                film["width"] = width
            if height:
                film["height"] = height
    parser.transform_all(config, state)
    return parser.instantiate(config, state)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", help="a Mitsuba 3 XML scene file")
    ap.add_argument("--sampler", default="multijitter", help="Mitsuba's sampler plugin (default multijitter)")
    ap.add_argument("--spp", type=int, required=True, help="its sample_count")
    ap.add_argument("--out", required=True, help="the EXR written")
    ap.add_argument("-D", "--define", action="append", default=[], metavar="NAME=VALUE",
                    help="the file's $NAME (repeatable), as load_file's keyword arguments")
    ap.add_argument("--width", type=int, help="the film's width (default: the file's)")
    ap.add_argument("--height", type=int, help="the film's height (default: the file's)")
    ap.add_argument("--repeats", type=int, default=1, help="timed renders (seeds --seed..), the median kept")
    ap.add_argument("--chunks", type=int, default=1, help="average this many renders (seeds --seed..) into --out")
    ap.add_argument("--seed", type=int, default=0, help="the first timed render's seed (default 0)")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--isa", choices=("native", *mitsuba_isa.LEVELS), default="native",
                    help="avx2: Dr.Jit and Embree as on an AVX2 CPU (llvm variants)")
    a = ap.parse_args()
    if a.spp < 1 or a.repeats < 1 or a.chunks < 1 or not 0 <= a.seed < 2**31 - 1 - max(a.repeats, a.chunks):
        ap.error("--spp, --repeats and --chunks must be at least 1, --seed at least 0 (and below 2^31 - 1)")
    mitsuba_isa.select(ap, a.isa, a.variant)
    scene = load_scene(a.scene, a.variant, a.sampler, a.spp, parse_defines(a.define), a.width, a.height)
    np.array(mi.render(scene, seed=2**31 - 1))  # compiles
    times, total = [], None
    for r in range(max(a.repeats, a.chunks)):
        t = time.perf_counter()
        img = np.array(mi.render(scene, seed=a.seed + r))
        times.append(time.perf_counter() - t)
        if r < a.chunks:
            img = img.astype(np.float64)
            total = img if total is None else total + img
    image = total / a.chunks
    if image.ndim == 3 and image.shape[2] > 3:
        image = image[..., :3]
    mi.Bitmap(image.astype(np.float32)).write(a.out)
    spp = scene.sensors()[0].sampler().sample_count()
    print(json.dumps({"median_s": statistics.median(times), "spp": spp * a.chunks, "sampler": a.sampler,
                      "variant": a.variant,
                      "llvm_target": mitsuba_isa.llvm_target() if a.variant.startswith("llvm_") else None}))


if __name__ == "__main__":
    main()
