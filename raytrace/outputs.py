"""Output files, all or nothing: reserved before the work, written into temporary files, renamed into place
together at the end, and removed on every other way out (an exception, SIGINT, SIGTERM, SIGHUP).

    with Outputs(inputs=[scene_path]) as outputs:
        tmp = outputs.reserve("-o", path)          # checked now; InputError naming -o and the path
        ...                                        # the expensive work
        with outputs.writing(tmp):                 # an OSError here names -o and the path too
            write_image_file(tmp, ...)
        outputs.commit()                           # every temporary renamed over its output

reserve() refuses a directory, a device, a FIFO or a socket, an input of the same run, another output of
the same command, a missing directory, a name too long for its file system and a directory where no file can
be made; it makes the temporary file (".raytrace-XXXXXXXX" + the extension) in the output's own directory,
which proves the directory writable and makes the final rename atomic. A symbolic link is followed: its
target is written (and a note says so), the link stays. handle_signals() turns SIGTERM, SIGHUP and SIGINT
into Interrupted, raised in the main thread, so that clean-up runs; the creation, renaming and removal of
files are never cut in half by one (a signal arriving then is raised right after). While a render's passes run
(keep_signals(True)), the first SIGINT or SIGTERM is kept instead, for the render to end after its pass and write
what it has; a second signal is raised as ever."""
import contextlib
import json
import math
import os
import signal
import stat
import sys
import tempfile
import threading

import numpy as np

from .errors import InputError

PREFIX = ".raytrace-"
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
KEPT_SIGNALS = (signal.SIGINT, signal.SIGTERM)  # a render keeps its samples on these; SIGHUP (the terminal gone) not


class Interrupted(BaseException):
    """A signal, raised as an exception in the main thread (a BaseException: no `except Exception` stops it)."""

    def __init__(self, signum):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


class _State:
    held = 0           # > 0 while files are made, renamed or removed: a signal waits until the end
    signum = None      # the first signal received; the later ones are ignored, the way out is under way
    raised = False
    committed = 0      # outputs renamed into place so far (an interruption after them did not undo them)
    keeping = False    # keep_signals(): the first of KEPT_SIGNALS is kept, not raised
    kept = None        # that signal, once received


def _on_signal(signum, frame):
    if _State.signum is not None:
        return
    if _State.keeping and _State.kept is None and signum in KEPT_SIGNALS:
        _State.kept = signum
        if _on_a_terminal():  # someone pressed Ctrl-C and waits: say what happens (a log keeps its one line)
            os.write(2, f"\rraytrace: {signal.Signals(signum).name}: ending after the pass under way; again to end at "
                        "once, writing nothing\n".encode())
        return
    _State.signum = signum
    if not _State.held:
        _raise()


def _on_a_terminal():
    try:
        return os.isatty(2)
    except OSError:
        return False


def _raise():
    _State.raised = True
    sys.unraisablehook = _unraisable_after_a_signal
    raise Interrupted(_State.signum)


def _unraisable_after_a_signal(unraisable):
    """What sys.unraisablehook prints no more once a signal has been raised: the command is ending on it, with
    its one line, and an object the signal cut short in its constructor may fail in its __del__ as the process
    tears down (pytools' PersistentDict, interrupted while pyopencl set up its cache, printed "Exception ignored
    in ... AttributeError: ... no attribute 'mutex'" after the line: 1 of 150 signals in the first half
    second of a render, measured). Nothing the user can act on, so nothing is printed."""


@contextlib.contextmanager
def _held():
    """Files made, renamed or removed in here are not cut in half by a signal."""
    _State.held += 1
    try:
        yield
    finally:
        _State.held -= 1
    if not _State.held and _State.signum is not None and not _State.raised:
        _raise()


