"""Mitsuba's delta lights, point, spot, directional and projector (raytrace/scene/delta_lights.py,
kernels/emitters.cl's sample_delta): their samples against float64 references, and the light they cast against
closed forms, in the direct and path models.

Samples, at every lane width, from 4000 random reference points each: the point (the light's position), its
normal (from the light towards the reference point), its density (r^2; 1 for a directional light) and what
arrives per unit of 1 / density (the intensity; a spot's times its falloff, Mitsuba's linear ramp in the angle
from beam_width to cutoff_angle, and its texture; a projector's pi scale E(u, v) r^2 / (z^2 cos), E its image at
Mitsuba's perspective (u, v)) against numpy in float64. Tolerance 1e-5 relative (of the brightest value for
the radiance): each is a dozen float32 operations from float32 inputs (a few ulp, 6e-8 each), but for the spot's
falloff, whose acos amplifies cos(theta)'s error of about 1e-7 by 1 / sin(theta) <= 1 / sin(9 degrees) (the beam's
edge here), then the ramp's slope 1 / (3 degrees) = 19: 1.2e-5 of the intensity at worst, so the spot's
tolerance is 5e-5. Reference points within 1e-3 of a texture's discontinuity (a checkerboard's edges, the
projector's frame) are left out: float32's (u, v) may fall on either side.

Light, per pixel at the pixel's centre (the `center` sampler: no noise; the delta lights take no random numbers),
against the closed forms rho / pi E at the floor's point: a point light's E = I cos(theta) / r^2, a spot's the same
times its falloff and texture, a directional light's E = E0 cos(theta) (and 0 in a sphere's shadow, from a sphere
outside the view: the shadow segment reaches beyond the scene), a projector's pi scale E(u, v) cos(theta) r^2 /
(z^2 cos(theta_p)) / r^2. The direct model's light samples, and the path model's at max_depth 2 (a delta light's
MIS weight is 1: no BSDF sample reaches it). Tolerance 2e-5 relative to the image's brightest value: the camera
ray's hit on the plane and the sample's cosine and distance are a few dozen float32 operations (under 3e-6), the
spot's falloff as above; pixels whose reference value lies within 1e-3 of a discontinuity are left out.

Mutations tried (each failed the tests named, 40 of 61 for the first; the file was restored after each):
- emitters.cl sample_delta: pdf r instead of r^2 (sqrt(d2)): the samples and floors of every light but the sun;
- emitters.cl sample_delta: the spot's falloff dropped (1 inside the cone): the spot's samples and floors;
- emitters.cl sample_delta: the spot's cone test on cos_beam for cos_cutoff: the spot's samples and floors;
- emitters.cl sample_delta: the projector's 1 / cos(theta_p) dropped: the projectors' samples and floors;
- emitters.cl sample_delta: the directional light's far point 0.5 extents away, not 4: its samples; 0.25
  extents (short of the sphere): its floors (the shadow);
- direct_lighting.cl emitter_weight: cos(theta_s) dropped: every direct floor;
- path_tracing.cl emitter_weight: the delta light's MIS weight the power heuristic's: every path floor;
- packing.py delta_struct: the projector's v not turned (uv_scale[1] > 0): the checkered projector's samples
  and floors.
"""
import math

import numpy as np
import pytest

import raytrace
from helpers import at_lane_ends
from reference import camera_rays
from raytrace.errors import InputError
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

KERNEL = """
#include "emitters.cl"
__kernel void sample(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const float *ref, int emitter,
                     __global float *p, __global float *normal, __global float *pdf, __global float *radiance)
{
    Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    s.textures = ts;
    vec2 u = {(vfloat)(0.5f), (vfloat)(0.5f)};
    EmitterSample es = sample_emitter(&s, &s.emitters[emitter], IN3(ref), u, (vfloat)(0.0f) == 0.0f);
    OUT3(p, es.p);
    OUT3(normal, es.n);
    OUT(pdf, es.pdf);
    OUT3(radiance, es.radiance);
}
"""
N = 4000
RHO = np.array([0.7, 0.5, 0.3])
CHECKER = {"type": "checkerboard", "color0": [1.0, 0.8, 0.6], "color1": [0.1, 0.2, 0.3],
           "to_uv": [[3.0, 0.0, 0.0], [0.0, 3.0, 0.0]]}
