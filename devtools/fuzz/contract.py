"""The fuzz suite's contract and how it is checked: the Hypothesis budget, the command line run in this
process (stderr captured at the file-descriptor level, Python warnings as the command line prints them) or in a
child process, one exception type per way of breaking the contract (the inputs a run was given, compared byte
for byte before and after it, among them), and one scene example run and checked."""
import contextlib
import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from hypothesis import HealthCheck, Phase, assume, event, note, settings

from .scenes import node_at, node_paths
from . import ROOT

# --- budget -------------------------------------------------------------------------------------------

LONG_RUN = int(os.environ.get("RAYTRACE_FUZZ_EXAMPLES", "0") or 0)
SHRINK = bool(LONG_RUN or os.environ.get("RAYTRACE_FUZZ_SHRINK"))
SURVEY = os.environ.get("RAYTRACE_FUZZ_SURVEY")
EXAMPLE_SECONDS = 120  # one example that takes longer than this is a failure of its own (a hang)


def budget(ci_examples):
    """Hypothesis settings: `ci_examples` derandomised examples, or RAYTRACE_FUZZ_EXAMPLES random ones.
    Failures are shrunk only in a long run or with RAYTRACE_FUZZ_SHRINK=1: shrinking one takes a minute or
    more (every step a render), which the CI budget has not got."""
    phases = [Phase.explicit, Phase.reuse, Phase.generate] + ([Phase.shrink, Phase.explain] if SHRINK else [])
    return settings(max_examples=LONG_RUN or ci_examples, deadline=None, derandomize=not LONG_RUN, database=None,
                    phases=phases, print_blob=bool(LONG_RUN), report_multiple_bugs=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                           HealthCheck.data_too_large, HealthCheck.large_base_example])


# --- running the command line in this process ----------------------------------------------------------

class ExampleTimedOut(BaseException):
    """One example ran longer than EXAMPLE_SECONDS (a BaseException, so `except Exception` cannot eat it)."""


@contextlib.contextmanager
def time_limit(seconds):
    def expired(signum, frame):
        raise ExampleTimedOut(f"the example ran for more than {seconds} s")
    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def captured_stderr():
    """fd 2 and sys.stderr both into one temporary file (C libraries write to the fd, Python to sys.stderr);
    yields a list that holds the text afterwards."""
    sys.stderr.flush()
    saved_fd, saved_stream, text = os.dup(2), sys.stderr, []
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        sys.stderr = stream = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False, buffering=1)
        try:
            yield text
        finally:
            stream.close()  # flushed; fd 2 stays open
            sys.stderr = saved_stream
            os.dup2(saved_fd, 2)
            os.close(saved_fd)
            f.seek(0)
            text.append(f.read().decode("utf-8", "backslashreplace"))


@contextlib.contextmanager
def working_directory(path):
    previous = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(previous)


@contextlib.contextmanager
def environment(changes):
    saved = {k: os.environ.get(k) for k in changes}
    os.environ.update(changes)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def files_in(directory):
    """Every file under `directory`, as paths relative to it."""
    return {os.path.relpath(os.path.join(d, f), directory) for d, _, names in os.walk(directory) for f in names}


@dataclasses.dataclass
class Outcome:
    argv: list
    rc: object          # the exit status, or "SystemExit(...)" when argparse exits
    stderr: str         # fd 2's bytes, then the Python warnings the CLI would print
    error: BaseException | None  # an exception that escaped main
    new_files: set
    warnings: list = dataclasses.field(default_factory=list)  # the Python warnings among stderr's lines


def run_cli(main, argv, directory, env=None):
    """`main` (raytrace.cli.main: the tests hand it in, so this tool imports nothing above the renderer) run
    on argv in `directory`, as the command line would run it."""
    before = files_in(directory)
    rc, error = None, None
    with captured_stderr() as stderr, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # a command line shows each warning once, and runs once
        for hidden in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
            warnings.simplefilter("ignore", hidden)  # as Python's default filters do outside __main__
        with working_directory(directory), environment(env or {}):
            try:
                with time_limit(EXAMPLE_SECONDS):
                    rc = main(list(argv))
            except SystemExit as e:
                rc = f"SystemExit({e.code!r})"
            except (Exception, ExampleTimedOut) as e:
                error = e
    shown = [warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line) for w in caught]
    return Outcome(list(argv), rc, stderr[0] + "".join(shown), error, files_in(directory) - before, shown)


WARNING_LINE = re.compile(r"^.*:\d+: \w*Warning: ", re.MULTILINE)  # warnings.formatwarning's first line