@contextlib.contextmanager
def handle_signals():
    """SIGINT, SIGTERM and SIGHUP raise Interrupted in the main thread for the duration (the handlers
    before are restored at the end). A signal ignored (nohup, a background job) stays ignored; elsewhere
    than in the main thread, nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _State.signum, _State.raised, _State.committed, _State.keeping, _State.kept = None, False, 0, False, None
    _State.held += 1  # a signal while the handlers go in is held: raise_pending() raises it in the caller's try
    try:
        before = {s: signal.signal(s, _on_signal) for s in SIGNALS if signal.getsignal(s) is not signal.SIG_IGN}
    finally:
        _State.held -= 1
    try:
        yield
    finally:
        _State.keeping = False
        for s, handler in before.items():
            signal.signal(s, handler)


def raise_pending():
    """Raise Interrupted for a signal handle_signals() held while it put its handlers in (found: Ctrl-C at
    that moment gave a traceback, the exception leaving before the command's try had begun)."""
    if _State.signum is not None and not _State.held and not _State.raised:
        _raise()


def keep_signals(keeping):
    """While `keeping` (a render's passes), the first SIGINT or SIGTERM is kept (kept_signal()) rather than
    raised: the render ends after the current pass and writes the samples done. A second signal, or one after
    keep_signals(False), is raised as any other (the way out writes nothing)."""
    _State.keeping = keeping


def kept_signal():
    """The signal keep_signals() kept, or None."""
    return _State.kept


def committed():
    """How many outputs were renamed into place since handle_signals() began."""
    return _State.committed


def umask():
    """The process's umask, read without setting it (os.umask would change it for every thread meanwhile)."""
    try:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1], 8) for line in f if line.startswith("Umask:"))
    except (OSError, StopIteration, ValueError):
        return 0o022


