"""tests/bsdf_reference.py, the float64 references of Mitsuba 3's BSDFs, against Mitsuba 3.9.1 itself and
against the physics it must obey.

Against Mitsuba: tests/data/mitsuba_bsdf_values.npz holds what Mitsuba's scalar_rgb variant (float32)
returned for 30 plugin dicts (every BSDF; alpha from 0.001 to 1, anisotropic, int_ior < ext_ior, total
internal reflection, nonlinear on and off, sample_visible off) at 96 points each: eval and pdf at uniform
directions and at the directions its sample() drew, and sample() itself (devtools/peers/mitsuba_bsdf.py
records them; its `compare` mode runs the same comparison on the full 4096 points a case). Each value's
tolerance (bsdf_reference.mitsuba_errors) is 8 (spread + noise) + 16 ULP |value| + 1e-15, ULP = 2^-24:
  - 16 ULP: Mitsuba computes each value by a chain of some tens of float32 operations, each rounded by at
    most 1/2 ULP relative; where the value is well conditioned that is the whole error (the diffuse and
    smooth dielectric values agree to 1e-7, the conductor's Fresnel term, Moeller's real form against the
    complex amplitudes here, to 1e-6);
  - spread: how far the float64 value moves when the float32 inputs move by 4 ULP (and the stretched
    direction of the visible-normal sampler and roughplastic's tables by their own float32 rounding):
    Mitsuba rounds the half vector and its normalisations, which near a narrow peak (alpha = 0.001: D changes
    by 2e-4 for a 1e-7 turn of h) or a total-internal-reflection edge is worth far more than 16 ULP of the
    value. The largest relative errors (1e-4 to 1e-1, at values 1e-6 of the lobe's peak on a critical-angle
    edge) come from there, and the spread accounts for each;
  - noise: the error of the same formulas evaluated in float32 near the point: the cancellation in 1 - F at
    grazing angles (plastic: 1e-4 relative) and near the critical angle;
  - the factor 8: spread and noise are maxima over 8 draws, estimates of a rounding that Mitsuba's code (FMAs,
    another order of operations) does not repeat exactly. Over the full recording (30 x 4096 points, two
    seeds of the draws) the largest error is 0.63 of this tolerance, over the fixture (five seeds) 0.53.
A wrong factor or a wrong branch cannot hide in it: half the tolerances are below 3e-5 of the value
(test_the_tolerances_are_tight_where_the_values_are_well_conditioned). Mutation checks, each run by hand on a
copy of the reference: plastic's 1 / eta^2 made 1 / eta (fails the 3 plastic cases), roughdielectric's
transmission Jacobian with eta for eta^2 (all 7 roughdielectric cases), roughplastic's R_int by the
trapezoid rule instead of Mitsuba's 64-point mean (all 5 roughplastic cases), thindielectric's 2R / (1 + R)
replaced by R (both cases), and Beckmann's rational G1 replaced by its exact erf form, 0.3 % away at most
(all 9 Beckmann cases).

Against physics (no Mitsuba): reciprocity of eval where the model is reciprocal (and the generalised form
of refraction's radiance scaling), white furnaces (delta lobes exactly; the rough ones by quadrature and by
the mean of sample()'s weights), the pdf integrating over the sphere to the share of sample()'s draws that
carry light, sample()'s pdf and weight equal to pdf() and eval() / pdf() at the sampled direction (but for
Mitsuba's own inconsistency, test_roughdielectric_weights_without_visible_normals_are_mitsubas), and
roughplastic's tables against an independent integral. The whole file runs in about 5 s (one core)."""
import functools
import json
import math

import numpy as np
import pytest

import bsdf_reference as ref
from devtools.peers.mitsuba_bsdf import CASES, FIXTURE, RECORD, load
from helpers import ROOT

RECORDED = load(FIXTURE)
RNG_SEED = 20260807


