"""Command line: `python -m raytrace render SCENE -o OUT ...`, `python -m raytrace bench ...`,
`python -m raytrace assets [--out DIR]`, `python -m raytrace converge ...` and
`python -m raytrace stability [--json PATH] [--lanes 1|8]`.

Bad input ends with one line on stderr naming the file (or the command line), the key and the value,
and exit status 2; no output file is left behind. Outputs follow raytrace/outputs.py: checked before the
work, written into temporary files, renamed into place together at the end. SIGINT, SIGTERM and SIGHUP end
a command with one line and exit status 128 + the signal's number, leaving no temporary file."""
import argparse
import contextlib
import dataclasses
import re
import signal
import sys
import warnings
from pathlib import Path

import numpy as np

from . import aovs as aov_types, samplers
from .errors import InputError, UnsupportedWarning, did_you_mean, interrupted_line
from .outputs import (Interrupted, Outputs, committed, handle_signals, keep_signals, kept_signal, raise_pending,
                      scene_inputs, write_json)
from .watch import Watcher
from .image import Image
from .image_file import FORMATS, check_extension, write_image_file
from .options import API, CHECKPOINT_EVERY, SYNONYMS, command_line_name, declared, option_type
from .commands.converge_peer import PEER_SAMPLERS

EXIT_BAD_INPUT = 2


DESCRIPTION = ("A ray tracer whose per-pixel pipeline is one OpenCL C kernel: render a scene, benchmark it, "
               "measure image error against run time, compile the kernel for other devices, check the float32 "
               "arithmetic against float64.")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        m = re.match(r"argument ([^:]+): (.*)", message)
        required = re.match(r"the following arguments are required: (.*)", message)
        if required:  # a missing command or argument: named as the key, not after the program's name
            raise InputError("command line", required.group(1), None, "is required" + (
                f" (one of: {', '.join(_commands())})" if required.group(1) == "command" else ""))
        key = m.group(1).split("/")[-1] if m else self.prog
        value = re.search(r"(?:value|choice): (?:'([^']*)'|(\S+) \()", message)  # a number is not quoted
        value = value.group(1) or value.group(2) if value else None
        problem = m.group(2) if m else message
        if key == "command" and value is not None:
            problem += did_you_mean(value, _commands(), ";")
        raise InputError("command line", key, value, problem)

    def _get_values(self, action, arg_strings):
        """argparse drops a value of '--' (`--texture-filter=--`) as if it ended the options, leaving an option
        of one value a list of none, which no check expects: refused here instead."""
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            raise InputError("command line", action.option_strings[-1], "--", "takes a value; '--' is none")
        return super()._get_values(action, arg_strings)


def _commands():
    return next(a for a in parser()._actions if a.dest == "command").choices


def _refuse_unknown(args, extras):
    """An argument no option of the command takes: one line, with the closest option's name."""
    if extras:
        names = [name for action in parser_actions(args.command) for name in action.option_strings]
        word = extras[0].split("=")[0]
        synonyms = {command_line_name(theirs): command_line_name(ours) for theirs, ours in SYNONYMS.items()}
        known = did_you_mean(word, names, ";", synonyms) if word.startswith("-") else ""
        raise InputError("command line", word, None, f"is no {args.command} option or argument{known}")


def _add_scene_loading(p):
    """The options of reading a scene file: a Mitsuba XML file's parameters, and its unsupported plugins."""
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                   help="a Mitsuba XML scene's parameter ($NAME), as Mitsuba's -D")
    p.add_argument("--ignore-unsupported", action="store_true", help="render a Mitsuba XML scene without what "
                   "raytrace does not render (one warning per kind) instead of refusing it")


def _defines(args):
    defines = {}
    for given in args.defines:
        name, equals, value = given.partition("=")
        if not equals or not name:
            raise InputError("command line", "-D", given, "must be NAME=VALUE")
        defines[name] = value
    return defines


def load_scene(args, translated=False):
    """The scene of args.scene (TOML, or Mitsuba XML with -D and --ignore-unsupported), its warnings printed
    as one line each; with `translated`, (scene, the mitsuba.Translation of an XML file or None)."""
    from .scene.scene_file import load_file, load_mitsuba_file
    xml = Path(args.scene).suffix.lower() == ".xml"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnsupportedWarning)
        if xml:
            scene, translation = load_mitsuba_file(args.scene, _defines(args) or None, args.ignore_unsupported)
        else:
            scene, translation = load_file(args.scene, _defines(args) or None), None
    for w in caught:
        print(f"raytrace: warning: {w.message}", file=sys.stderr)
    return (scene, translation) if translated else scene


