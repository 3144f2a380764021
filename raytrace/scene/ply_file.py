"""Reading PLY files for raytrace.scene.mesh_file.load_mesh: the file's vertices, polygons, normals and uvs,
before the checks shared with OBJ (mesh_file._checked). Limits: texture coordinates stored per face corner
("texcoord" lists) keep one uv per vertex.

One gap in trimesh is filled here: its binary PLY reader needs all face lists to have one length, so
binary files mixing triangles, quads and n-gons are read by a small reader of our own.

Hostile files (random bytes, truncations, absurd counts) get one InputError naming the file: the header is
parsed and checked line by line, and the body's size against the counts it declares, before trimesh sees
it (trimesh reads a cut-off header as an empty line and fails with an IndexError, and would allocate
whatever `element vertex 999999999999` asks for). The shared parts come from meshes.
"""
import io
import re
import struct

import numpy as np

from ..errors import InputError
from .meshes import NO_FACES, fan, quiet, why


def read_ply(path, data):
    """The file's (vertices, polygons, normals, uvs). fix_texture=False keeps the file's vertex order."""
    endian, elements, body = _ply_header(path, data)
    _check_ply_size(path, endian, elements, body)
    from trimesh.exchange.ply import load_ply
    try:
        with quiet():
            read = load_ply(io.BytesIO(_canonical_header(endian, elements) + body), fix_texture=False,
                            skip_materials=True)
    except Exception as e:  # trimesh raises whatever its parsing hits on malformed data
        if endian:  # e.g. faces of mixed sizes, which trimesh's binary reader cannot take: ours can
            return _read_binary_ply(path, endian, elements, body)
        if isinstance(e, IndexError):  # trimesh gathers per-vertex uvs by the face indices
            raise InputError(path, "face", None, "a face refers to a vertex that does not exist") from None
        raise InputError(path, "file", None, f"cannot be read as PLY ({why(e)})") from None
    if endian and not _uniform_face_lists(endian, elements, body):  # trimesh took every face as the first's
        return _read_binary_ply(path, endian, elements, body)
    faces = read.get("faces")
    if faces is None or not len(faces):
        raise InputError(path, "face", None, NO_FACES)
    raw = read.get("metadata", {}).get("_ply_raw", {}).get("vertex", {}).get("data", {})
    if isinstance(raw, np.ndarray):  # trimesh's binary reader: a structured array
        raw = {name: raw[name] for name in raw.dtype.names or ()}
    columns = {name: np.asarray(values).reshape(-1) for name, values in raw.items()
               if np.asarray(values).size == len(read["vertices"])}
    return read["vertices"], fan(np.asarray(faces)), read.get("vertex_normals"), \
        getattr(read.get("visual"), "uv", None), vertex_attributes(columns)


# A PLY file's vertex colour properties, as Mitsuba 3 groups them into its "vertex_color" attribute
COLOUR_NAMES = (("r", "g", "b"), ("red", "green", "blue"))


def vertex_attributes(columns):
    """{"vertex_color": (V, 3) float64} of a PLY file's vertex properties ({name: values}) r, g, b (or red, green,
    blue), as Mitsuba 3's PLY reader names them; {} without them. Integer colours (MeshLab's and Blender's 8-bit
    ones) become code / the type's largest code, where Mitsuba takes the codes themselves as values (and warns
    that it expects [0, 1]): a colour of 255 is no reflectance anyone means."""
    for names in COLOUR_NAMES:
        if all(name in columns for name in names):
            rgb = np.stack([columns[name] for name in names], 1)
            if np.issubdtype(rgb.dtype, np.integer):
                return {"vertex_color": rgb / float(np.iinfo(rgb.dtype).max)}
            return {"vertex_color": rgb.astype(np.float64)}
    return {}


def _uniform_face_lists(endian, elements, body):
    """Whether every record of a binary file's face element holds as many indices as the first: trimesh's
    binary reader reads the first record's count and takes every face to have it, so a later face claiming
    another (255 indices where 3 follow) would be read from the wrong bytes without a word. Elements before
    the faces with lists of their own: False (not checked here; the record-by-record reader reads them)."""
    offset = 0
    for name, count, properties in elements:
        if name == "face":
            break
        if any(p[0] == "list" for p in properties):
            return False
        offset += count * sum(struct.calcsize(PLY_TYPES[p[0]]) for p in properties)
    else:
        return True
    if not count:
        return True
    first, fields = None, []
    position = offset
    for p in properties:
        if p[0] == "list":
            n = struct.unpack_from(endian + PLY_TYPES[p[1]], body, position)[0]
            first = n if p[3] in PLY_INDEX_NAMES else first
            fields += [(f"n{len(fields)}", endian + PLY_TYPES[p[1]]),
                       (f"v{len(fields)}", endian + PLY_TYPES[p[2]], (n,))]
            position += struct.calcsize(endian + PLY_TYPES[p[1]]) + n * struct.calcsize(endian + PLY_TYPES[p[2]])
        else:
            fields.append((f"s{len(fields)}", endian + PLY_TYPES[p[0]]))
            position += struct.calcsize(endian + PLY_TYPES[p[0]])
    record = np.dtype([(f[0], *f[1:]) for f in fields])
    if offset + count * record.itemsize > len(body):
        return False
    records = np.frombuffer(body, record, count, offset)
    return all((records[f[0]] == records[f[0]][0]).all() for f in fields if f[0].startswith("n"))