def _stat(path):
    """os.stat of an existing path, None for a missing one (OSError for anything else)."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        return None


def _same(a, b):
    """Paths (both resolved) naming the same file: equal, or one file under two names (hard links)."""
    if a == b:
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


class _Output:
    def __init__(self, key, given, path, source):
        self.key, self.given, self.path, self.source = key, given, str(path), source
        self.target, self.link = os.path.realpath(path), os.path.islink(path)
        self.tmp = None

    def error(self, problem):
        where = "" if self.path == self.given else f"{self.path}: "
        return InputError(self.source, self.key, self.given, where + problem)

    def note(self):
        """A line to print once written, for a symbolic link followed to its target."""
        if self.link:
            return f"raytrace: note: {self.path} is a symbolic link: wrote its target {self.target}"
        return None


class Outputs:
    """The output files of one command (see the module's docstring). `inputs`: paths the command reads
    (more with add_inputs()), never to be overwritten. `source` names the origin of the paths in errors."""

    def __init__(self, inputs=(), source="command line"):
        self.source, self.inputs, self.outputs, self.made = source, [], [], []
        self.add_inputs(inputs)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.discard()
        return False

    def add_inputs(self, paths):
        """Paths the command reads (the scene's textures and meshes, once it is loaded): InputError if an
        output reserved already is one of them."""
        for path in paths:
            resolved = os.path.realpath(path)
            self.inputs.append((str(path), resolved))
            for out in self.outputs:
                self._distinct(out, str(path), resolved, "an input of this run")

    def _distinct(self, out, other, resolved, what):
        if _same(out.target, resolved):
            raise out.error(f"is {what} ({other}): refusing to overwrite it")

    def make_directory(self, key, path):
        """Make the directory `path` (and its missing parents) for outputs: removed again, if still empty,
        when the outputs are not committed."""
        missing = []
        probe = os.path.abspath(path)
        while not os.path.lexists(probe):
            missing.append(probe)
            probe = os.path.dirname(probe)
        if not os.path.isdir(probe):
            where = "" if probe == os.path.abspath(path) else f"{probe} "
            raise InputError(self.source, key, str(path), f"{where}exists and is not a directory")
        for directory in reversed(missing):
            with _held():
                try:
                    os.mkdir(directory)
                except OSError as e:
                    raise InputError(self.source, key, str(path), f"cannot make {directory}: {e.strerror}") from None
                self.made.append(directory)

    def check_other_file(self, key, path):
        """Check `path`, a file the command keeps writing whatever happens (a checkpoint), outside the outputs'
        all or nothing: its directory exists, it is no directory, input or output of this run."""
        out = _Output(key, str(path), path, self.source)
        if not os.path.isdir(os.path.dirname(out.target)):
            raise out.error("its directory does not exist")
        if os.path.isdir(out.target):
            raise out.error("is a directory")
        for other, resolved in self.inputs:
            self._distinct(out, other, resolved, "an input of this run")
        for other in self.outputs:
            self._distinct(out, f"{other.key} {other.path}", other.target, "also another output")

    def reserve(self, key, path, given=None):
        """Check `path` as the output of option `key` (the user wrote `given`, by default the path) and make
        its temporary file beside it; returns the temporary's path, to be written with writing()."""
        out = _Output(key, str(path) if given is None else str(given), path, self.source)
        if str(path).endswith(os.sep):
            raise out.error("names a directory")
        directory, name = os.path.split(out.target)
        if not os.path.isdir(directory):
            raise out.error("its directory does not exist")
        try:
            name_max = os.pathconf(directory, "PC_NAME_MAX")
        except (OSError, ValueError):
            name_max = 255
        if len(os.fsencode(name)) > name_max:
            raise out.error(f"the file name is longer than this file system's {name_max} bytes")
        try:
            st = _stat(out.target)
        except OSError as e:
            raise out.error(f"cannot check: {e.strerror}") from None
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise out.error("is a directory")
        if st is not None and not stat.S_ISREG(st.st_mode):
            raise out.error("is not a regular file (a device, a FIFO or a socket): refusing to replace it")
        for other, resolved in self.inputs:
            self._distinct(out, other, resolved, "an input of this run")
        for other in self.outputs:
            self._distinct(out, f"{other.key} {other.path}", other.target, "also another output")
        mode = stat.S_IMODE(st.st_mode) if st is not None else 0o666 & ~umask()
        with _held():
            try:
                fd, out.tmp = tempfile.mkstemp(prefix=PREFIX, suffix=os.path.splitext(name)[1], dir=directory)
            except OSError as e:
                raise out.error(f"cannot write in its directory: {e.strerror}") from None
            self.outputs.append(out)
            os.fchmod(fd, mode)  # mkstemp makes it private: the output keeps its mode, a new one gets the usual
            os.close(fd)
        return out.tmp

    @contextlib.contextmanager
    def writing(self, tmp):
        """Around the writing of a reserved temporary: an OSError about it (a full disk, a file too large)
        becomes the InputError naming the option and the path the user gave. A signal meanwhile is held until
        the writer is done (the temporary is then removed, as after any signal)."""
        [out] = [o for o in self.outputs if o.tmp == str(tmp)]
        try:
            with _held():  # a writer cut short by a signal complains on stderr itself (libpng: "No IDATs written")
                yield out.tmp
        except OSError as e:
            if e.filename not in (None, out.tmp):
                raise
            why = str(e.strerror or e).replace(out.tmp, out.path)  # a writer's message may name the temporary
            raise out.error(f"cannot write: {why}") from None

    def commit(self):
        """Flush every temporary to disk, then rename them all over their outputs; prints a note for each
        symbolic link followed."""
        for out in self.outputs:
            with self.writing(out.tmp):
                fd = os.open(out.tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
        with _held():
            for out in self.outputs:
                try:
                    os.replace(out.tmp, out.target)
                except OSError as e:
                    raise out.error(f"cannot write: {e.strerror}") from None
                out.tmp = None
                _State.committed += 1
            self.made = []
        for note in filter(None, (out.note() for out in self.outputs)):
            print(note, file=sys.stderr)

    def discard(self):
        """Remove every temporary not renamed into place, and the directories made for them."""
        with _held():
            for out in self.outputs:
                if out.tmp is not None:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(out.tmp)
                    out.tmp = None
            for directory in reversed(self.made):
                with contextlib.suppress(OSError):
                    os.rmdir(directory)
            self.made = []


def scene_inputs(scene):
    """Every file a loaded scene was read from: its own, its textures' (colour, normal and height maps), its
    meshes' and its environment map's. Outputs resolves them through symbolic links and hard links."""
    paths = [scene.path] + [texture.path for texture in scene.textures] + [mesh.source for mesh in scene.meshes]
    if scene.environment_map is not None:
        paths.append(scene.environment_map.path)
    return [str(path) for path in paths if path and os.path.isfile(path)]


def finite_json(value):
    """`value` with every number that is not finite (NaN, Inf; float or numpy) replaced by None, and numpy
    scalars and arrays made Python's: JSON has no NaN or Infinity (json.dump would write them as the
    JavaScript words, which strict parsers refuse). docs/cli.md says what a null means."""
    if isinstance(value, dict):
        return {key: finite_json(v) for key, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return finite_json(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path, data):
    """`data` as indented JSON into `path` (a reserved temporary); a number that is not finite is written as
    null (finite_json), and anything else JSON cannot hold raises (TypeError; allow_nan=False makes a NaN that
    got past finite_json a ValueError), so the temporary is discarded, never renamed into a file that is not
    JSON."""
    with open(path, "w") as f:
        json.dump(finite_json(data), f, indent=2, allow_nan=False)
        f.write("\n")