def _add_render_options(p, scene_help=None, resumable=False):
    if scene_help:
        p.add_argument("scene", nargs="*", help=scene_help)
    else:
        p.add_argument("scene", nargs="?" if resumable else None,
                       help="scene file (TOML, or Mitsuba 3 XML)" + (" (none with --resume)" if resumable else ""))
        _add_scene_loading(p)
    for name, default, doc, cli, choices, metavar in declared():
        if cli and name != "scheduler":
            _add_option(p, name, default, doc, choices, metavar)
    _add_declared(p, "scheduler")


def _add_option(p, name, default, doc, choices=None, metavar=None):
    """render()'s option `name` (raytrace/options.py) as --name on the command line, of its declared type."""
    parser_checks = choices if name in ("texture_filter", "shading") else None  # render() checks the patterns
    p.add_argument(command_line_name(name), dest=name, type=option_type(name), default=default,
                   choices=list(parser_checks) if parser_checks else None, metavar=metavar,
                   help=doc + (f": {', '.join(choices)}" if choices and not parser_checks else "")
                   + (f" (default: {default})" if default is not None else ""))


def _add_declared(p, option):
    """render()'s option `option` alone, as _add_render_options adds them all."""
    name, default, doc, _, choices, metavar = next(o for o in declared() if o[0] == option)
    _add_option(p, name, default, doc, choices, metavar)


