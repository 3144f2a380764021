"""MIP pyramids, the packed buffer and the MIP-mapped filters (raytrace/scene/mipmap.py, kernels/mipmap.cl)
against the float64 reference (tests/reference_textures.py) and OpenImageIO (make_texture, TextureSystem)."""
import numpy as np
import OpenImageIO as oiio
import pytest

import raytrace

import reference_textures as ref
from raytrace.renderer import packing
from raytrace.scene import mipmap
from raytrace import structs
from raytrace.scene.textures import make_texture
from helpers import kernel_lookup, openimageio_lookup, stored_levels


@pytest.mark.parametrize("shape", [(16, 16), (7, 5), (1, 9), (6, 3), (33, 64)])
def test_pyramid_is_the_area_average(shape):
    """Against the reference's interval-overlap matrices (a different construction): float64 rounding only
    (1e-12). Area averaging keeps the image's mean at every level, whatever the sizes."""
    image = np.random.default_rng(0).random(shape + (3,))
    levels, want = mipmap.pyramid(image), ref.pyramid(image)
    assert [lv.shape for lv in levels] == [lv.shape for lv in want]
    assert levels[-1].shape[:2] == (1, 1)
    for got, expected in zip(levels, want):
        np.testing.assert_allclose(got, expected, atol=1e-12)
        np.testing.assert_allclose(got.mean(axis=(0, 1)), image.mean(axis=(0, 1)), atol=1e-12)


def test_pyramid_matches_openimageio_box_filter(tmp_path):
    """OpenImageIO's make_texture with the box filter: on power-of-two sizes each level is the 2 x 2 mean of
    the one above, as ours; float32 files, so the bound is float32 rounding of means of values < 1 (1e-6)."""
    image = np.random.default_rng(1).random((32, 64, 3)).astype(np.float32)
    config = oiio.ImageSpec()
    config.attribute("maketx:filtername", "box")
    assert oiio.ImageBufAlgo.make_texture(oiio.MakeTxTexture, oiio.ImageBuf(image), str(tmp_path / "t.tx"), config)
    theirs = oiio.ImageInput.open(str(tmp_path / "t.tx"))
    ours = mipmap.pyramid(image)
    for level, expected in enumerate(ours):
        assert theirs.seek_subimage(0, level)
        np.testing.assert_allclose(theirs.read_image("float"), expected, atol=1e-6)
    assert not theirs.seek_subimage(0, len(ours))
    theirs.close()


def test_eight_bit_levels_are_the_nearest_codes():
    """Each coarser 8-bit level holds, per texel, the code whose decoded value is nearest to the linear
    average: no code is farther from it than its neighbour codes are."""
    codes = np.random.default_rng(2).integers(0, 256, (16, 24, 4), dtype=np.uint8)
    for srgb in (True, False):
        levels = mipmap.pyramid_8bit(codes, srgb)
        linear = mipmap.pyramid(mipmap.decode_8bit(codes, srgb))
        np.testing.assert_array_equal(levels[0], codes)
        table = mipmap.SRGB8_TO_LINEAR if srgb else np.arange(256) / 255
        for stored, exact in zip(levels[1:], linear[1:]):
            error = np.abs(table[stored[..., :3]] - exact[..., :3])
            for step in (-1, 1):
                neighbour = np.clip(stored[..., :3].astype(int) + step, 0, 255)
                assert np.all(error <= np.abs(table[neighbour] - exact[..., :3]) + 1e-15)


def test_sixteen_bit_levels_are_the_nearest_codes():
    """16-bit height maps: level 0 keeps the codes; each coarser level holds the code nearest to the exact
    average of code / 65535 (within half a code), in the levels' layout."""
    codes = np.random.default_rng(5).integers(0, 65536, (12, 20, 1)).astype(np.uint16)
    levels = mipmap.pyramid_16bit(codes)
    exact = mipmap.pyramid(codes / 65535.0)
    np.testing.assert_array_equal(levels[0], codes)
    assert [level.shape for level in levels] == [level.shape for level in exact]
    for stored, average in zip(levels[1:], exact[1:]):
        assert stored.dtype == np.uint16 and np.all(np.abs(stored / 65535.0 - average) <= 0.5 / 65535.0 + 1e-15)


