"""The environment in the direct model (kernels/direct_lighting.cl's environment_sum; Mitsuba's direct integrator
sees constant and envmap emitters too): a constant environment over a diffuse floor under a black sphere, against
the closed form, and the environment seen where camera rays leave the scene.

Under a constant radiance L the floor's irradiance is pi L less what the sphere hides: pi L (r / d)^2 cos(beta)
wherever the sphere is wholly above the floor's horizon (the same form factor as tests/test_shape_emitters.py's
sphere light, here subtracted), so its radiance is rho L (1 - (r / d)^2 cos(beta)), averaged over each pixel's
footprint by a 6 x 6 grid. Judged per pixel by devtools/judge.py's Z-test (variances from CHUNKS independent
renders) at ALPHA = 1e-4 per scale, about 4e-4 per image, two images (the lane-width ends): 8e-4 per run. A ray
that leaves the scene shows L itself, exactly (float32 stores L's channels as given here).

Mutations tried (each failed the test named; the file was restored after each):
- direct_lighting.cl environment_sum: no shadow rays (every sample open): the floor (no darkening under the sphere);
- direct_lighting.cl environment_sum: 1 / n dropped (light_samples = 4): the floor;
- direct_lighting.cl shade: the environment not shown where a ray leaves the scene: the sky.
"""
import numpy as np

import raytrace
from devtools.judge import judge
from helpers import at_lane_ends
from reference import floor_footprint, pixel_means
from render_judging import CHUNKS, assert_judged, chunked

ALPHA = 1e-4
L = np.array([0.8, 1.0, 1.25])
RHO = np.array([0.8, 0.6, 0.4])
CENTRE, RADIUS = np.array([0.4, 0.3, 1.2]), 0.35


def floor_scene(look_at=(0.35, 0.25, 0.0)):
    """A 20 x 20 diffuse floor under a black sphere, lit by the constant environment alone (no light), seen from
    below the sphere (every pixel on the floor)."""
    return {"camera": {"position": [0.1, -0.2, 0.75], "look_at": list(look_at), "up": [0.0, 0.0, 1.0], "fov": 60.0},
            "image": {"width": 24, "height": 24},
            "render": {"shading": "direct", "light_samples": 4, "light_sampler": "random"},
            "materials": {"floor": {"colour": RHO.tolist()}, "black": {"colour": [0.0, 0.0, 0.0]}},
            "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [20.0, 20.0],
                        "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0], "material": "floor"},
                       {"type": "ellipsoid", "center": CENTRE.tolist(), "axes": (np.eye(3) * RADIUS).tolist(),
                        "material": "black"}],
            "environment": {"type": "constant", "radiance": L.tolist()}}


def floor_radiance(table):
    """rho L (1 - (r / d)^2 cos(beta)) over each pixel's footprint (a 6 x 6 grid)."""
    scene = raytrace.load_dict(table)
    p = floor_footprint(scene)[3]
    to_centre = CENTRE - p
    d2 = np.sum(to_centre ** 2, 1)
    assert np.all(to_centre[:, 2] > RADIUS)  # the sphere wholly above every point's horizon
    hidden = RADIUS ** 2 / d2 * to_centre[:, 2] / np.sqrt(d2)
    value = RHO * L * (1 - hidden)[:, None]
    return pixel_means(scene, value)


@at_lane_ends
def test_a_constant_environment_on_a_floor_in_the_direct_model(lanes):
    table = floor_scene()
    mean, var = chunked(table, lanes, 4)
    expected = floor_radiance(table)
    assert (expected / (RHO * L)).min() < 0.95  # the sphere's shadow is in view
    assert_judged(judge(mean, var, expected, np.zeros_like(var), alpha=ALPHA, dof=CHUNKS - 1, tile_alpha=ALPHA),
                  f"direct environment, lanes {lanes}")


@at_lane_ends
def test_the_sky_is_seen_where_a_ray_leaves_the_scene(lanes):
    """Looking up past the sphere: the pixels that meet nothing show L, exactly."""
    table = floor_scene(look_at=(-0.5, 0.0, 1.5))
    image = np.asarray(raytrace.render(raytrace.load_dict(table), lanes=lanes, spp=4)[0], np.float64)
    sky = np.all(np.abs(image - L.astype(np.float32)) == 0, axis=2)
    assert sky.mean() > 0.3, sky.mean()