def parser():
    from .commands.compile import TARGETS
    p = _Parser(prog="raytrace", description=DESCRIPTION)
    p.add_argument("--version", action="version", version=f"raytrace {_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    r = sub.add_parser("render", help="render a scene to an image file")
    _add_render_options(r, resumable=True)
    r.add_argument("-o", "--output", required=True, help=f"image file ({', '.join(sorted(FORMATS))})")
    r.add_argument("--denoise", action="store_true", help="write the image denoised by Intel Open Image Denoise "
                   "(the denoise extra), given the albedo and normal AOVs; an .exr keeps the noisy one as noisy.R ...")
    r.add_argument("--stats-json", help="write render statistics to this JSON file")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--checkpoint", metavar="FILE", help="keep the render's state in FILE (every "
                   "--checkpoint-every seconds and at the end), to continue it with --resume FILE")
    r.add_argument("--checkpoint-every", type=float, default=CHECKPOINT_EVERY, metavar="SECONDS",
                   help=f"seconds between checkpoints; 0: after every pass (default: {CHECKPOINT_EVERY:g}; with "
                   "--resume, the checkpoint's)")
    r.add_argument("--resume", metavar="FILE", help="continue the render kept in the checkpoint FILE (its scene and "
                   "options; keeps checkpointing into FILE) to the image the render would have made uninterrupted")
    r.add_argument("--display", metavar="tev[:HOST:PORT]", help="show each pass in the tev viewer, at tev's "
                   "default address (127.0.0.1:14158) or HOST:PORT; without a tev, one warning")
    b = sub.add_parser("bench", help="the benchmark suite: rays per second against the scalar kernel, build and "
                       "process seconds, memory (default: 512 x 512, 16 spp x 16 light samples)")
    _add_render_options(b, scene_help="scene files (TOML; default: the suite, scenes/cornell.toml, "
                        "textured_cornell.toml, grid_floor.toml and mesh_cornell.toml)")
    b.set_defaults(width=512, height=512, spp=16, light_samples=16)  # the same work for every scene
    b.add_argument("--repeat", type=int, default=3, help="timed renders per kernel (the best counts)")
    b.add_argument("--json", help="write the table, with the machine, to this JSON file")
    b.add_argument("--peer", metavar="COMMAND", help="also run another renderer's benchmark (a shell command "
                   "whose last output line is JSON with its nominal mrays_per_s), measure the first scene again beside it "
                   "and report the ratio, best against best")
    b.add_argument("--scaling", metavar="DIR", help="instead: seconds per ray and BVH build seconds against "
                   "the triangle count of a procedural mesh in the scene's room; scaling.csv and .png in DIR")
    b.add_argument("--max-triangles", type=int, default=10**6, help="--scaling's largest mesh (default 10^6)")
    a = sub.add_parser("assets", help="generate the procedural textures the scenes use")
    a.add_argument("--out", default="assets/textures", help="output directory (default: assets/textures)")
    a.add_argument("--seed", type=int, default=0, help="seed of the textures' random patterns")
    c = sub.add_parser("converge", help="image error against run time for every sample pattern")
    c.add_argument("scene", help="scene file (TOML)")
    c.add_argument("--samplers", required=True,
                   help=f"comma-separated pixel sample patterns: {', '.join(samplers.SAMPLERS)}")
    c.add_argument("--max-spp", type=int, required=True, help="the largest pixel sample count measured")
    c.add_argument("--reference", help="reference image of the same size (default: rendered, sobol)")
    c.add_argument("--width", type=int, help="image width in pixels (default: the scene's)")
    c.add_argument("--height", type=int, help="image height in pixels (default: the scene's)")
    c.add_argument("--light-samples", type=int, help="samples per light (default: the scene's)")
    c.add_argument("--seed", type=int, default=0, help="seed of the measured renders (the reference's: seed + 1000003)")
    c.add_argument("--json", help="also write the rows, the race against the peer and the machine to this JSON file")
    c.add_argument("--repeats", type=int, default=1,
                   help="renders timed per sample count, the median kept (default 1; at most 100)")
    _add_declared(c, "scheduler")
    _add_declared(c, "device")
    c.add_argument("--peer", metavar="TEMPLATE", help="also another renderer's patterns: a shell command with "
                   "{sampler}, {spp} and {out} that writes an EXR and prints JSON with median_s")
    c.add_argument("--peer-samplers", default=",".join(PEER_SAMPLERS),
                   help=f"the peer's sampler names (default: {','.join(PEER_SAMPLERS)})")
    c.add_argument("--clamp", action="store_true", help="RMSE of the images clamped to [0, 1]")
    c.add_argument("--reference-spp", type=int, help="the rendered reference's samples (default: 16 x max-spp, "
                   "at most 65536)")
    c.add_argument("--montage-seconds", type=float, help="time per pattern in the montage (default: a quarter of "
                   "random's longest render)")
    c.add_argument("--crop", help="the montage's crop, X,Y,W,H in fractions of the image (default: "
                   "0.70,0.72,0.18,0.18, the ellipsoid's shadow in scenes/cornell.toml)")
    c.add_argument("--out", required=True, help="output directory")
    k = sub.add_parser("compile", help="compile a scene's kernel for a GPU target with clang (Debian's, else "
                       "PyPI's ziglang), or with PoCL")
    k.add_argument("scene", help="scene file (TOML)")
    k.add_argument("--target", required=True, help=f"{', '.join(TARGETS)} (pocl: PoCL on this CPU; spirv: SPIR-V "
                   "1.0; the x86-64 levels: that CPU level with clang)")
    k.add_argument("-o", "--output", help="write what the compiler made to this file (PoCL's binary, PTX text, an "
                   "object file, SPIR or SPIR-V)")
    k.add_argument("--lanes", type=int, choices=[1, 4, 8, 16], help="lane width (default: 1, or the CPU's for pocl)")
    v = sub.add_parser("convert", help="convert a scene between raytrace's TOML and Mitsuba 3's XML")
    v.add_argument("scene", help="scene file: Mitsuba 3 XML (.xml) or raytrace's TOML")
    v.add_argument("-o", "--output", required=True, help="the converted scene: .toml from XML, .xml from TOML (meshes "
                   "raytrace holds inline or generates are written beside it as PLY files)")
    _add_scene_loading(v)
    s = sub.add_parser("stability", help="the numerical stability suite: float32 results against float64")
    s.add_argument("--json", help="write the table's rows to this JSON file")
    s.add_argument("--lanes", type=int, choices=[1, 8], help="pixels per work-item (default: the device's)")
    return p


def _version():
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("raytrace")
    except PackageNotFoundError:  # a checkout on the path, not installed
        return "(not installed)"


def _render_kwargs(args):
    """render()'s keyword arguments from the command line's options."""
    return {name: getattr(args, name) for name, _, _, cli, _, _ in declared() if cli}


class _KeepOnSignal(Watcher):
    """`render`'s Ctrl-C: once the passes have begun, the first SIGINT or SIGTERM ends the render after its pass,
    and what it has is written (outputs.keep_signals); cmd_render ends the keeping once the files are in place."""

    def started(self, report):
        keep_signals(True)

    def pass_done(self, report):
        signum = kept_signal()
        return None if signum is None else signal.Signals(signum).name

    def finished(self, report):
        if report is None:  # an exception ends the render: a signal now ends the command at once
            keep_signals(False)


