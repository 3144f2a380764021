"""The specular BSDFs, the perfect mirror (a smooth conductor) and clear glass (a smooth dielectric;
kernels/bsdfs/conductor.cl and dielectric.cl): mirror reflection, refraction by Snell's law with its 1 / eta^2
radiance factor, total internal reflection, the choice between reflection and refraction by Fresnel, and a
furnace through which both are lossless."""
import numpy as np
import pytest

import raytrace
from raytrace.commands.stability.probe import planar

from bsdf_support import facing
from path_support import FACES, SPECULAR, assert_mean, fresnel_reference


SCATTER = """
#include "path_tracing.cl"
/* The smooth BSDFs' sample (bsdf.cl's bsdf_sample) at a surface of normal nrm seen along wo, u choosing
 * reflection or refraction. */
__kernel void scatter(int n, __global const float *wo_, __global const float *nrm, __global const float *eta,
                      __global const float *u, __global const int *bsdf, __global const int *backface,
                      __global float *wi, __global float *weight, __global float *transmit, __global float *pdf)
{
    vec3 normal = IN3(nrm);
    ShadingPoint sp;
    sp.p = v3_splat(0.0f, 0.0f, 0.0f);
    sp.err = 0.0f;
    sp.ng = sp.n = normal;
    sp.k = v3_splat(1.0f, 1.0f, 1.0f);
    sp.bsdf = VLOAD_INT(bsdf + I * LANES);
    sp.eta = v3((vfloat)(IN(eta)), (vfloat)(0.0f), (vfloat)(0.0f));
    sp.k_imag = v3_splat(0.0f, 0.0f, 0.0f);
    sp.backface = VLOAD_INT(backface + I * LANES);
    vec2 u2 = {(vfloat)(0.5f), (vfloat)(0.5f)};
    BSDFSample bs = bsdf_sample(sp, IN3(wo_), IN(u), u2, (vint)(-1) != 0);
    OUT3(wi, bs.wi);
    OUT3(weight, bs.weight);
    OUT(transmit, SELECT((vfloat)(0.0f), (vfloat)(1.0f), bs.transmit != 0));
    OUT(pdf, SELECT(bs.pdf, (vfloat)(-1.0f), bs.delta == 0)); /* -1: not a delta lobe's */
}
"""


def test_reflection_and_refraction_directions(harness):
    """Mirror reflection about the normal, and refraction by Snell's law: the refracted direction is a unit
    vector in the plane of wo and n, on the far side, with eta sin(theta_t) = sin(theta_i); inside a shape
    (backface) the index is inverted; past the critical angle every sample reflects. The radiance of a
    refracted sample is divided by eta^2 (pbrt-v4 9.5). Float32 to a few roundings: 1e-5."""
    rng = np.random.default_rng(5)
    m = 4096
    normal, wo = facing(rng, m)  # wo on the normal's side
    eta = rng.uniform(1.1, 2.5, m)
    u = rng.uniform(0, 1, m)
    bsdf = rng.choice([1, 2], m).astype(np.int32)
    backface = rng.choice([0, -1], m).astype(np.int32)
    out = harness.run(SCATTER, "scatter", m, [planar(wo), planar(normal), eta, u, bsdf, backface],
                      {"wi": 3, "weight": 3, "transmit": 1, "pdf": 1}, **SPECULAR)
    wi, weight, transmit = out["wi"].T, out["weight"].T, out["transmit"] > 0
    cos_i = np.sum(wo * normal, axis=1)
    mirror = 2 * cos_i[:, None] * normal - wo
    reflect = ~transmit
    np.testing.assert_allclose(wi[reflect], mirror[reflect], atol=1e-5)
    assert not np.any(transmit & (bsdf == 1))
    rel = np.where(backface != 0, 1 / eta, eta)
    t = transmit
    np.testing.assert_allclose(np.linalg.norm(wi[t], axis=1), 1, atol=1e-5)
    cos_t = -np.sum(wi[t] * normal[t], axis=1)
    assert np.all(cos_t > 0)
    sin_t = np.linalg.norm(np.cross(wi[t], normal[t]), axis=1)
    np.testing.assert_allclose(rel[t] * sin_t, np.sqrt(1 - cos_i[t] ** 2), atol=1e-5)
    np.testing.assert_allclose(np.sum(np.cross(wo[t], normal[t]) * wi[t], axis=1), 0, atol=1e-5)  # coplanar
    np.testing.assert_allclose(weight[t], 1 / rel[t, None] ** 2 * np.ones((1, 3)), rtol=1e-5)
    beyond = (bsdf == 2) & ((1 - cos_i**2) / rel**2 >= 1)
    assert beyond.sum() > 100 and not np.any(transmit[beyond])
    # the choice is Fresnel's: the share of samples refracted matches 1 - F to the binomial noise
    f = fresnel_reference(cos_i, rel, 0 * rel)
    glass = bsdf == 2
    assert abs(transmit[glass].mean() - (1 - f[glass]).mean()) < 5 * np.sqrt(0.25 / glass.sum())
    # both are delta lobes, chosen with probability 1 (the mirror), F (reflection) and 1 - F (refraction)
    expected = np.where(bsdf == 1, 1.0, np.where(transmit, 1 - f, f))
    np.testing.assert_allclose(out["pdf"], expected, atol=1e-5)


@pytest.mark.parametrize("inside", [False, True])
def test_furnace_with_a_mirror_and_glass(inside):
    """A perfect mirror (conductor of material "none") and clear glass are lossless: in the furnace's uniform
    radiance L_e / (1 - rho) a camera sees that radiance through and off them too, in expectation (2.0 at
    rho = 0.5). Light reaching a wall through the glass comes only by the BSDF's rays (shadow rays stop at the
    glass), with MIS weight 1 after a specular vertex: a weight of the diffuse kind there fails it. A camera
    inside the glass (a large ellipsoid around it) sees eta^2 times that radiance, the radiance of a medium
    of index eta in the same field: the factor 1 / eta^2 of every refraction, which cancels for paths that go
    in and out again, decides it; leaving it out fails it."""
    table = {
        "camera": {"position": [0.0, -0.85 + 0.2 * inside, 0.0], "look_at": [0.0, 0.5, 0.0], "up": [0, 0, 1],
                   "fov": 70.0},
        "image": {"width": 48, "height": 48},
        "render": {"shading": "path"},
        "materials": {"grey": {"colour": [0.5] * 3}, "glass": {"type": "dielectric", "int_ior": 1.5},
                      "mirror": {"type": "conductor"}},
        "lights": [{"center": c, "size": [2.0, 2.0], "normal": [-x for x in c], "tangent": t, "radiance": 1.0,
                    "material": "grey"} for c, t in FACES],
        "shapes": [{"type": "ellipsoid", "material": "glass", "center": [-0.3, 0.3, 0.0],
                    "axes": [[0.35, 0, 0], [0, 0.3, 0], [0, 0, 0.4]]},
                   {"type": "ellipsoid", "material": "mirror", "center": [0.35, 0.4, 0.1],
                    "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]}]}
    if inside:
        table["shapes"] = [{"type": "ellipsoid", "material": "glass", "center": [0.0, -0.6, 0.0],
                            "axes": [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]]}] + table["shapes"][1:]
    image, stats = raytrace.render(raytrace.load_dict(table), spp=64, light_samples=1)
    assert "-DHAS_DIELECTRICS=1" in stats.build_options and "-DHAS_CONDUCTORS=1" in stats.build_options
    assert_mean(image, 2.0 * (1.5 / 1.000277) ** 2 if inside else 2.0)
