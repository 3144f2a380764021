"""Area emitters on shapes (kernels/emitters.cl, Mitsuba's `area` on any shape): their sampling, against float64
references and by chi-square, and the light they cast, against closed forms and against the rectangular lights.

Sampling, at every lane width: a mesh's points are uniform over its area (a triangle chosen in proportion to its
area, then a uniform point on it), tested by chi-square over each triangle's four midpoint sub-triangles, which
have a quarter of its area each; a sphere's points are uniform over the cone of directions it subtends from the
reference point, tested by chi-square over 16 x 16 equal cells of ((1 - cos(theta)) / (1 - cos(theta_max)), phi /
2 pi) about the axis to its centre, near (the cone wide) and far (its narrow-cone series); a disk's uniform over
its area under a shearing map ((r^2, phi) in its local space), a cylinder's uniform in its local (phi, z). Each
chi-square test fails by chance with SIGNIFICANCE (1e-4): 5 per lane width, about 2e-3 per run on a machine of 4
widths. The uniform numbers are float64 draws rounded to float32 (a step of 2^-24 at most, far below a cell's
width), the same at every width.

Densities: the sample's density per solid angle p = d^2 / (A cos(theta_l)) (a mesh) or 1 / (2 pi (1 - cos
theta_max)) (a sphere) against float64 at relative 1e-5: each is a dozen float32 operations (a dot product, a
rsqrt of 2 ulp, a division of 2.5 ulp), about 2e-6 relative, away from grazing (the reference points are chosen
with cos(theta_l) > 0.05, so the cosine's cancellation is at most 20 ulp of the products' size: 1.2e-6 / 0.05).
Where the cone is narrow (sin^2 < 0.00068523) pbrt-v4's series s / 2 stands for 1 - sqrt(1 - s), which is off
by s / 4 relative at most: that tolerance there. The density the path model's MIS weight uses for a point a ray
hits (emitter_pdf) must equal the sample's own (same formula, the distance and cosine from the point): 1e-5.

Light, judged per pixel by devtools/judge.py's Z-test (variances from CHUNKS independent renders; each scale at
ALPHA = 1e-4: about 4e-4 per image, 10 images at the lane-width ends, 4e-3 per run):
- a diffuse floor under a sphere light, whose irradiance is pi L sin^2(theta_max) cos(beta) wherever the sphere
  is wholly above the floor's horizon (Lambert), and under a disk light parallel to it (the coaxial disk's form
  factor): radiance rho E / pi, in the direct model (light samples alone)
  and the path model at max_depth 2 (light samples and BSDF samples weighted by MIS: a weight that does not sum
  to 1 shows as a ratio), the closed form averaged over each pixel's footprint by a 6 x 6 grid (the pixel's
  curvature term then below 1e-4 of the value);
- a Cornell box lit by its light as a `lights[]` rectangle and as an emitting mesh of two triangles (no BSDF): the
  same image in expectation, in the path model (all bounces, MIS against the mesh's area sampling).

Mutations tried (each in a copy of the kernels; every one failed the tests named, and the copy was discarded):
- emitters.cl sample_mesh: u not rescaled within the chosen triangle's share: the mesh chi-square;
- emitters.cl sample_mesh: the binary search's comparison reversed: the mesh chi-square;
- emitters.cl sample_mesh: Heitz's map with its branches' condition reversed (a > b): the mesh chi-square;
- emitters.cl cone_one_minus_cos: the series used at every angle: the near sphere's density, both floors;
- emitters.cl sample_emitter: the sphere's cos(theta) drawn with u^2 for u: the sphere chi-square;
- path_tracing.cl path_hit: an emitter's MIS weight left at 1 (`weighed` not set): the path floor and the box;
- intersect.cl hit_emission: emission from both sides: the box (the mesh light's back faces the ceiling).
- emitters.cl sample_emitter: the disk's radius drawn as u, not sqrt(u): the disk chi-square;
- emitters.cl sample_emitter: the cylinder's density by its mean area, not the point's own: the cylinder's;
- emitters.cl cylinder_jacobian: dp/dz read from to_world's third row, not column: the cylinder's density.
- model_check.py: _check_emitters not called; rules.py: _emitting_areas not called: the refusals.
- ellipsoid.cl ellipsoid_normal: normal_sign ignored (flip_normals): both flipped-sphere tests.
"""
import dataclasses

