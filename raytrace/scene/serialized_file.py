"""Reading Mitsuba's .serialized meshes for raytrace.scene.mesh_file.load_mesh: one shape of the file (shape_index)
as its vertices, triangles, normals, uvs and vertex colours, before the checks shared with OBJ and PLY
(mesh_file._checked). The format is Mitsuba 3's (src/shapes/serialized.cpp and its plugin reference), little
endian throughout:

    per shape:  uint16 0x041C, uint16 version (3 or 4), then one zlib stream of
                uint32 flags, [v4: the shape's name, NUL-terminated], uint64 vertex count, uint64 triangle count,
                positions (3 per vertex), [normals (3)], [uvs (2)], [colours (3)], in float32 or float64,
                and the triangles' indices (3 per triangle) in uint32 (uint64 past 2^32 vertices)
    at the end: the file offset of each shape's header (uint64 in v4, uint32 in v3), then uint32 their count

Flags: 0x0001 normals, 0x0002 uvs, 0x0008 colours, 0x0010 face normals, 0x1000 float32, 0x2000 float64.

As Mitsuba reads it: shape 0 starts the file, so reading it needs no end-of-file dictionary (single-shape files
may lack one); float64 where 0x2000 is set, else float32; the face-normals flag is ignored (Mitsuba 3's reader
never reads it: the face_normals parameter decides), and so are flags it has no use for (0x0004, tangents). Its
colours, which Mitsuba 3 reads past (a TODO in its reader), are kept here as the mesh attribute "vertex_color",
as a PLY file's are (ply_file.py), for the mesh_attribute texture.

Stricter than Mitsuba, which reads whatever the bytes say: each error one InputError naming the file, the part
and its value, never a partial mesh. A wrong format id or version, a shape_index beyond the dictionary's count
(Mitsuba's own test lets shape_index == count through), a dictionary or offset outside the file, a shape header
that differs from the file's, a corrupt or cut-off zlib stream, or one whose length differs from what its counts
need (by a byte either way), and both precision flags at once. Index ranges and finite, float32-sized values are
mesh_file._checked's, as for the other formats.
"""
import struct
import sys
import zlib

import numpy as np

from ..errors import InputError
from .meshes import NO_FACES

FORMAT_ID = 0x041C
VERSIONS = (3, 4)
HAS_NORMALS, HAS_UVS, HAS_COLOURS = 0x0001, 0x0002, 0x0008
SINGLE, DOUBLE = 0x1000, 0x2000
NAME_LIMIT = 1 << 16  # bytes of a shape's name at most: a stream without its NUL is not read to its end for it
CHUNK = 1 << 16       # decompressed bytes per step while the header is read


def read_serialized(path, data, shape_index=0):
    """Shape `shape_index` of the file: (vertices, triangles, normals, uvs, attributes), the arrays as stored
    (float64, and int64 indices), normals and uvs None where the file has none."""
    version = _header(path, data, 0, "file")
    start = 0 if shape_index == 0 else _shape_offset(path, data, version, shape_index)
    if start:
        if _header(path, data, start, f"shape {shape_index}") != version:
            raise InputError(path, f"shape {shape_index}", start, f"starts a header of another version than the "
                             f"file's ({version})")
    return _shape(path, memoryview(data)[start + 4:], version, shape_index)


def _header(path, data, at, what):
    """The version of the shape header at byte `at` (the file's first, or a shape's)."""
    if len(data) < at + 4:
        raise InputError(path, what, len(data), "is cut off: a .serialized file starts with 4 bytes of header "
                         "(0x041C and the version)")
    format_id, version = struct.unpack_from("<HH", data, at)
    if format_id != FORMAT_ID:
        raise InputError(path, f"{what} format id", f"0x{format_id:04X}", "is not a Mitsuba .serialized mesh "
                         "(format id 0x041C, little endian)")
    if version not in VERSIONS:
        raise InputError(path, f"{what} version", version, "must be 3 or 4 (the versions Mitsuba 3 reads)")
    return version


