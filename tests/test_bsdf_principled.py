"""The principled BSDF (type = "principled", kernels/bsdfs/principled.cl: Mitsuba 3's `principled`, Disney's model)
and its host terms (raytrace/scene/principled_terms.py): the float64 reference (tests/principled_reference.py)
against Mitsuba 3.9.1's own eval, pdf and samples, the host's terms against the reference's, the kernel's eval and
pdf against the reference at every lane width, its samples' directions by chi-square against that pdf, their
weights against eval / pdf, the albedo of each lobe (a white furnace), and the scene file's, the Mitsuba loader's
and writer's side, and the reflection's reciprocity (the transmission, in radiance mode, is not reciprocal).
Every test runs on fixed inputs and seeds: each passes or fails deterministically."""
import numpy as np
import pytest

import raytrace
from raytrace import structs
from raytrace.renderer.packing import material_structs
from raytrace.scene import principled_terms
from raytrace.scene.model import Material

import bsdf_support
import lookup_support as mts
import principled_reference as pr
from devtools.peers import mitsuba_bsdf
from helpers import LANE_ENDS, ROOT, at_lane_ends, lane_id, runnable_lane_widths
from principled_support import (U, check_against_reference, check_chi_square, check_reciprocity,
                               check_sample_weights, d_conditioning, eval_case, f32, fresnel_conditioning, furnace_means,
                               mitsuba_worst, random_case, xml_round_trip)

DEFINES = dict(HAS_PATH_TRACING=1, HAS_PRINCIPLED=1, HAS_RECTANGLES=1)
ANISOTROPIC = dict(DEFINES, HAS_ANISOTROPIC=1)  # a scene with anisotropic != 0: the tangent's frame
OUTPUTS = ("f", "pdf", "s_wi", "s_weight", "s_pdf", "s_f", "s_eval_pdf", "s_transmit")
RED, BLUE, WHITE = (0.8, 0.2, 0.1), (0.2, 0.5, 0.8), (1.0, 1.0, 1.0)

# Materials by Mitsuba's names (base_color, eta, specular are principled_reference's; the rest model.Material's
# fields of those names). The extremes: roughness 0 (the main lobe's alpha at Mitsuba's clamp 1e-3) and 1,
# metallic 1, spec_trans 1, eta below 1 (the inside denser than the outside) and eta 1 with transmission (Mitsuba
# takes it as 1.001), anisotropic 1 (alpha_u / alpha_v = 1 / 0.1), clearcoat_gloss 1 (GTR1 at 1e-3), sampling
# rates at their bounds' orders, specular 0 (eta 1: no dielectric reflection; a viewer below the normal then has
# no lobe at all, which once made the lobes' probabilities 0 / 0), flatness (Hanrahan-Krueger's fake subsurface)
# whole on a rough diffuse base, and partial among the other lobes with an inside.
MATERIALS = [
    dict(base_color=(0.5, 0.5, 0.5)),                                                       # 0 Mitsuba's defaults
    dict(base_color=RED, roughness=1.0, sheen=1.0, sheen_tint=0.7),                         # 1 diffuse, sheen
    dict(base_color=(0.95, 0.64, 0.54), metallic=1.0, roughness=0.2),                       # 2 metal
    dict(base_color=BLUE, roughness=0.15, specular=0.9, spec_tint=0.6),                     # 3 glossy dielectric
    dict(base_color=BLUE, roughness=0.7, clearcoat=1.0, clearcoat_gloss=0.9,                # 4 clearcoat
         clearcoat_sampling_rate=2.0),
    dict(base_color=(0.9, 0.9, 0.8), roughness=0.3, spec_trans=1.0, eta=1.5),               # 5 glass
    dict(base_color=BLUE, roughness=0.5, spec_trans=0.6, eta=0.8, metallic=0.2,             # 6 eta < 1, mixed
         clearcoat=0.5, sheen=0.5),
    dict(base_color=RED, roughness=0.0, spec_trans=0.5, specular=0.3),                      # 7 roughness 0
    dict(base_color=RED, roughness=0.8, metallic=0.3, spec_trans=0.3, specular=0.6,         # 8 everything
         spec_tint=0.4, sheen=0.6, sheen_tint=0.3, clearcoat=0.7, clearcoat_gloss=1.0,
         main_specular_sampling_rate=0.5, clearcoat_sampling_rate=0.3, diffuse_reflectance_sampling_rate=2.0),
    dict(base_color=(0.7, 0.7, 0.7), roughness=0.25, spec_trans=1.0, eta=1.0),              # 9 eta 1: 1.001
    dict(base_color=RED, roughness=0.4, anisotropic=0.8, metallic=0.5),                     # 10 anisotropic
    dict(base_color=(0.9, 0.9, 0.9), roughness=0.6, anisotropic=1.0, spec_trans=0.8, eta=1.33),  # 11 aniso glass
    dict(base_color=(0.6, 0.6, 0.6), roughness=0.5, specular=0.0),                          # 12 eta 1: F = 0
    dict(base_color=RED, roughness=0.8, flatness=1.0),                                      # 13 fake subsurface
    dict(base_color=BLUE, roughness=0.3, flatness=0.6, metallic=0.2, spec_trans=0.5,        # 14 flatness mixed
         eta=1.3, sheen=0.5, clearcoat=0.4),
]
ISOTROPIC = [i for i, m in enumerate(MATERIALS) if not m.get("anisotropic")]
MODEL_NAMES = {"eta": "principled_eta", "specular": "principled_specular"}


