"""The thin principled BSDF (type = "principledthin", kernels/bsdfs/principledthin.cl: Mitsuba 3's `principledthin`)
and its host terms (raytrace/scene/principled_terms.py): the float64 reference (tests/principledthin_reference.py)
against Mitsuba 3.9.1's own eval, pdf and samples, the host's terms against the reference's, the kernel's eval and
pdf against the reference at every lane width, its samples' directions by chi-square against that pdf, their
weights against eval / pdf, the albedo of each lobe (a white furnace), the reflection's reciprocity, and the
scene file's, the Mitsuba loader's and writer's side. Every test runs on fixed inputs and seeds: each passes or
fails deterministically. The helpers shared with principled's tests (the random cases, the float32 conditioning
of GGX's D and of Fresnel's term) are tests/principled_support.py's, shared with tests/test_bsdf_principled.py."""
import numpy as np
import pytest

from raytrace import structs
from raytrace.renderer.packing import material_structs
from raytrace.scene import principled_terms
from raytrace.scene.model import Material

import bsdf_support
import principledthin_reference as tr
from devtools.peers import mitsuba_bsdf
from helpers import LANE_ENDS, ROOT, at_lane_ends, lane_id, runnable_lane_widths
from principled_support import (U, check_against_reference, check_chi_square, check_reciprocity,
                               check_sample_weights, d_conditioning, eval_case, f32, fresnel_conditioning, furnace_means,
                               mitsuba_worst, random_case, xml_round_trip)

DEFINES = dict(HAS_PATH_TRACING=1, HAS_PRINCIPLEDTHIN=1, HAS_RECTANGLES=1)
ANISOTROPIC = dict(DEFINES, HAS_ANISOTROPIC=1)  # a scene with anisotropic != 0: the tangent's frame
OUTPUTS = ("f", "pdf", "s_wi", "s_weight", "s_pdf", "s_f", "s_eval_pdf", "s_transmit")
RED, BLUE, GREEN, WHITE = (0.8, 0.2, 0.1), (0.2, 0.5, 0.8), (0.3, 0.6, 0.2), (1.0, 1.0, 1.0)

# Materials by Mitsuba's names (base_color and eta are principledthin_reference's; the rest model.Material's fields
# of those names). The extremes: roughness 0 (both lobes' alpha at Mitsuba's clamp 1e-3) and 1, spec_trans 1,
# diff_trans 2 (all the diffuse light transmitted), flatness 1, eta below 1 (total internal reflection of the
# Fresnel term: no transmission beyond the critical angle; and (0.65 eta - 0.35) roughness the smaller), eta 1
# (F = 0: no reflection), anisotropic 1 (alpha_u / alpha_v = 1 / 0.1), the sampling rates at 2^-10 and 2^10.
MATERIALS = [
    dict(base_color=(0.5, 0.5, 0.5)),                                                        # 0 Mitsuba's defaults
    dict(base_color=RED, roughness=1.0, sheen=1.0, sheen_tint=0.7, flatness=0.6),            # 1 diffuse, sheen
    dict(base_color=GREEN, roughness=0.4, diff_trans=1.0),                                   # 2 leaf
    dict(base_color=GREEN, diff_trans=2.0, flatness=1.0),                                    # 3 all through
    dict(base_color=(0.9, 0.9, 0.8), roughness=0.3, spec_trans=1.0, eta=1.5),                # 4 frosted pane
    dict(base_color=BLUE, roughness=0.5, spec_trans=0.7, eta=0.8, spec_tint=0.5),            # 5 eta < 1
    dict(base_color=RED, roughness=0.0, spec_trans=0.4, eta=2.0),                            # 6 roughness 0
    dict(base_color=GREEN, roughness=0.35, spec_trans=0.8, eta=1.0, diff_trans=0.5),         # 7 eta 1: F = 0
    dict(base_color=BLUE, roughness=0.7, spec_trans=0.4, eta=1.45, spec_tint=0.3, sheen=0.6,  # 8 everything
         sheen_tint=0.4, flatness=0.5, diff_trans=1.3, diffuse_reflectance_sampling_rate=2.0,
         specular_reflectance_sampling_rate=2.0**-10, specular_transmittance_sampling_rate=1024.0,
         diffuse_transmittance_sampling_rate=0.25),
    dict(base_color=RED, roughness=0.6, anisotropic=0.8, spec_trans=0.5, eta=1.33, diff_trans=0.6),  # 9 aniso
    dict(base_color=(0.9, 0.9, 0.9), roughness=0.25, anisotropic=1.0, spec_trans=1.0, eta=1.5),      # 10 aniso pane
]
ISOTROPIC = [i for i, m in enumerate(MATERIALS) if not m.get("anisotropic")]


