"""AOVs (kernels/aovs.cl, raytrace/aovs.py): the kernel's values per pixel against float64 references, the
option's parsing and refusals, and the EXR channels read back.

The geometric AOVs are exact functions of the camera ray: a wall at a known distance, one sample per pixel at
the pixel's centre (the center sampler), gives per pixel the depth t = (D - o.y) / d.y along the unit direction
d of the float64 reference camera (reference_camera.camera_directions, the same formulas as camera.cl), the
position o + t d, the normal and the uv of the rectangle. Tolerance: the kernel forms d from the film point in
about 10 float32 roundings (camera.cl: the scaled film coordinates, three multiply-adds, rsqrt's 2 ulp as 4),
t in about 10 more (rectangle.cl's plane distance and division, 2.5 ulp as 5), p and uv in 4 more each: within
24 roundings, u = 2^-24 each, of values whose magnitude is at most the scene's M = 8 (the wall's distance and
half size). A bound of 64 u M leaves more than a factor 2 over that count; a pixel off by a wrong formula (a
depth from the camera's position instead of the near clip plane, a flipped normal, uv swapped) is off by 1e-2
or more. The albedo is a checkerboard's colour, constant over each square: pixels whose uv lies within 1e-3 of a
square's edge (where the uv's rounding may pick either) are left out.

Mutations tried, each failing a test here: the normal turned towards the viewer (sign of `side`
dropped: test_wall_values, back side), the planes of position and uv swapped in aovs.planes, misses not zeroed
(the depth of a miss: test_wall_values, an Inf the host counts), the depth of a passed light from the moved
origin (test_hidden_light_is_passed), the albedo of the material's constant colour instead of the textured one
(test_albedo_of_a_checkerboard), the rfilter weight left off the AOV sums (test_filtered_mean_is_weighted).
"""

import numpy as np
import pytest

import raytrace
from helpers import ROOT, run
from raytrace import aovs
from raytrace.commands.stability.reference_camera import camera_directions
from raytrace.errors import InputError

U = 2.0 ** -24
D = 4.0       # the wall's distance from the camera along +y
HALF = 2.0    # the wall's half size: the view's edges miss it (sky)
W, H = 24, 16
ALL = "albedo,normal,g:geo_normal,depth,position,uv,shape"  # every type


