"""The kernel's inline log2, exp2 and 1/sqrt (kernels/vmath.h) against float64 numpy, at both lane widths.

The bounds are the ones argued in vmath.h, in u = 2^-24 (one float32 rounding); the inputs cover every binade
the shading can feed them, the values next to 1 where Phong highlights peak, and the special cases."""
import numpy as np
import pytest

from raytrace.numerics import U

TINY = 2.0**-126

VMATH = """
#include "vmath.h"
__kernel void log2_(int n, __global const float *x, __global float *out) { OUT(out, vlog2(IN(x))); }
__kernel void exp2_(int n, __global const float *z, __global float *out) { OUT(out, vexp2(IN(z))); }
__kernel void rsqrt_(int n, __global const float *x, __global float *out) { OUT(out, vrsqrt(IN(x))); }
__kernel void sin_(int n, __global const float *x, __global float *out) { vfloat s, c; vsincos_quarter(IN(x), &s, &c); OUT(out, s); }
__kernel void cos_(int n, __global const float *x, __global float *out) { vfloat s, c; vsincos_quarter(IN(x), &s, &c); OUT(out, c); }
"""


def run(harness, name, x):
    x = np.asarray(x, np.float32)
    pad = (-len(x)) % 8
    x = np.concatenate([x, np.ones(pad, np.float32)])
    return harness.run(VMATH, name, len(x), [x], {"out": 1})["out"][:len(x) - pad], x[:len(x) - pad]


def log_inputs(rng):
    """Random mantissas in every normal binade, the 2000 floats on either side of 1, the binade edges and
    sqrt(2) (where the reduction switches), 1 itself."""
    binades = 2.0 ** rng.integers(-126, 128, 20000) * rng.uniform(1, 2, 20000)
    near_one = np.concatenate([1 - np.arange(1, 2001) * U, 1 + np.arange(1, 2001) * 2 * U])
    edges = np.concatenate([2.0 ** np.arange(-126, 127), np.sqrt(2) * (1 + np.arange(-8, 9) * 2 * U), [1.0]])
    return np.concatenate([binades, near_one, edges]).astype(np.float32)


def test_log2(harness):
    """Within 11u of |log2 x| (vmath.h: 6 roundings in s, 4 more in the series, products and constant, one
    in the sum with the exponent); log2 1 = 0 exactly."""
    out, x = run(harness, "log2_", log_inputs(np.random.default_rng(1)))
    ref = np.log2(x.astype(np.float64))
    nonzero = ref != 0
    assert np.all(out[~nonzero] == 0)
    assert np.max(np.abs(out - ref)[nonzero] / np.abs(ref[nonzero])) <= 11 * U


def test_log2_special(harness):
    """0 and subnormals give -inf (so that x^n = exp2(n log2 x) is 0, never NaN)."""
    out, _ = run(harness, "log2_", [0.0, 1e-45, 1e-40, TINY / 2])
    assert np.all(out == -np.inf)


def test_exp2(harness):
    """Within 3u of 2^z for every z in [-126, 0] (vmath.h: Taylor remainder 0.12u, Horner 2-3u, 2^i exact),
    including the integers and half-integers where the reduction switches."""
    rng = np.random.default_rng(2)
    z = np.concatenate([rng.uniform(-126, 0, 20000), -10.0 ** rng.uniform(-8, 0, 4000), -np.arange(127.0),
                        -np.arange(126) - 0.5, [0.0]]).astype(np.float32)
    out, z = run(harness, "exp2_", z)
    ref = np.exp2(z.astype(np.float64))
    assert np.max(np.abs(out - ref) / ref) <= 3 * U
    assert out[z == 0][0] == 1.0


