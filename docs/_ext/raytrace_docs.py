"""The part of the manual generated from the data when the manual is built, so that the two cannot drift apart:
`{performance-tables}`, the current figures per machine kind, from benchmarks/results/*.json.

The tables generated from the code (every key of a scene file, from raytrace/scene/keys.py) are written into
the Markdown pages themselves by `python -m devtools.docs_tables`, so that a page shows them on a repository's
web page too, where a directive shows nothing; tests/test_docs.py checks that they are current.
"""
import json
import re
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive, Parser
from docutils.utils import new_document

ROOT = Path(__file__).resolve().parents[2]


def list_table(header, rows, widths):
    lines = [".. list-table::", "   :header-rows: 1", f"   :widths: {' '.join(map(str, widths))}", ""]
    for row in [header, *rows]:
        lines.append(f"   * - {row[0]}")
        lines.extend(f"     - {cell}" for cell in row[1:])
    return lines + [""]


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
    scene of its command goes first: a TOML scene by its stem, a Mitsuba XML one with its suffix."""
    scene = re.match(r"python -m raytrace converge (\S+)\.(toml|xml)\b", record["command"])
    if not scene:
        return figure["what"]
    return f"{Path(scene[1]).name}{'' if scene[2] == 'toml' else '.xml'}: {figure['what']}"


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


class PerformanceTables(_Generated):
    make = staticmethod(performance_lines)


def setup(app):
    app.add_directive("performance-tables", PerformanceTables)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
