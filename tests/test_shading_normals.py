"""Shading normals in the path model: the shading normals of a normal map and of a bump map feed the frame of
every BSDF (kernels/path_tracing.cl), so mapped walls differ from the same walls without their maps."""
import numpy as np
import pytest

import raytrace

from helpers import ROOT


@pytest.mark.parametrize("bsdf", ["roughconductor", "conductor", "dielectric"])
def test_normal_and_bump_maps_with_every_bsdf(cornell, tmp_path, bsdf):
    """textured_cornell.toml in the path model with its normal-mapped and bump-mapped walls turned to each of
    the new BSDFs: the maps' shading normals feed the BSDF's frame, so the walls differ from the same walls
    without the maps, rendered with the same samples (by more than 1% in more than a tenth of their pixels),
    and the image stays finite."""
    text = open(cornell.path.replace("cornell.toml", "textured_cornell.toml")).read()
    light = "tangent = [1.0, 0.0, 0.0]\ncolour = [1.0, 1.0, 1.0]"
    text = text.replace("../assets/", str(ROOT / "assets") + "/")
    for old, new in (("ambient =", "# ambient ="),
                     ("[render]", '[render]\nshading = "path"'),
                     (light, "tangent = [1.0, 0.0, 0.0]\nradiance = 40.0"),
                     ("[materials.red_bricks]", f'[materials.red_bricks]\ntype = "{bsdf}"'),
                     ("[materials.green_bricks]", f'[materials.green_bricks]\ntype = "{bsdf}"')):
        assert old in text, old
        text = text.replace(old, new, 1)
    mapped, flat = tmp_path / "mapped.toml", tmp_path / "flat.toml"
    mapped.write_text(text)
    flat.write_text("\n".join(line for line in text.splitlines()
                               if not line.startswith(("normal_map =", "height_map =", "height_scale ="))))
    options = dict(width=48, height=48, spp=16, light_samples=1, light_sampler="sobol")
    a, stats = raytrace.render(raytrace.load_file(mapped), **options)
    b, _ = raytrace.render(raytrace.load_file(flat), **options)
    # (the path model reads the course's maps as Mitsuba's normalmap and bumpmap: raytrace/scene/course_maps.py)
    assert stats.extra["nonfinite_values"] == 0 and "-DHAS_PERTURBED_NORMALS=1" in stats.build_options
    side = list(range(0, 8)) + list(range(40, 48))  # the red and green walls' columns
    a, b = np.asarray(a)[:, side].max(axis=-1), np.asarray(b)[:, side].max(axis=-1)
    assert np.mean(np.abs(a - b) > 0.01 * (a + b)) > 0.1  # the same samples: without a map's effect, equal
