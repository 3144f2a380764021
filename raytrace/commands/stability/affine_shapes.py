"""Cases grazing_disks_cylinders, extreme_disks_cylinders and rays_leaving_disks_cylinders: Mitsuba's disk and
cylinder (kernels/disk.cl, cylinder.cl) at their edges and silhouettes, at extreme scales and distances, and
for rays that leave them. The float64 truths here are on the stored float32 values (tests/test_disk.py and
tests/test_cylinder.py use them too).

Mutations tried (each fails a row here, lanes 8): cylinder_point's bound gamma(16) -> gamma(1) (Hit.p 2.15
Hit.err from the tube; 2 rays leaving meet the cylinder again); disk_point's gamma(8) -> gamma(1) (Hit.p 1.22
Hit.err from the plane). One survives: cylinder_roots without its origin-on-the-surface test (|c| <= dc never
true) passes, the offset origins being clear of the surface by more than c's rounding in every ray here; the
test stays as ellipsoid.cl's does, for origins that are not offset."""
import numpy as np

from ...scene import Cylinder, Disk
from ...numerics import U, f32
from ...renderer.packing import affine_shape_structs
from .common import Row, closest_hit, hit_nonfinite, shapes, stored, unit


def _local(s, o, d):
    """(c, L, A, o_l = L (o - c), d_l = L d, |L| |o - c|, |L| |d|) of the stored shape s for rays (o, d)."""
    c, lo, a = stored(s, "center"), stored(s, "to_local").reshape(3, 3), stored(s, "to_world").reshape(3, 3)
    oc = o - c
    return c, lo, a, oc @ lo.T, d @ lo.T, np.abs(oc) @ np.abs(lo).T, np.abs(d) @ np.abs(lo).T


