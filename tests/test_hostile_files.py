"""Hostile texture and mesh files (raytrace/scene/textures.py, raytrace/scene/meshes.py): random bytes,
truncated and corrupted copies of valid files, empty files and absurd headers, in every format the readers
take, read the way a scene reads them (load_file of a scene that names the file). Each must end in a valid
scene or in one InputError naming the file, with nothing else on file descriptor 2 (where libpng and other
C libraries print), no Python warning a user would see, and no OpenImageIO error left pending (one left
pending is printed when the process exits). The command line is run for the cases that used to print two
lines."""
import struct
import warnings

import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import ROOT, run
from raytrace.errors import InputError
from raytrace.memory import available_memory
from raytrace.scene import load_file, meshgen, textures

HEADER = (ROOT / "scenes" / "cornell.toml").read_text().split("[[shapes]]")[0]
# Black light and ambient, and a tiny height scale, so that however bright or high a valid texture's texels,
# the scene's own range rules (raytrace/scene/ranges.py, which name the scene's keys) never decide: the
# texture reader does.
DARK_HEADER = HEADER.replace("ambient = [0.1, 0.1, 0.1]", "ambient = [0.0, 0.0, 0.0]").replace(
    "colour = [1.0, 1.0, 1.0]", "colour = [0.0, 0.0, 0.0]")
FLOOR = ('[[shapes]]\ntype = "rectangle"\ncenter = [0.0, 0.0, 0.0]\nsize = [2.0, 2.0]\nnormal = [0.0, 0.0, 1.0]\n'
         'tangent = [1.0, 0.0, 0.0]\nmaterial = "t"\n')
TEXTURE_KEYS = ("texture", "normal_map", "height_map")


def texture_scene(folder, name, key):
    path = folder / "textured.toml"
    extra = {"texture": "", "normal_map": ", colour = [0.5, 0.5, 0.5]",
             "height_map": ", colour = [0.5, 0.5, 0.5], height_scale = 1e-30"}[key]
    path.write_text(DARK_HEADER.replace("[materials]", f'[materials]\nt = {{ {key} = "{name}"{extra} }}') + FLOOR)
    return path


def mesh_scene(folder, name):
    path = folder / "mesh.toml"
    path.write_text(HEADER + f'[[shapes]]\ntype = "mesh"\nfile = "{name}"\nmaterial = "white"\n')
    return path


def outcome(capfd, scene, named):
    """'ok' or the InputError's text, after checking the promise: no other exception, the error names the
    file `named` in one line, nothing printed on fd 1 or 2, no visible warning, no pending OpenImageIO error."""
    capfd.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            load_file(scene)
            result = "ok"
        except InputError as e:
            result = str(e)
            assert str(named) in result and "\n" not in result, result
    shown = [w for w in caught if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning))]
    assert not shown, [str(w.message) for w in shown]  # Python's default filters would print these
    printed = capfd.readouterr()
    assert printed.err == "" and printed.out == "", printed
    assert oiio.geterror() == ""
    return result


