"""MIP pyramids (Williams 1983): every level of a texture, from its file's pixels.

A level has max(1, W // 2) x max(1, H // 2) texels of the level above, each the exact area average of
the part of the finer level it covers (a box filter): for even sizes the 2 x 2 mean, for odd sizes the
three input texels under a 2 + 1/m wide box, weighted by their overlap. The pyramid ends at 1 x 1. 8-bit
levels are filtered in linear values (decoded from sRGB for colour maps) and encoded back to the nearest
8-bit code; level 0 keeps the file's codes exactly. 16-bit height maps keep 16-bit codes in the same way.
"""
import numpy as np


def _box_axis(image, axis):
    """Halve `image` along `axis` (n -> max(1, n // 2)) by area averaging."""
    n = image.shape[axis]
    m = max(1, n // 2)
    r = n / m                                    # the box's width in input texels, in [2, 3) (1 when n is 1)
    lo = np.arange(m) * r
    first = np.floor(lo).astype(np.int64)
    out = 0.0
    for j in range(4):                           # a box of width < 3 touches at most 4 texels
        index = first + j
        overlap = np.clip(np.minimum(index + 1, lo + r) - np.maximum(index, lo), 0.0, None)
        taps = np.take(image, np.minimum(index, n - 1), axis=axis)
        shape = [1] * image.ndim
        shape[axis] = m
        out = out + taps * (overlap / r).reshape(shape)
    return out


def downsample(level):
    """The next coarser level of an H x W x C float array."""
    return _box_axis(_box_axis(np.asarray(level, dtype=np.float64), 1), 0)


def pyramid(level0):
    """Every level, finest first, float64."""
    levels = [np.asarray(level0, dtype=np.float64)]
    while levels[-1].shape[0] > 1 or levels[-1].shape[1] > 1:
        levels.append(downsample(levels[-1]))
    return levels


def srgb_to_linear(c):
    """The inverse of the sRGB transfer function (IEC 61966-2-1), c in [0, 1]."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


SRGB8_TO_LINEAR = srgb_to_linear(np.arange(256) / 255.0)  # also the kernel's decoding table (in float32)


def _decode_table(srgb):
    return SRGB8_TO_LINEAR if srgb else np.arange(256) / 255.0


def encode_8bit(linear, srgb):
    """The 8-bit code whose decoded value is nearest to each linear value (alpha, channel 3, is linear)."""
    codes = np.empty(linear.shape, np.uint8)
    for table, channels in ((_decode_table(srgb), slice(0, 3)), (_decode_table(False), slice(3, 4))):
        midpoints = (table[1:] + table[:-1]) / 2
        codes[..., channels] = np.searchsorted(midpoints, linear[..., channels])
    return codes


def decode_8bit(codes, srgb):
    """Linear float64 values of H x W x C codes (RGB through the sRGB curve when srgb, alpha linear)."""
    linear = codes / 255.0
    linear[..., :3] = _decode_table(srgb)[codes[..., :3]]
    return linear


def pyramid_8bit(codes, srgb):
    """Levels of an H x W x C uint8 image (channel 3, if any, alpha), filtered in linear values, each stored as
    8-bit codes."""
    levels = pyramid(decode_8bit(codes, srgb))
    return [np.asarray(codes, np.uint8)] + [encode_8bit(level, srgb) for level in levels[1:]]


def pyramid_16bit(codes):
    """Levels of an H x W x C uint16 image of linear data (code / 65535), each stored as the nearest 16-bit
    codes; level 0 keeps the file's codes exactly."""
    levels = pyramid(codes / 65535.0)
    return [np.asarray(codes, np.uint16)] + [np.rint(level * 65535.0).astype(np.uint16) for level in levels[1:]]


def height_quads(level):
    """An H x W x C level's first channel (a height map's heights) as quads, the layout of kernels/types.h's
    TEXELS_QUAD8, TEXELS_QUAD16 and TEXELS_QUADF: each texel with its right, lower and lower-right
    neighbours' heights, 0 beyond the edges (where the neighbour depends on the wrap mode: the kernel reads
    those from the neighbours' own texels). Same dtype as the level."""
    h = np.zeros((level.shape[0] + 1, level.shape[1] + 1), level.dtype)
    h[:-1, :-1] = level[..., 0]
    return np.stack([h[:-1, :-1], h[:-1, 1:], h[1:, :-1], h[1:, 1:]], axis=2)
