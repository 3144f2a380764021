"""Texture images: read with OpenImageIO in any format it knows, checked, decoded, and given their MIP
pyramid (raytrace/scene/mipmap.py) in the form the kernel stores them (kernels/textures.cl).

What the values mean:
- colour maps with 8 or 16 bits per channel are sRGB-encoded, float ones (EXR, HDR, float TIFF) linear;
- normal and height maps are data: code / 255 (or / 65535), never sRGB-decoded;
- 1 channel is grey, 2 are grey and alpha, 3 or 4 are RGB (and alpha); alpha is not used.

8-bit textures stay 8-bit on the device (one 32-bit word per RGBA texel, decoded in the kernel); the rest
are stored as float32 RGBA. Height maps, whose height is the first channel, hold each texel's height and
those of its right, lower and lower-right neighbours instead (kernels/types.h's TEXELS_QUAD8, TEXELS_QUAD16
and TEXELS_QUADF), so that a bilinear lookup reads one texel instead of four; 8- and 16-bit height maps keep
codes of their own depth at every level (the coarser levels' nearest codes to their exact averages), so that
a quad takes one word or two.

A file that cannot be a texture is refused with one InputError naming the scene file, the key and the
texture: unreadable or corrupt files (the libraries' own error line, captured from file descriptor 2 where
libpng prints it, becomes the message), images without pixels, images too large for the device buffer or
the host memory (checked from the header, before the pixels are read), NaN, infinite or beyond-float32
texels, and negative colours or heights.
"""
import contextlib
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from . import mipmap
from ..memory import available_memory
from .. import structs
from .mipmap import srgb_to_linear
from ..errors import InputError

ROLES = ("colour", "normal", "height", "data")  # colour map, normal map, height map, raw values (a bitmap's raw)


@dataclass(eq=False)
class Texture:
    """One image in one role: its levels, finest first, each H x W x 4 (uint8 codes or float32)."""
    path: str
    role: str
    encoding: int  # structs.TEXELS_*
    levels: list

    @property
    def size(self):
        return self.levels[0].shape[1], self.levels[0].shape[0]


def read_image(path):
    """(pixels H x W x C, kind) of the first image in the file, kind "8-bit" (uint8 codes), "16-bit" (uint16
    codes as floats, code / 65535), "integer" (other integer formats, as floats in [0, 1], or [-1, 1] when
    signed), "float" or "double" (float64, so that values beyond float32's range stay visible); raises
    OSError with one line of the libraries' words."""
    printed = []
    try:
        with _stderr_captured(printed):
            return _read_image(path)
    except OSError as e:
        raise OSError(_reason(printed, str(e))) from None


@contextlib.contextmanager
def _stderr_captured(lines):
    """Send file descriptor 2 to a temporary file, its lines appended to `lines` when restored: libpng and
    other C libraries under OpenImageIO print their errors there themselves, which would give the user
    two lines for one bad file (and warnings, such as libpng's about colour profiles, for good ones)."""
    sys.stderr.flush()
    with tempfile.TemporaryFile() as sink:
        saved = os.dup(2)
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            lines += [_printable(line) for line in sink.read().decode(errors="replace").splitlines()]


def _printable(text):
    """One line without control characters (error messages can quote a corrupt file's bytes)."""
    return "".join(c if c.isprintable() else "?" for c in text.strip())


def _reason(printed, message):
    """The most useful line: what a library printed as its error (libpng's is more precise than what
    OpenImageIO passes on), else OpenImageIO's first line, else whatever was printed."""
    errors = [line for line in printed if "error" in line.lower()]
    lines = errors + [_printable(line) for line in message.splitlines() if line.strip()] + printed
    return next((line for line in lines if line), "cannot be read")


def _oiio_error(geterror):
    """OpenImageIO's pending error as text; always clears it (one left pending is printed when the process
    exits). Its messages can quote a corrupt header's bytes, which are not always UTF-8."""
    try:
        return geterror()
    except UnicodeDecodeError as e:
        return e.object.decode(errors="replace")