import numpy as np
import pytest

import raytrace
from scipy import stats

from devtools.chi_square import SIGNIFICANCE
from devtools.judge import judge
from helpers import ROOT, at_lane_ends
from render_judging import CHUNKS, assert_judged, chunked
from reference import floor_footprint, pixel_means
from raytrace.errors import InputError
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables

KERNEL = """
#include "emitters.cl"
__kernel void sample(int n, SCENE_PARAMETERS, __global const float *ref, __global const float *u, int emitter,
                     __global float *p, __global float *normal, __global float *pdf, __global float *hit_pdf)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    __global const Emitter *e = &s.emitters[emitter];
    vec3 r = IN3(ref);
    vec2 uv = {IN(u), IN(u + n)};
    EmitterSample es = sample_emitter(&s, e, r, uv, (vfloat)(0.0f) == 0.0f);
    OUT3(p, es.p);
    OUT3(normal, es.n);
    OUT(pdf, es.pdf);
    vec3 w = v3_sub(es.p, r);
    vfloat d = sqrt(v3_dot(w, w));
    OUT(hit_pdf, emitter_pdf(&s, e, r, es.p, d, vabs(v3_dot(es.n, w)) / d));
}
"""
N = 40000
ALPHA = 1e-4
NARROW = 0.00068523  # sin^2(theta_max) below which emitters.cl takes the cone's series (pbrt-v4's)

# five triangles of different areas, none coplanar with another, their fronts facing +z (towards the
# reference points above them)
MESH = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0.1]],
                 [[2, 0, 0.3], [4, 0, 0.2], [2, 3, 0]],
                 [[-1, -1, 0.5], [-0.5, -1, 0.5], [-1, -0.2, 0.7]],
                 [[0, 2, 0.9], [1.5, 2, 1.0], [0, 2.5, 1.2]],
                 [[-3, 0, -0.4], [-1.5, 0.2, -0.3], [-2.5, 1.8, -0.2]]], np.float64)


def emitter_scene(shapes):
    return {"camera": {"position": [0.0, -5.0, 3.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0],
                       "fov": 40.0},
            "image": {"width": 8, "height": 8}, "render": {"shading": "path"},
            "materials": {"grey": {"colour": [0.5, 0.5, 0.5]}}, "shapes": shapes}


def sample(harness, table, ref, seed):
    """The kernel's samples of emitter 0 of scene `table` from the reference points `ref` (N x 3)."""
    scene = raytrace.load_dict(table)
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    assert defines["HAS_SHAPE_EMITTERS"] == 1
    u = np.random.default_rng(seed).random((2, len(ref))).astype(np.float32)
    args = {**scene_tables(scene, 8, 8, 1, 1, "bilinear", features=features), "ref": ref.T.astype(np.float32),
            "u": u, "emitter": np.int32(0)}
    out = harness.run(KERNEL, "sample", len(ref), args, {"p": 3, "normal": 3, "pdf": 1, "hit_pdf": 1}, **defines)
    return out["p"].T, out["normal"].T, out["pdf"], out["hit_pdf"], u.astype(np.float64)


def uniform_chi_square(a, b, cells=16):
    """(p-value, statistic) of Pearson's test that the points (a, b) are uniform on [0, 1]^2, over cells x cells
    equal cells (each expecting N / 256 = 156 samples: the chi-square distribution holds)."""
    observed, _, _ = np.histogram2d(a, b, bins=cells, range=[[0, 1], [0, 1]])
    expected = len(a) / cells ** 2
    statistic = float(np.sum((observed - expected) ** 2 / expected))
    return float(stats.chi2.sf(statistic, cells ** 2 - 1)), statistic