def model(row, name="m"):
    """The model.Material of a row of MATERIALS."""
    fields = {MODEL_NAMES.get(k, k): v for k, v in row.items() if k != "base_color"}
    return Material(name=name, colour=np.array(row["base_color"], float), bsdf="principled", **fields)


def packed(rows=MATERIALS):
    return material_structs([model(row, f"m{i}") for i, row in enumerate(rows)])


def reference_material(row, entry=None):
    """principled_reference's material of a row; with its packed entry, the float32 values the kernel reads (eta,
    the alphas, the clearcoat's alpha), which test_host_terms_match_reference checks against its own."""
    p = pr.material(**row)
    if entry is not None:
        p["eta"], p["alpha_u"], p["alpha_v"] = float(entry["eta"][0]), float(entry["alpha"]), float(entry["alpha_v"])
        p["clearcoat_alpha"] = float(entry["principled"][6])
    return p


def frames(n, t, backface, entry_rows, table):
    """Each lane's local frame as the kernel takes it (rows x, y, z): z the outward normal, n turned over where
    the hit is from inside a material that transmits ((1 - metallic) spec_trans > 0), x the tangent t."""
    bsdf = np.array([(1 - table[j]["principled"][1]) * table[j]["principled"][7] for j in entry_rows])
    z = n * np.where((backface != 0) & (bsdf > 0), -1.0, 1.0)[:, None]
    return np.stack([t, np.cross(z, t), z], axis=1)