def variants(valid, rng, header):
    """{name: bytes}: empty, random, random text, truncations, the first `header` bytes followed by
    garbage, and copies of `valid` with a few bytes changed."""
    cases = {"empty": b"", "random": rng.bytes(600), "text": bytes(rng.integers(32, 127, 600, dtype=np.uint8))}
    if valid is None:
        return cases
    cases.update({f"cut{k}": valid[:len(valid) * k // 5] for k in range(1, 5)})
    cases["header+garbage"] = valid[:header] + rng.bytes(300)
    for k in range(6):
        changed = bytearray(valid)
        for i in rng.integers(0, min(len(valid), 200 if k % 2 else len(valid)), 3):  # half in the header
            changed[i] = rng.integers(0, 256)
        cases[f"changed{k}"] = bytes(changed)
    return cases


# --- textures -------------------------------------------------------------------------------------------

# Every format OpenImageIO reads here (oiio.get_string_attribute("extension_list")); the first group it can
# also write, so their valid files are truncated and corrupted too. "null" is OpenImageIO's plugin that makes
# up an image for any name: never a texture.
WRITABLE = ["png", "jpg", "exr", "tif", "hdr", "bmp", "tga", "gif", "webp", "ppm", "pfm", "sgi", "ico", "jxl",
            "fits", "dpx", "iff", "rla", "jp2"]
READ_ONLY = ["psd", "dds", "cin", "pic", "zfile", "null"]


def valid_image(path, ext, rng):
    """A 12 x 9 RGB image written in the format of `ext`, its bytes (None if OpenImageIO cannot write it)."""
    floats = ext in ("exr", "hdr", "pfm", "fits")
    pixels = rng.random((9, 12, 3)).astype(np.float32) if floats else rng.integers(0, 256, (9, 12, 3), np.uint8)
    out = oiio.ImageOutput.create(str(path))
    ok = out is not None and out.open(str(path), oiio.ImageSpec(12, 9, 3, "float" if floats else "uint8")) \
        and out.write_image(pixels) and out.close()
    oiio.geterror()
    return path.read_bytes() if ok else None


@pytest.mark.parametrize("ext", WRITABLE + READ_ONLY)
def test_hostile_textures(tmp_path, capfd, ext):
    """Every variant of a texture file, in turn a colour, normal and height map."""
    rng = np.random.default_rng(sum(map(ord, ext)))
    valid = valid_image(tmp_path / f"valid.{ext}", ext, rng) if ext in WRITABLE else None
    assert (valid is not None) == (ext in WRITABLE)
    results = {}
    for i, (name, data) in enumerate(variants(valid, rng, 48).items()):
        path = tmp_path / f"{name}.{ext}"
        path.write_bytes(data)
        results[name] = outcome(capfd, texture_scene(tmp_path, path.name, TEXTURE_KEYS[i % 3]), path)
    assert results["empty"] != "ok" and results["random"] != "ok", results


@pytest.mark.parametrize("case", ["truncated", "0x0"])
def test_broken_png_is_one_line_on_the_command_line(tmp_path, case):
    """libpng prints its own error line on fd 2 before OpenImageIO reports it: the user must see only ours,
    exit status 2, no image, and the library's words in our line."""
    path = tmp_path / "t.png"
    if case == "truncated":
        valid_image(path, "png", np.random.default_rng(0))
        path.write_bytes(path.read_bytes()[:-40])  # cut in the image data
    else:
        path.write_bytes(png_chunks(0, 0))
    out = tmp_path / "out" / "x.png"
    out.parent.mkdir()
    r = run("render", texture_scene(tmp_path, "t.png", "texture"), "-o", out, "--width", 8, "--height", 8)
    assert r.returncode == 2 and not any(out.parent.iterdir())
    assert r.stderr.count("\n") == 1 and str(path) in r.stderr, r.stderr
    assert ("IDAT" if case == "truncated" else "IHDR") in r.stderr, r.stderr


def png_chunks(width, height):
    """A PNG with this IHDR and an empty compressed IDAT (libpng rejects a 0 x 0 IHDR itself)."""
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")


@pytest.mark.parametrize("side", [50000, 40000])
def test_absurd_image_sizes_are_refused_before_reading(tmp_path, capfd, side):
    """A header claiming a huge image (OpenImageIO takes it when the file holds at least about a thousandth
    of the claimed bytes, and a compressed file can be that small) is refused from the header, naming the
    file, before the pixels are read or the pyramid built (a MemoryError, or the kernel's OOM killer,
    otherwise): 50000^2 texels do not fit in one device buffer (2^31 words, an 8-bit texel a word), 40000^2
    do, but building their levels takes about 170 GB of host memory. Where a host has that, the pixels run
    out instead."""
    path = tmp_path / "big.pgm"
    path.write_bytes(f"P5\n{side} {side}\n255\n".encode() + bytes(3_000_000))
    result = outcome(capfd, texture_scene(tmp_path, "big.pgm", "texture"), path)
    if side == 50000:
        assert "more than one buffer holds" in result, result
    elif available_memory() < side * side * (textures.HOST_BYTES_PER_TEXEL + 3):
        assert "memory to load" in result, result
    else:
        assert "Premature end of file" in result, result


# --- meshes ---------------------------------------------------------------------------------------------

def valid_mesh(kind):
    """A small UV sphere (normals, uvs) as an OBJ or a PLY ("ascii", "binary_little_endian" or
    "binary_big_endian"), its bytes, and where its header ends."""
    m = meshgen.sphere(60)
    if kind == "obj":
        lines = [f"v {x:.6g} {y:.6g} {z:.6g}" for x, y, z in m.vertices] + [f"vt {u:.6g} {v:.6g}" for u, v in m.uvs]
        lines += [f"vn {x:.6g} {y:.6g} {z:.6g}" for x, y, z in m.normals]
        lines += ["f " + " ".join(f"{i + 1}/{i + 1}/{i + 1}" for i in face) for face in m.faces]
        return ("\n".join(lines) + "\n").encode(), 200
    header = (f"ply\nformat {kind} 1.0\nelement vertex {len(m.vertices)}\n" +
              "".join(f"property float {p}\n" for p in ("x", "y", "z", "nx", "ny", "nz", "s", "t")) +
              f"element face {len(m.faces)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    rows = np.hstack([m.vertices, m.normals, m.uvs])
    if kind == "ascii":
        body = "".join(" ".join(f"{x:.6g}" for x in r) + "\n" for r in rows)
        body += "".join(f"3 {a} {b} {c}\n" for a, b, c in m.faces)
        return header + body.encode(), len(header)
    e = "<" if "little" in kind else ">"
    body = b"".join(struct.pack(e + "8f", *r) for r in rows) + b"".join(struct.pack(e + "B3i", 3, *f) for f in m.faces)
    return header + body, len(header)


MESH_KINDS = ["obj", "ascii", "binary_little_endian", "binary_big_endian"]


@pytest.mark.parametrize("kind", MESH_KINDS)
def test_hostile_meshes(tmp_path, capfd, kind):
    """Every variant of a mesh file, the header cut at 60 bytes, absurd element counts and face indices."""
    rng = np.random.default_rng(MESH_KINDS.index(kind))
    valid, header = valid_mesh(kind)
    cases = variants(valid, rng, header)
    cases.update({"valid": valid, "cut60": valid[:60]})
    if kind != "obj":
        cases["absurd"] = valid.replace(b"element vertex 55", b"element vertex 999999999999")
        cases["absurd_faces"] = valid.replace(b"element face 60", b"element face 999999999999")
    if kind == "ascii":  # face indices numpy casts to int with a RuntimeWarning (Python prints it on stderr)
        first_face = valid.index(b"\n3 ") + 1
        for name, line in (("index_3e43", b"3 30e42 41"), ("index_1e40", b"3 1e40 2 3")):
            cases[name] = valid[:first_face] + line + valid[valid.index(b"\n", first_face):]
    results = {}
    for name, data in cases.items():
        path = tmp_path / f"{name}.{'obj' if kind == 'obj' else 'ply'}"
        path.write_bytes(data)
        results[name] = outcome(capfd, mesh_scene(tmp_path, path.name), path)
    assert results["valid"] == "ok" and results["empty"] != "ok", results
    if kind != "obj":
        assert all("truncated" in results[k] for k in ("cut60", "cut1", "absurd", "absurd_faces")), results