def run_child(argv, directory, env):
    """`python -m raytrace` on argv in a child process in `directory`, with the environment `env` (the tests hand
    in raytrace.commands.child_env's, which puts this checkout on the path): the command line as the user runs it,
    its exit status from the interpreter. The Python warnings it printed are picked out of its stderr."""
    before = files_in(directory)
    try:
        r = subprocess.run([sys.executable, "-m", "raytrace", *argv], cwd=directory, capture_output=True, env=env,
                           timeout=EXAMPLE_SECONDS, check=False)
        rc, stderr, error = r.returncode, r.stderr.decode("utf-8", "backslashreplace"), None
    except subprocess.TimeoutExpired as e:
        rc, stderr = None, (e.stderr or b"").decode("utf-8", "backslashreplace")
        error = ExampleTimedOut(f"the child ran for more than {EXAMPLE_SECONDS} s")
    return Outcome(list(argv), rc, stderr, error, files_in(directory) - before, WARNING_LINE.findall(stderr))


def read_image(path):
    """(spec, pixels) in the file's own format, as tests/test_cli.py reads them."""
    image = oiio.ImageInput.open(str(path))
    if image is None:
        return None, oiio.geterror()
    spec = image.spec()
    pixels = image.read_image(spec.format)
    image.close()
    return spec, pixels


# --- the contract --------------------------------------------------------------------------------------
# One exception type per way of breaking it, so that Hypothesis reports (and shrinks) each kind apart.

class ContractBroken(AssertionError):
    pass


class WrongExitStatus(ContractBroken):
    pass


class NotOneLine(ContractBroken):
    pass


class WrongErrorLine(ContractBroken):
    pass


class FilesLeftBehind(ContractBroken):
    pass


class BadImage(ContractBroken):
    pass


class StrayFiles(ContractBroken):
    pass


class TracebackOnStderr(ContractBroken):
    pass


class WarningOnStderr(ContractBroken):
    """A Python warning (numpy's overflow, division by zero, ...) printed by a render that succeeded: a sign
    of a value that went through unchecked, and noise in the user's terminal."""


class NonFiniteValuesCounted(ContractBroken):
    pass


class ValidInputRefused(ContractBroken):
    pass


class InputNotProtected(ContractBroken):
    """An output that names one of the run's inputs (itself, through another spelling or a link) was written."""


class InputChanged(ContractBroken):
    """A file the run was given (the scene, a texture, a mesh, the environment map, a link to one of them) is not
    as it was: overwritten, removed, or a link replaced; whatever the exit status."""


def snapshot(directory):
    """Every entry under `directory` as it is now: a file's bytes, a symbolic link's target, a directory."""
    entries = {}
    for d, subdirectories, names in os.walk(directory):
        for name in subdirectories + names:
            path = os.path.join(d, name)
            relative = os.path.relpath(path, directory)
            if os.path.islink(path):
                entries[relative] = ("link", os.readlink(path))
            elif os.path.isdir(path):
                entries[relative] = ("directory",)
            else:
                with open(path, "rb") as f:
                    entries[relative] = ("file", f.read())
    return entries


def check_inputs(outcome, directory, inputs, example_text=None):
    """Every entry of `inputs` (a snapshot taken before the run) still there and the same."""
    now = snapshot(directory)
    changed = sorted(name for name, entry in inputs.items() if now.get(name) != entry)
    if changed:
        broken(InputChanged, outcome, f"inputs changed by the run: {changed}", example_text)


def broken(kind, outcome, message, example_text=None):
    """Raise `kind`, or in a survey record it and go on."""
    if SURVEY:
        record = {"kind": kind.__name__, "message": message, "argv": outcome.argv, "rc": outcome.rc,
                  "stderr": outcome.stderr[-3000:], "scene": example_text}
        with open(SURVEY, "a") as f:
            f.write(json.dumps(record, default=repr) + "\n")
        return
    raise kind(f"{message}\nargv: {outcome.argv}\nexit status: {outcome.rc!r}\nstderr:\n{outcome.stderr}")


class EscapedException(ContractBroken):
    """An exception escaped main; a subclass per exception type and place it was raised (see escaped)."""


_escaped_kinds = {}


def raised_at(e):
    """file:line of the deepest frame in the raytrace package (else the deepest frame) of e's traceback."""
    frames = traceback.extract_tb(e.__traceback__)
    ours = [f for f in frames if f"{os.sep}raytrace{os.sep}" in f.filename] or frames
    return f"{os.path.relpath(ours[-1].filename, ROOT)}:{ours[-1].lineno}" if ours else "?"


