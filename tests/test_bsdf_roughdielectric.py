"""Rough glass, `roughdielectric` (kernels/bsdfs/roughdielectric.cl: GGX or Beckmann microfacets, isotropic or
anisotropic, Walter et al. 2007, as Mitsuba 3 writes it), through bsdf.cl's interface: eval and pdf against
tests/bsdf_reference.py's float64 RoughDielectric at every lane width, the samples' directions by a chi-square
test against bsdf_pdf, the samples' weight against eval / pdf, the transmission's reciprocity with Mitsuba's
radiance factor, and a white furnace. Each runs in the isotropic build (HAS_ANISOTROPIC 0: microfacet.cl sees
cosines alone, the build of an isotropic scene) and the anisotropic one (the frame of the shading tangent)."""
import numpy as np
import pytest

from helpers import LANE_ENDS, at_lane_ends, lane_id

import bsdf_reference as ref
import bsdf_support
from bsdf_support import unit
from devtools.chi_square import SIGNIFICANCE, chi_square

BK7 = 1.5046 / 1.000277  # Mitsuba's default int_ior over ext_ior
KINDS = ("ggx", "beckmann")  # the microfacet distributions
# bsdf_sample's direction, weight, density and side, and bsdf_eval_pdf at the direction (bsdf_support.OUTPUTS)
SAMPLED = ("s_wi", "s_weight", "s_pdf", "s_transmit", "s_f", "s_eval_pdf")


def defines(anisotropic):
    """The isotropic build (HAS_ANISOTROPIC 0: microfacet.cl sees only cosines to the normal, the build an
    isotropic scene gets) or the anisotropic one (the local frame of the shading tangent), both with Beckmann's
    distribution compiled in."""
    return dict(HAS_PATH_TRACING=1, HAS_ROUGH_DIELECTRICS=1, HAS_RECTANGLES=1, HAS_BECKMANN=1,
                HAS_ANISOTROPIC=int(anisotropic))


def f32(v):
    return np.asarray(v, np.float32).astype(np.float64)


def frame(n):
    """An orthonormal frame (columns t, b, n) per unit normal n: local coordinates are directions @ frame."""
    a = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = unit(np.cross(n, a))
    return np.stack([t, np.cross(n, t), n], axis=-1)


def ref_frame(n, t):
    """The float64 frame (columns t, b, n) of the float32 normal n and tangent t the kernel reads, t made
    orthogonal to n (the kernel takes t as it is: orthogonal within float32's rounding)."""
    t = unit(t - np.sum(t * n, axis=1)[:, None] * n)
    return np.stack([t, np.cross(n, t), n], axis=-1)


def to_local(v, f):
    return np.einsum("ni,nij->nj", v, f)


def lanes_of(case, m):
    """m lanes of case (distribution, alpha_u, alpha_v, eta): its Material (colour 1) and each lane's index into
    that table (bsdf_support.run's table and which)."""
    kind, au, av, eta = case
    table = bsdf_support.material_table(bsdf="roughdielectric", eta=(eta, 0.0, 0.0), alpha=au, alpha_v=av,
                                        distribution=kind)
    return table, np.zeros(m, int)


def run_eval(harness, anisotropic, wo, wi, n, t, params, backface):
    """bsdf_eval_pdf per lane, the shading point's normal n (sp.n, on wo's side unless a test puts it
    elsewhere), tangent t (the anisotropic build's sp.t), the hit from inside where backface; params = (a
    Material table, each lane's index into it) (lanes_of)."""
    table, which = params
    out = bsdf_support.run(harness, table, n, wo, wi, None, ("f", "pdf"), which=which, tangent=t, backface=backface,
                           **defines(anisotropic))
    return out["f"], out["pdf"]


def run_sample(harness, anisotropic, wo, n, t, params, backface, u):
    """bsdf_sample per lane from u (m, 3), and bsdf_eval_pdf at each sampled direction (SAMPLED)."""
    table, which = params
    return bsdf_support.run(harness, table, n, wo, None, u, SAMPLED, which=which, tangent=t, backface=backface,
                            **defines(anisotropic))


U = 2.0 ** -24  # float32's unit roundoff
def reference(case):
    kind, au, av, eta = case
    return ref.RoughDielectric(distribution=kind, alpha_u=au, alpha_v=av, int_ior=eta, ext_ior=1.0)


