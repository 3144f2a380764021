"""The material at a hit (kernels/material.cl): colour maps, normal maps, bump maps and displacement, for
each kind of shape, from camera ray to shading point, against the float64 reference composed of
tests/reference.py (rays, intersections) and tests/reference_textures.py (surfaces, footprints, filters)."""
import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace
import reference
import reference_textures as ref
from helpers import ROOT, at_lane_ends, stored_levels
from raytrace.renderer.program import Features
from raytrace.scene import parse_scene
from raytrace.numerics import U
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.scene_tables import scene_tables

SOURCE = """
#include "camera.cl"
#include "material.cl"
__kernel void shading(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS,
                      __global const float *xy,
                      __global float *k, __global float *nrm, __global float *pos, __global float *err)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    Ray r = generate_camera_ray(camera, IN(xy), IN(xy + n), lens, &tmax);
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    ShadingPoint sp = shading_point(&s, ts, r, hit);
    OUT3(k, sp.k);
    OUT3(nrm, sp.n);
    OUT3(pos, sp.p);
    OUT(err, sp.err);
}
"""

SIZE = 64


def smooth_map(rng, channels, lo, hi, size=SIZE):
    """A periodic size x size map of a few low-frequency waves in [lo, hi]: its texel-to-texel steps are
    small, so float32 rounding of coordinates moves a lookup by little (the tests' bounds use this)."""
    y, x = np.mgrid[0:size, 0:size] * (2 * np.pi / size)
    out = []
    for _ in range(channels):
        a, b, c = rng.integers(1, 4, 3)
        wave = np.sin(a * x + rng.uniform(0, 6)) * np.cos(b * y + c * x + rng.uniform(0, 6))
        out.append(lo + (hi - lo) * (wave + 1) / 2)
    return np.stack(out, axis=2)


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """Real files: an 8-bit sRGB colour map, an 8-bit normal map tilted up to ~35 degrees, a float height
    map, a float height map of half their size, and one of their width and half their height (the same
    number of levels and the same width as the others: a filter shared by shape must tell it apart)."""
    rng, folder = np.random.default_rng(8), tmp_path_factory.mktemp("maps")
    colour = np.round(smooth_map(rng, 3, 0.1, 0.9) * 255).astype(np.uint8)
    normal = np.concatenate([smooth_map(rng, 2, 0.3, 0.7), np.full((SIZE, SIZE, 1), 0.9)], axis=2)
    height = smooth_map(rng, 1, 0.0, 1.0).astype(np.float32)
    small = smooth_map(rng, 1, 0.0, 1.0, SIZE // 2).astype(np.float32)
    short = np.ascontiguousarray(smooth_map(rng, 1, 0.0, 1.0)[::2])
    files = {}
    for name, pixels, fmt in (("colour.png", colour, "uint8"), ("normal.png", np.round(normal * 255).astype(np.uint8),
                                                                  "uint8"), ("height.exr", height, "float"),
                              ("small_height.exr", small, "float"), ("short_height.exr", short.astype(np.float32),
                                                                     "float")):
        spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
        out = oiio.ImageOutput.create(str(folder / name))
        assert out.open(str(folder / name), spec) and out.write_image(pixels) and out.close()
        files[name.split(".")[0]] = str(folder / name)
    return files


SHAPES = {
    "rectangle": {"type": "rectangle", "center": [0.0, 0.5, 0.0], "size": [3.0, 2.2], "normal": [0.0, 0.0, 1.0],
                  "tangent": [1.0, 0.0, 0.0]},
    "triangle": {"type": "triangle", "vertices": [[-1.5, 1.0, 0.0], [1.5, 0.5, 0.2], [0.0, 1.2, 2.2]],
                 "uv": [[0.1, 0.0], [1.3, 0.2], [0.5, 1.1]]},
    "ellipsoid": {"type": "ellipsoid", "center": [0.0, 0.5, 1.0], "axes": [[0.8, 0.1, 0.0], [0.0, 0.6, -0.4],
                                                                            [0.0, 0.3, 0.7]]},
}


def make_scene(shape, material):
    table = {"camera": {"position": [0.0, -3.0, 1.3], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0], "fov": 45.0},
             "image": {"width": 48, "height": 40}, "ambient": [0.1, 0.1, 0.1],
             "lights": [{"center": [0.0, 0.0, 3.0], "size": [0.5, 0.3], "normal": [0.0, 0.0, -1.0],
                         "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0]}],
             "materials": {"m": material}, "shapes": [{**SHAPES[shape], "material": "m"}]}
    return parse_scene(table, str(ROOT / "scenes" / "test.toml"))


def expected_shading(scene, x, y, spp, filter_name):
    """The float64 composition: camera ray, hit, surface, footprint, uv transform, lookups, frame, normal
    map, bump, displacement. Returns (hit mask, colour, shading normal, shading point, geometric normal)."""
    cam, m = scene.camera, scene.materials[0]
    o, d = reference.camera_rays(scene, x, y, scene.width, scene.height)
    if scene.rectangles:
        r = scene.rectangles[0]
        t = reference.intersect_rectangle(r, o, d, 0, np.inf)
        surface = ref.rectangle_surface(r.center, r.size, r.normal, r.tangent, o + t[:, None] * d)
    elif scene.triangles:
        tri = scene.triangles[0]
        t, b1, b2 = reference.intersect_triangle(tri.vertices, o, d, 0, np.inf)
        surface = ref.triangle_surface(tri.vertices, tri.uv, b1, b2)
    else:
        e = scene.ellipsoids[0]
        t, _ = reference.intersect_ellipsoid(e, o, d, 0, np.inf)
        surface = ref.ellipsoid_surface(e.center, e.matrix, o + np.where(np.isfinite(t), t, 0)[:, None] * d)
    hit = np.isfinite(t)
    p = o + np.where(hit, t, 0)[:, None] * d
    ng = np.where((np.einsum("ij,ij->i", surface["normal"], d) > 0)[:, None], -surface["normal"], surface["normal"])
    basis = ref.camera_basis(cam.position, cam.look_at, cam.ref_up)
    _, d_x, d_y = ref.ray_differentials(basis, cam.fov_deg, cam.focal_length, scene.width, scene.height, x, y,
                                        max(0.125, 1 / np.sqrt(spp)))
    derivs_uv = ref.uv_derivatives(surface["dpdu"], surface["dpdv"], *ref.surface_differentials(o, p, ng, d_x, d_y))
    s, tt, derivs = ref.texture_coords(surface["u"], surface["v"], derivs_uv, m.uv_scale, m.uv_offset)
    levels = [stored_levels(texture) for texture in scene.textures]
    colour = ref.lookup(levels[m.colour_map], filter_name, s, tt, derivs, m.wrap) if m.colour_map >= 0 else m.colour
    frame = ref.shading_frame(surface)
    n = frame[2]
    if m.normal_map >= 0:
        n = ref.normal_map_normal(frame, ref.lookup(levels[m.normal_map], filter_name, s, tt, derivs, m.wrap))
    if m.height_map >= 0:
        h, hu, hv = ref.height_gradient(levels[m.height_map], filter_name, surface["u"], surface["v"], derivs_uv,
                                        m.wrap, m.uv_scale, m.uv_offset)
        n = ref.bump_normal(surface["dpdu"] / m.uv_scale[0], surface["dpdv"] / m.uv_scale[1], n, m.height_scale,
                            hu, hv)
        p = p + ng * (m.height_scale * h)[:, None]
    side = np.sign(np.einsum("ij,ij->i", frame[2], ng))
    return hit, colour, n * side[:, None], p, ng


def kernel_shading(harness, scene, x, y, spp, filter_name):
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    args = {**scene_tables(scene, scene.width, scene.height, spp, 1, filter_name, features=features),
            **texture_tables(scene), "xy": np.concatenate([x, y]).astype(np.float32)}
    return harness.run(SOURCE, "shading", len(x), args, {"k": 3, "nrm": 3, "pos": 3, "err": 1}, **defines)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("filter_name", ["trilinear", "anisotropic"])
@pytest.mark.parametrize("height", ["height", "small_height", "short_height"])
def test_shading_point_matches_reference(harness, maps, shape, filter_name, height):
    """All three maps at once, with a uv transform and mirror wrapping, on each kind of shape, at random
    pixel positions; the height map of the maps' size (the kernel finds one filter for all three,
    material.cl) or of half their size or half their height (a filter of its own: a shared one would read the
    wrong levels; its steps between texels double, and so does its bump's step du below, so its bound holds
    too). The maps are
    smooth (steps between texels <= ~0.1), so the kernel's float32 rounding of uv (~1e-6 relative) and of
    the footprint (~1e-4 relative, from differences of hit points ~3 units from the camera) moves a lookup by < 1e-4 of the value range and the MIP level by < 2e-4: colour
    bound 1e-3. The bump divides differences of two such lookups by the step du ~ the footprint (>= 1/2
    texel = 1/128 of uv): 1e-4 / (1/128) * height_scale 0.05 tilts the normal by < 1e-3 radian on a
    tangent of unit size; with the normal map's own error, bound 3e-3 on the normal. Displaced points
    move by height_scale * h: error 0.05 * 1e-3, plus float32 of coordinates ~3: bound 1e-4."""
    material = {"texture": maps["colour"], "normal_map": maps["normal"], "height_map": maps[height],
                "height_scale": 0.05, "uv_scale": [2.0, 1.5], "uv_offset": [0.1, -0.3], "wrap": "mirror"}
    scene = make_scene(shape, material)
    rng = np.random.default_rng(9)
    x, y = rng.uniform(0, scene.width, 512), rng.uniform(0, scene.height, 512)
    got = kernel_shading(harness, scene, x, y, 4, filter_name)
    with np.errstate(invalid="ignore"):  # the reference also runs its lookups for the rays that miss
        hit, colour, normal, p, ng = expected_shading(scene, x, y, 4, filter_name)
    assert np.count_nonzero(hit) > 100
    np.testing.assert_allclose(got["k"].T[hit], colour[hit], atol=1e-3)
    np.testing.assert_allclose(got["nrm"].T[hit], normal[hit], atol=3e-3)
    np.testing.assert_allclose(got["pos"].T[hit], p[hit], atol=1e-4)
    assert np.all(got["k"].T[~hit] == 0)
    check_displacement_bound(harness, shape, material, x, y, filter_name, got, ng, hit)


def check_displacement_bound(harness, shape, material, x, y, filter_name, got, ng, hit):
    """The displaced point's error bound is the surface point's (the same material without its height map)
    plus the rounding of p + (kh h) ng: kh h, its product with ng_i and the sum round once each, within
    gamma(3) (|p_i| + |kh h ng_i|) per coordinate whatever the sum's size, projected on |ng|. The kernel
    forms that in float32 (a few roundings of a bound: relative 1e-5); kh h is read back from the two
    points along ng (exact enough: its rounding changes the bound by 1e-7 relative)."""
    flat = {k: v for k, v in material.items() if k not in ("height_map", "height_scale")}
    plain = kernel_shading(harness, make_scene(shape, flat), x, y, 4, filter_name)
    p0, p1 = plain["pos"].T[hit].astype(np.float64), got["pos"].T[hit].astype(np.float64)
    n = np.abs(ng[hit])
    lift = np.abs(np.einsum("ij,ij->i", p1 - p0, ng[hit]))
    expect = 3 * U / (1 - 3 * U) * np.einsum("ij,ij->i", n, np.abs(p0) + n * lift[:, None])
    np.testing.assert_allclose(got["err"][hit] - plain["err"][hit], expect, rtol=1e-5, atol=1e-12)


def flat_maps(tmp_path):
    """A float normal map of exactly (0.5, 0.5, 1) and a height map of zeros, as files."""
    for name, value in (("flat.exr", [0.5, 0.5, 1.0]), ("zero.exr", [0.0])):
        pixels = np.broadcast_to(np.array(value, np.float32), (8, 8, len(value))).copy()
        out = oiio.ImageOutput.create(str(tmp_path / name))
        assert out.open(str(tmp_path / name), oiio.ImageSpec(8, 8, len(value), "float")) and out.write_image(pixels)
        out.close()
    return str(tmp_path / "flat.exr"), str(tmp_path / "zero.exr")


@at_lane_ends
def test_flat_normal_map_and_zero_height_change_nothing(tmp_path, lanes):
    """A flat normal map gives the frame's normal, which is the geometric normal up to its float32
    rounding (a few 1e-7); a height map of zeros tilts nothing (its differences are exactly 0) and
    displaces nothing. Shadow rays leave from the same points along the same normal, so no shadow test
    can flip; the lobes move by < 16 (the exponent) * 1e-6: bound 2e-5 per pixel, for every shape kind."""
    flat, zero = flat_maps(tmp_path)
    for shape in SHAPES:
        plain = make_scene(shape, {"colour": [0.7, 0.6, 0.5]})
        mapped = make_scene(shape, {"colour": [0.7, 0.6, 0.5], "normal_map": flat, "height_map": zero,
                                    "height_scale": 0.1})
        a, _ = raytrace.render(plain, spp=4, light_samples=4, lanes=lanes)
        b, stats = raytrace.render(mapped, spp=4, light_samples=4, lanes=lanes)
        assert "-DHAS_NORMAL_MAPS=1" in stats.build_options and "-DHAS_HEIGHT_MAPS=1" in stats.build_options
        assert a.max() > 0.3
        np.testing.assert_allclose(b, a, atol=2e-5, err_msg=shape)


@pytest.mark.parametrize("filter_name", ["nearest", "bilinear", "trilinear", "anisotropic"])
def test_lanes_with_different_materials_match_one_lane(cl_env, maps, filter_name):
    """Neighbouring lanes that hit different materials: material.cl runs each textured material's lookups
    on all lanes and keeps them on that material's lanes only. Random pixels (so each group of 8 mixes a
    colour-mapped wall, a normal- and height-mapped wall with another uv transform and wrap mode, an
    untextured ellipsoid and misses) at LANES=8 against LANES=1, which the tests above check against the
    float64 reference lane by lane; under every filter (each gathers its levels and probes per lane). Both
    widths run the same float32 operations; only where the compiler
    fuses a multiply-add can a rounding differ (~1e-7), which the bump's division by du (>= 1/2 texel of a
    64-texel map at uv_scale 3) and height_scale 0.05 amplify by < 0.05 * 384 = 20: bound 1e-5."""
    from raytrace.commands.stability.probe import Probe
    table = {"camera": {"position": [0.0, -3.0, 1.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0],
                        "fov": 60.0},
             "image": {"width": 48, "height": 40}, "ambient": [0.1, 0.1, 0.1],
             "lights": [{"center": [0.0, -1.0, 3.0], "size": [0.5, 0.3], "normal": [0.0, 0.0, -1.0],
                         "tangent": [1.0, 0.0, 0.0], "colour": [1.0, 1.0, 1.0]}],
             "materials": {"painted": {"texture": maps["colour"], "uv_scale": [2.0, 1.0], "wrap": "mirror"},
                           "bumpy": {"colour": [0.8, 0.7, 0.6], "normal_map": maps["normal"], "height_map": maps["height"],
                                     "height_scale": 0.05, "uv_scale": [3.0, 3.0], "uv_offset": [0.2, 0.1]},
                           "plain": {"colour": [0.3, 0.6, 0.2]}},
             "shapes": [{"type": "rectangle", "center": [-1.0, 0.5, 1.0], "size": [2.0, 2.0],
                         "normal": [0.0, -1.0, 0.0], "tangent": [1.0, 0.0, 0.0], "material": "painted"},
                        {"type": "rectangle", "center": [1.0, 0.5, 1.0], "size": [2.0, 2.0],
                         "normal": [0.0, -1.0, 0.0], "tangent": [1.0, 0.0, 0.0], "material": "bumpy"},
                        {"type": "ellipsoid", "center": [0.0, -0.5, 1.2], "axes": [[0.4, 0, 0], [0, 0.4, 0],
                                                                                     [0, 0, 0.4]],
                         "material": "plain"}]}
    scene = parse_scene(table, str(ROOT / "scenes" / "test.toml"))
    rng = np.random.default_rng(10)
    x, y = rng.uniform(0, scene.width, 1024), rng.uniform(0, scene.height * 1.1, 1024)
    one = kernel_shading(Probe(1, env=cl_env), scene, x, y, 4, filter_name)
    eight = kernel_shading(Probe(8, env=cl_env), scene, x, y, 4, filter_name)
    red = one["k"][0].reshape(-1, 8)  # 0.8 on "bumpy", 0.3 on "plain", a colour map's texel or 0 (a miss)
    kinds = [len({0.8 if np.isclose(r, 0.8) else 0.3 if np.isclose(r, 0.3) else 0 if r == 0 else 1 for r in g})
             for g in red]
    assert np.mean(np.array(kinds) >= 3) > 0.5, "most groups of 8 lanes mix three kinds of hit"
    for key in ("k", "nrm", "pos"):
        np.testing.assert_allclose(eight[key], one[key], atol=1e-5, err_msg=key)
    np.testing.assert_allclose(eight["err"], one["err"], rtol=1e-5, err_msg="err (a bound: relative)")