def test_a_mesh_is_sampled_uniformly_by_area(harness):
    """Each sample lies on one of the mesh's triangles (within float32 rounding of its plane), counts fall into
    the triangles' midpoint sub-triangles in proportion to their areas (chi-square), and the density is d^2 / (A
    cos(theta_l)) of the whole mesh's area, the same as the MIS weight's for that point."""
    faces = np.arange(15).reshape(5, 3)
    table = emitter_scene([{"type": "mesh", "vertices": MESH.reshape(-1, 3).tolist(), "faces": faces.tolist(),
                            "radiance": 1.0}])
    rng = np.random.default_rng(1)
    ref = np.column_stack([rng.uniform(-1, 1, N), rng.uniform(-1, 1, N), rng.uniform(4, 6, N)])
    p, normal, pdf, hit_pdf, _ = sample(harness, table, ref, seed=2)
    # which triangle: the one whose barycentrics of p (in its plane) are all >= -1e-5
    a, b, c = MESH[:, 0], MESH[:, 1], MESH[:, 2]
    n = np.cross(b - a, c - a)
    areas = np.linalg.norm(n, axis=1) / 2
    plane = np.abs(np.einsum("tk,ntk->nt", n / (2 * areas[:, None]), p[:, None, :] - a[None]))
    tri = np.argmin(plane, axis=1)
    assert np.all(plane[np.arange(N), tri] < 1e-5 * 4)  # float32 rounding of coordinates of size 4
    e0, e1, q = b[tri] - a[tri], c[tri] - a[tri], p - a[tri]
    d00, d01, d11 = np.sum(e0 * e0, 1), np.sum(e0 * e1, 1), np.sum(e1 * e1, 1)
    d20, d21 = np.sum(q * e0, 1), np.sum(q * e1, 1)
    det = d00 * d11 - d01 * d01
    b1, b2 = (d11 * d20 - d01 * d21) / det, (d00 * d21 - d01 * d20) / det
    bary = np.column_stack([1 - b1 - b2, b1, b2])
    assert np.all(bary > -1e-5)
    # sub-triangle: the corner whose barycentric exceeds 1/2, else the middle one (3)
    corner = np.where(bary.max(axis=1) > 0.5, bary.argmax(axis=1), 3)
    observed = np.bincount(tri * 4 + corner, minlength=20)
    expected = np.repeat(areas / areas.sum() / 4, 4) * N
    statistic = np.sum((observed - expected) ** 2 / expected)
    pvalue = stats.chi2.sf(statistic, len(expected) - 1)
    print(f"mesh: chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    # densities per solid angle, against float64
    w = p - ref
    d2 = np.sum(w * w, 1)
    unit_n = n[tri] / np.linalg.norm(n[tri], axis=1, keepdims=True)
    cos_l = np.abs(np.sum(unit_n * w, 1)) / np.sqrt(d2)
    assert cos_l.min() > 0.05
    np.testing.assert_allclose(normal, unit_n, atol=1e-6)
    np.testing.assert_allclose(pdf, d2 / (areas.sum() * cos_l), rtol=1e-5)
    np.testing.assert_allclose(hit_pdf, pdf, rtol=1e-5)


@pytest.mark.parametrize("distance", [1.6, 150.0])
def test_a_sphere_is_sampled_uniformly_over_its_cone(harness, distance):
    """From a point `distance` radii from the centre (the cone wide, and narrow enough for the series), each
    sample lies on the sphere, on the side the point sees, its direction uniform over the cone (chi-square about
    the axis to the centre); the density is 1 / (2 pi (1 - cos(theta_max))), the MIS weight's too. A point inside
    gets no sample."""
    centre, radius = np.array([0.3, -0.2, 1.0]), 0.7
    table = emitter_scene([{"type": "ellipsoid", "center": centre.tolist(),
                            "axes": (np.eye(3) * radius).tolist(), "radiance": 1.0}])
    rng = np.random.default_rng(int(distance))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    ref = np.broadcast_to(centre + distance * radius * axis, (N, 3))
    p, normal, pdf, hit_pdf, _ = sample(harness, table, ref, seed=3)
    np.testing.assert_allclose(np.linalg.norm(p - centre, axis=1), radius, rtol=2e-6)
    np.testing.assert_allclose(normal, (p - centre) / radius, atol=2e-6)
    assert np.all(np.sum(normal * (ref - p), 1) > 0)
    sin2_max = 1 / distance ** 2
    one_minus_cos = 1 - np.sqrt(1 - sin2_max)
    rtol = 1e-5 + (sin2_max / 4 if sin2_max < NARROW else 0.0)
    np.testing.assert_allclose(pdf, 1 / (2 * np.pi * one_minus_cos), rtol=rtol)
    np.testing.assert_allclose(hit_pdf, pdf, rtol=1e-5)
    # the directions in a frame whose z is the axis to the centre
    z = -axis
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    frame = np.array([x, np.cross(z, x), z])
    w = (p - ref) @ frame.T
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    # uniform over the cone: (1 - cos(theta)) / (1 - cos(theta_max)) and phi / 2 pi uniform on [0, 1)^2
    radial = np.clip((1 - w[:, 2]) / one_minus_cos, 0, 1)
    phi = np.mod(np.arctan2(w[:, 1], w[:, 0]), 2 * np.pi) / (2 * np.pi)
    assert np.all((1 - w[:, 2]) / one_minus_cos < 1 + 1e-3)
    pvalue, statistic = uniform_chi_square(radial, phi)
    print(f"sphere at {distance} radii: chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    inside = sample(harness, table, np.broadcast_to(centre + 0.5 * radius * axis, (64, 3)), seed=4)[2]
    assert np.all(inside == 0.0)


DISK_TO_WORLD = np.array([[0.6, 0.2, 0.0, 0.3], [-0.1, 0.35, 0.1, -0.2], [0.05, -0.1, -0.9, 1.5], [0, 0, 0, 1]])


def test_a_disk_is_sampled_uniformly_by_area(harness):
    """A disk under a shearing, non-uniform to_world: each sample on it (back in its local space, on the unit
    disk within float32 rounding), uniform over it ((r^2, phi) uniform in local space, whose image under an
    affine map keeps area ratios), its normal to_world's inverse transpose of +z (turned: its front faces down,
    towards the reference points below), its density d^2 / (A cos(theta_l)) with A = pi |dp/dx x dp/dy|."""
    table = emitter_scene([{"type": "disk", "to_world": DISK_TO_WORLD.tolist(), "radiance": 1.0}])
    rng = np.random.default_rng(5)
    ref = np.column_stack([rng.uniform(-1, 1, N), rng.uniform(-1, 1, N), rng.uniform(-3, -1, N)])
    p, normal, pdf, hit_pdf, _ = sample(harness, table, ref, seed=6)
    linear, centre = DISK_TO_WORLD[:3, :3], DISK_TO_WORLD[:3, 3]
    local = (p - centre) @ np.linalg.inv(linear).T
    assert np.abs(local[:, 2]).max() < 1e-5 and np.hypot(local[:, 0], local[:, 1]).max() < 1 + 1e-5
    pvalue, statistic = uniform_chi_square(np.clip(np.sum(local[:, :2] ** 2, 1), 0, 1),
                                           np.mod(np.arctan2(local[:, 1], local[:, 0]), 2 * np.pi) / (2 * np.pi))
    print(f"disk: chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    n = np.linalg.inv(linear).T @ [0.0, 0.0, 1.0]
    np.testing.assert_allclose(normal, np.broadcast_to(n / np.linalg.norm(n), normal.shape), atol=1e-6)
    area = np.pi * np.linalg.norm(np.cross(linear[:, 0], linear[:, 1]))
    w = p - ref
    d2 = np.sum(w * w, 1)
    cos_l = np.abs(w @ (n / np.linalg.norm(n))) / np.sqrt(d2)
    assert cos_l.min() > 0.05
    np.testing.assert_allclose(pdf, d2 / (area * cos_l), rtol=1e-5)
    np.testing.assert_allclose(hit_pdf, pdf, rtol=1e-5)


def test_a_cylinder_is_sampled_uniformly_in_phi_and_z(harness):
    """An elliptic cylinder (to_world scales across its axis unevenly): each sample on the tube, uniform in its
    local (phi, z), its normal outwards, its density d^2 / (2 pi |dp/dphi x dp/dz| cos(theta_l)) at the point
    itself (the area element varies with phi), the MIS density of the point the same."""
    to_world = np.array([[1.5, 0.0, 0.0, 0.2], [0.0, 0.6, 0.0, 0.1], [0.0, 0.0, 1.0, -0.3], [0, 0, 0, 1]])
    table = emitter_scene([{"type": "cylinder", "p0": [0.0, 0.0, -0.5], "p1": [0.3, 0.2, 0.8], "radius": 0.4,
                            "to_world": to_world.tolist(), "radiance": 1.0}])
    scene = raytrace.load_dict(table)
    matrix = scene.cylinders[0].matrix
    linear, centre = matrix[:3, :3], matrix[:3, 3]
    rng = np.random.default_rng(7)
    direction = rng.normal(size=(N, 3))
    ref = centre + 4 * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    p, normal, pdf, hit_pdf, _ = sample(harness, table, ref, seed=8)
    local = (p - centre) @ np.linalg.inv(linear).T
    np.testing.assert_allclose(np.hypot(local[:, 0], local[:, 1]), 1.0, atol=1e-5)
    phi = np.mod(np.arctan2(local[:, 1], local[:, 0]), 2 * np.pi)
    pvalue, statistic = uniform_chi_square(phi / (2 * np.pi), np.clip(local[:, 2], 0, 1))
    print(f"cylinder: chi-square {statistic:.1f}, p = {pvalue:.3g}")
    assert pvalue >= SIGNIFICANCE
    n = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(N)]) @ np.linalg.inv(linear)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(normal, n, atol=2e-6)
    jacobian = np.linalg.norm(np.cross(np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(N)]) @ linear.T,
                                       linear[:, 2]), axis=1)
    w = p - ref
    d2 = np.sum(w * w, 1)
    cos_l = np.abs(np.sum(n * w, 1)) / np.sqrt(d2)
    clear = cos_l > 0.05  # away from grazing, where the cosine's cancellation exceeds the tolerance
    assert clear.mean() > 0.8
    np.testing.assert_allclose(pdf[clear], (d2 / (2 * np.pi * jacobian * cos_l))[clear], rtol=1e-5)
    np.testing.assert_allclose(hit_pdf[clear], pdf[clear], rtol=1e-5)