def gtr1_conditioning(p, lh):
    """The same for the clearcoat's GTR1 D ~ 1 / (1 + (a^2 - 1) c), c = cos^2(theta_h), which Mitsuba and the
    kernel both take from cos(theta_h) alone: |1 - a^2| dc / (1 + (a^2 - 1) c) relatively, dc = 32 U; at
    clearcoat_gloss 0.9's a = 0.011 some 2e-2 at the peak, at gloss 1's 1e-3 the whole value (float32 cannot
    resolve that lobe from the cosine)."""
    a2 = p["clearcoat_alpha"] ** 2
    c = np.minimum(lh[:, 2] ** 2, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(abs(1 - a2) / (1 + (a2 - 1) * c) * 32 * U) * (p["clearcoat"] > 0)


def half_vector(p, lo, li):
    """The reference's half vector (principled_reference's), for the conditioning."""
    reflect = lo[:, 2] * li[:, 2] > 0
    eta_path = np.where(lo[:, 2] > 0, p["eta"], 1 / p["eta"])
    h = lo + li * np.where(reflect, 1.0, eta_path)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(h / np.linalg.norm(h, axis=1, keepdims=True))


def tolerance(p, lo, li, rng, anisotropic, draws=4):
    """The reference's (f, pdf) at the float32 inputs and their tolerances:
        tol = 4 spread + 64 U |r64| + conditioning (|main lobes' part|, |clearcoat's|, |reflection's|; |pdf|) + 1e-6,
    spread the largest change of the float64 value over `draws` inputs within 4 U of these (the value's
    condition: the half vector's near grazing and near a narrow lobe's peak, Fresnel's at the critical angle;
    the kernel takes world directions, its local coordinates off by some U), 64 U the roundings of a chain of
    some tens of float32 operations (the five lobes summed; GTR1's logarithm by vlog2, 11 U), the isotropic
    build's D conditioning on the main lobes' value and on the pdf, GTR1's on the clearcoat's (and the pdf),
    the Fresnel term's near eta = 1 on the reflection's (and the pdf), the front's reflection share's on the
    pdf, and 1e-6 absolutely (values below it count
    for nothing beside the lobes' peaks of 1e2 to 1e5)."""
    f, pdf, lobes = pr.eval_pdf(p, lo, li)
    spread_f, spread_p = np.zeros_like(f), np.zeros_like(pdf)
    for _ in range(draws):
        o, i = (w + 4 * U * rng.uniform(-1, 1, w.shape) for w in (lo, li))
        f2, p2, _ = pr.eval_pdf(p, o, i)
        spread_f, spread_p = np.maximum(spread_f, np.abs(f2 - f)), np.maximum(spread_p, np.abs(p2 - pdf))
    h = half_vector(p, lo, li)
    cond, cond_cc, cond_f = d_conditioning(p, h, anisotropic), gtr1_conditioning(p, h), fresnel_conditioning(p, lo, h)
    main = np.abs(lobes["reflection"]) + np.abs(lobes["transmission"])
    tol_f = (4 * spread_f + 64 * U * np.abs(f) + cond[:, None] * main + cond_cc[:, None] * lobes["clearcoat"]
             + cond_f[:, None] * lobes["reflection"] + 1e-6)
    # the front's reflection share 1 - bsdf (1 - F) rounds 1 - F to U: at spec_trans 1 and eta 1.001 (F 2.5e-7)
    # float32 knows it within 4 U / F, some 100% (Mitsuba's arithmetic, the kernel's alike)
    bsdf = (1 - p["metallic"]) * p["spec_trans"]
    f_h = np.nan_to_num(pr.ref.fresnel_dielectric(np.sum(lo * h, axis=1), p["eta"])[0])
    with np.errstate(divide="ignore"):
        cond_mix = np.where(lo[:, 2] > 0, np.minimum(4 * U * bsdf / (1 - bsdf * (1 - f_h)), 1.0), 0.0)
    tol_p = 4 * spread_p + 64 * U * np.abs(pdf) + (cond + cond_cc + cond_f + cond_mix) * np.abs(pdf) + 1e-6
    return f, pdf, tol_f, tol_p


def run(harness, table, which, n, t, backface, wo, wi, u, defines=DEFINES, outputs=OUTPUTS):
    return bsdf_support.run(harness, table, n, wo, wi, u, outputs, which=which, tangent=t, backface=backface,
                            **defines)


def test_reference_matches_mitsuba():
    """principled_reference's eval and pdf against Mitsuba 3.9.1's own (tests/data/mitsuba_principled_values.npz,
    recorded by devtools/peers/mitsuba_principled.py: 13 cases (3 with flatness), 256 points each, a quarter of them
    or more with wo inside for the transmitting ones, wi uniform on the sphere) and at the directions Mitsuba's
    sampler drew (its pdf there and its weight, eval / pdf), within the reference's own tolerance (4 times its
    spread over inputs within 4 U, 64 U relative, 1e-6; tolerance() above, without an isotropic build's term:
    Mitsuba's D takes m's x and y): Mitsuba computes in float32, the reference's condition at its inputs bounds what
    that costs. A sample Mitsuba refuses has weight 0 (its pdf may be the direction's all the same): those are left
    out. Measured: the largest error is 0.097 of its tolerance (the pdf at a sampled direction of roughness 0's
    alpha 1e-3 lobe), the largest relative error of values above 1e-3 1.5e-5 (eval and pdf, the mixed cases; 1.4e-6
    in the flatness cases, whose largest error is 0.034 of its tolerance). The samples' lobes (s_component) are not
    compared: the reference has no sampler; their pdf and weight are. Deterministic (fixed inputs and seeds). It
    fails (each tried on the reference): the transmission's half vector wo + wi / eta' (the inverted index), the
    sheen without its tint, the clearcoat's pdf without the Jacobian of its half vector, Burley's retro-reflection
    Rr without its factor 2, and the fake subsurface's f_ss without its 1.25, with Fss90 = Rr (not Rr / 2), or with
    twice the viewer's cosine for |cos_o| + |cos_i|."""
    cases = mitsuba_bsdf.load(ROOT / "tests" / "data" / "mitsuba_principled_values.npz")
    assert len(cases) == 13
    worst = mitsuba_worst(cases, pr.material, tolerance, np.random.default_rng(5), kept_share=0.75)
    assert worst > 0.02  # the tolerance is not so loose that nothing comes near it


def test_host_terms_match_reference():
    """principled_terms (the host's float32 eta from specular or eta, the main lobe's alphas and the clearcoat's,
    Mitsuba's arithmetic) against the reference's float64 within 1e-6 relatively (a few float32 roundings), and
    the packed values in types.h's PRINCIPLED_* order (flatness in PRINCIPLED_FLATNESS). flatness packed as 0
    fails it (tried)."""
    table = packed()
    for row, entry in zip(MATERIALS, table):
        p = pr.material(**row)
        m = model(row)
        assert abs(principled_terms.eta(m) - p["eta"]) <= 1e-6 * p["eta"], (row, principled_terms.eta(m), p["eta"])
        au, av = principled_terms.alphas(m)
        assert abs(au - p["alpha_u"]) <= 1e-6 * p["alpha_u"] and abs(av - p["alpha_v"]) <= 1e-6 * p["alpha_v"]
        assert abs(principled_terms.clearcoat_alpha(m) - p["clearcoat_alpha"]) <= 1e-6 * p["clearcoat_alpha"]
        want = [p["roughness"], p["metallic"], p["spec_tint"], p["sheen"], p["sheen_tint"], p["clearcoat"],
                p["clearcoat_alpha"], p["spec_trans"], p["main_specular_sampling_rate"], p["clearcoat_sampling_rate"],
                p["diffuse_reflectance_sampling_rate"], p["anisotropic"], float(p["spec_trans"] != 0), p["flatness"]]
        want += [0.0] * 5  # principledthin's other own slots
        np.testing.assert_allclose(entry["principled"], want, rtol=1e-6)
        assert entry["bsdf"] == structs.BSDFS["principled"] and entry["distribution"] == 0
    assert principled_terms.eta(model(MATERIALS[9])) == pytest.approx(1.001)  # eta 1 with transmission


EVAL_DATA = {}


def lanes_of(anisotropic):
    """The eval test's lanes (4096; isotropic materials only in the isotropic build), their references and
    tolerances (principled_support.eval_case), computed once for every lane width."""
    table = packed()
    return eval_case(EVAL_DATA, anisotropic, 11, list(range(len(MATERIALS))) if anisotropic else ISOTROPIC, table,
                     [reference_material(row, entry) for row, entry in zip(MATERIALS, table)],
                     lambda n, t, backface, which: frames(n, t, backface, which, table), tolerance)


@pytest.mark.parametrize("lanes, anisotropic", [(n, False) for n in runnable_lane_widths()]
                         + [(n, True) for n in LANE_ENDS],
                         ids=[f"{lane_id(n)}-isotropic" for n in runnable_lane_widths()]
                         + [f"{lane_id(n)}-anisotropic" for n in LANE_ENDS])
def test_eval_and_pdf_against_reference(harness, anisotropic):
    """eval (f cos_i, RGB) and pdf of the kernel against the float64 reference, on 4096 lanes mixing the materials
    lane by lane (the isotropic ones in the isotropic build, all fifteen in the anisotropic one), at random
    normals and tangents, a quarter of the hits from inside (backface: the transmitting materials' inside,
    eta inverted; the opaque ones' back, which is their front), 1/8 of the viewers below the normal (the inside
    of Mitsuba's frame), wi uniform or within 2e-3 of wo's mirror and refracted directions. Every lane width in
    the isotropic build, both lane ends in the anisotropic one. Each value within tolerance() (the reference's
    condition at the float32 inputs, 64 roundings, an isotropic build's D near roughness 0's peak): a bound on a
    correct float32 kernel's error that fails one only where its first-order model is wrong. Deterministic
    (fixed seeds). Measured: the largest error is 0.12 (eval) and 0.14 (pdf) of its tolerance in the isotropic
    build (the same bits at widths 1, 4, 8, 16), 0.39 (eval) and 0.67 (pdf: eta 1.001's reflection share, F
    2.5e-7) in the anisotropic one, and 0.11 on the flatness materials' lanes; the largest relative error of
    values above 1e-3 is 0.17 in the isotropic build (roughness 0's alpha 1e-3 lobe 2e-3 off its peak: D from
    cos(theta_h) alone, within its conditioning term) and 0.13 in the anisotropic one (clearcoat_gloss 1's GTR1
    lobe of alpha 1e-3, from cos(theta_h) in Mitsuba too). It fails (each tried on the kernel): the transmission
    without sqrt(k), the clearcoat's Fresnel 0.4 + 0.6 Fw, the retro-reflection Rr without its factor 2, the
    inside's eta not inverted (eta_path = eta), the probabilities' clearcoat rate dropped, the sheen's tint k /
    lum without lum, the flatness lerp dropped (principled_diffuse's value alone), f_ss without its 1.25 (which
    fails principledthin's too: the code is shared), its 1 / (|cos_o| + |cos_i|) as 1 / (2 |cos_o|), and
    the diffuse lobe's probability scaled by 1 - flatness / 2 (its pdf)."""
    table, (n, t, backface, wo, wi, which, u), (ref_f, ref_p, tol_f, tol_p), lo, li = lanes_of(anisotropic)
    out = run(harness, table, which, n, t, backface, wo, wi, u, ANISOTROPIC if anisotropic else DEFINES,
              ("f", "pdf"))
    check_against_reference(out, ref_f, ref_p, tol_f, tol_p, which, lo, li)


@pytest.mark.parametrize("lanes", runnable_lane_widths(), ids=lane_id)
def test_sample_weight_is_eval_over_pdf(harness):
    """bsdf_sample's weight is bsdf_eval / bsdf_pdf at the direction it drew, and its pdf bsdf_pdf's, within
    float32 rounding (2e-5 relatively: a division and the same terms, plus 1e-7); a sample without a density
    (pdf 0: the main lobes' or the clearcoat's reflection below the surface, a refraction that stays on wo's
    side) has weight 0; transmit is set exactly where wi crosses the surface, and only then. Every material
    (anisotropic build), every lane width, 4096 lanes, a quarter from inside. Measured: the weight within 1.1e-7
    of eval / pdf relatively, 88% of the samples valid. A weight 0.1% off eval / pdf fails it (tried)."""
    rng = np.random.default_rng(3)
    table = packed()
    n, t, backface, wo, wi, which, u = random_case(rng, 4096, list(range(len(MATERIALS))))
    out = run(harness, table, which, n, t, backface, wo, wi, u, ANISOTROPIC)
    check_sample_weights(out, n, wo, valid_share=0.75, transmitted=200)


@pytest.mark.parametrize("lanes", LANE_ENDS, ids=lane_id)
def test_reflection_is_reciprocal(harness):
    """f = eval / cos_i of the reflection (wo and wi above the normal, the front) is symmetric in (wo, wi): each
    lobe is (F_p D G / (4 cos_o cos_i), the diffuse's symmetric in Fo and Fi, the sheen's and clearcoat's
    Fw(wi . h) and F_s(wo . h) with wi . h = wo . h): eval(wo, wi) cos_o == eval(wi, wo) cos_i within 2e-4
    relatively plus 1e-6 (the two evaluations round the half vector's terms differently), away from the mirror direction
    (cosine 0.999: the narrow lobes' condition there), every material, the anisotropic build, both lane ends.
    Measured: within 3.1e-4 relatively of values above 1e-6 (a narrow lobe's flank, inside the 1e-6 absolute
    term). The diffuse's Fi of cos_o^2 for |cos_o|, the sheen times an extra cos_o, and the fake subsurface's 1 /
    (|cos_o| + |cos_i|) as 1 / (2 |cos_o|) fail it (tried)."""
    rng = np.random.default_rng(13)
    table = packed()
    n, t, backface, wo, wi, which, u = random_case(rng, 4096, list(range(len(MATERIALS))))
    out = run(harness, table, which, n, t, np.zeros_like(backface), wo, wi, u, ANISOTROPIC, ("f", "f_swapped"))
    check_reciprocity(out, n, wo, wi)


# (row, theta_o, backface) of the chi-square test: metal, glossy dielectric, clearcoat, diffuse with sheen, glass
# from outside and from inside (eta 1.5: total internal reflection beyond 42 degrees), eta below 1 mixed, and
# the anisotropic metal, and flatness among the other lobes (its diffuse lobe still sampled by the cosine, as
# Mitsuba's: the density is flatness's too).
CHI_CASES = [(2, 0.5, 0), (3, 1.1, 0), (4, 0.8, 0), (1, 0.3, 0), (5, 0.6, 0), (5, 0.9, 1), (6, 0.7, 0), (10, 1.0, 0),
             (14, 1.2, 0)]
_DENSITIES = {}


@at_lane_ends
@pytest.mark.parametrize("row, theta_o, backface", CHI_CASES)
def test_sampling_chi_square(harness, row, theta_o, backface):
    """bsdf_sample's directions from one wo against the reference's pdf (which the eval test matches to the
    kernel's): Pearson's chi-square over 16 x 32 cells of the sphere (devtools/chi_square.py), 2^17 samples. The
    samples the kernel refuses (pdf 0: a reflection below the surface, a refraction back to wo's side) are left
    out and the density renormalised over the rest, its mass the share kept (checked to 5 binomial standard
    errors plus 2e-3, the quadrature's error of the mass). The normal is z, the tangent x, wo in the xz-plane
    (the anisotropic case in the anisotropic build, at azimuth 0.6 rad). 9 cases at 2 lane widths at
    significance 1e-4: with fresh random numbers a correct sampler would fail one run in 556; with the fixed
    seeds here the run is deterministic. Measured p (the same at widths 1 and 16): metal 0.97, glossy 0.59,
    clearcoat 0.57, sheen 0.87, glass 0.27, glass inside 0.43, eta 0.8 mixed 0.89, anisotropic 0.23, flatness
    mixed 0.73. It fails (each tried): GTR1's normals sampled with a^2 = a (the clearcoat's roughness 0.011
    taken for its square), the lobe choice with half the diffuse lobe's probability, the refraction with eta in
    place of 1 / eta (Mitsuba's eta_ti), the visible normals sampled from wo not turned to the front (inside),
    and the diffuse lobe's probability scaled by 1 - flatness / 2 (the flatness case)."""
    table = packed()
    m = 1 << 17
    rng = np.random.default_rng(17 + row)
    anisotropic = bool(MATERIALS[row].get("anisotropic"))
    phi_o = 0.6 if anisotropic else 0.0
    wo1 = np.array([[np.sin(theta_o) * np.cos(phi_o), np.sin(theta_o) * np.sin(phi_o), np.cos(theta_o)]])
    nrm, tan = np.tile([0.0, 0.0, 1.0], (m, 1)), np.tile([1.0, 0.0, 0.0], (m, 1))
    wo = np.repeat(f32(wo1), m, axis=0)
    bf = np.full(m, backface, np.int32)
    out = run(harness, table, np.full(m, row), nrm, tan, bf, wo, wo, rng.uniform(size=(m, 3)),
              ANISOTROPIC if anisotropic else DEFINES, ("s_wi", "s_pdf"))
    fr = frames(nrm[:1], tan[:1], bf[:1], [row], table)[0]  # the local frame: z turned over inside
    p = reference_material(MATERIALS[row], table[row])

    def density(c, phi):  # in world coordinates (z the normal sp.n), on chi_square's grid: once a case
        key = (row, theta_o, backface, c.shape)
        if key not in _DENSITIES:
            s = np.sqrt(np.maximum(0, 1 - c * c))
            w = np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1).reshape(-1, 3)
            lo = np.repeat((fr @ f32(wo1)[0])[None], len(w), axis=0)
            _DENSITIES[key] = pr.eval_pdf(p, lo, w @ fr.T)[1].reshape(c.shape)
        return _DENSITIES[key]

    check_chi_square(out, density)


