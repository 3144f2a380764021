"""The path model's ranges (raytrace/scene/ranges.py's rule 5): the throughput a path can reach (the albedo
raised to the depth, glass's squared ratio of indices) and the brightest sample it can make (with its
emitters, lights and environment, and its light samples) are bounded so that float32 sums and squares stay
finite whatever Russian roulette does, likely or not; a scene beyond is an error naming the key, from every
entry, and every scene the checks accept renders with no NaN or infinity."""
import dataclasses
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import Phase, assume, find, given, note, settings

import raytrace
from devtools.fuzz.contract import budget, write_example
from devtools.fuzz.scenes import PATH_KEYS, path_materials, path_scenes
from helpers import ROOT
from raytrace.errors import InputError
from raytrace.scene import parse_scene
from raytrace.scene.bsdfs import DECLARED
from raytrace.scene.ranges import PATH_BRIGHTEST_LIMIT, path_brightest, path_gain

CORNELL_PATH = ROOT / "scenes" / "cornell_path.toml"
SKY = str(ROOT / "assets" / "textures" / "sky.exr")
SMALL = dict(width=16, height=16, spp=4, light_samples=1, progress=False, max_pass_work=1)  # a pass per sample


def cornell_path(edit=None):
    """scenes/cornell_path.toml's table (radiance 60, albedos up to 1, unbounded depth), edited."""
    with open(CORNELL_PATH, "rb") as f:
        table = tomllib.load(f)
    if edit:
        edit(table)
    return table


def refused(edit):
    with pytest.raises(InputError) as info:
        parse_scene(cornell_path(edit), "hostile.toml")
    return info.value


def white(colour, **render):
    def edit(t):
        t["materials"]["white"]["colour"] = colour
        t["render"].update(render)
    return edit


REFUSED = [  # issue 55's item 1, each accepted before rule 5 and rendered with non-finite values zeroed
    ("environment.radiance", 1e25, "sample as bright",
     lambda t: t.update(environment={"type": "constant", "radiance": 1e25})),
    ("environment.scale", 1e25, "sample as bright",
     lambda t: t.update(environment={"type": "envmap", "filename": SKY, "scale": 1e25})),
    ("materials.white.colour", [1.5, 1.5, 1.5], "reflects more light than it receives", white([1.5, 1.5, 1.5])),
    ("materials.white.colour", [3.0, 3.0, 3.0], "throughput as large", white([3.0, 3.0, 3.0], max_depth=1024)),
    ("materials.white.colour", [1.2, 1.2, 1.2], "sample as bright", white([1.2, 1.2, 1.2], max_depth=100)),
    ("materials.yellow.int_ior", 1e20, "throughput as large",
     lambda t: t["materials"].update(yellow={"type": "dielectric", "int_ior": 1e20})),
    ("materials.yellow.ext_ior", 1e-20, "throughput as large",
     lambda t: t["materials"].update(yellow={"type": "dielectric", "ext_ior": 1e-20})),
    ("materials.yellow.int_ior", 1e20, "throughput as large",  # rough glass's refractions count as glass's
     lambda t: t["materials"].update(yellow={"type": "roughdielectric", "int_ior": 1e20})),
    ("materials.yellow.colour", [2.0, 2.0, 2.0], "throughput as large",  # nonlinear: d / (1 - d R), d R >= 1
     lambda t: (t["materials"].update(yellow={"type": "plastic", "nonlinear": True, "colour": [2.0, 2.0, 2.0]}),
                t["render"].update(max_depth=8))),
    # item 4: a path-model light's radiance was named lights[0].colour, missing
    ("lights[0].radiance", 5e18, "sample as bright", lambda t: t["lights"][0].update(radiance=5e18)),
]


@pytest.mark.parametrize("key,value,problem,edit", REFUSED, ids=[f"{k}={v}" for k, v, _, _ in REFUSED])
def test_beyond_the_path_model_s_bounds_is_refused(key, value, problem, edit):
    """One line naming the file, the key that brings the bound past 2^32 and its value as the file has it."""
    error = refused(edit)
    assert (error.source, error.key, error.value) == ("hostile.toml", key, value), error
    assert problem in error.problem and ("2^32" in error.problem or "max_depth" in error.problem), error


