"""Cases 3 and 4, grazing_ellipsoids and extreme_ellipsoids: grazing rays on an ellipsoid; extreme axis ratios,
scales and distances."""
import numpy as np

from ...scene import Ellipsoid
from ...numerics import U, f32
from ...renderer.packing import ellipsoid_structs
from .common import Row, closest_hit, hit_nonfinite, shapes, stored, unit


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