@functools.cache
def errors_of(case):
    """bsdf_reference.mitsuba_errors of a recorded case (once per process: two tests read them)."""
    _, plugin, values = RECORDED[case]
    return ref.mitsuba_errors(plugin, values)


def sphere(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def sphere_grid(n_cos=128, n_phi=128):
    """Quadrature of the sphere: Gauss-Legendre in cos(theta) on each hemisphere (the lobes end at the
    horizon), the periodic trapezoid rule in phi: (directions (n, 3), weights (n,)), the weights sum to 4 pi."""
    x, w = ref.gauss_legendre(n_cos)
    c = np.concatenate([(x - 1) / 2, (x + 1) / 2])
    wc = np.concatenate([w / 2, w / 2])
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    cc, pp = np.meshgrid(c, phi, indexing="ij")
    s = np.sqrt(1 - cc ** 2)
    dirs = np.stack([s * np.cos(pp), s * np.sin(pp), cc], axis=-1).reshape(-1, 3)
    return dirs, np.outer(wc, np.full(n_phi, 2 * np.pi / n_phi)).ravel()


def direction(z, phi=0.3):
    s = math.sqrt(1 - z * z)
    return np.array([[s * math.cos(phi), s * math.sin(phi), z]])


# ---------------------------------------------------------------------------------------------------------
# Against Mitsuba's values

def test_the_record_says_what_was_recorded():
    """The JSON beside the fixture names Mitsuba 3.9.1's scalar_rgb variant and the command; the fixture holds
    the rig's current cases (a case added to devtools/peers/mitsuba_bsdf.py is recorded before it counts) and
    stays small."""
    record = json.loads(RECORD.read_text())
    assert record["mitsuba"] == "3.9.1" and record["variant"] == "scalar_rgb"
    assert "devtools/peers/mitsuba_bsdf.py record" in record["command"] and record["date"]
    assert [(n, p) for n, p, _ in RECORDED] == [(n, p) for n, p in CASES]
    assert all(len(v["wo"]) == record["points"] for _, _, v in RECORDED)
    assert FIXTURE.stat().st_size < 300_000
    assert FIXTURE.is_relative_to(ROOT / "tests" / "data")


def test_the_cases_cover_what_the_docstring_says():
    """Every BSDF; for the rough ones alpha 0.001 and 1, both distributions and (where Mitsuba allows it)
    anisotropy and sample_visible off; int_ior < ext_ior for every dielectric; nonlinear on and off; and
    among the points, viewers below one-sided surfaces and inside glass past the critical angle."""
    plugins = [p for _, p, _ in RECORDED]
    by_type = {}
    for p in plugins:
        by_type.setdefault(p["type"], []).append(p)
    assert set(by_type) == set(ref.BSDFS)
    for kind in ("roughconductor", "roughdielectric", "roughplastic"):
        alphas = [a for p in by_type[kind] for a in (p.get("alpha", p.get("alpha_u", 0.1)), p.get("alpha_v", 0.1))]
        assert min(alphas) <= 0.001 and max(alphas) >= 1.0, kind
        assert {p.get("distribution", "beckmann") for p in by_type[kind]} == {"beckmann", "ggx"}
        assert any(p.get("sample_visible") is False for p in by_type[kind])
    for kind in ("roughconductor", "roughdielectric"):
        assert any(p.get("alpha_u", 0) != p.get("alpha_v", 0) for p in by_type[kind])
    for kind in ("dielectric", "thindielectric", "roughdielectric", "plastic", "roughplastic"):
        assert any(ref.ior(p.get("int_ior", 1.5)) < ref.ior(p.get("ext_ior", 1.0)) for p in by_type[kind]), kind
    assert {bool(p.get("nonlinear", False)) for p in by_type["plastic"] + by_type["roughplastic"]} == {True, False}
    for name, plugin, values in RECORDED:
        if plugin["type"] not in ("dielectric", "thindielectric", "roughdielectric"):
            assert np.sum(values["wo"][:, 2] < 0) >= 8, name
    name, plugin, values = next(c for c in RECORDED if c[0] == "dielectric 1.5")
    transmission = ref.load_dict(plugin).delta_lobes(values["wo"].astype(np.float64))[1]
    assert np.sum(transmission.prob == 0) >= 5  # inside, past the critical angle: Mitsuba reflects with pdf 1
    assert np.all(values["s_pdf"][transmission.prob == 0] == 1)


@pytest.mark.parametrize("case", range(len(RECORDED)), ids=[n for n, _, _ in RECORDED])
def test_against_mitsuba(case):
    """Every recorded value within its tolerance (see the module's docstring); a sample's lobe differs from
    Mitsuba's only where u1 lies within 1e-5 of the lobe choice's threshold; and there is something to
    compare: the sampled directions carry light, and a BSDF with a glossy or diffuse lobe has nonzero eval
    at its own samples."""
    _, plugin, values = RECORDED[case]
    errors = dict(errors_of(case))
    components = errors.pop("components")
    assert components["flips"] <= 2 and components["flips_explained"], components
    worst = {k: float(e["excess"].max(initial=0)) for k, e in errors.items()}
    assert all(w <= 1 for w in worst.values()), worst
    assert len(errors["s_weight"]["err"]) >= 40
    if plugin["type"] not in ("conductor", "dielectric", "thindielectric"):
        assert np.sum(np.abs(values["s_eval"]).max(axis=1) > 0) >= 10


def test_the_tolerances_are_tight_where_the_values_are_well_conditioned():
    """The comparison can fail: over all cases, half of the nonzero eval and pdf values have a tolerance
    below 3e-5 of the value, three quarters below 1e-4; in every case three quarters are below 1e-3, so a
    factor off by 0.1 % fails on most of a case's points (a wrong factor changes every value it enters).
    But for the Beckmann alpha = 0.001 cases (three quarters below 3e-2): that peak is 0.1 degree wide, every
    value sits on its flank, where a float32 ULP of the half vector moves D by 1e-3 or more."""
    every = []
    for case, (name, _, values) in enumerate(RECORDED):
        errors = errors_of(case)
        rel = []
        for q in ("eval", "pdf", "s_eval", "s_pdf_eval"):
            got = np.abs(values[q].astype(np.float64)).ravel()
            tol = errors[q]["tol"].ravel()
            rel.append(tol[got > 1e-12] / got[got > 1e-12])
        rel = np.concatenate(rel)
        if len(rel):
            assert np.quantile(rel, 0.75) < (3e-2 if "beckmann 0.001" in name else 1e-3), name
        every.append(rel)
    every = np.concatenate(every)
    assert len(every) > 10000
    assert np.quantile(every, 0.5) < 3e-5 and np.quantile(every, 0.75) < 1e-4


# ---------------------------------------------------------------------------------------------------------
# Against physics

RECIPROCAL = {
    "diffuse": {"type": "diffuse", "reflectance": [0.2, 0.5, 0.8]},
    "roughconductor": {"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.1, "alpha_v": 0.4,
                       "eta": 0.2, "k": 3.9},
    "roughconductor beckmann": {"type": "roughconductor", "alpha": 0.3, "eta": 1.1, "k": 2.0},
    "plastic": {"type": "plastic", "diffuse_reflectance": [0.2, 0.5, 0.8], "nonlinear": True},
    "roughplastic": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "int_ior": 1.9, "ext_ior": 1.0},
    "roughdielectric": {"type": "roughdielectric", "distribution": "ggx", "alpha_u": 0.2, "alpha_v": 0.5,
                        "int_ior": 1.5, "ext_ior": 1.0},
}