def half_vector(wo, wi, eta):
    """Mitsuba's generalised half vector of local wo, wi (z along Mitsuba's normal), flipped up, and the float32
    kernel's absolute error bound on each of its components (in the kernel's frame: what D sees): h = wo + e wi
    (e = 1 or the relative index eta_rel) rounds each component within 2 U (1 + e) absolutely, which its
    normalisation divides by |h| (small for refraction between nearly equal indices: |h| >= |1 - eta_rel|);
    the normalisation (vrsqrt, within 4 U, and the products) adds 4 U, the dot products with the frame's
    axes 3 U and the frame's own rounding (sp.t orthogonal to n within U, n unit within 1.5 U) 1 U: 8 U +
    4 U (1 + e) / |h|, doubling the first term's 2 U for the roundings' sum over three components. That sum
    is nearly reached (the isotropic build's worst D error at alpha 1e-3 is 0.9 of the D error it implies),
    so the bound takes twice it: room as the other terms' factor 4 gives them."""
    refl = wo[:, 2] * wi[:, 2] > 0
    e = np.where(refl, 1.0, np.where(wo[:, 2] > 0, eta, 1 / eta))
    h = wo + wi * e[:, None]
    size = np.linalg.norm(h, axis=1)
    m = h / size[:, None]
    return m * np.sign(m[:, 2:3]), 2 * (8 + 4 * (1 + e) / size) * U


def d_conditioning(case, anisotropic, wo, wi):
    """The relative error of the kernel's D(m) that float32 cannot avoid in each build, by finite differences
    of the float64 D at the perturbations the kernel's rounding makes (first order where small, the actual
    change where not), with dm the bound of half_vector on the error of m's components:
    - the isotropic build takes cos(theta_m) alone (microfacet.cl's ggx_d and isotropic beckmann_d), and
      GGX's c (alpha^2 - 1) + 1 and Beckmann's (1 - c) / (c alpha^2) cancel near the normal: an error in
      c = cos^2 costs 2 |1 - alpha^2| |dc| / d in GGX's D ~ 1 / d^2 (d = 1e-6 at alpha 1e-3's peak: D
      within a factor 5 only), |dc| / (c^2 alpha^2) in Beckmann's exponent; cos(theta_m) = n . m is within
      dm of its value, c within 2 dm relative (cos ~ 1 where it matters). (Mitsuba's float32 D, from m's x
      and y, does not cancel: the reference's float32 evaluation does not see this error, hence this term.)
    - the anisotropic build takes m's local x, y and z (the dot products of m with sp.t, n x sp.t and n):
      GGX's (x / alpha_u)^2 + (y / alpha_v)^2 + z^2 has no cancellation, and an absolute error dx in x moves
      D by some 2 |dx| / alpha relative at the peak (some 1e-3 of D at alpha 1e-3 where the isotropic
      build's is a factor 5): each of the three components moved by dm, the changes summed.
    0 where D is 0."""
    distr = reference(case).distr
    m, dm = half_vector(wo, wi, case[3])
    d0 = distr.D(m)
    if anisotropic:
        moved = [[m + s * dm[:, None] * np.eye(3)[k] for s in (1, -1)] for k in range(3)]
        with np.errstate(invalid="ignore", divide="ignore"):
            cond = sum(np.maximum(*(np.abs(distr.D(x) - d0) for x in pair)) for pair in moved) / d0
    else:
        a2 = case[1] ** 2
        cos_only = {"ggx": lambda c: a2 / (np.pi * (c * (a2 - 1) + 1) ** 2),  # the kernel's forms of c = cos^2,
                    "beckmann": lambda c: np.exp(-np.maximum(1 - c, 0) / (c * a2)) / (np.pi * a2 * c * c)}[case[0]]
        c2 = m[:, 2] ** 2  # c past 1 too, as the kernel's may be
        with np.errstate(invalid="ignore", divide="ignore"):
            cond = np.maximum(*(np.abs(cos_only(c2 * (1 + 2 * s * dm)) - d0) for s in (1, -1))) / d0
    return np.where(d0 > 0, np.nan_to_num(cond), 0.0)


