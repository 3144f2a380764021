"""The shape of the repository: imports run one way through the package's layers, the installed package holds
no developer rig and imports no test-only dependency, no test module imports another, and every repository
path the code, the tests and the manual name exists. Each test reads the source as text (ast, regular expressions): nothing here can pass by
importing less."""
import ast
import configparser
import re
import subprocess
from pathlib import Path

import pytest

from helpers import ROOT

PACKAGE = ROOT / "raytrace"

# The package's layers, lowest first: a module may import its own layer and those below, never one above. A
# module's layer is that of the longest prefix of its name listed here.
LAYERS = [["raytrace.errors", "raytrace.numerics", "raytrace.memory", "raytrace.structs",
           "raytrace.aovs"],
          ["raytrace.samplers"],
          ["raytrace.scene"],
          ["raytrace.renderer"],
          ["raytrace.render", "raytrace.outputs", "raytrace.image_file", "raytrace.options", "raytrace.image",
           "raytrace.parameters", "raytrace.watch", "raytrace.progress", "raytrace.checkpoint", "raytrace.denoise"],
          ["raytrace.tev", "raytrace.notebook"],
          ["raytrace.commands"],
          ["raytrace.cli", "raytrace.__main__", "raytrace"]]

# What the tests, the manual and the developer rigs need, and the installed package must never import.
TEST_ONLY = {"pytest", "hypothesis", "embreex", "scipy", "sphinx", "myst_parser", "sphinxarg", "tests", "fuzz",
             "helpers", "benchmarks", "devtools"}


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports(name, top_level_only=False):
    """(the raytrace modules `name` imports, the other top-level packages it imports); with top_level_only,
    only the imports that run when the module is imported (not those inside functions)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    nodes = tree.body if top_level_only else ast.walk(tree)
    ours, theirs = set(), set()
    for node in nodes:
        if isinstance(node, ast.ImportFrom):
            base = (".".join(package.split(".")[:len(package.split(".")) - node.level + 1] +
                             ([node.module] if node.module else [])) if node.level else node.module)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                ours.add(sub) if sub in MODULES else (ours.add(base) if base in MODULES else theirs.add(base))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                ours.add(alias.name) if alias.name in MODULES else theirs.add(alias.name)
    ours.discard(name)
    return ours, {t.split(".")[0] for t in theirs}


def layer(name):
    best = max((prefix for row in LAYERS for prefix in row if name == prefix or name.startswith(prefix + ".")),
               key=len)
    return next(k for k, row in enumerate(LAYERS) if best in row)


def test_imports_run_down_the_layers():
    """No module imports one of a higher layer (function-level imports included: a deferred import is still
    an arrow). It fails if, say, renderer/ imported outputs.py, as renderer/image.py once did."""
    upwards = [(name, target) for name in MODULES for target in imports(name)[0] if layer(target) > layer(name)]
    assert upwards == []


def test_no_import_cycle():
    """The graph of the modules' top-level imports has no cycle (a package's __init__ counts as a module): a
    cycle makes the import order matter, as stability/table.py reading CASES from its package once did."""
    graph = {name: imports(name, top_level_only=True)[0] for name in MODULES}
    state = {}

    def visit(node, path):
        state[node] = "open"
        for target in sorted(graph[node]):
            if state.get(target) == "open":
                pytest.fail(" -> ".join(path[path.index(target):] + [target]) if target in path else target)
            if target not in state:
                visit(target, path + [target])
        state[node] = "done"
    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


def test_the_checker_sees_arrows_and_cycles(tmp_path, monkeypatch):
    """The two tests above can fail: an upward import and a two-module cycle planted in a copy of the map."""
    fake = {"raytrace.scene.a": tmp_path / "a.py", "raytrace.scene.b": tmp_path / "b.py",
            "raytrace.cli": PACKAGE / "cli.py"}
    fake["raytrace.scene.a"].write_text("from . import b\nfrom ..cli import main\n")
    fake["raytrace.scene.b"].write_text("from .a import x\n")
    monkeypatch.setattr(__import__(__name__), "MODULES", fake)
    assert imports("raytrace.scene.a")[0] == {"raytrace.scene.b", "raytrace.cli"}
    with pytest.raises(AssertionError):
        test_imports_run_down_the_layers()
    fake.pop("raytrace.cli")
    fake["raytrace.scene.a"].write_text("from . import b\n")
    with pytest.raises(pytest.fail.Exception, match="raytrace.scene.a -> raytrace.scene.b -> raytrace.scene.a"):
        test_no_import_cycle()


def test_the_installed_package_imports_no_test_only_dependency():
    found = {(name, dep) for name in MODULES for dep in imports(name)[1] if dep in TEST_ONLY}
    assert found == set()


def imports_of_test_modules(files):
    """(importer, imported) for every import of a test module (one whose name starts with test_) in `files`, at
    the top level or inside a function: `import test_x`, `from test_x import y`, `from tests.test_x import y`,
    `from tests import test_x`, `from . import test_x` and importlib.import_module or __import__ of such a name;
    the importer as a path under the checkout."""
    def is_test_module(name):
        return any(part.startswith("test_") for part in name.split("."))
    found = []
    for path in map(Path, files):
        importer = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = "." * node.level + (node.module or "")
                names = [base] if is_test_module(base) else [
                    f"{base}.{alias.name}" if node.module else base + alias.name for alias in node.names]
            elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) in
                  ("import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant)):
                names = [str(node.args[0].value)]
            else:
                continue
            found += [(importer, name) for name in names if is_test_module(name)]
    return found


def test_no_test_module_imports_another():
    """A test module imports no other test module, at the top level or inside a function: what tests share is
    in helpers.py, path_support.py or conftest.py (none named test_*), and a test runs only in its own module,
    so that each module can be read, moved and renamed alone and no test is collected twice. It failed on six
    imports: test_environment_map.py and test_visits.py took test_path_tracing.py's helpers, test_record.py ran
    a test of test_docs.py as its check, among them."""
    found = imports_of_test_modules(sorted((ROOT / "tests").rglob("*.py")))
    assert found == [], "; ".join(f"{importer} imports {imported}" for importer, imported in found)


def test_the_checker_sees_test_module_imports(tmp_path):
    """The test above can fail: every form of import of a test module planted in a file, one inside a
    function; helpers and path_support pass."""
    planted = tmp_path / "test_planted.py"
    planted.write_text("import os\nfrom helpers import ROOT\nfrom path_support import traced\nimport test_a\n"
                       "from tests.test_b import x\nfrom tests import test_c\nfrom . import test_d\n"
                       "from .test_e import y\n\n\ndef f():\n    from test_f import furnace as g\n"
                       "    importlib.import_module('test_g')\n")
    assert sorted(imports_of_test_modules([planted])) == [(str(planted), name) for name in (
        ".test_d", ".test_e", "test_a", "test_f", "test_g", "tests.test_b", "tests.test_c")]


def test_setup_installs_every_package_of_raytrace_and_nothing_else():
    """setup.cfg's packages are exactly raytrace's folders with an __init__.py (and the kernels): a new folder
    is not forgotten, and benchmarks/, devtools/ and tests/ are never installed."""
    config = configparser.ConfigParser()
    config.read(ROOT / "setup.cfg")
    listed = {p.strip() for p in config["options"]["packages"].split(",")}
    folders = {module_name(p) for p in PACKAGE.rglob("__init__.py")}
    assert listed == folders | {"raytrace.kernels"}


def tracked_files():
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout.split()
    return [p for p in out if (ROOT / p).is_file()]


# Names of files that are not the repository's: PoCL's header, files tests and commands write for themselves.
# names of other projects' files, and generic ones: Mitsuba 3's and pbrt-v4's headers, which the BSDFs cite
NOT_OURS = {"opencl-c.h", "render_entry.cl", "peer.py", "scene.py", "script.py", "microfacet.h", "fresnel.h", "warp.h", "principledhelpers.h",
            "sampling.h"}
REPO_PATH = re.compile(r"(?<![\w./-])((?:raytrace|kernels|tests|benchmarks|devtools|scenes|assets|docs|\.ci)"
                       r"/[\w./*-]*[\w*])")
FILE_NAME = re.compile(r"(?<![\w./-])([\w/-]*[A-Za-z_]\w*\.(?:py|cl|h))\b")
MODULE = re.compile(r"python -m ((?:raytrace|benchmarks|devtools)(?:\.\w+)*)")


def placeholder(path):
    """A path with a part in capitals (DIR, DATE-MACHINE-COMMAND.json) or a build folder stands for others."""
    return any(re.search(r"[A-Z]{3}", part) for part in path.split("/")) or "_build" in path


def stale_paths(files):
    """(file, name) for every repository path, source file name and `python -m` module named in `files`
    that does not exist, placeholders aside."""
    listed = tracked_files()
    stale = []
    for f in files:
        text = (ROOT / f).read_text(errors="replace")  # an absolute path stays itself
        for m in REPO_PATH.finditer(text):
            path = m.group(1).rstrip(".")
            if placeholder(path):
                continue
            if not ((ROOT / path).exists() if "*" not in path else any(ROOT.glob(path))):
                stale.append((f, path))
        for m in FILE_NAME.finditer(text):
            name = m.group(1)
            if name not in NOT_OURS and not placeholder(name) and not any(p == name or p.endswith("/" + name) for p in listed):
                stale.append((f, name))
        for m in MODULE.finditer(text):
            module = ROOT / m.group(1).replace(".", "/")
            if not (module.with_suffix(".py").is_file() or (module / "__init__.py").is_file()):
                stale.append((f, f"python -m {m.group(1)}"))
    return stale


def test_every_path_named_in_code_tests_and_docs_exists():
    """Docstrings, comments, scene files, the manual and the README name files that exist and modules that
    run: a file moved or renamed is named anew everywhere. It fails on the names the old layout left behind
    (raytrace/mipmap.py, raytrace/probe.py, raytrace.tools.same_images)."""
    files = [f for f in tracked_files() if (f.endswith((".py", ".cl", ".h", ".md", ".cfg", ".toml"))
             or f.startswith(".ci/")) and f != "tests/test_layout.py"]  # this file names stale paths as examples
    assert stale_paths(files) == []


def test_stale_names_are_found(tmp_path):
    """The path check fails on a moved file, a missing module and a bare stale file name, and passes the
    names that exist and the placeholders."""
    doc = tmp_path / "page.md"
    doc.write_text("See raytrace/probe.py, `python -m raytrace.tools.same_images` and picture.py; not\n"
                   "raytrace/commands/stability/probe.py, `python -m devtools.same_images`, kernels/DIR/x.cl.\n")
    assert {name for _, name in stale_paths([doc])} == {
        "raytrace/probe.py", "picture.py", "python -m raytrace.tools.same_images"}
