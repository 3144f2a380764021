"""The rough conductor (type = "roughconductor": GGX microfacets with a conductor's Fresnel,
kernels/path_tracing.cl) in the path model: its value in the lights' samples and its own visible-normal samples
estimate the same radiance. The microfacet distribution itself is tests/test_microfacet.py's."""
import numpy as np

import raytrace
from raytrace.renderer.program import Features

from helpers import ROOT, at_lane_ends
from path_support import assert_techniques_agree, traced


@at_lane_ends
def test_rough_conductor_techniques_agree(harness, cornell):
    """A rough gold conductor (alpha 0.3, Fresnel per channel) on every white surface of scene 0's direct
    variant: the BSDF's value in the lights' samples (pi F D G2 / (4 cos_o) per channel, light_sampling.cl
    summing colours) and its visible-normal samples must estimate the same radiance, alone and combined by
    MIS, within 5 standard errors of each difference: on the lit floor, and under the light, where the
    viewer above sees the light's reflection and both techniques carry weight. A wrong D, G2, Fresnel or
    density in either technique moves it away from the other (a missing factor 4 fails it, seen)."""
    text = open(cornell.path.replace("cornell.toml", "cornell_direct.toml")).read()
    text = text.replace('shading = "direct"', 'shading = "path"').replace(
        "white = { colour = [0.7, 0.7, 0.7] }", 'white = { type = "roughconductor", alpha = 0.3, colour = [1.0, 1.0, '
        "1.0], eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603] }")
    scene = raytrace.load_string(text)
    assert scene.materials[0].bsdf == "roughconductor"
    p = np.array([[-0.3, -0.5, 0.0], [0.05, 0.02, 1.6], [0.2, -0.1, 1.8]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0]])
    est = {k: traced(harness, scene, p, n, k, shaded=True) for k in (0, 1, 2)}
    mean, _ = assert_techniques_agree(est)
    assert np.all(mean[0] > 0)


def test_effectively_smooth_rough_conductor_is_the_smooth_one():
    """alpha may be any number in (0, 1]. Below 2^-63 alpha^2 is subnormal, then 0, and GGX's D(h) 0 / 0 (issue
    55: alpha 1e-30 zeroed 12 NaN values of scene 0's path variant at 16 x 16); and long before, near 1e-3,
    float32's cos^2(theta_h) no longer resolves the lobe (raytrace/renderer/packing.py's SMOOTH_ALPHA). Below
    1e-3 the rough conductor renders as the smooth one, as pbrt-v4's ConductorBxDF does where its distribution
    is EffectivelySmooth: the same image bit for bit as type = "conductor" with its eta, k and colour, and
    nothing zeroed; at 1e-3 it is the microfacet BSDF still."""
    text = open(ROOT / "scenes" / "cornell_path.toml").read()
    gold = 'colour = [1.0, 0.93, 0.6], eta = [0.143, 0.374, 1.442], k = [3.983, 2.385, 1.603]'

    def render(material):
        scene = raytrace.load_string(text.replace("yellow = { colour = [1.0, 0.93, 0.6] }",
                                                  f"yellow = {{ {material}, {gold} }}"))
        image, stats = raytrace.render(scene, width=16, height=16, spp=4, progress=False)
        return scene, np.asarray(image), stats.extra["nonfinite_values"]

    _, smooth, bad = render('type = "conductor"')
    assert bad == 0
    for alpha in (1e-45, 1e-30, 2.0 ** -63, 9.99e-4):
        scene, image, bad = render(f'type = "roughconductor", alpha = {alpha!r}')
        assert bad == 0 and np.array_equal(image, smooth), alpha
        assert not Features.of(scene, 8).rough_conductors and Features.of(scene, 8).conductors
    scene, image, bad = render('type = "roughconductor", alpha = 1e-3')
    assert bad == 0 and Features.of(scene, 8).rough_conductors and not np.array_equal(image, smooth)
