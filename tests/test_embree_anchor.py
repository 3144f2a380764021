"""The Embree anchor of `bench --scaling`, `python -m benchmarks.embree_anchor` (benchmarks/embree_anchor.py): its rays are the scene's
(primary hits at the float64 reference's distances, shadow segments blocked where the reference blocks them,
plausible fractions), and without embreex it fails in one line. embreex (PyPI) is a measuring tool, not a
dependency of the renderer: the `test` extra installs it, so these run in CI; elsewhere the tests that trace
are skipped without it."""
import dataclasses
import sys

import numpy as np
import pytest

import reference
from helpers import CORNELL, ROOT, run
from raytrace.errors import InputError
from raytrace.scene import Triangle, load_file
from benchmarks import embree_anchor
from raytrace.commands.scaling import mesh_room

RECTANGLE_TRIANGLES = 10  # scene 0's five walls, two triangles each, come first in the anchor's soup


@pytest.fixture(scope="module")
def room():
    return mesh_room(load_file(CORNELL), 1000)


@pytest.fixture(scope="module")
def traced(room):
    """The anchor's Embree scene, primary rays (64 x 64, 4 per pixel), their hits and the shadow segments."""
    pytest.importorskip("embreex")
    rng = np.random.default_rng(1)
    embree, soup = embree_anchor.embree_scene(room)
    o, d = embree_anchor.camera_rays(room, 64, 64, 4, rng)
    hits = embree_anchor.closest_hits(embree, o, d)
    return embree, o, d, hits, embree_anchor.shadow_rays(room, soup, o, d, hits, 4, rng)


def reference_scene(room):
    """The room with its mesh as the reference's plain triangles (the reference knows no meshes)."""
    mesh = room.meshes[0]
    tris = [Triangle(v, mesh.material) for v in mesh.mesh.vertices[mesh.mesh.faces]]
    return dataclasses.replace(room, triangles=tris, meshes=[])


def sample(mask, count, rng):
    """Up to `count` indices where mask holds and as many where it does not: both kinds get tested."""
    return np.concatenate([rng.permutation(np.nonzero(m)[0])[:count] for m in (mask, ~mask)])


def test_primary_distances_match_float64_reference(room, traced):
    """Embree's closest hits (float32) against reference.closest_hit (float64) on the same float32 rays, half
    of them on the torus: the same shape hit, at the same distance to 1e-4."""
    _, o, d, hits, _ = traced
    index = sample(hits["primID"] >= RECTANGLE_TRIANGLES, 150, np.random.default_rng(2))
    expected = reference.closest_hit(reference_scene(room), o[index].astype(np.float64),
                                     d[index].astype(np.float64), include_lights=False)
    assert np.all(np.isfinite(expected["t"])) and np.all(hits["primID"][index] >= 0)
    on_torus = expected["material"] == room.meshes[0].material
    assert 100 <= on_torus.sum() <= 200
    np.testing.assert_array_equal(hits["primID"][index] >= RECTANGLE_TRIANGLES, on_torus)
    np.testing.assert_allclose(hits["tfar"][index], expected["t"], rtol=1e-4)


def test_shadow_segments_match_float64_reference(room, traced):
    """Embree's any-hit answers on segments it calls blocked and unblocked, against reference.occluded from the
    same origin to the same light point; the origins lie off their surfaces, on the light's side."""
    embree, _, _, _, (o, d, tfar) = traced
    blocked = embree.run(o, d, tfar, query="OCCLUDED") >= 0
    index = sample(blocked, 150, np.random.default_rng(3))
    p = o[index].astype(np.float64)
    expected = reference.occluded(reference_scene(room), p, p + d[index].astype(np.float64))
    assert 100 <= expected.sum() <= 200
    assert np.mean(expected == blocked[index]) >= 0.99


@pytest.mark.parametrize("torus", [True, False], ids=["torus", "empty-room"])
def test_fractions_are_plausible(room, torus):
    """Every primary ray meets the closed-behind room; the torus shadows a part of the shadow rays, and nothing
    shadows them in the empty room (the light hangs inside it). Shadow rays go only where the point faces the
    light, at most light_samples per hit."""
    pytest.importorskip("embreex")
    scene = room if torus else dataclasses.replace(room, meshes=[])
    m = embree_anchor.measure(scene, width=32, height=32, repeat=1)
    assert m["primary_rays"] == 32 * 32 * 4 and m["rays"] == m["primary_rays"] + m["shadow_rays"]
    assert m["hit_fraction"] == 1.0
    assert 0.5 * m["primary_rays"] * 4 <= m["shadow_rays"] <= m["primary_rays"] * 4
    assert (0.05 <= m["blocked_fraction"] <= 0.5) if torus else m["blocked_fraction"] == 0.0
    assert m["threads"] == 1 and 0 < m["ns_per_ray_all_cores"] <= m["ns_per_ray"] < 1e6


class _UniformRadius:
    """A generator whose first draw comes squared: cosine_directions' disk radius sqrt(u) becomes u, the
    uniform-radius mutation (the disk's points crowd its centre, the directions the normal)."""

    def __init__(self, rng):
        self.rng, self.draws = rng, 0

    def random(self, size):
        self.draws += 1
        u = self.rng.random(size)
        return u * u if self.draws == 1 else u