def escaped(outcome, example_text=None):
    """An exception escaped main: raised again as an EscapedException subclass named after it and made once
    per (type, place raised), so that Hypothesis tells them apart and replays each the same way (a
    RecursionError's deepest frame moves), with the end of the original traceback in the message."""
    e, where = outcome.error, raised_at(outcome.error)
    tail = "".join(traceback.format_exception(e, limit=-12))[-4000:]
    message = f"{type(e).__name__} escaped raytrace.cli.main, raised at {where}: {str(e)[:300]}"
    if SURVEY:
        record = {"kind": "EscapedException", "message": message, "argv": outcome.argv, "rc": None,
                  "stderr": outcome.stderr[-3000:], "scene": example_text, "traceback": tail}
        with open(SURVEY, "a") as f:
            f.write(json.dumps(record, default=repr) + "\n")
        return
    kind = _escaped_kinds.setdefault((type(e), where), type(f"Escaped{type(e).__name__}", (EscapedException,), {}))
    raise kind(f"{message}\nargv: {outcome.argv}\n{tail}") from None


def check(outcome, directory, output, size, sources, stats=None, must_render=False, example_text=None,
          inputs=None, must_refuse=False):
    """The contract for one run. `output`: the image path asked for (relative to `directory`); `size`:
    (width, height) it must have, None if not known; `sources`: what an error line may name first;
    `stats`: the --stats-json path asked for, if any; `inputs`: a snapshot() of `directory` before the run,
    every entry of which must be unchanged after it (None: not checked); `must_refuse`: the run must end in
    exit status 2 (an output names an input)."""
    event(f"exit status {outcome.rc!r}" if outcome.error is None else "an exception escaped")
    if outcome.error is not None:
        return escaped(outcome, example_text)
    if inputs is not None:
        check_inputs(outcome, directory, inputs, example_text)
    if outcome.rc == 0 and must_refuse:
        broken(InputNotProtected, outcome, "an output that names an input was written (exit status 0)", example_text)
    elif outcome.rc == 0:
        check_rendered(outcome, directory, output, size, stats, example_text)
    elif outcome.rc == 2:
        if must_render:
            broken(ValidInputRefused, outcome, "a valid scene was refused", example_text)
        check_refused(outcome, sources, example_text)
    else:
        broken(WrongExitStatus, outcome, f"exit status {outcome.rc!r}", example_text)


def check_rendered(outcome, directory, output, size, stats, example_text):
    if "Traceback" in outcome.stderr:
        broken(TracebackOnStderr, outcome, "a traceback on stderr with exit status 0", example_text)
    if outcome.warnings:
        broken(WarningOnStderr, outcome, f"Python warnings on stderr with exit status 0: {outcome.warnings[0]}",
               example_text)
    output = os.path.normpath(output)
    expected = {output, os.path.normpath(stats)} if stats else {output}
    if outcome.new_files - expected:
        broken(StrayFiles, outcome, f"files left besides the image: {sorted(outcome.new_files - expected)}",
               example_text)
    path = directory / output
    if not path.is_file():
        return broken(BadImage, outcome, "exit status 0 but no image file", example_text)
    spec, pixels = read_image(path)
    if spec is None:
        return broken(BadImage, outcome, f"the image does not read back: {pixels}", example_text)
    if size is not None and (spec.width, spec.height) != tuple(size):
        broken(BadImage, outcome, f"image is {spec.width} x {spec.height}, not {size[0]} x {size[1]}", example_text)
    if pixels is None or (np.asarray(pixels).dtype.kind == "f" and not np.isfinite(pixels).all()):
        broken(BadImage, outcome, "the image holds NaN or infinite values (or no pixels)", example_text)
    if stats:
        data = json.loads((directory / stats).read_text())
        if data.get("extra", {}).get("nonfinite_values", 0) != 0:
            broken(NonFiniteValuesCounted, outcome, f"the kernel produced {data['extra']['nonfinite_values']} NaN "
                   f"or infinite values (zeroed before writing; docs/cli.md says always 0)", example_text)


def names_toml_source(text, sources):
    """`text` starts with one of `sources`, as given or with control characters escaped, then `: ` (or
    `:line:column: `, a TOML syntax error's)."""
    return any(re.match(re.escape(shown) + r"(:\d+:\d+)?: ", text) for source in sources
               for shown in (source, repr(source)[1:-1]))


def check_refused(outcome, sources, example_text, names_source=names_toml_source, listed=sorted):
    """The refusal: one line on stderr, `raytrace: error: ` then a source (`names_source(rest, sources)`: the rest
    of the line names one; `listed(sources)`: them as a broken contract's message lists them), no file left."""
    text = outcome.stderr
    if text.count("\n") != 1 or not text.endswith("\n"):
        broken(NotOneLine, outcome, f"{text.count(chr(10))} lines on stderr, not one", example_text)
    line = text.split("\n")[0]
    if "Traceback" in text:
        broken(TracebackOnStderr, outcome, "a traceback on stderr", example_text)
    prefix = "raytrace: error: "
    if not line.startswith(prefix):
        broken(WrongErrorLine, outcome, f"the line does not start with {prefix!r}", example_text)
    elif not names_source(line[len(prefix):], sources):
        broken(WrongErrorLine, outcome, f"the line names none of {listed(sources)} as the source", example_text)
    if outcome.new_files:
        broken(FilesLeftBehind, outcome, f"exit status 2 but files left: {sorted(outcome.new_files)}", example_text)