def eval_tolerance(case, anisotropic, wo, wi, rng, draws=4):
    """The float64 reference's eval and pdf at the float32 inputs (local frame), and each value's tolerance,
    as tests/bsdf_reference.py's mitsuba_errors argues it for Mitsuba's own float32 values:
        tol = 4 (spread + noise) + (16 U + 16 U e_B + D's conditioning) |r64| + 1e-30,
    spread the largest change of the float64 value over `draws` inputs whose components lie within 4 U of
    these, absolutely (the condition of the value: the half vector's, the Fresnel term's at the critical
    angle, the boundaries of the lobes' validity; absolutely, not relatively as for Mitsuba's local inputs,
    because the kernel takes world directions: its cos(theta) = n . w is off by some U whatever its size,
    which near grazing moves G1 and 1 / cos_o by a part in 10^4), noise the largest difference of the same
    formulas in float32 from float64 over `draws` inputs within 1e-4 (float32's own error there, the
    cancellation of 1 - F near total internal reflection included), 16 U the roundings of a chain of some tens
    of operations, 16 U e_B Beckmann's exponential (e_B = tan^2(theta_m) / alpha^2, its argument, rounded
    and then exponentiated by vexp2: an error of e_B's relative rounding times e_B), and d_conditioning."""
    b64 = reference(case)
    with ref.precision(np.float32):
        b32 = reference(case)
    f64, p64 = b64.eval(wo, wi)[:, 0], b64.pdf(wo, wi)
    spread, noise = np.zeros((2, len(wo))), np.zeros((2, len(wo)))
    for _ in range(draws):
        o, i = (w + 4 * U * rng.uniform(-1, 1, w.shape) for w in (wo, wi))
        spread = np.maximum(spread, np.abs(np.stack([b64.eval(o, i)[:, 0], b64.pdf(o, i)]) - [f64, p64]))
        o, i = (unit(w + 1e-4 * rng.uniform(-1, 1, w.shape)) for w in (wo, wi))
        with ref.precision(np.float32):
            o32, i32 = o.astype(np.float32), i.astype(np.float32)
            r32 = np.stack([b32.eval(o32, i32)[:, 0], b32.pdf(o32, i32)]).astype(np.float64)
        o, i = o32.astype(np.float64), i32.astype(np.float64)
        noise = np.maximum(noise, np.nan_to_num(np.abs(r32 - np.stack([b64.eval(o, i)[:, 0], b64.pdf(o, i)]))))
    kind, au, av, eta = case
    m = half_vector(wo, wi, eta)[0]
    e_b = ((m[:, 0] / au) ** 2 + (m[:, 1] / av) ** 2) / m[:, 2] ** 2 if kind == "beckmann" else 0.0
    relative = 16 * U + 16 * U * e_b + d_conditioning(case, anisotropic, wo, wi)
    tol = 4 * (spread + noise) + relative * np.abs([f64, p64]) + 1e-30
    return f64, p64, tol[0], tol[1]


ALPHAS = (0.001, 0.01, 0.1, 0.3, 0.7, 1.0)
ETAS = (BK7, 1 / 1.33, 2.4)  # glass in air, an air bubble in water (int_ior below ext_ior), diamond-like
# (alpha_u, alpha_v) of the anisotropic build: isotropic at 1e-3 (the peak the isotropic build cannot resolve),
# a needle (1e-3 across 0.05), and stretched lobes at moderate and large roughness
ANISOTROPIC_ALPHAS = ((0.001, 0.001), (0.001, 0.05), (0.02, 0.4), (0.3, 0.05), (0.7, 0.2), (1.0, 0.5))
CASES = {False: [(kind, f32(a), f32(a), e) for kind in KINDS for a in ALPHAS for e in ETAS],
         True: [(kind, f32(au), f32(av), e) for kind in KINDS for au, av in ANISOTROPIC_ALPHAS for e in ETAS]}
BUILDS = pytest.mark.parametrize("anisotropic", [False, True], ids=["isotropic", "anisotropic"])


