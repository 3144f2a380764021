"""The rough plastic BSDF (type = "roughplastic", kernels/bsdfs/roughplastic.cl: Mitsuba 3's roughplastic, GGX or
Beckmann microfacets) and its host tables (raytrace/scene/rough_transmittance.py): the tables against
Mitsuba's own, eval and pdf against a float64 reference written here from Mitsuba 3.9.1's roughplastic.cpp
(with tests/bsdf_reference.py's microfacet distribution), its samples' directions by chi-square against that
pdf, their weights against eval / pdf, reciprocity, and a furnace."""
import numpy as np
import pytest

from raytrace.scene import rough_transmittance
from raytrace.renderer.packing import material_structs
from raytrace.scene.model import Material

import bsdf_reference as ref
import bsdf_support
from devtools.chi_square import SIGNIFICANCE, cell_integrals, chi_square
from helpers import LANE_ENDS, ROOT, at_lane_ends, lane_id, runnable_lane_widths

# Beckmann's terms compiled in (both distributions per lane); ANISOTROPIC the build of a scene that also has an
# anisotropic BSDF, whose microfacet terms read m's x and y.
DEFINES = dict(HAS_PATH_TRACING=1, HAS_ROUGH_PLASTICS=1, HAS_RECTANGLES=1, HAS_BECKMANN=1)
ANISOTROPIC = dict(DEFINES, HAS_ANISOTROPIC=1)

# eval and pdf at (wo, wi), a sample, and eval and pdf at its direction (bsdf_support.OUTPUTS)
OUTPUTS = ("f", "pdf", "s_wi", "s_weight", "s_pdf", "s_f", "s_eval_pdf")

# (alpha, int_ior, ext_ior, colour, specular, nonlinear, distribution): alpha from 1e-3 to 1, the relative index
# above and below 1 (the coat seen from a denser medium: total internal reflection within the coat's
# transmittance), a coloured coat, nonlinear, and Beckmann's distribution (alpha 0.01 to 0.5: below 0.01 an
# isotropic build's Beckmann D is float32's guess near the peak, beckmann_d's 1 - cos^2 cancelling; D's
# conditioning below).
MATERIALS = [(0.3, 1.49, 1.000277, (0.7, 0.15, 0.08), (1.0, 1.0, 1.0), False, "ggx"),
             (0.001, 1.49, 1.000277, (0.2, 0.5, 0.8), (1.0, 1.0, 1.0), False, "ggx"),
             (0.05, 2.4, 1.0, (0.5, 0.5, 0.5), (0.8, 0.9, 1.0), True, "ggx"),
             (1.0, 1.0, 1.4, (0.9, 0.9, 0.9), (1.0, 1.0, 1.0), False, "ggx"),
             (0.6, 1.0, 1.05, (0.1, 0.25, 0.7), (1.0, 0.5, 0.25), True, "ggx"),
             (0.1, 1.5, 1.0, (0.6, 0.3, 0.2), (1.0, 1.0, 1.0), False, "beckmann"),
             (0.01, 1.49, 1.000277, (0.3, 0.6, 0.3), (1.0, 1.0, 1.0), True, "beckmann"),
             (0.5, 1.0, 1.33, (0.8, 0.8, 0.8), (1.0, 1.0, 1.0), False, "beckmann")]


def materials(rows=MATERIALS):
    """model.Materials of the rows, and their packed table (packing.material_structs)."""
    found = [Material(name=f"m{i}", colour=np.array(c, float), bsdf="roughplastic", alpha=a, int_ior=ni,
                      ext_ior=ne, distribution=dist, specular=s, nonlinear=nl)
             for i, (a, ni, ne, c, s, nl, dist) in enumerate(rows)]
    return found, material_structs(found)


# ------------------------------------------------------------------------------------------------------
# A float64 reference from Mitsuba 3.9.1's roughplastic.cpp (eval, pdf) and its microfacet header, in the local
# frame (z the normal), with the material's packed table and internal reflectance (their quadrature is
# test_tables_match_mitsuba's); wo the viewer's direction (Mitsuba's si.wi), wi the light's.

