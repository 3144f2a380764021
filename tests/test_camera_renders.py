"""Rendered images of the camera types, the clip planes and the crop window (docs/model.md, camera and the film):
a thin lens's circle of confusion against its formula, the far plane showing what a miss shows, a crop window
the same pixels as the whole film's."""
import math

import numpy as np
import pytest

import raytrace

FOV = 30.0
SIZE = 64


def point_scene(depth, kind="thinlens", aperture=0.15, focus=4.0, spp=1024, radius=0.05):
    """A small emitting sphere of `radius` on the view axis at `depth`, nothing else: the path model to depth 1
    (the emitter seen directly), 64 x 64 pixels, Sobol's samples, a thin lens of `aperture` focused at `focus`
    (or a pinhole)."""
    camera = {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 1.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": FOV}
    if kind == "thinlens":
        camera.update(type="thinlens", aperture_radius=aperture, focus_distance=focus)
    return raytrace.load_dict({
        "camera": camera, "image": {"width": SIZE, "height": SIZE},
        "render": {"shading": "path", "max_depth": 1, "spp": spp, "sampler": "sobol"},
        "materials": {"black": {"type": "diffuse", "colour": [0.0, 0.0, 0.0]}},
        "shapes": [{"type": "ellipsoid", "center": [0.0, depth, 0.0], "axes": (radius * np.eye(3)).tolist(),
                    "material": "black", "radiance": 100.0}]})


def second_moment(image):
    """The image's mean squared distance from its centroid, in pixels^2 (the red channel's energy)."""
    e = np.asarray(image, np.float64)[..., 0]
    y, x = np.mgrid[0:e.shape[0], 0:e.shape[1]] + 0.5
    total = e.sum()
    cx, cy = (e * x).sum() / total, (e * y).sum() / total
    return (e * ((x - cx) ** 2 + (y - cy) ** 2)).sum() / total


def test_the_circle_of_confusion_is_the_thin_lens_formula():
    """A point at depth z seen through a lens of radius A focused at z_f is a uniform disk of diameter c = 2A |z -
    z_f| / z on the focal plane: c H / (2 z_f tan(fov / 2)) pixels (docs/model.md). The sphere (radius 0.05)
    is itself a uniform disk of radius R_s = f rs / sqrt(z^2 - rs^2) pixels (f = H / (2 tan(fov / 2))) on the
    image, and the image is the two disks convolved: a uniform disk of radius R has the second moment R^2 / 2,
    moments of independent spreads add, and a pixel grid adds 1/12 per axis (Sheppard's correction, exact for a
    smooth image, within about 1% of the radius for these disks of sharp edges). So the lens's radius is
    sqrt(2 (M - 1/6 - R_s^2 / 2)) from the image's moment M: at z = 2 (in front) and z = 8 (behind) within 2%
    of the formula's (measured 0.2% and 0.5%: 4.486 against 4.478, 2.229 against 2.239 pixels); at z = z_f the
    image is the pinhole's (moments within 2%: measured 0.05%). Mutations tried, each failing it: the lens
    point's disk twice its radius; the focal plane at the image plane's distance (focus_distance ignored)."""
    focus, aperture, rs = 4.0, 0.15, 0.05
    f = SIZE / (2 * math.tan(math.radians(FOV) / 2))
    for depth in (2.0, 8.0):
        moment = second_moment(raytrace.render(point_scene(depth, aperture=aperture, focus=focus, radius=rs),
                                               progress=False)[0])
        sphere = f * rs / math.sqrt(depth ** 2 - rs ** 2)
        got = math.sqrt(2 * (moment - 1 / 6 - sphere ** 2 / 2))
        want = aperture * abs(depth - focus) / depth * f / focus
        assert got == pytest.approx(want, rel=0.02), (depth, got, want)
    pinhole, lens = (second_moment(raytrace.render(point_scene(focus, kind, aperture=aperture, focus=focus,
                                                               radius=rs), progress=False)[0])
                     for kind in ("perspective", "thinlens"))
    assert lens == pytest.approx(pinhole, rel=0.02)


def test_a_lens_of_no_aperture_is_a_pinhole():
    """aperture_radius = 0 (which Mitsuba accepts, taking 1e-4 with a warning) loads and renders the pinhole's
    image: the point at depth 2, far out of focus, has the pinhole's second moment within 2% (the tolerance of
    the test above), where any lens would blur it."""
    pinhole, lens = (second_moment(raytrace.render(point_scene(2.0, kind, aperture=0.0), progress=False)[0])
                     for kind in ("perspective", "thinlens"))
    assert lens == pytest.approx(pinhole, rel=0.02)


def box_scene(**changes):
    """cornell_path.toml at 48 x 40, 16 samples, with a constant environment seen through the open front, the
    image table's or camera's `changes` ({"image.crop_width": 20, ...})."""
    import tomllib
    from helpers import ROOT
    table = tomllib.loads((ROOT / "scenes" / "cornell_path.toml").read_text())
    table["image"] = {"width": 48, "height": 40}
    table["render"]["spp"] = 16
    table["environment"] = {"type": "constant", "radiance": [0.3, 0.1, 2.0]}
    for key, value in changes.items():
        name, field = key.split(".")
        table[name][field] = value
    return raytrace.load_dict(table)


@pytest.mark.parametrize("rfilter", ["box", "gaussian"])
def test_a_crop_is_the_whole_films_pixels(rfilter):
    """A crop window's pixels are keyed and placed by the whole film's coordinates: with the box filter, exactly
    the whole render's pixels there, bit for bit; with the gaussian (radius 2), those at least 2 pixels inside
    the window's edge, where no sample leaves the window."""
    whole = np.asarray(raytrace.render(box_scene(**{"image.rfilter": rfilter}), progress=False)[0])
    crop = np.asarray(raytrace.render(box_scene(**{"image.rfilter": rfilter, "image.crop_offset_x": 13,
                                                   "image.crop_offset_y": 7, "image.crop_width": 21,
                                                   "image.crop_height": 17}), progress=False)[0])
    assert crop.shape == (17, 21, 3)
    part = whole[7:24, 13:34]
    if rfilter == "box":
        assert np.array_equal(crop, part)
    else:
        assert np.array_equal(crop[2:-2, 2:-2], part[2:-2, 2:-2])
        assert not np.array_equal(crop, part)  # the edge's pixels average the filter's part inside


def test_beyond_the_far_plane_is_the_environment():
    """A far plane at 3.5 along the view (the back wall at 4): the back wall's pixels see the constant
    environment, every sample of them exactly its radiance (the unclipped render's differ); a near plane at 2.5
    cuts the floor's front (at 2 to 2.5), so the bottom rows differ from the unclipped render's."""
    far = np.asarray(raytrace.render(box_scene(**{"camera.far_clip": 3.5}), progress=False)[0])
    centre = far[14:22, 20:28]
    np.testing.assert_allclose(centre, np.broadcast_to([0.3, 0.1, 2.0], centre.shape), rtol=1e-6)
    plain = np.asarray(raytrace.render(box_scene(), progress=False)[0])
    assert np.abs(plain[14:22, 20:28] - centre).max(axis=2).min() > 0.1
    near = np.asarray(raytrace.render(box_scene(**{"camera.near_clip": 2.5}), progress=False)[0])
    assert np.abs(near[-4:] - plain[-4:]).max() > 0.1


def test_a_moved_and_scaled_scene_scales_its_cameras_lengths():
    """transform.transformed (the invariance tests' similarity x -> s x + t) scales the clip planes, a thin lens's
    aperture and focus distance and an orthographic view's size with the scene: its image is the same."""
    import dataclasses
    from raytrace.scene.transform import transformed
    scene = point_scene(2.0)
    scene.camera = dataclasses.replace(scene.camera, near_clip=0.5, far_clip=9.0)
    camera = transformed(scene, 3.0, (1.0, 2.0, 3.0)).camera
    assert (camera.near_clip, camera.far_clip, camera.aperture_radius, camera.focus_distance) == (1.5, 27.0,
                                                                                                  0.15 * 3.0, 12.0)
    ortho = dataclasses.replace(scene.camera, kind="orthographic", fov_deg=None, size=np.array([2.0, 1.0]))
    scene.camera = ortho
    assert np.array_equal(transformed(scene, 3.0).camera.size, [6.0, 3.0])


@pytest.mark.parametrize("rfilter", [{"rfilter": "gaussian"}, {"rfilter": "tent", "rfilter_radius": 1.5},
                                     {"rfilter": "mitchell"}, {"rfilter": "lanczos", "rfilter_lobes": 2}],
                         ids=lambda r: r["rfilter"])
def test_an_edge_renders_as_the_filters_convolution(rfilter):
    """An orthographic view (one scene unit per pixel, 16 x 2 pixels) of a light of radiance 1 covering the film
    left of x = 7.3: column j's value is the filter's share left of the edge, of its part inside the film,
    int_{-c}^{min(7.3, 16) - c} f / int_{-c}^{16 - c} f with c = j + 0.5 (float64 quadrature of Mitsuba's
    formula). The image is 16 renders of 1024 samples (seeds 0 to 15), and each of the 32 pixels' mean (red) is
    compared by a t-test on the renders' spread, 15 degrees of freedom: |t| < 7.5 (two-sided 2e-6 each, 6e-5 for
    the 32; the spread floored at 1e-6, float32's rounding of a sum of weights 1 where a pixel is lit whole).
    Mutations tried, each failing it: the weights over the whole filter's integral at the film's edge (columns
    0, 1, 14, 15); the offsets about the pixel's corner, not its centre.
    """
    from raytrace.renderer.film_filter import formula
    edge = 7.3
    scene = raytrace.load_dict({
        "camera": {"type": "orthographic", "position": [8.0, 0.0, 1.0], "look_at": [8.0, 1.0, 1.0],
                   "up": [0.0, 0.0, 1.0], "size": [16.0, 2.0]},
        "image": {"width": 16, "height": 2, **rfilter},
        "render": {"shading": "path", "max_depth": 1, "spp": 1024, "sampler": "random"},
        "lights": [{"center": [edge / 2 - 10.0, 5.0, 1.0], "size": [edge + 20.0, 10.0], "normal": [0.0, -1.0, 0.0],
                    "tangent": [1.0, 0.0, 0.0], "radiance": 1.0}],
        "materials": {"black": {"type": "diffuse", "colour": [0.0, 0.0, 0.0]}}})
    renders = np.array([np.asarray(raytrace.render(scene, seed=seed, progress=False)[0], np.float64)[..., 0]
                        for seed in range(16)])
    params = {"gaussian": {"stddev": 0.5}, "tent": {"radius": 1.5}, "mitchell": {"B": 1 / 3, "C": 1 / 3},
              "lanczos": {"lobes": 2}}[rfilter["rfilter"]]
    radius, f, _, _ = formula(rfilter["rfilter"], params)
    want = []
    for j in range(16):
        c = j + 0.5
        lo, hi = max(-c, -radius), min(16 - c, radius)
        want.append(quad(f, lo, max(lo, min(edge - c, hi))) / quad(f, lo, hi))
    error = renders.std(axis=0, ddof=1) / 4 + 1e-6
    t = (renders.mean(axis=0) - np.array(want)[None, :]) / error
    assert np.abs(t).max() < 7.5, np.round(t, 2)


def quad(f, a, b):
    """f's integral over [a, b] by 64-point Gauss-Legendre on pieces split at the half-integers (the formulas'
    kinks but the gaussian's cut-off, where f is below 3e-4: error below 1e-9)."""
    if b <= a:
        return 0.0
    x, w = np.polynomial.legendre.leggauss(64)
    cuts = np.unique(np.concatenate([[a, b], np.arange(math.ceil(2 * a), math.floor(2 * b) + 1) / 2]))
    return sum(float(np.sum(w * f((lo + hi) / 2 + (hi - lo) / 2 * x)) * (hi - lo) / 2)
               for lo, hi in zip(cuts[:-1], cuts[1:]))


@pytest.mark.parametrize("key, value", [("aperture_radius", 1e18), ("focus_distance", 1e18), ("near_clip", 1e30),
                                        ("size", [1e19, 1.0])])
def test_camera_points_beyond_float32s_reach_are_refused(key, value):
    """ranges.py's rule 2 takes the points a camera's rays start from or aim at (the near plane's centre, a thin
    lens's extent and focal point, an orthographic view's corners): one beyond 2^60 (1.15e18) is refused naming its
    key (the eye at 3e17 on each axis, within it)."""
    camera = {"position": [3e17] * 3, "look_at": [3e17, 3e17 + 1e3, 3e17], "up": [0.0, 0.0, 1.0], key: value}
    camera.update({"size": {"type": "orthographic"}}.get(key, {"type": "thinlens", "fov": 40.0}))
    if camera["type"] == "thinlens":
        camera.setdefault("aperture_radius", 0.1)
        camera.setdefault("focus_distance", 2.0)
    if key == "near_clip":
        camera["far_clip"] = 3e30
    with pytest.raises(raytrace.InputError) as error:
        raytrace.load_dict({"camera": camera, "image": {"width": 4, "height": 4}, "render": {"shading": "path"},
                            "materials": {"m": {"colour": [0.5, 0.5, 0.5]}},
                            "environment": {"type": "constant", "radiance": 1.0}})
    assert error.value.key == f"camera.{key}" and "2^60" in error.value.problem
