"""Mitsuba 3's spectra as its RGB variants (scalar_rgb, llvm_ad_rgb, ...) turn them into linear sRGB when they
load a scene: a `<spectrum>`'s uniform value or (wavelength, value) list, and its `.spd` files.

Mitsuba 3.9.1's code is the specification (https://github.com/mitsuba-renderer/mitsuba3/tree/v3.9.1/src/core):
Properties::get_texture_impl in properties.cpp picks the conversion, spectrum_list_to_srgb in spectrum.cpp
does it, with the tables, constants and matrix of its header include/mitsuba/core/spectrum. A list is
integrated in float64 (Properties::Spectrum holds doubles) over float32 tables; so is everything here, and the
colour is returned before Mitsuba's one rounding to float32 (the model keeps float64).

- A reflectance's list (any BSDF parameter's) is integrated against CIE 1931 x, y, z times the D65 illuminant,
  so that a flat list of 1 is (nearly) white, and clamped to [0, 1]; an unbounded parameter's (conductor eta
  and k, roughness alpha) is only clamped at 0. A uniform value stays as it is: Mitsuba makes a `uniform`
  texture of it, unclamped.
- An emitter's list is integrated against x, y, z alone (the light is the spectrum itself, not D65-lit) and
  clamped at 0; a uniform value v becomes v * xyz_to_srgb(1, 1, 1), an equal-energy light's "purple-ish"
  colour, so that the RGB variants agree with the spectral ones.
"""
import re
from pathlib import Path

import numpy as np

from ..errors import InputError

# CIE 1931 2-degree colour matching functions x, y, z from 360 to 830 nm in 5 nm steps (CIE 015:2018, the
# values of Mitsuba's cie1931_tbl in src/core/spectrum.cpp, which stores them as float32).
_CIE = """
0.0001299 0.0002321 0.0004149 0.0007416 0.001368 0.002236 0.004243 0.00765 0.01431 0.02319 0.04351 0.07763
0.13438 0.21477 0.2839 0.3285 0.34828 0.34806 0.3362 0.3187 0.2908 0.2511 0.19536 0.1421 0.09564 0.05795001
0.03201 0.0147 0.0049 0.0024 0.0093 0.0291 0.06327 0.1096 0.1655 0.2257499 0.2904 0.3597 0.4334499 0.5120501
0.5945 0.6784 0.7621 0.8425 0.9163 0.9786 1.0263 1.0567 1.0622 1.0456 1.0026 0.9384 0.8544499 0.7514 0.6424
0.5419 0.4479 0.3608 0.2835 0.2187 0.1649 0.1212 0.0874 0.0636 0.04677 0.0329 0.0227 0.01584 0.01135916
0.008110916 0.005790346 0.004109457 0.002899327 0.00204919 0.001439971 0.0009999493 0.0006900786 0.0004760213
0.0003323011 0.0002348261 0.0001661505 0.000117413 8.307527e-05 5.870652e-05 4.150994e-05 2.935326e-05
2.067383e-05 1.455977e-05 1.025398e-05 7.221456e-06 5.085868e-06 3.581652e-06 2.522525e-06 1.776509e-06
1.251141e-06

3.917e-06 6.965e-06 1.239e-05 2.202e-05 3.9e-05 6.4e-05 0.00012 0.000217 0.000396 0.00064 0.00121 0.00218 0.004
0.0073 0.0116 0.01684 0.023 0.0298 0.038 0.048 0.06 0.0739 0.09098 0.1126 0.13902 0.1693 0.20802 0.2586 0.323
0.4073 0.503 0.6082 0.71 0.7932 0.862 0.9148501 0.954 0.9803 0.9949501 1.0 0.995 0.9786 0.952 0.9154 0.87
0.8163 0.757 0.6949 0.631 0.5668 0.503 0.4412 0.381 0.321 0.265 0.217 0.175 0.1382 0.107 0.0816 0.061 0.04458
0.032 0.0232 0.017 0.01192 0.00821 0.005723 0.004102 0.002929 0.002091 0.001484 0.001047 0.00074 0.00052
0.0003611 0.0002492 0.0001719 0.00012 8.48e-05 6e-05 4.24e-05 3e-05 2.12e-05 1.499e-05 1.06e-05 7.4657e-06
5.2578e-06 3.7029e-06 2.6078e-06 1.8366e-06 1.2934e-06 9.1093e-07 6.4153e-07 4.5181e-07

0.0006061 0.001086 0.001946 0.003486 0.006450001 0.01054999 0.02005001 0.03621 0.06785001 0.1102 0.2074 0.3713
0.6456 1.0390501 1.3856 1.62296 1.74706 1.7826 1.77211 1.7441 1.6692 1.5281 1.28764 1.0419 0.8129501 0.6162
0.46518 0.3533 0.272 0.2123 0.1582 0.1117 0.07824999 0.05725001 0.04216 0.02984 0.0203 0.0134 0.008749999
0.005749999 0.0039 0.002749999 0.0021 0.0018 0.001650001 0.0014 0.0011 0.001 0.0008 0.0006 0.00034 0.00024
0.00019 0.0001 4.999999e-05 3e-05 2e-05 1e-05""" + " 0" * 37  # z bar is 0 from 650 nm on

