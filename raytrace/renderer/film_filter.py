"""The film's reconstruction filters on the host: Mitsuba 3's formulas (src/rfilters/) in float64, and the
tables by which kernels/film_filter.cl samples them (pbrt-v4 section 8.8.3's filter importance sampling, one
axis at a time: Mitsuba's filters are separable)."""
import math
from dataclasses import dataclass

import numpy as np

from ..structs import RFILTER_NODES

MAX_BINS = RFILTER_NODES - 1


def parameters(scene):
    """The scene's filter as camera_struct takes it: (name, {Mitsuba's parameter: value})."""
    name = scene.rfilter
    given = {"box": {}, "tent": {"radius": scene.rfilter_radius}, "gaussian": {"stddev": scene.rfilter_stddev},
             "mitchell": {"B": scene.rfilter_b, "C": scene.rfilter_c}, "lanczos": {"lobes": scene.rfilter_lobes}}
    return name, given[name]


def formula(name, p):
    """(radius, f, a, b): the filter's support [-radius, radius], f(x) in float64 (numpy), and the two numbers
    film_filter.cl's rfilter_eval reads it by."""
    if name == "tent":
        r = p["radius"]
        return r, lambda x: np.maximum(0.0, 1.0 - np.abs(x) / r), 1.0 / r, 0.0
    if name == "gaussian":
        sigma = p["stddev"]
        r, alpha = 4.0 * sigma, -1.0 / (2.0 * sigma * sigma)
        bias = math.exp(alpha * r * r)
        return r, lambda x: np.maximum(0.0, np.exp(alpha * np.square(x)) - bias), alpha, bias
    if name == "mitchell":
        b, c = p["B"], p["C"]

        def mitchell(x):
            x = np.abs(x)
            near = (12 - 9 * b - 6 * c) * x ** 3 + (-18 + 12 * b + 6 * c) * x ** 2 + (6 - 2 * b)
            far = (-b - 6 * c) * x ** 3 + (6 * b + 30 * c) * x ** 2 + (-12 * b - 48 * c) * x + (8 * b + 24 * c)
            return np.where(x < 1, near, np.where(x < 2, far, 0.0)) / 6
        return 2.0, mitchell, b, c
    if name == "lanczos":
        lobes = float(p["lobes"])
        return lobes, lambda x: np.where(np.abs(x) <= lobes, np.sinc(x) * np.sinc(x / lobes), 0.0), lobes, 0.0
    raise ValueError(name)


@dataclass(frozen=True)
class Tables:
    bins: int
    reach: float     # the table spans [-reach, reach]: the radius rounded up to a half-integer
    step: float      # 0.5 / a power of two: every half-integer offset is a node
    a: float
    b: float
    integral: float  # f's integral over the line
    pdf: np.ndarray         # |f| at the nodes over the integral of its piecewise-linear interpolation
    cdf: np.ndarray         # that density's integral up to each node (0 .. 1)
    cumulative: np.ndarray  # f's own integral up to each node, over `integral`


def _integral(f, lo, hi, kinks):
    """f's integral over [lo, hi] by 32-point Gauss-Legendre on the pieces between the kinks (where f or its
    derivative jumps): exact to rounding for the polynomial pieces, far below float32 for the others."""
    nodes, weights = np.polynomial.legendre.leggauss(32)
    cuts = [lo, *sorted(k for k in kinks if lo < k < hi), hi]
    return sum(float(np.sum(weights * f((a + b) / 2 + (b - a) / 2 * nodes)) * (b - a) / 2)
               for a, b in zip(cuts, cuts[1:]))


def rfilter_tables(name, p):
    """The sampling tables of filter `name` with parameters p (film_filter.cl): nodes every `step` over
    [-reach, reach], at most MAX_BINS bins."""
    radius, f, a, b = formula(name, p)
    reach = math.ceil(2 * radius) / 2
    k = 1 << max(0, int(math.floor(math.log2(MAX_BINS / (4 * reach)))))
    bins, step = int(4 * reach * k), 0.5 / k
    if bins > MAX_BINS:
        raise ValueError(f"a filter radius of {radius} is beyond the table's {MAX_BINS / 4} pixels")
    x = -reach + step * np.arange(bins + 1)
    absolute = np.abs(f(x))
    areas = (absolute[:-1] + absolute[1:]) * step / 2
    total = areas.sum()
    kinks = [-radius, radius, -1.0, 1.0, 0.0]
    pieces = np.array([_integral(f, x[i], x[i + 1], kinks) for i in range(bins)])
    integral = pieces.sum()
    cdf = np.concatenate([[0.0], np.cumsum(areas) / total])
    cdf[cdf >= 1.0] = 1.0
    cdf[-1] = 1.0
    return Tables(bins, reach, step, a, b, integral, absolute / total, cdf,
                  np.concatenate([[0.0], np.cumsum(pieces)]) / integral)
