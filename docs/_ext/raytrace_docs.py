"""Parts of the manual generated from the code and the data, so that the two cannot drift apart:

- `{scene-keys}`: every key of a scene file, from raytrace/scene/keys.py (the declarations the reader checks
  values against);
- `{performance-tables}`: the current figures per machine kind, from benchmarks/results/*.json.
"""
import json
import math
import re
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive, Parser
from docutils.utils import new_document

ROOT = Path(__file__).resolve().parents[2]


def _number(x):
    if x == math.inf:
        return "inf"
    if isinstance(x, float) and (abs(x) >= 1e6 or 0 < abs(x) < 1e-3):
        return f"{x:.6g}"
    return f"{x:g}" if isinstance(x, float) else str(x)


def _range(key):
    low, high = key.low > -math.inf, key.high < math.inf
    if low and high:
        return f"{'(' if key.open_low else '['}{_number(key.low)}, {_number(key.high)}{')' if key.open_high else ']'}"
    if low:
        return f"{'>' if key.open_low else '>='} {_number(key.low)}"
    return f"{'<' if key.open_high else '<='} {_number(key.high)}" if high else ""


def accepted(key):
    """(its type, what it accepts) in words, from a key's declaration alone."""
    kind = {"number": "number", "integer": "integer", "string": "string", "boolean": "true or false",
            "path": "file path", "table": "table", "tables": "array of tables", "named-tables": "table of tables",
            "faces": "list of index triples", "vector": f"{key.length} numbers",
            "number-or-vector": f"number or {key.length} numbers",
            "vectors": f"{key.count} vectors of {key.length} numbers" if key.count
            else f"one or more vectors of {key.length} numbers"}[key.kind]
    bounds = [_range(key)] if _range(key) else []
    if bounds and key.kind in ("vector", "vectors", "number-or-vector"):
        bounds = [("each in " if bounds[0][0] in "[(" else "each ") + bounds[0]]
    if key.choices:
        bounds.append("one of " + ", ".join(f"``{c}``" for c in key.choices))
    if key.nonzero:
        bounds.append("not all 0")
    if key.also:
        bounds.append(key.also)
    return kind, "; ".join(bounds) or "any"


def default_text(key):
    from raytrace.scene.keys import REQUIRED
    if key.default is REQUIRED:
        return "required"
    if key.default is None or key.default == {} or key.default == ():
        return "none"
    if isinstance(key.default, tuple):
        return "[" + ", ".join(_number(x) for x in key.default) + "]"
    if isinstance(key.default, str):
        return f'``"{key.default}"``'
    if isinstance(key.default, bool):
        return str(key.default).lower()
    return _number(key.default)


def list_table(header, rows, widths):
    lines = [".. list-table::", "   :header-rows: 1", f"   :widths: {' '.join(map(str, widths))}", ""]
    for row in [header, *rows]:
        lines.append(f"   * - {row[0]}")
        lines.extend(f"     - {cell}" for cell in row[1:])
    return lines + [""]


def scene_key_lines():
    from raytrace.scene.keys import TABLES
    lines = []
    for table, keys in TABLES.items():
        title = table or "top level"
        lines += [f"**{title}**", ""]
        rows = [[f"``{key.name}``", accepted(key)[0], default_text(key), accepted(key)[1], key.doc] for key in keys]
        lines += list_table(["key", "type", "default", "accepted", "meaning"], rows, [14, 16, 12, 28, 30])
    return lines


def records():
    """Every measurement record of benchmarks/results/, oldest first."""
    found = [json.loads(p.read_text()) | {"file": p.name} for p in sorted((ROOT / "benchmarks" / "results").glob("*.json"))]
    return sorted(found, key=lambda r: (r["date"], r["file"]))


def current(found):
    """{machine: [the newest record of each command]}: older runs of the same command are superseded."""
    latest = {}
    for record in found:
        latest[record["machine"], record["command"]] = record
    machines = {}
    for (machine, _), record in latest.items():
        machines.setdefault(machine, []).append(record)
    return machines


def performance_lines():
    """One table per machine kind: each figure with the number of the run (command, date, commit) it is from."""
    lines = []
    for machine, recs in sorted(current(records()).items()):
        recs = sorted(recs, key=lambda r: (r["date"], r["command"]))
        lines += [machine, "~" * len(machine), ""]
        rows = [[_what(r, figure), f"{_figure(figure['value'])} {figure['unit']}".strip(), f"[{k}]"]
                for k, r in enumerate(recs, 1) for figure in r["figures"]]
        lines += list_table(["what", "figure", "run"], rows, [70, 18, 12])
        for k, r in enumerate(recs, 1):
            lines += [f"[{k}] ``{r['command']}``, {r['date']}, commit ``{r['commit'][:8]}`` "
                      f"(``benchmarks/results/{r['file']}``)", ""]
    return lines


def _what(record, figure):
    """A figure's name; a converge record's figures name no scene (several records share them), so the
    scene of its command goes first."""
    scene = re.match(r"python -m raytrace converge (\S+)\.toml", record["command"])
    return f"{Path(scene[1]).name}: {figure['what']}" if scene else figure["what"]


def _figure(value):
    return f"{value:.3g}" if isinstance(value, float) else str(value)


class _Generated(Directive):
    """A directive whose body is reStructuredText made by `make()`. The body is parsed by docutils' own
    reStructuredText parser, not by the page's: the pages are MyST Markdown, whose parser reads a list-table
    as a paragraph and a list, and a ~~~ underline as a code fence."""
    make = None

    def run(self):
        page = self.state.document
        body = new_document(f"<{self.name}>", page.settings)
        body.reporter = page.reporter
        Parser().parse("\n".join(type(self).make()), body)
        for node in body.findall(nodes.Element):
            if node["ids"]:
                page.note_implicit_target(node, node)
        return body.children


class SceneKeys(_Generated):
    make = staticmethod(scene_key_lines)


class PerformanceTables(_Generated):
    make = staticmethod(performance_lines)


def setup(app):
    app.add_directive("scene-keys", SceneKeys)
    app.add_directive("performance-tables", PerformanceTables)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
