"""Sample patterns: the tables the host builds and the kernel reads (points in [0, 1)^2 for the pixel
offsets and for the points on a light), and how kernels/samplers.cl randomises them per pixel.

Tables are stored in 0.32 fixed point (uint32 pairs), so that the kernel's randomisations are exact
integer operations. The course's patterns (center, grid, rotated grids) are used as they are in every
pixel; random and low-discrepancy ones get a fresh randomisation per pixel and per sample stream."""
import math
from dataclasses import dataclass

import numpy as np

from . import structs

SAMPLERS = ("center", "grid", "rotated-grid-cw", "rotated-grid-ccw", "random", "jittered", "halton", "sobol")
SQUARE_ONLY = ("grid", "rotated-grid-cw", "rotated-grid-ccw")
FIXED = ("center",) + SQUARE_ONLY  # the course's patterns: the same points in every pixel
# The sequences, which any number of samples continues: a render towards a target error with no sample count
# runs them until the target (the grids and jittered strata are laid out for a count known in advance).
EXTENDING = ("random", "halton", "sobol")
DEFAULT_SPP = 16  # pixel samples of a scene that names none, as pbrt-v4's samplers default (1 for center)
ROTATION = math.atan(0.5)  # the course's rotated grid: 26.57 degrees


@dataclass(frozen=True)
class Pattern:
    name: str
    points: np.ndarray  # (n, 2) float64 in [0, 1): the table (for jittered: the strata's corners)
    randomize: str      # a key of structs.RANDOMIZE
    strata: tuple = (1, 1)  # jittered: strata along x and y

    def table(self):
        """The points in 0.32 fixed point, as the kernel reads them (uint2 per point)."""
        if self.randomize == "jitter":  # corners rounded up to 2^-24, the kernel's float resolution
            return (np.ceil(self.points * 2.0**24).astype(np.uint32) << np.uint32(8)).astype(np.uint32)
        return np.minimum(np.floor(self.points * 2.0**32), 2.0**32 - 1).astype(np.uint32)

    def sampler_struct(self):
        s = np.zeros((), structs.SAMPLER)
        s["randomize"] = structs.RANDOMIZE[self.randomize]
        s["cell_x"], s["cell_y"] = (2**24 // self.strata[0], 2**24 // self.strata[1])
        return s


def is_square(n):
    return n >= 1 and math.isqrt(n) ** 2 == n


def count_problem(name, n):
    """Why `name` cannot take n samples, or None."""
    if name not in SAMPLERS:
        return f"unknown sampler (have: {', '.join(SAMPLERS)})"
    if name == "center" and n != 1:
        return "the center sampler takes exactly one sample"
    if name in SQUARE_ONLY and not is_square(n):
        return f"the {name} sampler needs a square number (1, 4, 9, 16, ...)"
    return None


def default_count(name):
    """The pixel samples of a scene that gives `name` and no count."""
    return 1 if name == "center" else DEFAULT_SPP


def default_pattern(shading):
    """The pattern a scene gets when it names none: the course's grid in its Phong model; in a radiometric
    model the sequence that converges fastest, sobol (docs/sampling.md)."""
    return "grid" if shading == "phong" else "sobol"


def light_problem(name, n, shading):
    """Why `name` with n light samples would mislead in the `shading` model, or None: in a radiometric model a
    course's pattern of one point puts every light sample at the light's centre, a point light, biased by
    however many pixel samples (the Phong model defines its light samples by the pattern: the course's
    center sampler is that model's point light)."""
    if shading != "phong" and n == 1 and name in FIXED:
        return (f"with 1 light sample puts every light sample at the light's centre, a point light, biased in "
                f"the {shading} model (use sobol, or more light samples)")
    return None


def pattern(name, n):
    """The `name` pattern of n points; ValueError if it cannot have n."""
    problem = count_problem(name, n)
    if problem:
        raise ValueError(problem)
    if name == "center":
        return Pattern(name, np.full((1, 2), 0.5), "none")
    if name == "grid":
        k = math.isqrt(n)
        return Pattern(name, progressive(grid(n), (k, k)), "none")
    if name.startswith("rotated-grid"):
        return Pattern(name, rotated_grid(n, clockwise=name.endswith("-cw")), "none")
    if name == "random":
        return Pattern(name, np.zeros((n, 2)), "independent")
    if name == "jittered":
        strata = jitter_strata(n)
        return Pattern(name, progressive(grid_corners(*strata), strata), "jitter", strata)
    if name == "halton":
        i = np.arange(n)
        return Pattern(name, np.stack([radical_inverse(i, 2), radical_inverse(i, 3)], axis=1), "shift")
    return Pattern(name, sobol(n) / 2.0**32, "sobol")


def grid(n):
    """Cell centres of a sqrt(n) x sqrt(n) grid, row by row (n must be a square)."""
    k = math.isqrt(n)
    c = (np.arange(k) + 0.5) / k
    u, v = np.meshgrid(c, c)
    return np.stack([u.ravel(), v.ravel()], axis=1)


def grid_corners(nx, ny):
    """Lower corners of an nx x ny grid of cells, row by row."""
    u, v = np.meshgrid(np.arange(nx) / nx, np.arange(ny) / ny)
    return np.stack([u.ravel(), v.ravel()], axis=1)


def jitter_strata(n):
    """(nx, ny) with nx * ny = n and the cells as square as n allows: ny the largest divisor <= sqrt(n)."""
    ny = next(d for d in range(math.isqrt(n), 0, -1) if n % d == 0)
    return n // ny, ny


def rotated_grid(n, clockwise):
    """The grid rotated by atan(1/2) about the pixel centre, wrapped into the pixel, in the grid's
    progressive order. Clockwise as seen on the image, whose y axis points down."""
    k = math.isqrt(n)
    g = progressive(grid(n), (k, k)) - 0.5
    angle = ROTATION if clockwise else -ROTATION  # with y down, a positive angle turns clockwise on screen
    c, s = math.cos(angle), math.sin(angle)
    rotated = np.stack([c * g[:, 0] - s * g[:, 1], s * g[:, 0] + c * g[:, 1]], axis=1)
    return np.mod(rotated + 0.5, 1.0)


def progressive(points, cells):
    """The points, one per cell of a `cells` = (nx, ny) grid, reordered so that every block of 2^k
    consecutive points is spread over the pixel: a progressive render that stops early holds a coarser
    version of the pattern, and the passes it alternates between its two halves cover the pixel alike (else
    the halves would differ by which part of the pixel they cover, and the error estimate with them).
    When nx and ny are powers of two, cell i is the one the i-th Sobol point falls in: the Sobol sequence is
    a (0, 2)-sequence, so each aligned block of 2^k cells holds one cell of every elementary box of area
    2^-k. Otherwise the order is that of the cells' bit-reversed Morton codes (the first four fill the four
    quadrants, the first sixteen the 4 x 4 boxes, as far as the cells allow)."""
    nx, ny = cells
    ix = np.minimum(np.floor(points[:, 0] * nx), nx - 1).astype(np.int64)
    iy = np.minimum(np.floor(points[:, 1] * ny), ny - 1).astype(np.int64)
    if nx & (nx - 1) == 0 and ny & (ny - 1) == 0:
        order = sobol(nx * ny).astype(np.float64) / 2.0**32
        rank = np.empty(nx * ny, np.int64)
        rank[np.floor(order[:, 1] * ny).astype(np.int64) * nx + np.floor(order[:, 0] * nx).astype(np.int64)] = \
            np.arange(nx * ny)
        return points[np.argsort(rank[iy * nx + ix], kind="stable")]
    # Each cell's centre in b-bit fixed point, 2^b >= n: distinct per cell (centres lie 1/n >= 2^-b apart),
    # and each half's first cell sits at 0 or 2^(b-1) (the first centre past 1/2 is within 1/(2n) < 2^-b).
    bx, by = (max(1, int(n - 1).bit_length()) for n in (nx, ny))
    qx, qy = ((2 * ix + 1) << bx) // (2 * nx), ((2 * iy + 1) << by) // (2 * ny)
    code = np.zeros(len(points), np.int64)
    for level in range(max(bx, by)):  # the positions' most significant bits are the code's least
        if level < bx:
            code |= ((qx >> (bx - 1 - level)) & 1) << (2 * level)
        if level < by:
            code |= ((qy >> (by - 1 - level)) & 1) << (2 * level + 1)
    return points[np.argsort(code, kind="stable")]


def radical_inverse(i, base):
    """Van der Corput radical inverse of the integers i in `base`."""
    i = np.asarray(i, dtype=np.int64)
    result, scale = np.zeros(i.shape), 1.0 / base
    while np.any(i):
        result += (i % base) * scale
        i, scale = i // base, scale / base
    return result


def sobol(n):
    """The first n points of the two-dimensional Sobol sequence, unscrambled, as uint32 fixed point: a
    (0, 2)-sequence in base 2, in Gray-code order (point i is sobol_points(i xor i/2)), as scipy.stats.qmc.Sobol
    and Joe and Kuo generate them; it only reorders each aligned block of 2^m points."""
    i = np.arange(n, dtype=np.uint64)
    return sobol_points(i ^ (i >> np.uint64(1)))


def sobol_points(index):
    """Points `index` (an integer array) of the two-dimensional Sobol sequence, unscrambled, in index order, as
    uint32 fixed point (shape index.shape + (2,)). Dimension 0 is the van der Corput sequence; dimension 1 has
    the direction numbers v_k = v_{k-1} xor (v_{k-1} >> 1) (the upper-triangular Pascal matrix mod 2)."""
    i = np.asarray(index, np.uint64)
    directions = [np.uint64(1 << 31)]
    for _ in range(31):
        directions.append(directions[-1] ^ (directions[-1] >> np.uint64(1)))
    points = np.zeros(i.shape + (2,), np.uint64)
    for k in range(32):
        bit = (i >> np.uint64(k)) & np.uint64(1)
        points[..., 0] ^= bit * np.uint64(1 << (31 - k))
        points[..., 1] ^= bit * directions[k]
    return points.astype(np.uint32)
