"""Writing images with OpenImageIO: 8-bit formats encoded as the course does, float formats linear."""
import os
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from .errors import InputError

EIGHT_BIT = {".png", ".jpg", ".jpeg", ".bmp", ".tga"}
FLOAT = {".exr", ".hdr"}
SIXTEEN_BIT = {".tif", ".tiff"}
FORMATS = EIGHT_BIT | FLOAT | SIXTEEN_BIT


def encode_8bit(image):
    """the README's model, image files: ceil(255 * clamp(x, 0, 1)^(1/2.2)); NaN reads as 0."""
    x = np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return np.ceil(255.0 * x ** (1.0 / 2.2) - 1e-9).astype(np.uint8)


def write_image(path, image, metadata=None, variance=None):
    """Write H x W x 3 linear float `image` to `path`, atomically: a temporary file renamed into place,
    so a failed write leaves no partial file. An EXR file also carries `variance` (H x W x 3, the estimated
    variance of each pixel's mean), if given, as the channels variance.R, variance.G and variance.B."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise InputError("command line", "-o", str(path), f"unsupported extension (have: {', '.join(sorted(FORMATS))})")
    if not np.all(np.isfinite(image)) or (variance is not None and not np.all(np.isfinite(variance))):
        raise ValueError("refusing to write NaN or Inf into an image")
    if ext in EIGHT_BIT:
        pixels = encode_8bit(image)
    elif ext in SIXTEEN_BIT:
        pixels = np.round(65535.0 * np.clip(image, 0, 1) ** (1 / 2.2)).astype(np.uint16)
    else:
        pixels = np.ascontiguousarray(image, dtype=np.float32)
    channels = ["R", "G", "B"]
    if ext == ".exr" and variance is not None:
        pixels = np.ascontiguousarray(np.concatenate([pixels, np.asarray(variance, np.float32)], axis=-1))
        channels += ["variance.R", "variance.G", "variance.B"]
    height, width = image.shape[:2]
    spec = oiio.ImageSpec(width, height, len(channels),
                          oiio.TypeDesc(pixels.dtype.name if pixels.dtype != np.float32 else "float"))
    spec.channelnames = channels
    for key, value in (metadata or {}).items():
        spec.attribute(f"raytrace:{key}", value)
    if ext in FLOAT:
        spec.attribute("oiio:ColorSpace", "lin_rec709")
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise InputError("command line", "-o", str(path), "the output directory does not exist")
    fd, tmp = tempfile.mkstemp(suffix=ext, prefix=".raytrace-", dir=directory)
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec) or not out.write_image(pixels) or not out.close():
            message = oiio.geterror() or (out.geterror() if out else "no writer")
            raise InputError("command line", "-o", str(path), f"cannot write: {message}")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
