"""Independent float64 numpy reference renderer (docs/model.md: camera, shapes, shading), for the kernel's tests.

Plain and vectorised over N rays; loops only over shapes, lights and light samples. It takes the
raytrace.scene objects as input but imports nothing of the renderer, so a bug in the renderer's own
host code cannot hide in both the kernel and this file; the float64 camera model is the one the stability
suite shares (raytrace/commands/stability/reference_camera.py).
"""
import numpy as np

from raytrace.commands.stability.reference_camera import camera_directions


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --- 1. camera -----------------------------------------------------------------------------------------

def camera_rays(scene, x, y, width=None, height=None):
    """Primary rays through continuous pixel coordinates (x, y); row 0 at the top. width/height override
    the scene's (render() passes them so the aspect follows the requested image)."""
    w = scene.width if width is None else width
    h = scene.height if height is None else height
    d, _ = camera_directions(scene.camera, x, y, w, h)
    return np.broadcast_to(scene.camera.position, d.shape).copy(), d


FOOTPRINT_GRID = 6  # floor_footprint's points per pixel and axis


def floor_footprint(scene):
    """(o, d, t, p): the camera rays of a FOOTPRINT_GRID x FOOTPRINT_GRID grid in each pixel (row by row of the
    image, then of the grid) and where they meet the floor z = 0, for a closed form averaged over each pixel's
    footprint (pixel_means); every ray meets the floor ahead, within 10 of the origin."""
    k = FOOTPRINT_GRID
    ys, xs = np.mgrid[0:scene.height * k, 0:scene.width * k]
    o, d = camera_rays(scene, (xs.ravel() + 0.5) / k, (ys.ravel() + 0.5) / k)
    t = -o[:, 2] / d[:, 2]
    p = o + t[:, None] * d
    assert np.all(t > 0) and np.abs(p[:, :2]).max() < 10
    return o, d, t, p


def pixel_means(scene, value):
    """floor_footprint's per-ray RGB values averaged over each pixel: H x W x 3."""
    k = FOOTPRINT_GRID
    return value.reshape(scene.height, k, scene.width, k, 3).mean(axis=(1, 3))


# --- 2. geometry ---------------------------------------------------------------------------------------

def intersect_rectangle(rect, o, d, tmin, tmax):
    """t of the hit with a rectangle (or Light), np.inf on a miss; edges count as hits."""
    n = rect.normal
    denom = d @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((rect.center - o) @ n) / denom
    ok = (denom != 0) & (t >= tmin) & (t <= tmax)       # parallel rays miss (denom == 0)
    t = np.where(ok, t, np.inf)
    rel = o + np.where(ok, t, 0)[:, None] * d - rect.center
    ok &= (np.abs(rel @ rect.tangent) <= rect.size[0] / 2) & (np.abs(rel @ rect.bitangent) <= rect.size[1] / 2)
    return np.where(ok, t, np.inf)


def intersect_triangle(vertices, o, d, tmin, tmax):
    """Moller-Trumbore in float64. Returns (t, b1, b2); t = inf on a miss. Both faces hit; edges and
    vertices are inclusive (b1 >= 0, b2 >= 0, b1 + b2 <= 1)."""
    v0, v1, v2 = np.asarray(vertices, dtype=np.float64)
    e1, e2 = v1 - v0, v2 - v0
    pvec = np.cross(d, e2)
    det = pvec @ e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - v0
        b1 = _dot(s, pvec) * inv
        qvec = np.cross(s, e1)
        b2 = _dot(d, qvec) * inv
        t = (qvec @ e2) * inv
    ok = (det != 0) & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t >= tmin) & (t <= tmax)
    return np.where(ok, t, np.inf), b1, b2