def lerp_gather(table, x):
    x = np.clip(x, 0, 1) * (len(table) - 1)
    i = np.minimum(x.astype(int), len(table) - 2)
    return table[i] + (table[i + 1] - table[i]) * (x - i)


DISTRIBUTIONS = {0: "ggx", 1: "beckmann"}  # types.h's MICROFACET_*


def reference(packed, wo, wi):
    """(f cos_i (n, 3), pdf (n,), the coat's share of f cos_i (n, 3), of pdf (n,)) of the packed material (one
    struct) at local unit directions (n, 3), from roughplastic.cpp's eval and pdf; D and G1 are
    tests/bsdf_reference.py's Microfacet (Mitsuba's MicrofacetDistribution, from m's x, y and z)."""
    alpha, eta = max(float(packed["alpha"]), 1e-4), float(packed["eta"][0])
    distr = ref.Microfacet(DISTRIBUTIONS[int(packed["distribution"])], alpha)
    table, r = packed["transmittance"].astype(float), float(packed["internal_reflectance"])
    k, spec, w = packed["colour"].astype(float), packed["specular"].astype(float), float(packed["specular_weight"])
    co, ci = wo[:, 2], wi[:, 2]
    on = (co > 0) & (ci > 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        h = wo + wi
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        d = distr.D(h)
        g1_o = distr.smith_g1(wo, h)
        glossy = ref.fresnel_dielectric(np.sum(wo * h, axis=1), eta)[0] * d * g1_o * distr.smith_g1(wi, h) / (4 * co)
        t_o, t_i = lerp_gather(table, co), lerp_gather(table, ci)
        base = k / (1 - (k * r if packed["nonlinear"] else r))
        coat = glossy[:, None] * spec
        value = coat + base * (t_o * t_i * ci / (np.pi * eta**2))[:, None]
        ps, pd = (1 - t_o) * w, t_o * (1 - w)
        ps = ps / (ps + pd)
        coat_p = ps * d * g1_o / (4 * co)
        pdf = coat_p + (1 - ps) * ci / np.pi
    z = lambda a: np.where(on[:, None] if a.ndim == 2 else on, np.nan_to_num(a), 0.0)  # noqa: E731
    return z(value), z(pdf), z(coat), z(coat_p)


def frame(n):
    """Rows t, b, n: an orthonormal frame about each unit normal (n, 3)."""
    a = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(n, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return np.stack([t, np.cross(n, t), n], axis=1)


def local(f, v):
    return np.einsum("nij,nj->ni", f, v)


def f32(v):
    return np.asarray(v, np.float32).astype(np.float64)


def run(harness, packed, which, n, wo, wi, u, defines=DEFINES):
    """The kernel's outputs for lanes of materials `which` (indices into packed) at normals n."""
    return bsdf_support.run(harness, packed, n, wo, wi, u, OUTPUTS, which=which, **defines)


def random_case(rng, count, n_materials):
    """Unit normals, wo and wi (float32 values) with 1/8 of each below the normal's horizon and 1/8 of the wi
    near the mirror direction of wo (where the glossy lobe of a small alpha lies), material indices, u."""
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    wo, wi = rng.normal(size=(2, count, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    side = np.where(rng.uniform(size=count) < 0.125, -1.0, 1.0)  # 1/8 below the horizon
    wo *= (np.sign(np.sum(wo * n, axis=1)) * side)[:, None]
    mirror = 2 * np.sum(wo * n, axis=1)[:, None] * n - wo + rng.normal(scale=2e-3, size=(count, 3))
    wi = np.where((rng.uniform(size=count) < 0.125)[:, None], mirror, wi)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    flip = (np.sum(wi * n, axis=1) < 0) & (rng.uniform(size=count) < 0.875)
    wi = np.where(flip[:, None], wi - 2 * np.sum(wi * n, axis=1)[:, None] * n, wi)
    return (f32(n), f32(wo), f32(wi), rng.integers(0, n_materials, count), rng.uniform(size=(count, 3)))


U = 2.0**-24  # float32's unit roundoff
K_COS2 = 32  # cos^2(theta_h)'s error in an isotropic build's D, in units of U (d_conditioning)


def d_conditioning(packed, lh):
    """The relative error of an isotropic build's D(h) that float32 cannot avoid, to first order (as
    tests/test_bsdf_roughdielectric.py argues it for GGX): microfacet.cl's ggx_d and beckmann_d take cos(theta_h)
    alone, and their 1 - cos^2 cancels near the normal. The kernel's cos(theta_h) = n . h, h = (wo + wi)
    normalised by vrsqrt (within 4 U), its squared length and the dot products (3 U each), is within some 10 U
    of its value for the float32 inputs; its square within 21 U: K_COS2 = 32 U of error dc in c = cos^2.
    GGX's D ~ 1 / (c (alpha^2 - 1) + 1)^2 moves by 2 |1 - alpha^2| dc / (c (alpha^2 - 1) + 1) relatively;
    Beckmann's, exp(-(1 - c) / (c alpha^2)) / c^2, by |1 / (c^2 alpha^2) - 2 / c| dc. At the GGX lobe's peak of
    alpha 1e-3 that is 4 (float32 cannot resolve that lobe: packing.py's SMOOTH_ALPHA); Beckmann at alpha 0.01,
    2e-2. An anisotropic build's D, from h's x and y, does not cancel (nor does Mitsuba's float32 D)."""
    alpha = max(float(packed["alpha"]), 1e-4)
    c = np.minimum(lh[:, 2] ** 2, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        if DISTRIBUTIONS[int(packed["distribution"])] == "ggx":
            rel = 2 * abs(1 - alpha**2) / (c * (alpha**2 - 1) + 1)
        else:
            rel = np.abs(1 / (c * c * alpha**2) - 2 / c)
    return np.nan_to_num(rel * K_COS2 * U)


def eval_tolerance(packed, lo, li, rng, draws=4):
    """The float64 reference's eval and pdf at the float32 inputs (local frame), and each one's tolerance:
        tol = 4 spread + 16 U |r64| + conditioning |coat part| + 1e-7,
    spread the largest change of the float64 value over `draws` inputs whose components lie within 4 U of
    these, absolutely (the value's condition: the half vector's, G1's and 1 / cos_o's near grazing; the kernel
    takes world directions, and its cos(theta) = n . w is off by some U whatever its size); 16 U the roundings
    of a chain of some tens of float32 operations; the conditioning d_conditioning's, on the coat's share
    alone (the base's term has no D); 1e-7 absolute, below any value that counts."""
    f64, p64, cf, cp = reference(packed, lo, li)
    spread_f, spread_p = np.zeros_like(f64), np.zeros_like(p64)
    for _ in range(draws):
        o, i = (w + 4 * U * rng.uniform(-1, 1, w.shape) for w in (lo, li))
        f2, p2 = reference(packed, o, i)[:2]
        spread_f, spread_p = np.maximum(spread_f, np.abs(f2 - f64)), np.maximum(spread_p, np.abs(p2 - p64))
    h = lo + li
    cond = d_conditioning(packed, h / np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-30))
    tol_f = 4 * spread_f + 16 * U * np.abs(f64) + cond[:, None] * np.abs(cf) + 1e-7
    tol_p = 4 * spread_p + 16 * U * np.abs(p64) + cond * np.abs(cp) + 1e-7
    return f64, p64, tol_f, tol_p


def test_tables_match_mitsuba():
    """rough_transmittance.table and internal_reflectance against Mitsuba 3.9.1's own values, read back from the
    plugin (tests/data/roughplastic_mitsuba_tables.npz; devtools/peers/mitsuba_roughplastic_tables.py and the
    .json beside it say how): 19 cases, GGX and Beckmann, alpha 1e-3 to 1, eta 1.49, 2.4, 1.1 and below 1
    (0.714, 0.952). Mitsuba sums the rule's terms in float32 (32^2 of them where eta > 1, 128^2 below), a walk
    of roundings of about sqrt(terms) ULP of the sum, plus the eval it is read back through (float32, some
    tens of operations): 4e-6 absolute where eta > 1 (seen: 1.6e-6), 1e-4 below (seen: 3.8e-5; 16384 terms),
    3e-6 for R_int (seen: 1.1e-6). One Newton step for Beckmann's three in the sampler the quadrature follows
    (t off by 5e-5 at alpha 0.1), and the integral 2 int mu R dmu (trapezoid rule) in place of Mitsuba's mean
    for R_int, both fail it (tried on a copy of rough_transmittance.py)."""
    z = np.load(ROOT / "tests" / "data" / "roughplastic_mitsuba_tables.npz")
    mu = np.maximum(np.float32(1e-6), np.linspace(0, 1, 64, dtype=np.float32))
    x = mu * np.float32(63)  # the plugin's lerp_gather at mu, as the values were read
    i = np.minimum(x.astype(int), 62)
    for row in range(len(z["alpha"])):
        m = Material(name="m", colour=np.ones(3), bsdf="roughplastic", distribution=str(z["distribution"][row]),
                     alpha=float(z["alpha"][row]), int_ior=float(z["int_ior"][row]), ext_ior=float(z["ext_ior"][row]))
        t = rough_transmittance.table(m).astype(float)
        assert t.shape == (64,) and t.dtype == np.float64
        looked = t[i] + (t[i + 1] - t[i]) * (x - i)
        eta = m.int_ior / m.ext_ior
        np.testing.assert_allclose(looked, z["transmittance"][row], rtol=0, atol=4e-6 if eta > 1 else 1e-4,
                                   err_msg=str(row))
        assert abs(rough_transmittance.internal_reflectance(m) - z["r_int"][row]) < 3e-6, row


@pytest.mark.parametrize("lanes, defines", [(n, DEFINES) for n in runnable_lane_widths()]
                         + [(n, ANISOTROPIC) for n in LANE_ENDS],
                         ids=[f"{lane_id(n)}-isotropic" for n in runnable_lane_widths()]
                         + [f"{lane_id(n)}-anisotropic" for n in LANE_ENDS])
def test_eval_and_pdf_against_reference(harness, defines):
    """eval (f cos_i, RGB) and pdf of the kernel against the float64 reference above, on 4096 lanes mixing the
    eight MATERIALS lane by lane (the table's gather per lane, GGX and Beckmann lanes in one packet), at random
    normals, with 1/8 of wo and of wi below the horizon (0 expected) and 1/8 of wi within 2e-3 of wo's mirror
    direction (the peak of alpha 1e-3's lobe), at every lane width, in an isotropic build and in one with
    anisotropy compiled in (microfacet.cl's D and G1 from h's x and y). The kernel runs on float32 inputs;
    the reference takes the same ones. Each value within eval_tolerance (the float64 value's condition at the
    inputs, 16 roundings, and an isotropic build's unavoidable error in D near a narrow lobe's peak): a bound
    on a correct float32 kernel's error with room (4 times the measured condition), which fails a correct
    kernel only where its first-order model is wrong. Measured: the largest error is 0.21 of its tolerance in
    the isotropic build (the same bits at widths 1, 4, 8, 16), 0.31 in the anisotropic one; the largest
    relative error of values above 1e-3 is 0.78 in the isotropic build (alpha 1e-3, wi 2e-3 from the mirror
    direction: D's cancellation, within its conditioning term) and 1.1e-4 in the anisotropic one. It fails
    (each tried): the base without 1 / eta^2, the table read one entry up, the pdf's lobe choice from t(cos_i)
    instead of t(cos_o), and the pdf without G1(wo)."""
    rng = np.random.default_rng(1)
    mats, packed = materials()
    n, wo, wi, which, u = random_case(rng, 4096, len(mats))
    out = run(harness, packed, which, n, wo, wi, u, defines)
    fr = frame(n)
    lo, li = local(fr, wo), local(fr, wi)
    ref_f, ref_p, tol_f, tol_p = np.zeros((len(n), 3)), np.zeros(len(n)), np.zeros((len(n), 3)), np.zeros(len(n))
    for j in range(len(mats)):
        s = which == j
        ref_f[s], ref_p[s], tol_f[s], tol_p[s] = eval_tolerance(packed[j], lo[s], li[s], rng)
    err_f, err_p = np.abs(out["f"] - ref_f), np.abs(out["pdf"] - ref_p)
    ex_f, ex_p = np.max(err_f / tol_f, axis=1), err_p / tol_p
    assert np.all(ex_f <= 1), (np.max(ex_f), np.argmax(ex_f), which[np.argmax(ex_f)])
    assert np.all(ex_p <= 1), (np.max(ex_p), np.argmax(ex_p), which[np.argmax(ex_p)])
    below = (lo[:, 2] <= 0) | (li[:, 2] <= 0)
    assert below.sum() > 500 and np.all(out["f"][below] == 0) and np.all(out["pdf"][below] == 0)


def test_sample_weight_is_eval_over_pdf_and_reciprocity(harness):
    """bsdf_sample's weight is bsdf_eval / bsdf_pdf at the direction it drew, and its pdf bsdf_pdf's, within
    float32 rounding (1e-5 relative: a division and the same terms); samples below the horizon have pdf 0 and
    weight 0. Reciprocity: f = eval / cos_i is symmetric in (wo, wi) (F D G1 G1 / (4 cos_o cos_i) and the base's
    t t / (pi eta^2) both are): eval(wo, wi) cos_o == eval(wi, wo) cos_i within 2e-4 relative plus 1e-6 (the
    two evaluations round the half vector's terms differently; the lobe's condition is excluded by taking
    alpha >= 0.05 directions away from the mirror). Every lane width. Measured: the weight within 1.1e-7 of
    eval / pdf relatively, reciprocity within 5.6e-6. A weight 0.1% off eval / pdf fails it, and so does the
    base's t(cos_o) t(cos_o) for t(cos_o) t(cos_i) (reciprocity; each tried)."""
    rng = np.random.default_rng(2)
    rows = [r for r in MATERIALS if r[0] >= 0.05]
    mats, packed = materials(rows)
    n, wo, wi, which, u = random_case(rng, 2048, len(mats))
    out = run(harness, packed, which, n, wo, wi, u)
    valid = out["s_pdf"] > 0
    assert valid.mean() > 0.6
    np.testing.assert_allclose(out["s_pdf"][valid], out["s_eval_pdf"][valid], rtol=1e-5)
    np.testing.assert_allclose(out["s_weight"][valid] * out["s_pdf"][valid, None], out["s_f"][valid],
                               rtol=1e-5, atol=1e-7)
    assert np.all(out["s_weight"][~valid] == 0)
    back = run(harness, packed, which, n, wi, wo, u)
    co, ci = np.sum(wo * n, axis=1), np.sum(wi * n, axis=1)
    mirror = np.sum((2 * co[:, None] * n - wo) * wi, axis=1) > 0.999
    keep = (co > 0) & (ci > 0) & ~mirror
    a, b = out["f"][keep] * co[keep, None], back["f"][keep] * ci[keep, None]
    np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6)


_DENSITIES = {}  # the reference's pdf on the quadrature grid, per case: each lane width's test reads it


@at_lane_ends
@pytest.mark.parametrize("row, theta_o", [(0, 0.4), (2, 1.2), (3, 0.9), (5, 0.7)])
def test_sampling_chi_square(harness, row, theta_o):
    """bsdf_sample's directions from one wo against bsdf_pdf's density (the reference's, which
    test_eval_and_pdf_against_reference matches to the kernel's): Pearson's chi-square over 16 x 32 cells of
    the sphere (devtools/chi_square.py), 2^17 samples (every cell the lobes reach expects hundreds). Samples
    the kernel rejects (a glossy reflection below the horizon: pdf 0) are left out and the density
    renormalised over the hemisphere, as the rejected share is the density's missing mass (their share is
    checked against it, to 5 binomial standard errors plus 1e-3, the quadrature's error of the mass). 4 cases
    at 2 lane widths at significance 1e-4: a correct sampler fails once in 1250 runs. Cases: GGX alpha 0.3
    near the normal, GGX alpha 0.05 (narrow lobe) at eta 2.4 at 69 degrees, GGX alpha 1 inside a denser
    medium (eta 0.71), Beckmann alpha 0.1 (Jakob's sampler). Measured p: 0.16, 0.080, 0.63, 0.61, the same at
    widths 1 and 16. It fails (each tried): the lobe chosen with the specular weight alone (t(cos_o)
    ignored), the normals sampled at 1.25 alpha, and Beckmann's lanes sampled by GGX's sampler."""
    mats, packed = materials()
    m = 1 << 17
    rng = np.random.default_rng(7 + row)
    nrm = np.tile([0.0, 0.0, 1.0], (m, 1))
    wo = np.tile([np.sin(theta_o), 0.0, np.cos(theta_o)], (m, 1))
    out = run(harness, packed, np.full(m, row), nrm, wo, wo, rng.uniform(size=(m, 3)))
    valid = out["s_pdf"] > 0
    wo1 = f32(wo[:1])

    def density(c, phi):  # on chi_square's quadrature grid, the same at each call: computed once a case
        key = (row, theta_o, c.shape)
        if key not in _DENSITIES:
            s = np.sqrt(np.maximum(0, 1 - c * c))
            w = np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1).reshape(-1, 3)
            _DENSITIES[key] = reference(packed[row], np.repeat(wo1, len(w), axis=0), w)[1].reshape(c.shape)
        return _DENSITIES[key]

    mass = cell_integrals(density, np.linspace(-1, 1, 17), np.linspace(0, 2 * np.pi, 33)).sum()
    p, stat, total = chi_square(out["s_wi"][valid], lambda c, phi: density(c, phi) / mass)
    assert abs(valid.mean() - mass) <= 5 * np.sqrt(mass * (1 - mass) / m) + 1e-3, (valid.mean(), mass)
    assert p > SIGNIFICANCE, (p, stat, total)


@at_lane_ends
@pytest.mark.parametrize("row", [0, 1, 3, 7])
def test_white_furnace(harness, row):
    """The albedo, the mean of bsdf_sample's weight over samples from one wo (white base and coat, linear), is at
    most 1: the model loses the light masked by the coat's microfacets (Mitsuba's roughplastic is not energy
    conserving, as its separable G2 and single-scattering coat are not) and never creates it. Estimated at 8
    angles from 0 to 85 degrees with 2^14 samples each; the bound allows 5 standard errors of the mean. Where
    alpha >= 0.3 the mean is also checked against the float64 reference's integral of eval (midpoint rule on
    256 x 128 cells of the hemisphere) within 5 standard errors plus 2e-3 (the rule's error at the glossy
    peak; alpha 1e-3's lobe is narrower than a cell, so there only the bound holds). Cases: GGX alpha 0.3,
    1e-3, 1 (eta 0.71) and Beckmann alpha 0.5 (eta 0.75). Measured means: 0.63-0.69, 0.976-0.989,
    0.29-0.41, 0.71-0.97, the same at widths 1 and 16. The base without 1 / (1 - R_int) fails it at alpha
    0.3 and Beckmann 0.5 (tried)."""
    a, ni, ne, _, _, _, dist = MATERIALS[row]
    mats, packed = materials([(a, ni, ne, (1.0, 1.0, 1.0), (1.0, 1.0, 1.0), False, dist)])
    m = 1 << 14
    rng = np.random.default_rng(3 + row)
    means = []
    for theta_o in np.radians([0, 15, 30, 45, 60, 70, 80, 85]):
        nrm = np.tile([0.0, 0.0, 1.0], (m, 1))
        wo = np.tile([np.sin(theta_o), 0.0, np.cos(theta_o)], (m, 1))
        w = run(harness, packed, np.zeros(m, int), nrm, wo, wo, rng.uniform(size=(m, 3)))["s_weight"][:, 0]
        mean, se = w.mean(), w.std(ddof=1) / np.sqrt(m)
        means.append(mean)
        assert mean <= 1 + 5 * se, (theta_o, mean, se)
        if a >= 0.3:
            c = (np.arange(256) + 0.5) / 256
            phi = (np.arange(128) + 0.5) / 128 * np.pi
            cc, pp = np.meshgrid(c, phi, indexing="ij")
            s = np.sqrt(1 - cc * cc)
            wi = np.stack([s * np.cos(pp), s * np.sin(pp), cc], axis=-1).reshape(-1, 3)
            f = reference(packed[0], np.repeat(f32(wo[:1]), len(wi), axis=0), wi)[0][:, 0]
            albedo = 2 * np.sum(f) * (1 / 256) * (np.pi / 128)  # eval holds cos_i; d(omega) = d(cos) d(phi)
            assert abs(mean - albedo) <= 5 * se + 2e-3, (theta_o, mean, se, albedo)
    assert max(means) < 1


@at_lane_ends
def test_peak_of_a_lobe_below_float32_s_resolution(harness):
    """GGX of alpha below 1.7e-4 (the fuzz suite's find: a roughplastic of alpha 1e-4, Mitsuba's clamp, or
    anything below it rendered NaN): at its peak, h = n, the isotropic D = alpha^2 / (pi (c (alpha^2 - 1) + 1)^2)
    of c = cos^2(theta_h) = 1 took alpha^2 - 1 = -1 in float32 (alpha^2 < 2^-25), hence alpha^2 / 0 = inf, and
    the sample's weight inf / inf. Now D's denominator is c alpha^2 + (1 - c) with c <= 1: at most 1 / (pi
    alpha^2), 3.2e7 at the clamp. With wi the mirror image of wo about random normals (float32 rounding puts n . h
    at 1 and above it) and samples from the same wo, at alphas 1e-30 (clamped to 1e-4), 1e-4, 1.5e-4 and 2^-11
    (whose alpha^2 met c - 1 = 2^-22 at n . h one ulp above 1: D's denominator 2^-44), both lane ends: eval,
    pdf and the samples' weights finite and the pdfs positive; eval at most the float64 reference's at the exact
    peak (h = n in the local frame, D = 1 / (pi alpha^2)) within 1e-3 relatively (a few float32 roundings), and
    within it on at least a tenth of the lanes (where float32's cos(theta_h) rounds to 1). Nothing finer: such a
    lobe is narrower than float32's cos(theta_h) resolves (d_conditioning; 1 - c is off by some 1e-7, alpha^2
    1e-8), so off the exact peak the kernel's D is float32's guess. It failed before the fix (inf eval, NaN
    weights; the peak's value at alpha 2^-11 was 2.3e19 / pi)."""
    rows = [(a, 1.49, 1.000277, (0.5, 0.5, 0.5), (1.0, 1.0, 1.0), False, "ggx") for a in (1e-30, 1e-4, 1.5e-4, 2**-11)]
    mats, packed = materials(rows)
    rng = np.random.default_rng(11)
    m = 2048
    n, wo = map(f32, bsdf_support.facing(rng, m))
    wi = f32(2 * np.sum(wo * n, axis=1)[:, None] * n - wo)
    which = np.arange(m) % len(rows)
    out = run(harness, packed, which, n, wo, wi, rng.uniform(size=(m, 3)))
    for key in ("f", "pdf", "s_weight", "s_pdf", "s_f"):
        assert np.all(np.isfinite(out[key])), (key, np.argwhere(~np.isfinite(out[key]))[:4])
    fr = frame(n)
    lo = local(fr, wo)
    peak = lo * [-1.0, -1.0, 1.0]  # wo's mirror image about the local z exactly
    for j in range(len(rows)):
        s = which == j
        top = reference(packed[j], lo[s], peak[s])[0]
        ratio = out["f"][s] / top
        assert np.all(ratio <= 1 + 1e-3), (rows[j][0], ratio.max())
        assert np.mean(ratio >= 1 - 1e-3) > 0.1, (rows[j][0], np.mean(ratio >= 1 - 1e-3))
    assert np.all(out["s_pdf"] > 0)
