"""raytrace against Mitsuba 3 on the corpus of Mitsuba scenes, scenes/mitsuba/*.xml: each scene rendered by raytrace
and judged per pixel against the reference Mitsuba 3.9.1 rendered of it, committed beside it
(scenes/mitsuba/references/STEM.npz, the mean and the variance of the mean of 16 independent renders, with a
STEM.json record of how it was made). No Mitsuba is needed here: devtools/peers/xml_check.py's
judge_against_reference renders the scene with raytrace (SPP samples in 16 renders of SPP / 16, seeds 0 to 15,
with the defines the record names) and runs devtools/judge.py's Z-test against the reference.

The corpus is one small scene per plugin family raytrace reads (diffuse, conductor, roughconductor, dielectric,
rectangle placement, obj, ply and serialized meshes, shapegroup instances, constant and envmap emitters, the perspective sensor's fov
axes and focal length, the thinlens and orthographic sensors, clip planes, hdrfilm's crop window and its tent,
gaussian, mitchell and lanczos rfilters, the samplers, the path, direct and moment integrators (path's rr_depth
and hide_emitters, direct's BSDF samples beside its emitter samples), a version 0.6 file, $name parameters,
include, ref;
each BSDF; the textures bitmap, checkerboard and mesh_attribute (vertex, face and one-value attributes); the
wrappers twosided, blendbsdf, mask, normalmap
and bumpmap) and composite scenes (issue58.xml: a roughness-mapped metal, a masked leaf, a normal-mapped floor, a
blend and a principled material), the Cornell box in millimetres among them, and the plugins raytrace is gaining (PENDING); each
file's comment says what it exercises.

The false-failure rate (devtools/judge.py's docstring argues each figure). Where raytrace and Mitsuba converge to
the same image, a scene fails the pixels' test with a probability below 1e-90 (it allows 0.25% of the values to
exceed Sidak's threshold at 1%, and the expected count is 0.01), and each of the three tile scales (4 and 16
pixels, the whole image) at its alpha, 1e-4: about 3e-4 per scene, 2.0% for the corpus's 66. The seeds are
fixed, so a given raytrace passes or fails deterministically: a change in how raytrace draws its samples deals
the corpus a fresh draw, false with that probability. What the ideal null leaves out is kept out of the scenes:
a path tracer's rare bright paths (caustics off mirrors, glass and glossy metal seen from diffuse surfaces) make
the mean of a chunk of 64 samples skewed, so the chunks' spread underestimates its variance and the rare
failing values all lie below the reference; the scenes' lights are large, so that those paths are common, and
where the count of a stratified sampler's samples on a noise-free region beside black barely varies between
chunks (the sky along a glass rim), the scene uses the independent sampler. Measured at SPP on the corpus's first 17
scenes over seeds 0 to 9: no scene failed; at most 5 values of a scene (of the 19 to 36 allowed) exceeded the threshold, and
one 4 x 4 tile (of the 1 or 2 allowed) in all 170 renders.

A scene raytrace cannot render as Mitsuba does is not in the corpus (the differences found while making it are
recorded in the commit that added it), with one exception: PENDING's scenes, one per plugin family raytrace is
gaining and does not render yet, are in the corpus with their references, and their test is skipped
with a reason naming the BSDF; the entry goes when the BSDF lands. To remake a reference, with Mitsuba 3.9.1
installed as devtools/peers/xml_check.py's header says (16384 samples, or the record's own count; parameters.xml
with `--define radiance=12,10,7`: each STEM.json names the exact command):

    python -m devtools.peers.xml_check scenes/mitsuba/NAME.xml --write-reference --ref-spp 16384

and look at the side-by-side PNG it writes (xml_check/NAME.png) before committing it (a PENDING scene's with
--mitsuba-only, which writes the reference without raytrace: look at the reference itself).
"""
import json

import pytest

from devtools.peers import xml_check
from helpers import ROOT

CORPUS = ROOT / "scenes" / "mitsuba"
SCENES = sorted(CORPUS.glob("*.xml"))
SPP = 1024  # raytrace's samples per pixel: 16 chunks of 64 (a square and a power of two, as the grids need)
# The scenes of a plugin raytrace does not render yet, and that plugin: their references are committed and their
# test is skipped, naming it. Remove a scene's entry when its plugin lands.
PENDING = {}


def test_every_scene_has_a_reference():
    """No scene of the corpus is skipped for want of a reference, and no reference outlives its scene: each
    scenes/mitsuba/*.xml has references/STEM.npz and its record, made by Mitsuba 3 from 16 chunks."""
    assert len(SCENES) >= 16
    missing = [s.name for s in SCENES if not xml_check.reference_path(s).is_file()
               or not xml_check.reference_path(s).with_suffix(".json").is_file()]
    assert missing == [], f"scenes without a reference: {missing}"
    orphans = sorted({p.stem for p in (CORPUS / "references").glob("*.np*")} - {s.stem for s in SCENES})
    assert orphans == [], f"references without a scene: {orphans}"
    stale = sorted(set(PENDING) - {s.name for s in SCENES})
    assert stale == [], f"PENDING names scenes not in the corpus: {stale}"
    for scene in SCENES:
        record = json.loads(xml_check.reference_path(scene).with_suffix(".json").read_text())
        assert record["mitsuba_version"].startswith("3.") and record["chunks"] == 16, scene.name
        per_chunk = record["spp"] // 16  # a power of 4 (a square power of two), or Mitsuba's grids round it up
        assert record["spp"] % 16 == 0 and per_chunk & (per_chunk - 1) == 0 and per_chunk.bit_length() % 2, scene.name


def _judged(scene):
    """The scene as a parameter: skipped, naming its BSDF, where PENDING lists it."""
    if scene.name not in PENDING:
        return scene
    reason = f"{PENDING[scene.name]}: raytrace does not render it yet"
    return pytest.param(scene, marks=pytest.mark.skip(reason=reason))


@pytest.mark.parametrize("scene", [_judged(s) for s in SCENES if xml_check.reference_path(s).is_file()],
                         ids=lambda s: s.stem)
def test_raytrace_matches_mitsuba(scene):
    """raytrace's render of the scene passes the per-pixel Z-test against Mitsuba's reference: the pixels', the
    tiles' and the whole image's (the verdict, with its worst value and its bias per channel, on failure)."""
    verdict = xml_check.judge_against_reference(scene, SPP, seed=0)
    assert verdict.passed, json.dumps(verdict.as_dict(), indent=1)