@pytest.mark.parametrize("name", RECIPROCAL)
def test_reciprocity(name):
    """f(wo, wi) = f(wi, wo), with f = eval / |cos theta_i|, to 1e-9 at random pairs (a fifth or more of them
    nonzero). Refraction in radiance mode carries eta_ti^2 one way and not back: there eval(wo, wi) eta_i^2 /
    |cos theta_i| is symmetric, eta_i the index of wi's side (the generalised reciprocity of pbrt-v4 section
    9.5.2). Transposed, each expression fails by orders of magnitude."""
    rng = np.random.default_rng(RNG_SEED)
    wo, wi = sphere(rng, 4000), sphere(rng, 4000)
    b = ref.load_dict(RECIPROCAL[name])
    side = (lambda w: np.where(w[:, 2] > 0, 1.0, b.eta)) if name == "roughdielectric" else (lambda w: 1.0)
    forward = b.eval(wo, wi) * (side(wi) ** 2 / np.abs(wi[:, 2]))[:, None]
    backward = b.eval(wi, wo) * (side(wo) ** 2 / np.abs(wo[:, 2]))[:, None]
    nonzero = np.abs(forward).max(axis=1) > 0
    assert nonzero.mean() > 0.2
    np.testing.assert_allclose(forward, backward, rtol=1e-9, atol=0)
    if name == "roughdielectric":
        through = (wo[:, 2] * wi[:, 2] < 0) & nonzero
        plain_f, plain_b = (b.eval(a, c) / np.abs(c[:, 2])[:, None] for a, c in ((wo, wi), (wi, wo)))
        assert np.median(np.abs(plain_f[through, 0] / plain_b[through, 0] - 1)) > 0.5  # 1.5^2 / 1 apart


