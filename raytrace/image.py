"""What render() returns: the image as a numpy array that also knows how it was made, saves itself the way
the command line saves it, and shows itself in Jupyter."""
import math
import os
import tempfile

import numpy as np

from . import aovs as aov_types
from .errors import InputError
from .image_file import write_image


def metadata(stats, scene_path):
    """The attributes an image file carries (docs/cli.md): the samples, patterns, filter, seed, seconds,
    device and scene, and with two pixel samples or more the estimated RMSE (where it is finite: a NaN or Inf
    is written into no file)."""
    data = {"spp": stats.spp, "light_samples": stats.light_samples, "sampler": stats.sampler,
            "light_sampler": stats.light_sampler, "texture_filter": stats.texture_filter, "seed": stats.seed,
            "seconds": float(stats.render_seconds), "device": stats.device, "scene": str(scene_path)}
    if stats.estimated_rmse is not None and math.isfinite(stats.estimated_rmse):
        data["estimated_rmse"] = float(stats.estimated_rmse)
    if getattr(stats, "aovs", None):
        data["aovs"] = aov_types.to_string(stats.aovs)  # Mitsuba's "name:type,...": which AOVs, of which types
    return data


class Image(np.ndarray):
    """An H x W x 3 float32 array of linear radiance, row 0 at the top: a numpy array in every way (np.asarray
    gives its data without a copy), with

    - variance: the H x W x 3 estimated variance of each pixel's mean, or None (one pixel sample);
    - aovs: the AOVs render(aov=...) stored (raytrace/aovs.py), {name: H x W x C float32} in the order asked
      (C: albedo 3, sh_normal 3, geo_normal 3, depth 1, position 3, uv 2), {} without;
    - stats: the RenderStats of the render that made it;
    - metadata: the attributes its files carry;
    - write(path): the file the command line would write (the format from the extension; .png, .jpg, .bmp,
      .tga in the course's 8-bit encoding ceil(255 x^(1/2.2)), .tif 16-bit, .exr and .hdr linear floats, an
      .exr with the variance channels, then the AOVs' as Mitsuba names them: NAME.R, NAME.G, NAME.B ..., and
      a denoised image's noisy one as noisy.R, noisy.G, noisy.B);
    - _repr_png_(): the 8-bit image, which Jupyter shows inline.

    A slice or a computed array is an Image without them."""

    @classmethod
    def of(cls, pixels, variance=None, stats=None, scene_path="", aovs=None):
        image = np.asarray(pixels).view(cls)
        image.variance, image.stats, image.aovs = variance, stats, dict(aovs or {})
        image.metadata = metadata(stats, scene_path) if stats is not None else {}
        return image

    def __array_finalize__(self, obj):
        self.variance, self.stats, self.metadata, self.aovs = None, None, {}, {}

    def write(self, path):
        """Write the image to `path` (a str or os.PathLike) atomically (a temporary file renamed into place).
        InputError, and nothing written, for a path that is no str, an unknown extension, an array that is not
        H x W x 3 real numbers, a value that is not a finite float32 (NaN, Inf, or a float64 beyond
        +-3.4e38; the error says how many), in an .hdr a negative value or one of 2^127 or more (RGBE cannot
        hold them), or a failed write."""
        write_image(path, np.asarray(self), self.metadata, self.variance, key="path", source="Image.write()",
                    aovs=self.layers())

    def layers(self):
        """The file layers beside the image and its variance: the AOVs its metadata names, then a denoised
        image's noisy one ([(channel names, H x W x C array)], image_file.write_image_file's `aovs`)."""
        from .denoise import noisy_layers
        pairs = aov_types.parse(self.metadata.get("aovs"), "Image.write()", "metadata['aovs']")
        return aov_types.layers(pairs, self.aovs) + noisy_layers(self.aovs)

    def _repr_png_(self):
        """The 8-bit PNG, or None (Jupyter then shows the text) for an array write() refuses."""
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "image.png")
            try:
                write_image(path, np.asarray(self), key="path", source="Image._repr_png_()")
            except InputError:
                return None
            with open(path, "rb") as f:
                return f.read()
