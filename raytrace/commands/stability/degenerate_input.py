"""Case 11, degenerate_input: degenerate shapes in a scene file, refused at load and on the command line, and
nearly degenerate ones, rendered."""
import dataclasses
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...scene import Triangle, load_file
from ...scene.ranges import brightest
from .. import child_env
from .common import SCENE0, Row, nonfinite, outside


# ---------------------------------------------------------------------------------------------------------
# 11. Degenerate input

ZERO_AREA = [[0.0, 0.0, 0.5], [0.5, 0.5, 1.0], [1.0, 1.0, 1.5]]
SINGULAR = [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.2, 0.4, 0.0]]  # the third axis in the plane of the others
FLAT = [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.2, 0.2, 6e-7]]     # determinant 2.1e-6 of the axes' lengths
SLIVER = [[-0.6, 0.0, 1.0], [0.6, 0.0, 1.0], [0.0, 2.4e-9, 1.0]]  # area 2e-9 of its longest edge squared
AXES0 = "[[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.0, 0.0, 0.4]]"     # scene 0's ellipsoid


def with_triangle(text, vertices):
    return text + f'\n[[shapes]]\ntype = "triangle"\nvertices = {vertices}\nmaterial = "white"\n'


def rejected(path, key, value):
    """How many of 9 checks fail for a bad scene file: load_file raises InputError with its file, key and
    value, in one line (4); `python -m raytrace render FILE -o OUT` exits with 2 and one line on stderr
    naming file, key and value, no traceback, and writes nothing (5)."""
    failed = 0
    try:
        load_file(path)
        failed += 4
    except InputError as e:
        failed += (e.source != str(path)) + (e.key != key) + (e.value != value) + ("\n" in str(e))
    out = path.parent / "out" / "x.png"
    out.parent.mkdir()
    cli = subprocess.run([sys.executable, "-m", "raytrace", "render", str(path), "-o", str(out)], capture_output=True,
                         text=True, env=child_env())
    failed += (cli.returncode != 2) + (cli.stderr.count("\n") != 1) + (f"{path}: {key} = {value}" not in cli.stderr)
    return failed + ("Traceback" in cli.stderr) + bool(list(out.parent.iterdir()))


def degenerate_input(env):
    """Scene 0's file with a zero-area triangle added, or its ellipsoid made singular (the third axis in the
    plane of the other two): refused at load and on the command line (rejected(), bound 0). The nearly
    degenerate shapes the loader accepts, each just above its threshold: a triangle of area 2e-9 of its
    longest edge squared (2.4e-9 across; the loader refuses 1e-9, so 1e-12 cannot come from a file) and an
    ellipsoid whose axes' determinant is 2.1e-6 of the product of their lengths (1e-6 thick): rendered
    48 x 48, no NaN or Inf, every value in [0, brightest()]. A triangle of area 1e-12 of its edge squared,
    built directly in Python, is refused by render() as the loader refuses it (bound 0 checks failed of 3:
    an InputError naming triangles[4].vertices, in one line, before any work)."""
    text, rows = SCENE0.read_text(), []
    with tempfile.TemporaryDirectory() as tmp:
        for name, edited, key, value in (("zero-area triangle", with_triangle(text, ZERO_AREA), "shapes[7].vertices",
                                          ZERO_AREA),
                                         ("singular ellipsoid", text.replace(AXES0, str(SINGULAR)), "shapes[6].axes",
                                          SINGULAR)):
            path = Path(tmp) / name.replace(" ", "-") / "bad.toml"
            path.parent.mkdir()
            path.write_text(edited)
            rows.append(Row(f"{name} in a scene file: loader and command-line checks failed (of 9)",
                            rejected(path, key, value), "checks", 0, "one line: file, key, value; exit 2"))
        path = Path(tmp) / "nearly.toml"
        path.write_text(with_triangle(text.replace(AXES0, str(FLAT)), SLIVER))
        nearly = load_file(path)
    needle = Triangle(np.array([[0.0, 0.3, 0.2], [0.0, 0.3, 1.4], [1.2e-12, 0.3, 0.8]]))
    built = dataclasses.replace(env.cornell, triangles=env.cornell.triangles + [needle])
    try:
        env.render(built, width=48, height=48, spp=1, sampler="center", light_samples=4)
        failed = 3
    except InputError as e:
        failed = (e.source != "render()") + (e.key != f"triangles[{len(built.triangles) - 1}].vertices") + ("\n" in str(e))
    rows.append(Row("a 1e-12 triangle built in Python: render()'s checks failed (of 3)", failed, "checks", 0,
                    "the loader's check, on every path"))
    images, bad = [], 0
    image, b = env.render(nearly, width=48, height=48, spp=1, sampler="center", light_samples=4)
    images.append(image)
    bad += b + nonfinite(image)
    limit = brightest(nearly)
    rows.append(Row(f"nearly degenerate triangle and ellipsoid: values outside [0, {limit:.3g}]",
                    outside(images, limit), "values", 0, "max k (ambient + 2 sum L)", bad))
    return rows
