"""Environment maps: the `envmap` emitter's equirectangular image (kernels/environment.cl), read with
OpenImageIO in any format it knows and checked like a colour texture (scene/textures.py): float files (EXR,
HDR, float TIFF) hold linear radiance, 8- and 16-bit ones are sRGB-encoded; grey is replicated to RGB and
alpha is not used. A file that cannot be one is refused with one InputError naming the scene file, the key and
the file: unreadable, no pixels, too large, NaN, infinite, beyond float32 or negative values."""
import numpy as np

from .mipmap import srgb_to_linear
from .textures import load_checked, rgb_channels

ROWS_PROBLEM = "an environment map needs at least 2 rows (its first looks at the zenith, its last at the nadir)"


def linear_rgb(pixels, kind):
    """H x W x 3 float32 linear RGB from H x W x C pixels as textures.read_image gives them."""
    rgb = rgb_channels(pixels)
    if kind == "8-bit":
        rgb = srgb_to_linear(rgb / 255.0)
    elif kind in ("16-bit", "integer"):
        rgb = srgb_to_linear(rgb)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def load(path, source, key):
    """The map at `path` as H x W x 3 float32 linear RGB; errors name the scene file (`source`), the key and
    the path."""
    def make(pixels, kind):
        if pixels.shape[0] < 2:
            raise ValueError(ROWS_PROBLEM)
        return linear_rgb(pixels, kind)
    return load_checked(path, "environment", source, key, make)
