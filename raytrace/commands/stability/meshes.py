"""Case 1, mesh_edges: a closed mesh, rays through its shared edges and vertices."""
import numpy as np

from ...scene import Triangle
from ...numerics import f32
from .common import Row, closest_hit, hit_nonfinite, shapes, unit


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
