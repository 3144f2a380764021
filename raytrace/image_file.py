"""Writing images with OpenImageIO: 8-bit formats encoded as the course does, float formats linear; written in
bands of rows, so an image of any size is written with little more memory than it takes. Nothing that is not a
finite float32 is ever written (checked after the cast to float32: a float64 beyond +-3.4e38 becomes Inf), nor
a value an .hdr file cannot hold."""
import errno
import json
import os

import numpy as np
import OpenImageIO as oiio

from .errors import InputError, check_path
from .outputs import Outputs, finite_json
from .renderer.progressive import row_chunks

EIGHT_BIT = {".png", ".jpg", ".jpeg", ".bmp", ".tga"}
FLOAT = {".exr", ".hdr"}
SIXTEEN_BIT = {".tif", ".tiff"}
FORMATS = EIGHT_BIT | FLOAT | SIXTEEN_BIT
BAND_BYTES = 16 << 20  # rows of the float image encoded and written at a time
# Radiance HDR's RGBE stores a pixel as three 8-bit mantissas under one exponent, with no sign: OpenImageIO 3.2's
# float2rgbe wraps the exponent byte of a pixel whose largest channel is 2^127 or more (the pixel reads back as
# 0) and makes garbage of a negative channel (0.5, -0.1, 0.25 read back as 0.5, 0.902, 0.25): measured.
HDR_LIMIT = 2.0 ** 127


def encode_8bit(image):
    """docs/model.md, image files: ceil(255 * clamp(x, 0, 1)^(1/2.2)); NaN reads as 0."""
    x = np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return np.ceil(255.0 * x ** (1.0 / 2.2) - 1e-9).astype(np.uint8)


def _row_bands(image):
    """Slices of at most BAND_BYTES of the image's rows (at least one row)."""
    return row_chunks(image.shape[0], max(1, image[0].nbytes), BAND_BYTES)


