"""The front page and the manual: the manual builds strictly (every warning an error: a broken link, a missing
page or anchor, an unresolved reference), its generated parts hold what the code and the records say (the
tables made from the code are written into the Markdown, and are current), the measurement records are well
formed, and the README's commands, examples and error line are the ones that work."""
import html as html_text
import importlib.util
import math
import os
import re
import subprocess
import sys
import tomllib

import pytest

import raytrace
from devtools import docs_tables
from devtools.docs_tables import accepted, default_text
from helpers import ROOT, assert_record_well_formed
from raytrace.scene import parse_scene
from raytrace.scene.keys import TABLES

if os.environ.get("RAYTRACE_DEVICE") and importlib.util.find_spec("sphinx") is None:
    # .ci/gpu's site for a GPU machine carries what the renderer's tests need, not the manual's tools; on
    # every other run (CI included) a missing Sphinx is a failure, not a skip
    pytest.skip("the manual is built by the CPU runs; this GPU site has no Sphinx", allow_module_level=True)

README = (ROOT / "README.md").read_text()
RECORDS = sorted((ROOT / "benchmarks" / "results").glob("*.json"))


@pytest.fixture(scope="module")
def manual(tmp_path_factory):
    """The manual built as HTML with -W --keep-going -n: (exit status, warnings and errors, output folder)."""
    out = tmp_path_factory.mktemp("html")
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-E", "-b", "html",
                        str(ROOT / "docs"), str(out)], capture_output=True, text=True, cwd=ROOT)
    return r.returncode, r.stderr, out


def test_the_manual_builds_strictly(manual):
    status, log, out = manual
    assert status == 0 and log.strip() == "", log
    pages = {p.stem for p in out.glob("*.html")}
    assert {"index", "getting-started", "cli", "scene-format", "bsdfs", "mitsuba", "python-api", "model", "sampling",
            "numerics", "meshes", "gpu", "dask", "design", "performance"} <= pages


def test_a_broken_anchor_fails_the_build(tmp_path):
    """The strict build is strict: a link to a missing anchor, copied into a small project, is an error."""
    (tmp_path / "conf.py").write_text((ROOT / "docs" / "conf.py").read_text().replace(
        'DOCS = Path(__file__).resolve().parent', f'DOCS = Path({str(ROOT / "docs")!r})'))
    (tmp_path / "index.md").write_text("# Index\n\n## Here\n\n[there](#there) and [here](#here)\n")
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-n", "-q", "-b", "html", str(tmp_path),
                        str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode != 0 and "there" in r.stderr


def test_the_generated_parts_are_tables_under_headings(manual):
    """The generated reStructuredText is parsed as such, not as the pages' Markdown, which had made a
    paragraph and nested lists of each list-table and a code block of each ~~~ underline: no directive is
    left as text, each key table is an HTML table, and each machine kind is a heading over its table."""
    from raytrace_docs import current, records
    out = manual[2]
    for page in out.glob("*.html"):
        assert "list-table::" not in page.read_text(), page.name
    assert (out / "scene-format.html").read_text().count("<table") >= len(TABLES)
    html = (out / "performance.html").read_text()
    machines = current(records())
    assert html.count("<table") == len(machines)
    assert len(re.findall(r"</h2>\s*<table", html)) == len(machines)
    converged = [m[1] for recs in machines.values() for r in recs
                 if (m := re.match(r"python -m raytrace converge scenes/(\w+)\.toml", r["command"]))]
    assert converged and all(f"<td><p>{scene}: " in html for scene in converged)


def test_the_scene_format_page_lists_every_key(manual):
    """The generated tables (devtools/docs_tables.py from raytrace/scene/keys.py) name every table and key."""
    html = (manual[2] / "scene-format.html").read_text()
    for table, keys in TABLES.items():
        for key in keys:
            assert f"<code class=\"docutils literal notranslate\"><span class=\"pre\">{key.name}</span></code>" in html, \
                (table, key.name)