def test_the_delta_lobes_conserve_energy():
    """Smooth interfaces without absorption: the dielectric's lobes sum to 1 in flux (prob R + prob T, each
    weight over its radiance factor eta_ti^2), their radiance weights to R + T eta_ti^2; the thin slab's R' +
    T' = 1 and its R' is 2R / (1 + R); the default conductor (eta 0, k 1) is a perfect mirror, gold is not."""
    rng = np.random.default_rng(RNG_SEED)
    wo = sphere(rng, 3000)
    for eta in (1.5, 1 / 1.33):
        b = ref.Dielectric(int_ior=eta, ext_ior=1.0)
        refl, trans = b.delta_lobes(wo)
        r, _, _, eta_ti = ref.fresnel_dielectric(wo[:, 2], eta)
        np.testing.assert_allclose(refl.prob * refl.weight[:, 0] + trans.prob * trans.weight[:, 0] / eta_ti ** 2,
                                   1, rtol=1e-12)
        np.testing.assert_allclose(refl.prob, r, rtol=1e-12)
        np.testing.assert_allclose(trans.weight[trans.prob > 0, 0], eta_ti[trans.prob > 0] ** 2, rtol=1e-12)
        assert np.any(trans.prob == 0)  # total internal reflection, on the denser side
    thin = ref.ThinDielectric(int_ior=1.5, ext_ior=1.0)
    refl, null = thin.delta_lobes(wo)
    np.testing.assert_allclose(refl.prob + null.prob, 1, rtol=1e-12)
    r = ref.fresnel_dielectric(np.abs(wo[:, 2]), 1.5)[0]
    np.testing.assert_allclose(refl.prob, 2 * r / (1 + r), rtol=1e-12)
    np.testing.assert_array_equal(null.wi, -wo)
    up = wo[wo[:, 2] > 0]
    mirror = ref.Conductor().delta_lobes(up)[0]
    np.testing.assert_allclose(mirror.prob * mirror.weight[:, 0], 1, rtol=1e-12)
    gold = ref.Conductor(eta=[0.1431, 0.3749, 1.4425], k=[3.9831, 2.3857, 1.6032]).delta_lobes(up)[0]
    assert np.all(gold.weight < 1) and np.all(gold.weight[:, 0] > 0.9)


