"""Reading PLY files for raytrace.scene.mesh_file.load_mesh: the file's vertices, polygons (fanned into
triangles in the file's order), normals, uvs and mesh attributes, before the checks shared with OBJ
(mesh_file._checked). Limits: texture coordinates stored per face corner ("texcoord" lists) keep one uv per
vertex.

Mesh attributes are Mitsuba 3's: the vertex and face properties beyond the geometry, grouped and named as its PLY
reader does ("vertex_color", "face_color", "vertex_<prefix>", ...: attribute_groups), for its mesh_attribute
texture. A face attribute has a row per triangle, its polygon's value.

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
from .meshes import NO_FACES, fan_polygons, quiet, why


def read_ply(path, data):
    """The file's (vertices, triangles, normals, uvs, attributes). fix_texture=False keeps the file's vertex
    order; the faces come from trimesh's raw lists, fanned here in the file's order, so that the face
    attributes' rows follow them."""
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
    raw = read.get("metadata", {}).get("_ply_raw", {})
    vertex_data, face_data = (_columns(raw.get(name, {}).get("data", {})) for name in ("vertex", "face"))
    indices = next((face_data[name] for name in PLY_INDEX_NAMES if name in face_data), read.get("faces", []))
    if isinstance(indices, np.ndarray) and indices.dtype.names:  # the binary reader's (count, indices) records
        indices = indices["f1"]
    faces, polygon = fan_polygons(indices)  # trimesh's own fan puts mixed sizes out of the file's order
    if not len(faces):
        raise InputError(path, "face", None, NO_FACES)
    attributes = element_attributes(path, elements, "vertex", vertex_data, len(read["vertices"]))
    attributes |= {name: values[polygon] for name, values in element_attributes(
        path, elements, "face", face_data, len(indices)).items()}  # each triangle its polygon's value
    return read["vertices"], faces, read.get("vertex_normals"), getattr(read.get("visual"), "uv", None), attributes


def _columns(data):
    """{property: values} of trimesh's raw data of an element (a dict, or its binary reader's structured array)."""
    if isinstance(data, np.ndarray):
        return {name: data[name] for name in data.dtype.names or ()}
    return dict(data)


# Mitsuba 3's PLY reader (find_other_fields, in the header beside src/shapes/ply.cpp) groups an element's
# properties into attributes: r, g, b (or red, green, blue), and a (alpha), into "<element>_color"; then
# consecutive properties <prefix>_<postfix> whose postfixes run through one of these schemes, from its first
# letter, into "<element>_<prefix>" (the rgba scheme's "<element>_<prefix>_color"), of one or three values (two
# or four are ignored, as Mitsuba ignores them with a warning); names without "_" are ignored.
POSTFIXES = ("xr01", "yg12", "zb23", "wa34")  # a scheme's k-th postfix: POSTFIXES[k][scheme]
# The fields Mitsuba reads as geometry, which no attribute takes (lists become NAME.count, i0, i1, i2)
RESERVED = {"vertex": {"x", "y", "z", "nx", "ny", "nz", "u", "v", "r", "g", "b", "a"},
            "face": {"vertex_index.count", "vertex_indices.count", "i0", "i1", "i2", "r", "g", "b", "a"}}


def element_attributes(path, elements, element, columns, count):
    """{name: (count, dim) float64} of the mesh attributes Mitsuba 3 reads from a PLY element ("vertex" or
    "face"; `columns`: {property: values}), with its names (attribute_groups). Values as Mitsuba reads them,
    except integer colours (attributes whose name has "color", Mitsuba's test for a colour: MeshLab's and
    Blender's 8-bit vertex colours), which become code / the type's largest code: Mitsuba takes an 8-bit code
    as it is (and warns that it expects [0, 1]), and a 16- or 32-bit one as sRGB, decoded from code / largest
    code, which no one means by a colour of 255. Other integer attributes as Mitsuba reads them: uchar codes as
    they are, other integer types sRGB-decoded (its PLY header marks every integer property normalised and
    gamma-encoded, and its conversion applies that to all but 8-bit ones)."""
    properties = next((p for name, _, p in elements if name == element), [])
    types = {p[-1]: p[0] for p in properties if p[0] != "list"}
    attributes = {}
    for name, fields in attribute_groups(element, properties):
        if name in attributes:  # Mitsuba's add_attribute refuses a second one
            raise InputError(path, element, name, "two groups of properties make this mesh attribute (r, g, b and "
                             "a prefixed group named color), which Mitsuba refuses")
        missing = [field for field in fields if field not in columns]
        if missing:  # after its slip on a malformed sequence (attribute_groups), Mitsuba's reader fails so
            raise InputError(path, element, name, f"Mitsuba's PLY reader makes this attribute of properties "
                             f"{', '.join(fields)}, and refuses the file, which has no {missing[0]}")
        values = []
        for field in fields:
            column = np.asarray(columns[field]).reshape(-1)
            if column.size != count:
                break  # trimesh could not read the element's records (a list of another length in them)
            values.append(_attribute_values(column, types[field], "color" in name))
        else:
            attributes[name] = np.stack(values, 1)
    return attributes


