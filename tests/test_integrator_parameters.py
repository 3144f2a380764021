"""The integrators' parameters of Mitsuba's names (render.rr_depth, render.hide_emitters, render.bsdf_samples:
kernels/roulette.cl, kernels/hide_emitters.cl, kernels/path_tracing.cl's path_hit, kernels/direct_lighting.cl),
each judged on whole renders against an expectation it must not change or must change exactly:

- rr_depth changes where Russian roulette starts, not what a path estimates: a render with roulette from the
  first vertex agrees per pixel with one whose roulette never plays (rr_depth 100), and traces fewer rays
  (where roulette starts, path_support's kernel test, tests/test_path_integrator.py, checks to the bit);
- hide_emitters takes from the image exactly what the camera sees directly of the emitters (the lights, an
  emitting sphere, the environment): a render with it hidden agrees per pixel with the render without, less the
  emitters seen directly (the path model at max_depth 1, or the direct model with every albedo 0), the lights'
  light on the floor staying; and the camera sees past a hidden light what it would see without it (a wall);
  scenes/mitsuba/path_rr.xml judges the same against Mitsuba;
- bsdf_samples changes the direct model's estimate, not its expectation: light samples and BSDF samples
  combined by MIS agree per pixel with the light samples alone, under a large light close to the floor and an
  emitting sphere; the agreement with Mitsuba's direct is scenes/mitsuba/direct_bsdf.xml's.

Statistics: each judged image is the mean of CHUNKS = 16 independent renders (render_judging.py), each value's
variance from their spread, judged by devtools/judge.py per pixel and on tiles of 4 and 16 pixels and the whole
image, each scale at a false-failure rate of ALPHA = 1e-4: about 3e-4 per judged image (judge.py's docstring),
12 judged images at the two lane-width ends, 3.6e-3 per run (the seeds are fixed: a given kernel passes or
fails deterministically, and a change in how it draws its samples deals a fresh draw).

Mutations tried (each in the kernels, undone after; every one failed the tests named):
- path_tracing.cl, path_hit: the environment and emission counted with hide_emitters (the `seen` mask not
  narrowed): the path model's hidden emitters;
- render.cl: pass_emitters not called in render_paths, or in render_samples (the camera rays stop at the hidden
  light, black): the camera rays passing hidden lights;
- hide_emitters.cl: the origin moved to the hit's own side (`hit.n`, not `-hit.n`: the ray meets the light
  again until the cap, then black): the camera rays passing hidden lights;
- direct_lighting.cl: the BSDF samples' MIS weight without the counts (x = p_l / p_b, the light samples' with
  them), their light counted whole (weight 1), the emitting sphere's density left out of their x, or the light
  samples' weight without the BSDF count (bsdf_count 1): the direct model's BSDF samples (the first only on the
  whole image's bias, z about 5.2 against its threshold 4.1: a weight that drops the counts on both sides
  stays unbiased, being the power heuristic without counts).
"""
import copy
import tomllib
import warnings

import pytest

import raytrace
from devtools.judge import judge
from helpers import ROOT, at_lane_ends
from render_judging import CHUNKS, assert_judged, chunked

ALPHA = 1e-4  # devtools/judge.py's false-failure rate per scale (pixels, tiles of 4 and 16, the whole image)


def _judged(mean, var, ref, ref_var, label):
    assert_judged(judge(mean, var, ref, ref_var, alpha=ALPHA, dof=CHUNKS - 1, ref_dof=CHUNKS - 1, tile_alpha=ALPHA),
                  label)


def cornell_path(**render):
    """scenes/cornell_path.toml at 24 x 24, with `render`'s keys."""
    table = tomllib.loads((ROOT / "scenes" / "cornell_path.toml").read_text())
    table["image"] = {"width": 24, "height": 24}
    table["render"].update(render)
    return table


@at_lane_ends
def test_rr_depth_keeps_the_expectation(lanes):
    """Roulette from the first vertex (rr_depth 1) against none (rr_depth 100, beyond any path's length here:
    the paths leave the box's open side), per pixel: the same expectation. Roulette from the first vertex
    ends paths sooner: fewer rays (measured 0.37 of them, and 0.57 at the default rr_depth 5)."""
    early, early_var = chunked(cornell_path(rr_depth=1), lanes, 16)
    never, never_var = chunked(cornell_path(rr_depth=100), lanes, 16, seed=CHUNKS)
    assert never.mean() > 0.1
    _judged(early, early_var, never, never_var, f"rr_depth 1 against 100, lanes {lanes}")
    rays = [raytrace.render(raytrace.load_dict(cornell_path(rr_depth=d)), spp=16, lanes=lanes)[1].rays
            for d in (1, 5, 100)]
    assert rays[0] < 0.9 * rays[2] and rays[0] < rays[1] < rays[2], rays