def _read_image(path):
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)  # the colours as stored, not multiplied by alpha
    image = oiio.ImageInput.open(str(path), config)
    if image is None:
        raise OSError(_oiio_error(oiio.geterror) or "cannot open")
    try:
        spec = image.spec()
        base = spec.format.basetype
        kind = {oiio.UINT8: "8-bit", oiio.UINT16: "16-bit", oiio.HALF: "float", oiio.FLOAT: "float",
                oiio.DOUBLE: "double"}.get(base, "integer")
        _check_spec(image.format_name(), spec, kind)
        pixels = image.read_image(0, 0, 0, spec.nchannels, {"8-bit": "uint8", "double": "double"}.get(kind, "float"))
        if pixels is None:
            raise OSError(_oiio_error(image.geterror) or "cannot read the pixels")
    finally:
        image.close()
        _oiio_error(oiio.geterror)
    pixels = np.asarray(pixels)
    return (pixels[:, :, None] if pixels.ndim == 2 else pixels), kind


# Peak host memory of make_texture per texel of level 0 (measured with tracemalloc: 84 bytes for 8-bit maps,
# 104 for the others: the float64 pyramid and its temporaries), to which each channel of the file adds its
# pixels as read and the value checks' temporaries (three times its bytes).
HOST_BYTES_PER_TEXEL = 104


def _check_spec(format_name, spec, kind):
    """Refuse (ValueError), before any pixel is read, what cannot become a texture: OpenImageIO's "null"
    plugin (it makes up an image for any name ending in .null, existing or not), deep images, images without
    pixels, and images too large to load."""
    if format_name == "null":
        raise ValueError("is not an image file: OpenImageIO's null plugin makes up an image for any .null name")
    if spec.deep:
        raise ValueError("is a deep image: not supported")
    if spec.width < 1 or spec.height < 1 or spec.nchannels < 1:
        raise ValueError(f"the image has no pixels ({spec.width} x {spec.height}, {spec.nchannels} channels)")
    _check_size(spec, kind)


def _check_size(spec, kind):
    """Refuse an image whose levels the device buffer cannot hold, or whose loading the host memory cannot
    (a PNG of a few MB can claim 20000 x 20000 texels; the pyramid's float64 levels take 100 bytes a texel)."""
    size = f"{spec.width} x {spec.height}"
    words = _pyramid_texels(spec.width, spec.height) * (1 if kind == "8-bit" else 4)
    if words > structs.MAX_WORDS:
        raise ValueError(f"{size} is too large: its levels need {words * 4 / 2**30:.1f} GiB of device memory, "
                         f"more than one buffer holds ({structs.MAX_WORDS * 4 / 2**30:.0f} GiB)")
    channel_bytes = 3 * spec.nchannels * {"8-bit": 1, "double": 8}.get(kind, 4)
    needed, available = spec.width * spec.height * (HOST_BYTES_PER_TEXEL + channel_bytes), available_memory()
    if needed > available:
        raise ValueError(f"{size} is too large: it needs about {needed / 2**30:.1f} GiB of memory to load, "
                         f"{available / 2**30:.1f} GiB available")


