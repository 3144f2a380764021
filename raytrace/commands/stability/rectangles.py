"""Case 2, grazing_rectangles: grazing and nearly parallel rays on a rectangle."""
import numpy as np

from ...scene import Rectangle
from ...numerics import U, f32
from ...renderer.packing import rectangle_structs
from .common import Row, closest_hit, hit_nonfinite, shapes, stored, unit


# ---------------------------------------------------------------------------------------------------------
# 2. Grazing and nearly parallel rays on a rectangle

def segment_meets_box(a, b, half):
    """Whether the 2-D segments from a to b (n x 2) meet the boxes |x| <= half (n x 2)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        s1, s2 = (-half - a) / (b - a), (half - a) / (b - a)
    level = a == b  # a segment parallel to a slab: inside it entirely or not at all
    lo = np.where(level, np.where(np.abs(a) <= half, 0.0, np.inf), np.minimum(s1, s2))
    hi = np.where(level, np.where(np.abs(a) <= half, 1.0, -np.inf), np.maximum(s1, s2))
    return np.maximum(lo.max(axis=1), 0.0) <= np.minimum(hi.min(axis=1), 1.0)


def rectangle_truth(s, o, d):
    """Float64 on the stored rectangle s for rays (o, d): (t, r: the bound on the relative error of float32's
    t argued in grazing_rectangles, clear hits, clear misses). Clear: the same answer for every t within
    twice r, with (u, v) within twice their rounding (8u of |c - o| + |t d|) of the rectangle's border."""
    c, n, tan, bit = (stored(s, k) for k in ("center", "normal", "tangent", "bitangent"))
    half = np.array([float(s["half_x"]), float(s["half_y"])])
    co = c - o
    num, den = co @ n, d @ n
    e_num, e_den = 6 * U * (np.abs(co) @ np.abs(n)), 5 * U * (np.abs(d) @ np.abs(n))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / den
        r = (1 + e_num / np.abs(num)) * (1 + 6 * U) / (1 - e_den / np.abs(den)) - 1
        r2 = (1 + 2 * e_num / np.abs(num)) * (1 + 12 * U) / (1 - 2 * e_den / np.abs(den)) - 1
    resolved = 2 * e_den < np.abs(den)
    t_lo, t_hi = (np.where(resolved, t - sign * np.abs(t) * r2, np.nan) for sign in (1, -1))
    uv = lambda t: np.stack([(o + t[:, None] * d - c) @ tan, (o + t[:, None] * d - c) @ bit], axis=1)  # noqa
    margin = (16 * U * (np.abs(co).sum(1) + np.abs(t_hi) * np.abs(d).sum(1)))[:, None]
    a, b = uv(t_lo), uv(t_hi)
    inside = np.all(np.abs(a) <= half - margin, axis=1) & np.all(np.abs(b) <= half - margin, axis=1)
    clear_miss = resolved & ((t_hi < 0) | ~segment_meets_box(a, b, half + margin))
    return t, r, resolved & (t_lo > 0) & inside, clear_miss


def rectangle_crossing(env, s, rect, o, d):
    """(kernel hit, float64 t, its bound r, rays where hit and miss disagree though float64 is clear, clear
    rays)."""
    hit = closest_hit(env, shapes(env, rectangles=[rect]), o, d)
    t, r, clear_hit, clear_miss = rectangle_truth(s, o, d)
    hits = np.isfinite(hit["t"])
    wrong = (clear_hit & ~hits) | (clear_miss & hits)
    return hit, t, r, int(np.count_nonzero(wrong)), int(np.count_nonzero(clear_hit | clear_miss))