def test_packed_layout():
    """Offsets increase, levels never overlap, float levels are 16-byte aligned, and the buffer ends where
    the last level does."""
    rng = np.random.default_rng(3)
    textures = [make_texture(rng.integers(0, 256, (5, 7, 3), dtype=np.uint8), "8-bit", "colour"),
                make_texture(rng.random((9, 4, 1)).astype(np.float32), "float", "height"),
                make_texture(rng.integers(0, 256, (3, 3, 3), dtype=np.uint8), "8-bit", "normal")]
    texels, levels, table = packing.pack_textures(textures)
    assert table.tolist() == [(0, 3, 0), (3, 4, structs.TEXELS_QUADF), (7, 2, 1)]
    words = [structs.TEXEL_WORDS[t.encoding] for t in textures for _ in t.levels]
    end = 0
    for (offset, width, height), per_texel in zip(levels.tolist(), words):
        assert offset >= end and (per_texel == 1 or offset % 4 == 0)
        end = offset + width * height * per_texel
    assert end == texels.size


def test_every_level_is_reachable(harness):
    """A footprint of exactly 2^l level-0 texels selects level l alone (D = l, no blend): at that level's
    texel centres the trilinear lookup returns its stored texels exactly, for every level of every texture
    in one packed buffer."""
    rng = np.random.default_rng(4)
    textures = [make_texture(rng.integers(0, 256, (8, 16, 3), dtype=np.uint8), "8-bit", "colour"),
                make_texture(rng.random((16, 8, 3)).astype(np.float32), "float", "colour"),
                make_texture(rng.integers(0, 256, (8, 16, 1), dtype=np.uint8), "8-bit", "height"),
                make_texture(rng.random((16, 8, 1)).astype(np.float32), "float", "height"),
                make_texture(rng.random((8, 16, 1)).astype(np.float32), "16-bit", "height")]
    for index, texture in enumerate(textures):
        levels = stored_levels(texture)
        w0, h0 = texture.size
        for level, expected in enumerate(levels):
            h, w = expected.shape[:2]
            jj, ii = np.mgrid[0:h, 0:w]
            s, t = ((ii + 0.5) / w).ravel(), ((jj + 0.5) / h).ravel()
            size = 2.0 ** level
            derivs = np.tile([[size / w0], [0], [0], [size / h0]], len(s))
            got = kernel_lookup(harness, textures, index, "trilinear", "repeat", s, t, derivs)
            np.testing.assert_allclose(got, expected.reshape(-1, 3), atol=1e-6)


def random_footprints(rng, n, size):
    """Footprint derivatives (ds/dx, dt/dx, ds/dy, dt/dy) from 0.3 to 40 level-0 texels, any orientation and
    elongation up to 12."""
    length = np.exp(rng.uniform(np.log(0.3), np.log(40), n))
    angle, ratio = rng.uniform(0, 2 * np.pi, n), np.exp(rng.uniform(0, np.log(12), n))
    major = length * np.stack([np.cos(angle), np.sin(angle)])
    minor = length / ratio * np.stack([-np.sin(angle), np.cos(angle)])
    swap = rng.random(n) < 0.5  # the major axis along x or along y
    ax, ay = np.where(swap, minor, major), np.where(swap, major, minor)
    return np.stack([ax[0] / size[0], ax[1] / size[1], ay[0] / size[0], ay[1] / size[1]])