def wall_scene(normal_y=-1.0, shading="path", reflectance=None, extra=(), fov=70.0):
    material = {"type": "diffuse", "reflectance": reflectance} if reflectance is not None else {"colour": [0.25, 0.5, 0.75]}
    return raytrace.load_dict({
        "camera": {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 1.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": fov},
        "image": {"width": W, "height": H},
        "render": {"shading": shading, "sampler": "center", "spp": 1},
        "lights": [{"center": [0.0, 1.0, 3.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                    "tangent": [1.0, 0.0, 0.0], **({"colour": [1.0, 1.0, 1.0]} if shading == "phong" else
                                                   {"radiance": 5.0})}],
        "materials": {"wall": material},
        "shapes": [{"type": "rectangle", "center": [0.0, D, 0.0], "size": [2 * HALF, 2 * HALF],
                    "normal": [0.0, normal_y, 0.0], "tangent": [1.0, 0.0, 0.0], "material": "wall"}, *extra]})


def reference(scene):
    """Per pixel (H x W): the float64 depth, position, normal (the rectangle's own; a mesh's: -y), uv and
    whether the ray meets the wall, for the pixel centres."""
    y, x = np.mgrid[0:H, 0:W] + 0.5
    d, _ = camera_directions(scene.camera, x, y, W, H)
    t = D / d[:, 1]
    p = t[:, None] * d
    hit = (np.abs(p[:, 0]) < HALF) & (np.abs(p[:, 2]) < HALF)
    u = p[:, 0] / (2 * HALF) + 0.5                  # along the tangent +x
    normal = np.array([0.0, np.sign(scene.rectangles[0].normal[1]) if scene.rectangles else -1.0, 0.0])
    v = np.cross(normal, [1.0, 0.0, 0.0]) @ p.T / (2 * HALF) + 0.5  # along normal x tangent
    return {"depth": t.reshape(H, W, 1), "position": p.reshape(H, W, 3),
            "normal": np.broadcast_to(normal, (H * W, 3)).reshape(H, W, 3),
            "uv": np.stack([u, v], -1).reshape(H, W, 2), "hit": hit.reshape(H, W)}


@pytest.mark.parametrize("shading", ["phong", "path"])
@pytest.mark.parametrize("normal_y", [-1.0, 1.0], ids=["front", "back"])
def test_wall_values(lanes, shading, normal_y):
    """Depth, position, both normals and uv per pixel at every lane width, in the Phong and path models (their
    own render loops: render_samples and render_paths), seen from the front and from the back (the normal is
    the shape's own, not turned to the viewer); 0 in every plane where the ray misses."""
    scene = wall_scene(normal_y, shading)
    image, stats = raytrace.render(scene, lanes=lanes, aov="depth,position,normal,uv,g:geo_normal")
    ref = reference(scene)
    hit, bound = ref["hit"], 64 * U * 2 * D
    assert hit.any() and not hit.all() and stats.extra["nonfinite_values"] == 0  # (the host zeroes an Inf)
    assert stats.aovs == [["depth", "depth"], ["position", "position"], ["normal", "sh_normal"], ["uv", "uv"],
                          ["g", "geo_normal"]]
    for name, key in (("depth", "depth"), ("position", "position"), ("normal", "normal"), ("g", "normal"),
                      ("uv", "uv")):
        got = image.aovs[name]
        assert got.dtype == np.float32 and got.shape == ref[key].shape
        np.testing.assert_allclose(got[hit], ref[key][hit], rtol=0, atol=bound, err_msg=name)
        assert not got[~hit].any(), name


def test_albedo_of_a_checkerboard(lanes):
    """The albedo AOV of a diffuse wall whose reflectance is a checkerboard (Mitsuba's eval_diffuse_reflectance
    of diffuse: its reflectance at the hit) is the square's colour per pixel, and 0 off the wall."""
    c0, c1 = [0.9, 0.5, 0.1], [0.05, 0.2, 0.6]
    scene = wall_scene(reflectance={"type": "checkerboard", "color0": c0, "color1": c1, "to_uv": [[4, 0, 0], [0, 4, 0]]})
    image, _ = raytrace.render(scene, lanes=lanes, aov="albedo")
    ref = reference(scene)
    st = np.stack([4 * ref["uv"][..., 0], 1 - 4 * ref["uv"][..., 1]], -1)  # the kernel's t runs down (packing.py)
    frac = st - np.floor(st)
    clear = ref["hit"] & (np.abs(frac - 0.5) > 1e-3).all(-1) & (np.minimum(frac, 1 - frac) > 1e-3).all(-1)
    same = (frac[..., 0] > 0.5) == (frac[..., 1] > 0.5)
    expected = np.where(same[..., None], c0, c1)
    got = image.aovs["albedo"]
    np.testing.assert_allclose(got[clear], expected[clear], rtol=1e-6)
    assert not got[~ref["hit"]].any()


# A two-triangle mesh without uvs (its uv AOV: each face's barycentrics, geometry.DEFAULT_UV) on the wall's
# plane; the corners are off the view's diagonals so no pixel centre lies on the shared edge.
MESH_CORNERS = np.array([[-HALF, D, -HALF], [HALF, D, -0.5], [HALF, D, HALF], [-HALF, D, HALF]])
MESH_FACES = ((0, 1, 2), (0, 2, 3))


def mesh_reference(scene):
    """Per pixel: the float64 barycentrics (b1, b2) of the hit in the face it lies in, that face's number (-1
    off the mesh) and its distance in b from the face's edges (to leave out pixels a rounding may put on the
    other face)."""
    ref = reference(scene)
    p = ref["position"].reshape(-1, 3)[:, [0, 2]]
    uv, face, margin = np.zeros((len(p), 2)), np.full(len(p), -1), np.zeros(len(p))
    for k, corners in enumerate(MESH_FACES):
        a, b, c = MESH_CORNERS[list(corners)][:, [0, 2]]
        b12 = np.linalg.solve(np.stack([b - a, c - a], 1), (p - a).T).T
        weights = np.column_stack([1 - b12.sum(1), b12])
        inside = (weights >= 0).all(1)
        uv[inside], face[inside], margin[inside] = b12[inside], k, weights[inside].min(1)
    return uv.reshape(H, W, 2), face.reshape(H, W), margin.reshape(H, W)


def test_mesh_without_uvs(lanes):
    """Every AOV of a triangle mesh without uvs or textures (the uv AOV reads the triangles' uv table, packed
    only for textures once: garbage, up to 1e28, and NaNs read past a one-entry table) against float64: the uv
    is the face's barycentrics (b1, b2), the depth, position and normals as the wall's (test_wall_values), the
    albedo the material's colour, the shape_index the face's number (each face of an inline mesh is a shape:
    aovs.SHAPE_ORDER), and no value is non-finite. The barycentrics' tolerance: the kernel's intersection
    (triangle.cl) forms them from the ray and two edges in about 20 roundings of terms up to M = 8 in
    magnitude, divided by the determinant's 2 |e1 x e2| / |d| ~ 8: 64 u, as the wall's bound, on values below 1
    (measured: 2.6 u).
    Mutation: the uv table packed for textures only (the fix undone): the uvs are garbage, fails here."""
    scene = raytrace.load_dict({
        "camera": {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 1.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": 70.0},
        "image": {"width": W, "height": H}, "render": {"shading": "path", "sampler": "center", "spp": 1},
        "lights": [{"center": [0.0, 1.0, 3.0], "size": [0.5, 0.5], "normal": [0.0, 0.0, -1.0],
                    "tangent": [1.0, 0.0, 0.0], "radiance": 5.0}],
        "materials": {"m": {"colour": [0.25, 0.5, 0.75]}},
        "shapes": [{"type": "mesh", "vertices": MESH_CORNERS.tolist(), "faces": [list(f) for f in MESH_FACES],
                    "material": "m"}]})
    image, stats = raytrace.render(scene, lanes=lanes, aov=ALL)
    assert stats.extra["nonfinite_values"] == 0
    ref = reference(scene)
    uv, face, margin = mesh_reference(scene)
    on, clear = face >= 0, margin > 1e-3
    assert clear.sum() >= 100 and (face[clear] == 0).any() and (face[clear] == 1).any()
    np.testing.assert_allclose(image.aovs["uv"][clear], uv[clear], rtol=0, atol=64 * U)
    assert np.isfinite(image.aovs["uv"]).all() and not image.aovs["uv"][~on].any()
    np.testing.assert_array_equal(image.aovs["shape"][clear][:, 0], face[clear] + 1)
    np.testing.assert_allclose(image.aovs["albedo"][on], np.broadcast_to([0.25, 0.5, 0.75], (on.sum(), 3)),
                               rtol=1e-6)
    for name, key in (("depth", "depth"), ("position", "position"), ("normal", "normal"), ("g", "normal")):
        np.testing.assert_allclose(image.aovs[name][on], ref[key][on], rtol=0, atol=64 * U * 2 * D, err_msg=name)
        assert not image.aovs[name][~on].any(), name


def test_cornell_aovs_are_finite(cornell):
    """scenes/cornell.toml (rectangles and a mesh without uvs, no textures) with every AOV: no value non-finite
    (the host zeroes and counts them) and the uvs within [0, 1] (the rectangles' and the barycentrics).
    Mutation: the uv table packed for textures only: 63 NaNs or uvs of 1e24 and more, fails here."""
    image, stats = raytrace.render(cornell, width=48, height=32, spp=4, aov=ALL)
    assert stats.extra["nonfinite_values"] == 0
    uv = image.aovs["uv"]
    assert (uv >= 0).all() and (uv <= 1 + 1e-6).all()


@pytest.mark.parametrize("name", ["cornell", "cornell_path", "materials"])
def test_beauty_is_unchanged(name):
    """Every AOV on leaves the beauty and its variance bit for bit as without (the same samples, the same
    shading: the AOVs only read the camera rays' hits and shading points), in the Phong model (cornell: its
    render_samples loop), the path model (cornell_path: render_paths, where the camera hits are shaded once for
    both) and the path model's BSDFs (materials: conductor, roughconductor, dielectric, an environment map); no
    AOV value is non-finite. Mutations tried (render.cl), each failing here: a sample dimension taken after
    add_aovs (as an AOV drawing a random number would: cornell_path and materials), the shading point's
    colour changed after add_aovs in render_samples (cornell). Not caught: the camera rays' path_vertex given
    `alive & camera` for `alive` (no packet at 4 spp mixes camera rays with bounces here)."""
    scene = raytrace.load_file(ROOT / "scenes" / f"{name}.toml")
    plain, _ = raytrace.render(scene, width=32, height=24, spp=4)
    image, stats = raytrace.render(scene, width=32, height=24, spp=4, aov=ALL)
    assert f"-DHAS_AOVS={aovs.mask(aovs.parse(ALL, 'x', 'aov'))}" in stats.build_options
    np.testing.assert_array_equal(np.asarray(image), np.asarray(plain))
    np.testing.assert_array_equal(image.variance, plain.variance)
    assert stats.extra["nonfinite_values"] == 0 and len(image.aovs) == 7


GOLD = {"eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}  # scenes/materials.toml's
ALBEDO_BSDFS = {
    "plastic": ({"type": "plastic", "diffuse_reflectance": [0.2, 0.4, 0.6]}, [0.2, 0.4, 0.6]),
    "roughplastic": ({"type": "roughplastic", "diffuse_reflectance": [0.6, 0.3, 0.1], "alpha": 0.3},
                     [0.6, 0.3, 0.1]),
    "principled": ({"type": "principled", "base_color": [0.3, 0.5, 0.7], "metallic": 0.5, "roughness": 0.4},
                   [0.3, 0.5, 0.7]),
    "conductor": ({"type": "conductor", **GOLD}, [0.0, 0.0, 0.0]),
    "dielectric": ({"type": "dielectric", "int_ior": 1.5}, [0.0, 0.0, 0.0]),
    "roughconductor_ggx": ({"type": "roughconductor", "distribution": "ggx", "alpha": 0.3,
                            "specular_reflectance": [0.9, 0.8, 0.7], **GOLD}, None),
    "roughconductor_beckmann": ({"type": "roughconductor", "distribution": "beckmann", "alpha": 0.3, **GOLD}, None),
}


def fresnel_conductor(cos_i, eta, k):
    """The unpolarised Fresnel reflectance of a conductor of index eta + i k, in complex float64 (Born and Wolf's
    amplitudes; pbrt-v4's FrComplex)."""
    n = np.asarray(eta, np.float64) + 1j * np.asarray(k, np.float64)
    cos_t = np.sqrt(1 - (1 - cos_i ** 2) / n ** 2)
    r_parallel = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    r_perpendicular = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    return (np.abs(r_parallel) ** 2 + np.abs(r_perpendicular) ** 2) / 2


def rough_conductor_albedo(material, wi):
    """Mitsuba's eval_diffuse_reflectance of roughconductor seen from wi (unit, towards the viewer; the normal
    +z): pi f(wi, n) cos(n, n) = pi k F(wi . h) D(h) G1(wi) G1(n) / (4 cos theta_i), h the half vector of wi and
    n, G1(n) = 1; GGX's D and Smith G1, Beckmann's D and G1 by Walter et al.'s rational fit (Mitsuba's
    smith_g1), in float64."""
    alpha, cos_i = material["alpha"], wi[2]
    h = (wi + [0.0, 0.0, 1.0]) / np.linalg.norm(wi + [0.0, 0.0, 1.0])
    c2 = h[2] ** 2
    tan2_i = (1 - cos_i ** 2) / cos_i ** 2
    if material["distribution"] == "ggx":
        d = alpha ** 2 / (np.pi * (c2 * alpha ** 2 + 1 - c2) ** 2)
        g1 = 2 / (1 + np.sqrt(1 + alpha ** 2 * tan2_i))
    else:
        d = np.exp(-(1 - c2) / c2 / alpha ** 2) / (np.pi * alpha ** 2 * c2 ** 2)
        a = 1 / (alpha * np.sqrt(tan2_i))
        g1 = 1.0 if a >= 1.6 else (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a)
    k = np.asarray(material.get("specular_reflectance", [1.0, 1.0, 1.0]))
    return np.pi * k * fresnel_conductor(wi @ h, material["eta"], material["k"]) * d * g1 / (4 * cos_i)


@pytest.mark.parametrize("bsdf", ALBEDO_BSDFS)
def test_albedo_of_other_bsdfs(bsdf):
    """The albedo AOV of the path model's BSDFs other than diffuse, as aovs.cl's aov_albedo documents them after
    Mitsuba's eval_diffuse_reflectance: the plastics' diffuse_reflectance, principled's base_color, 0 for the
    smooth conductor and the dielectric (delta BSDFs), and the rough conductor's pi f(wi, n) (Mitsuba's default)
    against float64 (rough_conductor_albedo), GGX and Beckmann. An orthographic camera sees a wall 40 degrees off
    its normal, so every pixel's wi is the same, off the normal (where D, G1 and F all vary with the angle).
    Tolerance, the rough conductor: the kernel forms the direction, the half vector and its cosines in about 10
    float32 roundings, D, G1 and F in about 15 each (exp2 and sqrt counted as 2 to 4); the cosines' errors are
    amplified by D's slope, |d ln D / d ln cos^2 theta_h| < 11 at alpha 0.3 and theta_h = 20 degrees: 256 u
    relative bounds the lot with room (measured: 17 u GGX, 21 u Beckmann). The others are a parameter's float32
    copy, or 0, exactly. Mutations tried (aovs.cl), each failing here: the rough conductor's f(n, wi) for
    f(wi, n) (its cosine then wi's: both rough conductors), its pi dropped (both), plastic given 0 as the
    conductor is (plastic)."""
    material, expected = ALBEDO_BSDFS[bsdf]
    theta = np.radians(40.0)
    wi = np.array([np.sin(theta), 0.0, np.cos(theta)])  # towards the camera, the wall's normal +z
    scene = raytrace.load_dict({
        "camera": {"type": "orthographic", "position": (6.0 * wi).tolist(), "look_at": [0.0, 0.0, 0.0],
                   "up": [0.0, 1.0, 0.0], "size": [2.0, 1.5]},
        "image": {"width": 8, "height": 6}, "render": {"shading": "path", "sampler": "center", "spp": 1},
        "lights": [{"center": [0.0, 0.0, 8.0], "size": [1.0, 1.0], "normal": [0.0, 0.0, -1.0],
                    "tangent": [1.0, 0.0, 0.0], "radiance": 1.0}],
        "materials": {"m": material},
        "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [20.0, 20.0], "normal": [0.0, 0.0, 1.0],
                    "tangent": [1.0, 0.0, 0.0], "material": "m"}]})
    image, _ = raytrace.render(scene, aov="albedo")
    got = image.aovs["albedo"].reshape(-1, 3).astype(np.float64)
    if expected is None:
        expected = rough_conductor_albedo(material, wi)
        np.testing.assert_allclose(got, np.broadcast_to(expected, got.shape), rtol=256 * U, atol=0)
        assert (expected > 0.1).all()
    else:
        np.testing.assert_allclose(got, np.broadcast_to(np.float32(expected), got.shape), rtol=0, atol=0)


def test_hidden_light_is_passed():
    """With hide_emitters, a camera ray through a light records what lies beyond it (the surface the image shows),
    its depth from the camera's origin, not from where it passed the light."""
    light = {"type": "rectangle", "center": [0.0, 2.0, 0.0], "size": [8.0, 8.0], "normal": [0.0, -1.0, 0.0],
             "tangent": [1.0, 0.0, 0.0], "radiance": 1.0}
    scene = wall_scene(extra=[light])
    scene.hide_emitters = True
    scene.checked = None
    image, _ = raytrace.render(scene, aov="depth,albedo")
    ref = reference(scene)
    hit = ref["hit"]
    np.testing.assert_allclose(image.aovs["depth"][hit], ref["depth"][hit], rtol=0, atol=64 * U * 2 * D)
    np.testing.assert_allclose(image.aovs["albedo"][hit], np.broadcast_to([0.25, 0.5, 0.75], (hit.sum(), 3)),
                               rtol=1e-6)


@pytest.mark.parametrize("shading", ["phong", "path"])
@pytest.mark.parametrize("rfilter", ["lanczos", "mitchell"])
def test_filtered_mean_is_weighted(shading, rfilter):
    """With a reconstruction filter, each sample's AOV counts with the sample's filter weight, as its radiance
    does, and the host divides both sums by the sample count: the AOV's mean is the filter's normalised
    convolution of the AOV, as the beauty's is of the radiance (test_camera_renders'
    test_an_edge_renders_as_the_filters_convolution checks the beauty against a float64 quadrature). A scene
    where every camera sample's AOV equals its radiance makes the two the same numbers: two lights side by side
    and nothing else, radiance 1 (Phong: colour) left of x = 0.3 and 2 right of it, are shapes 1 and 2
    (aovs.SHAPE_ORDER), so each sample adds i w to the beauty's sums and i w to the shape_index's, the same
    float32 product of the same exact i and weight w, in the same order with the same compensation: the AOV
    equals each colour channel of the beauty bit for bit (measured). The filters have negative lobes (weights
    of either sign) and the edge between the lights lies within their reach of 4 to 6 of the 24 columns, where
    the weighted mean (int f(x - c) i(x) dx / int f) differs most from an unweighted one; elsewhere a constant
    i averages to i times the weights' mean, not i: with the weight dropped from the AOV the two differ in every
    pixel, by 0.0026 to 1.08 (median 0.19) for Lanczos and 0.0015 to 0.39 (median 0.07) for Mitchell at 64
    random samples per pixel, far above any rounding.

    Mutations tried, each failing every case here: the weight dropped from add_aovs (render.cl); the AOV sums
    divided by the count plus 1 (progressive.py's aov_means)."""
    scene = raytrace.load_dict({
        "camera": {"position": [0.3, 0.0, 0.0], "look_at": [0.3, 1.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": 70.0},
        "image": {"width": W, "height": H, "rfilter": rfilter},
        "render": {"shading": shading, "sampler": "random", "spp": 64},
        "lights": [{"center": [sign * 4.0, D, 0.0], "size": [8.0, 16.0], "normal": [0.0, -1.0, 0.0],
                    "tangent": [1.0, 0.0, 0.0], **({"colour": [i, i, i]} if shading == "phong" else {"radiance": i})}
                   for sign, i in ((-1, 1.0), (1, 2.0))],
        "materials": {"m": {"colour": [0.5, 0.5, 0.5]}}})
    image, stats = raytrace.render(scene, aov="shape")
    assert "-DHAS_RFILTER=1" in stats.build_options
    got = image.aovs["shape"][..., 0]
    for channel in range(3):
        np.testing.assert_array_equal(got, np.asarray(image)[..., channel])
    assert got[:, 0].mean() < 1.5 < got[:, -1].mean()

def test_parse():
    assert aovs.parse("albedo, normal", "x", "aov") == (("albedo", "albedo"), ("normal", "sh_normal"))
    assert aovs.parse(["dd.y:depth", "nn:sh_normal"], "x", "aov") == (("dd.y", "depth"), ("nn", "sh_normal"))
    assert aovs.parse("", "x", "aov") == () and aovs.parse(None, "x", "aov") == ()
    assert aovs.channel_names((("dd.y", "depth"), ("a", "albedo"))) == ["dd.y.T", "a.R", "a.G", "a.B"]
    for bad, words in (("albdo", "did you mean 'albedo'"), ("x:prim_index", "does not compute"),
                       ("x:normals", "did you mean 'sh_normal'"), (":depth", "needs a name"),
                       ("a:depth,a:uv", "given twice"), (3, "must be a string")):
        with pytest.raises(InputError, match=words) as e:
            aovs.parse(bad, "render()", "aov")
        assert str(e.value).startswith("render(): aov = ") and "\n" not in str(e.value)


def test_refusals(cornell):
    with pytest.raises(InputError, match="did you mean 'depth'"):
        raytrace.render(cornell, width=4, height=4, spp=1, aov="dept")
    with pytest.raises(InputError, match="AOVs adds them up on the host"):
        raytrace.render(cornell, width=4, height=4, spp=1, aov="depth", accumulate="device")


def test_no_aovs_builds_none(cornell):
    image, stats = raytrace.render(cornell, width=4, height=4, spp=1, sampler="center")
    assert "-DHAS_AOVS=0" in stats.build_options and image.aovs == {} and stats.aovs == []


def test_exr_channels(tmp_path):
    """Image.write and the command line write the AOVs as EXR channels named as Mitsuba's aov integrator names
    them, with the values of image.aovs; the command line refuses --aov with another output before any work."""
    import OpenImageIO as oiio
    scene = wall_scene()
    image, _ = raytrace.render(scene, aov="albedo,dd:depth,uv", spp=4, sampler="sobol")
    image.write(tmp_path / "a.exr")
    read = oiio.ImageInput.open(str(tmp_path / "a.exr"))
    names = list(read.spec().channelnames)
    pixels = read.read_image("float")
    assert read.spec().getattribute("raytrace:aovs") == "albedo:albedo,dd:depth,uv:uv"
    read.close()
    assert set(names) == {"R", "G", "B", "variance.R", "variance.G", "variance.B", "albedo.R", "albedo.G",
                          "albedo.B", "dd.T", "uv.U", "uv.V"}
    for channel, (name, k) in {"albedo.G": ("albedo", 1), "dd.T": ("dd", 0), "uv.V": ("uv", 1)}.items():
        np.testing.assert_array_equal(pixels[..., names.index(channel)], image.aovs[name][..., k])
    toml = ROOT / "scenes" / "cornell.toml"
    result = run("render", str(toml), "-o", str(tmp_path / "b.png"), "--aov", "albedo", "--spp", "1")
    assert result.returncode == 2 and "--aov" in result.stderr and len(result.stderr.splitlines()) == 1
    assert not (tmp_path / "b.png").exists()
    result = run("render", str(toml), "-o", str(tmp_path / "c.exr"), "--aov", "albedo,normal", "--spp", "1",
                 "--width", "8", "--height", "8")
    assert result.returncode == 0, result.stderr
    spec = oiio.ImageInput.open(str(tmp_path / "c.exr")).spec()
    assert {"albedo.R", "normal.X", "normal.Y", "normal.Z"} <= set(spec.channelnames)


def test_dask_carries_aovs():
    """A Dask render's AOVs are the local render's (the same bands' sums, added on the client)."""
    pytest.importorskip("dask.distributed")
    scene = wall_scene()
    local, _ = raytrace.render(scene, aov="depth,albedo")
    dist, _ = raytrace.render(scene, aov="depth,albedo", scheduler="local:1")
    for name in ("depth", "albedo"):
        np.testing.assert_array_equal(local.aovs[name], dist.aovs[name])


# The shapes of shape_scene, each alone in its part of the view, with the number the shape_index AOV gives it
# (aovs.SHAPE_ORDER: rectangles, loose triangles, meshes, ellipsoids, disks, cylinders, lights, instances) and a
# float64 test of whether a world point lies on it (the meshes' spheres: between the inscribed and the
# circumscribed radius of their tessellation; the other shapes: within 1e-4 of their surface, 1e4 times the
# kernel's position error at this scale, 10^3 times less than the 0.1 or more between shapes).
def _on_sphere(c, r, slack):
    return lambda p: np.abs(np.linalg.norm(p - c, axis=-1) - r) < slack


def _on_plane_square(c, axis, half):
    others = [k for k in range(3) if k != axis]
    return lambda p: (np.abs(p[..., axis] - c[axis]) < 1e-4) & np.all(np.abs(p[..., others] - c[others]) <= half, -1)


def _on_triangle(p):
    return (np.abs(p[..., 1]) < 1e-4) & (p[..., 2] >= 0.6 - 1e-4) & (p[..., 2] - 0.6 <= 2 * (p[..., 0] - 0.8) + 1e-4) \
        & (p[..., 2] - 0.6 <= 2 * (1.6 - p[..., 0]) + 1e-4)


SHAPES = {
    "rectangle": (1, _on_plane_square(np.array([0.0, 3.0, 0.0]), 1, 3.0)),
    "triangle": (2, _on_triangle),
    "mesh": (3, _on_sphere(np.array([0.0, 0.0, 1.0]), 0.4, 0.02)),
    "ellipsoid": (4, _on_sphere(np.array([-1.2, 0.0, 1.0]), 0.4, 1e-4)),
    "disk": (5, lambda p: (np.abs(p[..., 1]) < 1e-4) & (np.hypot(p[..., 0] + 1.2, p[..., 2] + 0.9) <= 0.4 + 1e-4)),
    "cylinder": (6, lambda p: (np.abs(np.hypot(p[..., 0], p[..., 1]) - 0.3) < 1e-4) & (p[..., 2] > -1.5 - 1e-4)
                 & (p[..., 2] < -0.7 + 1e-4)),
    "light": (7, _on_plane_square(np.array([1.2, 0.0, -0.9]), 1, 0.3)),
    "instance": (8, _on_sphere(np.array([0.0, 0.0, 0.05]), 0.25, 0.02)),
}


def shape_scene(instance=True):
    sphere = {"type": "mesh", "generate": {"shape": "sphere", "triangles": 400}, "material": "m"}
    shapes = [
        {"type": "triangle", "vertices": [[0.8, 0.0, 0.6], [1.6, 0.0, 0.6], [1.2, 0.0, 1.4]], "material": "m"},
        {"type": "ellipsoid", "center": [-1.2, 0.0, 1.0], "axes": [[0.4, 0, 0], [0, 0.4, 0], [0, 0, 0.4]],
         "material": "m"},
        {**sphere, "scale": 0.4, "translate": [0.0, 0.0, 1.0]},
        {"type": "cylinder", "radius": 0.3, "p0": [0.0, 0.0, -1.5], "p1": [0.0, 0.0, -0.7], "material": "m"},
        {"type": "disk", "to_world": [[0.4, 0, 0, -1.2], [0, 0, -0.4, 0], [0, 0.4, 0, -0.9], [0, 0, 0, 1]],
         "material": "m"},
        {"type": "rectangle", "center": [0.0, 3.0, 0.0], "size": [6.0, 6.0], "normal": [0.0, -1.0, 0.0],
         "tangent": [1.0, 0.0, 0.0], "material": "m"}]  # (not in SHAPE_ORDER's order: the lists are)
    table = {"camera": {"position": [0.0, -4.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": 50.0},
             "image": {"width": 48, "height": 40}, "render": {"shading": "path", "sampler": "center", "spp": 1},
             "lights": [{"center": [1.2, 0.0, -0.9], "size": [0.6, 0.6], "normal": [0.0, -1.0, 0.0],
                         "tangent": [1.0, 0.0, 0.0], "radiance": 1.0}],
             "materials": {"m": {"colour": [0.5, 0.5, 0.5]}}, "shapes": shapes}
    if instance:
        table["groups"] = {"g": {"shapes": [{**sphere, "scale": 0.25}]}}
        shapes.append({"type": "instance", "group": "g", "translate": [0.0, 0.0, 0.05]})
    return raytrace.load_dict(table)


@pytest.mark.parametrize("variant", ["instance", "bvh", "loop"])
def test_shape_index(lanes, variant):
    """The shape_index AOV (Mitsuba's, numbered in aovs.SHAPE_ORDER) of each pixel's centre ray is the number
    of the one shape its hit point lies on (SHAPES' float64 tests), and 0 where it meets nothing: every kind of
    shape (a light and an instance too) at every lane width, over a BVH whose leaf order renumbers the triangles
    (a mesh and an instance make one) and over the loop without one. The mean of one sample is the number itself.

    Mutations tried, each failing here: the triangles' numbers read in the soup's order instead of the leaf
    order (the mesh's pixels get other numbers), the disks' and cylinders' bases swapped in aovs.cl, the
    instance not standing for its group's triangles (0), a miss given the light's number."""
    import dataclasses
    from raytrace.renderer.program import Features
    scene = shape_scene(instance=variant == "instance")
    features = Features.of(scene, lanes)
    if variant != "instance":
        features = dataclasses.replace(features, bvh=variant == "bvh")
    image, stats = raytrace.render(scene, lanes=lanes, features=features, aov="shape,position")
    assert stats.aovs == [["shape", "shape_index"], ["position", "position"]]
    got, p = image.aovs["shape"][..., 0], image.aovs["position"].astype(np.float64)
    on = {name: test(p) for name, (_, test) in SHAPES.items() if variant == "instance" or name != "instance"}
    count = sum(on.values())
    miss = (p == 0).all(-1)
    assert (count[~miss] == 1).all()  # each hit point on one shape only
    for name, where in on.items():
        assert where.sum() >= 4, name
        np.testing.assert_array_equal(got[where], SHAPES[name][0], err_msg=name)
    assert miss.any() and not got[miss].any()


def test_memory_counts_the_aov_planes(monkeypatch):
    """render()'s memory check counts the AOVs' planes (16 bytes a plane per pixel: the float64 sum, the float32
    mean, image.aovs' array): with memory for the image alone, a render with AOVs is refused before any work.
    Mutation: the planes left out of check_memory's estimate (this render then starts: fails here)."""
    import importlib
    render_module = importlib.import_module("raytrace.render")
    scene = wall_scene()
    pixels = W * H
    monkeypatch.setattr(render_module, "available_memory",
                        lambda: pixels * render_module.BYTES_PER_PIXEL + render_module.HEADROOM_BYTES + 8 * pixels)
    render_module.check_memory(W, H)  # the image alone fits
    with pytest.raises(InputError, match="GiB of memory") as e:
        raytrace.render(scene, aov="albedo,depth")  # 4 planes: 64 bytes a pixel more
    assert "\n" not in str(e.value)


def test_the_scenes_aovs_need_an_exr(tmp_path):
    """A scene's own AOVs (render.aovs, or Mitsuba's aov integrator) with an output other than .exr are refused
    in one line naming the scene file and the key, before any work, as --aov is; an .exr output carries them.
    Mutation: the check for args.aov only (the PNG is written: fails here)."""
    text = (ROOT / "scenes" / "cornell.toml").read_text()
    assert "[render]" in text
    scene = tmp_path / "s.toml"
    scene.write_text(text.replace("[render]", '[render]\naovs = "albedo,dd:depth"', 1))
    result = run("render", str(scene), "-o", str(tmp_path / "b.png"), "--spp", "1", "--width", "8", "--height", "8")
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1, result.stderr
    assert str(scene) in result.stderr and "render.aovs" in result.stderr and ".exr" in result.stderr
    assert not (tmp_path / "b.png").exists()
    result = run("render", str(scene), "-o", str(tmp_path / "c.exr"), "--spp", "1", "--width", "8", "--height", "8")
    assert result.returncode == 0 and (tmp_path / "c.exr").exists(), result.stderr


def test_stats_hold_no_arrays():
    """RenderStats.aov_images (the AOVs render_progressive returns beside the image) is no dataclass field, so
    --stats-json (dataclasses.asdict) holds no arrays, and each RenderStats has its own dict. Mutation: a class
    attribute `{}` (as it was): a RenderStats made by dataclasses.replace sees another's entries, fails here."""
    import dataclasses
    import json
    image, stats = raytrace.render(wall_scene(), aov="depth")
    assert stats.aov_images["depth"] is not None and "depth" in image.aovs
    assert "aov_images" not in json.dumps(dataclasses.asdict(stats))
    first, second = dataclasses.replace(stats), dataclasses.replace(stats)
    first.aov_images["x"] = 1
    assert second.aov_images == {} and "x" not in stats.aov_images


def test_only_a_file_with_the_layers_names_them(tmp_path):
    """An image's metadata names its AOVs ("aovs": Mitsuba's "name:type,..."); a file carries that attribute
    only with the AOVs' layers: an EXR does, a PNG (no layers) does not, though it carries the other (text)
    attributes. Mutation: the attribute kept in every file (as it was): the PNG names albedo and depth, fails here."""
    import OpenImageIO as oiio
    image, _ = raytrace.render(wall_scene(), aov="albedo,depth")
    for name, named in (("a.png", None), ("a.exr", "albedo:albedo,depth:depth")):
        image.write(tmp_path / name)
        spec = oiio.ImageInput.open(str(tmp_path / name)).spec()
        assert spec.getattribute("raytrace:aovs") == named, name
        assert spec.getattribute("raytrace:sampler") == "center", name