# a light 3 above the floor looking down along -z, its local x along the world's +x and y along -y
DOWN = [[1.0, 0.0, 0.0, 0.2], [0.0, -1.0, 0.0, -0.1], [0.0, 0.0, -1.0, 3.0], [0.0, 0.0, 0.0, 1.0]]
SPOT = {"type": "spot", "to_world": DOWN, "intensity": [6.0, 5.0, 4.0], "cutoff_angle": 40.0, "beam_width": 25.0}
LIGHTS = {
    "point": {"type": "point", "position": [0.3, -0.2, 1.5], "intensity": [2.0, 3.0, 4.0]},
    "spot": SPOT,
    "spot_texture": {**SPOT, "texture": CHECKER},
    "directional": {"type": "directional", "direction": [0.6, 0.2, -1.0], "irradiance": [1.5, 1.0, 0.5]},
    "projector": {"type": "projector", "to_world": DOWN, "fov": 50.0, "scale": 0.8, "irradiance": CHECKER},
    "projector_constant": {"type": "projector", "to_world": DOWN, "fov": 70.0, "fov_axis": "diagonal",
                           "irradiance": [0.5, 0.4, 0.3]}}


def floor_scene(light, shading="direct", extra=()):
    """A 12 x 12 diffuse floor at z = 0 seen from above (every pixel on it) under the light."""
    render = {"shading": shading, "sampler": "center", "spp": 1, "light_sampler": "random",
              **({"max_depth": 2} if shading == "path" else {})}
    return {"camera": {"position": [0.0, 0.0, 5.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
                       "fov": 40.0},
            "image": {"width": 24, "height": 24}, "render": render,
            "materials": {"floor": {"colour": RHO.tolist()}},
            "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [12.0, 12.0],
                        "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0], "material": "floor"}, *extra],
            "emitters": [light]}


def checker(u, v):
    """CHECKER's colour at Mitsuba's (u, v) (to_uv scales both by 3), and the distance to its nearest edge."""
    s, t = 3 * u, 3 * v
    fs, ft = s - np.floor(s), t - np.floor(t)
    same = (fs > 0.5) == (ft > 0.5)
    colour = np.where(same[:, None], CHECKER["color0"], CHECKER["color1"])
    edge = np.minimum.reduce([np.abs(fs - 0.5), fs, 1 - fs, np.abs(ft - 0.5), ft, 1 - ft]) / 3
    return colour, edge


def arriving(name, ref):
    """(point, normal, density, radiance per unit of 1 / density, usable) of light LIGHTS[name] seen from the
    points ref (N x 3), in float64 (Mitsuba's sample_direction of each); `usable`: not within 1e-3 of a
    discontinuity."""
    light, n = LIGHTS[name], len(ref)
    usable = np.ones(n, bool)
    if light["type"] == "directional":
        d = np.array(light["direction"]) / np.linalg.norm(light["direction"])
        return None, np.tile(d, (n, 1)), np.ones(n), np.tile(light["irradiance"], (n, 1)), usable
    m = np.array(light.get("to_world", np.eye(4)), np.float64)
    position = np.array(light["position"]) if "position" in light else m[:3, 3]
    w = ref - position
    d2 = np.sum(w * w, 1)
    normal = w / np.sqrt(d2)[:, None]
    if light["type"] == "point":
        return position, normal, d2, np.tile(light["intensity"], (n, 1)), usable
    q = w @ np.linalg.inv(m[:3, :3]).T
    if light["type"] == "spot":
        cos = q[:, 2] / np.linalg.norm(q, axis=1)
        cutoff, beam = math.radians(light["cutoff_angle"]), math.radians(light["beam_width"])
        inside = cos > math.cos(cutoff)
        with np.errstate(divide="ignore", invalid="ignore"):  # (beam = cutoff: no ramp, its slope unused)
            ramp = (cutoff - np.arccos(np.minimum(cos, 1))) / (cutoff - beam)
        falloff = np.where(cos >= math.cos(beam), 1.0, ramp)
        falloff = np.where(inside, falloff, 0.0)
        radiance = np.array(light["intensity"]) * falloff[:, None]
        if "texture" in light:
            tan = math.tan(cutoff)
            colour, edge = checker(0.5 + 0.5 * q[:, 0] / (q[:, 2] * tan), 0.5 + 0.5 * q[:, 1] / (q[:, 2] * tan))
            radiance = radiance * colour
            usable &= ~inside | (edge > 1e-3)
        return position, normal, np.where(inside, d2, 0.0), radiance, usable
    # the projector: Mitsuba's perspective_projection, x fov, the image's aspect 1
    t = math.tan(math.radians(light["fov"]) / 2)
    if light.get("fov_axis") == "diagonal":
        t = t / math.sqrt(2)
    with np.errstate(divide="ignore", invalid="ignore"):  # (z = 0: outside, below)
        u, v = 0.5 - 0.5 * q[:, 0] / (q[:, 2] * t), 0.5 - 0.5 * q[:, 1] / (q[:, 2] * t)
    inside = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1) & (q[:, 2] > 0)
    usable &= np.minimum.reduce([np.abs(u), np.abs(1 - u), np.abs(v), np.abs(1 - v)]) > 1e-3
    cos_p = normal @ m[:3, 2]
    factor = math.pi * light.get("scale", 1.0) * d2 / (q[:, 2] ** 2 * cos_p)
    if isinstance(light["irradiance"], dict):
        colour, edge = checker(u, v)
        usable &= ~inside | (edge > 1e-3)
    else:
        colour = np.tile(light["irradiance"], (n, 1))
    radiance = np.where(inside[:, None], colour * factor[:, None], 0.0)
    return position, normal, np.where(inside, d2, 0.0), radiance, usable