SPHERE_CENTRE, SPHERE_RADIUS, SPHERE_RADIANCE = np.array([0.4, 0.3, 1.2]), 0.35, np.array([3.0, 2.0, 1.0])
RHO = np.array([0.8, 0.6, 0.4])


DISK_RADIUS, DISK_HEIGHT = 0.5, 1.2


def light_shape(light):
    """The floor's light: the sphere, or a disk of radius DISK_RADIUS facing down at DISK_HEIGHT over (0.4, 0.3)."""
    if light == "sphere":
        return {"type": "ellipsoid", "center": SPHERE_CENTRE.tolist(), "axes": (np.eye(3) * SPHERE_RADIUS).tolist(),
                "radiance": SPHERE_RADIANCE.tolist()}
    to_world = [[DISK_RADIUS, 0, 0, 0.4], [0, -DISK_RADIUS, 0, 0.3], [0, 0, -1, DISK_HEIGHT], [0, 0, 0, 1]]
    return {"type": "disk", "to_world": to_world, "radiance": SPHERE_RADIANCE.tolist()}


def floor_scene(shading, max_depth=-1, light="sphere"):
    """A 20 x 20 diffuse floor at z = 0 under a sphere light, wholly above its horizon, seen from below the
    sphere (which the camera does not see) so that every pixel sees the floor alone: no silhouette, whose pixels'
    coverage a Z-test cannot judge."""
    render = {"shading": shading, **({"max_depth": max_depth} if shading == "path" else {})}
    return {"camera": {"position": [0.1, -0.2, 0.75], "look_at": [0.35, 0.25, 0.0], "up": [0.0, 0.0, 1.0],
                       "fov": 60.0},
            "image": {"width": 24, "height": 24}, "render": render,
            "materials": {"floor": {"colour": RHO.tolist()}},
            "shapes": [{"type": "rectangle", "center": [0.0, 0.0, 0.0], "size": [20.0, 20.0],
                        "normal": [0.0, 0.0, 1.0], "tangent": [1.0, 0.0, 0.0], "material": "floor"},
                       light_shape(light)]}


