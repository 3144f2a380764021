"""`python -m devtools.docs_tables [--check]`: the manual's tables that are made from the code, written into the
Markdown pages themselves, so that a page reads the same on a repository's web page as in the built manual
(a Sphinx directive shows nothing there).

A generated part lies between two marker comments, which Markdown readers do not show:

    <!-- scene-keys:begin ... -->
    ...
    <!-- scene-keys:end -->

The command rewrites what is between them in every page of docs/ from the code; `--check` writes nothing and
exits with status 1, naming the pages, when a page differs from what the code makes now. tests/test_docs.py
fails the same way, so a key declared in raytrace/scene/keys.py and not regenerated into the page is caught.

Generated parts, by marker name:

- `scene-keys`: every key of a scene file, one table per table of the file, from raytrace/scene/keys.py (the
  declarations the reader checks each value against): its type, default, accepted values and meaning.
- `mitsuba-plugins`: every Mitsuba 3 plugin raytrace reads, from raytrace/scene/mitsuba.py's declarations: each
  parameter, Mitsuba's default and the raytrace key it becomes, with that key's accepted values from keys.py.
- `bsdfs`: the manual's page of BSDFs, from raytrace/scene/bsdfs.py's declarations: a section per BSDF with its
  doc, its parameters (the scene file's key, type, default, Mitsuba's default, accepted values) and an example.
"""
import argparse
import math
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
COMMAND = "python -m devtools.docs_tables"
REGION = re.compile(r"(<!-- ([\w-]+):begin[^\n]*?-->\n)(.*?)(<!-- \2:end -->)", re.S)


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
    """(its type, what it accepts) in words, from a key's declaration alone; names of values as Markdown code."""
    kind = {"number": "number", "integer": "integer", "string": "string", "boolean": "true or false",
            "number-or-name": "number or name",
            "path": "file path", "table": "table", "tables": "array of tables", "named-tables": "table of tables",
            "faces": "list of index triples", "vector": f"{key.length} numbers", "strings": f"{key.length} names",
            "number-or-vector": f"number or {key.length} numbers",
            "vectors": f"{key.count} vectors of {key.length} numbers" if key.count
            else f"one or more vectors of {key.length} numbers"}[key.kind]
    bounds = [_range(key)] if _range(key) else []
    if bounds and key.kind in ("vector", "vectors", "number-or-vector"):
        bounds = [("each in " if bounds[0][0] in "[(" else "each ") + bounds[0]]
    names = key.choices or tuple(name for name, _ in key.named)
    if len(names) > MANY:
        bounds.append(f"{'or ' if key.named else ''}one of {len(names)} names: {', '.join(f'`{c}`' for c in names[:4])}"
                      " and others (docs/bsdfs.md lists them)")
    elif names:
        bounds.append(f"{'or ' if key.named else ''}one of " + ", ".join(f"`{c}`" for c in names))
    if key.nonzero:
        bounds.append("not all 0")
    if key.also:
        bounds.append(key.also)
    return kind, "; ".join(bounds) or "any"


MANY = 12  # a key's names beyond this many are listed on the BSDFs' page, not in each table's cell


def default_text(key):
    """A key's default as the table shows it: "required", "none", a number, a list, `"text"` or true/false."""
    from raytrace.scene.keys import REQUIRED
    if key.default is REQUIRED:
        return "required"
    if key.default is None or key.default == {} or key.default == ():
        return "none"
    if isinstance(key.default, tuple):
        return "[" + ", ".join(_number(x) for x in key.default) + "]"
    if isinstance(key.default, str):
        return f'`"{key.default}"`'
    if isinstance(key.default, bool):
        return str(key.default).lower()
    return _number(key.default)


def markdown_table(header, rows):
    """A Markdown pipe table (GitHub's and MyST's): a | inside a cell is escaped."""
    def line(cells):
        return "| " + " | ".join(str(cell).replace("|", r"\|") for cell in cells) + " |"
    return [line(header), "|" + "---|" * len(header), *map(line, rows)]


def scene_keys():
    """Every table of a scene file, in keys.py's order: its name in bold, then its keys' table."""
    from raytrace.scene.keys import TABLES
    lines = []
    for table, keys in TABLES.items():
        rows = []
        for key in keys:
            kind, values = accepted(key)
            rows.append([f"`{key.name}`", kind, default_text(key), values, key.doc])
        lines += [f"**{table or 'top level'}**", "",
                  *markdown_table(["key", "type", "default", "accepted", "meaning"], rows), ""]
    return lines


def _raytrace_key(target):
    """A Mitsuba parameter's raytrace key ("table key" in keys.py's terms) as the table shows it, with what that
    key accepts; ("", "") where the parameter changes nothing raytrace computes."""
    from raytrace.scene.keys import TABLES, table
    if not target:
        return "(no effect)", ""
    if target in TABLES:
        return f"`{target}`", ""
    name, key = target.rsplit(" ", 1)
    declared = table(name).get(key)
    if declared is None:
        return f"`{target}`", ""
    values = accepted(declared)[1]
    return f"`{name.split(' ')[0]}.{key}`", "" if values == "any" else values


