"""Sample tables the host builds and the kernel reads: pixel offsets in [0, 1)^2 for anti-aliasing and
(u, v) points on the light rectangle."""
import math

import numpy as np

PIXEL_SAMPLERS = ("center", "grid")


def is_square(n):
    return n >= 1 and math.isqrt(n) ** 2 == n


def grid(n):
    """Cell centres of a sqrt(n) x sqrt(n) grid, row by row (n must be a square)."""
    k = math.isqrt(n)
    c = (np.arange(k) + 0.5) / k
    u, v = np.meshgrid(c, c)
    return np.stack([u.ravel(), v.ravel()], axis=1)


def radical_inverse(i, base):
    """Van der Corput radical inverse of the integers i in `base`."""
    i = np.asarray(i, dtype=np.int64)
    result, scale = np.zeros(i.shape), 1.0 / base
    while np.any(i):
        result += (i % base) * scale
        i, scale = i // base, scale / base
    return result


def hammersley(n):
    """(i + 1/2)/n against the base-2 radical inverse: a low-discrepancy set of exactly n points."""
    i = np.arange(n)
    return np.stack([(i + 0.5) / n, radical_inverse(i, 2)], axis=1)


def pixel_samples(name, n):
    """The anti-aliasing table: `center` (one sample; n must be 1) or `grid` (n a square)."""
    if name == "center":
        return np.full((n, 2), 0.5)
    if name == "grid":
        return grid(n)
    raise ValueError(name)


def light_samples(n):
    """The course's uniform grid of cell centres when n is a square, else the Hammersley set of n."""
    return grid(n) if is_square(n) else hammersley(n)