def disk_truth(s, o, d):
    """Float64 on the stored disk s for rays (o, d): {t: the plane crossing within the disk, ahead (NaN for a
    miss); r: its local radius; dt: intersect_disk's first-order bound on its t error, (6u |L_z| |o - c| + 5u
    |t| |L_z| |d|) / |d_l.z| + 6u |t|; edge: a bound on the local radius's error (dt along d_l plus o_l's 6
    roundings); n: the unit normal (normal_sign L_z); L, c}."""
    c, lo, _, ol, dl, so, sd = _local(s, o, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -ol[:, 2] / dl[:, 2]
        q = ol + t[:, None] * dl
        r = np.hypot(q[:, 0], q[:, 1])
        dt = (6 * U * so[:, 2] + 5 * U * np.abs(t) * sd[:, 2]) / np.abs(dl[:, 2]) + 6 * U * np.abs(t)
    edge = dt * np.linalg.norm(dl, axis=1) + 6 * U * np.linalg.norm(so, axis=1) + 2 * U * np.abs(t) * np.linalg.norm(sd, axis=1)
    t = np.where((t > 0) & (r <= 1), t, np.nan)
    n = unit(lo[2]) * float(s["normal_sign"])
    return {"t": t, "r": r, "dt": dt, "edge": edge, "n": np.broadcast_to(n, o.shape), "L": lo, "c": c}


def disk_distance(s, p):
    """Distance of points p from the stored disk's plane L_z (x - c) = 0."""
    lo = stored(s, "to_local").reshape(3, 3)
    return np.abs((p - stored(s, "center")) @ lo[2]) / np.linalg.norm(lo[2])


def cylinder_truth(s, o, d):
    """Float64 on the stored cylinder s for rays (o, d), roots chosen as cylinder_roots chooses them (the near
    one if ahead and within 0 <= z <= 1, else the far one if it is): {t (NaN for none); b2: the squared distance
    of the ray's line from the axis in local (x, y); z: the chosen root's local z; S: | |L| |o - c| | + |t|
    | |L| |d| |, S_c the same at the closest approach; o_l, d_l, L, c, sign}."""
    c, lo, _, ol, dl, so, sd = _local(s, o, d)
    a, h = np.sum(dl[:, :2] ** 2, 1), np.sum(ol[:, :2] * dl[:, :2], 1)
    cc = np.sum(ol[:, :2] ** 2, 1) - 1
    with np.errstate(divide="ignore", invalid="ignore"):
        f = ol[:, :2] - (h / a)[:, None] * dl[:, :2]
        b2 = np.sum(f * f, 1)
        root = -(h + np.copysign(np.sqrt(np.maximum(a * (1 - b2), 0)), h))
        t0, t1 = root / a, cc / root
    near, far = np.minimum(t0, t1), np.maximum(t0, t1)
    z_near, z_far = ol[:, 2] + near * dl[:, 2], ol[:, 2] + far * dl[:, 2]
    on_near = (b2 <= 1) & (near > 0) & (z_near >= 0) & (z_near <= 1)
    on_far = (b2 <= 1) & (far > 0) & (z_far >= 0) & (z_far <= 1)
    t = np.where(on_near, near, np.where(on_far, far, np.nan))
    z = np.where(on_near, z_near, z_far)
    norm = lambda v: np.linalg.norm(v, axis=1)  # noqa: E731
    with np.errstate(invalid="ignore"):
        return {"t": t, "b2": b2, "z": z, "o_l": ol, "d_l": dl, "d": d, "L": lo, "c": c, "S_o": norm(so), "S_d": norm(sd),
                "inside": cc < 0, "far_root": np.where(b2 <= 1, far, np.nan),
                "S": norm(so) + np.abs(np.nan_to_num(t)) * norm(sd), "S_c": norm(so) + np.abs(h / a) * norm(sd),
                "sign": float(s["normal_sign"])}


def cylinder_clear(truth):
    """Where float64's hit or miss is clear: the silhouette as grazing_ellipsoids' ellipsoid_clear (|1 - b2|
    over twice the rounding of the kernel's 1 - |f|^2: 16u S_c + 5u), and the chosen root's z at least
    twice its rounding (8u S in local units, the mapping's 6 and the sum's 2) from the open ends."""
    z = truth["z"]
    ends = np.minimum(np.abs(z), np.abs(z - 1))
    return (np.abs(1 - truth["b2"]) > 2 * (16 * U * truth["S_c"] + 5 * U)) & ~(ends <= 2 * 8 * U * truth["S"])


@np.errstate(invalid="ignore", divide="ignore")
def cylinder_t_error(hit_t, truth):
    """The kernel's t error in u kt, kt = S / |q.d_l| + |t| (q.d_l in (x, y): the root's condition number),
    grazing_ellipsoids' measure."""
    t = truth["t"]
    q = truth["o_l"][:, :2] + t[:, None] * truth["d_l"][:, :2]
    return np.abs(hit_t - t) / (U * (truth["S"] / np.abs(np.sum(q * truth["d_l"][:, :2], 1)) + np.abs(t)))


@np.errstate(invalid="ignore", divide="ignore")
def cylinder_normal_error(hit_t, hit_n, truth):
    """The kernel's normal error in u kn against normalize(L^T (q.x, q.y, 0)) at its own t, facing the ray;
    kn = (|L| S + | |L^T| |q| |) / |L^T q| + 1, ellipsoids.py's normal_error."""
    lo = truth["L"]
    q = truth["o_l"] + hit_t[:, None] * truth["d_l"]
    q[:, 2] = 0
    g = q @ lo
    n = unit(g) * -np.sign(np.sum(g * truth["d"], 1))[:, None]
    kn = (np.linalg.norm(lo, 2) * truth["S"] + np.linalg.norm(np.abs(q) @ np.abs(lo), axis=1)) / np.linalg.norm(g, axis=1)
    return np.linalg.norm(hit_n - n, axis=1) / (U * (kn + 1))


def cylinder_distance(s, p):
    """Distance of points p from the stored tube |L_xy (x - c)| = 1 along the normal line through p, exactly:
    the root nearest 0 of a quadratic in x (ellipsoids.py's surface_distance, in (x, y))."""
    w = stored(s, "to_local").reshape(3, 3)[:2]
    qp = (p - stored(s, "center")) @ w.T
    wg = unit(qp @ w) @ w.T
    a, b, cc = np.sum(wg * wg, 1), np.sum(qp * wg, 1), np.sum(qp * qp, 1) - 1
    return np.abs(cc / (b + np.copysign(np.sqrt(b * b - a * cc), b)))


def skewed(rng, scale, ratio):
    """A 4 x 4 to_world: rotation, scales (1, 1 / sqrt(ratio), 1 / ratio) times `scale`, rotation (non-uniform
    and not aligned with the local axes)."""
    q1, q2 = np.linalg.qr(rng.normal(size=(3, 3)))[0], np.linalg.qr(rng.normal(size=(3, 3)))[0]
    m = np.eye(4)
    m[:3, :3] = scale * q1 @ np.diag([1.0, ratio**-0.5, 1.0 / ratio]) @ q2
    return m


def placed(m, centre):
    m = m.copy()
    m[:3, 3] = centre
    return m


def disk_rays(rng, disk, n, radius, away):
    """Rays from `away` (in disk radii, from the centre) through local points at radius `radius` (scalar or
    per ray) of the disk, in world space."""
    m = disk.matrix
    phi = rng.uniform(0, 2 * np.pi, n)
    target = np.stack([radius * np.cos(phi), radius * np.sin(phi), np.zeros(n)], 1) @ m[:3, :3].T + m[:3, 3]
    line = unit(rng.normal(size=(n, 3)))
    size = np.linalg.norm(m[:3, :2], 2)
    return target - away * size * line, line


def cylinder_rays(rng, cylinder, n, foot_radius, away, z=(0.05, 0.95)):
    """Rays whose line passes at local distance foot_radius from the axis (scalar or per ray), at a local
    height in `z`, starting `away` (in cylinder sizes) before that point."""
    m = cylinder.matrix
    line = unit(rng.normal(size=(n, 3)))  # local directions, not along the axis
    line[:, 2] *= 0.5
    line = unit(line)
    perp = unit(np.cross(line, [0.0, 0.0, 1.0]))
    foot = perp * np.reshape(foot_radius, (-1, 1))
    foot[:, 2] = rng.uniform(*z, n)
    o_l = foot - away * line * 2
    return f32(o_l @ m[:3, :3].T + m[:3, 3]), f32(unit(line @ m[:3, :3].T))


def grazing_disks_cylinders(env):
    """A disk and a cylinder under skewed non-uniform maps; rays through the disk's edge at local radius 1 -+
    1e-3 .. 1e-6, and lines passing the cylinder's axis at 1 -+ 1e-3 .. 1e-6 (its silhouette), from 3 and 300
    sizes away. Truth: float64 on the same float32 values.

    Disk: hit or miss agrees wherever the local radius is further from 1 than twice its rounding bound (edge);
    t within intersect_disk's own first-order bound dt (ratio <= 1: the bound the kernel's self-hit test relies
    on). Cylinder: hit or miss agrees where clear (cylinder_clear), t within 17u kt (the argument of
    grazing_ellipsoids, in (x, y)). No NaN or Inf."""
    rng = np.random.default_rng(11)
    disk = Disk(placed(skewed(rng, 0.7, 10.0), [0.1, 0.2, -0.1]))
    cyl = Cylinder(placed(skewed(rng, 0.7, 10.0), [0.1, -0.3, 0.2]), radius=0.8, p1=np.array([0.1, 0.2, 1.5]))
    o, d, ro, rd = [], [], [], []
    for delta in (1e-3, 1e-4, 1e-5, 1e-6):
        for side in (-1, 1):
            for away in (3, 300):
                a, b = disk_rays(rng, disk, 128, 1 + side * delta, away)
                o.append(a), d.append(b)
                a, b = cylinder_rays(rng, cyl, 128, 1 + side * delta, away)
                ro.append(a), rd.append(b)
    o, d, ro, rd = (f32(np.concatenate(a)) for a in (o, d, ro, rd))
    ks, cs = affine_shape_structs([disk])[0], affine_shape_structs([cyl])[0]
    hit, truth = closest_hit(env, shapes(env, disks=[disk]), o, d), disk_truth(ks, o, d)
    clear = np.abs(truth["r"] - 1) > 2 * truth["edge"]
    wrong = clear & (np.isfinite(hit["t"]) != np.isfinite(truth["t"]))
    both = np.isfinite(hit["t"]) & np.isfinite(truth["t"])
    chit, ctruth = closest_hit(env, shapes(env, cylinders=[cyl]), ro, rd), cylinder_truth(cs, ro, rd)
    cclear, cboth = cylinder_clear(ctruth), np.isfinite(chit["t"]) & np.isfinite(ctruth["t"])
    cwrong = cclear & (np.isfinite(chit["t"]) != np.isfinite(ctruth["t"]))
    return [Row(f"disk edge 1e-3..1e-6: hit/miss against float64 where clear ({np.count_nonzero(clear)} of {len(o)})",
                int(np.count_nonzero(wrong)), "rays", 0, "clear: |r - 1| over twice its rounding", hit_nonfinite(hit)),
            Row(f"disk edge: t error ({np.count_nonzero(both)} hits)",
                float(np.max(np.abs(hit["t"] - truth["t"])[both] / truth["dt"][both])), "dt", 1,
                "intersect_disk's own bound"),
            Row(f"cylinder silhouette 1e-3..1e-6: hit/miss where clear ({np.count_nonzero(cclear)} of {len(ro)})",
                int(np.count_nonzero(cwrong)), "rays", 0, "clear: silhouette and ends over twice their rounding",
                hit_nonfinite(chit)),
            Row(f"cylinder silhouette: t error ({np.count_nonzero(cboth)} hits)",
                float(np.max(cylinder_t_error(chit["t"], ctruth)[cboth])), "u kt", 17, "as grazing_ellipsoids")]


def extreme_disks_cylinders(env):
    """Disks and cylinders under maps of scales 1e-4, 1, 1e4 and axis ratios 1 and 1e2 (non-uniform, skewed),
    at the origin and 1e4 out, where float32 resolves them (the smallest axis at least 256 float spacings at
    the largest coordinate; the others listed as skipped). Rays from 3 sizes away through points at local
    radius <= 0.9 (disk) and lines at <= 0.9 from the axis (cylinder): every one a clear hit.

    Disk: t within its own bound dt; Hit.p within Hit.err of the stored plane; the normal within 8u of
    normal_sign normalize(L_z) facing the ray (rsqrt as 4, the dot 3, the product 1). Cylinder: t within 17u
    kt, the normal within 9u kn (extreme_ellipsoids' arguments), Hit.p within Hit.err of the stored tube."""
    rng = np.random.default_rng(12)
    worst = {key: (0.0, "") for key in ("dt", "dp", "dn", "ct", "cn", "cp")}
    missed, rays, bad, skipped = 0, 0, 0, []

    def note(key, value, name):
        worst[key] = max(worst[key], (float(value), name))
    for ratio in (1.0, 1e2):
        for scale in (1e-4, 1.0, 1e4):
            for far in (0.0, 1e4):
                name = f"r {ratio:g} s {scale:g} at {far:g}"
                centre = far * np.array([1.0, -0.7, 0.4]) + scale * np.array([0.1, 0.2, -0.1])
                spacing = float(np.spacing(np.float32(np.abs(centre).max() + scale)))
                if scale / ratio < 256 * spacing:
                    skipped.append(f"{name} ({scale / ratio / spacing:.2g})")
                    continue
                m = placed(skewed(rng, scale, ratio), centre)
                disk, cyl = Disk(m, flip_normals=ratio > 1), Cylinder(m, flip_normals=ratio > 1)
                o, d = disk_rays(rng, disk, 256, 0.9 * np.sqrt(rng.uniform(size=256)), 3)
                o, d = f32(o), f32(d)
                ks = affine_shape_structs([disk])[0]
                hit, truth = closest_hit(env, shapes(env, disks=[disk]), o, d), disk_truth(ks, o, d)
                hits = np.isfinite(hit["t"])
                missed, rays, bad = missed + int(np.count_nonzero(~hits)), rays + len(o), bad + hit_nonfinite(hit)
                note("dt", np.max(np.abs(hit["t"] - truth["t"])[hits] / truth["dt"][hits]), name)
                note("dp", np.max(disk_distance(ks, hit["p"][hits]) / hit["err"][hits]), name)
                facing = truth["n"] * -np.sign(np.sum(truth["n"] * d, 1))[:, None]
                note("dn", np.max(np.linalg.norm(hit["n"] - facing, axis=1)[hits]) / U, name)
                ro, rd = cylinder_rays(rng, cyl, 256, 0.9 * np.sqrt(rng.uniform(size=256)), 3)
                cs = affine_shape_structs([cyl])[0]
                chit, ctruth = closest_hit(env, shapes(env, cylinders=[cyl]), ro, rd), cylinder_truth(cs, ro, rd)
                clear = cylinder_clear(ctruth) & np.isfinite(ctruth["t"])
                both = clear & np.isfinite(chit["t"])
                missed, rays = missed + int(np.count_nonzero(clear & ~np.isfinite(chit["t"]))), rays + int(clear.sum())
                bad += hit_nonfinite(chit)
                note("ct", np.max(cylinder_t_error(chit["t"], ctruth)[both]), name)
                note("cn", np.max(cylinder_normal_error(chit["t"], chit["n"], ctruth)[both]), name)
                note("cp", np.max(cylinder_distance(cs, chit["p"][both]) / chit["err"][both]), name)
    row = lambda key, what, unit_, bound, why: Row(f"{what}, worst at {worst[key][1]}", worst[key][0], unit_,  # noqa: E731
                                                   bound, why)
    return [Row(f"scales 1e-4..1e4, ratios to 1e2, at 0 and 1e4: clear hits missed (of {rays})", missed, "rays", 0,
                "all clear hits", bad),
            row("dt", "disk t error", "dt", 1, "intersect_disk's own bound"),
            row("dp", "disk Hit.p's distance from the plane", "Hit.err", 1, "Hit.err bounds it"),
            row("dn", "disk normal error", "u", 8, "rsqrt 4, dot 3, product 1"),
            row("ct", "cylinder t error", "u kt", 17, "as grazing_ellipsoids"),
            row("cn", "cylinder normal error", "u kn", 9, "as extreme_ellipsoids"),
            row("cp", "cylinder Hit.p's distance from the tube", "Hit.err", 1, "Hit.err bounds it"),
            Row("not resolved (spacings across): " + ", ".join(skipped), 0, "", 0,
                "under 256 float spacings across", skipped=True)]


def leaving(hit, side):
    """Origins of rays leaving the hits to `side` (+1: the side of Hit.n, towards the incoming ray; -1: through
    the surface), as ray.h's offset_ray_origin forms them: p + err n, rounded one float further."""
    n = hit["n"] * side
    o = f32(hit["p"] + hit["err"][:, None] * n).astype(np.float32)
    away = np.where(n > 0, np.inf, -np.inf).astype(np.float32)
    return np.where((n != 0) & (hit["err"][:, None] > 0), np.nextafter(o, away), o).astype(np.float64)


@np.errstate(invalid="ignore", divide="ignore")
def rays_leaving_disks_cylinders(env):
    """Rays that leave a disk and a cylinder (skewed non-uniform maps, scales 1e-4, 1 and 1e4, at 0 and 1e4 out)
    where camera-like rays hit them, in random directions of either side: back towards the incoming ray, and
    through the surface. A disk is never met again. A cylinder from outside, leaving outwards, neither; leaving
    inwards (or from inside, inwards) it meets the far wall: t against float64 from the same origin (its
    larger root, the origin being inside the tube) within 17u kt, where that root is a clear hit (cylinder_clear:
    a ray leaving nearly along the wall grazes it); a self-hit is any t below half of that root (any t at all
    where it is not ahead). Also rays from inside,
    from points on the axis: every one within the tube's height hits it."""
    rng = np.random.default_rng(13)
    again_disk = self_hits = far_missed = far_rays = rays = inside_missed = 0
    worst = (0.0, "")
    for scale in (1e-4, 1.0, 1e4):
        for far in (0.0, 1e4):
            name = f"s {scale:g} at {far:g}"
            centre = far * np.array([1.0, -0.7, 0.4])
            if scale < 256 * float(np.spacing(np.float32(np.abs(centre).max() + scale))):
                continue
            m = placed(skewed(rng, scale, 4.0), centre)
            disk, cyl = Disk(m), Cylinder(m, flip_normals=True)
            o, d = disk_rays(rng, disk, 256, 0.95 * np.sqrt(rng.uniform(size=256)), 3)
            hit = closest_hit(env, shapes(env, disks=[disk]), f32(o), f32(d))
            h = np.isfinite(hit["t"])
            for side in (1, -1):
                dirs = unit(rng.normal(size=(int(h.sum()), 3)))
                dirs *= np.sign(np.sum(dirs * hit["n"][h], 1))[:, None] * side
                again = closest_hit(env, shapes(env, disks=[disk]), f32(leaving({k: v[h] for k, v in hit.items()},
                                                                                 side)), f32(dirs))
                again_disk += int(np.count_nonzero(np.isfinite(again["t"])))
                rays += len(dirs)
            cs = affine_shape_structs([cyl])[0]
            for foot in (0.5, 0.95):  # lines crossing the tube: hits from outside, or inside after an open end
                ro, rd = cylinder_rays(rng, cyl, 256, foot * np.sqrt(rng.uniform(size=256)), 3)
                hit = closest_hit(env, shapes(env, cylinders=[cyl]), ro, rd)
                h = np.isfinite(hit["t"])
                sub = {k: v[h] for k, v in hit.items()}
                for side in (1, -1):
                    dirs = unit(rng.normal(size=(int(h.sum()), 3)))
                    dirs *= np.sign(np.sum(dirs * sub["n"], 1))[:, None] * side
                    lo = f32(leaving(sub, side))
                    again = closest_hit(env, shapes(env, cylinders=[cyl]), lo, f32(dirs))
                    truth = cylinder_truth(cs, lo, f32(dirs))
                    ol, dl = truth["o_l"], truth["d_l"]
                    # an origin inside the tube (leaving inwards) meets it at its larger root, one outside
                    # (leaving outwards) nowhere ahead
                    t_far = np.where(truth["inside"], truth["far_root"], -np.inf)
                    far_truth = {**truth, "t": t_far, "z": ol[:, 2] + t_far * dl[:, 2],
                                 "S": truth["S_o"] + np.where(np.isfinite(t_far), np.abs(t_far), 0) * truth["S_d"]}
                    expected = (t_far > 0) & (far_truth["z"] >= 0) & (far_truth["z"] <= 1) & cylinder_clear(far_truth)
                    got = again["t"]
                    self_hits += int(np.count_nonzero(got < np.where(t_far > 0, 0.5 * t_far, np.inf)))
                    far_missed += int(np.count_nonzero(expected & ~np.isfinite(got)))
                    far_rays += int(expected.sum())
                    rays += len(dirs)
                    ok = expected & np.isfinite(got)
                    if ok.any():
                        worst = max(worst, (float(np.max(cylinder_t_error(got, far_truth)[ok])), name))
            axis = np.stack([np.zeros(256), np.zeros(256), rng.uniform(0.2, 0.8, 256)], 1) @ m[:3, :3].T + m[:3, 3]
            dirs = np.stack([rng.normal(size=256), rng.normal(size=256), np.zeros(256)], 1) @ m[:3, :3].T
            inside = closest_hit(env, shapes(env, cylinders=[cyl]), f32(axis), f32(unit(dirs)))
            inside_missed += int(np.count_nonzero(~np.isfinite(inside["t"])))
    return [Row(f"a disk met again by rays leaving it, either side (of {rays} rays in all)", again_disk, "rays", 0,
                "a plane is not met twice"),
            Row("a cylinder met again at t below half its far wall", self_hits, "rays", 0, "Hit.err offsets, and the "
                "origin's own error bound in cylinder_roots"),
            Row(f"the far wall missed where float64 clearly meets it (of {far_rays})", far_missed, "rays", 0,
                "clear as cylinder_clear"),
            Row(f"far wall t error, worst at {worst[1]}", worst[0], "u kt", 17, "as grazing_ellipsoids"),
            Row("rays from the axis outwards that miss the tube", inside_missed, "rays", 0, "every one meets it")]