def test_the_generated_tables_in_the_markdown_are_current():
    """The tables made from the code are written into the Markdown pages (devtools/docs_tables.py), so that they
    show on a repository's web page, where a Sphinx directive shows nothing; each generated part equals what
    the code makes now. A key added to raytrace/scene/keys.py and not written into the page fails here."""
    parts = {path.name: [name for name, _ in docs_tables.regions(path.read_text())] for path in docs_tables.pages()}
    assert parts["scene-format.md"] == ["scene-keys"]
    for path in docs_tables.pages():
        text = path.read_text()
        assert "```{scene-keys}" not in text, path.name
        for name, body in docs_tables.regions(text):
            assert body == docs_tables.generated(name), (
                f"docs/{path.name}: the {name} tables differ from {docs_tables.GENERATORS[name][1]}: "
                f"run `{docs_tables.COMMAND}` and commit the page")
        assert docs_tables.refreshed(text) == text, \
            f"docs/{path.name}: a generated part's marker is out of date: run `{docs_tables.COMMAND}`"


def test_a_stale_generated_table_is_found(tmp_path):
    """The check above can fail: one cell of the scene format's tables edited, a key dropped from a copy of the
    page, each is stale, and the rewrite restores the page; the command's --check passes on the checkout."""
    page = (ROOT / "docs" / "scene-format.md").read_text()
    for edit in (("| `fov` | number | none | (0, 180);", "| `fov` | number | none | (0, 90);"),
                 ("| `smooth` | true or false | false | any |", "")):
        assert edit[0] in page
        copy = tmp_path / "scene-format.md"
        copy.write_text(page.replace(*edit))
        assert docs_tables.stale([copy]) == [copy]
        assert docs_tables.refreshed(copy.read_text()) == page
    r = subprocess.run([sys.executable, "-m", "devtools.docs_tables", "--check"], capture_output=True, text=True,
                       cwd=ROOT)
    assert r.returncode == 0 and r.stderr == "", r.stderr


TYPOGRAPHY = {0x2019: "'", 0x201C: '"', 0x201D: '"', 0x2013: "--", 0x2014: "---"}  # Sphinx's smartquotes, undone


def _text(fragment):
    """An HTML fragment's text: tags dropped, entities and Sphinx's smartquotes undone, spaces joined."""
    text = html_text.unescape(re.sub(r"<[^>]+>", "", fragment)).translate(TYPOGRAPHY)
    return " ".join(text.split())


def _table_rows(fragment):
    """Each row of the HTML tables in `fragment`, as the text of its cells."""
    return [[_text(cell) for cell in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row, re.S)]
            for row in re.findall(r"<tr[^>]*>(.*?)</tr>", fragment, re.S)]


def test_the_command_line_page_lists_every_option(manual):
    """The options come from the parser (sphinx-argparse): each command has its own section, and each of its
    options is in that section, with the start of its help text (a whole-page search passed with the
    sections of commands whose options all recur in others left out)."""
    from raytrace.cli import parser
    page = (manual[2] / "cli.html").read_text()
    commands = next(a for a in parser()._actions if a.dest == "command").choices
    starts = {name: page.index(f'<section id="python-m-raytrace-{name}">') for name in commands}
    ends = sorted(starts.values()) + [len(page)]
    for name, sub in commands.items():
        section = page[starts[name]:ends[ends.index(starts[name]) + 1]]
        for action in sub._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert re.search(rf"<kbd>([^<]*, )?{re.escape(option)}(, [^<]*)?</kbd>", section), (name, option)
            if action.help and action.option_strings != ["-h", "--help"]:
                words = " ".join(action.help.split("%")[0].split()[:4])
                assert words in _text(section), (name, action.dest, words)