def _pyramid_texels(width, height):
    """Texels of all MIP levels (mipmap.pyramid's sizes)."""
    total = width * height
    while width > 1 or height > 1:
        width, height = max(1, width // 2), max(1, height // 2)
        total += width * height
    return total


def rgb_channels(pixels):
    """Grey (1 or 2 channels) replicated to RGB; RGB(A) kept as RGB."""
    return np.repeat(pixels[:, :, :1], 3, axis=2) if pixels.shape[2] < 3 else pixels[:, :, :3]


def _rgba(rgb, alpha):
    return np.concatenate([rgb, np.full(rgb.shape[:2] + (1,), alpha, rgb.dtype)], axis=2)


def _filtered(rgb, role, alpha):
    """The channels the MIP pyramid filters: RGBA, or a height map's height (its first channel) alone."""
    return rgb[..., :1] if role == "height" else _rgba(rgb, alpha)


def load_texture(path, role, source, key):
    """Read `path` for `role`; errors name the scene file (`source`), the key and the path."""
    return load_checked(path, role, source, key, lambda pixels, kind: make_texture(pixels, kind, role, str(path)))


def load_checked(path, role, source, key, make):
    """make(pixels, kind) of the image at `path`, read (read_image) and checked for `role` (check_pixels; a
    ValueError `make` raises counts as a check too); any problem is one InputError naming the scene file
    (`source`), the key and the path."""
    def fail(problem):
        raise InputError(source, key, str(path), problem) from None
    if Path(path).exists() and not Path(path).is_file():  # a directory, a FIFO, /dev/zero: never an image
        fail("is not a regular file")
    try:
        pixels, kind = read_image(path)
        check_pixels(pixels, kind, role)
        return make(pixels, kind)
    except OSError as e:
        fail(f"cannot read the image: {e}")
    except ValueError as e:
        fail(str(e))
    except MemoryError:
        fail("the image does not fit in memory")


def check_pixels(pixels, kind, role):
    """ValueError for values no texture can hold: NaN and infinities (any role), values beyond float32's
    range (float64 files), fewer than 3 channels in a normal map, negative colours and heights (float and
    signed integer files; a negative colour would give negative light)."""
    if role == "normal" and pixels.shape[2] < 3:
        raise ValueError(f"a normal map needs 3 channels (x, y, z), it has {pixels.shape[2]}")
    if kind == "8-bit":
        return
    bad = ~(np.abs(pixels) <= np.finfo(np.float32).max)  # NaN, infinite, or too large for float32
    if bad.any():
        y, x, c = np.argwhere(bad)[0]
        value = pixels[y, x, c]
        what = "NaN or infinite values" if not np.isfinite(value) else "values beyond float32's range"
        raise ValueError(f"the image holds {what}: texel (x={x}, y={y}) channel {c} is {value:g}")
    used = rgb_channels(pixels)[..., :1 if role == "height" else 3]
    if role != "normal" and used.min() < 0:
        name = {"colour": "a colour map's values must be >= 0", "data": "a texture's values must be >= 0", "environment": "an environment map's values must "
                "be >= 0", "height": "a height map's heights must be >= 0 (relief lifts the surface outwards)"}[role]
        raise ValueError(f"{name}, its lowest is {float(used.min()):g}")


def make_texture(pixels, kind, role, path="<array>"):
    """A Texture from H x W x C pixels as read_image gives them (kind "8-bit", "16-bit", "integer", "float" or
    "double")."""
    rgb = rgb_channels(pixels)
    if kind == "8-bit":
        encoding = structs.TEXELS_SRGB8 if role == "colour" else structs.TEXELS_UNORM8
        levels = mipmap.pyramid_8bit(_filtered(rgb, role, 255), srgb=encoding == structs.TEXELS_SRGB8)
    elif kind == "16-bit" and role == "height":
        encoding = structs.TEXELS_QUAD16
        levels = mipmap.pyramid_16bit(np.rint(_filtered(rgb, role, 1.0) * 65535.0).astype(np.uint16))
    else:  # other integer formats arrive as floats in [0, 1] (or [-1, 1], refused for colours)
        linear = srgb_to_linear(rgb) if role == "colour" and kind in ("16-bit", "integer") else rgb.astype(np.float64)
        encoding = structs.TEXELS_FLOAT
        levels = [level.astype(np.float32) for level in mipmap.pyramid(_filtered(linear, role, 1.0))]
    if role == "height":  # the texels hold their neighbours' heights too
        encoding = {structs.TEXELS_UNORM8: structs.TEXELS_QUAD8, structs.TEXELS_QUAD16: structs.TEXELS_QUAD16,
                    structs.TEXELS_FLOAT: structs.TEXELS_QUADF}[encoding]
        levels = [mipmap.height_quads(level) for level in levels]
    return Texture(path, role, encoding, levels)


class TextureCache:
    """The textures of one scene, each (file, role) read once."""

    def __init__(self, base_dir):
        self.base_dir, self.textures, self._index = Path(base_dir), [], {}

    def index(self, relative_path, role, source, key):
        path = (self.base_dir / relative_path).resolve()
        if (path, role) not in self._index:
            self._index[path, role] = len(self.textures)
            self.textures.append(load_texture(path, role, source, key))
        return self._index[path, role]
