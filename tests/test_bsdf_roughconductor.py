"""The rough conductor behind the BSDF interface (kernels/bsdfs/roughconductor.cl through bsdf.cl's bsdf_eval_pdf
and bsdf_sample) with GGX and Beckmann microfacets, isotropic and anisotropic, against tests/bsdf_reference.py's
float64 Mitsuba 3 roughconductor: eval and pdf at random direction pairs and roughness down to 1e-3, a
chi-square test of bsdf_sample's directions, sample weights against eval / pdf, reciprocity, and a white
furnace. Each runs in the isotropic build (HAS_ANISOTROPIC 0: only cosines to the normal) and, where the
roughness is anisotropic, the anisotropic one (HAS_ANISOTROPIC 1: the local frame of the shading tangent)."""
import numpy as np
import pytest

import bsdf_support
from bsdf_support import unit
from bsdf_reference import Microfacet, fresnel_conductor
from devtools.chi_square import SIGNIFICANCE, chi_square

# eval and pdf at (wo, wi), eval of the swapped pair, a sample and eval and pdf at its direction (bsdf_support)
OUTPUTS = ("f", "pdf", "f_swapped", "s_wi", "s_weight", "s_pdf", "s_f", "s_eval_pdf")
U = 2.0 ** -24
GOLD = (np.array([0.143, 0.374, 1.442]), np.array([3.983, 2.385, 1.603]))


def f32(a):
    return np.asarray(a, np.float32).astype(np.float64)


def defines(anisotropic):
    return dict(HAS_PATH_TRACING=1, HAS_ROUGH_CONDUCTORS=1, HAS_RECTANGLES=1, HAS_BECKMANN=1,
                HAS_ANISOTROPIC=int(anisotropic))


def frames(rng, k, rotated):
    """Per lane a unit normal and a unit tangent orthogonal to it (random, or the z and x axes)."""
    if not rotated:
        return np.tile([0.0, 0.0, 1.0], (k, 1)), np.tile([1.0, 0.0, 0.0], (k, 1))
    n = unit(rng.normal(size=(k, 3)))
    t = unit(np.cross(n, rng.normal(size=(k, 3))))
    return n, t


def local_frame64(n, t):
    """The float64 local frame (t, b, n) of the float32-rounded n and t the kernel reads."""
    n64 = f32(n)
    t64 = f32(t)
    t64 = unit(t64 - np.sum(t64 * n64, 1)[:, None] * n64)
    return t64, np.cross(n64, t64), n64


def to_local(frame, v):
    t, b, n = frame
    return np.stack([np.sum(v * t, 1), np.sum(v * b, 1), np.sum(v * n, 1)], 1)


def run(harness, anisotropic, distribution, n, t, au, av, wo, wi, u, eta=GOLD[0], k=GOLD[1]):
    """A rough conductor's shading point per lane: normal n, tangent t (the anisotropic build's), roughness au
    and av (one for every lane, or one per lane) of the distribution, eta + i k per channel, colour 1. Its eval
    and pdf at (wo, wi), its eval of the swapped pair, and a sample from u with eval and pdf at the sampled
    direction."""
    table = bsdf_support.material_table(max(np.size(au), np.size(av)), bsdf="roughconductor", eta=eta, k=k,
                                        alpha=au, alpha_v=av, distribution=distribution)
    return bsdf_support.run(harness, table, n, wo, wi, u, OUTPUTS, tangent=t, **defines(anisotropic))