# The CIE D65 illuminant on the same wavelengths, relative to its power at 560 nm (Mitsuba's d65_table).
_D65 = """
46.6383 49.3637 52.0891 51.0323 49.9755 52.3118 54.6482 68.7015 82.7549 87.1204 91.486 92.4589 93.4318 90.057
86.6823 95.7736 104.865 110.936 117.008 117.41 117.812 116.336 114.861 115.392 115.923 112.367 108.811 109.082
109.354 108.578 107.802 106.296 104.79 106.239 107.689 106.047 104.405 104.225 104.046 102.023 100.0 98.1671
96.3342 96.0611 95.788 92.2368 88.6856 89.3459 90.0062 89.8026 89.5991 88.6489 87.6987 85.4936 83.2886 83.4939
83.6992 81.863 80.0268 80.1207 80.2146 81.2462 82.2778 80.281 78.2842 74.0027 69.7213 70.6652 71.6091 72.979
74.349 67.9765 61.604 65.7448 69.8856 72.4863 75.087 69.3398 63.5927 55.0054 46.4182 56.6118 66.8054 65.0941
63.3828 63.8434 64.304 61.8779 59.4519 55.7054 51.959 54.6998 57.4406 58.8765 60.3125"""


def _float32_table(text):
    """Decimal numbers as Mitsuba's float32 tables hold them, in float64 (none of these numbers rounds
    differently through float64 than directly)."""
    return np.array(text.split(), np.float64).astype(np.float32).astype(np.float64)


CIE_MIN, CIE_MAX, CIE_SAMPLES = 360.0, 830.0, 95
CIE_XYZ = _float32_table(_CIE).reshape(3, CIE_SAMPLES)
D65 = _float32_table(_D65)
# Scale factors that make a unit spectrum's luminance Y 1 (MI_CIE_Y_NORMALIZATION) and D65's luminance 1
# (MI_CIE_D65_NORMALIZATION), as Mitsuba writes them.
Y_NORMALIZATION = 1.0 / 106.7502593994140625
D65_NORMALIZATION = 1.0 / 98.99741751876255
# XYZ to linear sRGB (ITU-R BT.709 primaries, D65 white): Mitsuba's xyz_to_srgb, float32 literals.
XYZ_TO_SRGB = _float32_table("""3.240479 -1.537150 -0.498535
                                -0.969256 1.875991 0.041556
                                0.055648 -0.204043 1.057311""").reshape(3, 3)
# A uniform emission's colour per unit: xyz_to_srgb(1, 1, 1), an equal-energy spectrum's XYZ in sRGB.
UNIFORM_EMISSION = XYZ_TO_SRGB.sum(axis=1)

# spectrum_list_to_srgb's quadrature: 1000 points from 360 to 830 nm inclusive, their sum scaled by
# (830 - 360) / 1000, not / 999: Mitsuba's Riemann sum, kept because its colours are the reference.
_STEPS = 1000
_GRID = CIE_MIN + (np.arange(_STEPS) / (_STEPS - 1)) * (CIE_MAX - CIE_MIN)


def _at(table, w):
    """Mitsuba's lookup of a 5 nm table at wavelengths `w` in [360, 830] (cie1931_xyz, cie_d65): linear
    between the two samples around each."""
    t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) / (CIE_MAX - CIE_MIN))
    i0 = np.clip(t.astype(np.int64), 0, CIE_SAMPLES - 2)
    w1 = t - i0
    return (1 - w1) * table[..., i0] + w1 * table[..., i0 + 1]


