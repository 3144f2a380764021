"""The small textures of the Mitsuba corpus's textured scenes (issue 58): `python -m devtools.corpus_textures`
writes them into scenes/mitsuba/textures.

Each is a few texels magnified on screen, so that where a texel lands, and how it is filtered and wrapped, can be
told apart per pixel when raytrace is judged against Mitsuba 3 on the same file:

- `letter_f.png` (8 x 6, 8-bit sRGB RGB): four dark corner colours, bilinearly blended over the texels (red at
  the top left, green at the top right, blue at the bottom left, olive at the bottom right, as the file is
  viewed: row 0 on top), and over them a near-white letter F (stem in column 1, bars in rows 1 and 3).
  Asymmetric under both flips and under the swap of u and v, so any orientation error shows; small, so that
  nearest and bilinear filtering differ over whole pixels, and both wrap and clamp edges show.
- `letter_f_grey.png` (8 x 6, 8-bit, one channel, sRGB): the luminance of `letter_f.png` (Rec. 709 weights,
  in linear), a single-channel image read as a colour (Mitsuba broadcasts it to all channels).
- `roughness.png` (64 x 64, 8-bit, one channel, data): a roughness map for a roughconductor's `alpha`, read
  raw, values from 0.05 to 0.6: four smooth stripes along v (a cosine across u) crossed by three Gaussian
  blobs where the stripes' value is inverted, so that both polished spots on rough metal and rough spots on
  polished metal show.
- `leaf.png` (32 x 32, 8-bit, one channel, data): a leaf's opacity for the `mask` BSDF, read raw: the
  intersection of two discs of unequal radii (a lopsided pointed leaf, its tip to the top right), a stem from
  its base to the bottom left, and a round hole 3 texels across in its wider half; opacity falls from 1 to 0
  over 1.5 texels of the signed distance to the outline, so bilinear filtering of the soft edge matters.

The colour images are built in linear RGB and encoded with the sRGB curve (what Mitsuba decodes for an 8-bit
PNG not read raw); the data maps hold their values as code / 255. Nothing is random: the same bytes each run.
"""
import argparse
from pathlib import Path

import numpy as np

from raytrace.commands.assets import DATA_SPACE, SRGB_SPACE, encode_srgb, write_png

OUT = Path(__file__).resolve().parents[1] / "scenes" / "mitsuba" / "textures"

CORNERS = np.array([[[0.60, 0.08, 0.05], [0.08, 0.45, 0.10]],    # top left red, top right green
                    [[0.05, 0.12, 0.60], [0.45, 0.40, 0.10]]])   # bottom left blue, bottom right olive
GLYPH = np.array([0.90, 0.90, 0.85])
REC709 = np.array([0.2126, 0.7152, 0.0722])


def letter_f():
    """8 x 6 x 3 linear RGB: the corners' bilinear blend under a letter F."""
    h, w = 6, 8
    t = np.linspace(0.0, 1.0, w)[None, :, None]
    s = np.linspace(0.0, 1.0, h)[:, None, None]
    rgb = ((1 - s) * ((1 - t) * CORNERS[0, 0] + t * CORNERS[0, 1])
           + s * ((1 - t) * CORNERS[1, 0] + t * CORNERS[1, 1]))
    glyph = np.zeros((h, w), bool)
    glyph[1:5, 1] = True     # the stem, rows 1 to 4
    glyph[1, 1:6] = True     # the top bar
    glyph[3, 1:5] = True     # the middle bar, shorter
    rgb[glyph] = GLYPH
    return rgb


def roughness(n=64, lo=0.05, hi=0.6):
    """n x n alpha values in [lo, hi]: stripes across u, inverted inside three blobs."""
    y, x = np.mgrid[0:n, 0:n] + 0.5
    stripes = 0.5 + 0.5 * np.cos(2 * np.pi * 4 * x / n)
    blob = np.zeros((n, n))
    for cx, cy, sigma in ((0.25, 0.3, 5.0), (0.7, 0.65, 7.0), (0.45, 0.85, 4.0)):
        blob = np.maximum(blob, np.exp(-((x - cx * n) ** 2 + (y - cy * n) ** 2) / (2 * sigma ** 2)))
    f = stripes * (1 - blob) + (1 - stripes) * blob
    return lo + (hi - lo) * f


def leaf(n=32, soft=1.5):
    """n x n opacity in [0, 1]: a lopsided leaf, its stem and a hole, soft over `soft` texels."""
    y, x = np.mgrid[0:n, 0:n] + 0.5
    y = n - y   # y up, as the image is viewed
    # the leaf's axis runs from its base (9, 9) to its tip (27, 27); u along it, v across (to the upper left)
    base, tip = np.array([9.0, 9.0]), np.array([27.0, 27.0])
    axis = (tip - base) / np.linalg.norm(tip - base)
    half = np.linalg.norm(tip - base) / 2
    u = (x - (base[0] + tip[0]) / 2) * axis[0] + (y - (base[1] + tip[1]) / 2) * axis[1]
    v = -(x - (base[0] + tip[0]) / 2) * axis[1] + (y - (base[1] + tip[1]) / 2) * axis[0]
    # two discs through base and tip, centred off the axis on opposite sides: radius r puts the centre at
    # sqrt(r^2 - half^2) from the axis; the smaller disc, centred on +v, bulges more (the wider half is on -v)
    discs = []
    for r, side in ((18.0, -1.0), (24.0, 1.0)):
        offset = np.sqrt(r * r - half * half)
        discs.append(np.hypot(u, v + side * offset) - r)
    d = np.maximum(*discs)
    hole = 1.5 - np.hypot(u + 1.0, v + 1.5)        # a hole of radius 1.5 texels in the wider half
    d = np.maximum(d, hole)
    # the stem: a segment 6 texels long from the base outwards, 1.6 texels wide
    t = np.clip(-(u + half), 0.0, 6.0)
    stem = np.hypot(u + half + t, v) - 0.8
    d = np.minimum(d, stem)
    return np.clip(0.5 - d / soft, 0.0, 1.0)


def textures():
    """{file name: (uint8 array, colour space)} of every texture."""
    rgb = letter_f()
    return {"letter_f.png": (encode_srgb(rgb), SRGB_SPACE),
            "letter_f_grey.png": (encode_srgb(rgb @ REC709), SRGB_SPACE),
            "roughness.png": (np.round(255.0 * roughness()).astype(np.uint8), DATA_SPACE),
            "leaf.png": (np.round(255.0 * leaf()).astype(np.uint8), DATA_SPACE)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT, help="the folder to write into")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, (pixels, space) in textures().items():
        write_png(args.out / name, pixels, space)
        print(args.out / name)


if __name__ == "__main__":
    main()