def model(row, name="m"):
    """The model.Material of a row of MATERIALS."""
    fields = {("principled_eta" if k == "eta" else k): v for k, v in row.items() if k != "base_color"}
    return Material(name=name, colour=np.array(row["base_color"], float), bsdf="principledthin", **fields)


def packed(rows=MATERIALS):
    return material_structs([model(row, f"m{i}") for i, row in enumerate(rows)])


def reference_material(row, entry=None):
    """principledthin_reference's material of a row; with its packed entry, the float32 alphas the kernel reads,
    which test_host_terms_match_reference checks against the reference's own."""
    p = tr.material(**row)
    if entry is not None:
        p["alpha_u"], p["alpha_v"] = float(entry["alpha"]), float(entry["alpha_v"])
        p["trans_alpha_u"], p["trans_alpha_v"] = (float(entry["principled"][structs.PRINCIPLED.index(name)])
                                                  for name in ("trans_alpha_u", "trans_alpha_v"))
    return p


def frames(n, t):
    """Each lane's local frame as the kernel takes it (rows x, y, z): z the normal n (a sheet has no inside; the
    reference turns both directions to the viewer's side itself), x the tangent t."""
    return np.stack([t, np.cross(n, t), n], axis=1)


def half_vector(lo, li):
    """The reference's half vector of wo and wi mirrored to wo's side (for the conditioning)."""
    s = np.where(lo[:, 2] < 0, -1.0, 1.0)[:, None]
    o, i = lo * s, li * s
    h = o + np.concatenate([i[:, :2], np.abs(i[:, 2:])], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(h / np.linalg.norm(h, axis=1, keepdims=True)), o


def tolerance(p, lo, li, rng, anisotropic, draws=4):
    """The reference's (f, pdf) at the float32 inputs and their tolerances, principled's (tests/test_bsdf_principled.py):
        tol = 4 spread + 64 U |r64| + conditioning (|reflection's part|, |transmission's|; |pdf|) + 1e-6,
    spread the largest change of the float64 value over `draws` inputs within 4 U of these (the value's condition:
    a narrow lobe's peak, the half vector near grazing; the kernel takes world directions, its local coordinates
    off by some U), 64 U the roundings of a chain of some tens of float32 operations, the isotropic build's GGX D
    conditioning (D from cos(theta_h) alone: 4 at alpha 1e-3's peak) of each glossy lobe on its value and on
    the pdf, the Fresnel term's near eta = 1 on the reflection (and the pdf), and 1e-6 absolutely (values below it
    count for nothing beside the lobes' peaks of 1e2 to 1e5)."""
    f, pdf, lobes = tr.eval_pdf(p, lo, li)
    spread_f, spread_p = np.zeros_like(f), np.zeros_like(pdf)
    for _ in range(draws):
        o, i = (w + 4 * U * rng.uniform(-1, 1, w.shape) for w in (lo, li))
        f2, p2, _ = tr.eval_pdf(p, o, i)
        spread_f, spread_p = np.maximum(spread_f, np.abs(f2 - f)), np.maximum(spread_p, np.abs(p2 - pdf))
    h, o = half_vector(lo, li)
    cond_r = d_conditioning(p, h, anisotropic)
    cond_t = d_conditioning(dict(p, alpha_u=p["trans_alpha_u"]), h, anisotropic)
    cond_f = fresnel_conditioning(p, o, h)
    tol_f = (4 * spread_f + 64 * U * np.abs(f) + (cond_r + cond_f)[:, None] * lobes["reflection"]
             + (cond_t + cond_f)[:, None] * lobes["transmission"] + 1e-6)
    tol_p = 4 * spread_p + 64 * U * np.abs(pdf) + (cond_r + cond_t + cond_f) * np.abs(pdf) + 1e-6
    return f, pdf, tol_f, tol_p


def run(harness, table, which, n, t, wo, wi, u, defines=DEFINES, outputs=OUTPUTS, backface=None):
    return bsdf_support.run(harness, table, n, wo, wi, u, outputs, which=which, tangent=t,
                            backface=np.zeros(len(n), np.int32) if backface is None else backface, **defines)


def test_reference_matches_mitsuba():
    """principledthin_reference's eval and pdf against Mitsuba 3.9.1's own
    (tests/data/mitsuba_principledthin_values.npz, recorded by devtools/peers/mitsuba_principled.py --thin: 10
    cases, 256 points each, wo and wi uniform on the sphere) and at the directions Mitsuba's sampler drew (its pdf
    there and its weight, eval / pdf), within the reference's own tolerance (tolerance() above, without an
    isotropic build's term: Mitsuba's D takes m's x and y): Mitsuba computes in float32, the reference's condition
    at its inputs bounds what that costs. A sample Mitsuba refuses (a glossy one on the wrong side, or against
    mac_mic_compatibility) has weight 0, though its pdf there may be the other lobes': those are left out.
    Measured: the largest error is 0.044 of its tolerance, the largest relative error of values above 1e-3 1.1e-6
    (eval, pdf, the samples' pdf) and 1.7e-5 (the weights: quotients). Deterministic (fixed inputs and seeds). It fails (each
    tried on the reference): the transmission's roughness not scaled by 0.65 eta - 0.35, the transmission's
    colour sqrt(k) (principled's) for k, the half vector of wo itself rather than of wo mirrored, flatness's
    Fss90 = Rr for Rr / 2, and diff_trans not halved."""
    cases = mitsuba_bsdf.load(ROOT / "tests" / "data" / "mitsuba_principledthin_values.npz")
    assert len(cases) == 10
    # kept_share 0.7: at eta 0.8 a transmission beyond the critical angle has weight 0 (24% of that case's samples)
    worst = mitsuba_worst(cases, tr.material, tolerance, np.random.default_rng(7), kept_share=0.7)
    assert worst > 0.005  # the tolerance is not so loose that nothing comes near it


def test_host_terms_match_reference():
    """principled_terms (the host's float32 eta, the reflection's alphas and the transmission's, Mitsuba's
    arithmetic) against the reference's float64 within 1e-6 relatively (a few float32 roundings), and the packed
    values in types.h's PRINCIPLED_* order (principledthin's rates in principled's slots and its own)."""
    table = packed()
    for row, entry in zip(MATERIALS, table):
        p = tr.material(**row)
        m = model(row)
        assert principled_terms.eta(m) == pytest.approx(p["eta"], rel=1e-7)
        got = principled_terms.alphas(m) + principled_terms.transmission_alphas(m)
        want = (p["alpha_u"], p["alpha_v"], p["trans_alpha_u"], p["trans_alpha_v"])
        np.testing.assert_allclose(got, want, rtol=1e-6)
        want = [p["roughness"], 0, p["spec_tint"], p["sheen"], p["sheen_tint"], 0, 0, p["spec_trans"],
                p["specular_reflectance_sampling_rate"], 0, p["diffuse_reflectance_sampling_rate"], p["anisotropic"], 0,
                p["flatness"],
                p["diff_trans"] / 2, p["trans_alpha_u"], p["trans_alpha_v"], p["specular_transmittance_sampling_rate"],
                p["diffuse_transmittance_sampling_rate"]]
        np.testing.assert_allclose(entry["principled"], want, rtol=1e-6)
        assert entry["bsdf"] == structs.BSDFS["principledthin"] and entry["distribution"] == 0
        assert entry["eta"][0] == np.float32(p["eta"])
    assert principled_terms.eta(Material(name="m", colour=np.ones(3), bsdf="principledthin")) == 1.5  # Mitsuba's default


EVAL_DATA = {}


def lanes_of(anisotropic):
    """The eval test's lanes (4096; isotropic materials only in the isotropic build), their references and
    tolerances (principled_support.eval_case), computed once for every lane width."""
    table = packed()
    return eval_case(EVAL_DATA, anisotropic, 31, list(range(len(MATERIALS))) if anisotropic else ISOTROPIC, table,
                     [reference_material(row, entry) for row, entry in zip(MATERIALS, table)],
                     lambda n, t, backface, which: frames(n, t), tolerance)


@pytest.mark.parametrize("lanes, anisotropic", [(n, False) for n in runnable_lane_widths()]
                         + [(n, True) for n in LANE_ENDS],
                         ids=[f"{lane_id(n)}-isotropic" for n in runnable_lane_widths()]
                         + [f"{lane_id(n)}-anisotropic" for n in LANE_ENDS])
def test_eval_and_pdf_against_reference(harness, anisotropic):
    """eval (f cos_i, RGB) and pdf of the kernel against the float64 reference, on 4096 lanes mixing the materials
    lane by lane (the isotropic ones in the isotropic build, all eleven in the anisotropic one), at random normals
    and tangents, 1/8 of the viewers below the normal (the sheet's other side), wi uniform or within 2e-3 of wo's
    mirror and refracted directions. Every lane width in the isotropic build, both lane ends in the anisotropic
    one. Each value within tolerance() (the reference's condition at the float32 inputs, 64 roundings, an
    isotropic build's D near roughness 0's peak): a bound on a correct float32 kernel's error that fails one only
    where its first-order model is wrong. Deterministic (fixed seeds). Measured: the largest error is 0.12 (eval)
    and 0.10 (pdf) of its tolerance in the isotropic build (the same at widths 1, 4, 8, 16), 0.12 and 0.17 in the
    anisotropic one; the largest relative error of values above 1e-3 is 0.20 in the isotropic build (roughness
    0's alpha 1e-3 lobe near its peak: D from cos(theta_h) alone, within its conditioning term), 4e-4 (eval) and
    2.3e-3 (pdf) in the anisotropic one. It fails
    (each tried on the kernel): the transmission of the reflection's alphas, the transmission's colour sqrt(k),
    the flatness lerp's weight 1 - flatness, the diffuse transmission without its 1 / pi, the sheen without
    (1 - diff_trans / 2), the viewer below the normal not turned over (no mulsign), and the tint's Schlick
    weight of the cosine's complement squared (principled_schlick_weight(oh)^2)."""
    table, (n, t, _, wo, wi, which, u), (ref_f, ref_p, tol_f, tol_p), lo, li = lanes_of(anisotropic)
    out = run(harness, table, which, n, t, wo, wi, u, ANISOTROPIC if anisotropic else DEFINES, ("f", "pdf"))
    check_against_reference(out, ref_f, ref_p, tol_f, tol_p, which, lo, li)


@pytest.mark.parametrize("lanes", runnable_lane_widths(), ids=lane_id)
def test_sample_weight_is_eval_over_pdf(harness):
    """bsdf_sample's weight is bsdf_eval / bsdf_pdf at the direction it drew, and its pdf bsdf_pdf's, within
    float32 rounding (2e-5 relatively: a division and the same terms, plus 1e-7); a refused sample (a glossy one
    on the wrong side of the sheet or against mac_mic_compatibility) has pdf and weight 0; transmit is set
    exactly where wi crosses the surface, and only then; a quarter of the hits flagged backface change nothing (a
    sheet has no inside). Every material (anisotropic build), every lane width, 4096 lanes. Measured: the weight
    within 1.1e-7 of eval / pdf relatively, 97.8% of the samples valid. A weight 0.1% off eval / pdf fails it
    (tried)."""
    rng = np.random.default_rng(3)
    table = packed()
    n, t, backface, wo, wi, which, u = random_case(rng, 4096, list(range(len(MATERIALS))))
    out = run(harness, table, which, n, t, wo, wi, u, ANISOTROPIC, backface=backface)
    check_sample_weights(out, n, wo, valid_share=0.9, transmitted=500)


@pytest.mark.parametrize("lanes", LANE_ENDS, ids=lane_id)
def test_reflection_is_reciprocal(harness):
    """f = eval / cos_i of the reflection (wo and wi on the normal's side) is symmetric in (wo, wi): the glossy
    reflection's F(wo . h) D G / (4 cos_o cos_i), the diffuse's and flatness's (symmetric in Fo and Fi, and in
    |cos_o| + |cos_i|) and the sheen's Fw(wi . h) with wi . h = wo . h: eval(wo, wi) cos_o == eval(wi, wo) cos_i
    within 2e-4 relatively plus 1e-6, away from the mirror direction (cosine 0.999: the narrow lobes' condition
    there), every material, the anisotropic build, both lane ends. (The glossy transmission is not reciprocal:
    Mitsuba's mac_mic_compatibility of wi mirrored is not symmetric in the two directions.) Measured: within
    3.1e-4 relatively of values above 1e-6 (a narrow lobe's flank, inside the 1e-6 absolute term). The flatness's 1 / (|cos_o| + |cos_i|) taken as 1 / (2 |cos_o|)
    fails it (tried)."""
    rng = np.random.default_rng(13)
    table = packed()
    n, t, _, wo, wi, which, u = random_case(rng, 4096, list(range(len(MATERIALS))))
    out = run(harness, table, which, n, t, wo, wi, u, ANISOTROPIC, ("f", "f_swapped"))
    check_reciprocity(out, n, wo, wi)


# (row, theta_o, viewer below the normal) of the chi-square test: the defaults, the diffuse with sheen and
# flatness, the leaf (diff_trans 1), all transmitted (diff_trans 2), the frosted pane (spec_trans 1), eta 0.8 from
# below the normal, eta 1 with every lobe, the rates at their edges, and the anisotropic mix. Not roughness 0: the
# quadrature of 16 x 32 cells misses an alpha 1e-3 lobe's mass by 2% (the eval test covers it).
CHI_CASES = [(0, 0.4, 0), (1, 1.2, 0), (2, 0.7, 0), (3, 0.5, 0), (4, 0.6, 0), (5, 0.9, 1), (7, 1.0, 0),
             (8, 0.8, 0), (9, 1.1, 0)]
_DENSITIES = {}


@at_lane_ends
@pytest.mark.parametrize("row, theta_o, below", CHI_CASES)
def test_sampling_chi_square(harness, row, theta_o, below):
    """bsdf_sample's directions from one wo against the reference's pdf (which the eval test matches to the
    kernel's): Pearson's chi-square over 16 x 32 cells of the sphere (devtools/chi_square.py), 2^17 samples. The
    samples the kernel refuses (pdf 0: a glossy one on the wrong side or against mac_mic_compatibility) are left
    out and the density renormalised over the rest, its mass the share kept (checked to 5 binomial standard errors
    plus 2e-3, the quadrature's error of the mass): the density counts no refused direction, so the kept ones are
    distributed as it. The normal is z, the tangent x, wo in the xz-plane (the anisotropic case at azimuth 0.6
    rad), below the normal where `below`. 9 cases at 2 lane widths at significance 1e-4: with fresh random numbers
    a correct sampler would fail one run in 555 (1 - (1 - 1e-4)^18); with the fixed seeds here the run is
    deterministic. Measured p (the same at widths 1 and 16): defaults 0.051, sheen 0.92, leaf 0.30, all through
    0.035, pane 0.32, eta 0.8 below 0.46, eta 1 0.0062, rates 0.44, anisotropic 0.28. It fails (each tried): the
    transmission sampled with the reflection's alphas, the diffuse transmission on the viewer's side (no minus),
    the lobe choice with half the glossy transmission's probability, and the diffuse transmission's share
    without its rate."""
    table = packed()
    m = 1 << 17
    rng = np.random.default_rng(41 + row)
    anisotropic = bool(MATERIALS[row].get("anisotropic"))
    phi_o = 0.6 if anisotropic else 0.0
    z = -1.0 if below else 1.0
    wo1 = np.array([[np.sin(theta_o) * np.cos(phi_o), np.sin(theta_o) * np.sin(phi_o), z * np.cos(theta_o)]])
    nrm, tan = np.tile([0.0, 0.0, 1.0], (m, 1)), np.tile([1.0, 0.0, 0.0], (m, 1))
    wo = np.repeat(f32(wo1), m, axis=0)
    out = run(harness, table, np.full(m, row), nrm, tan, wo, wo, rng.uniform(size=(m, 3)),
              ANISOTROPIC if anisotropic else DEFINES, ("s_wi", "s_pdf"))
    p = reference_material(MATERIALS[row], table[row])

    def density(c, phi):  # in the frame (z the normal): once a case
        key = (row, theta_o, below, c.shape)
        if key not in _DENSITIES:
            s = np.sqrt(np.maximum(0, 1 - c * c))
            w = np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1).reshape(-1, 3)
            lo = np.repeat(f32(wo1), len(w), axis=0)
            _DENSITIES[key] = tr.eval_pdf(p, lo, w)[1].reshape(c.shape)
        return _DENSITIES[key]

    check_chi_square(out, density)


