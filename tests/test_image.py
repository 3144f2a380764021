"""Image.write (raytrace/image.py, raytrace/image_file.py) as a user of the Python API meets it, with real
files read back with OpenImageIO: what cannot be written as asked (a value that is no finite float32, a value
an .hdr cannot hold, an array that is no image, a path that is no path) is refused with one InputError that
names the argument and the value, and nothing is written; what can be written reads back as it was."""
import pathlib
import re

import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
from raytrace.image_file import write_image_file


def read(path):
    image = oiio.ImageInput.open(str(path))
    assert image is not None, oiio.geterror()
    pixels = image.read_image("float")
    image.close()
    return pixels


def names(directory):
    return sorted(p.name for p in directory.iterdir())


def refused(call, match):
    """`call` raises one InputError, of one line, matching `match` (a regular expression)."""
    with pytest.raises(raytrace.InputError, match=match) as error:
        call()
    assert "\n" not in str(error.value)
    return error.value


@pytest.mark.parametrize("ext", [".exr", ".hdr", ".png", ".tif"])
def test_values_beyond_float32_are_refused_not_written_as_inf(tmp_path, ext):
    """Issue 55, item 2: 1e39 is finite as a float64 and Inf as the float32 the file holds; the check ran before
    the cast, so the .exr held 12 Inf values (and the .hdr 12 zeros)."""
    path = tmp_path / ("x" + ext)
    error = refused(lambda: raytrace.Image.of(np.full((2, 2, 3), 1e39)).write(path),
                    r"^Image.write\(\): path = .*: the image holds 12 values that are not finite as float32")
    assert (error.key, error.value) == ("path", str(path))
    assert names(tmp_path) == []


def test_the_largest_float32_is_written(tmp_path):
    """The bound is float32's own: its largest value, as a float64, is written and read back exactly."""
    top = float(np.finfo(np.float32).max)
    raytrace.Image.of(np.full((2, 2, 3), top)).write(tmp_path / "x.exr")
    assert np.all(read(tmp_path / "x.exr") == np.float32(top))


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_one_nonfinite_pixel_is_one_line(tmp_path, value):
    """Issue 55, item 5: a NaN pixel raised ValueError, a Python exception that is no InputError."""
    pixels = np.full((3, 4, 3), 0.5, np.float32)
    pixels[1, 2, 0] = value
    refused(lambda: raytrace.Image.of(pixels).write(tmp_path / "x.png"),
            r"path = .*x.png': the image holds 1 value that is not finite as float32 .*: refusing to write it$")
    assert names(tmp_path) == []


def test_a_nonfinite_variance_is_refused_in_an_exr_only(tmp_path):
    """The variance goes into an .exr only: there it is checked; a .png without it is written."""
    image = raytrace.Image.of(np.full((2, 2, 3), 0.5, np.float32), variance=np.full((2, 2, 3), np.inf, np.float32))
    refused(lambda: image.write(tmp_path / "x.exr"), r"its variance holds 12 values that are not finite as float32")
    image.write(tmp_path / "x.png")
    assert names(tmp_path) == ["x.png"]


def test_hdr_holds_what_rgbe_can(tmp_path):
    """Issue 55, item 2: RGBE shares one exponent byte among a pixel's channels and has no sign; OpenImageIO
    wrote a pixel of 2^127 or more as 0, and a negative channel as garbage (-0.1 read back as 0.902). Values
    from 0 to just below 2^127 are written (to RGBE's 8-bit mantissa, 1/256 of the pixel's largest channel);
    the others are refused, counted, and nothing is written."""
    good = np.array([[[1.6e38, 1.0e38, 0.0], [0.5, 0.25, 0.125]]], np.float32)
    raytrace.Image.of(good).write(tmp_path / "good.hdr")
    np.testing.assert_allclose(read(tmp_path / "good.hdr"), good, rtol=1 / 128)
    for name, pixels, count in (("big.hdr", np.full((2, 2, 3), 2.0 ** 127), 12),
                                ("negative.hdr", np.array([[[0.5, -0.1, 0.25]]]), 1)):
        refused(lambda: raytrace.Image.of(pixels).write(tmp_path / name),
                rf"{name}': the image holds {count} values? an .hdr file cannot store .*: write an .exr$")
    assert names(tmp_path) == ["good.hdr"]
    raytrace.Image.of(np.array([[[0.5, -0.1, 0.25]]])).write(tmp_path / "negative.exr")  # an .exr holds them
    np.testing.assert_array_equal(read(tmp_path / "negative.exr"), np.float32([[[0.5, -0.1, 0.25]]]))


@pytest.mark.parametrize("pixels, key, shown", [
    (np.zeros(5), "image.shape", "(5,)"),
    (np.zeros((4, 4)), "image.shape", "(4, 4)"),
    (np.zeros((4, 4, 4)), "image.shape", "(4, 4, 4)"),
    (np.zeros((0, 4, 3)), "image.shape", "(0, 4, 3)"),
    (np.zeros((2, 2, 3), complex), "image.dtype", "'complex128'"),
    (np.full((2, 2, 3), "a"), "image.dtype", "'<U1'"),
], ids=["1-D", "2-D", "4-channels", "empty", "complex", "strings"])
def test_an_array_that_is_no_image(tmp_path, pixels, key, shown):
    """Issue 55, item 5: a 1-D array raised IndexError. Each is one line naming the array's shape or type."""
    refused(lambda: raytrace.Image.of(pixels).write(tmp_path / "x.exr"),
            rf"^Image.write\(\): {key} = {re.escape(shown)}: must ")
    assert names(tmp_path) == []


def test_a_path_that_is_no_str(tmp_path, monkeypatch):
    """Issue 55, item 6: bytes were shown as "b'x.exr'" and called an unknown extension. A str and an
    os.PathLike are paths; bytes, an int and None are not; a NUL character is in no file name."""
    monkeypatch.chdir(tmp_path)
    image = raytrace.Image.of(np.full((2, 2, 3), 0.5, np.float32))
    for path in (b"x.exr", 3, None):
        error = refused(lambda: image.write(path),
                        r"^Image.write\(\): path( = .*)?: must be a str or os.PathLike path$")
        assert error.value == path
    refused(lambda: image.write("a\0.exr"), r"^Image.write\(\): path = " + re.escape(repr("a\0.exr")) + ": holds a NUL")
    assert names(tmp_path) == []
    image.write("x.exr")
    image.write(pathlib.Path("y.exr"))
    assert names(tmp_path) == ["x.exr", "y.exr"]


def test_the_writer_itself_never_writes_inf(tmp_path):
    """write_image_file, which the command line calls on a render's image (always finite: the renderer zeroes
    and counts a NaN), is the last guard: ValueError, no file."""
    with pytest.raises(ValueError, match="not finite as float32"):
        write_image_file(tmp_path / "x.exr", np.full((2, 2, 3), 1e39))
    assert names(tmp_path) == []


def test_jupyter_gets_no_png_of_an_image_write_refuses():
    """_repr_png_ answers None (Jupyter shows the text) for what write() refuses, as for a wrong shape."""
    assert raytrace.Image.of(np.full((2, 2, 3), np.nan))._repr_png_() is None
    assert raytrace.Image.of(np.zeros(5))._repr_png_() is None
    assert raytrace.Image.of(np.zeros((2, 2, 3)))._repr_png_().startswith(b"\x89PNG")