@pytest.mark.parametrize("filter_name", ["trilinear", "anisotropic"])
@pytest.mark.parametrize("wrap", ["repeat", "mirror"])
def test_mipmapped_filters_match_reference(harness, filter_name, wrap):
    """Random points and footprints against the reference. The level D = log2 L is a float32 log of a
    float32 length: off by ~1e-6, which moves the blend weight by as much, on values < 1; the bilinear
    weights add ~1e-6 more: bound 1e-5 (anisotropic: a mean of such probes, same bound). The probe count
    is a ceil() of a ratio; the reference rounds the ratio to 1e-3 first, and points within float32 noise
    of such a step are rare enough (measure zero) that none of these 256 sits on one."""
    rng = np.random.default_rng(5)
    texture = make_texture(rng.integers(0, 256, (24, 40, 3), dtype=np.uint8), "8-bit", "colour")
    s, t = rng.uniform(-1, 2, 256), rng.uniform(-1, 2, 256)
    derivs = random_footprints(rng, 256, texture.size)
    got = kernel_lookup(harness, [texture], 0, filter_name, wrap, s, t, derivs)
    want = ref.lookup(stored_levels(texture), filter_name, s, t, derivs, wrap)
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_trilinear_against_openimageio(harness, tmp_path):
    """OpenImageIO's TextureSystem, trilinear, isotropic footprints of w level-0 texels. It blends levels
    l0 = floor(log2 w) and l0 + 1 with weight f' = w / 2^l0 - 1 where we use f = log2 w - l0 (docs/textures.md's
    D = log2 L); so per point |ours - theirs| <= |f - f'| |level l0 - level l0 + 1| (bilinear values at the
    point, from the reference), which is the bound checked, plus 2e-6 of float32 rounding. At w = 2^k both
    rules agree and so must the results (to 2e-6)."""
    rng = np.random.default_rng(6)
    image = rng.random((32, 32, 3)).astype(np.float32)
    levels = ref.pyramid(image.astype(np.float64))
    s, t = rng.random(128), rng.random(128)
    w = np.concatenate([np.exp(rng.uniform(0, np.log(16), 120)), [1, 2, 4, 8, 1, 2, 4, 8]])
    theirs = openimageio_lookup(tmp_path, image, oiio.MipMode.Trilinear, s, t, np.stack([w / 32, 0 * w, 0 * w, w / 32]))
    ours = kernel_lookup(harness, [make_texture(image, "float", "colour")], 0, "trilinear", "repeat", s, t,
                         np.stack([w / 32, 0 * w, 0 * w, w / 32]))
    l0 = np.floor(np.log2(w)).astype(int)
    fine = np.array([ref.bilinear(levels[lv], s[i:i + 1], t[i:i + 1], "repeat")[0] for i, lv in enumerate(l0)])
    coarse = np.array([ref.bilinear(levels[lv + 1], s[i:i + 1], t[i:i + 1], "repeat")[0] for i, lv in enumerate(l0)])
    bound = np.abs((np.log2(w) - l0) - (w / 2.0 ** l0 - 1))[:, None] * np.abs(fine - coarse) + 2e-6
    assert np.all(np.abs(ours - theirs) <= bound)
    assert np.abs(ours - theirs).max() > 1e-4, "the two blend rules do differ between powers of two"


@pytest.fixture(scope="module")
def grid_floor():
    from helpers import ROOT
    return raytrace.load_file(ROOT / "scenes" / "grid_floor.toml")


def test_mipmapping_removes_aliasing(grid_floor):
    """The course's aliasing test, measured: the grid floor at 1 spp with trilinear filtering is closer
    (RMSE) to a 256-spp supersampled render than the 1-spp render with nearest filtering, by at least 30%.
    The supersampled render uses bilinear (no MIP-mapping), so the reference does not favour MIP-maps.
    One light sample: shading is not what is compared. (The grid's lines sit on the pyramid's texel
    pairs; lines straddling them blur twice as wide at every level, and then trilinear gains only ~10%
    here: raytrace/commands/assets.py.)"""
    size = dict(width=96, height=96, light_samples=1)
    truth, _ = raytrace.render(grid_floor, spp=256, sampler="grid", texture_filter="bilinear", **size)
    rmse = {f: np.sqrt(np.mean((raytrace.render(grid_floor, spp=1, sampler="center", texture_filter=f, **size)[0]
                                - truth) ** 2)) for f in ("nearest", "trilinear", "anisotropic")}
    assert rmse["trilinear"] <= 0.7 * rmse["nearest"], rmse
    assert rmse["anisotropic"] <= rmse["trilinear"], rmse


def test_texture_content_never_rebuilds(grid_floor, tmp_path):
    """Another texture (other size, other format), another filter, another spp: the same program, built
    once (build seconds 0 after the first render of this variant in the process)."""
    import dataclasses
    from raytrace.scene.textures import make_texture
    raytrace.render(grid_floor, width=16, height=16, spp=1, sampler="center", light_samples=1)
    other = dataclasses.replace(grid_floor, textures=[make_texture(np.random.default_rng(0).random((37, 21, 3)).astype(
        np.float32), "float", "colour")])
    for scene, f, spp in ((other, "nearest", 4), (grid_floor, "anisotropic", 9), (other, "trilinear", 1)):
        image, stats = raytrace.render(scene, width=16, height=16, spp=spp, light_samples=1, texture_filter=f,
                                       sampler="center" if spp == 1 else "grid")
        assert stats.build_seconds == 0 and np.all(np.isfinite(image))
