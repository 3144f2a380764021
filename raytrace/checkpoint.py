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
    """The package's version and a digest of the kernel sources: a checkpoint of another build is refused (its
    passes may not add up to the same bits)."""
    from importlib.metadata import PackageNotFoundError, version
    from .renderer.program import kernel_dir
    try:
        package = version("raytrace")
    except PackageNotFoundError:
        package = "unknown"
    digest = hashlib.blake2b(digest_size=8)
    for path in sorted(Path(kernel_dir()).rglob("*")):
        if path.suffix in (".cl", ".h"):
            digest.update(path.relative_to(kernel_dir()).as_posix().encode())
            digest.update(path.read_bytes())
    return f"{package}+kernels.{digest.hexdigest()}"


def fingerprint(final, options, r, device):
    """What must agree for a checkpoint to be continued: {part: value}, each part compared by name on
    resuming, so that a refusal says which differs."""
    from .scene.model import fingerprint as model_fingerprint
    features = options.features.options() if options.features is not None else None
    return {"version": software_version(), "scene": model_fingerprint(final),
            "options": {"texture_filter": options.texture_filter, "time_limit": options.time_limit,
                        "target_error": options.target_error, "lanes": options.lanes,
                        "features": None if features is None else list(features),
                        "max_pass_work": options.max_pass_work, "accumulate": options.accumulate},
            "schedule": [list(p) for p in r.passes], "device": device}


PARTS = {"version": "another raytrace or kernel source", "scene": "another scene (or the scene changed since)",
         "options": "other options", "schedule": "another pass schedule", "device": "another device or kernel variant"}


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


def load(path, source="command line", key="--resume"):
    """(meta, arrays) of a checkpoint file; InputError naming it for a file that is not one."""
    try:
        with open(path, "rb") as f:
            data = f.read()
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
        meta = json.loads(arrays.pop("meta").tobytes().decode())
    except OSError as e:
        raise InputError(source, key, str(path), f"cannot read: {e.strerror or e}") from None
    except (zipfile.BadZipFile, EOFError):
        raise InputError(source, key, str(path), "is not a raytrace checkpoint (not an .npz archive)") from None
    except (ValueError, KeyError, UnicodeDecodeError):
        raise InputError(source, key, str(path), "is not a raytrace checkpoint (no meta it can read)") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(source, key, str(path), f"is not a raytrace checkpoint (no '{FORMAT}' header)")
    return meta, arrays


def check_fingerprint(meta, expected, path, source="command line", key="--resume"):
    """Refuse, in one line naming the first part that differs, a checkpoint made for another render."""
    given = meta.get("fingerprint") or {}
    expected = json.loads(json.dumps(finite_json(expected)))  # as the file holds it: lists, not tuples
    for part, what in PARTS.items():
        if part == "device" and None in (given.get(part), expected.get(part)):
            continue  # a Dask render's: its workers' devices are known after a pass (a Dask render equals a local one)
        if given.get(part) != expected.get(part):
            raise InputError(source, key, str(path), f"was made for {what}: refusing to continue it")


class Checkpoints:
    """A render's checkpoints (render.py): saved every `options.checkpoint_every` seconds of passes and when the
    passes end; with `options.resume`, the file's state restored first."""

    def __init__(self, options, final, r, passes):
        from .errors import API
        from .renderer.device_render import LocalPasses
        info = passes.info() if isinstance(passes, LocalPasses) else None  # a Dask render's workers: after a pass
        device = None if info is None else {"device": info["device"], "build_options": info["build_options"]}
        self.path, self.every, self.source = options.checkpoint, options.checkpoint_every, API
        self.fingerprint = fingerprint(final, options, r, device)
        self.command, self.last = options.checkpoint_command, None

    def resume(self, acc):
        """Restore `acc` from the file; returns the seconds and history done (render.py's `done`)."""
        meta, arrays = load(self.path, self.source, "checkpoint")
        check_fingerprint(meta, self.fingerprint, self.path, self.source, "checkpoint")
        try:
            progress = meta["progress"]
            acc.restore(progress["counts"], arrays)
            done = {"render_seconds": float(progress["render_seconds"]),
                    "wall_seconds": float(progress["wall_seconds"]), "history": list(progress["history"])}
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(self.source, "checkpoint", str(self.path), f"is damaged: {e}") from None
        return done

    def save_if_due(self, acc, render_seconds, wall_seconds, history):
        """save() once `every` seconds have passed since the last (or since the passes began)."""
        if wall_seconds - (self.last if self.last is not None else 0.0) >= self.every:
            self.save(acc, render_seconds, wall_seconds, history)

    def save(self, acc, render_seconds, wall_seconds, history):
        counts, arrays = acc.state()
        save(self.path, {"fingerprint": self.fingerprint, "command": self.command,
                         "progress": {"counts": counts, "render_seconds": render_seconds, "wall_seconds": wall_seconds,
                                      "history": history}}, arrays)
        self.last = wall_seconds
