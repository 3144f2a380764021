"""Checkpoints: a render's accumulation state in one file, written atomically every so many seconds and when
the render ends, from which `render --resume FILE` (or render(checkpoint=FILE, resume=True)) continues to the
very image the render would have made uninterrupted, bit for bit.

What a render's image depends on is all in the file: the sums as they are (float64 totals and the float32
prefix on the host; a device's double-float sums as their two float32 halves), the counts of samples,
passes and rays, the pass schedule (render.Resolved.passes: the sizes a time limit or a target error chose),
the estimated errors so far, and the seconds spent, so that a resumed render's time limit and statistics go on
from them. A fingerprint refuses a checkpoint that the render would not continue exactly: another scene (a
digest of every value the kernel reads: model.fingerprint), other options, another raytrace or kernel source,
another device or kernel variant. The passes are deterministic functions of their sample indices, so the
state after pass k, restored, and pass k + 1 rendered again give the sums the uninterrupted render adds.

The file is a numpy .npz archive (any name): `meta`, JSON as bytes, and the arrays. It is written into a
temporary file beside it, flushed to disk and renamed over it: a process killed at any moment (SIGKILL
included) leaves the last whole checkpoint, or none, and perhaps a `.raytrace-*` temporary."""
import hashlib
import io
import json
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from .errors import InputError
from .outputs import PREFIX, finite_json, umask

FORMAT = "raytrace checkpoint 1"


def software_version():
    """The package's version and a digest of its sources, Python and kernels: a checkpoint of another build is
    refused (its passes, packing or schedule may not add up to the same bits)."""
    from importlib.metadata import PackageNotFoundError, version
    from .renderer.program import kernel_dir
    try:
        package = version("raytrace")
    except PackageNotFoundError:
        package = "unknown"
    digest = hashlib.blake2b(digest_size=8)
    for root, suffixes in ((Path(kernel_dir()), (".cl", ".h")), (Path(__file__).parent, (".py",))):
        for path in sorted(root.rglob("*")):
            if path.suffix in suffixes:
                digest.update(path.relative_to(root).as_posix().encode())
                digest.update(path.read_bytes())
    return f"{package}+sources.{digest.hexdigest()}"


def fingerprint(final, options, r, device, sums):
    """What must agree for a checkpoint to be continued: {part: value}, each part compared by name on
    resuming, so that a refusal says which differs."""
    from .scene.model import fingerprint as model_fingerprint
    features = options.features.options() if options.features is not None else None
    return {"version": software_version(), "scene": model_fingerprint(final),
            "options": {"texture_filter": options.texture_filter, "time_limit": options.time_limit,
                        "target_error": options.target_error, "lanes": options.lanes,
                        "features": None if features is None else list(features),
                        "max_pass_work": options.max_pass_work, "accumulate": options.accumulate},
            "schedule": [list(p) for p in r.passes], "sums": sums, "device": device}


PARTS = {"version": "another raytrace or kernel source", "scene": "another scene (or the scene changed since)",
         "options": "other options", "schedule": "another pass schedule",
         "sums": "sums kept elsewhere (--accumulate: the host's or a device's)",
         "device": "another device or kernel variant"}


