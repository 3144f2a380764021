"""The constant environment (environment = {type = "constant"}) in the path model: a furnace in which a convex
object sees only the environment, and the three estimators agreeing with the environment seen through scene
0's open room. The environment map is tests/test_environment_map.py's."""
import numpy as np
import pytest

import raytrace

from helpers import at_lane_ends
from path_support import assert_mean, assert_techniques_agree, environment_scene, traced


@pytest.mark.parametrize("material, expected", [
    ({"colour": [1.0, 1.0, 1.0]}, 1.0), ({"colour": [0.5, 0.5, 0.5]}, 0.5), ({"type": "conductor"}, 1.0),
    ({"type": "dielectric"}, 1.0), ({"type": "dielectric", "int_ior": 2.4}, 1.0)])
def test_environment_furnace(material, expected):
    """A convex object sees only the environment: in a constant radiance L it leaves rho L (a diffuse albedo
    rho, one bounce) and L through or off lossless glass and a perfect mirror: a white sphere vanishes. The
    environment is reached both by its own cosine-distributed samples and by the BSDF's rays that escape,
    weighted by MIS: a weight of 1 for either fails it (seen). The middle 24 x 24 pixels lie on the sphere;
    the background is L exactly."""
    image, stats = raytrace.render(environment_scene(material, 2.0), spp=64, light_samples=1)
    assert "-DHAS_ENVIRONMENT=1" in stats.build_options and stats.extra["nonfinite_values"] == 0
    assert np.all(np.asarray(image)[:3, :3] == 2.0)
    assert_mean(np.asarray(image)[20:44, 20:44], 2.0 * expected)


def test_lights_only_an_environment_may_replace():
    """No light is a scene lit by its environment alone (the furnace above has none); without an environment
    it is one line naming the lights, from a file's table and from a model changed in Python alike."""
    table = {"camera": {"position": [0, -3, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40.0},
             "image": {"width": 4, "height": 4}, "render": {"shading": "path"}, "materials": {"m": {"colour": [1] * 3}},
             "lights": []}
    problem = ('must hold one or more lights: only a scene with an [environment], [[emitters]] or a shape with '
               'radiance (shading = "direct" or "path") needs none')
    with pytest.raises(raytrace.InputError) as error:
        raytrace.load_dict(table)
    assert str(error.value) == f"load_dict(): lights = []: {problem}"
    scene = environment_scene({"colour": [0.5] * 3})
    scene.environment = None
    with pytest.raises(raytrace.InputError, match=r"lights = \[\]: must hold one or more lights"):
        raytrace.render(scene, spp=1)


@at_lane_ends
def test_environment_techniques_agree(harness, cornell):
    """The environment seen through the open front of scene 0's room: sampling lights and environment alone,
    the BSDF alone, and MIS agree at a floor point near the opening, one deep in the room, and one on a
    rough gold wall, within 5 standard errors of each difference."""
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    text = text.replace('shading = "direct"', 'shading = "path"').replace(
        "red = { colour = [0.8, 0.0, 0.0] }", 'red = { type = "roughconductor", alpha = 0.4, colour = [1.0, 1.0, '
        "1.0], eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603] }")
    text += '\n[environment]\ntype = "constant"\nradiance = [0.5, 0.8, 1.2]\n'
    scene = raytrace.load_string(text)
    p = np.array([[0.2, -0.9, 0.0], [-0.4, 0.6, 0.0], [-0.999, -0.5, 0.8]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [1.0, 0, 0]])
    est = {k: traced(harness, scene, p, n, k, shaded=True) for k in (0, 1, 2)}
    mean, _ = assert_techniques_agree(est)
    assert np.all(mean[0] > 0)
