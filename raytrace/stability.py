"""The numerical stability suite (`python -m raytrace stability`, tests/stability/): the kernel's float32
results at the edges of its input space, against float64 computed here, independently, in numpy.

Each case is one function returning rows: what is measured, the largest error found, and the bound it is
held to, argued in the case's docstring from the float32 rounding of the computation (u = 2^-24, the unit
roundoff; OpenCL 1.2's ulp limits for the builtins) and the conditioning of the problem. Float64 always
works on the float32 values the kernel reads (the packed structs), so that only the kernel's arithmetic is
measured. A row passes when its error is within its bound and no NaN or Inf appeared; a known limit is a
row whose bound is a stated limit of float32 rather than a guarantee, held so that it cannot get worse."""
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import samplers
from .converge import rmse
from .errors import InputError
from .probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, Probe, planar, scene_args
from .render import render
from .scene import Ellipsoid, Light, Rectangle, Triangle, load_scene
from .transform import f32
from .structs import (camera_struct, ellipsoid_structs, light_structs, material_structs, params_struct,
                      rectangle_structs)

U = 2.0**-24  # float32 unit roundoff: one rounding moves a value by at most u of itself
SCENES = Path(__file__).resolve().parent.parent / "scenes"
SCENE0 = SCENES / "cornell.toml"


@dataclasses.dataclass
class Row:
    measured: str
    error: float
    unit: str
    bound: float
    why: str               # the bound, argued in one phrase
    nonfinite: int = 0     # NaN and Inf values seen
    known_limit: bool = False
    skipped: bool = False  # not measured, for the reason given in `measured`
    case: str = ""

    @property
    def verdict(self):
        if self.skipped:
            return "skipped"
        if not (self.error <= self.bound and self.nonfinite == 0):  # a NaN error fails too
            return "FAIL"
        return "known limit" if self.known_limit else "pass"


class Env:
    """What the cases run on: a probe at one lane width, renders at the same width, scene 0."""

    def __init__(self, lanes, device=None):
        self.lanes, self.device = lanes, device
        self.probe = Probe(lanes, device)
        self.cornell = load_scene(SCENE0)

    def render(self, scene, **kwargs):
        """(image, its NaN and Inf values: render() zeroes them and counts them in its stats)."""
        image, stats = render(scene, lanes=self.lanes, device=self.device, progress=False, **kwargs)
        return image, stats.extra["nonfinite_values"]


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def stored(struct, key):
    """A field of a packed struct: the float32 values the kernel reads, in float64."""
    return np.asarray(struct[key], np.float64)


def nonfinite(*arrays):
    return int(sum(np.count_nonzero(~np.isfinite(a)) for a in arrays))


def hit_nonfinite(hit):
    """NaN and Inf in a closest_hit(): t is finite or +inf, p and n finite where t is."""
    hits = np.isfinite(hit["t"])
    return nonfinite(hit["t"][~np.isinf(hit["t"])], hit["p"][hits], hit["n"][hits])


def brightest(scene):
    """No pixel can exceed max k (ambient + 2 sum L) (n.l and the specular power are each at most 1), or a
    light's colour."""
    k = max(m.colour.max() for m in scene.materials)
    lights = [light.colour.max() for light in scene.lights]
    return max(k * (scene.ambient.max() + 2 * sum(lights)), *lights)


def outside(images, limit):
    return sum(int(np.count_nonzero((a < 0) | (a > limit))) for a in images)


# ---------------------------------------------------------------------------------------------------------
# closest_hit over a scene of a few shapes

def shapes(env, rectangles=(), triangles=(), ellipsoids=()):
    """Scene 0's materials and camera with only these shapes and no lights."""
    return dataclasses.replace(env.cornell, lights=[], rectangles=list(rectangles), triangles=list(triangles),
                               ellipsoids=list(ellipsoids))


