"""Embree as an anchor for `bench --scaling`: `python -m benchmarks.embree_anchor DIR [SCENE]` gives the per-ray cost of Intel's Embree on
the same triangles and the same kinds of rays, so that our cost's growth with the triangle count stands beside
that of a production BVH.

Embree sees every triangle of the scene, a mesh's and the room's rectangles split in two (the lights are not
geometry to it, as to our shadow rays). It traces the primary rays of a width x height image at `spp` uniformly
random pixel sample positions (the camera model of reference_camera.py) with its closest-hit query, then from
each surface hit `light_samples` shadow segments to uniformly random points of each light with its any-hit
query, only where our renderer would cast them (the point faces the light, both by its geometric and its
shading normal, and no light hides it). Scattered rays besides: from every surface hit one bounce ray,
cosine-distributed about the shading normal (the path model's diffuse sample), where it leaves the surface on
the ray's side, with the closest-hit query. Only the queries are timed, each the best of `repeat`.

This is a measuring tool, not a dependency: embreex (PyPI) is imported only where it is used. Its binding traces
one ray at a time on one thread, so its figures are per core; ours use every core of the OpenCL device, so
what compares fairly is how each grows with the triangle count, not the absolute ns per ray."""
import argparse
import sys
import dataclasses
import os
import time

import numpy as np

from raytrace.errors import InputError
from raytrace.renderer.geometry import triangle_soup
from raytrace.scene import Triangle
from raytrace.commands.stability.reference_camera import camera_directions

SHADOW_END = 1 - 1e-4  # shadow segments stop short of the light: an occluder flush with it does not count
OFFSET = 1e-5          # shadow origins leave their surface by this much times the point's largest coordinate


def rectangle_triangles(rect):
    """The rectangle as the two triangles (c0, c1, c2) and (c0, c2, c3) of its corners, counter-clockwise
    seen from its normal's side."""
    tx, ty = rect.size[0] / 2 * rect.tangent, rect.size[1] / 2 * rect.bitangent
    c = [rect.center - tx - ty, rect.center + tx - ty, rect.center + tx + ty, rect.center - tx + ty]
    return [Triangle(np.array([c[0], c[1], c[2]]), rect.material),
            Triangle(np.array([c[0], c[2], c[3]]), rect.material)]


def embree_scene(scene):
    """An Embree scene of every triangle of `scene` and its rectangles (not its lights), with the triangle
    soup (geometry.triangle_soup, the rectangles' triangles first) whose order Embree's primIDs index. The
    binding's default scene flag is Embree's robust (watertight) traversal: kept."""
    try:
        from embreex import mesh_construction, rtcore_scene
    except ImportError:
        raise InputError("environment", "embreex", None, "needs the embreex package: pip install embreex") from None
    if scene.ellipsoids:
        raise InputError(scene.path, "shapes", None, "the Embree anchor takes triangles and rectangles only")
    rects = [t for r in scene.rectangles for t in rectangle_triangles(r)]
    soup = triangle_soup(dataclasses.replace(scene, rectangles=[], triangles=rects + list(scene.triangles)))
    embree = rtcore_scene.EmbreeScene()
    mesh_construction.TriangleMesh(embree, soup.v.astype(np.float32))
    return embree, soup


def camera_rays(scene, width, height, spp, rng):
    """Origins and unit directions (float32, as Embree takes them) of `spp` rays per pixel at uniformly random
    positions in it, pixel by pixel in rows from the top, as our renderer orders them."""
    y, x = np.divmod(np.repeat(np.arange(width * height), spp), width)
    d, _ = camera_directions(scene.camera, x + rng.random(len(x)), y + rng.random(len(y)), width, height)
    return np.broadcast_to(scene.camera.position, d.shape).astype(np.float32), d.astype(np.float32)


def closest_hits(embree, o, d):
    """Embree's closest hits: tfar, primID (-1 on a miss) and barycentrics u, v (of v1 and v2)."""
    return embree.run(o, d, query="INTERSECT", output=True)


def light_distances(lights, o, d):
    """Distance along each ray to the nearest light (inf where it meets none): the renderer sees the light
    there, not the surface Embree finds behind it, and casts no shadow ray from it."""
    t = np.full(len(o), np.inf)
    for light in lights:
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((light.center - o) @ light.normal) / (d @ light.normal)
            rel = o + s[:, None] * d - light.center
            inside = ((s > 0) & (np.abs(rel @ light.tangent) <= light.size[0] / 2)
                      & (np.abs(rel @ light.bitangent) <= light.size[1] / 2))
        t = np.where(inside, np.minimum(t, s), t)
    return t


