"""Reading OBJ files for raytrace.scene.mesh_file.load_mesh: the file's vertices, polygons, normals and uvs,
before the checks shared with PLY (mesh_file._checked). Limits: OBJ materials are ignored.

trimesh's OBJ reader is lenient, so what it gets silently wrong is refused here first, naming the line:
index 0 and relative indices it would misread, NaN and infinite values, uvs and normals beyond float32's
range and vertex coordinates beyond raytrace.numerics.COORDINATE_LIMIT (it reads them as float64), and
face references to texture coordinates or normals that it drops. A line it fails on is found and named
once it has failed. The shared parts come from meshes.
"""
import io
import re

import numpy as np

from ..errors import InputError
from ..numerics import COORDINATE_LIMIT, FLOAT32_MAX
from .meshes import NO_FACES, fan, quiet, value_problem, why


def read_obj(path, data):
    """The file's (vertices, polygons, normals, uvs), from all its `usemtl` groups."""
    if b"\0" in data:
        raise InputError(path, "file", None, "is binary data, not OBJ text")
    text = _plain_lines(data.decode("latin-1"))  # only ASCII matters; other encodings' names pass
    _check_obj_indices(path, text)
    _check_obj_values(path, text)
    # here, not at the top: importing trimesh is slow (measured in commit 6b64997)
    from trimesh.exchange.obj import load_obj
    try:
        with quiet():
            parts = load_obj(io.StringIO(text), skip_materials=True, group_material=False).get("geometry", {})
    except Exception as e:  # trimesh raises whatever its parsing hits on malformed text
        raise (_obj_bad_line(path, text) or
               InputError(path, "file", None, f"cannot be read as OBJ ({why(e)})")) from None
    parts = [p for p in parts.values() if len(p.get("faces", ()))]
    if not parts:
        raise InputError(path, "f", None, NO_FACES)
    uvs = [_uv_pairs(getattr(p.get("visual"), "uv", None)) for p in parts]
    normals = [p.get("vertex_normals") for p in parts]
    for key, refs, got, what in (("vt", r"\d/-?\d", uvs, "texture coordinates"),
                                 ("vn", r"\d/-?\d*/-?\d", normals, "normals")):
        if re.search(r"^f[ \t][^\n]*?" + refs, text, re.M) and not re.search(rf"^{key}[ \t]", text, re.M):
            raise InputError(path, key, None, f"faces refer to {what}, and the file has none")
    if any(uv is not None for uv in uvs):  # groups of faces with uvs and without: (0, 0) where none is given
        uvs = [np.zeros((len(p["vertices"]), 2)) if uv is None else uv for p, uv in zip(parts, uvs)]
    offsets = np.cumsum([0] + [len(p["vertices"]) for p in parts])
    return (np.concatenate([p["vertices"] for p in parts]),
            np.concatenate([fan(np.asarray(p["faces"])) + o for p, o in zip(parts, offsets)]),
            None if any(n is None for n in normals) else np.concatenate(normals),
            None if any(uv is None for uv in uvs) else np.concatenate(uvs))


def _plain_lines(text):
    """The OBJ text as trimesh's reader takes it: LF line ends, tabs as spaces, no indentation, no comment
    after a statement (`f 1 2 3 # face 0`); all legal OBJ, which it would misread or skip."""
    text = text.replace("\r\n", "\n").replace("\t", " ")
    text = re.sub(r"^ +", "", text, flags=re.M)
    return re.sub(r"(?<=\S) +#[^\n]*", "", text)


def _uv_pairs(uv):
    """(u, v) per vertex from the file's `vt` lines: `vt u` alone is legal OBJ, v then 0 (the format's
    default), and a third component (w) is not a texture coordinate here."""
    if uv is None:
        return None
    uv = np.asarray(uv, dtype=np.float64).reshape(len(uv), -1)
    return np.hstack([uv, np.zeros((len(uv), 1))]) if uv.shape[1] == 1 else uv[:, :2]


# Where an OBJ value beyond the limits may be: "nan", "inf", 11 digits in a row, an exponent of 10 or more
# (the limits are far above 1e10). Found by string searches, which run at C speed (one regular expression
# with these alternatives took a large share of a large OBJ's reading time: measured in commit 056b35d); only
# the lines found are parsed.
EXPONENT = re.compile(r"e\+?0*[1-9]\d")
DIGITS_TO_ZERO = str.maketrans("123456789", "000000000")