def test_bounce_rays_are_cosine_distributed_and_meet_the_reference(room, traced):
    """The scattered rays: one from nearly every surface hit (those whose direction leaves the surface), unit
    directions whose cosine to the hit's normal has the density 2 cos (cos(theta) / pi over the hemisphere): a
    chi-square test over 10 equal-probability bins of cos^2 (uniform for that density), at a false-failure rate
    of 1e-4; the same test fails the uniform-radius mutation (p below 1e-4; at this sample size the two
    densities' bins differ by far more than the noise). Embree's closest hits along them at the float64
    reference's distances to 1e-4."""
    embree, o, d, hits, _ = traced
    _, soup = embree_anchor.embree_scene(room)
    bo, bd = embree_anchor.bounce_rays(room, soup, o, d, hits, np.random.default_rng(5))
    assert 0.9 * len(o) <= len(bo) <= len(o)
    np.testing.assert_allclose(np.linalg.norm(bd, axis=1), 1, atol=1e-6)
    index = np.nonzero((hits["primID"] >= 0))[0]
    _, n = embree_anchor.surface_frames(soup, hits, d.astype(np.float64), index)
    rng = np.random.default_rng(6)
    wi = embree_anchor.cosine_directions(n, rng)
    cos2 = np.einsum("ij,ij->i", wi, n) ** 2
    counts = np.histogram(cos2, bins=10, range=(0, 1))[0]
    from scipy.stats import chisquare
    assert chisquare(counts).pvalue > 1e-4
    mutated = embree_anchor.cosine_directions(n, _UniformRadius(np.random.default_rng(6)))
    cos2 = np.einsum("ij,ij->i", mutated, n) ** 2
    assert chisquare(np.histogram(cos2, bins=10, range=(0, 1))[0]).pvalue < 1e-4
    got = embree_anchor.closest_hits(embree, bo, bd)
    pick = np.random.default_rng(7).permutation(len(bo))[:200]
    expected = reference.closest_hit(reference_scene(room), bo[pick].astype(np.float64),
                                     bd[pick].astype(np.float64), include_lights=False)
    met = np.isfinite(expected["t"])
    assert np.array_equal(got["primID"][pick] >= 0, met) and met.mean() > 0.5
    np.testing.assert_allclose(got["tfar"][pick][met], expected["t"][met], rtol=1e-4)


def test_no_ray_meets_the_unmet_scene_and_one_aimed_at_it_does(room, traced):
    """The scene that times the binding's own cost (embree_anchor.unmet_scene) must cost every traced ray its
    root box and nothing more: no camera ray hits it and no shadow segment is blocked by it; and it is a real
    triangle, not an empty scene that every query would miss whatever it held: a ray aimed at its centroid hits
    it."""
    _, o, d, _, (so, sd, tfar) = traced
    unmet = embree_anchor.unmet_scene(room, embree_anchor.embree_scene(room)[1])
    assert (embree_anchor.closest_hits(unmet, o, d)["primID"] == -1).all()
    assert (unmet.run(so, sd, tfar, query="OCCLUDED") == -1).all()
    forward, right, up = room.camera.basis()
    aim = (-3e3 * forward + right + up).astype(np.float32)[None]  # its centroid: 10^3 sizes back, a third up and right
    hit = embree_anchor.closest_hits(unmet, o[:1], aim)
    assert hit["primID"][0] == 0


def test_binding_cost_is_a_part_of_the_measured_cost(room):
    """The binding's ns a ray is positive and below the whole query's: the rays against the room do the unmet
    scene's work and a traversal besides; the net figure is the difference."""
    pytest.importorskip("embreex")
    m = embree_anchor.measure(room, width=32, height=32, repeat=3)
    assert 0 < m["binding_ns_per_ray"] < m["ns_per_ray"]
    assert m["net_ns_per_ray"] == pytest.approx(m["ns_per_ray"] - m["binding_ns_per_ray"])


def test_missing_embreex_is_one_line_input_error(room, monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", None)
    with pytest.raises(InputError, match="needs the embreex package: pip install embreex") as error:
        embree_anchor.measure(room, width=8, height=8, repeat=1)
    assert "\n" not in str(error.value) and error.value.key == "embreex"


def test_scaling_command_line_with_embree(tmp_path):
    """The smallest --scaling run with --embree: the column in the CSV, the figure in the printed line; and
    the BVH node visits per ray (raytrace/commands/visits.py), positive: the room and the torus are in one BVH, and
    their map."""
    pytest.importorskip("embreex")
    r = run(tmp_path / "out", "--max-triangles", 100, module="benchmarks.embree_anchor", cwd=ROOT)
    assert r.returncode == 0, r.stderr
    header, row = (l.split(",") for l in (tmp_path / "out" / "scaling.csv").read_text().splitlines())
    values = dict(zip(header, row))
    assert header[-4:] == ["embree_ns_per_ray", "embree_net_ns_per_ray", "embree_bounce_ns_per_ray",
                           "embree_bounce_net_ns_per_ray"]
    assert 0 < float(values["embree_net_ns_per_ray"]) < float(values["embree_ns_per_ray"])
    assert 0 < float(values["embree_bounce_net_ns_per_ray"]) < float(values["embree_bounce_ns_per_ray"])
    assert float(values["bounce_seconds_per_ray"]) > 0 and int(values["bounce_rays"]) > 0.5 * 256 * 256 * 4
    assert float(values["visits_per_camera_ray"]) > 0 and float(values["visits_per_shadow_ray"]) > 0
    assert "Embree" in r.stdout and (tmp_path / "out" / "scaling.png").stat().st_size > 0
    assert (tmp_path / "out" / "visits.png").stat().st_size > 0


def test_a_bad_value_is_one_line(tmp_path):
    r = run(tmp_path / "out", "--max-triangles", 10, module="benchmarks.embree_anchor", cwd=ROOT)
    assert r.returncode == 2 and r.stdout == "" and not (tmp_path / "out").exists()
    assert r.stderr.strip() == ("benchmarks.embree_anchor: error: command line: --max-triangles = 10: "
                                "must be in [100, 10^7]")
