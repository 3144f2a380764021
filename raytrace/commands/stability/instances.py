"""Cases extreme_instances and rays_leaving_instances: a group's triangles placed by instances
(kernels/instances.cl, bvh.cl's two-level traversal) under extreme maps: uniform scales 1e-4 and 1e4, a
1e3 : 1 : 1e-3 scale, a shear, a mirror, each at the origin and 1e4 out. The float64 truths are on the stored
float32 values: the group's vertices, the stored centre, and the float64 map both stored matrices are rounded
from (to_world and its inverse; the rays meet the surface the stored inverse places, the hits are brought back
by the stored map: either may be called the surface, and the bound must hold for both).

Mutations tried (lanes 8): instance_point without the centre's sum (gamma(1) |c| -> 0): Hit.p 7.0e3 Hit.err
from the plane (the mirror at 1e4). One survives: the next origin's term (gamma(6) -> 0) passes every row here,
the local triangle test's own t > dt (ray.h's hit_in_range) turning back the leaving rays' residual crossings;
the term stays, as the bound instance_point argues for an origin carried into the group's space."""
import dataclasses

import numpy as np

from ...numerics import U, f32
from ...renderer.program import Features
from ...scene import load_dict
from .affine_shapes import leaving
from .common import Row, hit_nonfinite, stored, unit
from .probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, planar, scene_args

# A unit square of two triangles in the group's local (x, y) plane, its corners float32 values (moved by a
# placement's local shift in x and y).
QUAD = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]])
FAR = np.array([1.0, -0.7, 0.4])

SHADOW = """
#include "intersect.cl"
__kernel void shadow(int n, SCENE_PARAMETERS, __global const float *o, __global const float *q,
                     __global float *blocked)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    vec3 from = IN3(o);
    Ray r = {from, v3_sub(IN3(q), from)};
    OUT(blocked, MASK_TO_ONE(occluded(&s, r, 0u, (vfloat)(0.0f) == 0.0f)));
}
"""


def rotation(axis, degrees):
    """The rotation about `axis` by `degrees` (Rodrigues)."""
    k = unit(np.asarray(axis, np.float64))
    a = np.radians(degrees)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * cross + (1 - np.cos(a)) * cross @ cross


def placements():
    """(name, 3 x 3 linear part, the placed quad's smallest axis, the quad's local shift) of the extreme maps,
    each turned off the coordinate axes."""
    turn, tilt = rotation([1.0, 2.0, 3.0], 50.0), rotation([0.3, -1.0, 0.2], 23.0)
    shear = np.array([[1.0, 3.0, 0.0], [0.0, 1.0, -2.0], [0.0, 0.0, 1.0]])
    none, away = np.zeros(3), np.array([768.0, -1024.0, 0.0])
    return [("scale 1e-4", 1e-4 * turn, 1e-4, none), ("scale 1e4", 1e4 * turn, 1e4, none),
            ("scale 1e3:1:1e-3", turn @ np.diag([1e3, 1.0, 1e-3]) @ tilt, 1e-3, none),
            ("scale 1e3:1e-3:1 (thin in the plane)", turn @ np.diag([1e3, 1e-3, 1.0]) @ tilt, 1e-3, none),
            ("shear", turn @ shear, float(np.linalg.svd(shear, compute_uv=False).min()), none),
            ("mirror", turn @ np.diag([-1.0, 1.0, 1.0]), 1.0, none),
            ("scale 1e-3, the quad 1280 from the group's origin", 1e-3 * turn, 1e-3, away)]