# (name, row of white-based materials, the bound of its albedo (None: none)): each lobe alone where the model
# allows (eta 1: no glossy reflection, F = 0).
FURNACE = [("diffuse, roughness 0", dict(base_color=WHITE, roughness=0.0), 1.0),
           ("diffuse, roughness 1 (retro-reflection)", dict(base_color=WHITE, roughness=1.0), None),
           ("fake subsurface (flatness 1)", dict(base_color=WHITE, roughness=0.5, flatness=1.0), None),
           ("diffuse transmission (diff_trans 2)", dict(base_color=WHITE, diff_trans=2.0), 1.0),
           ("leaf (diff_trans 1, roughness 0)", dict(base_color=WHITE, roughness=0.0, diff_trans=1.0), 1.0),
           ("pane, roughness 0.3", dict(base_color=WHITE, spec_trans=1.0, roughness=0.3, eta=1.5), None),
           ("pane, roughness 0.6, eta 0.8", dict(base_color=WHITE, spec_trans=1.0, roughness=0.6, eta=0.8), None),
           ("transmission alone (eta 1)", dict(base_color=WHITE, spec_trans=1.0, roughness=0.4, eta=1.0), 1.0),
           ("sheen on black", dict(base_color=(0.0, 0.0, 0.0), roughness=0.0, sheen=1.0), 1.0)]