def test_the_scene_format_tables_say_what_the_declarations_do(manual):
    """Each key table of the scene format's page lists its keys in the declarations' order (raytrace/scene/
    keys.py), each with the type, default and accepted values the generator derives from its declaration;
    and a few rows written out here, so that the check is not only the generator's code run twice."""
    parts = re.split(r"<p><strong>(.*?)</strong></p>", (manual[2] / "scene-format.html").read_text())
    tables = {_text(parts[i]): _table_rows(parts[i + 1].split("</table>")[0]) for i in range(1, len(parts), 2)}
    unmark = lambda text: " ".join(text.replace("`", "").split())  # noqa: E731  (Markdown's code spans)
    for table, keys in TABLES.items():
        rows = tables[_text(table or "top level")]
        assert rows[0] == ["key", "type", "default", "accepted", "meaning"] and len(rows) == len(keys) + 1
        for row, key in zip(rows[1:], keys):
            kind, values = accepted(key)
            assert row[:4] == [key.name, kind, unmark(default_text(key)), unmark(values)], (table, row)
    by_hand = {("camera", "fov"): ["number", "none", '(0, 180); required for type = "perspective" and "thinlens"; '
                                   'not with "orthographic"'],
               ("top level", "ambient"): ["3 numbers", "[0, 0, 0]", 'each >= 0; shading = "phong" only'],
               ("render", "max_depth"): ["integer", "-1", "[-1, 1024]"],
               ("render", "shading"): ["string", '"phong"', "one of phong, direct, path"],
               ('materials.NAME type = "roughconductor"', "alpha"): ["number", "0.1",
                                                                    "(0, 1]; not with alpha_u, alpha_v"],
               ('materials.NAME type = "plastic"', "int_ior"): [
                   "number or name", "1.49", "> 0; or one of 23 names: vacuum, helium, hydrogen, air and others "
                   "(docs/bsdfs.md lists them)"],
               ('shapes[] type = "mesh", from a file or generated', "smooth"): ["true or false", "false", "any"]}
    for (table, key), cells in by_hand.items():
        assert next(row[1:4] for row in tables[table] if row[0] == key) == cells, (table, key)


def test_the_bsdf_page_has_a_section_per_declaration(manual):
    """docs/bsdfs.md (made by devtools/docs_tables.py from raytrace/scene/bsdfs.py) has a section per declared BSDF,
    in model.BSDFS's order, titled by its Mitsuba name: its doc, a table of its scene file keys in declaration order
    (then the parameters of Mitsuba's scenes only) with the type, default, Mitsuba's default and accepted values
    the generator derives, and its example; the page is linked from the manual's contents."""
    from raytrace.scene import bsdfs, model
    html = (manual[2] / "bsdfs.html").read_text()
    sections = re.findall(r'<section id="([\w-]+)">', html)
    assert [s for s in sections if s in bsdfs.BY_NAME] == list(model.BSDFS) and "named-materials" in sections
    unmark = lambda text: " ".join(text.replace("`", "").split())  # noqa: E731
    for bsdf in bsdfs.DECLARED:
        section = html.split(f'<section id="{bsdf.name}">')[1].split("</section>")[0]
        assert " ".join(bsdf.doc.split()[:6]) in _text(section)
        rows = _table_rows(section)
        keys = [p for p in bsdf.parameters if p.key is not None]
        others = [p for p in bsdf.parameters if p.key is None]
        assert rows[0] == ["key", "type", "default", "Mitsuba's default", "accepted", "meaning"]
        assert [row[0] for row in rows[1:]] == [p.key.name for p in keys] + [p.name for p in others]
        for row, p in zip(rows[1:], keys):
            kind, values = accepted(p.key)
            assert row[1:3] + row[4:5] == [kind, unmark(default_text(p.key)), unmark(values)], (bsdf.name, row)
        assert f'type = "{bsdf.name}"' in _text(section)
    assert 'href="bsdfs.html"' in (manual[2] / "index.html").read_text()


def test_the_performance_page_shows_each_records_figures(manual):
    """Under each machine kind's heading, one row per figure of its current records: the figure's name, its
    value to the page's three significant digits (so within 0.5% of the record's) with its unit, and the
    number of the run listed below the table that names the record's file."""
    from raytrace_docs import current, records
    page = (manual[2] / "performance.html").read_text()
    sections = {_text(part.split('<a class="headerlink"')[0]): part
                for part in re.split(r'<section id="[^"]+">\s*<h2>', page)[1:]}
    for machine, recs in current(records()).items():
        section = sections[machine]
        listed = _text(section.split("</table>")[-1])  # the runs, below the table
        runs = dict(re.findall(r"\[(\d+)\] .*? \( ?benchmarks/results/(\S+\.json) ?\)", listed))
        by_file = {record["file"]: record for record in recs}
        assert sorted(runs.values()) == sorted(by_file), machine
        rows = _table_rows(section)[1:]
        assert len(rows) == sum(len(record["figures"]) for record in recs), machine
        for what, figure, run in rows:
            value, _, unit = figure.partition(" ")
            record = by_file[runs[run.strip("[]")]]
            assert any(what.endswith(f["what"]) and f["unit"] == unit
                       and math.isclose(float(value), f["value"], rel_tol=5.01e-3) for f in record["figures"]), \
                (machine, what, figure, run)


