"""End to end: the kernel's image of the course's scene 0 against the float64 numpy renderer."""
import dataclasses

import numpy as np
import pytest

import reference
from helpers import runnable_lane_widths
import raytrace
from raytrace import samplers
from raytrace.renderer.program import Features


@pytest.fixture(scope="module")
def small(cornell):
    """48 x 48, 2 x 2 grid pixel samples, 4 x 4 light grid: both renders of the same model."""
    image, stats = raytrace.render(cornell, width=48, height=48, spp=4, light_samples=16)
    ref = reference.render(cornell, samplers.grid(4), samplers.grid(16), 48, 48)
    return image, stats, ref


def test_matches_reference_renderer(small):
    """Where both renders see the same surfaces and the same lit light samples, they differ only by float32
    rounding of smooth shading (terms <= 2, some tens of roundings of 2^-24: below 1e-5; bound 1e-4).
    Elsewhere a (pixel sample, light sample) pair may flip: the kernel leaves surfaces from a point offset
    by its float32 error bound and computes in float32, which moves shadow edges by far less than 1e-4
    scene units, a few thousandths of a pixel here, so at most about one pair in a hundred boundary pixels
    flips. One flip moves a pixel by at most
    k L (n.l + 1) / (spp N) <= 2/64 = 0.031; so at most 1% of the pixels may differ by more than 1e-4
    and the RMSE stays below sqrt(0.01) * 0.031 = 3.1e-3."""
    image, _, ref = small
    err = np.abs(image - ref).max(axis=-1)
    assert np.mean(err > 1e-4) <= 0.01
    assert np.sqrt(np.mean((image - ref) ** 2)) <= 3.1e-3
    assert np.all(err <= 2 * 0.031 + 1e-4), "never more than two flipped pairs in a pixel"


def test_counts_rays_and_stays_finite(small):
    image, stats, _ = small
    assert image.shape == (48, 48, 3) and image.dtype == np.float32
    assert np.all(np.isfinite(image)) and stats.extra["nonfinite_values"] == 0
    primary = 48 * 48 * 4
    assert primary < stats.rays <= primary * (1 + 16)   # camera rays + at most 16 shadow rays each
    assert stats.render_seconds > 0 and stats.mrays_per_s > 0


def test_orientation(cornell):
    """Red wall on the left, green on the right, floor at the bottom, light at the top (row 0 on top);
    the width (42) is not a multiple of the lane width, so the masked last lanes are covered too."""
    image, _ = raytrace.render(cornell, width=42, height=42, spp=1, light_samples=4, sampler="center")
    left, right = image[15:30, :3].mean(axis=(0, 1)), image[15:30, -3:].mean(axis=(0, 1))
    assert left[0] > 5 * left[1] and right[1] > 5 * right[0]
    assert image[-2:, 15:27].mean() > 0.3, "the lit floor at the bottom"
    top = image[:8, 15:27]
    assert np.all(top.max(axis=(0, 1)) >= 1.0), "the light (colour 1) is seen near the top"


@pytest.mark.parametrize("lanes", [n for n in runnable_lane_widths() if n > 1])
def test_lanes_agree(cornell, lanes):
    """The scalar (GPU-style) kernel and the vector kernel are one source: they compute the same image. At 16
    spp a pass holds 8 samples, so the vector kernel's lanes hold up to 8 samples of a pixel at once
    (kernels/tile.h) and add them up at the end, where the scalar kernel adds one sample after another: the
    sums round differently, by a few float32 roundings of values below 2 (atol 1e-6)."""
    options = dict(width=24, height=16, spp=16, light_samples=4)
    one, _ = raytrace.render(cornell, **options, lanes=1)
    vector, _ = raytrace.render(cornell, **options, lanes=lanes)
    np.testing.assert_allclose(one, vector, atol=1e-6)


