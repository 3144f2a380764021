"""raytrace.show() in a real notebook: a notebook made here is executed by nbclient with a real IPython kernel
(ipykernel, this interpreter), and the kernel's messages are read as Jupyter reads them. The cell that calls
show() makes two outputs with display ids, the line and the image; the image is replaced by an
update_display_data message after each pass but the first (which made it), the line after each moment; what
the cell holds at the end is the final image (the PNG of the returned image, as the image shows itself) under
the final line (the samples taken).

The render: 64 x 48 at 6144 samples, three passes of 2048 (renderer/progressive.PASS_WORK) of about a tenth
of a second each, against a PNG of 64 x 48 in about a millisecond: every pass is shown (notebook.py's budget
is a tenth of the render's time).

Mutations tried, each failing the test: a new display each pass instead of an update (display_data per pass);
no update in pass_done (the image updates are none); the final image shown again whatever was shown (passes
updates, not passes - 1); the line's samples the passes' count; no final line; the image of the first pass
kept (the cell's image is not the returned one's PNG)."""
import base64
import hashlib
import re

import nbformat
from nbclient import NotebookClient

from helpers import CORNELL
from raytrace.commands import child_env

KERNEL_SECONDS = 180  # a kernel's start on a loaded machine: seconds, allowed minutes
CELL_SECONDS = 600    # a cold PoCL cache builds the kernel (a minute), then a second of rendering


class RecordingClient(NotebookClient):
    """nbclient's client, which also keeps every display message of the kernel, with its cell."""

    def process_message(self, msg, cell, cell_index):
        if msg["msg_type"] in ("display_data", "update_display_data"):
            self.displays.append((cell_index, msg["msg_type"], msg["content"]))
        return super().process_message(msg, cell, cell_index)


def test_show_updates_the_image_in_place(tmp_path):
    cells = ["import hashlib\nimport raytrace\nscene = raytrace.load_file(%r)" % CORNELL,
             'image, stats = raytrace.show(scene, width=64, height=48, spp=6144, sampler="sobol")',
             "print(stats.passes, stats.spp, hashlib.sha256(image._repr_png_()).hexdigest())"]
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    client = RecordingClient(notebook, timeout=CELL_SECONDS, startup_timeout=KERNEL_SECONDS, kernel_name="python3",
                             resources={"metadata": {"path": str(tmp_path)}})
    client.displays = []
    client.execute(env=child_env())

    passes, spp, digest = notebook.cells[2].outputs[0]["text"].split()
    passes, spp = int(passes), int(spp)
    assert passes == 3 and spp == 6144
    shown = [(kind, content) for cell, kind, content in client.displays if cell == 1]
    images = [(kind, content) for kind, content in shown if "image/png" in content["data"]]
    lines = [(kind, content) for kind, content in shown if "image/png" not in content["data"]]
    assert [kind for kind, _ in images] == ["display_data"] + ["update_display_data"] * (passes - 1)
    assert len({content["transient"]["display_id"] for _, content in images}) == 1
    assert [kind for kind, _ in lines][0] == "display_data" and len({c["transient"]["display_id"] for _, c in lines}) == 1
    texts = [content["data"]["text/plain"] for _, content in lines]
    pass_lines = [t for t in texts if t.startswith("pass ")]
    assert [re.match(r"pass (\d+), (\d+) spp, ", t).groups() for t in pass_lines] == [
        (str(k), str(2048 * k)) for k in range(1, passes + 1)]
    assert texts[-1].startswith(f"{spp} spp in {passes} passes, ") and texts[-1].endswith("; stopped by spp")

    outputs = notebook.cells[1].outputs  # as the kernel left them: the line, then the image, each updated in place
    assert [o["output_type"] for o in outputs] == ["display_data", "display_data"]
    assert outputs[0]["data"]["text/plain"] == texts[-1]
    assert hashlib.sha256(base64.b64decode(outputs[1]["data"]["image/png"])).hexdigest() == digest


class InterruptingClient(RecordingClient):
    """Interrupts the kernel, as the stop button does, once the first image of the render is shown."""

    def process_message(self, msg, cell, cell_index):
        content = msg.get("content", {})
        if (msg["msg_type"] == "display_data" and "image/png" in content.get("data", {}) and not self.sent):
            import asyncio
            self.sent = True
            asyncio.ensure_future(self.km.interrupt_kernel())
        return super().process_message(msg, cell, cell_index)


def test_an_interrupt_keeps_the_samples_done(tmp_path):
    """The kernel interrupted after the first pass is shown: the render ends after the pass under way and show()
    returns its image (the cell does not fail), stopped by "interrupt", with fewer samples than asked for. A render
    of 64 passes of 1024 samples at 64 x 48, a fraction of a second each: the interrupt lands within a few.
    Mutation tried: no handler put in (the interrupt raises KeyboardInterrupt in the cell: the test fails)."""
    cells = ["import raytrace\nscene = raytrace.load_file(%r)" % CORNELL,
             'image, stats = raytrace.show(scene, width=64, height=48, spp=65536, sampler="sobol", '
             'max_pass_work=64 * 48 * 17 * 1024)',
             "print(stats.stopped_by, stats.spp, stats.passes)"]
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    client = InterruptingClient(notebook, timeout=CELL_SECONDS, startup_timeout=KERNEL_SECONDS,
                                kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.displays, client.sent = [], False
    client.execute(env=child_env())
    stopped_by, spp, passes = notebook.cells[2].outputs[0]["text"].split()
    assert client.sent and stopped_by == "interrupt" and 0 < int(spp) < 65536 and int(passes) >= 1
    line = notebook.cells[1].outputs[0]["data"]["text/plain"]
    assert line.endswith("; stopped by interrupt") and line.startswith(f"{spp} spp in {passes} pass")