@at_lane_ends
@pytest.mark.parametrize("name, row, bound", FURNACE, ids=[f[0] for f in FURNACE])
def test_white_furnace(harness, name, row, bound):
    """Each lobe's albedo, the mean of bsdf_sample's weight over 2^15 samples from one wo, at 6 angles from 0 to 85
    degrees, against the float64 reference's integral of eval (f cos) over the sphere, estimated with the
    reference's own density as importance (the mean of the reference's eval / pdf at the kernel's sampled
    directions, which test_sampling_chi_square finds distributed as that pdf: an unbiased estimate of the
    integral wherever pdf > 0 covers the lobes) within 5 standard errors of the difference plus 1e-4 of it; and
    at most its bound (within 5 standard errors) where the lobe has one: Burley's diffuse at roughness 0 ((1 -
    Fo/2)(1 - Fi/2) <= 1), the Lambertian transmission (1 exactly: its 1 / pi cos integrates to 1), the leaf (the
    two shares of them), the glossy transmission alone at eta 1 (F = 0: its weight is 2 G1(wi) on the half of
    the samples that choose it, G1 <= 1; no refraction, so no 1 / eta^2), and the sheen (Fw <= 1, alone on a
    black base) each 1. Unbounded: the retro-reflection at roughness 1 (Burley's diffuse gains energy towards
    grazing angles), the fake subsurface (Hanrahan-Krueger's 1 / (cos_o + cos_i) grows towards grazing), and the
    pane's reflection and transmission, whose F and 1 - F are taken over lobes of different roughness (the
    transmission's (0.65 eta - 0.35) roughness): at eta 0.8 the wider reflection meets total internal
    reflection's F = 1 where the narrow transmission's 1 - F is near normal incidence's, and the sum passes 1.
    Measured albedos over the angles (the same at widths 1 and 16): diffuse 0.67-0.98, retro-reflective
    1.03-1.40, flatness 1 0.75-1.28, transmission 1.000, leaf 0.83-0.99, pane 0.75-1.00, pane eta 0.8
    0.35-1.07, transmission alone 0.97-1.003 (1 within its standard error, 0.0055), sheen 0.000-0.069.
    Deterministic (fixed seeds). The diffuse transmission with 1 / (2 pi) and the pane's
    transmission weighted F in place of 1 - F fail it (tried)."""
    table = material_structs([model(row)])
    p = reference_material(row, table[0])
    m = 1 << 15
    nrm, tan = np.tile([0.0, 0.0, 1.0], (m, 1)), np.tile([1.0, 0.0, 0.0], (m, 1))

    def sample(wo, u):
        return run(harness, table, np.zeros(m, int), nrm, tan, wo, wo, u, DEFINES, ("s_wi", "s_weight", "s_pdf"))

    furnace_means(sample, lambda wo, wi: tr.eval_pdf(p, wo, wi)[:2], bound, np.random.default_rng(29), m)