@pytest.mark.parametrize("name", list(LIGHTS))
def test_a_delta_light_is_sampled_as_mitsuba_samples_it(harness, name):
    """The kernel's sample of each light from random points against arriving()'s float64."""
    table = floor_scene(LIGHTS[name], "path")
    scene = raytrace.load_dict(table)
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    assert defines["HAS_DELTA_EMITTERS"] == 1 and defines["HAS_SHAPE_EMITTERS"] == 0
    rng = np.random.default_rng(7)
    ref = (rng.random((N, 3)) * [3.6, 3.6, 2.5] - [1.8, 1.8, 0]).astype(np.float32).astype(np.float64)
    tables = scene_tables(scene, 8, 8, 1, 1, "bilinear", features=features)
    args = {**tables, **texture_tables(scene), "ref": ref.T.astype(np.float32), "emitter": np.int32(0)}
    out = harness.run(KERNEL, "sample", N, args, {"p": 3, "normal": 3, "pdf": 1, "radiance": 3}, **defines)
    p, normal, pdf, radiance, usable = arriving(name, ref)
    assert usable.mean() > 0.8
    tolerance = 5e-5 if name.startswith("spot") else 1e-5
    counted = out["pdf"] > 0
    assert np.array_equal(counted[usable], (pdf > 0)[usable]), name
    assert counted.mean() > 0.05
    if p is None:  # directional: from 4 scene extents back along the direction
        extent = float(tables["params"]["scene_extent"])
        p = ref - 4 * extent * normal
    use = usable & counted
    np.testing.assert_allclose(out["p"].T[use], np.broadcast_to(p, (N, 3))[use], rtol=0, atol=1e-6 * np.abs(p).max())
    np.testing.assert_allclose(out["normal"].T[use], normal[use], atol=1e-6)
    np.testing.assert_allclose(out["pdf"][use], pdf[use], rtol=1e-5)
    np.testing.assert_allclose(out["radiance"].T[use], radiance[use], rtol=tolerance,
                               atol=tolerance * np.abs(radiance).max())


# out of the camera's view at its height (which spans |x|, |y| < 1.27 there), its shadow in it
SHADOW_CENTRE, SHADOW_RADIUS = np.array([-2.2, -0.3, 1.5]), 0.35