def _shape_offset(path, data, version, shape_index):
    """The file offset of shape `shape_index`'s header, from the end-of-file dictionary."""
    if len(data) < 8:
        raise InputError(path, "shape_index", shape_index, "needs the end-of-file dictionary of shape offsets, "
                         "which the file is too short to hold")
    count = struct.unpack_from("<I", data, len(data) - 4)[0]
    if shape_index >= count:
        raise InputError(path, "shape_index", shape_index, f"is out of range: the file holds {count} shape"
                         f"{'' if count == 1 else 's'} (0 to {count - 1})" if count else
                         "is out of range: the file's dictionary lists no shape")
    size = 8 if version == 4 else 4
    table = len(data) - 4 - size * count
    if table < 4:
        raise InputError(path, "shape count", count, f"is more than the file's {len(data)} bytes have room for "
                         f"in its end-of-file dictionary ({size} bytes each)")
    offset = struct.unpack_from("<Q" if size == 8 else "<I", data, table + size * shape_index)[0]
    if offset + 4 > table:
        raise InputError(path, f"shape {shape_index} offset", offset, f"is outside the shapes' bytes (0 to "
                         f"{table - 1}, before the end-of-file dictionary)")
    return offset


def _shape(path, stream, version, shape_index):
    """The shape whose zlib stream starts `stream`."""
    what = f"shape {shape_index}"
    z = zlib.decompressobj()
    head, tail = b"", stream
    while True:  # the header's length depends on the name's: decompress a chunk at a time until it is whole
        parsed = _stream_header(path, what, head, version)
        if parsed is not None:
            break
        if z.eof or not (tail or z.unconsumed_tail):
            raise InputError(path, what, len(head), "is cut off: its stream ends inside the header "
                             "(flags, name and counts)")
        head += _inflate(path, what, z, tail, CHUNK)
        tail = z.unconsumed_tail
    flags, length, vertex_count, face_count = parsed
    if flags & SINGLE and flags & DOUBLE:
        raise InputError(path, f"{what} flags", f"0x{flags:04X}", "set both single (0x1000) and double (0x2000) "
                         "precision")
    if not face_count:
        raise InputError(path, f"{what} triangle count", 0, NO_FACES)
    real = np.dtype("<f8" if flags & DOUBLE else "<f4")
    index = np.dtype("<u8" if vertex_count > 0xFFFFFFFF else "<u4")
    parts = [("positions", 3, True), ("normals", 3, flags & HAS_NORMALS), ("uvs", 2, flags & HAS_UVS),
             ("colours", 3, flags & HAS_COLOURS)]
    parts = [(name, width) for name, width, present in parts if present]
    need = length + sum(width for _, width in parts) * vertex_count * real.itemsize + 3 * face_count * index.itemsize
    body = head + _inflate(path, what, z, tail, min(need - len(head) + 1, sys.maxsize))  # a byte more: too long
    if len(body) != need or not z.eof:
        counts = f"its counts ({vertex_count} vertices, {face_count} triangles, flags 0x{flags:04X}) need {need} bytes"
        if len(body) > need:
            raise InputError(path, what, None, f"holds more bytes than {counts}")
        raise InputError(path, what, len(body), f"is cut off: its stream ends (or lacks its checksum) at "
                         f"{len(body)} bytes, where {counts}")
    arrays, at = {}, length
    for name, width in parts:
        arrays[name] = np.frombuffer(body, real, vertex_count * width, at).reshape(-1, width).astype(np.float64)
        at += vertex_count * width * real.itemsize
    faces = np.frombuffer(body, index, 3 * face_count, at).reshape(-1, 3)
    # an index past int64 stays out of range (mesh_file._checked refuses it), not wrapped negative
    faces = (np.minimum(faces, np.uint64(np.iinfo(np.int64).max)) if index.itemsize == 8 else faces).astype(np.int64)
    attributes = {"vertex_color": arrays["colours"]} if "colours" in arrays else {}
    return arrays["positions"], faces, arrays.get("normals"), arrays.get("uvs"), attributes


def _stream_header(path, what, head, version):
    """(flags, the header's length in bytes, vertex count, triangle count) once `head` holds the whole header;
    None before."""
    name_end = 4
    if version == 4:
        nul = head.find(b"\0", 4)
        if nul < 0:
            if len(head) > 4 + NAME_LIMIT:
                raise InputError(path, f"{what} name", None, f"runs past {NAME_LIMIT} bytes without its "
                                 "terminating NUL")
            return None
        name_end = nul + 1
    if len(head) < name_end + 16:
        return None
    flags, = struct.unpack_from("<I", head)
    vertex_count, face_count = struct.unpack_from("<QQ", head, name_end)
    return flags, name_end + 16, vertex_count, face_count


def _inflate(path, what, z, data, limit):
    """At most `limit` more bytes of the stream."""
    try:
        return z.decompress(data, limit)
    except zlib.error as e:
        raise InputError(path, what, None, f"is not a valid zlib stream ({e})") from None