@pytest.mark.parametrize("path", RECORDS, ids=[p.name for p in RECORDS])
def test_every_measurement_record_is_well_formed(path):
    """A record (docs/performance.md) says on which machine, at which commit, by which command its figures were
    measured, and each figure is a number with a unit (helpers.py's check, which test_record.py also runs)."""
    assert_record_well_formed(path)


def test_there_are_records_and_the_performance_page_shows_them(manual):
    from raytrace_docs import current, records  # docs/_ext, on the path once conf.py ran; imported here too
    assert RECORDS
    html = (manual[2] / "performance.html").read_text()
    for machine, recs in current(records()).items():
        assert machine.split(" (")[0] in html
        for record in recs:
            assert record["commit"][:8] in html


@pytest.fixture(scope="module", autouse=True)
def _docs_ext_on_path():
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    yield
    sys.path.remove(str(ROOT / "docs" / "_ext"))


def blocks(language):
    return re.findall(rf"```{language}\n(.*?)```", README, re.S)


def test_the_readme_is_a_front_page():
    """About 200 lines, the two commands in its first screen (its first 40 lines), links into the manual."""
    lines = README.splitlines()
    assert len(lines) <= 220
    first_screen = "\n".join(lines[:40])
    assert "pip install" in first_screen and "python -m pytest" in first_screen
    assert len(re.findall(r"\]\(docs/[\w-]+\.md\)", README)) >= 10


def test_ci_runs_the_readmes_test_command():
    install, test = (b.strip() for b in blocks("sh")[:2])
    assert install.startswith("python3 -m venv .venv") and "python -m raytrace render scenes/cornell.toml" in install
    ci = (ROOT / ".ci" / "run").read_text()
    assert test.replace(". .venv/bin/activate && ", "") in ci.splitlines()
    assert 'pip install -q -e ".[test]"' in ci


def test_the_readmes_scene_loads():
    (scene,) = blocks("toml")
    parse_scene(tomllib.loads(scene), str(ROOT / "scenes" / "readme.toml"))


def test_the_readmes_error_line_is_the_one_every_entry_gives(tmp_path, monkeypatch):
    """The README's example of a broken rule (raytrace/scene/rules.py) is the command line's line, word for
    word, and render()'s, and a file's that breaks the same rule (scene 0 in the direct model, its light given
    a radiance): the errors' format on the front page is the one the code has."""
    (line,) = (b.strip() for b in blocks("text"))
    r = subprocess.run([sys.executable, "-m", "raytrace", "render", "scenes/cornell.toml", "-o",
                        str(tmp_path / "out.png"), "--shading", "direct", "--no-progress"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and r.stderr.strip() == line, r.stderr
    monkeypatch.chdir(ROOT)
    scene = raytrace.load_file("scenes/cornell.toml")
    with pytest.raises(raytrace.InputError) as error:
        raytrace.render(scene, shading="direct")
    assert f"raytrace: error: {error.value}" == line
    text = (ROOT / "scenes" / "cornell.toml").read_text().replace("[render]", '[render]\nshading = "direct"')
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "cornell.toml").write_text(text.replace("colour = [1.0, 1.0, 1.0]", "radiance = 1.0"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(raytrace.InputError) as error:
        raytrace.load_file("scenes/cornell.toml")
    assert f"raytrace: error: {error.value}" == line


def test_the_readmes_python_runs(tmp_path):
    """The tour's Python, as a user runs it from a checkout (here at 32 x 32 pixels): it writes its PNG."""
    (code,) = blocks("python")
    code = code.replace('"scenes/', f'"{ROOT}/scenes/').replace("spp=16", "width=32, height=32, spp=16")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "cornell.png").stat().st_size > 0 and "Mrays/s on" in r.stdout