def pairs(rng, m, case):
    """m direction pairs about random normals: (wo, wi, sp.n, sp.t, backface, the reference's frame), float32
    values in float64. Mitsuba's normal N is uniform on the sphere, the tangent random about it; wo is uniform
    on the sphere (so inside for half, grazing for some); sp.n faces wo, as the renderer's shading normal faces
    the viewer's side of the geometric normal, but for one pair in eight it is left on the other side (a
    shading normal the viewer is below: the kernel turns it over, as Mitsuba's frame would see wo, and the
    anisotropic frame's y axis with it). wi: uniform on the sphere for half the pairs, for the other half the
    reference's own sample of wo (inside the lobes, which uniform directions miss when they are narrow)."""
    n_mitsuba = f32(unit(rng.normal(size=(m, 3))))
    t = f32(unit(np.cross(n_mitsuba, rng.normal(size=(m, 3)))))
    fr = ref_frame(n_mitsuba, t)
    wo = f32(unit(rng.normal(size=(m, 3))))
    lo = to_local(wo, fr)
    backface = lo[:, 2] < 0  # sp.n on wo's side: backface says wo is below N
    sp_n = np.where(backface[:, None], -n_mitsuba, n_mitsuba)
    odd = rng.uniform(size=m) < 0.125
    sp_n = np.where(odd[:, None], -sp_n, sp_n)
    backface = np.where(odd, ~backface, backface)  # then N = -sp.n where backface, still
    s = reference(case).sample(lo, rng.uniform(size=m), rng.uniform(size=(m, 2)))
    li = unit(rng.normal(size=(m, 3)))
    sampled = s.valid & (np.arange(m) % 2 == 1)
    li[sampled] = s.wi[sampled]
    wi = f32(np.einsum("nij,nj->ni", fr, li))
    return wo, wi, sp_n, t, np.where(backface, -1, 0).astype(np.int32), fr


EVAL_DATA = {}


def eval_data(anisotropic, m=256):
    """The eval test's pairs (m per case of CASES[anisotropic]) and their references and tolerances, computed
    once per build for every lane width."""
    if anisotropic not in EVAL_DATA:
        rng = np.random.default_rng(57 + anisotropic)
        cases = CASES[anisotropic]
        data = [pairs(rng, m, c) for c in cases]
        refs = [eval_tolerance(c, anisotropic, to_local(d[0], d[5]), to_local(d[1], d[5]), rng)
                for c, d in zip(cases, data)]
        params = np.concatenate([lanes_of(c, m)[0] for c in cases]), np.repeat(np.arange(len(cases)), m)
        EVAL_DATA[anisotropic] = [np.concatenate([d[k] for d in data]) for k in range(5)], params, refs
    return EVAL_DATA[anisotropic]