def floor_expected(table, name):
    """rho / pi E at each pixel centre's floor point (float64), and which pixels are usable (arriving's)."""
    scene = raytrace.load_dict(table)
    ys, xs = np.mgrid[0:scene.height, 0:scene.width]
    o, d = camera_rays(scene, xs.ravel() + 0.5, ys.ravel() + 0.5)
    p = o + (-o[:, 2] / d[:, 2])[:, None] * d
    _, normal, pdf, radiance, usable = arriving(name, p)
    cos = -normal[:, 2]  # the floor's normal +z against the way the light arrives
    value = np.where((pdf > 0)[:, None], RHO / math.pi * radiance * np.maximum(cos, 0)[:, None]
                     / np.where(pdf > 0, pdf, 1)[:, None], 0.0)
    if name == "directional":  # the sphere's shadow, along -direction from each point
        oc = p - SHADOW_CENTRE
        h = oc @ normal[0]
        closest = np.sum(oc * oc, 1) - h * h
        shadowed = (h > 0) & (closest < SHADOW_RADIUS ** 2)
        value[shadowed] = 0.0
        usable &= np.abs(np.sqrt(closest) - SHADOW_RADIUS) > 1e-3
        assert shadowed.mean() > 0.01
    return value.reshape(scene.height, scene.width, 3), usable.reshape(scene.height, scene.width)


@at_lane_ends
@pytest.mark.parametrize("shading", ["direct", "path"])
@pytest.mark.parametrize("name", list(LIGHTS))
def test_a_delta_light_on_a_floor(lanes, shading, name):
    """The floor's radiance at each pixel's centre against floor_expected()'s closed form."""
    extra = ()
    if name == "directional":  # a sphere out of view whose shadow falls in it
        extra = ({"type": "ellipsoid", "center": SHADOW_CENTRE.tolist(),
                  "axes": (np.eye(3) * SHADOW_RADIUS).tolist(), "material": "floor"},)
    table = floor_scene(LIGHTS[name], shading, extra)
    image = np.asarray(raytrace.render(raytrace.load_dict(table), lanes=lanes)[0], np.float64)
    expected, usable = floor_expected(table, name)
    assert expected.max() > 0 and (expected[usable] == 0).mean() < 0.9
    np.testing.assert_allclose(image[usable], expected[usable], rtol=0, atol=2e-5 * expected.max())