# PLY scalar types as struct codes, which numpy reads too (np.dtype("<i") is int32).
PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
             "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
             "double": "d", "float64": "d"}
PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}  # -> byte order
PLY_UV_NAMES = (("texture_u", "texture_v"), ("u", "v"), ("s", "t"))  # trimesh's, in its order
PLY_INDEX_NAMES = ("vertex_indices", "vertex_index")


def _ply_header(path, data):
    """(byte order, "" for ascii; [(element, count, [property words])]; the body) of a PLY file whose header
    is complete and well formed: the PLY magic, an end_header line, a known format, elements with counts,
    properties of known types, a vertex element with x, y and z and a face element with index lists."""
    data = data[3:] if data.startswith(b"\xef\xbb\xbf") else data  # a UTF-8 byte-order mark
    if not re.match(rb"ply[ \t]*\r?\n", data):
        raise InputError(path, "file", None, "is not a PLY file: it does not start with the line 'ply'")
    end = re.search(rb"^end_header[ \t]*(?:\r?\n|\Z)", data, re.M)
    if end is None:
        raise InputError(path, "file", None, "is truncated: no end_header line ends its header")
    try:
        lines = [line.rstrip("\r") for line in data[:end.start()].decode("utf-8").split("\n")[1:-1]]
    except UnicodeDecodeError as e:
        raise InputError(path, "file", None, f"its PLY header is not text (byte {e.start})") from None
    form = lines[0].split() if lines else []
    if len(form) != 3 or form[0] != "format" or form[1] not in PLY_FORMATS or form[2] not in ("1", "1.0"):
        raise InputError(path, "line 2", (lines or [""])[0][:80], "must be 'format ascii 1.0', 'format "
                         "binary_little_endian 1.0' or 'format binary_big_endian 1.0'")
    elements, taken_as_comments = [], []
    for n, line in enumerate(lines[1:], 3):
        problem = _ply_header_line(line.split(), elements)
        if problem:
            raise InputError(path, f"line {n}", line[:80], problem)
        if line.split()[:1] not in ([], ["comment"], ["obj_info"], ["element"], ["property"]):
            taken_as_comments.append(f"line {n} {line[:80]!r}")
    try:
        _check_ply_elements(path, elements)
    except InputError as e:  # a misspelt keyword is read as a comment: say so beside what it left missing
        if taken_as_comments:
            raise InputError(e.source, e.key, e.value, f"{e.problem} ({taken_as_comments[0]} was taken as a "
                             "comment)") from None
        raise
    return PLY_FORMATS[form[1]], elements, data[end.end():]


def _ply_header_line(words, elements):
    """Add an element or property line to `elements`; what is wrong with the line, or None."""
    if words[:1] in (["comment"], ["obj_info"]):
        return None
    if words[:1] == ["element"]:
        if len(words) != 3 or not words[2].isdigit():
            return "must be 'element NAME COUNT'"
        if words[1] in (name for name, _, _ in elements):
            return f"element {words[1]} is declared twice"
        elements.append((words[1], int(words[2]), []))
    elif words[:1] == ["property"]:
        scalar = len(words) == 3 and words[1] in PLY_TYPES
        listed = len(words) == 5 and words[1] == "list" and words[2] in PLY_TYPES and words[3] in PLY_TYPES \
            and PLY_TYPES[words[2]] not in "fd"
        if not (scalar or listed) or not elements:
            return "must be 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME' (integer COUNT_TYPE), " \
                   f"after an element line; types: {', '.join(PLY_TYPES)}"
        if words[-1] in (p[-1] for p in elements[-1][2]):
            return f"property {words[-1]} is declared twice in element {elements[-1][0]}"
        elements[-1][2].append(words[1:])
    elif words[:1] == ["format"]:
        return "a second format line"
    # any other line is taken as a comment: Blender 2.4x wrote "Created by Blender3D ..." without the keyword
    return None


def _check_ply_elements(path, elements):
    """The elements a mesh needs: vertices with x, y and z, faces with a list of vertex indices."""
    table = {name: properties for name, _, properties in elements}
    empty = next((name for name, count, properties in elements if count and not properties), None)
    if empty:
        raise InputError(path, empty, None, "the header declares no property for this element")
    scalars = {p[1] for p in table.get("vertex", []) if len(p) == 2}
    if not {"x", "y", "z"} <= scalars:
        raise InputError(path, "vertex", None, "the header declares no vertex element with x, y and z properties")
    counts = {name: count for name, count, _ in elements}
    if not counts.get("face"):
        raise InputError(path, "face", None, NO_FACES)
    if not any(p[0] == "list" and p[3] in PLY_INDEX_NAMES for p in table["face"]):
        raise InputError(path, "face", None, "the face element has no vertex_indices list")