FURNACES = {
    "diffuse": ({"type": "diffuse", "reflectance": 1.0}, 1.0, 1e-9),
    "mirror-rough ggx 0.3": ({"type": "roughconductor", "distribution": "ggx", "alpha": 0.3}, None, 0),
    "mirror-rough beckmann 0.5": ({"type": "roughconductor", "alpha": 0.5}, None, 0),
    "rough glass ggx 0.3": ({"type": "roughdielectric", "distribution": "ggx", "alpha": 0.3, "int_ior": 1.5,
                             "ext_ior": 1.0}, None, 0),
    "white plastic": ({"type": "plastic", "diffuse_reflectance": 1.0}, 1.0, 2e-3),
    "white rough plastic": ({"type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
                             "diffuse_reflectance": 1.0}, None, 0),
}


@pytest.mark.parametrize("name", FURNACES)
def test_white_furnace(name):
    """Light that enters a white, lossless BSDF leaves it, all or some: the albedo (the integral of eval
    over the sphere by quadrature, plus the delta lobes' prob x weight; refraction counted in flux, its
    radiance factor eta_ti^2 divided out) is at most 1, and equals 1 for the Lambertian (1e-9) and smooth
    plastic (within 2e-3: Mitsuba's Fdr fit is 0.08 % off the integral at eta = 1.49, and 1 / (1 - Fdr)
    makes that 1.001 at most; exactly, the coat would return it all). The microfacet models lose what
    single scattering does not follow (masking), rough plastic also what its Riemann-mean R_int misses. The
    same albedo is the mean of sample()'s weights (4 standard errors): pdf() is sample()'s density."""
    plugin, expected, tol = FURNACES[name]
    b = ref.load_dict(plugin)
    dirs, weights = sphere_grid()
    rng = np.random.default_rng(RNG_SEED)
    for z in (0.9, 0.3, -0.5):
        wo = direction(z)
        value = b.eval(np.repeat(wo, len(dirs), 0), dirs)[:, 0]
        if isinstance(b, ref.RoughDielectric):
            eta_it = b.eta if z > 0 else 1 / b.eta
            flux = np.where(dirs[:, 2] * z < 0, value * eta_it ** 2, value)
        else:
            flux = value
        delta = sum(float(lobe.prob[0] * lobe.weight[0, 0]) for lobe in b.delta_lobes(wo))
        albedo = float(np.sum(flux * weights)) + delta
        assert albedo <= 1 + (tol or 1e-6), (z, albedo)
        if plugin["type"] not in ("roughdielectric",) and z < 0:
            assert albedo == 0  # one-sided: nothing below the horizon
        elif expected is not None:
            assert abs(albedo - expected) <= tol, (z, albedo)
        else:
            assert albedo > 0.4, (z, albedo)
        n = 30_000
        s = b.sample(np.repeat(wo, n, 0), rng.uniform(size=n), rng.uniform(size=(n, 2)))
        radiance = float(np.sum(value * weights)) + delta
        mean, sem = s.weight[:, 0].mean(), s.weight[:, 0].std() / math.sqrt(n)
        assert abs(mean - radiance) <= 4 * sem + 2e-3 * radiance, (z, mean, radiance)


PDFS = {
    "diffuse": {"type": "diffuse"},
    "roughconductor ggx aniso": {"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.2, "alpha_v": 0.6},
    "roughconductor beckmann not visible": {"type": "roughconductor", "alpha": 0.4, "sample_visible": False},
    "roughdielectric ggx": {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.4, "int_ior": 1.5,
                            "ext_ior": 1.0},
    "roughdielectric beckmann int < ext": {"type": "roughdielectric", "alpha": 0.3, "int_ior": 1.0, "ext_ior": 1.33},
    "plastic": {"type": "plastic", "diffuse_reflectance": [0.2, 0.5, 0.8]},
    "roughplastic": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "diffuse_reflectance": 0.3},
}


