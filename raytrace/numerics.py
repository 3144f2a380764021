"""Float32 numerics shared by the host, the tools and the tests: the unit roundoff, the rounding bound of n
operations, a value as float32 stores it, and the RMSE between images.

The kernel computes in float32. Its error bounds are counted in roundings: one rounding moves a value by at
most u of itself, n of them by at most gamma(n) = n u / (1 - n u) (Higham, "Accuracy and Stability of
Numerical Algorithms", section 3.1; pbrt-v4 section 6.8.1). kernels/ray.h's GAMMA(n) is the same bound."""
import numpy as np

def is_integer(value):
    """An int as a checked value must be: a bool, though an int in Python, is no count."""
    return isinstance(value, int) and not isinstance(value, bool)


def is_real(value):
    """An int or a float as a checked value must be (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


U = 2.0**-24  # float32 unit roundoff
FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT32_TINY = float(np.finfo(np.float32).tiny)  # the smallest normal float32
COORDINATE_LIMIT = 2.0**60  # the largest coordinate of a scene point (raytrace/scene/ranges.py says why)


def gamma(n):
    """The relative error bound of n float32 roundings."""
    return n * U / (1 - n * U)


def f32(x):
    """x as float32 stores it, back in float64."""
    return np.asarray(x, np.float64).astype(np.float32).astype(np.float64)


def rmse(image, reference):
    """Root-mean-square difference of two images, in float64."""
    return float(np.sqrt(np.mean((image.astype(np.float64) - reference) ** 2)))
