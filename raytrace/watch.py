"""Watching a render as it goes: render(scene, watch=[...]) calls each watcher's methods at the render's
moments, with a PassReport of where it stands. The progress bar (progress.py) and the command line's Ctrl-C
that keeps the samples done (cli.py) are watchers, as are the viewers that show a render as it goes; so may a
user's object be.

Every method is optional (Watcher's do nothing):

    building(what)          a slow step before the passes: "building the kernel", "uploading the scene"
    started(report)         the passes are about to begin (report.spp: 0, or a resumed render's samples)
    pass_done(report)       after every pass; a str returned stops the render after it (stats.stopped_by)
    finished(report)        once at the end, however the passes ended; report.image() is the final image;
                            report None where an exception (an error, an interrupting signal) ended the render

An exception in a watcher ends the render as any other does."""
from dataclasses import dataclass, field

DISPLAY_SHARE = 0.1  # of a render's wall time, what a viewer's updates may take at most (tev.py, notebook.py)


@dataclass
class PassReport:
    """Where a render stands: passes done and planned, pixel samples done and asked for, wall seconds since
    the passes began (a resumed render's earlier seconds included), the estimated error (None until two halves
    of the samples exist), the image's size; image() the mean of the samples so far."""
    passes: int
    planned_passes: int
    spp: int
    max_spp: int
    seconds: float
    estimated_rmse: float | None
    estimated_relative_rmse: float | None
    width: int
    height: int
    stopped_by: str | None = None  # finished(): "spp", "time-limit", "target-error" or a watcher's reason
    _image: object = field(default=None, repr=False)  # a function making the image, or the image once made

    def image(self):
        """H x W x 3 float32: the linear mean of the samples so far (made on the first call: host time)."""
        if callable(self._image):
            self._image = self._image()
        return self._image


class Watcher:
    """A render's watcher, given as render(scene, watch=[...]): override the moments it needs; each is called
    in the render's own thread, between passes (so a slow watcher slows the render)."""

    def building(self, what):
        """A slow step before the passes begins: `what` says which ("building the kernel")."""

    def started(self, report):
        """The passes are about to begin: report.spp is 0, or the samples a resumed render had."""

    def pass_done(self, report):
        """A pass has been added; return a str to stop the render after it (RenderStats.stopped_by), else None."""
        return None

    def finished(self, report):
        """The passes ended (report.stopped_by says why); report.image() is the final image. `report` is None
        where an exception ended the render: let go of what the watcher holds (a socket, a thread)."""


def check_watchers(watch, source, key):
    """The watchers given as render(watch=...): a list or tuple of objects, each with at least one of the
    moments' methods; InputError otherwise."""
    from .errors import InputError
    if watch is None:
        return []
    if not isinstance(watch, (list, tuple)):
        raise InputError(source, key, type(watch).__name__, "must be a list of watchers (raytrace.Watcher)")
    moments = ("building", "started", "pass_done", "finished")
    for w in watch:
        if not any(callable(getattr(w, m, None)) for m in moments):
            raise InputError(source, key, type(w).__name__, f"is no watcher: it has none of {', '.join(moments)}")
    return list(watch)


def call(watchers, moment, *args):
    """Call `moment` of every watcher that has it; the first str returned (pass_done's stop), or None."""
    reason = None
    for w in watchers:
        method = getattr(w, moment, None)
        if callable(method):
            returned = method(*args)
            if reason is None and isinstance(returned, str):
                reason = returned
    return reason