def floor_radiance(table, light="sphere"):
    """rho E / pi over each pixel's footprint, by a 6 x 6 grid per pixel (the floor's, every ray meeting it):
    under the sphere E = pi L (r / d)^2 cos(beta); under the disk, parallel to the floor at height h, at radial
    distance rho from its axis, E = pi L / 2 (1 - (h^2 + rho^2 - R^2) / sqrt((h^2 + rho^2 + R^2)^2 - 4 rho^2
    R^2)) (the form factor of a coaxial disk to a parallel element)."""
    scene = raytrace.load_dict(table)
    o, d, t, p = floor_footprint(scene)
    to_centre = SPHERE_CENTRE - p
    d2 = np.sum(to_centre ** 2, 1)
    cos_beta = to_centre[:, 2] / np.sqrt(d2)
    oc = o - SPHERE_CENTRE  # no ray meets the sphere
    h = np.sum(oc * d, 1)
    assert np.all(h * h - (np.sum(oc * oc, 1) - SPHERE_RADIUS ** 2) < 0)
    value = RHO * SPHERE_RADIANCE * (SPHERE_RADIUS ** 2 * cos_beta / d2)[:, None]
    if light == "disk":
        h2, r2, big2 = DISK_HEIGHT ** 2, np.sum((p[:, :2] - [0.4, 0.3]) ** 2, 1), DISK_RADIUS ** 2
        irradiance_over_pi = 0.5 * (1 - (h2 + r2 - big2) / np.sqrt((h2 + r2 + big2) ** 2 - 4 * r2 * big2))
        value = RHO * SPHERE_RADIANCE * irradiance_over_pi[:, None]
    return pixel_means(scene, value)