def test_sin_cos_of_a_quarter_turn(harness):
    """vsincos_quarter on [-pi/4, pi/4] (uniform, and 2000 values by factors of 2 down to 2^-60, where sin x = x
    must hold): the sine within 2u |sin x|, the cosine within 2u (vmath.h); a degree-5 Taylor sine (the Cephes
    coefficients cut short) misses the bound by far, so the test can fail."""
    rng = np.random.default_rng(7)
    x = np.concatenate([rng.uniform(-np.pi / 4, np.pi / 4, 40000), 2.0 ** -rng.uniform(1, 60, 2000),
                        [np.float32(np.pi / 4), -np.float32(np.pi / 4), 0.0]]).astype(np.float32)
    sin, x = run(harness, "sin_", x)
    cos, _ = run(harness, "cos_", x)
    x64 = x.astype(np.float64)
    assert np.all(np.abs(sin - np.sin(x64)) <= 2 * U * np.abs(np.sin(x64)))
    assert np.max(np.abs(cos - np.cos(x64))) <= 2 * U
    taylor = x64 - x64 ** 3 / 6 + x64 ** 5 / 120
    assert np.max(np.abs(taylor - np.sin(x64)) / np.maximum(np.abs(np.sin(x64)), 1e-30)) > 2 * U


def test_exp2_underflow(harness):
    """Below 2^-126 only the size is kept: in [0, 2^-125]; -inf gives exactly 0."""
    out, _ = run(harness, "exp2_", [-126.3, -126.9, -127.0, -200.0, -1e30, -np.inf])
    assert np.all((out >= 0) & (out <= 2 * TINY))
    assert out[-1] == 0


@pytest.mark.parametrize("scale", [1e-30, 1.0, 1e30])
def test_rsqrt(harness, scale):
    """Within 4u of 1/sqrt(x): three Newton steps leave 3e-11 of the first guess's error, and the last step
    rounds at most 3 times (vmath.h); over a range of magnitudes, since the first guess works on the bits."""
    x = (np.random.default_rng(3).uniform(0.25, 4, 8000) * scale).astype(np.float32)
    out, x = run(harness, "rsqrt_", x)
    ref = 1 / np.sqrt(x.astype(np.float64))
    assert np.max(np.abs(out - ref) / ref) <= 4 * U


FLOOR = """
#include "vmath.h"
__kernel void floor_(int n, __global const float *x, __global float *out) { OUT(out, vfloor(IN(x))); }
"""


def test_vfloor(harness):
    """vfloor is exactly floor: integers, halves and values next to them on both sides of 0, values from
    2^22 to 2^31 (where truncation to int would overflow), infinities; NaN stays NaN."""
    near = np.nextafter(np.float32([1, -1, 2**22, -2**22, 0.5, -0.5]), np.float32(0))
    x = np.concatenate([np.arange(-20, 20) * 0.5, near, [2.0**22 + 0.5, 2.0**23, 2.0**31, -2.0**31, 3e38, -3e38,
                                                         np.inf, -np.inf, 0.0, -0.0, 1e-45, -1e-45, np.nan]])
    x = np.concatenate([x, np.zeros((-len(x)) % 8)]).astype(np.float32)
    out = harness.run(FLOOR, "floor_", len(x), [x], {"out": 1})["out"]
    np.testing.assert_array_equal(out, np.floor(x))


def test_exp2_above_zero_is_one(harness):
    """z > 0 is outside the domain (x^n for x <= 1): taken as 0, so a rounding of r.v above 1 at a highlight
    with a huge shininess gives 1, not a wrapped exponent (a negative colour)."""
    out, _ = run(harness, "exp2_", [1e-7, 1.0, 200.0, 1e12])
    assert np.all(out == 1.0)


SCALAR = """
#include "vmath.h"
__kernel void scalar(int n, __global const float *v, __global float *out)
{
    for (int k = 0; k < LANES; ++k) {
        int i = I * LANES + k;
        float3 u = normalize3((float3)(v[i], 2.0f * v[i], 2.0f * v[i]));
        out[i] = u.x + length_of((float2)(3.0f * v[i], 4.0f * v[i])) / (5.0f * v[i]);
    }
}
"""