@BUILDS
def test_eval_and_pdf_against_float64(harness, anisotropic):
    """bsdf_eval_pdf of rough glass against tests/bsdf_reference.py's float64 RoughDielectric (Mitsuba 3.9.1's
    roughdielectric.cpp in numpy, checked against Mitsuba itself) at 256 direction pairs for each case: GGX
    and Beckmann, eta in {1.504 (bk7 in air), 1 / 1.33 (air in water), 2.4}, and in the isotropic build alpha
    in {0.001, 0.01, 0.1, 0.3, 0.7, 1}, in the anisotropic one (alpha_u, alpha_v) in ANISOTROPIC_ALPHAS: both
    sides of the surface (the index inverts inside), reflection, refraction, total internal reflection (eta <
    1 from outside, eta > 1 from inside: past the critical angle no microfacet refracts), the sign checks of
    G1 (pairs no microfacet joins have value and density 0), random tangents, and shading normals the viewer
    is below. Each value within its tolerance (eval_tolerance: the float64 value's condition at float32
    inputs, float32's own error, 16 roundings, Beckmann's exponential, and D's error in each build, which in
    the isotropic build is a factor 5 at alpha 1e-3's peak and in the anisotropic one, with m's x and y, 2e-3:
    d_conditioning). The tolerance bounds the error of a correct float32 kernel with room (a factor 4 on the
    measured condition), so it fails a correct kernel only where the bound's first-order model is wrong;
    measured at every lane width (the same bits at each): the largest error is 0.87 of its tolerance in the
    isotropic build (GGX at alpha 1e-3, whose tolerance there is about the value itself: the kernel's D is
    1.9 times the reference's at the worst peak), 0.14 in the anisotropic one (0.07 at alpha 1e-3, where the
    tolerance is some 0.5% of the value). It fails a missing 1 / eta^2 in the transmission's radiance
    factor, F in place of 1 - F, a factor 4 dropped from the reflection's Jacobian, the index not inverted
    inside, and the half vector of refraction formed with 1 / eta (each tried in the GGX-only version, each
    failing at hundreds of pairs); and (tried on this one) the anisotropic frame's x and y swapped (alpha_u
    along n x sp.t), G1 of wi taken at wo's local direction, Beckmann's lanes evaluated as GGX, and, for the
    tightened tolerance, the anisotropic build's D given the isotropic build's cancelling form, m's local x
    and y replaced by (0, sqrt(1 - cos^2)) where alpha_u = alpha_v (fails at the alpha 1e-3 cases, by 70 to
    260 times the tolerance)."""
    (wo, wi, sp_n, t, bf), params, refs = eval_data(anisotropic)
    m = len(wo) // len(refs)
    f, pdf = run_eval(harness, anisotropic, wo, wi, sp_n, t, params, bf)
    assert np.array_equal(f[:, 0], f[:, 1]) and np.array_equal(f[:, 0], f[:, 2])  # colour 1: grey
    worst = []
    for k, (case, (f64, p64, tol_f, tol_p)) in enumerate(zip(CASES[anisotropic], refs)):
        at = slice(k * m, (k + 1) * m)
        excess_f, excess_p = np.abs(f[at, 0] - f64) / tol_f, np.abs(pdf[at] - p64) / tol_p
        worst.append((case, float(excess_f.max()), float(excess_p.max())))
        assert (f64 > 0).sum() > m // 3, case  # most pairs have a value: the lobes are met
    bad = [w for w in worst if w[1] > 1 or w[2] > 1]
    assert not bad, bad


def case_point(theta_o, phi_o, backface, m):
    """m copies of one shading point (a tilted normal, sp.n facing the viewer, a tangent about it) seen theta_o
    off its normal at azimuth phi_o from the tangent, and the frame (columns: sp.t, sp.n x sp.t, sp.n)."""
    n = unit(np.array([[0.3, -0.5, 0.81]]))
    fr = frame(n)[0]
    wo = np.sin(theta_o) * (np.cos(phi_o) * fr[:, 0] + np.sin(phi_o) * fr[:, 1]) + np.cos(theta_o) * fr[:, 2]
    return (np.tile(wo, (m, 1)), np.tile(n, (m, 1)), np.tile(fr[:, 0], (m, 1)),
            np.full(m, -1 if backface else 0, np.int32), fr)


# (theta_o, phi_o, case, backface, anisotropic build): GGX glass seen from outside, near the normal and near
# grazing; from inside past the smooth critical angle (0.73), where only the rougher microfacets refract; an
# air bubble in water (eta < 1 from outside: total internal reflection on the outer side); inside a dense
# medium; Beckmann glass from outside and from inside; anisotropic GGX and Beckmann, the latter from inside
# an air bubble in water.
SAMPLING_CASES = [(0.7, 0.0, ("ggx", 0.2, 0.2, BK7), False, False), (1.3, 0.0, ("ggx", 0.6, 0.6, BK7), False, False),
                  (0.9, 0.0, ("ggx", 0.3, 0.3, BK7), True, False), (0.5, 0.0, ("ggx", 1.0, 1.0, 1 / 1.33), False, False),
                  (0.3, 0.0, ("ggx", 0.1, 0.1, 2.4), True, False),
                  (0.8, 0.0, ("beckmann", 0.3, 0.3, BK7), False, False),
                  (0.6, 0.0, ("beckmann", 0.15, 0.15, BK7), True, False),
                  (1.0, 0.7, ("ggx", 0.08, 0.5, BK7), False, True),
                  (0.7, 2.0, ("beckmann", 0.4, 0.1, 1 / 1.33), True, True)]


def case_id(c):
    return f"{c[2][0]}-{c[2][1]}-{c[2][2]}-{c[2][3]:.3f}-{'in' if c[3] else 'out'}-{c[0]}"