# --- running one example -------------------------------------------------------------------------------

def write_example(directory, scene_bytes, files):
    (directory / "scene.toml").write_bytes(scene_bytes)
    for f in files:
        if not (directory / f.name).exists() and "/" not in f.name and f.name not in ("", ".", ".."):
            f.write(directory)


def mesh_sources(table, scene_path="scene.toml"):
    """What an error from a mesh file names first: each `file` of the shapes, beside the scene file."""
    names = []
    shapes = table.get("shapes") if isinstance(table, dict) else None
    for shape in shapes if isinstance(shapes, list) else []:
        if isinstance(shape, dict) and isinstance(shape.get("file"), str):
            names.append(str(Path(scene_path).parent / shape["file"]))
    return names


def plain_int(table, *path, default=None):
    try:
        value = node_at(table, path)
    except (KeyError, IndexError, TypeError):
        return default
    return value if type(value) is int else None


def cost_flags(table):
    """A time limit for scenes whose samples make for a long render (they are valid, and only slow)."""
    width, height = plain_int(table, "image", "width"), plain_int(table, "image", "height")
    spp, ls = plain_int(table, "render", "spp", default=1), plain_int(table, "render", "light_samples", default=1)
    n_lights = len(table["lights"]) if isinstance(table.get("lights"), list) else 1
    if None in (width, height, spp, ls):
        return []
    assume(width * height <= 1 << 20 and width * height * (1 + ls * n_lights) <= 3e7)
    for path in node_paths(table):
        if path and path[-1] == "triangles":
            value = node_at(table, path)
            assume(not isinstance(value, int) or value <= 200_000)
    return ["--time-limit", "1"] if width * height * spp * (1 + ls * n_lights) > 2e6 else []


def fuzz_scene(main, scene_bytes, files, table, must_render=False, texture_filter="trilinear", child_env=None):
    """Render (through `main`, run_cli's) `scene_bytes` (beside `files`) with a valid command line; `table` is the
    scene as written (None when the bytes are not TOML we wrote). With `child_env`, in a child `python -m raytrace`
    with that environment instead (run_child). No file the example wrote may change."""
    text = scene_bytes.decode("utf-8", "backslashreplace")
    note(f"scene.toml:\n{text[:3000]}" + (f"... ({len(text)} characters)" if len(text) > 3000 else ""))
    note(f"files: {files!r}"[:3000])
    ext = ".exr" if len(scene_bytes) % 2 else ".png"
    flags = cost_flags(table) if table is not None else []
    stats = "stats.json"
    argv = ["render", "scene.toml", "-o", "out" + ext, "--no-progress", "--stats-json", stats,
            "--texture-filter", texture_filter, *flags]
    size = None
    if table is not None:  # the image is the film's crop window, to the film's edge by default
        width, height = plain_int(table, "image", "width"), plain_int(table, "image", "height")
        if width is not None and height is not None:
            x, y = plain_int(table, "image", "crop_offset_x", default=0), plain_int(table, "image", "crop_offset_y",
                                                                                  default=0)
            if x is not None and y is not None:
                width = plain_int(table, "image", "crop_width", default=width - x)
                height = plain_int(table, "image", "crop_height", default=height - y)
        size = (width, height) if width is not None and height is not None else None
    with tempfile.TemporaryDirectory(prefix="fuzz-") as d:
        directory = Path(d)
        write_example(directory, scene_bytes, files)
        inputs = snapshot(directory)
        outcome = run_cli(main, argv, directory) if child_env is None else run_child(argv, directory, child_env)
        sources = ["scene.toml"] + (mesh_sources(table) if table is not None else [])
        check(outcome, directory, "out" + ext, size, sources, stats, must_render, f"{text}\n# files: {files!r}",
              inputs)


def outside(directory, outcome, env):
    """The outcome without the new files under POCL_CACHE_DIR, where PoCL was asked to keep its cache."""
    cache = env.get("POCL_CACHE_DIR")
    if cache:
        cache = os.path.relpath(os.path.abspath(os.path.join(directory, cache)), directory)
        outcome.new_files = {f for f in outcome.new_files if not f.startswith(cache + os.sep)}
    return outcome
