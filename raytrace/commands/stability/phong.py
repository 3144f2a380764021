"""Case 6, phong_power: the specular power at high shininess."""
import numpy as np

from ...numerics import U, f32
from .common import TINY, Row, nonfinite


# ---------------------------------------------------------------------------------------------------------
# 6. The specular power at high shininess

POWER = """
#include "shading.cl"
__kernel void power(int n, __global const float *x, float shininess, __global float *out)
{
    OUT(out, phong_power(IN(x), (vfloat)(shininess)));
}
"""


def phong_power(env):
    """phong_power(x, n) = exp2(n log2 x) for x in [0, 1]: x = 1 - k 2^-24, k = 0 .. 1000 (the float32
    values just below 1, where highlights peak), x = 1 - 10^-j for j uniform in [0, 7], uniform x, and 0;
    shininess n = 1, 1e2, 1e3, 1e4; against x^n in float64.

    The kernel's own vlog2 and vexp2 (kernels/vmath.h, where their bounds are argued): log2 x within 11u
    of log2 x, the product one more u, exp2 within 3u of its result. exp2 turns an absolute error e of its
    argument z = n log2 x into a relative error ln2 e, so the relative error is at most ln2 |z| 12u + 3u <=
    12u k, k = 1 + ln2 n |log2 x| (the power's condition number; second order terms stay under 1e-3 of it): a
    few u near x = 1. Where x^n is below the normal range (2^-126) only its size is defined: the result must
    lie in [0, 2^-125]; and x = 0 gives exactly 0, never NaN (log2 0 = -inf, n (-inf) = -inf, exp2(-inf) =
    0)."""
    rng = np.random.default_rng(6)
    x = f32(np.concatenate([1 - np.arange(1001) * U, 1 - 10 ** -rng.uniform(0, 7, 523), rng.uniform(0, 1, 523),
                            [0.0]]))
    rows, tiny_wrong = [], 0
    for n in (1.0, 1e2, 1e3, 1e4):
        out = env.probe.run(POWER, "power", len(x), [x.astype(np.float32), np.float32(n)], {"out": 1})["out"]
        ref = x**n
        normal = ref >= TINY
        k = 1 + np.log(2) * n * np.abs(np.log2(x[normal]))
        tiny_wrong += int(np.count_nonzero(~((out[~normal] >= 0) & (out[~normal] <= 2 * TINY))))
        tiny_wrong += int(np.count_nonzero(out[x == 0] != 0))
        rows.append(Row(f"phong_power(x, {n:g}) against x^n: relative error (of {np.count_nonzero(normal)} x)",
                        float(np.max(np.abs(out[normal] - ref[normal]) / ref[normal] / (U * k))), "u k", 12,
                        "log2 11u, product u, exp2 3u; k = 1 + ln2 n |log2 x|", nonfinite(out)))
    rows.append(Row("x = 0 not giving 0; x^n below 2^-126 giving more than 2^-125", tiny_wrong, "values", 0,
                    "exp2(-inf) = 0; below 2^-126 only the size counts"))
    return rows
