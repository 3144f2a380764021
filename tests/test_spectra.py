"""Mitsuba 3's spectra in RGB (raytrace/scene/spectra.py) and its named materials
(raytrace/scene/named_materials.py) against Mitsuba itself: tests/data/mitsuba_spectra.json holds what
Mitsuba 3.9.1's scalar_rgb and llvm_ad_rgb variants made of each case (devtools/peers/mitsuba_spectra.py
records it; Mitsuba is not needed here), and float64 checks of properties that need no Mitsuba.

The bound on a case. Mitsuba integrates a (wavelength, value) list in float64 (Properties::Spectrum holds
doubles, so spectrum_list_to_srgb is its double instance), over the same float32 tables, and rounds the
colour to float32 once when it stores it (Color3f); a uniform emission is value * xyz_to_srgb(1, 1, 1), also
in float64, then rounded. to_rgb does the same sums in float64 in another order (numpy's pairwise sums, no
fused multiply-adds) and does not round. So the two differ by Mitsuba's one rounding, at most half a float32
ulp of its value, plus the two float64 sums' difference: 1000 terms of at most |v| * 1.78 (z bar's peak) *
1.19 (D65's, normalised), summed with an error of at most 1000 u64 times their total (u64 = 2^-53), then
scaled by 470 / 1000 / 106.75 and mixed by the matrix (rows of at most 5.3 in absolute sum): under 6e-12
|v|. The bound takes 1e-11 max(1, |v|). Observed: at most 0.5 ulp on every case and preset, as the argument
says, so a term missed (D65, the clamp, a table entry, the 1/1000 weight) fails by many ulps.
"""
import json

import numpy as np
import pytest

from helpers import ROOT
from raytrace.errors import InputError
from raytrace.scene import named_materials, spectra
from raytrace.scene.spectra import read_spd, to_rgb

RECORD = json.loads((ROOT / "tests" / "data" / "mitsuba_spectra.json").read_text())
CASES = {case["name"]: case for case in RECORD["cases"]}


def assert_mitsubas(ours, mitsuba, largest):
    """`ours` (float64) within half a float32 ulp of Mitsuba's stored `mitsuba`, plus the float64 term."""
    mitsuba = np.asarray(mitsuba, np.float64)
    bound = 0.5 * np.spacing(np.abs(mitsuba).astype(np.float32)).astype(np.float64) + 1e-11 * max(1.0, largest)
    assert np.all(np.abs(np.asarray(ours) - mitsuba) <= bound), (ours, list(mitsuba), bound)


def spectrum_of(case, tmp_path):
    if "spd" not in case:
        return case["spectrum"]
    path = tmp_path / "case.spd"
    path.write_text(case["spd"])
    return read_spd(path)


@pytest.mark.parametrize("name", CASES)
def test_each_case_is_mitsubas(name, tmp_path):
    """Uniform values and lists, short and long, regular and irregular, partly or wholly outside 360-830 nm,
    out of gamut (clamped to [0, 1] for a reflectance, at 0 otherwise), as a reflectance, a radiance, an
    irradiance and an unbounded conductor parameter, and from `.spd` files."""
    case = CASES[name]
    spectrum = spectrum_of(case, tmp_path)
    ours = to_rgb(spectrum, case["role"] == "emission", unbounded=case["role"] == "unbounded")
    assert isinstance(ours, tuple) and len(ours) == 3 and all(type(c) is float for c in ours)
    largest = abs(spectrum) if isinstance(spectrum, float) else max(abs(v) for _, v in spectrum)
    assert_mitsubas(ours, case["rgb"], largest)


def test_the_named_tables_are_mitsubas():
    """Every IOR name dielectric accepts, in Mitsuba's order, and every conductor preset with the eta and k
    Mitsuba's rgb variants use, to the float32."""
    assert list(named_materials.IORS) == list(RECORD["ior"])
    for name, value in RECORD["ior"].items():
        assert np.float32(named_materials.IORS[name]) == np.float32(value), name
    assert list(named_materials.CONDUCTORS) == list(RECORD["conductors"])
    for name, (eta, k) in RECORD["conductors"].items():
        assert np.array_equal(np.float32(named_materials.CONDUCTORS[name]), np.float32([eta, k])), name


@pytest.mark.parametrize("name", RECORD["preset_spd"])
def test_a_conductor_preset_is_its_spectra_integrated_like_an_emission(name, tmp_path):
    """The presets' numbers are what the method says they are: Mitsuba's measured spectra (Au and Cu, copied
    into the record) integrated without D65 and clamped at 0 only, as an emission is."""
    for part, rgb in zip(("eta", "k"), named_materials.CONDUCTORS[name]):
        path = tmp_path / f"{name}.{part}.spd"
        path.write_text(RECORD["preset_spd"][name][part])
        pairs = read_spd(path)
        assert_mitsubas(to_rgb(pairs, emission=True), np.float32(rgb), max(abs(v) for _, v in pairs))


def exact_white(illuminant):
    """sRGB of a flat spectrum lit by `illuminant` (sampled at the tables' knots), from the exact integral of
    the piecewise-linear tables (np.interp on a 0.005 nm grid, trapezoids: float64, no Mitsuba quadrature),
    normalised to Y = 1."""
    knots = np.linspace(spectra.CIE_MIN, spectra.CIE_MAX, spectra.CIE_SAMPLES)
    w = np.linspace(spectra.CIE_MIN, spectra.CIE_MAX, 94001)
    light = np.interp(w, knots, illuminant)
    xyz = np.array([np.trapezoid(np.interp(w, knots, bar) * light, w) for bar in spectra.CIE_XYZ])
    return spectra.XYZ_TO_SRGB @ (xyz / xyz[1])