def _not_finite_float32(image):
    """How many values of `image` are not finite once cast to float32 (NaN, Inf, or beyond +-3.4e38)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return sum(int(np.count_nonzero(~np.isfinite(np.asarray(image[rows], dtype=np.float32))))
                   for rows in _row_bands(image))


def _beyond_hdr(image):
    """How many values of `image` an .hdr file cannot hold: negative ones, and those of 2^127 or more."""
    def bad(band):
        band = np.asarray(band, dtype=np.float32)  # as written: a float64 just below 2^127 may round up to it
        return int(np.count_nonzero((band < 0) | (band >= HDR_LIMIT)))
    return sum(bad(image[rows]) for rows in _row_bands(image))


def _plural(n, one, many):
    return f"{n} {one if n == 1 else many}"


def pixel_problem(ext, image, variance=None, aovs=()):
    """Why the H x W x 3 arrays `image` (and `variance` and the `aovs`' arrays, for an .exr) cannot be written in
    the format of extension `ext`, or None: a value that is not a finite float32, in any format (the render's NaN
    and Inf are never written; a float64 beyond float32's range would be written as Inf); in an .hdr, a value
    RGBE cannot hold (HDR_LIMIT)."""
    for name, array in (("the image", image), ("its variance", variance),
                        *((f"its AOV {channels[0].rpartition('.')[0]!r}", a) for channels, a in aovs)):
        if array is None:
            continue
        bad = _not_finite_float32(array)
        if bad:
            them = "it" if bad == 1 else "them"
            return (f"{name} holds {_plural(bad, 'value that is', 'values that are')} not finite as float32 (NaN, "
                    f"Inf, or beyond +-{np.finfo(np.float32).max:.7g}): refusing to write {them}")
    if ext == ".hdr":
        bad = _beyond_hdr(image)
        if bad:
            return (f"the image holds {_plural(bad, 'value', 'values')} an .hdr file cannot store (RGBE: from 0 to "
                    f"below 2^127 = {HDR_LIMIT:.4g}; OpenImageIO would write 0 or garbage): write an .exr")
    return None


def _pixels(ext, image, variance, aovs=()):
    """The file's pixels for some rows of `image` (and `variance`, and the `aovs`' arrays for those rows): encoded,
    in the written channel order."""
    if ext in EIGHT_BIT:
        return encode_8bit(image)
    if ext in SIXTEEN_BIT:
        return np.round(65535.0 * np.clip(image, 0, 1) ** (1 / 2.2)).astype(np.uint16)
    if variance is None and not aovs:
        return np.ascontiguousarray(image, dtype=np.float32)
    return np.concatenate([image, *([] if variance is None else [variance]), *aovs], axis=-1, dtype=np.float32)


def _write(out, tmp, spec, ext, image, variance, aovs=()):
    """Open `tmp`, write the image band by band, close; False at the first failure. OIIO 3.2's PNG writer
    reports a failed write (a full disk) only in has_error, its calls all returning True."""
    if out is None or not out.open(tmp, spec):
        return False
    for rows in _row_bands(image):
        band_variance = None if variance is None else variance[rows]
        pixels = _pixels(ext, image[rows], band_variance, [a[rows] for _, a in aovs])
        if not out.write_scanlines(rows.start, rows.stop, 0, pixels) or out.has_error:
            return False
    return out.close() and not out.has_error


def _spec(ext, width, height, metadata, variance, aovs=()):
    channels = (["R", "G", "B"] + (["variance.R", "variance.G", "variance.B"] if variance is not None else [])
                + [name for names, _ in aovs for name in names])
    pixel_type = "uint8" if ext in EIGHT_BIT else "uint16" if ext in SIXTEEN_BIT else "float"
    spec = oiio.ImageSpec(width, height, len(channels), oiio.TypeDesc(pixel_type))
    spec.channelnames = channels
    if not aovs:  # a file names the AOVs it carries (an EXR's layers): a PNG, or an EXR without them, none
        metadata = {key: value for key, value in (metadata or {}).items() if key != "aovs"}
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
        described = {f"raytrace:{key}": value for key, value in (metadata or {}).items()}  # finite_json: numpy too
        spec.attribute("ImageDescription", json.dumps(finite_json(described), allow_nan=False))
    return spec


def write_image_file(path, image, metadata=None, variance=None, aovs=()):
    """Write H x W x 3 linear float `image` into the file `path` itself (a temporary reserved by
    raytrace.outputs.Outputs, which renames it into place), in the format of its extension; OSError when
    the writer fails (a full disk, a file too large). An EXR file also carries `variance` (H x W x 3, the
    estimated variance of each pixel's mean), if given, as the channels variance.R, variance.G and variance.B,
    and after them the `aovs`: (channel names, H x W x C array) each (raytrace/aovs.py's layers).
    Encoded and written in bands of rows, so that a large image needs no full-size copies. ValueError for an
    extension of no format and for pixels pixel_problem() refuses: the callers check their input first
    (write_image() with InputError); this is the last guard, never a file with NaN or Inf."""
    path = str(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        raise ValueError(f"{path}: unsupported extension (have: {', '.join(sorted(FORMATS))})")
    variance = variance if ext == ".exr" else None
    aovs = list(aovs) if ext == ".exr" else []
    problem = pixel_problem(ext, image, variance, aovs)
    if problem:
        raise ValueError(f"{path}: {problem}")
    _write_file(path, ext, image, metadata, variance, aovs)


def _write_file(path, ext, image, metadata, variance, aovs=()):
    """write_image_file's writing, its input checked."""
    spec = _spec(ext, image.shape[1], image.shape[0], metadata, variance, aovs)
    out = oiio.ImageOutput.create(path)
    if not _write(out, path, spec, ext, image, variance, aovs):
        message = oiio.geterror() or (out.geterror() if out else "") or "no writer"
        raise OSError(errno.EIO, message.splitlines()[0].strip(), path)


def check_extension(path, source, key):
    """Refuse an image path whose extension names no format it can be written in."""
    if os.path.splitext(str(path))[1].lower() not in FORMATS:
        raise InputError(source, key, str(path), f"unsupported extension (have: {', '.join(sorted(FORMATS))})")


def check_array(array, source, key, shape=None):
    """`array` as a numpy array of H x W x 3 real numbers (H, W >= 1; of `shape` where given); InputError
    naming `key` otherwise."""
    try:
        array = np.asarray(array)
    except (TypeError, ValueError) as e:  # a ragged nested list
        raise InputError(source, key, type(array).__name__, f"is no array: {e}") from None
    if array.ndim != 3 or array.shape[2] != 3 or 0 in array.shape:
        raise InputError(source, f"{key}.shape", array.shape, "must be an H x W x 3 array (RGB; H, W >= 1)")
    if shape is not None and array.shape != shape:
        raise InputError(source, f"{key}.shape", array.shape, f"must be the image's, {shape}")
    if array.dtype.kind not in "iuf":
        raise InputError(source, f"{key}.dtype", str(array.dtype), "must be a real number type (float, int)")
    return array


def _aov_array(array, source, names, shape):
    """An AOV's array as numpy: H x W x len(names) real numbers, H x W the image's; InputError otherwise."""
    key = f"aovs[{names[0].rpartition('.')[0]!r}]"
    array = np.asarray(array)
    if array.shape != (*shape[:2], len(names)) or array.dtype.kind not in "iuf":
        raise InputError(source, key, f"{array.shape} {array.dtype}", f"must be an H x W x {len(names)} array of real "
                         f"numbers, H x W the image's {shape[:2]}")
    return array


def write_image(path, image, metadata=None, variance=None, key="path", source="write_image()", aovs=()):
    """Write H x W x 3 linear float `image` to `path` as the command line does (write_image_file: the format
    from the extension, `metadata` as the file's attributes, an EXR with the `variance` channels), atomically:
    a temporary file beside `path` renamed into place, so a failed write leaves no partial file. Bad paths,
    arrays that are not H x W x 3 real numbers, pixels pixel_problem() refuses and failed writes raise
    InputError naming `source` and `key` (the path's; "image" and "variance" for the arrays), and nothing is
    written. An EXR carries the `aovs` too, (channel names, H x W x C array) each, after the variance."""
    path = check_path(path, source, key)
    check_extension(path, source, key)
    ext = os.path.splitext(path)[1].lower()
    image = check_array(image, source, "image")
    variance = check_array(variance, source, "variance", image.shape) if variance is not None and ext == ".exr" \
        else None
    aovs = [(names, _aov_array(a, source, names, image.shape)) for names, a in aovs] if ext == ".exr" else []
    problem = pixel_problem(ext, image, variance, aovs)
    if problem:
        raise InputError(source, key, path, problem)
    with Outputs(source=source) as outputs:
        tmp = outputs.reserve(key, path)
        with outputs.writing(tmp):
            _write_file(tmp, ext, image, metadata, variance, aovs)
        outputs.commit()