def mitsuba_plugins():
    """Every Mitsuba 3 plugin raytrace reads, by category, from raytrace/scene/mitsuba.py's PLUGINS: each
    parameter, Mitsuba's default, the raytrace key it becomes (and what that key accepts, from keys.py)."""
    from raytrace.scene.mitsuba import CATEGORIES, PLUGINS
    lines = []
    for category in CATEGORIES:
        for name, plugin in PLUGINS.items():
            if plugin.category != category:
                continue
            lines += [f"**{category} `{name}`**: {plugin.doc}", ""]
            rows = []
            for p in plugin.params:
                key, values = _raytrace_key(p.key)
                default = "required" if p.default is None else (
                    f"`{str(p.default).lower()}`" if isinstance(p.default, bool) else f"`{p.default}`")
                rows.append([f"`{p.name}`", default, key, "; ".join(x for x in (p.note, values) if x)])
            rows += [[f"`{name}`", f"`{str(default).lower()}`", "(Mitsuba's default only)", ""]
                     for name, default in plugin.only_default]
            if rows:
                lines += markdown_table(["parameter", "Mitsuba's default", "raytrace key", "notes"], rows)
            else:
                lines.append("No parameters.")
            lines.append("")
    return lines


def _value_text(value):
    """A default as the BSDFs' tables show it: a number, a list, `"text"`, true/false, or none."""
    from raytrace.scene.keys import Key
    return default_text(Key("", "", "", default=value))


def bsdf_pages():
    """The manual's page of BSDFs, from raytrace/scene/bsdfs.py: per BSDF (a section titled by its Mitsuba name)
    its doc, a table of its parameters (the scene file's key, its type, the scene file's default and Mitsuba's,
    what it accepts, its meaning; the parameters of Mitsuba's scenes only after them) and an example table; then
    Mitsuba's named media and metals."""
    from raytrace.scene.bsdfs import DECLARED
    from raytrace.scene.named_materials import CONDUCTORS, IORS
    lines = []
    for bsdf in DECLARED:
        lines += [f"## {bsdf.name}", "", f"**{bsdf.title[0].upper()}{bsdf.title[1:]}.** {' '.join(bsdf.doc.split())}",
                  ""]
        rows = []
        for p in bsdf.parameters:
            if p.key is not None:
                kind, values = accepted(p.key)
                rows.append([f"`{p.key.name}`", kind, default_text(p.key), _value_text(p.mitsuba_default), values,
                             p.key.doc])
        for p in bsdf.parameters:
            if p.key is None:
                rows.append([f"`{p.name}`", "(Mitsuba's scenes only)", "", _value_text(p.mitsuba_default), "",
                             p.note])
        lines += markdown_table(["key", "type", "default", "Mitsuba's default", "accepted", "meaning"], rows)
        lines += ["", "Beside these, every material's keys (`colour`, the texture maps, ...: "
                  "[the scene format](scene-format.md#every-key)).", "", "```toml",
                  f"[materials.{bsdf.name}_example]", bsdf.example, "```", ""]
    lines += ["## Named materials", "",
              "`int_ior` and `ext_ior` take a number or one of Mitsuba's named media (in any case), at about 589 nm:",
              "", *markdown_table(["name", "index of refraction"], [[f"`{name}`", _number(ior)]
                                                                   for name, ior in IORS.items()]), "",
              "A conductor's `material` is one of Mitsuba's named metals (case matters), its `eta` and `k` as "
              "Mitsuba's rgb variants have them (`raytrace/scene/named_materials.py`): "
              + ", ".join(f"`{name}`" for name in CONDUCTORS) + "."]
    return lines


GENERATORS = {"scene-keys": (scene_keys, "raytrace/scene/keys.py"),
              "mitsuba-plugins": (mitsuba_plugins, "raytrace/scene/mitsuba.py"),
              "bsdfs": (bsdf_pages, "raytrace/scene/bsdfs.py")}


def begin_marker(name):
    """The comment that opens a generated part: what it is made from, and the command that remakes it."""
    return f"<!-- {name}:begin: generated from {GENERATORS[name][1]} by `{COMMAND}`; edit that, not this -->"


def regions(text):
    """(marker name, the text between the markers) of each generated part of a page."""
    return [(m[2], m[3]) for m in REGION.finditer(text)]


def generated(name):
    """The text that belongs between the markers of `name`: a blank line, the lines, and the blank line left."""
    if name not in GENERATORS:
        raise KeyError(f"unknown generated part {name!r}: known are {', '.join(GENERATORS)}")
    lines = GENERATORS[name][0]()
    while lines and not lines[-1]:
        lines.pop()
    return "\n" + "\n".join(lines) + "\n\n"


def refreshed(text):
    """A page's text with every generated part made anew from the code (the begin marker too)."""
    return REGION.sub(lambda m: f"{begin_marker(m[2])}\n{generated(m[2])}{m[4]}", text)


def pages():
    return sorted(DOCS.glob("*.md"))


def stale(paths):
    """The pages among `paths` whose generated parts differ from what the code makes now."""
    return [path for path in paths if refreshed(path.read_text()) != path.read_text()]


def main(argv=None):
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit with status 1 if a page differs from what the code makes")
    args = parser.parse_args(argv)
    found = stale(pages())
    for path in found:
        if args.check:
            print(f"{path.relative_to(ROOT)}: generated tables out of date: run `{COMMAND}`", file=sys.stderr)
        else:
            path.write_text(refreshed(path.read_text()))
            print(f"rewrote {path.relative_to(ROOT)}")
    return 1 if args.check and found else 0


if __name__ == "__main__":
    sys.exit(main())
