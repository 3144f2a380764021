"""One rule for every value that reaches float32 (raytrace/scene/ranges.py): a value beyond float32, or one
whose derived quantities would overflow it (the scene's extent, areas, unit-sphere coordinates, the brightest
pixel and its square), is an error naming the file, the key and the value; values inside the range render
finite images. And one set of limits for image sizes and sample counts, reported where the value came from."""
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from helpers import CORNELL, run
from raytrace.errors import InputError
from raytrace.render import render_progressive
from raytrace.scene import parse_scene
from raytrace.scene.ranges import BRIGHTEST_LIMIT, COORDINATE_LIMIT

SMALL = dict(width=16, height=16, spp=4, light_samples=4, progress=False)


def cornell_table():
    with open(CORNELL, "rb") as f:
        return tomllib.load(f)


def refused(edit):
    table = cornell_table()
    edit(table)
    with pytest.raises(InputError) as info:
        parse_scene(table, "hostile.toml")
    return info.value


def accepted(edit):
    table = cornell_table()
    edit(table)
    return parse_scene(table, "hostile.toml")


BEYOND_FLOAT32 = [  # the issue's item 13, and item 1's rectangle and ellipsoid
    ("camera.position", lambda t: t["camera"].update(position=[0, -1e39, 1])),
    ("camera.focal_length", lambda t: t["camera"].update(focal_length=1e39)),
    ("lights[0].center", lambda t: t["lights"][0].update(center=[0, 0, 1e39])),
    ("lights[0].size", lambda t: t["lights"][0].update(size=[1e39, 1])),
    ("lights[0].colour", lambda t: t["lights"][0].update(colour=[1e39, 1, 1])),
    ("materials.white.colour", lambda t: t["materials"]["white"].update(colour=[1e39, 0.7, 0.7])),
    ("materials.white.shininess", lambda t: t["materials"]["white"].update(shininess=1e39)),
    ("ambient", lambda t: t.update(ambient=[1e39, 0, 0])),
    ("shapes[0].size", lambda t: t["shapes"][0].update(size=[1e39, 1e39])),
    ("shapes[6].center", lambda t: t["shapes"][6].update(center=[1e39, 0, 0])),
    ("shapes[5].vertices", lambda t: t["shapes"][5].update(vertices=[[-1e39, 0, 0], [1, 0, 0], [0, 1, 0]])),
]


@pytest.mark.parametrize("key,edit", BEYOND_FLOAT32, ids=[k for k, _ in BEYOND_FLOAT32])
def test_values_beyond_float32_are_refused(key, edit):
    error = refused(edit)
    assert (error.source, error.key) == ("hostile.toml", key) and "float32" in error.problem


DERIVED = [  # finite float32 values whose derived quantities overflow
    ("shapes[0].size", "2^60", lambda t: t["shapes"][0].update(size=[1e30, 1e30])),  # item 1: the BVH's bins
    ("shapes[6].center", "2^60", lambda t: t["shapes"][6].update(center=[3e18, 0, 0])),
    ("camera.position", "2^60", lambda t: t["camera"].update(position=[0, -2e18, 1])),
    ("lights[0].size", "normal float32", lambda t: t["lights"][0].update(size=[1e-20, 1e-20])),  # area 1e-40
    ("shapes[0].size", "normal float32", lambda t: t["shapes"][0].update(size=[1e-45, 2])),
    ("shapes[6].axes", "2^-60", lambda t: t["shapes"][6].update(axes=[[1e-19, 0, 0], [0, 1, 0], [0, 0, 1]])),
    ("ambient", "2^62", lambda t: t.update(ambient=[3e38, 3e38, 3e38])),  # the 2415 non-finite values
    ("lights[0].colour", "2^62", lambda t: t["lights"][0].update(colour=[3e38, 3e38, 3e38])),
    ("materials.white.colour", "2^62", lambda t: t["materials"]["white"].update(colour=[1e30, 1, 1])),
]


@pytest.mark.parametrize("key,limit,edit", DERIVED, ids=[f"{k}-{lim}" for k, lim, _ in DERIVED])
def test_derived_overflow_is_refused(key, limit, edit):
    error = refused(edit)
    assert (error.source, error.key) == ("hostile.toml", key) and limit in error.problem