def reference_eval_pdf(distribution, au, av, wo, wi, eta=GOLD[0], k=GOLD[1]):
    """Mitsuba's roughconductor (bsdf_reference.RoughConductor's formulas, with per-lane alphas): f cos and the
    density, local directions."""
    ref = Microfacet(distribution, au, av)
    h = unit(wo + wi)
    d = ref.D(h)
    on = (wo[:, 2] > 0) & (wi[:, 2] > 0) & (d != 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = d * ref.G(wo, wi, h) / (4 * wo[:, 2])
        pdf = d * ref.smith_g1(wo, h) / (4 * wo[:, 2])
    f = fresnel_conductor(np.clip(np.sum(wo * h, 1), 0, 1), eta, k)
    return np.where(on[:, None], value[:, None] * f, 0.0), np.where(on, pdf, 0.0)


BUILDS = [("isotropic", False, "ggx"), ("isotropic", False, "beckmann"), ("anisotropic", True, "ggx"),
          ("anisotropic", True, "beckmann")]


@pytest.mark.parametrize("roughness, anisotropic, distribution", BUILDS)
def test_eval_and_pdf_against_float64(harness, roughness, anisotropic, distribution):
    """bsdf_eval_pdf at 4096 random pairs in random shading frames, wi within a few alphas of wo's mirror
    direction (where the lobe is) for three quarters of them, roughness log-uniform in [1e-3, 1] (alpha_u and
    alpha_v independent in the anisotropic build), gold's eta and k, against the float64 reference at the
    float32-rounded inputs. The bound is microfacet.cl's D's (tests/test_microfacet.py: 16u e relative, e =
    tan^2(theta_h) / alpha^2, in the anisotropic build, plus 16u sqrt(e) (1 / alpha_u + 1 / alpha_v) for the
    frame's dot products, which put u of absolute error on h's local x and y, and e moves by 2 sqrt(e) of that
    over alpha; 16u (1 + e) / (alpha^2 cos^2(theta_h)) in the isotropic build, which has only cosines) plus
    1e-4 for G1 and F (measured: 1.5e-4 relative at alpha 1.5e-3, e = 4, within the bound); values below 1e-6 of
    the lobe's peak, 1 / (4 pi alpha_u alpha_v), are held to that absolute bound instead. The
    anisotropic build with the frame's x and y axes swapped (alpha_u along the bitangent) fails it (seen)."""
    rng = np.random.default_rng(17 + anisotropic * 2 + len(distribution))
    k = 4096
    n, t = frames(rng, k, rotated=True)
    frame = local_frame64(n, t)
    au = np.exp(rng.uniform(np.log(1e-3), 0, k))
    av = np.exp(rng.uniform(np.log(1e-3), 0, k)) if anisotropic else au
    au, av = f32(au), f32(av)
    lo = unit(rng.normal(size=(k, 3)) + [0, 0, 0.5])
    lo[:, 2] = np.abs(lo[:, 2]) + 1e-3
    lo = unit(lo)
    slope = rng.normal(size=(k, 2)) * np.stack([au, av], 1) * rng.uniform(0, 2.5, (k, 1))
    m = unit(np.concatenate([-slope, np.ones((k, 1))], 1))
    li = 2 * np.sum(lo * m, 1)[:, None] * m - lo
    li[::4] = unit(rng.normal(size=(len(li[::4]), 3)))
    li[:, 2] = np.abs(li[:, 2]) * np.where(rng.uniform(size=k) < 0.05, -1, 1)  # a few below the horizon
    li = unit(li)
    world = lambda v: v[:, :1] * frame[0] + v[:, 1:2] * frame[1] + v[:, 2:] * frame[2]  # noqa: E731
    wo, wi = f32(world(lo)), f32(world(li))
    out = run(harness, anisotropic, distribution, n, t, au, av, wo, wi, rng.uniform(size=(k, 3)))
    lo64, li64 = to_local(frame, wo), to_local(frame, wi)
    f_ref, pdf_ref = reference_eval_pdf(distribution, au, av, lo64, li64)
    h = unit(lo64 + li64)
    e = ((h[:, 0] / au) ** 2 + (h[:, 1] / av) ** 2) / h[:, 2] ** 2
    framed = e + np.sqrt(e) * (1 / au + 1 / av)  # the frame's dots round h's local x and y to u absolute
    bound = 1e-4 + 16 * U * (framed if anisotropic else (1 + e) / (au**2 * h[:, 2] ** 2))
    floor = 1e-6 / (4 * np.pi * au * av)
    np.testing.assert_array_less(np.abs(out["f"] - f_ref), bound[:, None] * f_ref + floor[:, None] + 1e-30)
    np.testing.assert_array_less(np.abs(out["pdf"] - pdf_ref), bound * pdf_ref + floor + 1e-30)
    below = (li64[:, 2] <= 0) | (lo64[:, 2] <= 0)
    assert np.all(out["f"][below] == 0) and np.all(out["pdf"][below] == 0)
    # reciprocity: f = eval / cos_i is symmetric (F(wo . h) = F(wi . h), G separable and symmetric), to the
    # rounding of the kernel's cosines (u absolute each: relative where they are small)
    above = ~below & (f_ref[:, 0] > floor)
    recip = out["f_swapped"][above] / lo64[above, 2:]
    direct = out["f"][above] / li64[above, 2:]
    cos_bound = 1e-5 + 8 * U / lo64[above, 2:] + 8 * U / li64[above, 2:]  # the kernel's cosines round to u
    np.testing.assert_array_less(np.abs(recip - direct), cos_bound * np.abs(direct))


SAMPLED = [("isotropic", False, "beckmann", 0.3, 0.3, 0.9), ("anisotropic", True, "beckmann", 0.1, 0.45, 0.6),
           ("anisotropic", True, "ggx", 0.5, 0.12, 1.2), ("anisotropic", True, "ggx", 0.3, 0.3, 0.3)]


def sphere_density(distribution, au, av, wo):
    """bsdf_reference's density of reflected visible-normal samples on the whole sphere (below the horizon
    too, where bsdf_sample still returns the reflected direction, with pdf 0): D(h) G1(wo, h) / (4 wo.z)."""
    ref = Microfacet(distribution, au, av)

    def density(cos_t, phi):
        shape = cos_t.shape
        sin_t = np.sqrt(np.maximum(0.0, 1 - cos_t**2))
        wi = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1).reshape(-1, 3)
        h = unit(wi + wo)
        with np.errstate(invalid="ignore", divide="ignore"):
            pdf = ref.D(h) * ref.smith_g1(np.broadcast_to(wo, h.shape), h) / (4 * wo[2])
        return np.where(h @ wo > 0, np.nan_to_num(pdf), 0.0).reshape(shape)
    return density


