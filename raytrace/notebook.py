"""Rendering in a Jupyter notebook: raytrace.show(scene, spp=...) renders as render() does and shows the image
as it converges, updated in place after each pass, below a line of where the render stands. A watcher
(watch.py) that speaks IPython's display protocol: an output made with a display_id and replaced by
update_display_data messages, which Jupyter, JupyterLab and VS Code redraw where the output is.

IPython is imported when show() is called, not with the package: it is no dependency of raytrace, and a
notebook's kernel has it.

The image is the PNG Image._repr_png_ makes (the 8-bit encoding of the command line's .png), so the shown
image and `image` displayed by itself are the same picture. A pass's update is skipped while the display has
taken more than watch.DISPLAY_SHARE of the render's wall time (the PNG encoding is host time), never the last."""
import signal
import threading
import time

from .image import Image
from .render import render
from .watch import DISPLAY_SHARE, Watcher


def _error(relative):
    return "?" if relative is None else f"{relative:.2e}"


def pass_line(report):
    """The line above the image after a pass: "pass 3, 48 spp, 1.2 s, est. rel. error 4.10e-03"."""
    return (f"pass {report.passes}, {report.spp} spp, {report.seconds:.1f} s, est. rel. error "
            f"{_error(report.estimated_relative_rmse)}")


def final_line(report):
    """The line once the render has ended: the samples, passes, seconds, error and what stopped it."""
    return (f"{report.spp} spp in {report.passes} pass{'es' * (report.passes != 1)}, {report.seconds:.1f} s, "
            f"est. rel. error {_error(report.estimated_relative_rmse)}; stopped by {report.stopped_by}")


class NotebookDisplay(Watcher):
    """Two outputs of the cell that renders: the line of where the render stands (from the first moment:
    "building the kernel", then each pass) and, from the first pass on, the image."""

    def __init__(self, max_share=DISPLAY_SHARE):
        from IPython import display  # here: a notebook's kernel has it, the package does not need it
        self.ipython, self.max_share = display, max_share
        self.line = self.image = None
        self.shown_spp, self.display_seconds = None, 0.0
        self.interrupted, self.handler = False, None

    def _keep_interrupt(self):
        """Jupyter's interrupt (SIGINT to the kernel) ends the render after the pass under way, keeping its samples,
        as Ctrl-C does on the command line; a second one raises KeyboardInterrupt as ever."""
        if threading.current_thread() is not threading.main_thread():
            return
        before = signal.getsignal(signal.SIGINT)

        def interrupt(signum, frame):
            if self.interrupted:
                self._release()
                raise KeyboardInterrupt
            self.interrupted = True
        self.handler = before
        signal.signal(signal.SIGINT, interrupt)

    def _release(self):
        if self.handler is not None:
            signal.signal(signal.SIGINT, self.handler)
            self.handler = None

    def _say(self, text):
        bundle = {"text/plain": text}
        if self.line is None:
            self.line = self.ipython.display(bundle, raw=True, display_id=True)
        else:
            self.line.update(bundle, raw=True)

    def building(self, what):
        self._say(what)

    def started(self, report):
        self._keep_interrupt()
        self._say(f"rendering {report.width}x{report.height}, {report.max_spp} spp")

    def pass_done(self, report):
        if self.max_share is None or self.display_seconds <= self.max_share * report.seconds:
            self._show(report)
            self._say(pass_line(report))
        return "interrupt" if self.interrupted else None

    def finished(self, report):
        self._release()
        if report is None:  # an exception ends the render: the cell shows it
            return
        if self.shown_spp != report.spp:
            self._show(report)
        self._say(final_line(report))

    def _show(self, report):
        start = time.perf_counter()
        png = Image.of(report.image())._repr_png_()
        if png is not None:
            picture = self.ipython.Image(data=png, format="png")
            if self.image is None:
                self.image = self.ipython.display(picture, display_id=True)
            else:
                self.image.update(picture)
        self.shown_spp = report.spp
        self.display_seconds += time.perf_counter() - start


def show(scene, **options):
    """Render `scene` in a Jupyter notebook, showing the image after each pass with a line of the passes,
    samples, seconds and estimated relative error; returns (image, stats) as render() does. Interrupting the
    kernel (the stop button, or I I) ends the render after the pass under way and returns what it has
    (stats.stopped_by "interrupt"); a second interrupt stops it at once. The keyword
    arguments are render()'s; progress defaults to False here (the line is the progress), and watchers given
    in watch= are called as well."""
    display, given = NotebookDisplay(), options.get("watch")
    options.setdefault("progress", False)
    options["watch"] = [*given, display] if isinstance(given, (list, tuple)) else given or [display]
    return render(scene, **options)
