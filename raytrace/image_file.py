"""Writing images with OpenImageIO: 8-bit formats encoded as the course does, float formats linear; written in
bands of rows, so an image of any size is written with little more memory than it takes."""
import errno
import json
import os

import numpy as np
import OpenImageIO as oiio

from .errors import InputError
from .outputs import Outputs, finite_json
from .renderer.progressive import row_chunks

EIGHT_BIT = {".png", ".jpg", ".jpeg", ".bmp", ".tga"}
FLOAT = {".exr", ".hdr"}
SIXTEEN_BIT = {".tif", ".tiff"}
FORMATS = EIGHT_BIT | FLOAT | SIXTEEN_BIT
BAND_BYTES = 16 << 20  # rows of the float image encoded and written at a time


def encode_8bit(image):
    """docs/model.md, image files: ceil(255 * clamp(x, 0, 1)^(1/2.2)); NaN reads as 0."""
    x = np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return np.ceil(255.0 * x ** (1.0 / 2.2) - 1e-9).astype(np.uint8)


def _row_bands(image):
    """Slices of at most BAND_BYTES of the image's rows (at least one row)."""
    return row_chunks(image.shape[0], max(1, image[0].nbytes), BAND_BYTES)


def _finite(image):
    return all(np.isfinite(image[rows]).all() for rows in _row_bands(image))


def _pixels(ext, image, variance):
    """The file's pixels for some rows of `image` (and `variance`): encoded, in the written channel order."""
    if ext in EIGHT_BIT:
        return encode_8bit(image)
    if ext in SIXTEEN_BIT:
        return np.round(65535.0 * np.clip(image, 0, 1) ** (1 / 2.2)).astype(np.uint16)
    if variance is None:
        return np.ascontiguousarray(image, dtype=np.float32)
    return np.concatenate([image, variance], axis=-1, dtype=np.float32)


def _write(out, tmp, spec, ext, image, variance):
    """Open `tmp`, write the image band by band, close; False at the first failure. OIIO 3.2's PNG writer
    reports a failed write (a full disk) only in has_error, its calls all returning True."""
    if out is None or not out.open(tmp, spec):
        return False
    for rows in _row_bands(image):
        band_variance = None if variance is None else variance[rows]
        if not out.write_scanlines(rows.start, rows.stop, 0, _pixels(ext, image[rows], band_variance)) or out.has_error:
            return False
    return out.close() and not out.has_error


def _spec(ext, width, height, metadata, variance):
    channels = ["R", "G", "B"] + (["variance.R", "variance.G", "variance.B"] if variance is not None else [])
    pixel_type = "uint8" if ext in EIGHT_BIT else "uint16" if ext in SIXTEEN_BIT else "float"
    spec = oiio.ImageSpec(width, height, len(channels), oiio.TypeDesc(pixel_type))
    spec.channelnames = channels
    for key, value in (metadata or {}).items():
        if isinstance(value, int) and value >= 2**31:  # a seed up to 2^32 - 1: int attributes are int32, and
            spec.attribute(f"raytrace:{key}", str(value))  # OIIO's Python binding sets no wider number exactly
        else:
            spec.attribute(f"raytrace:{key}", value)
    if ext in FLOAT:
        spec.attribute("oiio:ColorSpace", "lin_rec709")
    if ext in SIXTEEN_BIT:
        # OIIO 3.2.2's TIFF writer makes an Exif directory even when it has no Exif field to put in it (an
        # empty spec too), and libtiff 4.7 fails to write that: "failed TIFFWriteCustomDirectory() of the Exif
        # data". We have no Exif data. TIFF keeps no custom attributes, so the description carries them.
        spec.attribute("tiff:write_exif", 0)
        described = {f"raytrace:{key}": _plain(value) for key, value in (metadata or {}).items()}
        spec.attribute("ImageDescription", json.dumps(finite_json(described), allow_nan=False))
    return spec


def _plain(value):
    """A metadata value as JSON has it (numpy scalars as Python numbers)."""
    return value.item() if isinstance(value, np.generic) else value


def write_image_file(path, image, metadata=None, variance=None):
    """Write H x W x 3 linear float `image` into the file `path` itself (a temporary reserved by
    raytrace.outputs.Outputs, which renames it into place), in the format of its extension; OSError when
    the writer fails (a full disk, a file too large). An EXR file also carries `variance` (H x W x 3, the
    estimated variance of each pixel's mean), if given, as the channels variance.R, variance.G and variance.B.
    Encoded and written in bands of rows, so that a large image needs no full-size copies."""
    path = str(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        raise ValueError(f"{path}: unsupported extension (have: {', '.join(sorted(FORMATS))})")
    variance = variance if ext == ".exr" else None
    if not _finite(image) or (variance is not None and not _finite(variance)):
        raise ValueError("refusing to write NaN or Inf into an image")
    spec = _spec(ext, image.shape[1], image.shape[0], metadata, variance)
    out = oiio.ImageOutput.create(path)
    if not _write(out, path, spec, ext, image, variance):
        message = oiio.geterror() or (out.geterror() if out else "") or "no writer"
        raise OSError(errno.EIO, message.splitlines()[0].strip(), path)


def check_extension(path, source, key):
    """Refuse an image path whose extension names no format it can be written in."""
    if os.path.splitext(str(path))[1].lower() not in FORMATS:
        raise InputError(source, key, str(path), f"unsupported extension (have: {', '.join(sorted(FORMATS))})")


def write_image(path, image, metadata=None, variance=None, key="path", source="write_image()"):
    """Write H x W x 3 linear float `image` to `path` as the command line does (write_image_file: the format
    from the extension, `metadata` as the file's attributes, an EXR with the `variance` channels), atomically:
    a temporary file beside `path` renamed into place, so a failed write leaves no partial file. Bad paths and
    failed writes raise InputError naming `source`, `key` and `path`."""
    check_extension(path, source, key)
    with Outputs(source=source) as outputs:
        tmp = outputs.reserve(key, path)
        with outputs.writing(tmp):
            write_image_file(tmp, image, metadata, variance)
        outputs.commit()