def _resumed(args):
    """For `render --resume FILE`: args with the scene and the options the checkpoint keeps, or args unchanged.
    A scene or render option given beside --resume is refused: the checkpoint's are the ones it continues."""
    if args.resume is None:
        if args.scene is None:
            raise InputError("command line", "scene", None, "is required (or --resume FILE)")
        return args
    from .checkpoint import load
    given = [a.option_strings[0] if a.option_strings else a.dest for a in parser_actions("render")
             if a.dest in ("scene", "defines", "ignore_unsupported", "checkpoint", "denoise", *_render_kwargs(args))
             and getattr(args, a.dest) != a.default]
    if given:
        raise InputError("command line", given[0], None, "is not taken with --resume: the checkpoint's scene and "
                         "options are the ones it continues")
    meta, _ = load(args.resume, arrays=False)
    command = meta.get("command")
    if not isinstance(command, dict) or not isinstance(command.get("scene"), str):
        raise InputError("command line", "--resume", args.resume, "keeps no command line (made by render(), not "
                         "`raytrace render`): resume it with render(checkpoint=..., resume=True)")
    kept = {"scene": command["scene"], "defines": command.get("defines", []),
            "ignore_unsupported": command.get("ignore_unsupported", False), "denoise": command.get("denoise", False),
            "checkpoint": args.resume,
            "checkpoint_every": command.get("checkpoint_every", CHECKPOINT_EVERY), **command.get("options", {})}
    if args.checkpoint_every != CHECKPOINT_EVERY:  # how often is the resumed run's to choose: no bit depends on it
        kept["checkpoint_every"] = args.checkpoint_every
    return argparse.Namespace(**{**vars(args), **kept})


def _checkpoint_command(args):
    """What a checkpoint keeps to be resumed from the command line: the scene (as an absolute path), its loading
    options and the render options."""
    return {"scene": str(Path(args.scene).absolute()), "defines": args.defines,
            "ignore_unsupported": args.ignore_unsupported, "denoise": args.denoise,
            "checkpoint_every": args.checkpoint_every,
            "options": _render_kwargs(args)}


def _display(args):
    """--display's watcher: the image, named as the output file, in tev (raytrace/tev.py)."""
    from .tev import TevDisplay, parse_display
    host, port = parse_display(args.display)
    return TevDisplay(Path(args.output).name, host, port, label=f"--display {args.display}")


def _refuse_aovs_without_exr(output, source, key, value):
    """AOVs are channels of an EXR file: with any other output they are refused, in one line naming where they
    came from (--aov, or the scene's own), before any rendering."""
    if Path(output).suffix.lower() != ".exr":
        raise InputError(source, key, value, f"AOVs are written as channels of an .exr output; -o is {str(output)!r}")