def closest_hit(env, scene, o, d):
    """The kernel's closest hit of rays (o, d), (n, 3) float32 values: {t, p, err, n}; the rays are padded
    to whole work-items by repeating the last one."""
    n = len(o)
    padded = -(-n // env.lanes) * env.lanes
    o, d = (np.concatenate([a, np.repeat(a[-1:], padded - n, axis=0)]) for a in (o, d))
    out = env.probe.run(CLOSEST_HIT, "closest", padded, [*scene_args(scene), planar(o), planar(d)], CLOSEST_HIT_OUTPUTS,
                        HAS_RECTANGLES=bool(scene.rectangles), HAS_TRIANGLES=bool(scene.triangles),
                        HAS_ELLIPSOIDS=bool(scene.ellipsoids))
    return {"t": out["t"][:n], "p": out["p"].T[:n], "err": out["err"][:n], "n": out["nrm"].T[:n]}


# ---------------------------------------------------------------------------------------------------------
# 1. A closed mesh: rays through its shared edges and vertices

def icosphere():
    """The icosahedron subdivided once, on the unit sphere: 42 vertices, 80 outward-wound faces."""
    g = (1 + 5**0.5) / 2
    corners = [(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
               (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    vertices, middle = [np.array(p, float) for p in corners], {}

    def midpoint(i, j):
        key = (min(i, j), max(i, j))
        if key not in middle:
            middle[key] = len(vertices)
            vertices.append((vertices[i] + vertices[j]) / 2)
        return middle[key]
    finer = []
    for a, b, c in faces:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        finer += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return unit(np.array(vertices)), np.array(finer)


def mesh_targets(vertices, faces, rng):
    """Points of the mesh's vertices and edges (each vertex; each edge's midpoint and two random points of
    it), with the outward unit normals of the faces that share each point."""
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    normals = unit(np.cross(v1 - v0, v2 - v0))
    around = [np.any(faces == i, axis=1) for i in range(len(vertices))]
    points, sharing = list(vertices), [normals[a] for a in around]
    for i, j in sorted({tuple(sorted((f[k], f[(k + 1) % 3]))) for f in faces for k in range(3)}):
        for s in (0.5, *rng.uniform(0.05, 0.95, 2)):
            points.append(vertices[i] + s * (vertices[j] - vertices[i]))
            sharing.append(normals[around[i] & around[j]])
    return np.array(points), sharing


def entering_directions(point, sharing, rng, k):
    """Up to k directions entering the mesh at `point` steeper than 11.5 degrees to each face there
    (d.n < -0.2), so that the ray runs well inside before it leaves (a chord of about 0.4 radii or more)."""
    d = unit(-point + 0.6 * unit(rng.normal(size=(4 * k, 3))))
    return d[np.all(d @ sharing.T < -0.2, axis=1)][:k]


def mesh_edges(env):
    """A closed mesh (the icosahedron subdivided once: 80 faces, unit radius) at the origin, moved 1e4 units
    out, and scaled by 1e-3, its vertices stored in float32. Rays aimed at every vertex and at points of
    every edge (rounded to float32: within half a float spacing of the edge), 8 from outside and 8 from
    points inside per target, each ray's direction target - origin rounded once, so that it passes within a
    rounding of the target: a few float spacings from the edge in the plane the triangle test projects to.

    Bound 0: the watertight test (Woop, Benthin and Wald; kernels/triangle.cl) computes each edge function
    from the shared vertices alone, exactly negated between the two triangles of an edge, and counts a zero
    as inside, so a ray through an edge or a vertex hits one of the triangles there whatever the rounding.
    A ray from inside crosses the convex mesh once: it slips through where nothing is hit. A ray from outside
    enters at the target (t = 1) and leaves much later (t > 1.1): it slips through where its first hit is not
    within 1% of t = 1. (A test counting a zero edge function as outside lets about 1000 of each 6432 through.)"""
    rng = np.random.default_rng(1)
    vertices, faces = icosphere()
    rows = []
    for scale, offset in ((1.0, 0.0), (1.0, 1e4), (1e-3, 0.0)):
        place = lambda x: scale * x + offset * np.array([1.0, -0.7, 0.4])  # noqa: E731
        mesh = f32(place(vertices))
        scene = shapes(env, triangles=[Triangle(mesh[f]) for f in faces])
        points, sharing = mesh_targets(vertices, faces, rng)
        targets = f32(place(points))
        outside_rays = [(t, f32(place(p - 3 * d))) for p, s, t in zip(points, sharing, targets)
                        for d in entering_directions(p, s, rng, 8)]
        inside_rays = [(t, f32(place(0.5 * unit(x) * rng.uniform() ** (1 / 3)))) for t in targets
                       for x in rng.normal(size=(8, 3))]
        target, o = (np.array(a) for a in zip(*outside_rays, *inside_rays))
        hit = closest_hit(env, scene, o, f32(target - o))
        from_outside = np.arange(len(o)) < len(outside_rays)
        slipped = np.where(from_outside, ~(np.abs(hit["t"] - 1) <= 0.01), ~np.isfinite(hit["t"]))
        rows.append(Row(f"mesh x{scale:g} at {offset:g}: rays through edges and vertices slipping through "
                        f"(of {len(o)})", int(np.count_nonzero(slipped)), "rays", 0,
                        "watertight: shared edge functions exactly opposite", hit_nonfinite(hit)))
    return rows


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


# ---------------------------------------------------------------------------------------------------------
# 3, 4. Ellipsoids: grazing rays; extreme axis ratios, scales and distances

def ellipsoid_truth(s, o, d):
    """Float64 on the stored ellipsoid s (centre c, world_to_unit W: the surface |W (x - c)| = 1) for rays
    (o, d) from outside: {t: the near root (NaN for a miss); b2: the squared distance of the ray's line from
    the centre in unit-sphere space; o_u = W (o - c), d_u = W d, d, W; S = | |W| |o - c| | + |t| | |W| |d| |,
    the magnitudes that mapping the ray rounds; S_c, the same at the closest approach}."""
    c, w = stored(s, "center"), stored(s, "world_to_unit").reshape(3, 3)
    oc = o - c
    ou, du = oc @ w.T, d @ w.T
    a, h = np.sum(du * du, 1), np.sum(ou * du, 1)
    f = ou - (h / a)[:, None] * du
    b2 = np.sum(f * f, 1)
    root = -(h + np.copysign(np.sqrt(np.maximum(a * (1 - b2), 0)), h))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(b2 <= 1, np.minimum(root / a, (np.sum(ou * ou, 1) - 1) / root), np.nan)
    mapped = lambda v: np.linalg.norm(np.abs(v) @ np.abs(w).T, axis=1)  # noqa: E731
    return {"t": t, "b2": b2, "o_u": ou, "d_u": du, "d": d, "W": w, "S": mapped(oc) + np.abs(t) * mapped(d),
            "S_c": mapped(oc) + np.abs(h / a) * mapped(d)}


def ellipsoid_clear(truth):
    """Where float64's hit or miss is clear: |1 - b2| over twice the rounding of the kernel's 1 - |f|^2, f
    the foot of the ray's closest approach in unit-sphere space, which moves by 8u S_c (o_u and d_u mapped
    with 6 and 5 roundings, f = o_u - (h/a) d_u with 2 more), doubled through |f|^2 ~ 1, plus 5u in |f|^2."""
    return np.abs(1 - truth["b2"]) > 2 * (16 * U * truth["S_c"] + 5 * U)


def t_error(hit, truth):
    """The kernel's t error in u kt, kt = S / |q.d_u| + |t|: the near root's condition number 1 / |q.d_u| (q
    the hit on the unit sphere) times the magnitudes that mapping the ray rounds, plus t's own."""
    t = truth["t"]
    q = truth["o_u"] + t[:, None] * truth["d_u"]
    return np.abs(hit["t"] - t) / (U * (truth["S"] / np.abs(np.sum(q * truth["d_u"], 1)) + np.abs(t)))


T_BOUND, T_WHY = 17, "mapping 6u of S; h 5, sqrt 6, sum 1, a 5, division 5"


def grazing_ellipsoids(env):
    """A skewed ellipsoid; rays passing 1e-3 .. 1e-6 inside and outside its silhouette (in unit-sphere space,
    where it is the unit sphere: the line's distance from the centre is 1 -+ delta), from 3 and 300 radii
    away. Truth: float64 on the same float32 values.

    The near root of |o_u + t d_u| = 1 moves by dt = -(q.do_u + t q.dd_u) / q.d_u when o_u and d_u move
    (q the hit): its condition number 1 / |q.d_u| = 1 / sqrt(disc) is unbounded at the silhouette. The
    kernel's o_u and d_u carry at most 6 and 5 roundings of |W| |o - c| and |W| |d| (together S); its
    discriminant a (1 - |f|^2) rounds 1 - |f|^2 by 5u of |f|^2 ~ 1 <= S; the root's other operations (h, sqrt
    to 3 ulp, the sum, a, the division) by at most 17u of t. So the error is at most 17u kt, kt = S / |q.d_u|
    + |t| (t_error). Hit or miss must agree where float64 is clear (ellipsoid_clear). No NaN or Inf. (The
    textbook discriminant h^2 - a c, which cancels for the far rays, fails both: 87 clear rays wrong, 144u kt.)"""
    rng = np.random.default_rng(3)
    axes = np.array([[0.6, 0.2, 0.0], [-0.1, 0.3, 0.1], [0.0, 0.1, 0.5]])
    e = Ellipsoid(np.array([0.1, 0.2, -0.1]), axes)
    o, d = [], []
    for delta in (1e-3, 1e-4, 1e-5, 1e-6):
        for side in (-1, 1):
            for away in (3, 300):
                line = unit(rng.normal(size=(128, 3)))
                foot = unit(np.cross(line, rng.normal(size=(128, 3)))) * (1 + side * delta)
                o.append(e.center + (foot - away * line) @ axes)
                d.append(unit(line @ axes))
    o, d = f32(np.concatenate(o)), f32(np.concatenate(d))
    hit, truth = closest_hit(env, shapes(env, ellipsoids=[e]), o, d), ellipsoid_truth(ellipsoid_structs([e])[0], o, d)
    clear, both = ellipsoid_clear(truth), np.isfinite(hit["t"]) & np.isfinite(truth["t"])
    wrong = clear & (np.isfinite(hit["t"]) != np.isfinite(truth["t"]))
    return [Row(f"1e-3..1e-6 from the silhouette: hit/miss against float64 where clear "
                f"({np.count_nonzero(clear)} of {len(o)})", int(np.count_nonzero(wrong)), "rays", 0,
                "clear: |1 - b^2| over twice its rounding", hit_nonfinite(hit)),
            Row(f"1e-3..1e-6 from the silhouette: t error ({np.count_nonzero(both)} hits)",
                float(np.max(t_error(hit, truth)[both])), "u kt", T_BOUND, T_WHY)]


def normal_error(hit, truth):
    """The kernel's normal error in u kn, against normalize(W^T q) in float64 at the kernel's own t (its t
    error is measured apart), facing the ray; kn = (|W| S + | |W^T| |q| |) / |W^T q| + 1: W^T stretches errors
    of q by up to the axis ratio."""
    w = truth["W"]
    q = truth["o_u"] + hit["t"][:, None] * truth["d_u"]
    g = q @ w
    n = unit(g) * -np.sign(np.sum(g * truth["d"], 1))[:, None]
    kn = (np.linalg.norm(w, 2) * truth["S"] + np.linalg.norm(np.abs(q) @ np.abs(w), axis=1)) / np.linalg.norm(g, axis=1)
    return np.linalg.norm(hit["n"] - n, axis=1) / (U * (kn + 1))


def surface_distance(s, p):
    """Distance of points p from the stored ellipsoid s along the normal line through p, exactly: the root
    nearest 0 of |W (p + x g - c)|^2 = 1, a quadratic in x (g the unit gradient at p)."""
    c, w = stored(s, "center"), stored(s, "world_to_unit").reshape(3, 3)
    qp = (p - c) @ w.T
    wg = unit(qp @ w) @ w.T
    a, b, cc = np.sum(wg * wg, 1), np.sum(qp * wg, 1), np.sum(qp * qp, 1) - 1
    return np.abs(cc / (b + np.copysign(np.sqrt(b * b - a * cc), b)))


def extreme_ellipsoids(env):
    """Ellipsoids with axes s, s / sqrt(r), s / r along a skewed frame, for axis ratios r = 1, 1e2, 1e4 and
    scales s = 1e-3, 1, 1e4, at the origin and 1e4 units out, where float32 resolves them: the smallest axis
    spans at least 256 float spacings at the largest coordinate (else the float32 shape is a blur a few
    representable points across; those combinations are listed as skipped). Rays from 3 radii away through
    points within 0.9 of the centre (in unit-sphere space): every one a clear hit.

    t within 17u kt (grazing_ellipsoids' argument). The normal normalize(W^T q), against float64 at the
    kernel's own t: q = o_u + t d_u carries 6u of S from the mapping and 2u from the sum, W^T q five roundings
    of |W^T| |q|, normalising 8.5u: at most 9u kn (normal_error; at r = 1e4, kn u reaches 0.2 rad: the
    problem's own conditioning). Hit.p lies within Hit.err of the stored surface (exactly, along the normal
    line: surface_distance): bound 1 in units of Hit.err, the kernel's own bound (ray.h)."""
    rng = np.random.default_rng(4)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    t_err, n_err, p_err, missed, rays, bad, skipped = [], [], [], 0, 0, 0, []
    for ratio in (1.0, 1e2, 1e4):
        for scale in (1e-3, 1.0, 1e4):
            for far in (0.0, 1e4):
                name = f"r {ratio:g} s {scale:g} at {far:g}"
                centre = far * np.array([1.0, -0.7, 0.4]) + scale * np.array([0.1, 0.2, -0.1])
                spacing = float(np.spacing(np.float32(np.abs(centre).max() + scale)))
                if scale / ratio < 256 * spacing:
                    skipped.append(f"{name} ({scale / ratio / spacing:.2g})")
                    continue
                axes = np.diag([scale, scale / ratio**0.5, scale / ratio]) @ frame.T
                e = Ellipsoid(centre, axes)
                line = unit(rng.normal(size=(256, 3)))
                foot = unit(np.cross(line, rng.normal(size=(256, 3)))) * 0.9 * np.sqrt(rng.uniform(size=(256, 1)))
                o, d = f32(centre + (foot - 3 * line) @ axes), f32(unit(line @ axes))
                s = ellipsoid_structs([e])[0]
                hit, truth = closest_hit(env, shapes(env, ellipsoids=[e]), o, d), ellipsoid_truth(s, o, d)
                hits, both = np.isfinite(hit["t"]), np.isfinite(hit["t"]) & np.isfinite(truth["t"])
                missed, rays = missed + int(np.count_nonzero(ellipsoid_clear(truth) & ~hits)), rays + len(o)
                bad += hit_nonfinite(hit)
                t_err.append((float(np.max(t_error(hit, truth)[both])), name))
                n_err.append((float(np.max(normal_error(hit, truth)[both])), name))
                p_err.append((float(np.max(surface_distance(s, hit["p"][hits]) / hit["err"][hits])), name))
    (t_worst, t_at), (n_worst, n_at), (p_worst, p_at) = max(t_err), max(n_err), max(p_err)
    return [Row(f"ratios to 1e4, scales 1e-3..1e4, at 0 and 1e4: clear hits missed (of {rays})", missed, "rays",
                0, "impact parameter <= 0.9: all clear hits", bad),
            Row(f"t error, worst at {t_at}", t_worst, "u kt", T_BOUND, T_WHY),
            Row(f"normal error, worst at {n_at}", n_worst, "u kn", 9, "q 8u of S, W^T q 5u, normalising 8.5u"),
            Row(f"Hit.p's distance from the surface, worst at {p_at}", p_worst, "Hit.err", 1, "Hit.err bounds it"),
            Row("not resolved (spacings across): " + ", ".join(skipped), 0, "", 0,
                "under 256 float spacings across", skipped=True)]


# ---------------------------------------------------------------------------------------------------------
# 5. Lights on the horizon of the shaded point

SHADE = """
#include "shading.cl"
__kernel void shade_at(int n, __constant const RenderParams *params, __global const Light *lights,
                       __global const Material *materials, __global const uint2 *light_samples,
                       __global const float *p, __global const float *nrm, __global const float *d,
                       __global float *colour)
{
    const Scene s = {0, 0, 0, 0, 0, lights, materials, 0, params};
    Ray r = {v3_sub(IN3(p), IN3(d)), IN3(d)};
    Hit hit;
    hit.t = 1.0f;
    hit.p = IN3(p);
    hit.err = 0.0f;
    hit.n = IN3(nrm);
    hit.material = (vint)(0);
    hit.emitted = v3_splat(0.0f, 0.0f, 0.0f);
    ShadingPoint sp = {IN3(p), (vfloat)(0.0f), IN3(nrm), IN3(nrm), v3_splat(1.0f, 1.0f, 1.0f),
                       (vfloat)(materials[0].shininess)};
    vfloat rays = 0.0f;
    OUT3(colour, shade(&s, r, hit, sp, light_samples, (vuint)(0), &rays));
}
"""
AMBIENT = np.array([0.1, 0.2, 0.3])


def shade(env, light, p, n, d):
    """shade() at points p of a surface with normal n, seen along d (colour k = 1, shininess 16), under one
    light with 16 grid samples, ambient AMBIENT, nothing in the way: (m, 3) colours."""
    scene = dataclasses.replace(shapes(env), lights=[light], ambient=AMBIENT)
    grid = samplers.pattern("grid", 16)
    args = [params_struct(scene, light_samples=16, light_pattern=grid), light_structs([light]),
            material_structs(scene.materials), grid.table(), planar(p), planar(n), planar(d)]
    return env.probe.run(SHADE, "shade_at", len(p), args, {"colour": 3})["colour"].T


def lights_at_horizon(env):
    """shade() where every light sample lies on the shaded point's horizon or below it must return the
    ambient term exactly (k = 1: the ambient colour itself), with no NaN: samples at n.l <= 0 add nothing
    (the README's model), and nothing here may round them above.

    On the horizon: a light lying in the surface's own plane, for planes normal to each axis (either side):
    there q - p has an exact zero along the normal, so n.l is exactly 0; a quarter of the points sit on
    light samples (q = p, where l = normalize(0) is NaN and must not leak). Not on tilted planes: their float32
    points lie up to half a spacing either side of the plane, so that even float64 on the same values puts
    such samples above or below at random. Below the horizon: points of tilted planes under a small light
    1e-2 or 1e-5 rad below their horizon, far beyond the rounding of n.l (a few u). Bound 0 for both."""
    rng = np.random.default_rng(5)
    m, on, below = 256, [], []
    for k in range(3):  # a 1 x 1 light in the plane x_k = 0.75: its 4 x 4 grid samples are exact floats
        normal, tangent = np.eye(3)[k], np.eye(3)[(k + 1) % 3]
        p = f32(rng.uniform(-1, 1, (m, 3)))
        p[: m // 4, (k + 1) % 3], p[: m // 4, (k + 2) % 3] = rng.choice([-0.375, -0.125, 0.125, 0.375], (2, m // 4))
        p[:, k] = 0.75
        n = normal * rng.choice([-1.0, 1.0], (m, 1))
        view = f32(unit(-n + 0.8 * unit(rng.normal(size=(m, 3)))))
        on.append(shade(env, Light(0.75 * normal, np.ones(2), normal, tangent), p, n, view))
    for angle in (1e-2, 1e-5):
        p, centre = f32(rng.uniform(-1, 1, (m, 3))), np.array([0.3, -0.2, 2.5])
        towards = unit(centre - p)
        n = f32(np.cos(angle) * unit(np.cross(towards, rng.normal(size=(m, 3)))) - np.sin(angle) * towards)
        size = 0.1 * angle * np.linalg.norm(centre - p, axis=1).min() * np.ones(2)  # within 0.15 angle of centre
        light = Light(centre, size, np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0]))
        below.append(shade(env, light, p, n, f32(unit(-n + 0.8 * unit(rng.normal(size=(m, 3)))))))
    ambient = f32(AMBIENT)
    return [Row(f"light in the shaded plane, samples on 1/4 of the points: |colour - ambient| (of {3 * m})",
                float(np.max(np.abs(np.concatenate(on) - ambient))), "", 0, "n.l = 0 exactly adds nothing",
                nonfinite(*on)),
            Row(f"light 1e-2 and 1e-5 rad below the horizon: |colour - ambient| (of {2 * m})",
                float(np.max(np.abs(np.concatenate(below) - ambient))), "", 0, "n.l < 0 adds nothing",
                nonfinite(*below))]


# ---------------------------------------------------------------------------------------------------------
# 6. The specular power at high shininess

POWER = """
#include "shading.cl"
__kernel void power(int n, __global const float *x, float shininess, __global float *out)
{
    OUT(out, phong_power(IN(x), (vfloat)(shininess)));
}
"""
TINY = 2.0**-126  # the smallest normal float32: results below it may be subnormal or flushed to zero


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


# ---------------------------------------------------------------------------------------------------------
# 7. Camera rays at extreme fields of view

CAMERA = """
#include "camera.cl"
__kernel void rays(int n, __constant const Camera *cam, __global const float *x, __global const float *y,
                   float inv_w, float inv_h, __global float *d)
{
    OUT3(d, generate_camera_ray(cam, IN(x), IN(y), inv_w, inv_h).d);
}
"""


def camera_truth(camera, x, y, width, height):
    """The README's camera model in float64: (unit directions, their condition numbers (f + |sx| + |sy| +
    scale_x + scale_y) / |f forward + sx right + sy up|)."""
    forward = unit(camera.look_at - camera.position)
    right = unit(np.cross(forward, camera.ref_up))
    up = np.cross(right, forward)
    f, tan_half = camera.focal_length, np.tan(np.radians(camera.fov_deg) / 2)
    sx = (2 * x / width - 1) * width / height * f * tan_half
    sy = (1 - 2 * y / height) * f * tan_half
    d = f * forward + sx[:, None] * right + sy[:, None] * up
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], (f + np.abs(sx) + np.abs(sy) + f * tan_half * (1 + width / height)) / length


def extreme_fov(env):
    """Camera rays of scene 0's camera with vertical fields of view of 1e-3 and 179.9 degrees, 64 x 48, at a
    127 x 95 grid of pixel positions from corner to corner plus the centre's row and column; against the
    README's model in float64.

    d = f forward + sx right + sy up, sx = (2x/W - 1) scale_x: the screen coordinate carries at most 5u
    (1/W rounded, a product and a sum), so sx at most 5u scale_x + 2u |sx| (scale_x stored, the product);
    the stored basis and the two mads add at most 4u of each term. So |dd| <= 6u (f + |sx| + |sy| + scale_x
    + scale_y), and the direction moves by at most |dd| / |d|, plus u when normalised: 7u k, k = (f + |sx| +
    |sy| + scale_x + scale_y) / |d|. Near 180 degrees k is large at the centre, where tan(fov/2) magnifies
    the screen coordinate's rounding: the map's conditioning. The length: d.d rounds five times (half that
    in its root), rsqrt to 2 ulp (4u), the product once: ||d| - 1| <= 7.5u."""
    w, h = 64, 48
    x, y = (a.ravel() for a in np.meshgrid(f32([*np.linspace(0, w, 127), w / 2]),
                                           f32([*np.linspace(0, h, 95), h / 2])))
    rows = []
    for fov in (1e-3, 179.9):
        camera = dataclasses.replace(env.cornell.camera, fov_deg=fov)
        args = [camera_struct(camera, w, h), x.astype(np.float32), y.astype(np.float32), np.float32(1 / w),
                np.float32(1 / h)]
        d = env.probe.run(CAMERA, "rays", len(x), args, {"d": 3})["d"].T
        truth, k = camera_truth(camera, x, y, w, h)
        length = np.linalg.norm(d, axis=1)
        rows += [Row(f"fov {fov:g} deg: direction error (of {len(x)}, k up to {k.max():.3g})",
                     float(np.max(np.linalg.norm(d / length[:, None] - truth, axis=1) / (U * k))), "u k", 7,
                     "screen 5u, scale 2u, basis and mads 4u", nonfinite(d)),
                 Row(f"fov {fov:g} deg: |length - 1|", float(np.max(np.abs(length - 1)) / U), "u", 7.5,
                     "d.d 2.5u, rsqrt 4u, product u")]
    return rows


# ---------------------------------------------------------------------------------------------------------
# 8. A camera far away

def seen_from(scene, distance, shift=(0.0, 0.0, 0.0)):
    """`scene` with its camera moved along its axis to `distance` from look_at, its field of view narrowed to
    frame the look_at plane alike, then both camera points moved by `shift`."""
    cam = scene.camera
    axis = cam.position - cam.look_at
    tan_half = np.tan(np.radians(cam.fov_deg) / 2) * np.linalg.norm(axis) / distance
    camera = dataclasses.replace(cam, position=cam.look_at + axis * distance / np.linalg.norm(axis) + shift,
                                 look_at=cam.look_at + shift, fov_deg=float(np.degrees(2 * np.arctan(tan_half))))
    return dataclasses.replace(scene, camera=camera)


def far_camera(env):
    """Scene 0 seen from 1e5 units away on the course camera's axis, through the field of view (1.4e-3
    degrees) that frames the look_at plane as the course camera does; 48 x 48, 16 x 16 grid samples.

    Compared with the view from 1e3 units away on the same axis: float32 moves the far camera's position by
    up to 4e-3, and the near camera is moved alike, so that both share the axis the kernel sees. (The course
    camera itself, 3 units away at 45 degrees, sees another picture: its perspective shows the side walls,
    which the far camera sees edge-on.) From 1e3 to 1e5 units the perspective moves the image of a point at
    depth z and off-axis distance x by x z (1/1e3 - 1/1e5): at most 1.9e-3 units, 0.04 pixels; the near
    camera's own float32 error is 1% of the far one's. What remains is float32 at 1e5 units: one rounding
    there moves a hit point across the ray by u 1e5 = 6e-3 units (0.11 pixels), and the camera ray, the
    crossing's (u, v) and the triangle test's shear each take a few; the ellipsoid's normal, computed from its
    unit-sphere hit 3e5 radii from the ray's origin, tilts by about u 3e5 = 0.02 rad per rounding. A known
    limit, held to what a misregistration by that resolution costs: u 1e5 over the pixel's width in scene
    units (0.12 pixels here) times the RMSE between the near view and itself moved by one pixel (the smaller
    of x and y)."""
    far = seen_from(env.cornell, 1e5)
    image, bad = env.render(far, width=48, height=48, spp=16, light_samples=16)
    moved = f32(far.camera.position) - far.camera.position
    near, bad_near = env.render(seen_from(env.cornell, 1e3, moved), width=48, height=48, spp=16, light_samples=16)
    shifted = min(rmse(near[1:], near[:-1]), rmse(near[:, 1:], near[:, :-1]))
    pixel = 2 * np.tan(np.radians(far.camera.fov_deg) / 2) * 1e5 / 48  # scene units across one pixel
    resolution = 2.0**-24 * 1e5 / pixel
    return [Row("camera 1e5 away, fov 1.4e-3 deg: RMSE against the same view from 1e3 away", rmse(image, near),
                "", resolution * shifted, f"a shift by float32's resolution there, {resolution:.2f} pixels",
                bad + bad_near + nonfinite(image, near), known_limit=True)]


# ---------------------------------------------------------------------------------------------------------
# 9, 10. Image sizes and sample counts at their limits

def image_sizes(env):
    """Scene 0 through raytrace.render at 1 x 1, 1 x 4096 and 4096 x 1 (the last 179.93 degrees wide).

    The 1 x 1 pixel at 16 spp (the 4 x 4 grid) takes exactly the rays of a 4 x 4 image's pixel centres (the
    screen coordinates (k + 1/2) / 4 are exact in both), and the grid's light samples are the same in every
    pixel: it must equal that image's mean up to the kernel's float32 sum of its 16 samples (15 roundings of
    at most the sum) and one rounding of the result: 16u relative. The 1 x 4096 column takes the rays of the
    middle column of a 3 x 4096 image (same height; their screen x differ by one rounding of (2/3) 1.5 - 1, a
    direction change of 1e-11 rad), so its pixels must equal those to a few roundings of the shading: 8u
    relative. Every value lies in [0, brightest()], with no NaN or Inf."""
    cornell, limit = env.cornell, brightest(env.cornell)
    one, bad1 = env.render(cornell, width=1, height=1, spp=16, light_samples=16)
    grid, bad2 = env.render(cornell, width=4, height=4, spp=1, sampler="center", light_samples=16)
    column, bad3 = env.render(cornell, width=1, height=4096, spp=1, sampler="center", light_samples=4)
    wider, bad4 = env.render(cornell, width=3, height=4096, spp=1, sampler="center", light_samples=4)
    row, bad5 = env.render(cornell, width=4096, height=1, spp=1, sampler="center", light_samples=4)
    mean = grid.astype(np.float64).mean(axis=(0, 1))
    return [Row("1 x 1 at 16 spp against the mean of the same rays as a 4 x 4 image: relative",
                float(np.max(np.abs(one[0, 0] - mean) / mean) / U), "u", 16, "the kernel's float32 sum of 16",
                bad1 + bad2 + nonfinite(one, grid)),
            Row("1 x 4096 against the middle column of 3 x 4096: relative",
                float(np.max(np.abs(column[:, 0] - wider[:, 1]) / np.maximum(wider[:, 1], TINY)) / U), "u", 8,
                "the same rays to 1e-11 rad", bad3 + bad4 + nonfinite(column, wider)),
            Row(f"1 x 1, 1 x 4096, 4096 x 1: values outside [0, {limit:.3g}]", outside((one, column, row), limit),
                "values", 0, "max k (ambient + 2 sum L)", bad5 + nonfinite(row))]


def deep_accumulation(env):
    """65536 samples of one value: scene 0's back wall seen head-on through a 1 degree field of view (every
    sample sees it) under a black light (direct light exactly 0: every sample is k ambient = fl(0.7 * 0.1)
    exactly), 8 x 1 pixels, 1 light sample. The mean of 65536 equal float32 values must be that value to
    float32 rounding: the host accumulates in float64 (65536 additions of values below 1 lose at most 65536
    2^-53 of the sum) and rounds the mean to float32 once (u); 1e-6 is about 16u. A float32 sum of many
    samples anywhere on the way would show: a running float32 sum of n equal values drifts by up to n u / 2
    of their mean (2e-4 at n = 32768)."""
    camera = dataclasses.replace(env.cornell.camera, position=np.array([0.0, 0.0, 1.0]),
                                 look_at=np.array([0.0, 1.0, 1.0]), fov_deg=1.0)
    scene = dataclasses.replace(env.cornell, camera=camera,
                                lights=[dataclasses.replace(env.cornell.lights[0], colour=np.zeros(3))])
    single, bad1 = env.render(scene, width=8, height=1, spp=1, light_samples=1)
    deep, bad2 = env.render(scene, width=8, height=1, spp=65536, light_samples=1)
    return [Row("8 x 1 at 65536 spp of a constant against 1 spp: relative",
                float(np.max(np.abs(deep.astype(np.float64) - single) / single)), "", 1e-6,
                "float64 accumulation, one rounding", bad1 + bad2 + nonfinite(single, deep))]


# ---------------------------------------------------------------------------------------------------------
# 11. Degenerate input

ZERO_AREA = [[0.0, 0.0, 0.5], [0.5, 0.5, 1.0], [1.0, 1.0, 1.5]]
SINGULAR = [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.2, 0.4, 0.0]]  # the third axis in the plane of the others
FLAT = [[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.2, 0.2, 6e-7]]     # determinant 2.1e-6 of the axes' lengths
SLIVER = [[-0.6, 0.0, 1.0], [0.6, 0.0, 1.0], [0.0, 2.4e-9, 1.0]]  # area 2e-9 of its longest edge squared
AXES0 = "[[0.3, 0.1, 0.0], [-0.1, 0.3, 0.0], [0.0, 0.0, 0.4]]"     # scene 0's ellipsoid


def with_triangle(text, vertices):
    return text + f'\n[[shapes]]\ntype = "triangle"\nvertices = {vertices}\nmaterial = "white"\n'


def rejected(path, key, value):
    """How many of 9 checks fail for a bad scene file: load_scene raises InputError with its file, key and
    value, in one line (4); `python -m raytrace render FILE -o OUT` exits with 2 and one line on stderr
    naming file, key and value, no traceback, and writes nothing (5)."""
    failed = 0
    try:
        load_scene(path)
        failed += 4
    except InputError as e:
        failed += (e.source != str(path)) + (e.key != key) + (e.value != value) + ("\n" in str(e))
    out = path.parent / "out" / "x.png"
    out.parent.mkdir()
    cli = subprocess.run([sys.executable, "-m", "raytrace", "render", str(path), "-o", str(out)], capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": str(SCENES.parent)})
    failed += (cli.returncode != 2) + (cli.stderr.count("\n") != 1) + (f"{path}: {key} = {value}" not in cli.stderr)
    return failed + ("Traceback" in cli.stderr) + bool(list(out.parent.iterdir()))


def degenerate_input(env):
    """Scene 0's file with a zero-area triangle added, or its ellipsoid made singular (the third axis in the
    plane of the other two): refused at load and on the command line (rejected(), bound 0). The nearly
    degenerate shapes the loader accepts, each just above its threshold: a triangle of area 2e-9 of its
    longest edge squared (2.4e-9 across; the loader refuses 1e-9, so 1e-12 cannot come from a file) and an
    ellipsoid whose axes' determinant is 2.1e-6 of the product of their lengths (1e-6 thick); and, built
    directly, a triangle of area 1e-12 of its edge squared, seen edge-on: rendered 48 x 48, no NaN or Inf,
    every value in [0, brightest()]."""
    text, rows = SCENE0.read_text(), []
    with tempfile.TemporaryDirectory() as tmp:
        for name, edited, key, value in (("zero-area triangle", with_triangle(text, ZERO_AREA), "shapes[7].vertices",
                                          ZERO_AREA),
                                         ("singular ellipsoid", text.replace(AXES0, str(SINGULAR)), "shapes[6].axes",
                                          SINGULAR)):
            path = Path(tmp) / name.replace(" ", "-") / "bad.toml"
            path.parent.mkdir()
            path.write_text(edited)
            rows.append(Row(f"{name} in a scene file: loader and command-line checks failed (of 9)",
                            rejected(path, key, value), "checks", 0, "one line: file, key, value; exit 2"))
        path = Path(tmp) / "nearly.toml"
        path.write_text(with_triangle(text.replace(AXES0, str(FLAT)), SLIVER))
        nearly = load_scene(path)
    needle = Triangle(np.array([[0.0, 0.3, 0.2], [0.0, 0.3, 1.4], [1.2e-12, 0.3, 0.8]]))
    images, bad = [], 0
    for scene in (nearly, dataclasses.replace(env.cornell, triangles=env.cornell.triangles + [needle])):
        image, b = env.render(scene, width=48, height=48, spp=1, sampler="center", light_samples=4)
        images.append(image)
        bad += b + nonfinite(image)
    limit = brightest(nearly)
    rows.append(Row(f"nearly degenerate triangle and ellipsoid, 1e-12 triangle: values outside [0, {limit:.3g}]",
                    outside(images, limit), "values", 0, "max k (ambient + 2 sum L)", bad))
    return rows


# ---------------------------------------------------------------------------------------------------------
# 12. Textures at grazing angles

def textured_grazing(env):
    """The grid floor (scene 1, textured) seen along its plane from 1e-2, 1e-4 and 1e-6 above it and from
    in it, under each texture filter, and the textured shapes (their silhouettes are grazing), 64 x 64: the
    ray differentials divide by d.n, which vanishes there, so that a filter footprint grows without bound.
    No NaN or Inf may reach the image, and every value lies in [0, brightest()] (colour maps are at most 1)."""
    floor, textured = load_scene(SCENES / "grid_floor.toml"), load_scene(SCENES / "textured_shapes.toml")
    images, bad = [], 0
    for height in (1e-2, 1e-4, 1e-6, 0.0):
        camera = dataclasses.replace(floor.camera, position=np.array([0.0, -2.0, height]),
                                     look_at=np.array([0.0, 30.0, height]), fov_deg=10.0)
        for texture_filter in ("nearest", "trilinear", "anisotropic"):
            image, b = env.render(dataclasses.replace(floor, camera=camera), width=64, height=64, spp=4,
                                  light_samples=4, texture_filter=texture_filter)
            images.append(image)
            bad += b + nonfinite(image)
    image, b = env.render(textured, width=64, height=64, spp=4, light_samples=4, texture_filter="anisotropic")
    limit = max(brightest(floor), brightest(textured))
    return [Row(f"grid floor from 1e-2..0 above, 3 filters, and textured shapes: values outside [0, {limit:.3g}]",
                outside(images + [image], limit), "values", 0, "max k (ambient + 2 sum L)", bad + b + nonfinite(image))]


CASES = [mesh_edges, grazing_rectangles, grazing_ellipsoids, extreme_ellipsoids, lights_at_horizon, phong_power,
         extreme_fov, far_camera, image_sizes, deep_accumulation, degenerate_input, textured_grazing]


# ---------------------------------------------------------------------------------------------------------
# The table

def run_case(env, case):
    """One case's rows, each named after the case."""
    rows = case(env)
    for row in rows:
        row.case = case.__name__
    return rows


COLUMNS = "{:<18} {:<84} {:>14} {:>14} {:>7}  {:<11}  {}"


def _amount(value, unit):
    return f"{value:.3g} {unit}".strip() if isinstance(value, float) else f"{value} {unit}".strip()


def format_row(row):
    error, bound = ("", "") if row.skipped else (_amount(row.error, row.unit), _amount(row.bound, row.unit))
    return COLUMNS.format(row.case, row.measured, error, bound, row.nonfinite, row.verdict, row.why)


def report(lanes, device=None, json_path=None, out=sys.stdout):
    """Every case at one lane width, printed row by row as the table; the rows also to `json_path` if given.
    Returns whether no row failed (every one passed, is a known limit or was skipped)."""
    env, start, rows = Env(lanes, device), time.perf_counter(), []
    device_name = env.probe.queue.device.name.strip()
    print(f"raytrace numerical stability: LANES={lanes}, {device_name}", file=out)
    print(COLUMNS.format("case", "measured", "max error", "bound", "NaN/Inf", "verdict", "the bound, argued"),
          file=out, flush=True)
    for case in CASES:
        for row in run_case(env, case):
            rows.append(row)
            print(format_row(row), file=out, flush=True)
    seconds = time.perf_counter() - start
    verdicts = [row.verdict for row in rows]
    counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("pass", "known limit", "skipped", "FAIL"))
    print(f"{len(rows)} rows: {counts}; {seconds:.1f} s", file=out)
    if json_path:
        finite = lambda x: float(x) if np.isfinite(x) else None  # noqa: E731  (JSON has no NaN)
        data = {"lanes": lanes, "device": device_name, "seconds": seconds,
                "rows": [{**dataclasses.asdict(row), "error": finite(row.error), "bound": finite(row.bound),
                          "verdict": row.verdict} for row in rows]}
        Path(json_path).write_text(json.dumps(data, indent=2) + "\n")
    return "FAIL" not in verdicts