def _canonical_header(endian, elements):
    """The header as trimesh's reader expects it, from what _ply_header read: no byte-order mark, 'ply' and
    'format ... 1.0' exactly, no comments."""
    form = next(name for name, order in PLY_FORMATS.items() if order == endian)
    lines = ["ply", f"format {form} 1.0"]
    for name, count, properties in elements:
        lines += [f"element {name} {count}"] + [f"property {' '.join(p)}" for p in properties]
    return ("\n".join(lines + ["end_header"]) + "\n").encode()


def _check_ply_size(path, endian, elements, body):
    """Refuse a body too short for the header's counts (a truncated file, or an absurd count that trimesh
    would try to allocate): in binary, at least each record's scalars and list counts; in ascii, a line
    per record."""
    truncated = "is truncated: its header declares " + ", ".join(f"element {n} {count}" for n, count, _ in elements)
    if endian:
        fixed = [count * sum(struct.calcsize(PLY_TYPES[p[1] if p[0] == "list" else p[0]]) for p in properties)
                 for _, count, properties in elements]
        if len(body) < sum(fixed):
            raise InputError(path, "file", None, f"{truncated}, at least {sum(fixed)} bytes, and {len(body)} bytes "
                             "follow it")
    else:
        lines = body.count(b"\n") + (bool(body) and not body.endswith(b"\n"))
        if lines < sum(count for _, count, _ in elements):
            raise InputError(path, "file", None, f"{truncated}, a line each, and {lines} lines follow it")


def _read_binary_ply(path, endian, elements, body):
    """Binary PLY that trimesh refuses: its binary reader needs every face list to have one length, and
    quad meshes with a few triangles (or n-gons) do not. Vertices read by numpy, faces record by record
    (slow in Python on large meshes: measured in commit cd6cb18), then fanned by size."""
    tables = _ply_elements(path, endian, elements, body)
    vertex, polygons = tables["vertex"], tables["face"][1]
    columns = vertex.dtype.names
    normals = np.stack([vertex[k] for k in ("nx", "ny", "nz")], 1) if {"nx", "ny", "nz"} <= set(columns) else None
    uv = next(((u, v) for u, v in PLY_UV_NAMES if u in columns and v in columns), None)
    sizes = np.array([len(p) for p in polygons])
    faces = [fan(np.array([p for p in polygons if len(p) == k])) for k in np.unique(sizes[sizes >= 3])]
    return (np.stack([vertex[k] for k in "xyz"], 1), np.concatenate(faces) if faces else np.zeros((0, 3), int),
            normals, None if uv is None else np.stack([vertex[uv[0]], vertex[uv[1]]], 1),
            vertex_attributes({name: vertex[name] for name in columns}))


def _ply_elements(path, endian, elements, body):
    """{element name: structured array of its scalar properties, or for elements with list properties, (that
    array, their vertex index lists)}; the vertex element is always the array."""
    offset, tables = 0, {}
    try:
        for name, count, properties in elements:
            if any(p[0] == "list" for p in properties):
                scalars, lists, offset = _ply_lists(body, offset, count, properties, endian)
                tables[name] = scalars if name == "vertex" else (scalars, lists)
            else:
                dtype = np.dtype([(p[1], endian + PLY_TYPES[p[0]]) for p in properties])
                tables[name] = np.frombuffer(body, dtype, count, offset)
                offset += count * dtype.itemsize
    except (struct.error, ValueError):  # a list longer than the bytes left, a table beyond the end
        raise InputError(path, "file", None, f"is truncated: element {name} ends beyond the end of the file "
                         f"({len(body)} bytes after the header)") from None
    if body[offset:].strip(b" \t\r\n"):  # a writer's closing newline is no data; other bytes are
        raise InputError(path, "file", None, f"holds {len(body) - offset} bytes after its last element: a list's "
                         "count does not match the indices it holds, or the header's counts are short")
    return tables


def _ply_lists(body, offset, count, properties, endian):
    """Of `count` records that have list properties: (a structured array of their scalar properties, their
    vertex index lists, the offset after them). Record by record: each list's length is in its record."""
    polygons, rows = [], []
    scalar_properties = [p for p in properties if p[0] != "list"]
    for _ in range(count):
        row = []
        for p in properties:
            if p[0] == "list":
                n = struct.unpack_from(endian + PLY_TYPES[p[1]], body, offset)[0]
                offset += struct.calcsize(endian + PLY_TYPES[p[1]])
                values = struct.unpack_from(f"{endian}{n}{PLY_TYPES[p[2]]}", body, offset)
                offset += struct.calcsize(f"{endian}{n}{PLY_TYPES[p[2]]}")
                if p[3] in PLY_INDEX_NAMES:
                    polygons.append(values)
            else:
                row.append(struct.unpack_from(endian + PLY_TYPES[p[0]], body, offset)[0])
                offset += struct.calcsize(endian + PLY_TYPES[p[0]])
        rows.append(tuple(row))
    dtype = np.dtype([(p[1], PLY_TYPES[p[0]]) for p in scalar_properties])
    return np.array(rows, dtype), polygons, offset
