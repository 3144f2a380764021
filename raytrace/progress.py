"""The progress bar of a render (tqdm, on stderr), a watcher (watch.py): from the first moment on a terminal,
its slow steps before the passes labelled ("building the kernel"), then the pixel samples done of those asked
for, the pass, the estimated relative error and the time left.

The time left is estimated from the measured seconds per pixel sample of this run's passes (not from the
time since the bar appeared, which holds the kernel build) towards what ends the render first: the samples
asked for; the time limit; the target error, reached, as the error falls as 1/sqrt(samples), after
spp (error / target)^2 samples. A terminal's bar is redrawn twice a second (a thread), so that its clock runs
through a build; elsewhere (a log file) the bar appears once the render has taken a second, as before."""
import sys
import threading
import time

from .watch import Watcher

REDRAW_SECONDS = 0.5
QUIET_SECONDS = 1.0  # off a terminal, no bar for a render shorter than this


def seconds_left(report, rate, time_limit=None, target_error=None):
    """The estimated seconds until the render ends, or None before a rate is measured. `rate`: seconds per
    pixel sample of this run's passes."""
    if rate is None:
        return None
    samples = report.max_spp - report.spp
    relative = report.estimated_relative_rmse
    if target_error is not None and relative is not None and relative > 0 and report.spp > 0:
        samples = min(samples, max(0.0, report.spp * (relative / target_error) ** 2 - report.spp))
    left = samples * rate
    if time_limit is not None:
        left = min(left, max(0.0, time_limit - report.seconds))
    return left


def _clock(seconds):
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}" if seconds >= 3600 else \
        f"{seconds // 60:02d}:{seconds % 60:02d}"


class Progress(Watcher):
    """The bar: `wanted` True (always), False (never) or None (from the first moment on a terminal, after a
    second elsewhere)."""

    def __init__(self, wanted, time_limit=None, target_error=None, file=None):
        self.wanted, self.time_limit, self.target_error = wanted, time_limit, target_error
        self.file = file or sys.stderr
        self.bar, self.start, self.lock = None, time.perf_counter(), threading.Lock()
        self.first = None  # (seconds, spp) when this run's passes began
        self.stop, self.thread = threading.Event(), None  # one redraw thread, from the bar's first opening
        self.terminal = wanted is None and hasattr(self.file, "isatty") and self.file.isatty()

    def _open(self, description, total=None):
        if self.bar is None and self.wanted is not False:
            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="spp", file=self.file, leave=False, desc=description,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} spp [{elapsed}"
                            "{postfix}]" if total else "{desc} [{elapsed}]")
            if (self.wanted or self.terminal) and self.thread is None:
                self.thread = threading.Thread(target=self._redraw, daemon=True)
                self.thread.start()

    def _redraw(self):
        while not self.stop.wait(REDRAW_SECONDS):
            with self.lock:
                if self.bar is not None:
                    self.bar.refresh()

    def building(self, what):
        with self.lock:
            if self.wanted or self.terminal:
                self._open(what)
            elif self.bar is not None:
                self.bar.set_description_str(what, refresh=False)

    def started(self, report):
        with self.lock:
            self.first = (report.seconds, report.spp)
            if self.bar is not None:  # the build's bar becomes the passes'
                self.bar.close()
                self.bar = None
            if self.wanted or self.terminal:
                self._open("rendering", report.max_spp)
                self.bar.update(report.spp)

    def pass_done(self, report):
        with self.lock:
            if self.bar is None and self.wanted is None and report.spp < report.max_spp and (
                    time.perf_counter() - self.start > QUIET_SECONDS):
                self._open("rendering", report.max_spp)
            if self.bar is None:
                return None
            seconds, spp = self.first
            rate = (report.seconds - seconds) / (report.spp - spp) if report.spp > spp else None
            left = seconds_left(report, rate, self.time_limit, self.target_error)
            error = "?" if report.estimated_relative_rmse is None else f"{report.estimated_relative_rmse:.2e}"
            eta = "?" if left is None else _clock(left)
            self.bar.set_postfix_str(f"pass {report.passes}/{report.planned_passes}, est. rel. error {error}, "
                                     f"{eta} left", refresh=False)  # with the samples, in one redraw
            self.bar.n = report.spp
            self.bar.refresh()
        return None

    def finished(self, report):
        self.stop.set()
        with self.lock:
            if self.bar is not None:
                self.bar.close()
                self.bar = None