def lit_floor(shading):
    """A grey floor lit by a 1 x 1 light facing down and an emitting sphere, the camera below the light's plane
    so that it sees the light's face and the sphere against nothing (the path model: a constant environment,
    which it sees too)."""
    table = {
        "camera": {"position": [0.0, -3.0, 0.7], "look_at": [0.0, 0.0, 0.5], "up": [0.0, 0.0, 1.0], "fov": 60.0},
        "image": {"width": 24, "height": 20},
        "render": {"shading": shading},
        "materials": {"grey": {"colour": [0.6, 0.55, 0.5]}},
        "lights": [{"center": [0.2, 0.0, 1.5], "size": [1.0, 1.0], "normal": [0.0, 0.0, -1.0],
                    "tangent": [1.0, 0.0, 0.0], "radiance": [5.0, 4.5, 4.0]}],
        "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [6.0, 6.0], "normal": [0.0, 0.0, 1.0],
                    "tangent": [1.0, 0.0, 0.0], "material": "grey"},
                   {"type": "ellipsoid", "center": [-1.0, 0.5, 0.6], "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]],
                    "radiance": [2.0, 3.0, 4.0]}]}
    if shading == "path":
        table["environment"] = {"type": "constant", "radiance": [0.2, 0.25, 0.3]}
    return table


def _hidden(table):
    hidden = copy.deepcopy(table)
    hidden["render"]["hide_emitters"] = True
    return hidden


def _seen_directly(table):
    """What the camera sees directly of the emitters: the path model at max_depth 1, the direct model with its
    albedos 0."""
    seen = copy.deepcopy(table)
    if table["render"]["shading"] == "path":
        seen["render"]["max_depth"] = 1
    else:
        seen["materials"]["grey"]["colour"] = [0.0, 0.0, 0.0]
    return seen


def _assert_hidden(table, lanes, label):
    shown, shown_var = chunked(table, lanes, 8)
    hidden, hidden_var = chunked(_hidden(table), lanes, 8, seed=CHUNKS)
    seen, seen_var = chunked(_seen_directly(table), lanes, 8, seed=2 * CHUNKS)
    assert seen.max() > 4.0 and hidden.max() < 1.0  # the light's face (radiance 5) was in view, and is gone
    assert hidden.mean() > 0.04  # the floor stays lit
    ref_var = shown_var + seen_var  # independent renders: their difference's variance
    # the variance of a difference with dof 15 each is conservative as one of 15 dof (Welch's would be more)
    _judged(hidden, hidden_var, shown - seen, ref_var, label)


@at_lane_ends
def test_hidden_emitters_path(lanes):
    """The path model: the lights, the emitting sphere and the environment, hidden from the camera, take from
    each pixel what the camera saw of them directly, and nothing else."""
    _assert_hidden(lit_floor("path"), lanes, f"path, hidden emitters, lanes {lanes}")


@at_lane_ends
def test_hidden_emitters_direct(lanes):
    """The direct model: the same with the light and the emitting sphere (no environment)."""
    _assert_hidden(lit_floor("direct"), lanes, f"direct, hidden emitters, lanes {lanes}")


def wall_behind_a_light(shading, front=True):
    """A grey wall lit from above by a 3 x 1 light facing down, and, with `front`, a light between the camera and
    the wall facing the camera, its black back to the wall: it lights nothing the camera sees (the wall is
    behind it) and shadows nothing (the wall's segments to the light above never reach its plane, y = -1)."""
    lights = [{"center": [0.0, 0.5, 3.0], "size": [3.0, 1.0], "normal": [0.0, 0.0, -1.0], "tangent": [1.0, 0.0, 0.0],
               "radiance": [12.0, 12.0, 12.0]}]
    if front:
        lights.append({"center": [0.2, -1.0, 1.0], "size": [0.8, 0.6], "normal": [0.0, -1.0, 0.0],
                       "tangent": [1.0, 0.0, 0.0], "radiance": [5.0, 4.5, 4.0]})
    return {"camera": {"position": [0.0, -4.0, 1.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0], "fov": 40.0},
            "image": {"width": 24, "height": 20}, "render": {"shading": shading, "hide_emitters": True},
            "materials": {"grey": {"colour": [0.6, 0.55, 0.5]}}, "lights": lights,
            "shapes": [{"type": "rectangle", "center": [0.0, 2.0, 1.0], "size": [4.0, 2.0],
                        "normal": [0.0, -1.0, 0.0], "tangent": [1.0, 0.0, 0.0], "material": "grey"}]}


