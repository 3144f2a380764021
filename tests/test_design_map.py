"""docs/design.md against the tree: its kernel map names every file of kernels/ and nothing else, and its table
of `-D` options names exactly the options the host passes, beside a second table of the build options only
tests and measurements set, so that between them every switch the kernels test is on the page.

The page is the map a contributor reads first; it went stale once (five kernel files and six options of the
path model missing from it), and nothing said so. Here the files are listed from the directory, the host's
options from `Features.options` itself (every field set), and the kernels' switches from their preprocessor
directives, so a new file, option or switch that the page does not name fails a test, as does a name the page
keeps after its file or option is gone. The text is parsed, nothing is imported from the page."""
import dataclasses
import re

from helpers import ROOT
from raytrace.renderer.program import Features

PAGE = (ROOT / "docs" / "design.md").read_text()
KERNELS = ROOT / "kernels"
MACRO = re.compile(r"\b[A-Z][A-Z0-9_]*\b")


def section(text, heading):
    """The text under the heading (a line of #s and `heading`), up to the next heading of any level."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if re.fullmatch(r"#+ " + re.escape(heading), line))
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("#")), len(lines))
    return "\n".join(lines[start + 1:end])


def kernel_map(text):
    """The file names in the first column of the kernel map, the code block under "The kernel": an entry is a
    line indented by two spaces, its names before the first gap of two spaces or more (the description after
    it, which names other files, is not read; nor are its continuation lines)."""
    block = re.search(r"```\n(kernels[/].*?)```", section(text, "The kernel"), re.S).group(1)
    names = []
    for line in block.splitlines():
        entry = re.match(r"  (\S.*?)(?:\s{2,}|$)", line)
        if entry:
            names += re.findall(r"[\w.-]+\.(?:cl|h)\b", entry.group(1))
    return names


def tables(text):
    """{header's cells: [the first cell's `NAMES` of each row]} of the markdown tables in text."""
    found, rows = {}, []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
            continue
        if rows:
            found[tuple(rows[0])] = [re.findall(r"`([A-Z][A-Z0-9_]*)`", row[0]) for row in rows[2:]]
            rows = []
    return found


OPTIONS = section(PAGE, "Builds specialised by `-D` options")
HOST_HEADER, OTHER_HEADER = ("option", "set when"), ("option", "default, and the builds that change it")


def table_names(header):
    names = [name for row in tables(OPTIONS)[header] for name in row]
    assert len(names) == len(set(names)), f"a name twice in the table {header}: {names}"
    return set(names)


def host_options():
    """The -D names the host can pass: Features.options of a Features with every switch on (a switch off is
    still passed, as 0, except COUNT_VISITS, which is passed only when on)."""
    every = Features(**{f.name: True for f in dataclasses.fields(Features) if f.type in (bool, "bool")})
    return {option[2:].split("=")[0] for option in every.options()}


def directives():
    """(file name, directive, argument text) of every preprocessor line of kernels/, continuations joined and
    comments dropped."""
    found = []
    for path in sorted(KERNELS.iterdir()):
        if path.suffix not in (".cl", ".h"):
            continue
        text = re.sub(r"/\*.*?\*/", " ", path.read_text(), flags=re.S).replace("\\\n", " ")
        for line in text.splitlines():
            m = re.match(r"\s*#\s*(\w+)\s*(.*?)\s*(?://.*)?$", line)
            if m:
                found.append((path.name, m.group(1), m.group(2)))
    return found


def kernel_switches():
    """(tested, guards, defaults, derived) over kernels/: the macros #if, #elif, #ifdef and #ifndef test; the
    include guards (#ifndef X then #define X with no value); the defaults a build may override (#ifndef X then
    #define X value); and the macros the kernels define outright, with the text each is defined as."""
    tested, guards, defaults, derived = set(), set(), set(), {}
    found = directives()
    for i, (name, kind, rest) in enumerate(found):
        if kind in ("if", "elif", "ifdef", "ifndef"):
            tested |= set(MACRO.findall(rest))
        if kind == "ifndef" and i + 1 < len(found) and found[i + 1][1] == "define":
            macro, _, body = found[i + 1][2].partition(" ")
            if macro == rest:
                (defaults if body.strip() else guards).add(rest)
    for i, (name, kind, rest) in enumerate(found):
        if kind == "define":
            macro = re.match(r"\w+", rest).group(0)
            if macro not in defaults and macro not in guards:
                derived[macro] = rest[len(macro):]
    return tested, guards, defaults, derived


def test_the_kernel_map_lists_every_kernel_file():
    """Each file of kernels/ has its line in the map, and each name in the map is a file of kernels/."""
    files = {p.name for p in KERNELS.iterdir() if p.is_file() and not p.name.startswith(".")}
    names = kernel_map(PAGE)
    assert len(names) == len(set(names)), f"a kernel file listed twice: {names}"
    assert set(names) == files, (f"missing from the map: {sorted(files - set(names))}; "
                                 f"listed but not in kernels/: {sorted(set(names) - files)}")


def test_every_kernels_path_the_page_names_exists():
    """Every kernels/... path in the page's text, and every bare kernel file name in backticks, is a file."""
    paths = re.findall(r"(?<![\w/])kernels/([\w./-]*[\w])", PAGE)
    bare = re.findall(r"`([\w-]+\.(?:cl|h))`", PAGE)
    missing = sorted({p for p in paths + bare if not (KERNELS / p).exists()})
    assert missing == []


def test_the_option_table_is_what_the_host_passes():
    """The table of -D options names exactly the options Features.options can pass, LANES and COUNT_VISITS
    included, and every -DNAME spelled out in the package's source is among them."""
    table = table_names(HOST_HEADER)
    host = host_options()
    assert table == host, f"passed but not in the table: {sorted(host - table)}; in the table but never passed: " \
                          f"{sorted(table - host)}"
    spelled = {m for p in (ROOT / "raytrace").rglob("*.py") for m in re.findall(r"-D([A-Z][A-Z0-9_]*)\b(?!\{)",
                                                                              p.read_text())}
    assert spelled <= table, f"-D options in raytrace/ that the table lacks: {sorted(spelled - table)}"


def test_every_switch_the_kernels_test_is_on_the_page():
    """A macro the kernels test is an include guard, a macro they define themselves, a build option with a
    default (in the second table, or in the first where the host passes it too, as LANES), or one the host
    alone sets (in the first table); every option the host passes is tested by the kernels, directly or through
    a macro derived from it; and the derived switches (those defined from a host option, as HAS_BACKFACES) are
    named in the section, so that a reader finds what `#if HAS_BACKFACES` stands for."""
    tested, guards, defaults, derived = kernel_switches()
    host, other = table_names(HOST_HEADER), table_names(OTHER_HEADER)
    assert other == defaults - host, (f"defaults the second table lacks: {sorted(defaults - host - other)}; "
                                      f"in it but no default in kernels/: {sorted(other - (defaults - host))}")
    unset = tested - guards - defaults - set(derived)
    assert unset <= host, f"switches the kernels test that nothing on the page sets: {sorted(unset - host)}"
    used = tested | {m for body in derived.values() for m in MACRO.findall(body)}
    assert host <= used, f"options the host passes that no kernel reads: {sorted(host - used)}"
    from_options = {m for m, body in derived.items()  # object-like, a condition on options: not CONVERT_VINT(v)
                    if re.fullmatch(r"[\sA-Z0-9_()|&!<>=]+", body) and set(MACRO.findall(body)) & host}
    named = set(re.findall(r"`([A-Z][A-Z0-9_]*)`", OPTIONS))
    assert from_options <= named, f"switches derived from options, not named: {sorted(from_options - named)}"


def test_the_parsers_see_what_is_there():
    """The parsers find the page's parts (a test that finds nothing passes nothing): the map holds render.cl and
    path_tracing.cl, the host table LANES and HAS_PATH_TRACING, the second table LIGHT_SOLID_ANGLE; the kernels'
    directives give scene.h's guard, LANES's default and scene.h's HAS_BACKFACES; and a page without a row or
    a map line loses that name."""
    assert {"render.cl", "path_tracing.cl"} <= set(kernel_map(PAGE))
    assert {"LANES", "HAS_PATH_TRACING"} <= table_names(HOST_HEADER)
    assert "LIGHT_SOLID_ANGLE" in table_names(OTHER_HEADER)
    tested, guards, defaults, derived = kernel_switches()
    assert {"SCENE_H", "PATH_TRACING_CL"} <= guards and {"LANES", "LIGHT_SOLID_ANGLE"} <= defaults
    assert "HAS_BACKFACES" in derived and "HAS_BACKFACES" in tested
    cut = "\n".join(line for line in PAGE.splitlines() if not line.startswith("  microfacet.cl"))
    assert "microfacet.cl" not in kernel_map(cut)
    row = "\n".join(line for line in OPTIONS.splitlines() if not line.startswith("| `HAS_ENVIRONMENT_MAP`"))
    assert "HAS_ENVIRONMENT_MAP" not in {n for r in tables(row)[HOST_HEADER] for n in r}


def package_map(text):
    """The module file names the map of the installed package names: the `.py` names in the first column of
    its code block (an entry's names before the first gap of two spaces or more), and the stability suite's
    case modules, which one entry lists after "a module per family:"."""
    block = re.search(r"```\n(raytrace[/].*?)```", section(text, "The installed package"), re.S).group(1)
    names = set()
    for line in block.splitlines():
        entry = re.match(r" {2,}(\S.*?)(?:\s{2,}|$)", line)
        if entry:
            names |= set(re.findall(r"[\w]+\.py\b", entry.group(1)))
    family = re.search(r"a module per family: ([\w,\s]+)", block).group(1)
    return names | {f"{name}.py" for name in re.findall(r"\w+", family)}


def package_modules():
    """The base names of the package's modules, a subpackage's __init__.py aside (the top level's is the API)."""
    package = ROOT / "raytrace"
    return {p.name for p in package.rglob("*.py") if p.name != "__init__.py" or p.parent == package}


def test_the_package_map_lists_every_module():
    """Every module of raytrace/ is on the map, and every module the map names exists: a module added or
    renamed without its line fails here (scene/rules.py was one)."""
    named, modules = package_map(PAGE), package_modules()
    assert modules - named == set(), f"modules not on design.md's map: {sorted(modules - named)}"
    assert named - modules == set(), f"on design.md's map, not in raytrace/: {sorted(named - modules)}"


def test_the_package_map_parser_sees_what_is_there():
    """The parser finds the map's entries (rules.py, a name in a pair, a stability family), and a page without
    an entry loses that name."""
    named = package_map(PAGE)
    assert {"rules.py", "meshgen.py", "ply_file.py", "degenerate_input.py", "__main__.py"} <= named
    cut = "\n".join(line for line in PAGE.splitlines() if not line.lstrip().startswith("rules.py"))
    assert "rules.py" not in package_map(cut)