@at_lane_ends
@pytest.mark.parametrize("shading", ["direct", "path"])
@pytest.mark.parametrize("light", ["sphere", "disk"])
def test_a_shape_light_on_a_floor(lanes, shading, light):
    """The floor's radiance under a sphere light or a disk light against their closed forms: the direct model's
    light samples, the path model's light and BSDF samples weighted by MIS (max_depth 2: direct light alone)."""
    table = floor_scene(shading, max_depth=2, light=light)
    mean, var = chunked(table, lanes, 4)
    expected = floor_radiance(table, light)
    assert_judged(judge(mean, var, expected, np.zeros_like(var), alpha=ALPHA, dof=CHUNKS - 1, tile_alpha=ALPHA),
                  f"{light}, {shading}, lanes {lanes}")


def box(light_as_mesh):
    """scenes/cornell_path.toml's box at 24 x 24, lit by its light as a `lights[]` rectangle or as an emitting
    mesh of two triangles over the same corners (no BSDF: black, as the light)."""
    table = raytrace.load_file(ROOT / "scenes" / "cornell_path.toml").source
    table["image"] = {"width": 24, "height": 24}
    light = table["lights"][0]
    if light_as_mesh:
        (cx, cy, cz), (sx, sy) = light["center"], light["size"]
        corners = [[cx - sx / 2, cy - sy / 2, cz], [cx + sx / 2, cy - sy / 2, cz], [cx + sx / 2, cy + sy / 2, cz],
                   [cx - sx / 2, cy + sy / 2, cz]]
        assert light["normal"] == [0.0, 0.0, -1.0]
        table["lights"] = []  # the faces wound clockwise seen from above: their fronts face down, as the light's
        table["shapes"].append({"type": "mesh", "vertices": corners, "faces": [[0, 2, 1], [0, 3, 2]],
                                "radiance": light["radiance"]})
    return table


