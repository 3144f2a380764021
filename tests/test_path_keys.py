"""The path model's keys and options, as a scene file and render() take them: max_depth, shading, a light's
material, the BSDFs' types and parameters, and the environment; each bad value is refused in one line naming
the key and the value."""
import re

import pytest

import raytrace
from raytrace.errors import InputError


@pytest.mark.parametrize("change, message", [
    (dict(max_depth=-2), "render(): max_depth = -2: must be an integer in [-1, 1024]"),
    (dict(max_depth=1.5), "render(): max_depth = 1.5"),
    (dict(max_depth=3, shading="direct"), 'render.max_depth = 3: is the path model\'s: only with shading = "path", '
                                          'not "direct"'),
])
def test_bad_render_options_are_one_line(cornell, change, message):
    """A bad option's own value names the option (render(): max_depth); a rule it breaks with the scene's
    values names the scene's value, where it was written (scene/rules.py)."""
    path = cornell.path.replace("cornell.toml", "cornell_direct.toml")
    scene = raytrace.load_file(path)
    with pytest.raises(InputError) as e:
        raytrace.render(scene, **{"shading": "path", "width": 8, "height": 8, **change})
    expected = message if message.startswith("render()") else f"{path}: {message}"
    assert str(e.value).startswith(expected) and "\n" not in str(e.value)


def test_bad_scene_keys_are_one_line():
    table = lambda **render: {  # noqa: E731
        "camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
        "image": {"width": 8, "height": 8}, "render": render, "materials": {"grey": {"colour": [0.5] * 3}},
        "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                    "radiance": 1.0, "material": "grey"}]}
    cases = [(dict(shading="path", max_depth=-3), "render.max_depth = -3: must be"),
             (dict(shading="path", max_depth=2000), "render.max_depth = 2000: must be"),
             (dict(shading="direct"), "lights[0].material = 'grey': is the path model's: only with shading"),
             (dict(shading="direct", max_depth=3), "render.max_depth = 3: is the path model's")]
    for render, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict(table(**render))
    bad = table(shading="path")
    bad["lights"][0]["material"] = "gold"
    with pytest.raises(InputError, match=re.escape("lights[0].material = 'gold': no such material")):
        raytrace.load_dict(bad)
    scene = raytrace.load_dict(table(shading="path", max_depth=4))
    assert scene.max_depth == 4 and scene.lights[0].material == 0


def test_bsdf_keys_are_checked():
    base = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "render": {"shading": "path"},
            "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                        "radiance": 1.0}]}
    cases = [({"type": "glass"}, "materials.m.type = 'glass': must be one of: diffuse, conductor, dielectric, "
                                 "roughconductor, thindielectric, roughdielectric, plastic, roughplastic"),
             ({"type": "dielectric", "int_ior": 0.0}, "materials.m.int_ior = 0.0: must be > 0"),
             ({"type": "dielectric", "ext_ior": -1.0}, "materials.m.ext_ior = -1.0"),
             ({"type": "dielectric", "eta": 1.5}, "materials.m.eta = 1.5: is not a parameter of type = \"dielectric\""),
             ({"type": "conductor", "k": [1.0, -2.0, 1.0]}, "materials.m.k = [1.0, -2.0, 1.0]"),
             ({"colour": [1, 1, 1], "int_ior": 1.3}, "materials.m.int_ior = 1.3: is not a parameter"),
             ({"type": "roughconductor", "alpha": 0.0}, "materials.m.alpha = 0.0: must be > 0"),
             ({"type": "roughconductor", "alpha": 1.5}, "materials.m.alpha = 1.5"),
             ({"type": "conductor", "alpha": 0.3}, "materials.m.alpha = 0.3: is not a parameter of type = \"conductor\"")]
    for material, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict({**base, "materials": {"m": material}})
    direct = {**base, "render": {"shading": "direct"}, "materials": {"m": {"type": "conductor"}}}
    with pytest.raises(InputError, match=re.escape("materials.m.type = 'conductor': is the path model's")):
        raytrace.load_dict(direct)
    scene = raytrace.load_dict({**base, "materials": {"m": {"type": "conductor", "eta": 0.2, "k": [3.0, 3.5, 4.0]}}})
    assert scene.materials[0].eta == (0.2, 0.2, 0.2) and scene.materials[0].k == (3.0, 3.5, 4.0)


def test_environment_keys_are_checked():
    base = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov": 45.0},
            "image": {"width": 8, "height": 8}, "materials": {"m": {"colour": [0.5] * 3}},
            "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                        "radiance": 1.0}]}
    cases = [({"shading": "path"}, {"type": "sky", "radiance": 1.0}, "environment.type = 'sky': must be one of"),
             ({"shading": "path"}, {"type": "constant", "radiance": -1.0}, "environment.radiance = -1.0"),
             ({"shading": "path"}, {"type": "constant"}, "environment.radiance"),
             ({"shading": "path"}, {"type": "constant", "radiance": 1.0, "scale": 2}, "environment.scale")]
    for render, environment, message in cases:
        with pytest.raises(InputError, match=re.escape(message)):
            raytrace.load_dict({**base, "render": render, "environment": environment})
    scene = raytrace.load_dict({**base, "render": {"shading": "path"},
                                "environment": {"type": "constant", "radiance": [0.1, 0.2, 0.3]}})
    assert scene.environment.tolist() == [0.1, 0.2, 0.3]
    assert raytrace.load_dict({**base, "render": {"shading": "direct"}, "environment": {
        "type": "constant", "radiance": 1.0}}).environment.tolist() == [1.0] * 3  # Mitsuba's direct sees it too
    phong = {**base, "lights": [{**base["lights"][0], "colour": [1.0] * 3}], "environment": {
        "type": "constant", "radiance": 1.0}}
    del phong["lights"][0]["radiance"]
    with pytest.raises(InputError, match=re.escape("environment = [1.0, 1.0, 1.0]: is the radiometric models'")):
        raytrace.load_dict(phong)