def test_values_at_the_limits_render_finite_images():
    """Just inside every rule at once: the brightest pixel at 2^62 (its square in the variance image, 2^124,
    still a float32), the camera 2^59 away on its axis, an ellipsoid's semi-axis at 2^-60 of that extent:
    rc 0 with no value made finite by the renderer's last-resort zeroing (nonfinite_values 0)."""
    def edit(t):
        t["ambient"] = [BRIGHTEST_LIMIT * 0.99] * 3
        t["lights"][0]["colour"] = [1.0, 1.0, 1.0]
        t["camera"]["position"] = [0.0, -COORDINATE_LIMIT / 2, 1.0]
        t["camera"]["fov"] = 1e-15
        axis = COORDINATE_LIMIT / 2 * 2.0 ** -60 * 1.01
        t["shapes"][6]["axes"] = [[axis, 0, 0], [0, axis, 0], [0, 0, axis]]
    image, variance, stats = render_progressive(accepted(edit), **SMALL)
    assert np.isfinite(image).all() and np.isfinite(variance).all()
    assert stats.extra["nonfinite_values"] == 0 and image.max() > 1e17


def test_focal_length_cancels_at_any_float32_value(cornell):
    """The issue's item 13: focal lengths of 1e30 and 1e-30 gave black images, though the image plane grows
    with f and the ray directions do not change. Packed as 1, every f gives scene 0's image bit for bit."""
    reference, _ = render_progressive(cornell, **SMALL)[::2]
    for f in (1e30, 1e-30, 1e-45, 3e38):
        image, _ = render_progressive(accepted(lambda t: t["camera"].update(focal_length=f)), **SMALL)[::2]
        np.testing.assert_array_equal(image, reference)


@pytest.mark.parametrize("key,cli,value,limit", [
    ("image.width", "--width", 16385, 16384), ("image.height", "--height", 32768, 16384),
    ("render.spp", "--spp", 65537, 65536), ("render.light_samples", "--light-samples", 1 << 17, 65536)])
def test_one_set_of_limits_named_where_the_value_came_from(tmp_path, key, cli, value, limit):
    """The issue's item 14: a scene file's width of 32768 was reported as the command line's --width, and the
    file and the command line had different limits. Now both refuse the same values, each naming itself."""
    name = key.split(".")[1]
    scene = tmp_path / "big.toml"
    text, n = re.subn(rf"^{name} = \d+", f"{name} = {value}", Path(CORNELL).read_text(), flags=re.M)
    assert n == 1
    scene.write_text(text)
    r = run("render", scene, "-o", tmp_path / "x.png")
    assert r.returncode == 2 and r.stderr.strip() == (
        f"raytrace: error: {scene}: {key} = {value}: must be an integer in [1, {limit}]"), r.stderr
    r = run("render", CORNELL, "-o", tmp_path / "x.png", cli, value)
    assert r.returncode == 2 and f"command line: {cli} = {value}: must be an integer in [1, {limit}]" in r.stderr
    assert not list(tmp_path.glob("x*"))


def write_texture(path, value):
    import OpenImageIO as oiio
    pixels = np.full((2, 2, 3), value, np.float32)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(2, 2, 3, oiio.FLOAT)) and out.write_image(pixels) and out.close()


@pytest.mark.parametrize("material,key,limit", [
    ({"texture": "t.exr"}, "texture", "2^62"),                                    # a texel of 1e20
    ({"colour": [0.0, 0.0, 0.0], "texture": "t.exr"}, "texture", "2^62"),       # the map replaces colour 0
    ({"colour": [0.5, 0.5, 0.5], "height_map": "t.exr", "height_scale": 1e3}, "height_scale", "2^60")])
def test_maps_count_in_the_derived_ranges(tmp_path, material, key, limit):
    """A float colour map's brightest texel is the material's albedo (rule 4; the map replaces the colour, as
    the kernel renders it: a colour of 0 let texels of 1e20 through, and infinities into the variance), and a
    height map's largest value times height_scale displaces points (rule 2): the error names the key that
    brings it."""
    write_texture(tmp_path / "t.exr", 1e20 if key == "texture" else 1e16)
    table = cornell_table()
    table["materials"]["white"] = material
    with pytest.raises(InputError) as info:
        parse_scene(table, str(tmp_path / "s.toml"))
    assert info.value.key == f"materials.white.{key}" and limit in info.value.problem, info.value