@pytest.mark.parametrize("name", PDFS)
def test_the_pdf_integrates_to_the_share_of_samples_that_carry_light(name):
    """The integral of pdf() over the sphere (quadrature) is the probability that sample() returns a
    non-delta direction that carries light: 1 for the Lambertian; 1 - p_spec for plastic (its delta lobe
    takes the rest); less than 1 for the microfacet models, whose sampled normals may reflect wo below the
    horizon or be invisible from the sampled direction (Mitsuba returns those with weight 0, and pdf() is 0
    there). The share is counted among 60 000 samples (4 standard errors), the quadrature good to 2e-3."""
    b = ref.load_dict(PDFS[name])
    dirs, weights = sphere_grid()
    rng = np.random.default_rng(RNG_SEED)
    for z in (0.8, 0.15, -0.6):
        wo = direction(z, phi=1.1)
        integral = float(np.sum(b.pdf(np.repeat(wo, len(dirs), 0), dirs) * weights))
        n = 60_000
        s = b.sample(np.repeat(wo, n, 0), rng.uniform(size=n), rng.uniform(size=(n, 2)))
        share = float(np.mean(~s.delta & (np.abs(s.weight).max(axis=1) > 0)))
        assert abs(integral - share) <= 4 * math.sqrt(share * (1 - share) / n) + 2e-3, (z, integral, share)
        if name == "diffuse":
            assert abs(integral - (z > 0)) < 1e-9
        if name == "plastic" and z > 0:
            p_spec = b.delta_lobes(wo)[0].prob[0]
            assert abs(integral - (1 - p_spec)) < 1e-9 and 0.02 < p_spec < 0.9


@pytest.mark.parametrize("name", [n for n in PDFS] + ["roughplastic ggx 0.001"])
def test_sample_returns_pdf_and_eval_over_pdf(name):
    """Where a glossy or diffuse sample carries light, sample()'s pdf is pdf() at the sampled direction and
    its weight eval() / pdf() there (1e-8, float64), Mitsuba's contract; for the lobe choices too (plastic's
    F-weighted choice, roughplastic's table-weighted one, roughdielectric's F(wo . m))."""
    plugin = PDFS.get(name, {"type": "roughplastic", "distribution": "ggx", "alpha": 0.001})
    b = ref.load_dict(plugin)
    rng = np.random.default_rng(RNG_SEED)
    wo = sphere(rng, 20000)
    s = b.sample(wo, rng.uniform(size=len(wo)), rng.uniform(size=(len(wo), 2)))
    carries = ~s.delta & (np.abs(s.weight).max(axis=1) > 0)
    assert carries.sum() > 2000
    np.testing.assert_allclose(s.pdf[carries], b.pdf(wo, s.wi)[carries], rtol=1e-8)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = b.eval(wo, s.wi) / b.pdf(wo, s.wi)[:, None]
    np.testing.assert_allclose(s.weight[carries], ratio[carries], rtol=1e-8)


def test_roughdielectric_weights_without_visible_normals_are_mitsubas():
    """With sample_visible = False, Mitsuba's roughdielectric samples normals from D cos with alpha widened by
    1.2 - 0.2 sqrt(|cos theta_o|) (Walter's trick) but returns the weight G (wo . m) / (cos theta_o cos
    theta_m) of the unwidened D: the D / D_widened factor is missing (roughdielectric.cpp, sample()), so its
    weight is not eval / pdf. The reference returns Mitsuba's weight (test_against_mitsuba checks it, case
    "roughdielectric beckmann 0.3 not visible"); the mean weight is then not the albedo."""
    b = ref.RoughDielectric("beckmann", 0.3, int_ior=1.5, ext_ior=1.0, sample_visible=False)
    rng = np.random.default_rng(RNG_SEED)
    wo = sphere(rng, 20000)
    s = b.sample(wo, rng.uniform(size=len(wo)), rng.uniform(size=(len(wo), 2)))
    carries = np.abs(s.weight).max(axis=1) > 0
    np.testing.assert_allclose(s.pdf[carries], b.pdf(wo, s.wi)[carries], rtol=1e-8)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = s.weight[carries, 0] / (b.eval(wo, s.wi)[carries, 0] / b.pdf(wo, s.wi)[carries])
    assert np.quantile(ratio, 0.05) < 0.95 and np.quantile(ratio, 0.95) > 1.05


