"""Texture images: read with OpenImageIO in any format it knows, checked, decoded, and given their MIP
pyramid (raytrace/mipmap.py) in the form the kernel stores them (kernels/textures.cl).

What the values mean:
- colour maps with 8 or 16 bits per channel are sRGB-encoded, float ones (EXR, HDR, float TIFF) linear;
- normal and height maps are data: code / 255 (or / 65535), never sRGB-decoded;
- 1 channel is grey, 2 are grey and alpha, 3 or 4 are RGB (and alpha); alpha is not used.

8-bit textures stay 8-bit on the device (one 32-bit word per RGBA texel, decoded in the kernel); the rest
are stored as float32 RGBA.
"""
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from . import mipmap
from .. import structs
from .mipmap import srgb_to_linear
from ..errors import InputError

ROLES = ("colour", "normal", "height")  # colour map, normal map, height map


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
    """(pixels H x W x C, kind) of the first image in the file, kind "8-bit" (uint8 codes), "integer" (other
    integer formats, as floats in [0, 1]) or "float"; raises OSError with OpenImageIO's words."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)  # the colours as stored, not multiplied by alpha
    image = oiio.ImageInput.open(str(path), config)
    if image is None:
        raise OSError(oiio.geterror() or "cannot open")
    try:
        spec = image.spec()
        base = spec.format.basetype
        kind = "8-bit" if base == oiio.UINT8 else "float" if base in (oiio.HALF, oiio.FLOAT, oiio.DOUBLE) \
            else "integer"
        pixels = image.read_image(0, 0, 0, spec.nchannels, "uint8" if kind == "8-bit" else "float")
        if pixels is None:
            raise OSError(image.geterror() or "cannot read the pixels")
    finally:
        image.close()
    pixels = np.asarray(pixels)
    return (pixels[:, :, None] if pixels.ndim == 2 else pixels), kind


def _rgb(pixels):
    """Grey (1 or 2 channels) replicated to RGB; RGB(A) kept as RGB."""
    return np.repeat(pixels[:, :, :1], 3, axis=2) if pixels.shape[2] < 3 else pixels[:, :, :3]


def _rgba(rgb, alpha):
    return np.concatenate([rgb, np.full(rgb.shape[:2] + (1,), alpha, rgb.dtype)], axis=2)


def load_texture(path, role, source, key):
    """Read `path` for `role`; errors name the scene file (`source`), the key and the path."""
    try:
        pixels, kind = read_image(path)
    except OSError as e:
        raise InputError(source, key, str(path), f"cannot read the image: {str(e).splitlines()[0]}") from None
    if role == "normal" and pixels.shape[2] < 3:
        raise InputError(source, key, str(path), f"a normal map needs 3 channels (x, y, z), it has {pixels.shape[2]}")
    if not np.all(np.isfinite(pixels)):
        raise InputError(source, key, str(path), "the image holds NaN or infinite values")
    if role == "height" and pixels[..., 0].min() < 0:  # 8-bit and integer images read as >= 0
        raise InputError(source, key, str(path), f"a height map's heights must be >= 0 (relief lifts the surface "
                         f"outwards), its lowest is {float(pixels[..., 0].min()):g}")
    return make_texture(pixels, kind, role, str(path))


def make_texture(pixels, kind, role, path="<array>"):
    """A Texture from H x W x C pixels as read_image gives them (kind "8-bit", "integer" or "float")."""
    rgb = _rgb(pixels)
    if kind == "8-bit":
        encoding = structs.TEXELS_SRGB8 if role == "colour" else structs.TEXELS_UNORM8
        levels = mipmap.pyramid_8bit(_rgba(rgb, 255), srgb=encoding == structs.TEXELS_SRGB8)
    else:  # other integer formats arrive as floats in [0, 1]
        linear = srgb_to_linear(rgb) if role == "colour" and kind == "integer" else rgb.astype(np.float64)
        encoding = structs.TEXELS_FLOAT
        levels = [level.astype(np.float32) for level in mipmap.pyramid(_rgba(linear, 1.0))]
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