THIN_TOML = """
[materials.leaf]
type = "principledthin"
base_color = [0.3, 0.6, 0.2]
roughness = 0.45
anisotropic = 0.4
diff_trans = 1.2
flatness = 0.3
sheen = 0.2
diffuse_transmittance_sampling_rate = 2.0

[materials.pane]
type = "principledthin"
roughness = 0.2
spec_trans = 0.9
eta = 1.33
"""


def test_scene_file_mitsuba_xml_and_writer(tmp_path):
    """The host's side: principledthin materials in a TOML scene render with HAS_PRINCIPLEDTHIN (and
    HAS_ANISOTROPIC for anisotropic != 0), not HAS_PRINCIPLED; written as Mitsuba XML bare (Mitsuba's thin is
    two-sided, and its twosided refuses the diffuse transmission it always declares) and read back as the same
    model, bit for bit; a one-sided principledthin (two_sided = false) is refused, diff_trans above 2 and a
    sampling rate of 0 are refused, with their bounds. It fails (each tried): the writer wrapping it in
    twosided, and the Features leaving the anisotropic build off."""
    import raytrace
    from raytrace.errors import InputError
    from raytrace.renderer.program import Features
    from raytrace.scene.model import fingerprint
    shapes = "".join(f'\n[[shapes]]\ntype = "rectangle"\ncenter = [{x!r}, 0.3, 0.3]\nsize = [0.2, 0.2]\nnormal = [0.0, 0.0, 1.0]\ntangent = [1.0, 0.0, 0.0]\n'
                     f'material = "{name}"\n' for x, name in ((0.3, "leaf"), (0.6, "pane")))
    scene, back, text, toml = xml_round_trip(tmp_path, THIN_TOML + shapes)
    assert fingerprint(back.materials) == fingerprint(scene.materials)
    leaf = next(m for m in back.materials if m.name == "leaf")
    assert (leaf.bsdf, leaf.diff_trans, leaf.flatness, leaf.principled_eta, leaf.anisotropic) == (
        "principledthin", 1.2, 0.3, 1.5, 0.4)
    assert leaf.diffuse_transmittance_sampling_rate == 2.0
    assert '<bsdf type="principledthin" id="leaf">' in text and '<bsdf type="principledthin" id="pane">' in text
    options = Features.of(scene, 8).options()
    assert "-DHAS_PRINCIPLEDTHIN=1" in options and "-DHAS_ANISOTROPIC=1" in options
    assert "-DHAS_PRINCIPLED=0" in options
    for old, new, message in (("diff_trans = 1.2", "diff_trans = 2.5", "diff_trans = 2.5"),
                              ("eta = 1.33", "eta = 1.33\ntwo_sided = false", "two_sided"),
                              ("diffuse_transmittance_sampling_rate = 2.0", "diffuse_transmittance_sampling_rate = 0",
                               "diffuse_transmittance_sampling_rate = 0")):
        bad = tmp_path / "bad.toml"
        bad.write_text(toml.read_text().replace(old, new))
        with pytest.raises(InputError, match=message):
            raytrace.load_file(bad)