# (name, row of white-based materials, the bound of its albedo (None: none), backface): each lobe alone where the
# model allows (specular 0: eta 1, no dielectric reflection beside the diffuse and the sheen).
FURNACE = [("diffuse, roughness 0", dict(base_color=WHITE, roughness=0.0, specular=0.0), 1.0, 0),
           ("diffuse, roughness 1 (retro-reflection)", dict(base_color=WHITE, roughness=1.0, specular=0.0), None, 0),
           ("dielectric over diffuse", dict(base_color=WHITE, roughness=0.5), None, 0),
           ("metal, roughness 0.5", dict(base_color=WHITE, metallic=1.0, roughness=0.5), 1.0, 0),
           ("metal, roughness 0", dict(base_color=WHITE, metallic=1.0, roughness=0.0), 1.0, 0),
           ("glass, roughness 0.4", dict(base_color=WHITE, spec_trans=1.0, roughness=0.4, eta=1.5), 1.0, 0),
           ("glass, roughness 0.4, inside", dict(base_color=WHITE, spec_trans=1.0, roughness=0.4, eta=1.5), 1.5**2, 1),
           ("glass, roughness 0.4, eta 0.7", dict(base_color=WHITE, spec_trans=1.0, roughness=0.4, eta=0.7),
            1 / 0.7**2, 0),
           ("clearcoat on black metal", dict(base_color=(0.0, 0.0, 0.0), metallic=1.0, roughness=1.0,
                                             clearcoat=1.0, clearcoat_gloss=0.5), 1.0, 0),
           ("sheen on black", dict(base_color=(0.0, 0.0, 0.0), roughness=0.0, sheen=1.0, specular=0.0), 1.0, 0),
           ("fake subsurface (flatness 1)", dict(base_color=WHITE, roughness=0.5, flatness=1.0, specular=0.0), None,
            0)]