def test_specialised_kernel(cornell):
    """A scene without ellipsoids builds without ellipsoid code, and its image is the all-features
    kernel's image."""
    no_ellipsoid = dataclasses.replace(cornell, ellipsoids=[])
    features = Features.of(no_ellipsoid, 8)
    assert features.options() == ["-DLANES=8", "-DHAS_RECTANGLES=1", "-DHAS_TRIANGLES=1", "-DHAS_ELLIPSOIDS=0",
                                  "-DHAS_DISKS=0", "-DHAS_CYLINDERS=0",
                                  "-DHAS_COLOUR_MAPS=0", "-DHAS_NORMAL_MAPS=0", "-DHAS_HEIGHT_MAPS=0",
                                  "-DHAS_SMOOTH_NORMALS=0", "-DHAS_BVH=1", "-DHAS_DIRECT_LIGHTING=0",
                                  "-DHAS_PATH_TRACING=0", "-DHAS_CONDUCTORS=0", "-DHAS_DIELECTRICS=0",
                                  "-DHAS_ROUGH_CONDUCTORS=0", "-DHAS_ENVIRONMENT=0", "-DHAS_ENVIRONMENT_MAP=0",
                                  "-DHAS_THIN_DIELECTRICS=0", "-DHAS_ROUGH_DIELECTRICS=0", "-DHAS_PLASTICS=0",
                                  "-DHAS_ROUGH_PLASTICS=0", "-DHAS_PRINCIPLED=0", "-DHAS_PRINCIPLEDTHIN=0", "-DHAS_BECKMANN=0", "-DHAS_ANISOTROPIC=0",
                                  "-DHAS_LOOKUPS=0", "-DHAS_WRAPPERS=0", "-DHAS_NULLS=0",
                                  "-DHAS_PERTURBED_NORMALS=0", "-DHAS_PRINCIPLED_LOOKUPS=0", "-DHAS_SHAPE_EMITTERS=0",
                                  "-DHAS_DELTA_EMITTERS=0", "-DHAS_INSTANCES=0", "-DHAS_BSDF_SAMPLING=0",
                                  "-DHAS_THIN_LENS=0", "-DHAS_ORTHOGRAPHIC=0", "-DHAS_RFILTER=0",
                                  "-DHAS_AOVS=0"]
    special, s1 = raytrace.render(no_ellipsoid, width=32, height=32, spp=1, light_samples=4, sampler="center")
    full, s2 = raytrace.render(no_ellipsoid, width=32, height=32, spp=1, light_samples=4, sampler="center",
                               features=Features(8))
    assert "-DHAS_ELLIPSOIDS=0" in s1.build_options and "-DHAS_ELLIPSOIDS=1" in s2.build_options
    np.testing.assert_array_equal(special, full)
    with_ellipsoid, _ = raytrace.render(cornell, width=32, height=32, spp=1, light_samples=4, sampler="center")
    assert np.abs(with_ellipsoid - special).max() > 0.1


def test_texture_features_follow_the_scene():
    """Colour maps only: no normal- or height-map code; all three: all of it; none: no texture code."""
    from helpers import ROOT
    expect = {"cornell": (0, 0, 0), "grid_floor": (1, 0, 0), "normal_wall": (0, 1, 0), "textured_cornell": (1, 1, 1)}
    for name, flags in expect.items():
        options = Features.of(raytrace.load_file(ROOT / "scenes" / f"{name}.toml"), 8).options()
        assert [o for o in options if "_MAPS=" in o] == \
            [f"-DHAS_{m}_MAPS={f}" for m, f in zip(("COLOUR", "NORMAL", "HEIGHT"), flags)]


def test_image_size_and_sample_counts_never_rebuild(cornell):
    """Image size, pixel and light sample counts are kernel arguments (RenderParams and launch sizes): after
    the first render of this variant in the process, each of these reports build seconds 0, and the program
    cache holds one program for the variant."""
    from raytrace.renderer import program
    raytrace.render(cornell, width=8, height=8, spp=1, light_samples=1, progress=False)
    before = len(program._programs)
    for width, height, spp, light in ((33, 7, 4, 9), (1, 64, 2, 3), (17, 17, 9, 1)):
        _, stats = raytrace.render(cornell, width=width, height=height, spp=spp, light_samples=light,
                                   sampler="jittered", light_sampler="jittered", progress=False)
        assert stats.build_seconds == 0
    assert len(program._programs) == before