def intersect_ellipsoid(ell, o, d, tmin, tmax):
    """Returns (t, unit normal). The ray goes into unit-sphere space by x -> inv(M) (x - centre); the
    direction is NOT renormalised, so t is the same parameter in both spaces."""
    m_inv = np.linalg.inv(ell.matrix)
    os_ = (o - ell.center) @ m_inv.T
    ds = d @ m_inv.T
    a = _dot(ds, ds)
    hb = _dot(os_, ds)                                   # half of the linear coefficient
    c = _dot(os_, os_) - 1
    # disc = hb^2 - a c, written as a (1 - |f|^2) with f the point of closest approach to the centre: the
    # direct form cancels badly when the origin is far from the ellipsoid (Ray Tracing Gems, ch. 7).
    f = os_ - (hb / a)[:, None] * ds
    disc = a * (1 - _dot(f, f))
    root = np.sqrt(np.maximum(disc, 0))
    # Stable form: q = -(hb + sign(hb) sqrt(disc)); roots q/a and c/q (no cancellation in either).
    q = -(hb + np.copysign(root, hb))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = q / a
        r2 = np.where(q != 0, c / q, r1)                  # q == 0 only for a double root at 0
    near, far = np.minimum(r1, r2), np.maximum(r1, r2)
    hit = disc >= 0
    t = np.where(hit & (near >= tmin) & (near <= tmax), near,
                 np.where(hit & (far >= tmin) & (far <= tmax), far, np.inf))
    qs = os_ + np.where(np.isfinite(t), t, 0)[:, None] * ds
    normal = _normalize(qs @ m_inv)                       # rows: (inv(M).T @ q).T = q.T @ inv(M)
    return t, normal


def closest_hit(scene, o, d, tmin=1e-9, tmax=np.inf, include_lights=True):
    """Nearest hit over all shapes (and lights). Normals are face-forwarded (dot(normal, d) <= 0).
    Ties go to the shape met first in the order rectangles, triangles, ellipsoids, lights (strict <)."""
    n = len(o)
    best = np.full(n, np.inf)
    normal = np.zeros((n, 3))
    material = np.full(n, -1)
    light = np.full(n, -1)

    def take(t, nrm, mat, lit):
        closer = t < best
        best[closer] = t[closer]
        normal[closer] = nrm[closer] if np.ndim(nrm) == 2 else nrm
        material[closer] = mat
        light[closer] = lit

    for r in scene.rectangles:
        take(intersect_rectangle(r, o, d, tmin, tmax), r.normal, r.material, -1)
    for tri in scene.triangles:
        v0, v1, v2 = tri.vertices
        take(intersect_triangle(tri.vertices, o, d, tmin, tmax)[0],
             _normalize(np.cross(v1 - v0, v2 - v1)), tri.material, -1)
    for e in scene.ellipsoids:
        t, nrm = intersect_ellipsoid(e, o, d, tmin, tmax)
        take(t, nrm, e.material, -1)
    if include_lights:
        for i, lt in enumerate(scene.lights):
            take(intersect_rectangle(lt, o, d, tmin, tmax), lt.normal, -1, i)

    flip = _dot(normal, d) > 0
    normal[flip] *= -1
    return dict(t=best, normal=normal, material=material, light=light)


# --- 3. shading ----------------------------------------------------------------------------------------