def instanced(linear, centre, shift):
    """A scene of the quad's group (the quad moved by `shift`) under one instance x -> centre + linear x, and no
    lights."""
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, centre
    scene = load_dict({"camera": {"position": [0.0, -3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                                 "fov": 40.0},
                      "image": {"width": 8, "height": 8}, "materials": {"grey": {"colour": [0.5, 0.5, 0.5]}},
                      "lights": [{"center": [0.0, 0.0, 2.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                                  "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0]}],
                      "groups": {"quad": {"shapes": [{"type": "mesh", "vertices": (QUAD + shift).tolist(),
                                                      "faces": [[0, 1, 2], [0, 2, 3]], "material": "grey"}]}},
                      "shapes": [{"type": "instance", "group": "quad", "matrix": m.tolist()}]})
    return dataclasses.replace(scene, lights=[])  # (a scene file needs one; the rays here should meet none)


def _defines(scene, lanes):
    """The -D options the renderer would build the scene's kernel with, as the probe takes them."""
    options = Features.of(scene, lanes).options()[1:]
    return {o[2:].split("=")[0]: int(o.split("=")[1]) for o in options}


def instance_hit(env, scene, o, d):
    """closest_hit over the scene's two-level tree: {t, p, err, n} of rays (o, d), (n, 3) float32 values."""
    out = env.probe.run(CLOSEST_HIT, "closest", len(o), {**scene_args(scene, features=Features.of(scene, env.lanes)),
                                                          "o": planar(o), "d": planar(d)},
                        CLOSEST_HIT_OUTPUTS, **_defines(scene, env.lanes))
    return {"t": out["t"], "p": out["p"].T, "err": out["err"], "n": out["nrm"].T}


def blocked(env, scene, o, q):
    """occluded() over the scene's tree of the segments o -> q."""
    out = env.probe.run(SHADOW, "shadow", len(o), {**scene_args(scene, features=Features.of(scene, env.lanes)),
                                                    "o": planar(o), "q": planar(q)}, {"blocked": 1},
                        **_defines(scene, env.lanes))
    return out["blocked"] > 0.5


def truth(scene, o, d, shift):
    """Float64 on the stored values for rays (o, d): the placed quad's plane n.(L (x - c)) = n.v0 under the
    float64 map (A, L = A^-1) and under the stored inverse L32 (the surface the rays meet); t where the ray meets
    the first, its unit world normal facing the ray, and the kernel's t error bound dt (see extreme_instances)."""
    inst = scene.instances[0]
    s = scene_args(scene, features=Features.of(scene, 1))["instances"][0]
    a = np.asarray(inst.to_world, np.float64)[:3, :3]
    lo, lo32, c = np.linalg.inv(a), stored(s, "to_local").reshape(3, 3), stored(s, "center")
    n_l = np.array([0.0, 0.0, 1.0])
    oc = o - c
    o_l, d_l = oc @ lo.T, d @ lo.T
    t = -o_l[:, 2] / d_l[:, 2]
    q = o_l + t[:, None] * d_l
    n_w = unit(n_l @ lo)
    n_w = n_w * -np.sign(d @ n_w)[:, None]
    # the local ray's perturbation by the kernel's mapping: the centre's subtraction (1), mat3_apply (5) and L's
    # own rounding (1) of |L| |o - c|; mat3_apply (5) and L's rounding (1) of |L| |d|
    e_o, e_d = 7 * U * np.abs(oc) @ np.abs(lo32).T, 6 * U * np.abs(d) @ np.abs(lo32).T
    moved = (e_o[:, 2] + np.abs(t) * e_d[:, 2]) / np.abs(d_l[:, 2])
    # the crossing's local (x, y) moves by the same perturbation, and by the t error along d_l: a hit is clear
    # where the crossing is twice that from the quad's edges
    error = e_o[:, :2] + np.abs(t)[:, None] * e_d[:, :2] + (moved[:, None] * np.abs(d_l[:, :2]))
    clear = np.all(0.5 - np.abs(q[:, :2] - shift[:2]) > 2 * error, 1)
    return {"t": t, "q": q, "clear": clear, "moved": moved, "dt": moved + triangle_dt(o_l, d_l, t, shift), "L": lo,
            "n": n_w, "L32": lo32, "c": c}


def triangle_dt(o_l, d_l, t, shift):
    """triangle.cl's triangle_t_error in float64 on the quad's triangle the local ray meets (its first-order
    value: the shear of the exact local ray)."""
    v = QUAD + shift
    kz = np.argmax(np.abs(d_l), 1)
    kx, ky = (kz + 1) % 3, (kz + 2) % 3
    rows = np.arange(len(d_l))
    dz = d_l[rows, kz]
    sx, sy, sz = -d_l[rows, kx] / dz, -d_l[rows, ky] / dz, 1 / dz
    q = o_l + t[:, None] * d_l
    tri = np.where((q[:, 1] - shift[1] <= q[:, 0] - shift[0])[:, None, None], v[[0, 1, 2]], v[[0, 2, 3]])
    rel = tri - o_l[:, None, :]
    az = rel[rows[:, None], [[0, 1, 2]], kz[:, None]]
    xs = rel[rows[:, None], [[0, 1, 2]], kx[:, None]] + sx[:, None] * az
    ys = rel[rows[:, None], [[0, 1, 2]], ky[:, None]] + sy[:, None] * az
    zs = az * sz[:, None]
    e = np.stack([xs[:, 1] * ys[:, 2] - ys[:, 1] * xs[:, 2], xs[:, 2] * ys[:, 0] - ys[:, 2] * xs[:, 0],
                  xs[:, 0] * ys[:, 1] - ys[:, 0] * xs[:, 1]], 1)
    g = lambda k: k * U / (1 - k * U)  # noqa: E731
    max_z, max_x, max_y = (np.abs(a).max(1) for a in (zs, xs, ys))
    delta_x, delta_y = g(5) * (max_x + max_z), g(5) * (max_y + max_z)
    delta_e = 2 * (g(2) * max_x * max_y + delta_y * max_x + delta_x * max_y)
    return (3 * (g(3) * np.abs(e).max(1) * max_z + delta_e * max_z + g(3) * max_z * np.abs(e).max(1))
            / np.abs(e.sum(1)) + g(11) * np.abs(t))


def plane_distance(tr, p, lo):
    """Distance of world points p from the placed plane z_local = 0 under the local map lo (float64)."""
    g = lo[2]
    return np.abs((p - tr["c"]) @ g) / np.linalg.norm(g)


def quad_rays(rng, linear, centre, shift, n):
    """Rays from 3 sizes away, from either side, at 0.2 or more to the plane in local space, through local points
    of the quad at least 0.05 from its edges: float32 world values, and the float64 local targets."""
    target = np.column_stack([rng.uniform(-0.45, 0.45, (n, 2)), np.zeros(n)]) + shift
    line = unit(rng.normal(size=(n, 3)))
    line[:, 2] = np.where(np.abs(line[:, 2]) < 0.2, np.copysign(0.2, line[:, 2]), line[:, 2])
    line = unit(line)
    o = f32((target - 3 * line) @ linear.T + centre)
    return o, f32(unit(line @ linear.T))


def resolved(centre, smallest):
    """Whether float32 resolves the placement: its smallest axis 256 float spacings or more at its coordinates."""
    return smallest >= 256 * float(np.spacing(np.float32(np.abs(centre).max() + 1.0)))


@np.errstate(invalid="ignore", divide="ignore")
def extreme_instances(env):
    """The quad's group (two triangles) under one instance each of uniform scales 1e-4 and 1e4, 1e3 : 1 : 1e-3
    (thin along the quad's normal) and 1e3 : 1e-3 : 1 (thin in its plane), a shear (singular values 0.2 .. 4.2)
    and a mirror, every map turned off the axes, at the origin and 1e4 out where float32 resolves it (its
    smallest axis 256 float spacings or more; others listed as skipped). 256 rays each from 3 sizes away through
    the quad's points 0.05 or more from its edges, from both sides: every one a clear hit.

    t: the kernel's t is the exact t of the local ray it computed, within triangle_t_error (pbrt-v4's bound,
    evaluated here to first order on the exact local ray); that local ray differs from the exact one by the
    centre's subtraction (1 rounding), mat3_apply's 5 and L's own storage (1) of |L| |o - c|, and 6 of |L| |d|:
    a move of the plane crossing by (e_o.z + |t| e_d.z) / |d_l.z| (the quad's plane is z = 0). Their sum dt bounds
    the error (row: the worst ratio, at most 1). Hit.p: within Hit.err of the placed plane (both surfaces: under
    the float64 map and under the stored inverse), the bound instance_point argues (row: the worst ratio, at
    most 1). Normal: normalize(L^T n) facing the ray, within (7 kn + 8) u, kn = ||L^T| |n|| / |L^T n|: L's
    storage (1) and mat3_apply_transposed (5) and the stored local normal (1) of |L^T| |n|, carried to the
    unit vector by 1 / |L^T n|, and the normalisation's 8 (extreme_disks_cylinders' rsqrt 4, dot 3, product 1).
    No NaN or Inf."""
    rng = np.random.default_rng(21)
    worst = {key: (0.0, "") for key in ("t", "p", "p32", "n")}
    missed, rays, bad, skipped = 0, 0, 0, []

    def note(key, value, name):
        worst[key] = max(worst[key], (float(value), name))
    for name, linear, smallest, shift in placements():
        for far in (0.0, 1e4):
            label = f"{name} at {far:g}"
            centre = far * FAR
            if not resolved(centre, smallest):
                skipped.append(label)
                continue
            scene = instanced(linear, centre, shift)
            o, d = quad_rays(rng, linear, centre, shift, 1024)
            hit, tr = instance_hit(env, scene, o, d), truth(scene, o, d, shift)
            hits = np.isfinite(hit["t"])
            missed, rays = missed + int(np.count_nonzero(tr["clear"] & ~hits)), rays + int(tr["clear"].sum())
            bad += hit_nonfinite(hit)
            note("t", np.max(np.abs(hit["t"] - tr["t"])[hits] / tr["dt"][hits]), label)
            note("p", np.max(plane_distance(tr, hit["p"][hits], tr["L"]) / hit["err"][hits]), label)
            note("p32", np.max(plane_distance(tr, hit["p"][hits], tr["L32"]) / hit["err"][hits]), label)
            g = np.array([0.0, 0.0, 1.0]) @ tr["L32"]
            kn = np.linalg.norm(np.abs(tr["L32"][2])) / np.linalg.norm(g)
            note("n", np.max(np.linalg.norm(hit["n"] - tr["n"], axis=1)[hits]) / (U * (7 * kn + 8)), label)
    row = lambda key, what, unit_, why: Row(f"{what}, worst at {worst[key][1]}", worst[key][0], unit_, 1.0,  # noqa: E731
                                            why)
    return [Row(f"instanced triangles, extreme maps at 0 and 1e4: clear hits missed (of {rays})", missed, "rays", 0,
                "all clear hits", bad),
            row("t", "t error", "dt", "triangle_t_error and the mapping's"),
            row("p", "Hit.p's distance from the plane placed by the float64 map", "Hit.err", "Hit.err bounds it"),
            row("p32", "Hit.p's distance from the plane the rays meet (stored inverse)", "Hit.err",
                "Hit.err bounds it"),
            row("n", "normal error", "(7 kn + 8) u", "the map's and the normalisation's"),
            Row("not resolved: " + ", ".join(skipped), 0, "", 0, "under 256 float spacings across", skipped=True)]


def rays_leaving_instances(env):
    """Rays that leave the instanced quad (extreme_instances' maps and places) where rays from 3 sizes away hit it,
    from offset_ray_origin's origins (affine_shapes.leaving: p + Hit.err n, one float further), in random
    directions to either side: back towards the incoming ray, and through the surface. A plane is never met
    again: no self-hit. And shadow segments from those origins to points 10 sizes away on the side they leave
    to (occluded() through the two-level tree): none blocked, the quad being all the scene holds."""
    rng = np.random.default_rng(22)
    again = shadowed = rays = segments = 0
    worst = ""
    for name, linear, smallest, shift in placements():
        for far in (0.0, 1e4):
            centre = far * FAR
            if not resolved(centre, smallest):
                continue
            scene = instanced(linear, centre, shift)
            o, d = quad_rays(rng, linear, centre, shift, 256)
            hit = instance_hit(env, scene, o, d)
            h = np.isfinite(hit["t"])
            sub = {k: v[h] for k, v in hit.items()}
            size = np.linalg.norm(linear, 2)
            for side in (1, -1):
                dirs = unit(rng.normal(size=(int(h.sum()), 3)))
                dirs *= np.sign(np.sum(dirs * sub["n"], 1))[:, None] * side
                start = f32(leaving(sub, side))
                met = np.isfinite(instance_hit(env, scene, start, f32(dirs))["t"])
                q = f32(sub["p"] + 10 * size * dirs)
                shade = blocked(env, scene, start, q)
                if met.any() or shade.any():
                    worst += f" {name} at {far:g} side {side}: {int(met.sum())} hits, {int(shade.sum())} blocked;"
                again, shadowed = again + int(np.count_nonzero(met)), shadowed + int(np.count_nonzero(shade))
                rays, segments = rays + len(dirs), segments + len(dirs)
    return [Row(f"the instanced quad met again by rays leaving it, either side (of {rays}){worst}", again, "rays",
                0, "a plane is not met twice"),
            Row(f"shadow segments from it blocked by it (of {segments})", shadowed, "segments", 0,
                "the segment leaves the plane")]