@pytest.mark.parametrize("change, problem", [
    ({"shading": "phong"}, "is the radiometric models'"),
    ({"type": "spot", "beam_width": 30.0, "cutoff_angle": 20.0}, "must be at most cutoff_angle"),
    ({"type": "spot", "cutoff_angle": 95.0, "texture": CHECKER}, "must be below 90 with a texture"),
    ({"type": "point", "position": [0, 0, 1], "to_world": np.eye(4).tolist()}, "give either it or to_world"),
    ({"type": "directional", "colour": 1.0}, "unknown key"),
    ({"type": "point", "intensity": -1.0}, "must be >= 0"),
    ({"type": "projector", "fov": 180.0}, "must be < 180"),
    ({"type": "projector", "fov": 30.0, "focal_length": 35.0}, "give either a focal length"),
    ({"type": "spot", "to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]}, "invertible"),
    ({"type": "sun"}, "must be one of"),
])
def test_a_bad_delta_light_is_refused(change, problem):
    """One-line errors naming emitters[0] and the key."""
    light = {"type": "point", "position": [0.0, 0.0, 1.0]}
    shading = change.pop("shading", "direct")
    light.update(change)
    if light["type"] != "point":
        light.pop("position")
    table = floor_scene(light, shading)
    if shading == "phong":
        table["render"] = {"shading": "phong"}
    with pytest.raises(InputError, match=problem) as error:
        raytrace.load_dict(table)
    assert "emitters[0]" in str(error.value) and "\n" not in str(error.value)


def test_a_delta_light_built_in_python_is_checked():
    """The Python API's path into the kernel (check_model): a model value no scene file could hold is named."""
    import dataclasses
    scene = raytrace.load_dict(floor_scene(LIGHTS["spot"]))
    scene.emitters[0] = dataclasses.replace(scene.emitters[0], cutoff_angle=-5.0)
    with pytest.raises(InputError, match=r"emitters\[0\]\.cutoff_angle"):
        raytrace.render(scene)
    scene.emitters[0] = dataclasses.replace(scene.emitters[0], cutoff_angle=10.0)
    with pytest.raises(InputError, match=r"emitters\[0\]\.beam_width"):
        raytrace.render(scene)


def test_a_scene_lit_by_delta_lights_alone_needs_no_other_light():
    """A point light alone lights a scene (no [[lights]], no emitting shape): the "needs a light" rule counts it."""
    scene = raytrace.load_dict(floor_scene(LIGHTS["point"]))
    assert not scene.lights and len(scene.emitters) == 1


def test_the_power_of_a_delta_light():
    """emitter_power against the intensity integrated over the sphere of directions (a 1000 x 2000 midpoint grid in
    (cos(theta), phi) about the world's z, each cell's solid angle 4 pi / 2e6, the intensity read from
    arriving() at unit distance): a point's 4 pi I, a projector's pi scale A mean(E) (its checkerboard's edges
    cut cells: 1e-3), a spot whose beam is its cutoff (no ramp: pbrt-v4's form is then exact) 2 pi I (1 -
    cos(cutoff)); a directional light's pi r^2 E, r the bounding sphere of the floor (its half diagonal)."""
    from raytrace.scene.emitter_power import emitter_power
    from raytrace.scene.texture_lookups import luminance
    cos = -1 + (np.arange(1000) + 0.5) / 500
    phi = (np.arange(2000) + 0.5) * (2 * math.pi / 2000)
    c, p = np.meshgrid(cos, phi, indexing="ij")
    s = np.sqrt(1 - c * c)
    directions = np.stack([s * np.cos(p), s * np.sin(p), c], -1).reshape(-1, 3)
    for name, change, rtol in (("point", {}, 1e-6), ("projector", {}, 1e-3), ("spot", {"beam_width": 40.0}, 1e-3),
                               ("directional", {}, 1e-12)):
        LIGHTS[f"{name}_power"] = light = {**LIGHTS[name], **change}
        scene = raytrace.load_dict(floor_scene(light))
        if name == "directional":
            expected = math.pi * (math.sqrt(2) * 6) ** 2 * luminance(light["irradiance"])
        else:
            centre = np.array(light["position"]) if "position" in light else np.array(light["to_world"])[:3, 3]
            _, _, pdf, radiance, _ = arriving(f"{name}_power", centre + directions)
            intensity = np.where((pdf > 0)[:, None], radiance / np.where(pdf > 0, pdf, 1)[:, None], 0.0)
            expected = float(np.sum(intensity @ np.array((0.212671, 0.715160, 0.072169)))) * 4 * math.pi / len(
                directions)
        del LIGHTS[f"{name}_power"]
        assert emitter_power(scene, scene.emitters[0]) == pytest.approx(expected, rel=rtol), name


def test_the_light_selection_weighs_a_delta_light_by_its_power():
    """render.light_selection = "power" chooses among two point lights and a spot in proportion to
    emitter_power's powers (packing.py's selection); "uniform" alike."""
    from raytrace.renderer.scene_tables import scene_tables
    from raytrace.scene.emitter_power import emitter_power
    table = floor_scene(LIGHTS["point"])
    table["emitters"] += [{**LIGHTS["point"], "intensity": 6.0}, LIGHTS["spot"]]
    for selection in ("power", "uniform"):
        table["render"]["light_selection"] = selection
        scene = raytrace.load_dict(table)
        power = np.array([emitter_power(scene, e) for e in scene.emitters])
        expected = power / power.sum() if selection == "power" else np.full(3, 1 / 3)
        packed = scene_tables(scene)["emitters"]["selection_pdf"]
        np.testing.assert_allclose(packed, expected, rtol=1e-6)


@pytest.mark.parametrize("shading", ["direct", "path"])
def test_a_too_bright_delta_light_is_named(shading):
    """The brightness rules (ranges.py's rules 4 and 5) bound a delta light by its intensity, and a light beyond
    them is refused naming its key among the [[emitters]], not the floor's colour (seen before: the path model's
    check fell over on a scene lit by delta lights alone, the direct model's named the material)."""
    table = {"camera": {"position": [0.0, -3.0, 1.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                        "fov": 40.0},
             "image": {"width": 8, "height": 8}, "render": {"shading": shading},
             "materials": {"floor": {"colour": [0.5, 0.5, 0.5]}},
             "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [2.0, 2.0],
                         "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0], "material": "floor"}],
             "emitters": [{"type": "point", "position": [0.0, 0.0, 1.0], "intensity": 1e20}]}
    with pytest.raises(InputError, match=r"emitters\[0\]\.intensity = "):
        raytrace.load_dict(table)