@at_lane_ends
def test_camera_rays_pass_hidden_lights(lanes):
    """With hide_emitters, the camera sees past a light in front of a wall (hide_emitters.cl): the image is the
    one without that light, per pixel, in both radiometric models. A camera ray that stops at the hidden light
    (black) fails it."""
    for shading in ("direct", "path"):
        hidden, hidden_var = chunked(wall_behind_a_light(shading), lanes, 8)
        without, without_var = chunked(wall_behind_a_light(shading, front=False), lanes, 8, seed=CHUNKS)
        assert without.mean() > 0.05
        _judged(hidden, hidden_var, without, without_var, f"{shading}, past a hidden light, lanes {lanes}")


@at_lane_ends
def test_a_hidden_light_keeps_the_far_clip_of_the_rays_beside_it(lanes):
    """With hide_emitters and a far clip plane between the hidden light and the wall (the wall 6 along the view,
    the plane at 5.5), a camera ray that passes the light goes on without its far clip (Mitsuba's spawn_ray drops
    maxt) and sees the wall, while every other keeps its plane and sees nothing: black, exactly, wherever the
    light is not seen (the pixels the unhidden light's render leaves black). Tracing a packet's other lanes
    again without their plane, where one lane passes the light, fails it (seen: the review found it)."""
    for shading in ("direct", "path"):
        table = wall_behind_a_light(shading)
        table["camera"]["far_clip"] = 5.5
        hidden = raytrace.render(raytrace.load_dict(table), spp=4, lanes=lanes)[0]
        table["render"]["hide_emitters"] = False
        seen = raytrace.render(raytrace.load_dict(table), spp=4, lanes=lanes)[0]
        light = (seen > 0).any(axis=2)
        assert 0 < light.mean() < 0.5
        assert (hidden[~light] == 0).all(), shading
        assert hidden[light].mean() > 0.01, shading


def close_light(bsdf_samples):
    """The direct model under a 2 x 2 light 0.25 above the floor (whose light samples peak at 1 / r^2 close to
    it) and a bright emitting sphere low beside it, the camera over both; 1 light sample per light (counts
    unequal to the BSDF's 4, so that a weight that leaves a count out on one side only shows)."""
    table = lit_floor("direct")
    table["camera"] = {"position": [0.0, -2.5, 2.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                       "fov": 60.0}
    table["lights"][0].update(center=[0.5, 0.3, 0.25], size=[2.0, 2.0])
    table["shapes"][1].update(center=[-1.0, -0.3, 0.5], axes=[[0.4, 0, 0], [0, 0.4, 0], [0, 0, 0.4]],
                              radiance=[4.0, 6.0, 8.0])
    table["render"].update(light_samples=1, bsdf_samples=bsdf_samples, sampler="random", light_sampler="random")
    return table


@at_lane_ends
def test_bsdf_samples_keep_the_expectation(lanes):
    """The direct model with 4 BSDF samples beside 1 light sample per light, against the light samples alone:
    the same image in expectation, per pixel; and less noise (the sum of the variances lower), the large light
    being close."""
    mis, mis_var = chunked(close_light(4), lanes, 16)
    alone, alone_var = chunked(close_light(0), lanes, 16, seed=CHUNKS)
    assert alone.mean() > 0.1
    _judged(mis, mis_var, alone, alone_var, f"direct, 4 BSDF samples against 1 light sample, lanes {lanes}")
    assert mis_var.sum() < alone_var.sum(), (mis_var.sum(), alone_var.sum())


def test_counts_and_depths_rebuild_nothing():
    """rr_depth, hide_emitters and a nonzero bsdf_samples are values of the run (RenderParams): an edit of them
    (raytrace.parameters) changes no build option; only the direct model's BSDF samples turned on or off does
    (HAS_BSDF_SAMPLING), and the packed values follow the edits."""
    from raytrace.parameters import FeaturesChanged
    from raytrace.renderer.packing import params_struct
    scene = raytrace.load_dict(cornell_path())
    params = raytrace.parameters(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FeaturesChanged)
        params["render.rr_depth"] = 2
        params["render.hide_emitters"] = True
        params.update()
    packed = params_struct(scene)
    assert (scene.rr_depth, scene.hide_emitters) == (2, True)
    assert (packed["rr_depth"], packed["hide_emitters"]) == (2, 1)
    direct = raytrace.load_dict(close_light(1))
    params = raytrace.parameters(direct)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FeaturesChanged)
        params["render.bsdf_samples"] = 3
        params.update()
    assert params_struct(direct)["bsdf_samples"] == 3
    params["render.bsdf_samples"] = 0
    with pytest.warns(FeaturesChanged):
        params.update()