@at_lane_ends
def test_a_mesh_light_equals_the_rectangle_light(lanes):
    """The Cornell box lit by an emitting mesh renders the image of its rectangular light, in expectation: area
    sampling of two triangles and MIS against the BSDF's samples that hit them, every bounce."""
    mesh, mesh_var = chunked(box(True), lanes, 4)
    rect, rect_var = chunked(box(False), lanes, 4, seed=CHUNKS)
    assert rect.mean() > 0.05
    assert_judged(judge(mesh, mesh_var, rect, rect_var, alpha=ALPHA, dof=CHUNKS - 1, ref_dof=CHUNKS - 1,
                        tile_alpha=ALPHA), f"box, lanes {lanes}")


def test_a_scene_whose_emitters_do_not_hold_is_refused():
    """The Python API's path into the kernel (check_model): an emitter without its shape, one material emitting
    from two spheres (only one would be sampled), an emitter naming a material of another, and (from a file) an
    emitting triangle whose area rounds to 0 in float32: each one line naming the key."""
    table = floor_scene("direct")
    scene = raytrace.load_dict(table)
    sphere = scene.ellipsoids[0]
    cases = [(dataclasses.replace(scene, ellipsoids=[]), "emitters[0].material", "must be the material of one shape"),
             (dataclasses.replace(scene, ellipsoids=[sphere, dataclasses.replace(sphere, center=sphere.center + 1)]),
              "emitters[0].material", "not of 2"),
             (dataclasses.replace(scene, emitters=[dataclasses.replace(scene.emitters[0], material=0)]),
              "emitters[0].material", "a material of its own")]
    for broken, key, problem in cases:
        with pytest.raises(InputError) as error:
            raytrace.render(broken, spp=1)
        assert error.value.key == key and problem in str(error.value), str(error.value)
    far = 1e7
    table["shapes"][1] = {"type": "triangle", "vertices": [[far, far, 1.0], [far + 1e-3, far, 1.0],
                                                            [far, far + 1e-3, 1.0]], "radiance": 1.0}
    with pytest.raises(InputError) as error:
        raytrace.load_dict(table)
    assert error.value.key == "shapes[1].radiance" and "float32" in str(error.value)


@pytest.mark.parametrize("shading, lights", [("path", False), ("direct", False), ("path", True)])
def test_a_too_bright_emitting_shape_is_named(shading, lights):
    """The brightness rules (ranges.py's 4 and 5) name an emitting shape's radiance where it is the largest
    factor, with or without rectangular lights beside it (before: a crash without lights, another key with)."""
    table = emitter_scene([{"type": "rectangle", "center": [0, 0, 0], "size": [2, 2], "normal": [0, 0, 1],
                            "tangent": [1, 0, 0], "radiance": 3e38}])
    table["render"] = {"shading": shading}
    if lights:
        table["lights"] = [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "tangent": [1, 0, 0],
                            "radiance": 1.0}]
    with pytest.raises(InputError) as error:
        raytrace.load_dict(table)
    assert error.value.key == "shapes[0].radiance" and "as bright as" in str(error.value), str(error.value)


@pytest.mark.parametrize("inside", [False, True])
def test_a_flipped_sphere_light_emits_inwards(inside):
    """flip_normals turns a sphere's front inwards (Mitsuba's sphere's): a camera outside an emitting flipped
    sphere sees its back, black; one inside sees its radiance L on every pixel (the front, met head on:
    exactly L, the emitter's own value)."""
    radiance = [2.0, 3.0, 4.0]
    table = emitter_scene([{"type": "ellipsoid", "center": [0, 0, 0], "axes": np.eye(3).tolist(),
                            "radiance": radiance, "flip_normals": True}])
    if inside:
        table["camera"] = {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 1.0, 0.0], "up": [0.0, 0.0, 1.0],
                           "fov": 60.0}
    table["render"] = {"shading": "path", "max_depth": 1}
    image = np.asarray(raytrace.render(raytrace.load_dict(table), spp=1)[0])
    if inside:
        assert np.all(image == np.array(radiance, np.float32))
    else:
        assert np.all(image == 0.0)