@pytest.mark.parametrize("roughness, anisotropic, distribution, au, av, theta_o", SAMPLED)
def test_sample_chi_square_weight_and_furnace(harness, roughness, anisotropic, distribution, au, av, theta_o):
    """bsdf_sample in a tilted shading frame (normal and tangent not the axes, so that a wrong tangent or
    frame shows), wo at azimuth 0.7 from the tangent, 2^17 samples:
    - their directions, in the float64 local frame, pass a chi-square test (16 x 32 cells of the sphere, the
      samples below the horizon included: bsdf_sample returns them with pdf 0) against the reference density
      of reflected visible normals, which above the horizon is Mitsuba's roughconductor pdf; 4 cases at the
      significance 1e-4, a false failure once in 2500 runs; the same samples fail against alpha_u and alpha_v
      swapped (p < 1e-10) in the anisotropic cases;
    - bsdf_sample's pdf is bsdf_pdf's at the sampled direction (2e-4 relative: the same formulas, the
      direction rounded) and 0 exactly where wi is below the horizon; its weight is bsdf_eval / bsdf_pdf there
      (2e-4 relative);
    - a white furnace: with eta 0 and k 1 (Mitsuba's defaults, F = 1 at every angle) the mean weight is the
      rough mirror's albedo, at most 1 (its standard error below 2e-3), and matches the mean of the
      reference's f cos / pdf over the same directions within 5 standard errors of their difference.
    Mutations seen failing: the frame's x and y axes swapped (the three anisotropic cases), the sample's weight
    G1(wo) for G1(wi) (all four)."""
    rng = np.random.default_rng(int(theta_o * 1000 + au * 100 + av * 10) + anisotropic)
    k = 1 << 17
    axis = unit(np.array([0.3, -0.5, 1.0]))
    tangent = unit(np.cross(axis, [0.2, 1.0, 0.1]))
    n, t = np.tile(axis, (k, 1)), np.tile(tangent, (k, 1))
    frame = local_frame64(n[:1], t[:1])
    phi_o = 0.7
    lo = np.array([np.sin(theta_o) * np.cos(phi_o), np.sin(theta_o) * np.sin(phi_o), np.cos(theta_o)])
    wo = np.tile(f32(lo[0] * frame[0] + lo[1] * frame[1] + lo[2] * frame[2]), (1, 1))
    lo = to_local(frame, wo)[0]
    wo = np.tile(wo, (k, 1))
    out = run(harness, anisotropic, distribution, n, t, au, av, wo, wo, rng.uniform(size=(k, 3)),
              eta=np.zeros(3), k=np.ones(3))
    wi = to_local(frame, out["s_wi"])
    p, statistic, total = chi_square(wi, sphere_density(distribution, f32(au), f32(av), lo))
    assert abs(total - 1) < 2e-3, total
    assert p > SIGNIFICANCE, (p, statistic)
    if au != av:
        assert chi_square(wi, sphere_density(distribution, f32(av), f32(au), lo))[0] < 1e-10
    valid = out["s_pdf"] > 0
    assert np.all(out["s_pdf"][wi[:, 2] <= 0] == 0) and np.all(valid[wi[:, 2] > 1e-4])
    np.testing.assert_allclose(out["s_eval_pdf"][valid], out["s_pdf"][valid], rtol=2e-4)
    fine = valid & (out["s_eval_pdf"] > 1e-3)
    np.testing.assert_allclose(out["s_weight"][fine], out["s_f"][fine] / out["s_eval_pdf"][fine, None], rtol=2e-4)
    weight = np.where(valid, out["s_weight"][:, 0], 0.0)
    mean, se = weight.mean(), weight.std(ddof=1) / np.sqrt(k)
    assert mean <= 1 and se < 2e-3, (mean, se)
    f_ref, pdf_ref = reference_eval_pdf(distribution, f32(au), f32(av), np.tile(lo, (k, 1)), wi, np.zeros(3),
                                        np.ones(3))
    ref_weight = np.where(valid & (pdf_ref > 0), f_ref[:, 0] / np.where(pdf_ref > 0, pdf_ref, 1), 0.0)
    diff = weight - ref_weight
    assert abs(diff.mean()) <= 5 * diff.std(ddof=1) / np.sqrt(k) + 1e-6, (mean, ref_weight.mean())