def cmd_render(args):
    from .render import render_progressive

    check_extension(args.output, "command line", "-o")
    args = _resumed(args)
    displays = [_display(args)] if args.display is not None else []
    if args.aov:  # before any work
        _refuse_aovs_without_exr(args.output, "command line", "--aov", args.aov)
    if args.denoise:  # before any work: one line when the extra is missing
        from .denoise import require
        require("render --denoise")
    with Outputs(inputs=[args.scene]) as outputs:
        image_file = outputs.reserve("-o", args.output)
        stats_file = args.stats_json and outputs.reserve("--stats-json", args.stats_json)
        if args.checkpoint:
            outputs.check_other_file("--resume" if args.resume else "--checkpoint", args.checkpoint)
        scene = load_scene(args)
        if args.aov is None and scene.aovs:  # the scene's own (render.aovs, Mitsuba's aov integrator)
            _refuse_aovs_without_exr(args.output, scene.path, "render.aovs", aov_types.to_string(scene.aovs))
        outputs.add_inputs(scene_inputs(scene))
        kwargs = _render_kwargs(args)
        if args.denoise:
            from .denoise import aov_request
            kwargs["aov"] = aov_request(args.aov, scene, "command line", "--aov")
        try:
            image, variance, stats = render_progressive(
                scene, **kwargs, progress=False if args.no_progress else None, watch=[_KeepOnSignal(), *displays],
                checkpoint=args.checkpoint, checkpoint_every=args.checkpoint_every, resume=args.resume is not None,
                checkpoint_command=_checkpoint_command(args) if args.checkpoint else None)
        except InputError as e:  # the checkpoint resumed is the one --resume named
            if args.resume is None or (e.source, e.key) != (API, "checkpoint"):
                raise
            raise InputError("command line", "--resume", e.value, e.problem) from None
        image = Image.of(image, variance, stats, args.scene, stats.aov_images)  # as render() returns it
        if args.denoise:
            from .denoise import denoise
            image = denoise(image)
        with outputs.writing(image_file):
            write_image_file(image_file, np.asarray(image), image.metadata, image.variance, image.layers())
        if stats_file:
            with outputs.writing(stats_file):
                write_json(stats_file, dataclasses.asdict(stats))
        outputs.commit()
        signum = kept_signal()
        keep_signals(False)
    if signum is not None:  # the samples done are written: the one line says so
        print(f"raytrace: interrupted by {signal.Signals(signum).name}: wrote {args.output} with {stats.spp} of "
              f"{stats.max_spp} spp in {stats.passes} pass{'es' * (stats.passes != 1)}", file=sys.stderr)
        return 128 + signum
    for mesh in scene.meshes:  # after the render: a run that ends in an error says that one line only
        if mesh.dropped:
            print(f"raytrace: note: {mesh.source}: {mesh.dropped} degenerate faces left out", file=sys.stderr)
    error = "" if stats.estimated_rmse is None else (
        f", estimated RMSE {stats.estimated_rmse:.2e} ({stats.estimated_relative_rmse:.2%} of the mean)"
        + (" before denoising" if args.denoise else ""))
    passes = f"{stats.passes} pass{'es' * (stats.passes != 1)}"
    spp_from = {"option": "--spp", "scene": "the scene's spp", "default": "the default: the scene gives no spp",
                "target_error": f"until --target-error, at most {stats.max_spp}"}[stats.extra["spp_from"]]
    print(f"{Path(args.output)}: {stats.width}x{stats.height}, {stats.spp} spp ({stats.sampler}; {spp_from}) x "
          f"{stats.light_samples} light samples ({stats.light_sampler}) in {passes}, {stats.render_seconds:.3f} s, "
          f"{stats.mrays_per_s:.1f} Mrays/s on {stats.device} [{stats.extra['target']}]{error}; stopped by "
          f"{stats.stopped_by}", file=sys.stderr)


def cmd_convert(args):
    from .commands.convert import convert
    convert(args.scene, args.output, *load_scene(args, translated=True))


def cmd_bench(args):
    """Exit status 1 when a child render fails."""
    from .commands import require_extra
    from .commands.bench import BenchError, benchmark, suite_scenes
    from .commands.scaling import scaling

    if args.scaling is not None:
        if len(args.scene) > 1:
            raise InputError("command line", "scene", " ".join(args.scene), "--scaling takes one scene")
        if not 100 <= args.max_triangles <= 10**7:
            raise InputError("command line", "--max-triangles", args.max_triangles, "must be in [100, 10^7]")
        if not Path(args.scaling).parent.is_dir():
            raise InputError("command line", "--scaling", args.scaling, "its parent directory does not exist")
        if Path(args.scaling).exists() and not Path(args.scaling).is_dir():
            raise InputError("command line", "--scaling", args.scaling, "is a file, not a directory")
        require_extra("bench --scaling", "analysis", "matplotlib")
        scaling((args.scene or suite_scenes())[0], args.scaling, args.max_triangles, out=sys.stdout,
                scheduler=args.scheduler)
        return
    if args.scheduler:  # the suite times kernels in child processes, against this machine's own scalar kernel
        raise InputError("command line", "--scheduler", args.scheduler, "bench takes it only with --scaling")
    if args.repeat < 1:
        raise InputError("command line", "--repeat", args.repeat, "must be at least 1")
    scenes = args.scene or suite_scenes()
    with Outputs(inputs=scenes) as outputs:
        json_file = args.json and outputs.reserve("--json", args.json)

        def save(results):
            with outputs.writing(json_file):
                write_json(json_file, results)
        try:
            benchmark(scenes, repeat=args.repeat, peer=args.peer, save=save if json_file else None,
                      outputs=outputs, **_render_kwargs(args))
        except BenchError as e:
            print(f"raytrace: error: {e}", file=sys.stderr)
            return 1
        outputs.commit()


def cmd_assets(args):
    from .commands.assets import generate

    if not 0 <= args.seed < 2**32:
        raise InputError("command line", "--seed", args.seed, "must be in [0, 2^32)")
    for path in generate(args.out, seed=args.seed):
        print(path)