def surface_frames(soup, hits, d, index):
    """Geometric and shading normals (float64) at hits `index`, both on the side the ray came from; the
    shading normal is the soup's corner normals interpolated, flipped with the face as the kernel does."""
    prim, u, v = hits["primID"][index], hits["u"][index, None], hits["v"][index, None]
    tri = soup.v[prim]
    face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 1])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    side = -np.sign(np.einsum("ij,ij->i", face, d[index]))[:, None]
    corners = soup.normals[prim]
    shading = (1 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]
    return face * side, shading / np.linalg.norm(shading, axis=1, keepdims=True) * side


def surface_points(scene, soup, o, d, hits):
    """Where the rays (o, d) hit a surface before any light (the kernel shades those hits): the points
    (float64), their geometric and shading normals on the rays' side (surface_frames), and the origins of
    rays leaving them, off the surface by OFFSET times the point's largest coordinate."""
    o, d = o.astype(np.float64), d.astype(np.float64)
    t = hits["tfar"].astype(np.float64)
    index = np.nonzero((hits["primID"] >= 0) & (t < light_distances(scene.lights, o, d)))[0]
    p = o[index] + t[index, None] * d[index]
    ng, n = surface_frames(soup, hits, d, index)
    return p, ng, n, p + OFFSET * np.maximum(np.abs(p).max(1), 1.0)[:, None] * ng


def shadow_rays(scene, soup, o, d, hits, light_samples, rng):
    """Shadow segments (float32 origins, directions to the light point, and tfar) from every surface hit to
    `light_samples` uniformly random points of each light, where the kernel would cast them."""
    p, ng, n, origin = surface_points(scene, soup, o, d, hits)
    origins, directions = [], []
    for light in scene.lights:
        for uv in rng.random((light_samples, len(p), 2)):
            q = (light.center + ((uv[:, :1] - 0.5) * light.size[0]) * light.tangent
                 + ((uv[:, 1:] - 0.5) * light.size[1]) * light.bitangent)
            lit = (np.einsum("ij,ij->i", ng, q - p) > 0) & (np.einsum("ij,ij->i", n, q - p) > 0)
            origins.append(origin[lit])
            directions.append(q[lit] - origin[lit])
    o, d = np.concatenate(origins).astype(np.float32), np.concatenate(directions).astype(np.float32)
    return o, d, np.full(len(o), SHADOW_END, np.float32)


