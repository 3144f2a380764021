"""The course's normal_map and height_map in the path model are Mitsuba's normalmap and bumpmap
(raytrace/scene/course_maps.py); the Phong and direct models keep the course's own (kernels/material.cl's
texture_material: docs/textures.md).

Equivalence is exact: a material's normal_map with its uv_scale, uv_offset and wrap renders bit for bit what the
same image given as `normalmap = { type = "bitmap", raw = true }` with the matching to_uv and wrap_mode renders, and
a height_map with height_scale what `bumpmap` with bump_scale renders (the same lookups of the same texels, through
the same kernel code), at the lane-width ends. The explicit bitmaps are given the render's filter (bilinear here)
that the course's maps follow, where a bitmap's own default is Mitsuba's bilinear. No tolerance is needed.

Mutations tried (each in a copy of the checkout; every one failed the tests named, and the copy was discarded):
- course_maps.py: the uv_offset left out of to_uv: test_normal_map_is_normalmap, test_height_map_is_bumpmap;
- course_maps.py: the material's wrap not passed (the lookup's default, repeat): test_normal_map_is_normalmap;
- course_maps.py: bump_scale left at its default 1 (not height_scale): test_height_map_is_bumpmap;
- scene_tables.py: the material table packed from the scene's materials (not kernel_materials): both equivalence
  tests (the maps' lookups missing: flat walls);
- material.cl, perturb_normal: the normal map's frame from the unbumped dp/du with both maps:
  test_both_maps_are_bumpmap_around_normalmap does not see it (both sides run the same kernel code), the float64
  reference in test_perturbed_normals.py does;
- scene_file.py: a mix of the course's and Mitsuba's maps let through: test_both_maps_are_bumpmap_around_normalmap.
"""
import numpy as np
import pytest

import raytrace
import lookup_support as mts
from helpers import ROOT, at_lane_ends
from raytrace.errors import InputError
from raytrace.renderer.program import Features

NORMALS = str(ROOT / "assets" / "textures" / "bricks_normal.png")
HEIGHTS = str(ROOT / "assets" / "textures" / "bricks_height.png")
UV = {"uv_scale": [2.0, 3.0], "uv_offset": [0.25, 0.5], "wrap": "mirror"}
TO_UV = [[2.0, 0.0, 0.25], [0.0, 3.0, 0.5]]


def scene(material, shading="path"):
    """A diffuse panel and sphere of `material`'s keys under a sky and a light, in `shading`."""
    table = mts.path_scene({"m": {"colour": [0.7, 0.6, 0.5], **material}},
                           [mts.panel("m", center=(0.0, 0.5, 0.0)),
                            {"type": "ellipsoid", "material": "m", "center": [0.4, -0.6, -0.1],
                             "axes": [[0.4, 0.0, 0.0], [0.0, 0.4, 0.0], [0.0, 0.0, 0.4]]}],
                           environment=[0.6, 0.7, 0.8])
    table["lights"] = [{"center": [0.8, -1.5, 1.2], "size": [0.6, 0.6], "normal": [-0.4, 0.7, -0.6],
                        "tangent": [1.0, 0.0, 0.0], "radiance": [5.0, 5.0, 5.0]}]
    if shading != "path":
        table["render"]["shading"] = shading
        del table["environment"]
        if shading == "phong":
            table["lights"][0]["colour"] = table["lights"][0].pop("radiance")
    return raytrace.load_dict(table)


def render(material, lanes):
    image, stats = raytrace.render(scene(material), spp=8, lanes=lanes, texture_filter="bilinear")
    return np.asarray(image), stats


@at_lane_ends
def test_normal_map_is_normalmap(lanes):
    a, stats = render({"normal_map": NORMALS, **UV}, lanes)
    b, _ = render({"normalmap": {"type": "bitmap", "filename": NORMALS, "raw": True, "to_uv": TO_UV,
                                 "wrap_mode": "mirror"}}, lanes)
    flat, _ = render({}, lanes)
    assert "-DHAS_PERTURBED_NORMALS=1" in stats.build_options and "-DHAS_NORMAL_MAPS=0" in stats.build_options
    assert np.array_equal(a, b) and not np.array_equal(a, flat)


@at_lane_ends
def test_height_map_is_bumpmap(lanes):
    a, stats = render({"height_map": HEIGHTS, "height_scale": 0.03, **UV}, lanes)
    b, _ = render({"bumpmap": {"type": "bitmap", "filename": HEIGHTS, "raw": True, "to_uv": TO_UV,
                               "wrap_mode": "mirror"}, "bump_scale": 0.03}, lanes)
    flat, _ = render({}, lanes)
    assert "-DHAS_PERTURBED_NORMALS=1" in stats.build_options and "-DHAS_HEIGHT_MAPS=0" in stats.build_options
    assert np.array_equal(a, b) and not np.array_equal(a, flat)


@pytest.mark.parametrize("shading", ["phong", "direct"])
def test_other_models_keep_the_course_maps(shading):
    """The Phong and direct models build the course's maps, not the wrappers; render()'s shading override to
    the path model turns them into the wrappers."""
    s = scene({"normal_map": NORMALS, "height_map": HEIGHTS, "height_scale": 0.03, **UV}, shading)
    options = Features.of(s, 8).options()
    assert "-DHAS_NORMAL_MAPS=1" in options and "-DHAS_HEIGHT_MAPS=1" in options
    assert "-DHAS_PERTURBED_NORMALS=0" in options and "-DHAS_LOOKUPS=0" in options
    _, stats = raytrace.render(scene({"normal_map": NORMALS, **UV}, shading), spp=1, shading="path",
                               max_depth=3, light_sampler="sobol")
    assert "-DHAS_PERTURBED_NORMALS=1" in stats.build_options and "-DHAS_NORMAL_MAPS=0" in stats.build_options


@at_lane_ends
def test_both_maps_are_bumpmap_around_normalmap(lanes):
    """Both course maps: the TOML's normalmap and bumpmap together (Mitsuba's bumpmap around a normalmap, the
    normal map in the bumped frame: test_perturbed_normals.py checks that against float64), bit for bit; a mix of
    the course's and Mitsuba's maps is refused in one line."""
    a, _ = render({"normal_map": NORMALS, "height_map": HEIGHTS, "height_scale": 0.03, **UV}, lanes)
    b, _ = render({"normalmap": {"type": "bitmap", "filename": NORMALS, "raw": True, "to_uv": TO_UV,
                                 "wrap_mode": "mirror"},
                   "bumpmap": {"type": "bitmap", "filename": HEIGHTS, "raw": True, "to_uv": TO_UV,
                               "wrap_mode": "mirror"}, "bump_scale": 0.03}, lanes)
    normal_only, _ = render({"normal_map": NORMALS, **UV}, lanes)
    assert np.array_equal(a, b) and not np.array_equal(a, normal_only)
    with pytest.raises(InputError) as info:
        scene({"normal_map": NORMALS, "bumpmap": {"type": "bitmap", "filename": HEIGHTS, "raw": True}})
    line = str(info.value)
    assert "\n" not in line and "materials.m.normal_map = " in line and "not with bumpmap" in line, line