@pytest.mark.parametrize("distribution, alpha, eta", [("beckmann", 0.1, 1.49 / 1.000277),
                                                      ("ggx", 0.3, 1.49 / 1.000277), ("beckmann", 0.5, 1 / 1.4)])
def test_roughplastic_tables_against_the_integral(distribution, alpha, eta):
    """roughplastic's tables, Mitsuba's quadrature reproduced, against an independent integral over the
    microfacet normals (bsdf_reference.rough_interface_albedo, converged to 1e-8): t(mu) within 2e-3 (the
    32^2 or 128^2 Gauss-Legendre nodes over the sampler's square are least accurate at grazing mu); R_int
    equals the 64-point mean of the integral's R(mu) within 3e-4, and that mean falls 0.5 % to 3 % below
    2 int_0^1 mu R(mu) dmu (split at the critical angle): Mitsuba's mean of equally spaced samples, ends
    included, is a biased rule."""
    t, r_int = ref.roughplastic_tables(distribution, alpha, eta)
    mu = np.maximum(1e-6, np.linspace(0, 1, ref.TABLE_SIZE))
    picked = np.array([2, 9, 20, 35, 50, 63])
    exact = ref.rough_interface_albedo(mu[picked], distribution, alpha, eta, "transmission", 192, 128)
    np.testing.assert_allclose(t[picked], exact, atol=2e-3)  # 1.74e-3 at mu = 0.127, Beckmann 0.1
    r = ref.rough_interface_albedo(mu, distribution, alpha, 1 / eta, "reflection", 96, 64)
    assert abs(r_int - 2 * np.mean(mu * r)) < 3e-4
    crit = math.sqrt(1 - eta ** 2) if eta < 1 else math.sqrt(1 - 1 / eta ** 2)  # TIR from inside: 1 / eta < 1
    x, w = ref.gauss_legendre(24)
    total = 0.0
    for lo, hi in ((0.0, crit), (crit, 1.0)):
        m = lo + (hi - lo) * (x + 1) / 2
        total += np.sum(w * (hi - lo) / 2 * 2 * m * ref.rough_interface_albedo(m, distribution, alpha, 1 / eta,
                                                                               "reflection", 96, 64))
    assert 0.005 < (total - r_int) / total < 0.03, (r_int, total)


def test_the_fits_mitsuba_uses():
    """Mitsuba's approximations, reproduced as they are, against the exact forms: the Fdr fits within 0.5 %
    of 2 int mu F(mu) dmu for eta in [1/2, 3] (0.42 % at 0.9, the worst); Walter et al.'s rational Beckmann G1
    within 0.35 % (their claim) of 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi)))."""
    for eta in (0.5, 1 / 1.5, 1 / 1.33, 0.9, 1.1, 1.33, 1.5, 2.0, 3.0):
        fit, exact = ref.fresnel_diffuse_reflectance(eta), ref.fresnel_diffuse_reflectance_exact(eta)
        assert abs(fit - exact) < 5e-3 * exact, eta
    a = np.linspace(0.01, 3, 3000)
    distr = ref.Microfacet("beckmann", 1.0)
    v = np.stack([np.ones_like(a), np.zeros_like(a), a], axis=-1) / np.sqrt(1 + a * a)[:, None]  # tan = 1 / a
    g1 = distr.smith_g1(v, np.broadcast_to([0.0, 0.0, 1.0], v.shape))
    np.testing.assert_allclose(g1, np.where(a >= 1.6, 1.0, g1), rtol=0)
    assert np.max(np.abs(g1 / ref.beckmann_g1_exact(a) - 1)) < 3.5e-3