@pytest.mark.parametrize("lanes", LANE_ENDS[-1:], ids=lane_id)
@pytest.mark.parametrize("theta_o, phi_o, case, backface, anisotropic", SAMPLING_CASES,
                         ids=[case_id(c) for c in SAMPLING_CASES])
def test_sampling_chi_square(harness, theta_o, phi_o, case, backface, anisotropic):
    """bsdf_sample's directions are distributed as bsdf_pdf says (Mitsuba 3's test_chi2 approach): a chi-square
    test over 16 x 32 cells of the whole sphere (reflection and refraction at once, the lobe choice by F
    included) of 2^17 samples, against the kernel's own bsdf_pdf integrated over each cell by quadrature
    (devtools/chi_square.py), normalised over the valid samples; and the share of samples the sampler
    gives up (pdf 0: a reflection below the surface, a refraction above it) is 1 minus the density's total,
    within 5 binomial standard deviations plus the quadrature's 1e-3. Significance 1e-4 per case, 9 cases at
    1 lane width: a correct sampler fails once in 1100 runs (p measured: 0.58, 0.66, 0.48, 0.55, 0.93 for the
    GGX cases, 0.79 and 0.84 for Beckmann's, 0.41 and 0.79 for the anisotropic ones); the 5-sigma count once in
    10^5. The sample's transmit flag is the side wi leaves on. It fails (each tried) with the lobe chosen by
    1 - F, with the visible normals sampled for -wo's side inside, with refraction through m using eta for
    1 / eta, and with the sampler's alpha_u and alpha_v swapped (both anisotropic cases, p = 0)."""
    m = 1 << 17
    kind, au, av, eta = case
    wo, n, t, bf, fr = case_point(theta_o, phi_o, backface, m)
    params = lanes_of(case, m)
    u = np.random.default_rng(int(theta_o * 100 + au * 10 + av * 1000)).uniform(size=(m, 3))
    out = run_sample(harness, anisotropic, wo, n, t, params, bf, u)
    valid = out["s_pdf"] > 0
    local = out["s_wi"] @ fr
    np.testing.assert_array_equal(out["s_transmit"][valid] > 0, local[valid, 2] < 0)

    cache = {}

    def density(c, phi):
        if c.shape not in cache:
            s = np.sqrt(np.maximum(0.0, 1 - c**2))
            d = np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1).reshape(-1, 3) @ fr.T
            k = len(d)
            cache[c.shape] = run_eval(harness, anisotropic, np.tile(wo[0], (k, 1)), d, np.tile(n[0], (k, 1)),
                                      np.tile(t[0], (k, 1)), lanes_of(case, k), np.full(k, bf[0], np.int32))[1]
        return cache[c.shape].reshape(c.shape)

    _, _, total = chi_square(local[:1], density)
    p, statistic, _ = chi_square(local[valid], lambda c, phi: density(c, phi) / total)
    assert p > SIGNIFICANCE, (p, statistic)
    lost = 1 - valid.mean()
    assert abs(lost - (1 - total)) <= 5 * np.sqrt(max(lost * (1 - lost), 1e-6) / m) + 1e-3, (lost, total)


def weight_cases(anisotropic):
    """The roughness of sample_weight's and reciprocity's cases: the eval test's but alpha 1e-3 (where the
    sample's D and eval's differ by the isotropic build's conditioning)."""
    return [c for c in CASES[anisotropic] if min(c[1], c[2]) > 0.002]