def _attribute_values(column, kind, colour):
    """A property's values as a mesh attribute reads them (element_attributes)."""
    if PLY_TYPES[kind] in "fd":
        return column.astype(np.float64)
    largest = float(np.iinfo(np.dtype(PLY_TYPES[kind])).max)
    if colour:
        return column / largest
    if PLY_TYPES[kind] == "B":
        return column.astype(np.float64)
    x = column / largest  # sRGB's decoding, as Mitsuba applies it
    return np.where(x <= 0.04045, x / 12.92, ((np.abs(x) + 0.055) / 1.055) ** 2.4 * np.sign(x))


def attribute_groups(element, properties):
    """[(attribute name, [its properties])] of a PLY element's header properties (words after `property`), as
    Mitsuba 3.9.1's find_other_fields groups them, in its order: the colour first, then the prefixed groups.
    Ported line by line, with its slips on malformed sequences: after a prefix met before, or a postfix out of
    its scheme, it passes over the prefix's fields and then over one more field, and in the second case counts
    that field into the next group, which then mostly has 2 or 4 values and is dropped, or names a property the
    file lacks (element_attributes refuses the file then, as Mitsuba's reader does)."""
    fields = []
    for p in properties:
        fields += [f"{p[-1]}.count", "i0", "i1", "i2"] if p[0] == "list" else [p[-1]]
    names = set(fields)
    renames = {}
    if element == "vertex" and not {"u", "v"} <= names:  # Mitsuba's uv names, renamed to u and v
        pair = next((pair for pair in (("texture_u", "texture_v"), ("s", "t")) if set(pair) <= names), None)
        renames |= dict(zip(pair, ("u", "v"))) if pair else {}
    if not {"r", "g", "b"} <= names and {"red", "green", "blue"} <= names:
        renames |= {"red": "r", "green": "g", "blue": "b", "alpha": "a"}
    original = {renames.get(f, f): f for f in fields}
    fields = [renames.get(f, f) for f in fields]
    groups = []
    if {"r", "g", "b"} <= set(fields):
        groups.append((f"{element}_color", [original[c] for c in ("r", "g", "b", "a") if c in fields]))
    reserved, seen = RESERVED[element], set()
    prefix, scheme, level, reading = "", 0, 0, False
    i = 0
    while i < len(fields):
        name = fields[i]
        if name in reserved:
            i += 1
            continue
        head, underscore, postfix = name.rpartition("_")
        if not underscore or len(postfix) != 1:  # no postfix, or a longer one: ignored
            if reading:
                groups += _group(element, prefix, scheme, level, seen, original)
                prefix, level, reading = "", 0, False
            i += 1
            continue
        if reading and head != prefix:
            groups += _group(element, prefix, scheme, level, seen, original)
            prefix, level, reading = "", 0, False
        if not reading and head in seen:  # a prefix met before: its fields ignored (and one more, as Mitsuba's)
            while i < len(fields) and fields[i].startswith(head):
                i += 1
            i += 1
            continue
        if not reading:
            if postfix not in POSTFIXES[0]:  # no scheme starts with it
                i += 1
                continue
            prefix, scheme, reading = head, POSTFIXES[0].index(postfix), True
        elif level >= len(POSTFIXES) or postfix != POSTFIXES[level][scheme]:  # out of sequence: the group dropped
            prefix, level, reading = "", 0, False
            while i < len(fields) and fields[i].startswith(head):
                i += 1
            if i == len(fields):
                break
        level += 1
        i += 1
    if reading:
        groups += _group(element, prefix, scheme, level, seen, original)
    return groups


def _group(element, prefix, scheme, level, seen, original):
    """attribute_groups' group of `level` properties `prefix`_postfix, if it has 1 or 3 (Mitsuba's flush)."""
    if level not in (1, 3):
        return []
    seen.add(prefix)
    fields = [f"{prefix}_{POSTFIXES[k][scheme]}" for k in range(level)]
    return [(f"{element}_{prefix}{'_color' if scheme == 1 else ''}", [original.get(f, f) for f in fields])]


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
    faces, polygon = fan_polygons(polygons)
    attributes = element_attributes(path, elements, "vertex", {name: vertex[name] for name in columns}, len(vertex))
    face = tables["face"][0]
    attributes |= {name: values[polygon] for name, values in element_attributes(
        path, elements, "face", {name: face[name] for name in face.dtype.names or ()}, len(polygons)).items()}
    return (np.stack([vertex[k] for k in "xyz"], 1), faces, normals,
            None if uv is None else np.stack([vertex[uv[0]], vertex[uv[1]]], 1), attributes)


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