def save(path, meta, arrays):
    """Write the checkpoint atomically (the module's docstring): `meta` a JSON-able dict, `arrays` name ->
    numpy array."""
    directory, name = os.path.split(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=PREFIX, suffix=".ckpt", dir=directory)
    try:
        os.fchmod(fd, 0o666 & ~umask())  # mkstemp makes it private: a checkpoint gets a new file's usual mode
        with os.fdopen(fd, "wb") as f:
            data = json.dumps(finite_json({"format": FORMAT, **meta}), allow_nan=False).encode()
            np.savez(f, meta=np.frombuffer(data, np.uint8), **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def load(path, source="command line", key="--resume", arrays=True):
    """(meta, arrays) of a checkpoint file (arrays {} unless `arrays`: the command line reads the meta alone);
    InputError naming it for a file that is not one."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            meta = json.loads(archive["meta"].tobytes().decode())
            data = {name: archive[name] for name in archive.files if name != "meta"} if arrays else {}
    except (OSError, zipfile.BadZipFile, EOFError) as e:  # numpy says "no .npz" with an errno-less OSError
        if isinstance(e, OSError) and e.errno is not None:
            raise InputError(source, key, str(path), f"cannot read: {e.strerror or e}") from None
        raise InputError(source, key, str(path), "is not a raytrace checkpoint (not an .npz archive)") from None
    except (ValueError, KeyError, UnicodeDecodeError):
        raise InputError(source, key, str(path), "is not a raytrace checkpoint (no meta it can read)") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(source, key, str(path), f"is not a raytrace checkpoint (no '{FORMAT}' header)")
    return meta, data


def _made_for(what, path, source, key):
    return InputError(source, key, str(path), f"was made for {what}: refusing to continue it")


def check_fingerprint(meta, expected, path, source="command line", key="--resume"):
    """Refuse, in one line naming the first part that differs, a checkpoint made for another render. A part not
    known yet (a Dask render's device, before its first pass: Checkpoints.after_pass checks it then) is passed."""
    given = meta.get("fingerprint")
    given = given if isinstance(given, dict) else {}
    expected = json.loads(json.dumps(finite_json(expected)))  # as the file holds it: lists, not tuples
    for part, what in PARTS.items():
        if part == "device" and None in (given.get(part), expected.get(part)):
            continue
        if given.get(part) != expected.get(part):
            raise _made_for(what, path, source, key)


FINAL = ("spp", "target-error", "time-limit")  # what ended a render for good: a resume renders no pass more


def _seconds(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < float("inf"):
        raise ValueError(f"{name} = {value!r}")
    return float(value)


def _checked_progress(progress, r, arrays):
    """The `progress` of a checkpoint whose fingerprint matched, checked against the schedule it was made for:
    the counts must be those its passes give (Halves replayed), the history one entry a pass, the seconds finite,
    the sums finite; ValueError naming what is not."""
    from .renderer.progressive import Halves
    if not isinstance(progress, dict) or not isinstance(progress.get("counts"), dict):
        raise ValueError("progress: no counts")
    counts, passes = progress["counts"], progress["counts"].get("passes")
    if isinstance(passes, bool) or not isinstance(passes, int) or not 0 <= passes <= len(r.passes):
        raise ValueError(f"passes = {passes!r}")
    halves = Halves()
    for _, n, n_first in r.passes[:passes]:
        halves.end_pass(n, n_first)
    for name, value in halves.counts().items():
        if counts.get(name) != value:
            raise ValueError(f"{name} = {counts.get(name)!r}, its {passes} passes give {value}")
    history = progress.get("history")
    if not isinstance(history, list) or len(history) != passes or not all(isinstance(h, dict) for h in history):
        raise ValueError(f"history: not one entry a pass ({passes})")
    for h in history:
        for name in ("estimated_rmse", "estimated_relative_rmse"):
            if h.get(name) is not None:
                _seconds(h[name], name)
    if ("prefix" in arrays) != (halves.n_prefix > 0):
        raise ValueError("prefix: " + ("missing" if halves.n_prefix else "unexpected"))
    for name, a in arrays.items():
        if not np.isfinite(a).all():
            raise ValueError(f"{name}: not finite")
    stopped_by = progress.get("stopped_by")
    if stopped_by is not None and not isinstance(stopped_by, str):
        raise ValueError(f"stopped_by = {stopped_by!r}")
    return {"render_seconds": _seconds(progress.get("render_seconds"), "render_seconds"),
            "wall_seconds": _seconds(progress.get("wall_seconds"), "wall_seconds"), "history": history,
            "stopped_by": stopped_by}


def _probe(path, source):
    """Make and remove a file beside `path`: a checkpoint that cannot be written is refused before any work, not
    after the first pass."""
    directory = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=PREFIX, suffix=".ckpt", dir=directory)
    except OSError as e:
        raise InputError(source, "checkpoint", str(path), f"cannot write in its directory: {e.strerror}") from None
    os.close(fd)
    os.unlink(tmp)


class Checkpoints:
    """A render's checkpoints (render.py): saved every `options.checkpoint_every` seconds of passes and when the
    passes end; with `options.resume`, the file's state restored first."""

    def __init__(self, options, final, r, passes, acc):
        from .errors import API
        from .renderer.device_sums import DeviceSums
        self.path, self.every, self.source, self.r = options.checkpoint, options.checkpoint_every, API, r
        if not options.resume:
            _probe(self.path, self.source)
        self.fingerprint = fingerprint(final, options, r, passes.device_fingerprint(),
                                       "device" if isinstance(acc, DeviceSums) else "host")
        self.command, self.last, self.kept_device = options.checkpoint_command, None, None

    def resume(self, acc):
        """Restore `acc` from the file; returns the seconds, history and stopping reason done (render.py's
        `done`). A damaged file, or one whose counts its schedule cannot give, is refused in one line."""
        meta, arrays = load(self.path, self.source, "checkpoint")
        check_fingerprint(meta, self.fingerprint, self.path, self.source, "checkpoint")
        self.kept_device = (meta.get("fingerprint") or {}).get("device")
        try:
            done = _checked_progress(meta.get("progress"), self.r, arrays)
            acc.restore(meta["progress"]["counts"], arrays)
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            raise InputError(self.source, "checkpoint", str(self.path), f"is damaged: {e}") from None
        return done

    def after_pass(self, passes):
        """After this process's first pass: a Dask render's device, known now, checked against the file's (before
        anything is written) and kept in the fingerprint."""
        if self.fingerprint["device"] is None:
            device = passes.device_fingerprint()
            if self.kept_device is not None and json.loads(json.dumps(device)) != self.kept_device:
                raise _made_for(PARTS["device"], self.path, self.source, "checkpoint")
            self.fingerprint["device"] = device

    def save_if_due(self, acc, render_seconds, wall_seconds, history):
        """save() once `every` seconds have passed since the last (or since the passes began)."""
        if wall_seconds - (self.last if self.last is not None else 0.0) >= self.every:
            self.save(acc, render_seconds, wall_seconds, history)

    def save(self, acc, render_seconds, wall_seconds, history, stopped_by=None):
        """Write the state now (stopped_by: what ended the passes, at the end). An OSError (a full disk) is one
        line naming the file."""
        counts, arrays = acc.state()
        try:
            save(self.path, {"fingerprint": self.fingerprint, "command": self.command,
                             "progress": {"counts": counts, "render_seconds": render_seconds,
                                          "wall_seconds": wall_seconds, "history": history,
                                          "stopped_by": stopped_by}}, arrays)
        except OSError as e:
            raise InputError(self.source, "checkpoint", str(self.path), f"cannot write: {e.strerror or e}") from None
        self.last = wall_seconds