def _suspect_lines(text):
    """The starts of the lines that may hold a value beyond the limits, in file order."""
    low = text.lower()  # the same length: the text is latin-1, whose characters lower one to one
    hits = [m.start() for m in EXPONENT.finditer(low)]
    for haystack, needle in ((low, "nan"), (low, "inf"), (low.translate(DIGITS_TO_ZERO), "0" * 11)):
        i = haystack.find(needle)
        while i >= 0:
            hits.append(i)
            i = haystack.find(needle, i + len(needle))
    return sorted({text.rfind("\n", 0, i) + 1 for i in hits})


def _check_obj_values(path, text):
    """Refuse a v, vt or vn value that is NaN, infinite or too large (the coordinate limit for positions,
    float32's range for uvs and normals), naming its line: trimesh reads them as float64, where 1e39 is a
    number, and the faces around such a vertex would then be called degenerate."""
    for start in _suspect_lines(text):
        line = _line_at(text, start)
        words = line.split("#")[0].split()
        if words[:1] not in (["v"], ["vt"], ["vn"]):
            continue
        limit = COORDINATE_LIMIT if words[0] == "v" else FLOAT32_MAX
        for word in words[1:]:
            problem = value_problem(word, _number(word), limit)
            if problem:
                raise InputError(path, f"line {text.count(chr(10), 0, start) + 1}", line.strip()[:80], problem)


def _obj_bad_line(path, text):
    """The InputError for the first line trimesh could not read (searched once it has failed), or None: a
    v, vt or vn value that is not a number, a face corner that is not v[/vt][/vn] indices, or one that
    names a vertex the file does not have."""
    count = len(re.findall(r"^v[ \t]", text, re.M))
    for n, line in enumerate(text.splitlines(), 1):
        words = line.split("#")[0].split()
        problem = None
        if words[:1] in (["v"], ["vt"], ["vn"]):
            problem = next((f"{w!r} is not a number" for w in words[1:] if _number(w) is None), None)
        elif words[:1] == ["f"]:
            problem = next(filter(None, (_corner_problem(c, count) for c in words[1:])), None)
        if problem:
            return InputError(path, f"line {n}", line.strip()[:80], problem)
    return None


def _corner_problem(corner, vertices):
    if not re.fullmatch(r"-?\d+(/-?\d*){0,2}", corner):
        return f"{corner!r} is not a face corner (v, v/vt, v//vn or v/vt/vn indices)"
    index = int(corner.split("/")[0])
    if index > vertices or -index > vertices:
        return f"vertex {index} does not exist (the file has {vertices} vertices)"
    return None


def _line_at(text, start):
    end = text.find("\n", start)
    return text[start:end if end >= 0 else None]


def _number(word):
    """float(word), or None when it is not a number."""
    try:
        return float(word)
    except ValueError:
        return None



def _check_obj_indices(path, text):
    """What trimesh gets silently wrong: index 0 (OBJ counts from 1; trimesh reads it as the first
    vertex), and negative (relative) indices once vertices follow faces (trimesh counts back from the
    end of the file, not from the face)."""
    zero = re.search(r"^f[ \t][^\n]*?(?<=[ \t/])-?0(?=[ \t/\r]|$)", text, re.M)
    if zero:
        raise InputError(path, "f", zero.group(0).strip(), "indices start at 1")
    relative = re.search(r"^f[ \t][^\n]*?(?<=[ \t/])-\d", text, re.M)
    if relative and max(text.rfind(f"\n{k} ") for k in ("v", "vt", "vn")) > relative.start():
        raise InputError(path, "f", relative.group(0).strip(),
                         "relative (negative) indices are supported only when all vertices come first")
    _check_obj_references(path, text)


def _check_obj_references(path, text):
    """Texture coordinate and normal indices within the file's vt and vn lines (trimesh drops the uvs or
    normals of a face that names one beyond them, silently); vertex indices are checked on the mesh."""
    counts = {key: len(re.findall(rf"^{key}[ \t]", text, re.M)) for key in ("vt", "vn")}
    for line in re.finditer(r"^f[ \t][^\n]*", text, re.M):
        for corner in line.group(0).split()[1:]:
            parts = corner.split("/")
            for key, index in zip(("vt", "vn"), parts[1:3]):
                if index and index.lstrip("-").isdigit() and abs(int(index)) > counts[key]:
                    raise InputError(path, key, line.group(0).strip(), f"a face refers to {key} {index}, and the "
                                     f"file has {counts[key]}")
