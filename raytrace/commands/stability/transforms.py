"""Case 13, transformed_shapes: the course's shapes placed by a scene file's transform keys at huge and tiny
scales."""
import numpy as np

from ...numerics import f32
from ...renderer.packing import camera_struct, ellipsoid_structs, rectangle_structs
from ...scene import load_dict
from ...scene.transform import mesh_matrix
from .common import Row, closest_hit, hit_nonfinite, shapes, stored, unit
from .ellipsoids import T_BOUND, T_WHY, ellipsoid_clear, ellipsoid_truth, t_error
from .rectangles import rectangle_crossing

# ---------------------------------------------------------------------------------------------------------
# 13. Transformed shapes at huge and tiny scales

TRANSFORM_KEYS = ("scale", "rotate", "translate")


def scene_of(shape, transform=None, camera_transform=None):
    """A 16 x 16 Phong scene of one shape and a light above the origin, both placed by the same transform keys
    (none: as written), the camera (from (0, -3, 3), looking at the origin, z up) mapped by the same transform
    (or by `camera_transform`'s), one ray per pixel through its centre."""
    transform = transform or {}
    keys = {k: transform[k] for k in TRANSFORM_KEYS if k in transform}
    view = keys if camera_transform is None else camera_transform
    m = mesh_matrix(np.broadcast_to(np.asarray(view.get("scale", 1.0), np.float64), 3),
                    view.get("rotate", {}).get("axis", (0.0, 0.0, 1.0)), view.get("rotate", {}).get("degrees", 0.0),
                    view.get("translate", (0.0, 0.0, 0.0)))
    camera = ((0.0, -3.0, 3.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    position, look_at = (m[:3, :3] @ np.array(p) + m[:3, 3] for p in camera[:2])
    table = {"camera": {"position": position.tolist(), "look_at": look_at.tolist(),
                        "up": (m[:3, :3] @ np.array(camera[2])).tolist(), "fov": 40.0},
             "image": {"width": 16, "height": 16}, "ambient": [0.1, 0.1, 0.1],
             "render": {"spp": 1, "sampler": "center", "light_samples": 1, "light_sampler": "center"},
             "materials": {"grey": {"colour": [0.5, 0.5, 0.5]}},
             "lights": [{"center": [0.0, 0.0, 2.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                         "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0], **keys}],
             "shapes": [{**shape, **keys, "material": "grey"}]}
    return load_dict(table)


def placed(shape):
    """The shape of one table with transform keys, as a scene file's reader places it (scene_file.py)."""
    scene = scene_of({k: v for k, v in shape.items() if k not in TRANSFORM_KEYS}, shape)
    return (scene.rectangles or scene.ellipsoids)[0]


RECTANGLE = {"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [2.0, 1.5], "normal": [0.0, 0.0, 1.0],
             "tangent": [1.0, 0.0, 0.0]}


def pixel_rays(scene):
    """The pixel-centre camera rays of a scene (kernels/camera.cl), in float64 on the packed camera's values."""
    c = camera_struct(scene.camera, scene.width, scene.height)
    y, x = np.mgrid[0:scene.height, 0:scene.width] + 0.5
    sx = (2 * x.ravel() / scene.width - 1) * float(c["scale_x"])
    sy = (1 - 2 * y.ravel() / scene.height) * float(c["scale_y"])
    d = stored(c, "forward") + sx[:, None] * stored(c, "right") + sy[:, None] * stored(c, "up")
    return np.broadcast_to(stored(c, "position"), d.shape), unit(d)


def rendered(env, scenes):
    """(pixels lit in one image and not in the other, NaN and Inf values) of the renders of two scenes."""
    (a, bad_a), (b, bad_b) = (env.render(scene) for scene in scenes)
    lit = int(np.count_nonzero(a.max(axis=2) > 0))
    return int(np.count_nonzero((a.max(axis=2) > 0) != (b.max(axis=2) > 0))), bad_a + bad_b, lit


def transformed_shapes(env):
    """A 2 x 1.5 tilted rectangle placed by scale = 1e-4 and 1e4, a rotation and a translation of the same
    order; and a unit sphere placed by scale = [1e3, 1, 1e-3] (axes 1e6 apart) and a rotation. Rays from one
    side's length (the rectangle's; three radii for the ellipsoid, in unit-sphere space) away, at 0.1 rad or
    more to the rectangle's plane, through points within 80% of each half-size (within 0.9 of the centre in
    unit-sphere space): every one a clear hit, which must be found, with no NaN or Inf.

    The rectangle's t is held to grazing_rectangles' bound r, computed per ray from its float32 values (the
    row gives the largest error over r: at most 1), whatever the scale: every quantity in it scales with the
    rectangle. The ellipsoid's t is held to 17u kt (grazing_ellipsoids' argument): kt takes the mapping into
    unit-sphere space and the axis ratio into account, so the bound is the same at a ratio of 1e6. Its clear
    rays are few (about 1 in 12): the mapping's magnitudes S, under axes 1e6 apart turned off the coordinate
    axes, leave most of the rays' 1 - b^2 within their rounding; the kernel finds every one of the 512 all the
    same, as the row's text shows.

    Renders, 16 x 16, one ray through each pixel's centre, of the shape and a light above it placed by the same
    keys: at scales 1e-4 and 1e4 with the camera placed by them too (a similarity: the view of the same shape
    as at scale 1, whose edges lie off the pixel centres), the pixels hit must be those hit at scale 1; the
    disc the 1e3 : 1 : 1e-3 scale makes of the sphere, seen from 45 degrees above by a camera turned with it,
    hits the pixels float64's rays from the packed camera hit, wherever that is clear (ellipsoid_clear). No NaN
    or Inf in either (render()'s count)."""
    rng = np.random.default_rng(13)
    rows, m = [], 512
    for scale in (1e-4, 1e4):
        rect = placed({"type": "rectangle", "center": [0.3, -0.2, 0.5], "size": [2.0, 1.5], "normal": [1.0, -2.0, 3.0],
                       "tangent": [2.0, 1.0, 0.0], "scale": scale, "rotate": {"axis": [1.0, 1.0, 0.2], "degrees": 37.0},
                       "translate": [0.1 * scale, 0.4 * scale, -0.3 * scale]})
        s = rectangle_structs([rect])[0]
        c, n, tan, bit = (stored(s, k) for k in ("center", "normal", "tangent", "bitangent"))
        half = np.array([float(s["half_x"]), float(s["half_y"])])
        side = rng.choice([-1.0, 1.0], (m, 1))
        angle = rng.uniform(0.1, np.pi / 2, (m, 1))
        phi = rng.uniform(0, 2 * np.pi, (m, 1))
        d = f32(unit(np.cos(angle) * (np.cos(phi) * tan + np.sin(phi) * bit) - side * np.sin(angle) * n))
        o = f32(c + (rng.uniform(-0.8, 0.8, (m, 2)) * half) @ np.stack([tan, bit]) - 2 * scale * d)
        hit, t, r, wrong, clear = rectangle_crossing(env, s, rect, o, d)
        hits = np.isfinite(hit["t"])
        rows.append(Row(f"rectangle at scale {scale:g}, turned: hits found (of {m} clear: {clear})",
                        int(m - np.count_nonzero(hits) + wrong), "rays", 0, "every ray a clear hit",
                        hit_nonfinite(hit)))
        rows.append(Row(f"rectangle at scale {scale:g}, turned: t error over its bound r",
                        float(np.max(np.abs(hit["t"][hits] - t[hits]) / (np.abs(t[hits]) * r[hits]))), "r", 1.0,
                        "grazing_rectangles' r, per ray"))
    for scale in (1e-4, 1e4):
        transform = {"scale": scale, "rotate": {"axis": [1.0, 1.0, 0.2], "degrees": 37.0},
                     "translate": [0.1 * scale, 0.4 * scale, -0.3 * scale]}
        flips, bad, lit = rendered(env, (scene_of(RECTANGLE), scene_of(RECTANGLE, transform)))
        rows.append(Row(f"render of a rectangle and its light at scale {scale:g}, turned: pixels hit or missed "
                        f"unlike at scale 1 ({lit} of 256 hit there)", flips if lit else 256, "pixels", 0,
                        "a similarity: the same view", bad))
    e = placed({"type": "ellipsoid", "center": [0.1, 0.2, -0.1], "axes": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                                                                          [0.0, 0.0, 1.0]],
                "scale": [1e3, 1.0, 1e-3], "rotate": {"axis": [1.0, 2.0, 3.0], "degrees": 50.0}})
    line = unit(rng.normal(size=(m, 3)))
    foot = unit(np.cross(line, rng.normal(size=(m, 3)))) * 0.9 * np.sqrt(rng.uniform(size=(m, 1)))
    o, d = f32(e.center + (foot - 3 * line) @ e.axes), f32(unit(line @ e.axes))
    s = ellipsoid_structs([e])[0]
    hit, truth = closest_hit(env, shapes(env, ellipsoids=[e]), o, d), ellipsoid_truth(s, o, d)
    hits, both = np.isfinite(hit["t"]), np.isfinite(hit["t"]) & np.isfinite(truth["t"])
    clear = ellipsoid_clear(truth)
    rows.append(Row(f"ellipsoid scaled 1e3 : 1 : 1e-3, turned: clear hits missed (of {np.count_nonzero(clear)} "
                    f"clear; {np.count_nonzero(hits)} of {m} found)", int(np.count_nonzero(clear & ~hits)), "rays", 0,
                    "impact parameter <= 0.9: all clear hits", hit_nonfinite(hit)))
    rows.append(Row("ellipsoid scaled 1e3 : 1 : 1e-3, turned: t error", float(np.max(t_error(hit, truth)[both])),
                    "u kt", T_BOUND, T_WHY))
    sphere = {"type": "ellipsoid", "center": [0.0, 0.0, 0.0], "axes": np.eye(3).tolist()}
    # the camera turned with the disc, not scaled (that would flatten its view into the disc's plane): it sees
    # the disc, 1e3 x 1 x 1e-3, from 45 degrees above
    turn = {"rotate": {"axis": [1.0, 2.0, 3.0], "degrees": 50.0}}
    scene = scene_of(sphere, {"scale": [1e3, 1.0, 1e-3], **turn}, turn)
    image, bad = env.render(scene)
    o, d = pixel_rays(scene)
    truth = ellipsoid_truth(ellipsoid_structs(scene.ellipsoids)[0], o, d)
    expected, clear = np.isfinite(truth["t"]), ellipsoid_clear(truth)
    wrong = clear & ((image.max(axis=2).ravel() > 0) != expected)
    rows.append(Row(f"render of the ellipsoid scaled 1e3 : 1 : 1e-3 and its light: pixels hit or missed against "
                    f"float64 where clear ({np.count_nonzero(clear)} of 256, {np.count_nonzero(expected)} hit)",
                    int(np.count_nonzero(wrong)) if expected.any() else 256, "pixels", 0,
                    "clear: |1 - b^2| over twice its rounding", bad))
    return rows