def test_a_flat_spectrum_is_the_white_of_its_light():
    """Float64, independent of to_rgb's quadrature. A flat reflectance of 1 under D65 is sRGB's white, (1, 1, 1)
    to 1e-4 (the matrix's 7 digits and the tables'); a flat emission of 1 is the equal-energy white, which is
    also what a uniform emission is (Mitsuba's comment: so the RGB variants match the spectral ones).
    Mitsuba's sum weighs its 1000 points by 470/1000 nm where they lie 470/999 nm apart: a factor 0.999 that
    its luminance constant (its own sum of y bar) cancels for an emission, and that stays in a reflectance,
    whose D65 constant is the exact integral (its Y is 0.99989). The remaining quadrature error (the midpoint
    rule's, O(h^2) on 5 nm pieces with h = 0.47 nm) is under 1e-5."""
    assert np.allclose(exact_white(spectra.D65), 1, atol=1e-4)
    flat = [(360.0, 1.0), (830.0, 1.0)]
    assert np.allclose(to_rgb(flat, False), 0.999 * 0.99989 * exact_white(spectra.D65), rtol=1e-5)
    equal_energy = exact_white(np.ones(spectra.CIE_SAMPLES))
    assert np.allclose(to_rgb(flat, True), equal_energy, rtol=1e-5)
    # A uniform emission takes X = Y = Z; the 5 nm tables give E an X and a Z 0.8e-4 and 3.3e-4 above its Y.
    assert np.allclose(to_rgb(1.0, True), equal_energy, rtol=5e-4)


def test_linear_in_the_values_and_piecewise_linear_between_pairs():
    """Float64: an emission (unclamped while it stays in gamut) is linear in the values, and a pair inserted on
    the line between two others changes nothing, to float64's rounding (1e-12 relative)."""
    rng = np.random.default_rng(3)
    w = np.sort(rng.uniform(340, 850, 40))
    a, b = rng.uniform(0.5, 1, 40), rng.uniform(0.5, 1, 40)
    mix = to_rgb(list(zip(w, 2 * a + 3 * b)), True)
    assert np.allclose(mix, 2 * np.array(to_rgb(list(zip(w, a)), True)) + 3 * np.array(to_rgb(list(zip(w, b)), True)),
                       rtol=1e-12, atol=0)
    assert np.allclose(to_rgb(7.5, True), 7.5 * spectra.UNIFORM_EMISSION, rtol=1e-15, atol=0)
    inserted = sorted([*zip(w, a), ((w[4] + w[5]) / 2, (a[4] + a[5]) / 2)])
    assert np.allclose(to_rgb(inserted, True), to_rgb(list(zip(w, a)), True), rtol=1e-12, atol=0)


def test_read_spd(tmp_path):
    """A pair a line, as Mitsuba reads them: comments, blank lines, tabs, a leading + and .5 are fine."""
    path = tmp_path / "s.spd"
    path.write_text("# nm value\n\n400 0.1\r\n450\t0.7   # note\n  +500 .25\n600 9e-1\n")
    assert read_spd(path) == [(400.0, 0.1), (450.0, 0.7), (500.0, 0.25), (600.0, 0.9)]


@pytest.mark.parametrize("text, key", [
    ("400 0.1\n450 0.7 0.2\n", "line 2"),  # a third number (Mitsuba ignores it)
    ("400 0.1\n450, 0.7\n", "line 2"),
    ("400 0.1\nabc def\n", "line 2"),
    ("400 nan\n450 0.7\n", "line 1"),
    ("400 0.1\n", "file"),  # fewer than 2 pairs
    ("", "file"),
    ("500 0.1\n450 0.7\n", "file"),  # descending
    ("400 0.1\n400 0.7\n", "file"),
    ("400 1e999\n450 0.7\n", "file"),  # beyond float64
])
def test_read_spd_refuses(tmp_path, text, key):
    path = tmp_path / "bad.spd"
    path.write_text(text)
    with pytest.raises(InputError) as error:
        read_spd(path)
    assert (error.value.source, error.value.key) == (str(path), key)


def test_read_spd_refuses_binary_and_missing_files(tmp_path):
    path = tmp_path / "b.spd"
    path.write_bytes(b"400 0.1\n\xff\xfe\n")
    with pytest.raises(InputError, match="is not text"):
        read_spd(path)
    with pytest.raises(InputError, match="cannot be read"):
        read_spd(tmp_path / "missing.spd")


@pytest.mark.parametrize("spectrum", [[(400, 1)], [], [(500, 1), (450, 1)], [(400, 1), (400, 2)],
                                      [(400, float("nan")), (500, 1)], [(400, 1, 2), (500, 1, 2)], [400, 500],
                                      "400:1", float("inf"), [(400, 1e308), (500, 1e308)]])
def test_to_rgb_refuses_malformed_spectra(spectrum):
    """One pair, none, descending or repeated wavelengths, NaN, not pairs, infinite, or a colour beyond
    float64: ValueError, which the loader turns into a located error."""
    with pytest.raises(ValueError):
        to_rgb(spectrum, True)