def cosine_directions(n, rng):
    """Unit directions about the unit normals n (rows) with density cos(theta) / pi: a uniform point on the unit
    disk lifted to the hemisphere (Malley's method, pbrt-v4 section A.5.3)."""
    r, phi = np.sqrt(rng.random(len(n))), 2 * np.pi * rng.random(len(n))
    x, y = r * np.cos(phi), r * np.sin(phi)
    z = np.sqrt(np.maximum(0.0, 1 - x * x - y * y))
    helper = np.where(np.abs(n[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    return x[:, None] * t + y[:, None] * b + z[:, None] * n


def bounce_rays(scene, soup, o, d, hits, rng):
    """Scattered rays (float32 origins and unit directions): from every surface hit one direction drawn with
    density cos / pi about the shading normal, kept where it leaves the surface on the side the camera ray came
    from (the kernel's rule), its origin off the surface as the shadow rays' are."""
    _, ng, n, origin = surface_points(scene, soup, o, d, hits)
    wi = cosine_directions(n, rng)
    leaves = np.einsum("ij,ij->i", ng, wi) > 0
    return origin[leaves].astype(np.float32), wi[leaves].astype(np.float32)


def unmet_scene(scene, soup):
    """An Embree scene of one small triangle that no ray of `measure` meets (`soup`: embree_scene's, the room's
    triangles with the rectangles', whose extent sets the distance): 10^3 times the room's size behind
    the camera, beyond every camera ray (they all point ahead of it) and every shadow segment (they end at a
    light). Tracing the same rays against it times what a query costs besides Embree's traversal: the binding's
    loop over the rays, each ray's setup and a missed root box (its range on this project's machines: measured
    in commit bc8de19), measured in the same run, so that Embree's growth can be stated net of it."""
    from embreex import mesh_construction, rtcore_scene
    points = np.concatenate([soup.v.reshape(-1, 3), [scene.camera.position],
                             [light.center for light in scene.lights]])
    size = float(np.ptp(points, axis=0).max())
    forward, right, up = scene.camera.basis()
    corner = scene.camera.position - 1e3 * size * forward
    triangle = np.array([corner, corner + size * right, corner + size * up])
    embree = rtcore_scene.EmbreeScene()
    mesh_construction.TriangleMesh(embree, triangle[None].astype(np.float32))
    return embree


def best_seconds(query, repeat):
    """The shortest of `repeat` runs of query(): the least disturbed by whatever else the machine does."""
    seconds = []
    for _ in range(repeat):
        start = time.perf_counter()
        query()
        seconds.append(time.perf_counter() - start)
    return min(seconds)


def measure(scene, width=256, height=256, spp=4, light_samples=4, repeat=3, seed=0):
    """Embree's ns per ray on one core: primary (closest hit), shadow (any hit) and all rays together; the binding's
    own ns a ray (the same rays against unmet_scene) and all rays' net of it; the scattered rays' (bounce_rays,
    closest hit), as measured and net of the binding's cost for them, apart from the others; with
    the ray counts, the fraction of primary rays that hit and of shadow rays blocked (a check that the rays
    are the scene's), and ns_per_ray_all_cores, the all-rays figure divided by this machine's cores (linear
    scaling, an upper bound on what Embree's threads would do), to set beside our absolute figure."""
    rng = np.random.default_rng(seed)
    embree, soup = embree_scene(scene)
    o, d = camera_rays(scene, width, height, spp, rng)
    hits = closest_hits(embree, o, d)  # the first query builds Embree's BVH: not timed
    primary = best_seconds(lambda: closest_hits(embree, o, d), repeat)
    so, sd, tfar = shadow_rays(scene, soup, o, d, hits, light_samples, rng)
    blocked = embree.run(so, sd, tfar, query="OCCLUDED") >= 0
    shadow = best_seconds(lambda: embree.run(so, sd, tfar, query="OCCLUDED"), repeat)
    unmet = unmet_scene(scene, soup)
    binding = (best_seconds(lambda: closest_hits(unmet, o, d), repeat)
               + best_seconds(lambda: unmet.run(so, sd, tfar, query="OCCLUDED"), repeat))
    bo, bd = bounce_rays(scene, soup, o, d, hits, rng)
    bounce = best_seconds(lambda: closest_hits(embree, bo, bd), repeat)
    bounce_binding = best_seconds(lambda: closest_hits(unmet, bo, bd), repeat)
    rays = len(o) + len(so)
    ns_per_ray, binding_ns = (primary + shadow) / rays * 1e9, binding / rays * 1e9
    return {"primary_rays": len(o), "shadow_rays": len(so), "rays": rays, "threads": 1,
            "bounce_rays": len(bo), "bounce_ns_per_ray": bounce / max(len(bo), 1) * 1e9,
            "bounce_net_ns_per_ray": (bounce - bounce_binding) / max(len(bo), 1) * 1e9,
            "primary_ns_per_ray": primary / len(o) * 1e9, "shadow_ns_per_ray": shadow / max(len(so), 1) * 1e9,
            "ns_per_ray": ns_per_ray, "binding_ns_per_ray": binding_ns, "net_ns_per_ray": ns_per_ray - binding_ns,
            "cores": os.cpu_count(), "ns_per_ray_all_cores": ns_per_ray / os.cpu_count(),
            "hit_fraction": float(np.mean(hits["primID"] >= 0)), "blocked_fraction": float(np.mean(blocked))}


def main(argv=None):
    """`bench --scaling`'s table with Embree's columns beside ours."""
    from raytrace.commands.bench import suite_scenes
    from raytrace.commands.scaling import scaling

    p = argparse.ArgumentParser(prog="python -m benchmarks.embree_anchor", description=__doc__.split("\n")[0])
    p.add_argument("out", metavar="DIR", help="where scaling.csv, scaling.png and visits.png go")
    p.add_argument("scene", nargs="?", help="the room and its lights (default: scenes/cornell.toml)")
    p.add_argument("--max-triangles", type=int, default=10**6, help="the largest mesh (default 10^6)")
    args = p.parse_args(argv)
    if not 100 <= args.max_triangles <= 10**7:
        raise InputError("command line", "--max-triangles", args.max_triangles, "must be in [100, 10^7]")
    scaling(args.scene or suite_scenes()[0], args.out, args.max_triangles, out=sys.stdout, anchor=measure)


if __name__ == "__main__":
    from benchmarks import run_rig
    sys.exit(run_rig("benchmarks.embree_anchor", main))
