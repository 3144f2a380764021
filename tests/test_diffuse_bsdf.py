"""The diffuse BSDF's sampling (kernels/warp.cl's cosine_direction): its directions are distributed as
cos(theta) / pi about the normal, by a chi-square test (devtools/chi_square.py)."""
import numpy as np
import pytest

from raytrace.commands.stability.probe import planar

from devtools.chi_square import SIGNIFICANCE, chi_square
from path_support import SPECULAR


COSINE = """
#include "path_tracing.cl"
/* Each lane's cosine-weighted direction about nrm from u. */
__kernel void cosine(int n, __global const float *nrm, __global const float *u, __global float *wi)
{
    vec2 uu = {IN(u), IN(u + n)};
    OUT3(wi, cosine_direction(IN3(nrm), uu));
}
"""


@pytest.mark.parametrize("normal", [[0, 0, 1.0], [0, 0, -1.0], [0.48, -0.6, 0.64]])
def test_diffuse_sampling_chi_square(harness, normal):
    """The diffuse BSDF's directions (Malley's method on the concentric disk) are distributed as cos(theta) / pi
    about the normal, in the normal's frame (Duff et al.'s basis, also for a normal pointing down): a
    chi-square test over 16 x 32 cells of the sphere from 2^18 independent samples (devtools/chi_square.py),
    significance 1e-4 per case, 3 cases: a correct sampler fails once in 3000 runs. The same samples fail
    against the uniform hemisphere's density (p below 1e-10): the test sees a wrong density."""
    n = np.asarray(normal) / np.linalg.norm(normal)
    m = 1 << 18
    u = np.random.default_rng(11).uniform(0, 1, (2, m))
    wi = harness.run(COSINE, "cosine", m, [planar(np.tile(n, (m, 1))), np.ascontiguousarray(u.ravel())],
                     {"wi": 3}, **SPECULAR)["wi"].T
    t = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    t /= np.linalg.norm(t)
    local = wi @ np.stack([t, np.cross(n, t), n], axis=1)  # the directions in a frame of n (z along it)
    cosine = lambda c, phi: np.where(c > 0, c / np.pi, 0.0)  # noqa: E731
    p, statistic, total = chi_square(local, cosine)
    assert abs(total - 1) < 1e-9 and p > SIGNIFICANCE, (p, statistic)
    assert chi_square(local, lambda c, phi: np.where(c > 0, 1 / (2 * np.pi), 0.0))[0] < 1e-10
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1, atol=1e-5)