@at_lane_ends
@pytest.mark.parametrize("name, row, bound, backface", FURNACE, ids=[f[0] for f in FURNACE])
def test_white_furnace(harness, name, row, bound, backface):
    """Each lobe's albedo, the mean of bsdf_sample's weight over 2^15 samples from one wo, at 6 angles from 0 to 85
    degrees, against the float64 reference's integral of eval (f cos) over the sphere, estimated with the
    reference's own density as importance (the mean of the reference's eval / pdf at the kernel's sampled
    directions, which test_sampling_chi_square finds distributed as that pdf: an unbiased estimate of the
    integral wherever pdf > 0 covers the lobes) within 5 standard errors of the difference plus 1e-4 of it; and
    at most its bound (within 5 standard errors) where the lobe has one: Disney's diffuse at roughness 0 ((1 -
    Fo/2)(1 - Fi/2) <= 1), the metal (F = 1 white: the masked share is lost), the clearcoat (F <= 1) and the
    sheen (Fw <= 1, alone on a black base with specular 0), each 1; the glass 1 from the denser side's outside
    and 1 / eta'^2 where the light enters the denser side (from inside at eta 1.5: 2.25; from outside at eta
    0.7: 2.04): Mitsuba's transmission in radiance mode carries the radiance's 1 / eta'^2 (its two factors
    cancel in the value, not in the integral: the Jacobian of refraction brings it), as roughdielectric's does
    (raytrace/scene/ranges.py's rule 5 counts principled's eta with the glass's). Unbounded: the
    retro-reflection at roughness 1 (Burley's diffuse gains energy towards grazing angles), the default
    dielectric over the diffuse (Disney's lobes add, the diffuse not reduced by the reflection's share) and the
    fake subsurface (flatness 1: f_ss grows as 1 / (|cos_o| + |cos_i|) towards grazing).
    Measured albedos over the angles (the same at widths 1 and 16): diffuse 0.67-0.98, retro-reflective
    1.03-1.40, dielectric over diffuse 1.04-1.18, metal 0.5 0.83-0.92, metal 0 1.000, glass 0.47-0.53, glass
    inside 0.84-2.13, eta 0.7 0.83-1.95, clearcoat 0.016-0.029, sheen 0.000-0.066, fake subsurface 0.75-1.28
    (principledthin's, the same lobe). Deterministic (fixed seeds). The diffuse without its (1 - Fi/2), the
    metal's Schlick weight squared and the flatness lerp dropped in the kernel fail it (tried)."""
    table = material_structs([model(row)])
    p = reference_material(row, table[0])
    m = 1 << 15
    fr = frames(np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]), np.array([backface]), [0], table)[0]
    nrm, tan = np.tile([0.0, 0.0, 1.0], (m, 1)), np.tile([1.0, 0.0, 0.0], (m, 1))

    def sample(wo, u):
        return run(harness, table, np.zeros(m, int), nrm, tan, np.full(m, backface, np.int32), wo, wo, u, DEFINES,
                   ("s_wi", "s_weight", "s_pdf"))

    furnace_means(sample, lambda wo, wi: pr.eval_pdf(p, wo @ fr.T, wi @ fr.T)[:2], bound, np.random.default_rng(23), m)