def cmd_converge(args):
    from .commands import require_extra
    from .commands.converge import converge, parse_crop

    require_extra("converge", "analysis", "matplotlib", "flip_evaluator")

    converge(args.scene, [name.strip() for name in args.samplers.split(",")], args.max_spp, args.out,
             reference=args.reference, width=args.width, height=args.height, light_samples=args.light_samples,
             seed=args.seed, reference_spp=args.reference_spp, montage_seconds=args.montage_seconds,
             crop=None if args.crop is None else parse_crop(args.crop), out=sys.stdout, scheduler=args.scheduler,
             device=args.device,
             peer=args.peer, peer_samplers=[n.strip() for n in args.peer_samplers.split(",") if n.strip()],
             clamp=args.clamp, repeats=args.repeats, json_path=args.json)


def cmd_compile(args):
    """Exit status 1 when the compiler rejects the kernel."""
    from .commands.compile import compile_scene
    from .scene import load_file

    with Outputs(inputs=[args.scene]) as outputs:
        output = args.output and outputs.reserve("-o", args.output)
        scene = load_file(args.scene)
        outputs.add_inputs(scene_inputs(scene))
        try:
            r = compile_scene(scene, args.target, args.lanes)
        except RuntimeError as e:
            print(f"{args.scene}: {args.target}: FAILED: {e}", file=sys.stderr)
            return 1
        if output:
            with outputs.writing(output):
                Path(output).write_bytes(r["binary"])
        outputs.commit()
    written = f" -> {args.output}" if args.output else ""
    print(f"{args.scene}: {r['target']}: ok, {r['bytes']} bytes in {r['seconds']:.2f} s ({' '.join(r['options'])})"
          f"{written}")


def cmd_stability(args):
    """Exit status 1 when a row of the table fails."""
    from .renderer.device import default_lanes, select_device
    from .commands.stability import report

    with Outputs() as outputs:
        json_file = args.json and outputs.reserve("--json", args.json)
        with outputs.writing(json_file) if json_file else contextlib.nullcontext():
            passed = report(args.lanes or default_lanes(select_device(None)), json_path=json_file)
        outputs.commit()
    return 0 if passed else 1


def _refuse_empty(args):
    """An option or argument given as the empty string names no file, command or address: refused, rather
    than taken as absent (bench --scaling '' ran the whole bench) or as the working directory."""
    for action in parser_actions(args.command):
        value = getattr(args, action.dest, None)
        if value == "" or (isinstance(value, list) and "" in value):
            raise InputError("command line", action.option_strings[0] if action.option_strings else action.dest,
                             "", "must not be empty")


def parser_actions(command):
    """The arguments and options of a command, in the parser's order (-o before --output)."""
    sub = next(a for a in parser()._actions if a.dest == "command").choices[command]
    return [a for a in sub._actions if a.dest != "help"]


def _as_command_line(error):
    """An error about a render() option, named as the command line spells it (--spp, --light-samples)."""
    names = {option[0] for option in declared()}
    if error.source != API or not set(str(error.key).split("/")) <= names:
        return error
    return InputError("command line", command_line_name(error.key), error.value, error.problem)


@contextlib.contextmanager
def _dask_closed():
    """The Dask clients and local clusters a command started are closed when it ends, however it ends."""
    try:
        yield
    finally:
        if "raytrace.renderer.distributed" in sys.modules:
            sys.modules["raytrace.renderer.distributed"].close_all()


def main(argv=None):
    commands = {"render": cmd_render, "bench": cmd_bench, "assets": cmd_assets, "converge": cmd_converge,
                "compile": cmd_compile, "stability": cmd_stability, "convert": cmd_convert}
    with handle_signals(), _dask_closed():
        try:
            raise_pending()
            args, extras = parser().parse_known_args(argv)
            _refuse_unknown(args, extras)
            _refuse_empty(args)
            return commands[args.command](args) or 0
        except InputError as e:
            print(f"raytrace: error: {_as_command_line(e)}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except MemoryError:  # the up-front check (render.check_memory) cannot see every other limit
            print("raytrace: error: out of memory: try a smaller --width/--height", file=sys.stderr)
            return EXIT_BAD_INPUT
        except OSError as e:  # not an output (raytrace/outputs.py names those): a file read, say
            print(f"raytrace: error: {e.filename or 'environment'}: {e.strerror or e}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except (Interrupted, KeyboardInterrupt) as e:
            signum = getattr(e, "signum", signal.SIGINT)
            with contextlib.suppress(OSError):  # after SIGHUP, the terminal may be gone
                print(interrupted_line(signum, committed()), file=sys.stderr)
            return 128 + signum