@at_lane_ends
@BUILDS
def test_sample_weight_is_eval_over_pdf(harness, anisotropic):
    """Each sample's weight is bsdf_eval / bsdf_pdf at its direction, and its pdf bsdf_pdf there (what MIS needs
    of it), at 128 samples of random viewers (both sides, random tangents, shading normals the viewer is below)
    for each case of the eval test but alpha 1e-3 (GGX and Beckmann, in the anisotropic build anisotropic):
    the weight k G1(wi) (times 1 / eta^2 on refraction) within (64 + 4 / a^2) U relative, a = wo . m (eval /
    pdf has D, G1(wo) and F cancel to the rounding of some 20 operations per side, and of reflection's a / b,
    equal but for the half vector's rounding: m = (wo + wi) / |wo + wi| = (wo + wi) / 2a turns by U / a where
    wo and wi are nearly opposite, and b - a = (wi - wo) . m, |wi - wo| ~ 2, by U / a of a: measured at most
    0.6 U / a^2, at a grazing reflection, a = 0.009, 4.5e-4 relative; here at most 0.20 of the bound), and
    the pdf within eval's tolerance (at most 0.16 of it) of the float64 pdf at the sampled direction (the
    sample's pdf takes D at the sampled m, eval's at the m it recomputes). A sample the sampler gives up has pdf and weight 0. It fails (tried)
    without the 1 / eta^2 factor on the weight, and with the weight G1(wo) G1(wi)."""
    rng = np.random.default_rng(58 + anisotropic)
    m = 128
    for case in weight_cases(anisotropic):
        wo, _, sp_n, t, bf, fr = pairs(rng, m, case)
        out = run_sample(harness, anisotropic, wo, sp_n, t, lanes_of(case, m), bf, rng.uniform(size=(m, 3)))
        valid = out["s_pdf"] > 0
        assert valid.mean() > 0.5 and np.all(out["s_weight"][~valid] == 0), case
        w, f, p = out["s_weight"][valid, 0], out["s_f"][valid, 0], out["s_eval_pdf"][valid]
        lo, li = to_local(wo[valid], fr[valid]), to_local(out["s_wi"][valid], fr[valid])
        a = np.abs(np.sum(lo * half_vector(lo, li, case[3])[0], axis=1))
        assert np.all(np.abs(w - f / p) <= (64 * U + 4 * U / a**2) * f / p), case
        _, p64, _, tol_p = eval_tolerance(case, anisotropic, lo, li, rng)
        assert np.all(np.abs(out["s_pdf"][valid] - p64) <= tol_p), case


@at_lane_ends
@BUILDS
def test_reciprocity_with_the_radiance_factor(harness, anisotropic):
    """Reflection is reciprocal, f(wo, wi) = f(wi, wo); refraction in radiance mode is not (Mitsuba's 1 / eta^2):
    eta_wi^2 f(wo, wi) = eta_wo^2 f(wi, wo), eta_w the index of w's side (pbrt-v4 9.7.3's generalised
    reciprocity). The kernel's eval / |cos_i| times eta_wi^2 against the same with the directions swapped
    (the shading point then seen from wi: its sp.n turned to wi's side, backface where wi is inside, the same
    tangent), at 128 pairs per case of sample_weight's, within the sum of the two values' tolerances
    (eval_tolerance, scaled alike; the largest difference measured: 0.16 of it). Without the eta^2 factors the
    refracted pairs differ by up to eta^2 (the test's own check that it sees the factor: most refracted pairs
    fail without it)."""
    rng = np.random.default_rng(59 + anisotropic)
    m = 128
    for case in weight_cases(anisotropic):
        eta = case[3]
        wo, wi, sp_n, t, bf, fr = pairs(rng, m, case)
        params = lanes_of(case, m)
        f_ab = run_eval(harness, anisotropic, wo, wi, sp_n, t, params, bf)[0][:, 0]
        n_m = fr[:, :, 2]
        inside_i = np.sum(wi * n_m, axis=1) < 0
        inside_o = np.sum(wo * n_m, axis=1) < 0
        f_ba = run_eval(harness, anisotropic, wi, wo, np.where(inside_i[:, None], -n_m, n_m), t, params,
                        np.where(inside_i, -1, 0).astype(np.int32))[0][:, 0]
        lo, li = to_local(wo, fr), to_local(wi, fr)
        _, _, tol_ab, _ = eval_tolerance(case, anisotropic, lo, li, rng)
        _, _, tol_ba, _ = eval_tolerance(case, anisotropic, li, lo, rng)
        s_ab = np.where(inside_i, eta, 1.0) ** 2 / np.abs(li[:, 2])
        s_ba = np.where(inside_o, eta, 1.0) ** 2 / np.abs(lo[:, 2])
        assert np.all(np.abs(f_ab * s_ab - f_ba * s_ba) <= tol_ab * s_ab + tol_ba * s_ba), case
        crossing = (inside_i != inside_o) & (f_ab > 0)
        plain = np.abs(f_ab / np.abs(li[:, 2]) - f_ba / np.abs(lo[:, 2]))
        assert np.mean(plain[crossing] > (tol_ab * s_ab + tol_ba * s_ba)[crossing]) > 0.5, case