def checked_pairs(spectrum):
    """`spectrum`'s (wavelength, value) pairs as an (n, 2) float64 array, or ValueError: Mitsuba's own checks
    (at least 2 pairs, strictly ascending wavelengths) and finite numbers."""
    try:
        pairs = np.asarray(spectrum, np.float64)
    except (TypeError, ValueError):
        raise ValueError("must be (wavelength, value) pairs of numbers") from None
    if pairs.size == 0:  # [] holds too few pairs rather than malformed ones
        pairs = pairs.reshape(0, 2)
    if pairs.ndim != 2 or pairs.shape[1] != 2:
        raise ValueError("must be (wavelength, value) pairs of numbers")
    if len(pairs) < 2:
        raise ValueError("needs at least 2 (wavelength, value) pairs")
    if not np.isfinite(pairs).all():
        raise ValueError("holds a NaN or infinite number")
    down = np.flatnonzero(np.diff(pairs[:, 0]) <= 0)
    if len(down):
        a, b = pairs[down[0]:down[0] + 2, 0]
        raise ValueError(f"wavelengths must ascend, and {b:g} nm follows {a:g} nm")
    return pairs


def to_rgb(spectrum, emission, unbounded=False):
    """Linear sRGB (3 floats) of a Mitsuba spectrum as its RGB variants load it: `spectrum` a number (a
    uniform spectrum) or ascending (wavelength in nm, value) pairs; `emission` for an emitter's radiance or
    irradiance, `unbounded` for a BSDF parameter Mitsuba reads unbounded (eta, k, alpha), otherwise a
    reflectance. ValueError on a malformed spectrum, or one whose colour is beyond float64."""
    with np.errstate(over="ignore", invalid="ignore"):  # values near float64's limit: refused below
        if isinstance(spectrum, (int, float, np.number)):
            rgb = float(spectrum) * UNIFORM_EMISSION if emission else np.full(3, float(spectrum))
        else:
            rgb = _list_to_rgb(checked_pairs(spectrum), emission)
            # Out of gamut: Mitsuba warns and clamps every colour at 0, and a reflectance at 1 too.
            rgb = np.maximum(rgb, 0.0) if emission or unbounded else np.clip(rgb, 0.0, 1.0)
    if not np.isfinite(rgb).all():
        raise ValueError("is NaN or infinite, or its colour is beyond float64's range")
    return tuple(float(c) for c in rgb)


def _list_to_rgb(pairs, emission):
    """spectrum_list_to_srgb before its clamp: the list, linear between its pairs and zero outside them,
    times x, y, z (and D65 unless it is an emission), summed over the grid, in sRGB."""
    wavelengths, values = pairs[:, 0], pairs[:, 1]
    # Zero outside the list's range (Mitsuba's comment says the last value repeats; its code skips them).
    w = _GRID[(_GRID >= wavelengths[0]) & (_GRID <= wavelengths[-1])]
    i = np.clip(np.searchsorted(wavelengths, w, side="right") - 1, 0, len(wavelengths) - 2)
    w0, w1 = wavelengths[i], wavelengths[i + 1]
    v = ((w - w1) * values[i] + (w0 - w) * values[i + 1]) / (w0 - w1)
    weight = _at(CIE_XYZ, w) if emission else _at(CIE_XYZ, w) * (_at(D65, w) * D65_NORMALIZATION)
    xyz = (weight * v).sum(axis=1) * ((CIE_MAX - CIE_MIN) * Y_NORMALIZATION / _STEPS)
    return XYZ_TO_SRGB @ xyz


_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def read_spd(path):
    """The (wavelength, value) pairs of a Mitsuba `.spd` file (`<spectrum filename="..."/>`): a pair of
    numbers a line; blank lines and `#` comments are skipped. Mitsuba ignores what follows a line's two
    numbers; here a third number or other text is refused, as is anything to_rgb refuses (InputError)."""
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputError(path, "file", None, f"is not text (byte {e.start})") from None
    except OSError as e:
        raise InputError(path, "file", None, f"cannot be read ({e.strerror or e})") from None
    pairs = []
    for n, line in enumerate(text.splitlines(), 1):
        fields = line.split("#")[0].split()
        if not fields:
            continue
        if len(fields) != 2 or not all(_NUMBER.fullmatch(f) for f in fields):
            raise InputError(path, f"line {n}", line.strip()[:80], "must be a wavelength and a value")
        pairs.append((float(fields[0]), float(fields[1])))
    try:
        checked_pairs(pairs)
    except ValueError as e:
        raise InputError(path, "file", None, str(e)) from None
    return pairs