def test_normalize_and_length_at_every_magnitude(harness):
    """normalize3 and length_of stay exact to a few u where |v|^2 is subnormal or overflows (the builtins
    take over there): (1, 2, 2) / 3 has x = 1/3, and |(3, 4)| / 5 = 1, at 1e-30 .. 1e30."""
    v = np.float32(10.0) ** np.arange(-30, 31, 4, dtype=np.float32)
    v = np.concatenate([v, np.ones((-len(v)) % 8, np.float32)])
    out = harness.run(SCALAR, "scalar", len(v), [v], {"out": 1})["out"]
    np.testing.assert_allclose(out, 1 / 3 + 1, rtol=8 * U)


UNIT = """
#include "vmath.h"
__kernel void unit(int n, __global const float *v, __global float *out)
{
    vfloat x = IN(v);
    OUT3(out, v3_unit_or(v3(x, -2.0f * x, 2.0f * x), v3_splat(7.0f, 8.0f, 9.0f)));
    OUT(out + 3 * n, v2_length(3.0f * x, 4.0f * x) / (5.0f * x));
    OUT(out + 4 * n, v2_length(3.0f * x, 4.0f * x));
    OUT3(out + 5 * n, v3_unit_or(v3(1.0f, x, 0.0f), v3_splat(7.0f, 8.0f, 9.0f)));
    OUT3(out + 8 * n, v3_unit_or(v3(0.0f, 1.0f, x), v3_splat(7.0f, 8.0f, 9.0f)));
}
"""


def test_unit_vector_and_length_at_every_magnitude(harness):
    """v3_unit_or((1, -2, 2) x) = (1, -2, 2) / 3 for x from 1e-38 (subnormal squares) to 1e38 (overflowing
    ones): dividing by the largest coordinate (1 rounding) puts |a|^2 in [1, 3], then vrsqrt (4u) and the
    products (2u): bound 8u. 0, inf and NaN (in any coordinate) give the fallback. v2_length((3, 4) x) / 5x
    = 1 within 8u (squares and sum 3u, vrsqrt 4u, product 1u) where 25 x^2 is a normal float, 0 below, and
    2^63 (vrsqrt's 4u and a product: 5u; finite, past every mip level) where it overflows."""
    normal = np.float32(10.0) ** np.arange(-18, 19, 2, dtype=np.float32)
    tiny = np.float32([1e-38, 1e-30, 1e-20])
    odd = np.float32([0.0, np.inf, np.nan])
    v = np.concatenate([normal, tiny, np.float32([1e30, 1e38]), odd])
    v = np.concatenate([v, np.ones((-len(v)) % 8, np.float32)])
    out = harness.run(UNIT, "unit", len(v), [v], {"out": 11})["out"]
    finite = np.isfinite(v) & (v != 0)
    np.testing.assert_allclose(out[:3, finite].T, np.broadcast_to([1 / 3, -2 / 3, 2 / 3], (finite.sum(), 3)),
                               rtol=8 * U)
    assert np.all(out[:3, ~finite].T == [7, 8, 9])
    ratio = out[3, :len(normal)]
    np.testing.assert_allclose(ratio, 1, rtol=8 * U)
    assert np.all(out[3, len(normal):len(normal) + len(tiny)] == 0), "|v|^2 below the normal range: 0"
    huge = len(normal) + len(tiny)
    np.testing.assert_allclose(out[4, huge:huge + 2], 2.0 ** 63, rtol=5 * U, err_msg="|v|^2 overflows: 2^63")
    x = v.astype(np.float64)
    for rows, a in ((slice(5, 8), [np.ones_like(x), x, 0 * x]), (slice(8, 11), [0 * x, np.ones_like(x), x])):
        ok = np.isfinite(x)
        a = np.array(a)[:, ok]
        np.testing.assert_allclose(out[rows, ok], a / np.max(np.abs(a), 0) / np.linalg.norm(a / np.max(np.abs(a), 0), axis=0),
                                   rtol=8 * U, atol=8 * U)
        assert np.all(out[rows, ~ok].T == [7, 8, 9]), "a NaN or inf in one coordinate gives the fallback"