def light_points(light, uv):
    """Points on the light rectangle for uv in [0,1)^2 (u along the tangent, v along the bitangent)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    return (light.center + ((uv[:, 0] - 0.5) * light.size[0])[:, None] * light.tangent
            + ((uv[:, 1] - 0.5) * light.size[1])[:, None] * light.bitangent)


# Shadow segments p + s (q - p) are tested for s in (EPS, 1 - EPS). The reference is float64 and p is a
# hit point o + t d computed in float64, so it lies within ~1e-16 (relative to the scene's size ~1) of
# its own surface: a segment re-meets that surface at |s| ~ 1e-16 / (|q - p| |n.l|), far below 1e-6 for
# any n.l that matters. On the other side, only occluders within ~1e-6 * |q - p| (a few micrometres at
# this scene's scale) of either end could be missed, which no test scene has. The closed intervals the
# intersect_* functions use instead of open ones differ only on a set of measure zero.
SHADOW_EPS = 1e-6


def occluded(scene, p, q):
    """True where a rectangle, triangle or ellipsoid (not a light) blocks the segment from p to q."""
    d = q - p                                            # not normalised: the parameter is s itself
    lo, hi = SHADOW_EPS, 1 - SHADOW_EPS
    blocked = np.zeros(len(p), dtype=bool)
    for r in scene.rectangles:
        blocked |= np.isfinite(intersect_rectangle(r, p, d, lo, hi))
    for tri in scene.triangles:
        blocked |= np.isfinite(intersect_triangle(tri.vertices, p, d, lo, hi)[0])
    for e in scene.ellipsoids:
        blocked |= np.isfinite(intersect_ellipsoid(e, p, d, lo, hi)[0])
    return blocked


def shade(scene, p, n, d, material, light_uv):
    """The course's Phong model (docs/model.md, shading): ambient*k plus, per light, the mean over the K light
    samples of V * [n.l > 0] * (k L (n.l) + k L max(0, r.v)^shininess). Shininess is the material's."""
    light_uv = np.asarray(light_uv, dtype=np.float64).reshape(-1, 2)
    k = np.array([m.colour for m in scene.materials])[material]
    shin = np.array([m.shininess for m in scene.materials])[material]
    v = -d
    colour = scene.ambient * k
    for lt in scene.lights:
        acc = np.zeros_like(p)
        for s in light_points(lt, light_uv):             # one sample at a time bounds the memory
            l = _normalize(s - p)
            ndl = _dot(n, l)
            lit = ndl > 0                                 # back-facing samples need no shadow test
            idx = np.nonzero(lit)[0]
            idx = idx[~occluded(scene, p[idx], np.broadcast_to(s, (len(idx), 3)))]
            r = 2 * ndl[idx, None] * n[idx] - l[idx]
            spec = np.maximum(0, _dot(r, v[idx])) ** shin[idx]
            acc[idx] += (ndl[idx] + spec)[:, None]
        colour = colour + k * lt.colour * acc / len(light_uv)
    return colour


def trace(scene, o, d, light_uv):
    """Colour of each ray: light colour if a light is hit first, black on a miss, else Phong shading."""
    h = closest_hit(scene, o, d)
    out = np.zeros((len(o), 3))
    for i, lt in enumerate(scene.lights):
        out[h["light"] == i] = lt.colour
    surf = np.nonzero(h["material"] >= 0)[0]
    if len(surf):
        p = o[surf] + h["t"][surf, None] * d[surf]
        out[surf] = shade(scene, p, h["normal"][surf], d[surf], h["material"][surf], light_uv)
    return out


def render(scene, pixel_offsets, light_uv, width=None, height=None):
    """H x W x 3 float64 image: per pixel the box-filtered mean of trace() over the S pixel offsets."""
    w = scene.width if width is None else width
    h = scene.height if height is None else height
    offs = np.asarray(pixel_offsets, dtype=np.float64).reshape(-1, 2)
    assert np.all((offs >= 0) & (offs < 1)), "pixel offsets lie inside the pixel"
    assert np.all((np.asarray(light_uv) >= 0) & (np.asarray(light_uv) < 1)), "light samples lie on the light"
    s = len(offs)
    img = np.zeros((h, w, 3))
    rows = max(1, 32768 // (w * s))                      # <= ~32k rays per chunk: well under 1 GB
    for y0 in range(0, h, rows):
        ys = np.arange(y0, min(h, y0 + rows))
        shape = (len(ys), w, s)                          # ray order: row, column, sample
        x = np.broadcast_to(np.arange(w)[None, :, None] + offs[None, None, :, 0], shape)
        y = np.broadcast_to(ys[:, None, None] + offs[None, None, :, 1], shape)
        o, d = camera_rays(scene, x, y, w, h)
        img[ys] = trace(scene, o, d, light_uv).reshape(len(ys), w, s, 3).mean(axis=2)
    return img