def test_every_entry_meets_the_path_model_s_bounds():
    """The bound holds for the final model whatever made it (scene/rules.py): a parameter edit, a model changed
    by dataclasses.replace, render()'s options (max_depth, light_samples), and so a Dask render, each naming
    the value as the scene file would."""
    scene = raytrace.load_file(CORNELL_PATH)
    params = raytrace.parameters(scene)
    params["lights[0].radiance"] = 1e25
    with pytest.raises(InputError) as info:
        params.update()
    assert info.value.key == "lights[0].radiance"
    bright = dataclasses.replace(raytrace.load_file(CORNELL_PATH), environment=np.full(3, 1e25))
    for options in ({}, {"scheduler": "local:1"}):  # refused before any Dask worker starts
        with pytest.raises(InputError) as info:
            raytrace.render(bright, **SMALL, **options)
        assert (info.value.key, info.value.value) == ("environment.radiance", [1e25] * 3)
    deep = raytrace.load_dict(cornell_path(white([1.5, 1.5, 1.5], max_depth=8)))
    with pytest.raises(InputError) as info:
        raytrace.render(deep, **{**SMALL, "spp": 1}, max_depth=-1)
    assert info.value.key == "materials.white.colour" and "max_depth = -1" in info.value.problem
    lit = raytrace.load_dict(cornell_path(lambda t: t["lights"][0].update(radiance=1e8)))
    with pytest.raises(InputError) as info:
        raytrace.render(lit, **{**SMALL, "light_samples": 1024})
    assert info.value.key == "lights[0].radiance" and "2^32" in info.value.problem


@pytest.mark.parametrize("edit", [
    lambda t: t["lights"][0].update(radiance=0.99 * PATH_BRIGHTEST_LIMIT / 1.5),  # gathers L + k L / 2, k = 1
    white([1.5, 1.5, 1.5], max_depth=40),  # G = 1.5^39 = 7e6, and B with radiance 60 just inside
    lambda t: t.update(environment={"type": "constant", "radiance": 0.99 * PATH_BRIGHTEST_LIMIT / 1.5 - 60 * 1.5})],
    ids=["radiance", "albedo-1.5-depth-40", "environment"])
def test_path_scenes_at_the_bounds_render_finite(edit):
    """Just inside rule 5 (B within 1% of 2^32, or G near it): the image and the variance of 4 passes of one
    sample are finite, with nothing zeroed (nonfinite_values 0), and as bright as the bound allows."""
    def inside(t):
        edit(t)
        if t["render"].get("max_depth", -1) == 40:
            t["lights"][0]["radiance"] = 0.99 * PATH_BRIGHTEST_LIMIT / (1.5 ** 39 * (1 + 1.5 / 2))
    scene = raytrace.load_dict(cornell_path(inside))
    assert 0.5 * PATH_BRIGHTEST_LIMIT < path_brightest(scene) <= PATH_BRIGHTEST_LIMIT
    image, stats = raytrace.render(scene, **SMALL)
    assert np.isfinite(image).all() and np.isfinite(image.variance).all()
    assert stats.extra["nonfinite_values"] == 0 and image.max() > 0


def coat(**material):
    """An edit giving cornell_path's table a material `yellow` of these keys (its sphere's material)."""
    return lambda t: t["materials"].update(yellow=material)


COATS_AND_PANES = [  # the fuzz suite's finds (issue 57's BSDFs), each accepted before rules 5 and 6 counted them
    # rule 6: eta^2 = 0 in float32, the base's (1 - F)^2 / eta^2 0 / 0 (NaN in the image)
    ("materials.yellow.int_ior", 1e-30, "relative index", coat(type="plastic", int_ior=1e-30)),
    ("materials.yellow.int_ior", 1e-30, "relative index", coat(type="roughplastic", int_ior=1e-30)),
    # rule 6: eta = 1 / 1e-45 packed as float32's inf (numpy's overflow warning, then NaN)
    ("materials.yellow.ext_ior", 1e-45, "relative index", coat(type="thindielectric", int_ior=1.0, ext_ior=1e-45)),
    # Mitsuba's fit of the coat's internal reflectance past 1: a negative base (1 - R < 0), inf at R = 1
    ("materials.yellow.int_ior", 3.9, "internal reflectance", coat(type="plastic", int_ior=3.9)),
    # the fit's excess below that, 14 at 3.8, counted in the albedo (rule 5 took the colour, 0.5)
    ("materials.yellow.int_ior", 3.8, "throughput as large", lambda t: (
        coat(type="plastic", int_ior=3.8, colour=[0.5, 0.5, 0.5])(t), t["render"].update(max_depth=30))),
    # nonlinear, colour 1.67: d / (1 - d R) is 556 d, not d (d R = 0.997; rule 5 took G = 1.67^7 = 36)
    ("materials.yellow.colour", [1.67, 1.67, 1.67], "throughput as large", lambda t: (
        coat(type="plastic", nonlinear=True, int_ior=1.5, colour=[1.67, 1.67, 1.67])(t),
        t["render"].update(max_depth=8))),
]


@pytest.mark.parametrize("key,value,problem,edit", COATS_AND_PANES,
                         ids=[f"{k}={v}-{i}" for i, (k, v, _, _) in enumerate(COATS_AND_PANES)])