PRINCIPLED_TOML = """
[materials.satin]
type = "principled"
base_color = [0.8, 0.3, 0.2]
roughness = 0.35
anisotropic = 0.6
specular = 0.7
sheen = 0.4
flatness = 0.3
clearcoat = 0.5
clearcoat_gloss = 0.9
clearcoat_sampling_rate = 0.5

[materials.frost]
type = "principled"
roughness = 0.2
spec_trans = 0.9
eta = 1.33
"""


def test_scene_file_mitsuba_xml_and_writer(tmp_path):
    """The host's side: principled materials in a TOML scene render with HAS_PRINCIPLED (and HAS_ANISOTROPIC for
    anisotropic != 0), written as Mitsuba XML (the opaque one in twosided, Mitsuba's twosided refusing
    transmission: the transmitting one bare) and read back as the same model, bit for bit; eta beside specular
    is refused (Mitsuba's rule: one sets the other); flatness is written and read back. It fails (each tried):
    the writer leaving the opaque one bare, rules.py accepting eta beside specular, and the loader reading
    principled's eta as a conductor's."""
    import raytrace
    from raytrace.errors import InputError
    from raytrace.renderer.program import Features
    from raytrace.scene.model import fingerprint
    shapes = "".join(f'\n[[shapes]]\ntype = "ellipsoid"\ncenter = [{x!r}, 0.3, 0.3]\naxes = [[0.1, 0, 0], [0, 0.1, 0], '
                     f'[0, 0, 0.1]]\nmaterial = "{name}"\n' for x, name in ((0.3, "satin"), (0.6, "frost")))
    # warnings are errors: no "outside twosided", the opaque one is wrapped
    scene, back, text, toml = xml_round_trip(tmp_path, PRINCIPLED_TOML + shapes)
    assert fingerprint(back.materials) == fingerprint(scene.materials)
    satin = next(m for m in back.materials if m.name == "satin")
    assert (satin.bsdf, satin.principled_specular, satin.principled_eta, satin.anisotropic, satin.flatness) == (
        "principled", 0.7, None, 0.6, 0.3)
    text = (tmp_path / "out" / "scene.xml").read_text()
    assert '<bsdf type="twosided" id="satin">' in text and '<bsdf type="principled" id="frost">' in text
    options = Features.of(scene, 8).options()
    assert "-DHAS_PRINCIPLED=1" in options and "-DHAS_ANISOTROPIC=1" in options
    both = tmp_path / "both.toml"
    both.write_text(toml.read_text().replace('eta = 1.33', 'eta = 1.33\nspecular = 0.5'))
    with pytest.raises(InputError, match="eta = 1.33: not with specular"):
        raytrace.load_file(both)
    assert '<float name="flatness" value="0.3" />' in text  # Mitsuba's m_has_flatness: given, not 0


@at_lane_ends
@pytest.mark.parametrize("bsdf", ["principled", "principledthin"])
def test_a_colour_below_float32s_normals_renders_finite(lanes, bsdf):
    """A base colour whose luminance lies below float32's smallest normal number (a texel of 1e-39, found by the
    fuzz suite through a colour texture): the tint's 1 / lum overflowed to inf and k inf to inf or NaN in every
    pixel; the tint is white there, as where lum is 0, and every value is finite. Mutation-checked: the tint's
    test back at lum > 0 makes every pixel non-finite."""
    for colour in ([1e-39, 0.0, 0.0], [0.0, 0.0, 5e-39]):
        table = mts.path_scene({"m": {"type": bsdf, "base_color": colour, "spec_tint": 1.0, "sheen": 1.0,
                                      "sheen_tint": 1.0}},
                               [mts.panel("m"), {"type": "ellipsoid", "material": "m", "center": [0.0, -0.8, 0.0],
                                                 "axes": [[0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, 0.3]]}])
        image, stats = raytrace.render(raytrace.load_dict(table), spp=4, lanes=lanes)
        assert stats.extra["nonfinite_values"] == 0 and np.all(np.isfinite(np.asarray(image))), colour