# (theta_o, phi_o, case, backface, anisotropic build)
FURNACE_CASES = [(0.5, 0.0, ("ggx", 0.01, 0.01, BK7), False, False), (1.0, 0.0, ("ggx", 0.3, 0.3, BK7), False, False),
                 (0.5, 0.0, ("ggx", 0.3, 0.3, BK7), True, False), (1.3, 0.0, ("ggx", 1.0, 1.0, BK7), False, False),
                 (0.8, 0.0, ("ggx", 0.5, 0.5, 1 / 1.33), False, False), (0.3, 0.0, ("ggx", 0.7, 0.7, 2.4), True, False),
                 (0.5, 0.0, ("beckmann", 0.01, 0.01, BK7), False, False),
                 (1.1, 0.0, ("beckmann", 0.5, 0.5, BK7), True, False),
                 (1.2, 0.4, ("ggx", 0.6, 0.1, BK7), False, True),
                 (0.6, 1.9, ("beckmann", 0.2, 0.8, 2.4), True, True)]


@at_lane_ends
@BUILDS
def test_white_furnace(harness, anisotropic):
    """The energy a sample carries, its weight with the radiance factor undone (times eta^2 on refraction),
    averaged over 2^14 samples of each case of the build (GGX and Beckmann, anisotropic in the anisotropic
    build): at most 1 (the interface absorbs nothing; the single-scattering model loses what masking hides,
    Mitsuba's too), within 5 standard errors and 8 U (a refracted weight G1 = 1, Beckmann's from a = 1.6 on,
    is the float32 1 / eta^2, which times eta^2 is 1 within some 4 U), and equal to the float64 reference's own sampler's (Mitsuba's
    mapping: 2^16 samples) within 5 standard errors of the difference; the plain mean weight (radiance, the
    1 / eta^2 included) likewise against the reference. At alpha 0.01 the interface is all but smooth and the
    energy 1 within 1e-3 (the loss is 1 - E[G1(wi)], of order alpha^2). Measured energies: 0.99994, 0.952,
    0.874, 0.526, 0.707, 0.502 (GGX), 1.0000001, 0.763 (Beckmann), 0.829 and 0.843 (anisotropic GGX and
    Beckmann). Each of 10 cases x 3 checks x 2 widths fails by chance with probability 6e-7 (5 sigma): 4e-5 in
    all."""
    rng = np.random.default_rng(60 + anisotropic)
    m = 1 << 14
    for theta_o, phi_o, case, backface, build in FURNACE_CASES:
        if build != anisotropic:
            continue
        wo, n, t, bf, _ = case_point(theta_o, phi_o, backface, m)
        out = run_sample(harness, anisotropic, wo, n, t, lanes_of(case, m), bf, rng.uniform(size=(m, 3)))
        eta = case[3]
        e_rel = 1 / eta if backface else eta  # the index across, relative to wo's side
        energy = out["s_weight"][:, 0] * np.where(out["s_transmit"] > 0, e_rel**2, 1.0)
        lo = np.tile([np.sin(theta_o) * np.cos(phi_o), np.sin(theta_o) * np.sin(phi_o),
                      -np.cos(theta_o) if backface else np.cos(theta_o)], (4 * m, 1))
        s = reference(case).sample(lo, rng.uniform(size=4 * m), rng.uniform(size=(4 * m, 2)))
        transmit_ref = s.wi[:, 2] * lo[:, 2] < 0
        energy_ref = s.weight[:, 0] * np.where(transmit_ref, e_rel**2, 1.0)
        assert energy.mean() <= 1 + 5 * energy.std() / np.sqrt(m) + 8 * U, (theta_o, case, energy.mean())
        for k, r in ((energy, energy_ref), (out["s_weight"][:, 0], s.weight[:, 0])):
            se = np.sqrt(k.var() / m + r.var() / (4 * m))
            assert abs(k.mean() - r.mean()) <= 5 * se + 1e-7, (theta_o, case, k.mean(), r.mean(), se)
        if max(case[1], case[2]) <= 0.01:
            assert abs(energy.mean() - 1) < 1e-3, energy.mean()