def test_coats_and_panes_beyond_their_ranges_are_refused(key, value, problem, edit):
    """A plastic's or a thin dielectric's relative index within [2^-63, 2^63] (rule 6: its square and its
    reciprocal's normal float32 numbers), a linear plastic's coat whose fitted internal reflectance stays below
    1, and a plastic's albedo counted through its coat (rule 5: d T / (1 - r)): one line naming the file, the
    key and its value. Each was accepted before, and rendered with NaN values zeroed (1e-30, 1e-45), or negative
    and huge ones (3.8, 3.9: a base of 0.5 gave -18642 and 22375 at 3.85), or samples 5e8 where rule 5 allowed
    36 times the light's radiance (1.67)."""
    error = refused(edit)
    assert (error.source, error.key, error.value) == ("hostile.toml", key, value), error
    assert problem in error.problem, error


@pytest.mark.parametrize("material", [
    {"type": "plastic", "int_ior": 2.0**-62}, {"type": "roughplastic", "int_ior": 2.0**-62},
    {"type": "roughplastic", "int_ior": 2.0**62}, {"type": "thindielectric", "int_ior": 2.0**62},
    {"type": "thindielectric", "int_ior": 2.0**-62}, {"type": "plastic", "int_ior": 3.8},
    {"type": "plastic", "int_ior": 1.49, "colour": [1.0, 1.0, 1.0]}],
    ids=["plastic-2^-62", "roughplastic-2^-62", "roughplastic-2^62", "pane-2^62", "pane-2^-62", "plastic-3.8",
         "white-plastic"])
def test_coats_and_panes_within_their_ranges_render_finite(material):
    """Just inside rule 6 (eta = 2^-62 or 2^62, ext_ior 1) and the fit's R < 1 (3.8, an albedo of 14 times its
    colour at max_depth 8), and a white plastic of index 1.49 at unbounded depth (the fit's 0.1% excess is
    within FIT_SLACK, as before): accepted, and the image and variance finite with nothing zeroed."""
    def edit(t):
        coat(**material, ext_ior=1.0)(t)
        t["materials"]["white"] = dict(material, ext_ior=1.0)  # the walls too: paths bounce between coats
        if material.get("int_ior") == 3.8:
            t["render"].update(max_depth=8)
    scene = raytrace.load_dict(cornell_path(edit))
    image, stats = raytrace.render(scene, **SMALL)
    assert np.isfinite(image).all() and np.isfinite(image.variance).all()
    assert stats.extra["nonfinite_values"] == 0


def test_glass_counts_its_squared_ratio_once():
    """Through closed shapes, a path's refractions multiply its throughput by the squared ratio of the indices
    at its ends (pbrt-v4 section 9.5), so rule 5 counts glass's R^2 once, not once per vertex: scenes/
    materials.toml's glass of index 1.5 at max_depth 8 has G = 2.25."""
    scene = raytrace.load_file(ROOT / "scenes" / "materials.toml")
    assert path_gain(scene) == pytest.approx(1.5 ** 2)


def test_path_scenes_draw_every_bsdf_and_key():
    """devtools/fuzz/scenes.py's path_materials draws every BSDF of raytrace/scene/bsdfs.py with each of its keys
    (its PATH_KEYS are the declarations' keys), so that a BSDF or a parameter declared later is fuzzed or this
    fails: 600 derandomised draws meet every (type, key) (the rarest, a rough conductor's k, 12 times)."""
    assert {name: sorted(keys) for name, keys in PATH_KEYS.items()} == {b.name: sorted(b.key_names()) for b in DECLARED}
    seen = set()

    @settings(database=None, derandomize=True, max_examples=600, phases=[Phase.generate])
    @given(material=path_materials())
    def draw(material):
        seen.update((material.get("type", "diffuse"), key) for key in material)

    draw()
    assert {(name, key) for name, keys in PATH_KEYS.items() for key in keys} - seen == set()


@budget(60)
@given(example=path_scenes())
def test_accepted_path_scenes_render_finite(example):
    """Path scenes of every BSDF with values anywhere in their keys' ranges (colours, radiances, eta and k,
    alpha, the indices of refraction, an environment's radiance or scale and texels, max_depth): each one the
    checks accept renders (8 x 8, 1 to 4 samples, a pass per sample so that the variance is estimated too)
    with no NaN or infinity for the renderer to zero, in the image or the variance."""
    note(example.text())
    with tempfile.TemporaryDirectory(prefix="path-ranges-") as d:
        write_example(Path(d), example.text().encode(), example.files)
        try:
            scene = raytrace.load_file(Path(d) / "scene.toml")
        except InputError as error:
            note(str(error))
            assume(False)
        image, stats = raytrace.render(scene, progress=False, max_pass_work=1)
    assert stats.extra["nonfinite_values"] == 0