def grazing_rectangles(env):
    """A tilted 2 x 1.5 rectangle. Grazing rays at 1e-1 .. 1e-6 rad to its plane, at points within 80% of
    each half-size (away from the border), from one unit away, from either side; and nearly parallel rays:
    origins in the plane (as float32 rounds them) or 1e-7 .. 1e-3 off it, over and beside the rectangle,
    directions in the plane or tilted by 1e-8 .. 1e-4. Truth: float64 on the same float32 values.

    t = num / den, num = (c - o).n, den = d.n: c - o rounds once and a 3-term dot product (nested mads) at
    most five times per term, so num is within 6u |c - o|.|n| (componentwise absolute values) and den within
    5u |d|.|n|; the division (a reciprocal to 2.5 ulp and a product) adds 6u. So t's relative error is at
    most r = (1 + 6u kn)(1 + 6u) / (1 - 5u kd) - 1, with the condition numbers kn = |c - o|.|n| / |num| and
    kd = |d|.|n| / |den| = 1 / sin(angle): about 14u / sin(angle) here (kn ~ 1.4 kd), more at 1e-6 rad,
    where den is known to 30%. Rows give t's error in u / sin(angle) against the row's largest r.

    Hit or miss must agree with float64 where float64 is clear (rectangle_truth): for every t within twice
    r, the crossing is inside the rectangle shrunk by twice the rounding of its (u, v), or outside it grown
    so, or behind the ray. Elsewhere (a nearly parallel ray whose den is below its own rounding, a crossing
    at the border) either answer is float32's to give. No NaN or Inf in t, the normal or Hit.p."""
    rng = np.random.default_rng(2)
    normal = unit(np.array([1.0, -2.0, 3.0]))
    rect = Rectangle(np.array([0.3, -0.2, 0.5]), np.array([2.0, 1.5]), normal, unit(np.cross(normal, [0, 0, 1.0])))
    s = rectangle_structs([rect])[0]
    c, n, tan, bit = (stored(s, k) for k in ("center", "normal", "tangent", "bitangent"))
    half = np.array([float(s["half_x"]), float(s["half_y"])])
    in_plane = lambda phi: np.cos(phi)[:, None] * tan + np.sin(phi)[:, None] * bit  # noqa: E731
    rows, wrong, clear, total, m = [], 0, 0, 0, 512
    for angle in 10.0 ** -np.arange(1, 7):
        side = rng.choice([-1.0, 1.0], (m, 1))
        d = f32(unit(np.cos(angle) * in_plane(rng.uniform(0, 2 * np.pi, m)) - side * np.sin(angle) * n))
        o = f32(c + (rng.uniform(-0.8, 0.8, (m, 2)) * half) @ np.stack([tan, bit]) - d)
        hit, t, r, k, cl = rectangle_crossing(env, s, rect, o, d)
        sine = np.abs(d @ n) / (np.linalg.norm(d, axis=1) * np.linalg.norm(n))
        both = np.isfinite(hit["t"]) & np.isfinite(t)
        rows.append(Row(f"grazing at {angle:g} rad: t relative error (of {m})",
                        float(np.max(np.abs(hit["t"] - t)[both] / np.abs(t[both]) * sine[both] / U)), "u/sin",
                        float(np.max(r * sine / U)), "(1+6u kn)(1+6u)/(1-5u kd)-1, kd = 1/sin",
                        hit_nonfinite(hit)))
        wrong, clear, total = wrong + k, clear + cl, total + m
    rows.append(Row(f"grazing: hit/miss against float64 where clear ({clear} of {total})", wrong, "rays", 0,
                    "clear: one answer for every t within twice r"))
    m = 2048
    lift = rng.choice([0.0, 1e-7, 1e-5, 1e-3], (m, 1)) * rng.choice([-1.0, 1.0], (m, 1))
    tilt = rng.choice([0.0, 1e-8, 1e-6, 1e-4], (m, 1)) * rng.choice([-1.0, 1.0], (m, 1))
    o = f32(c + (rng.uniform(-1.5, 1.5, (m, 2)) * half) @ np.stack([tan, bit]) + lift * n)
    d = f32(unit(in_plane(rng.uniform(0, 2 * np.pi, m)) + tilt * n))
    hit, _, _, k, cl = rectangle_crossing(env, s, rect, o, d)
    rows.append(Row(f"nearly parallel: hit/miss against float64 where clear ({cl} of {m})", k, "rays", 0,
                    "clear: one answer for every t within twice r", hit_nonfinite(hit)))
    return rows
