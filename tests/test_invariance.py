"""A scene's image does not depend on where it sits or on its unit of length (raytrace/scene/transform.py).

Scene 0 at 96 x 96, 4 Sobol pixel samples x 16 Sobol light samples (randomised patterns: no sample sits
exactly on an edge, so no tie can flip either way by chance), rendered as it is and scaled by s, moved by up
to 1e4 units, or both.

Scaling alone rounds every coordinate by at most 2^-24 of itself and every computed quantity scales with
it: the image changes by float32 rounding of smooth shading (each of a pixel's 64 terms <= 2, some tens of
roundings of 2^-24 each: at most 64 * 2 * 50 * 6e-8 / 64 = 6e-6 per pixel), so RMSE <= 1e-5 (measured
1.6e-7). A sample would flip only if it lay within about 2^-24 of the view of an edge, which for 590000
samples has odds of about 5%: no pixel moves by more than 1e-3 in more than 0.1% of the pixels.

Moving the scene to 1e4 units out rounds its coordinates to the float32 spacing there (about 1e-3): that is
the scene's own float32 representation, which the renderer cannot undo, so the moved scene is compared with
`stored_back` (the same rounded geometry, mapped back to the origin). What remains is the renderer's own
float32 arithmetic at that magnitude: every point it computes is resolved to about one spacing, rho, so a
pixel sample or a light sample whose ray passes within rho of a silhouette or a shadow edge may flip. At 96
pixels over the ~2.5 units in view, rho = 1e-3 is 0.04 pixels: along the ~1000 pixels of silhouettes and
shadow edges that is at most ~40 pixel samples, each moving its pixel by at most 1/spp of a radiance <= 1.6,
so their RMSE is at most sqrt(40 * 0.4^2 / (96 * 96)) = 0.026: bound 0.03. Light-sample flips are common
but small: in a penumbra about rho / (light size 0.3) = 0.3% of the shadow rays pass that close to an edge,
so a few percent of the pixels hold one, each moving its pixel by at most 2 / (spp N) = 0.03. A change of
more than 0.05 takes a pixel-sample flip or two light-sample flips in one pixel: at most 1% of the pixels.
Acne or light leaks are not flips along edges: they move whole surfaces, and the mean image value, which
must stay within 1e-3 (the fixed 2^-12 (1 + |p|) offset this replaced changed 55% of the pixels by more than
0.05 and the mean by -0.14 at 1e4 units out, and 7% to 11% of the pixels at scales 1e-3 and 1e-2; with it
15 of these 18 cases fail).

Where float32 cannot resolve the scene at all (s <= 0.1 at 1e4 units: the 2-unit room spans fewer than
2^10 float spacings), the image is a known limit, listed in docs/numerics.md."""
import numpy as np
import pytest

import raytrace
from raytrace.numerics import rmse
from raytrace.scene.transform import stored_back, transformed

OPTIONS = dict(width=96, height=96, spp=4, light_samples=16, sampler="sobol", light_sampler="sobol", progress=False)
SCALES = [1e-3, 1e-2, 1e2, 1e3, 1e4]
DIRECTIONS = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1), (1, -1, 1), (-1, 1, -1)]
MOVES = ([(1.0, 1e4 * np.array(d, float)) for d in DIRECTIONS]
         + [(s, 1e4 * np.array([1.0, -1.0, 1.0])) for s in (1e2, 1e3, 1e4)]
         + [(1e-3, np.array([1.0, -1.0, 1.0])), (1e-2, np.array([10.0, -10.0, 10.0]))])


@pytest.fixture(scope="module")
def original(cornell):
    return raytrace.render(cornell, **OPTIONS)[0]


@pytest.mark.parametrize("scale", SCALES, ids=[f"s{s:g}" for s in SCALES])
def test_scaled(cornell, original, scale):
    image = raytrace.render(transformed(cornell, scale), **OPTIONS)[0]
    assert rmse(image, original) <= 1e-5
    assert np.mean(np.abs(image - original).max(axis=-1) > 1e-3) <= 1e-3


@pytest.mark.parametrize("scale, offset", MOVES, ids=[f"s{s:g}-at{tuple(o)}" for s, o in MOVES])
def test_moved(cornell, scale, offset):
    image = raytrace.render(transformed(cornell, scale, offset), **OPTIONS)[0]
    same_geometry = raytrace.render(stored_back(cornell, scale, offset), **OPTIONS)[0]
    assert np.all(np.isfinite(image))
    assert rmse(image, same_geometry) <= 0.03
    assert abs(float(image.mean()) - float(same_geometry.mean())) <= 1e-3, "no acne, no light leak"
    assert np.mean(np.abs(image - same_geometry).max(axis=-1) > 0.05) <= 0.01
