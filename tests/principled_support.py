"""What the principled BSDFs' tests share (tests/test_bsdf_principled.py, tests/test_bsdf_principledthin.py): the
random shading points and directions of their eval tests, the relative errors float32 cannot avoid in GGX's D
and in the dielectric Fresnel term (their tolerances' conditioning terms), and the checks both make: the float64
reference against Mitsuba's recorded values, the kernel against the reference, the samples' weights and
directions, reciprocity, the furnace, the scene file's round trip through Mitsuba XML."""
import numpy as np

from devtools.chi_square import SIGNIFICANCE, cell_integrals, chi_square
from helpers import ROOT

U = 2.0**-24  # float32's unit roundoff


def f32(v):
    return np.asarray(v, np.float32).astype(np.float64)


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def local(fr, v):
    return np.einsum("nij,nj->ni", fr, v)


def random_case(rng, count, rows):
    """Normals, tangents (orthogonal to them), backface flags (a quarter), viewers wo on the normal's side (1/8
    below it: a shading normal's), wi: half uniform on the sphere, a quarter within 2e-3 of wo's mirror image
    and a quarter of its refraction by eta 1.5 or 1 / 1.5 (where narrow lobes lie); material rows; u."""
    n = unit(rng.normal(size=(count, 3)))
    t = unit(np.cross(n, rng.normal(size=(count, 3))))
    wo = unit(rng.normal(size=(count, 3)))
    side = np.where(rng.uniform(size=count) < 0.125, -1.0, 1.0)
    wo *= (np.sign(np.sum(wo * n, axis=1)) * side)[:, None]
    c = np.sum(wo * n, axis=1)[:, None]
    mirror = 2 * c * n - wo
    eta = np.where(rng.uniform(size=(count, 1)) < 0.5, 1.5, 1 / 1.5)
    sin2 = (1 - c * c) / eta**2
    refracted = -wo / eta + (c / eta - np.sign(c) * np.sqrt(np.maximum(1 - sin2, 0))) * n
    wi = unit(rng.normal(size=(count, 3)))
    pick = rng.uniform(size=count)
    wi = np.where((pick < 0.25)[:, None], mirror, np.where((pick < 0.5)[:, None], refracted, wi))
    wi = unit(wi + rng.normal(scale=2e-3, size=wi.shape) * (pick < 0.5)[:, None])
    backface = (rng.uniform(size=count) < 0.25).astype(np.int32)
    return f32(n), f32(unit(t - np.sum(t * n, axis=1)[:, None] * n)), backface, f32(wo), f32(wi), \
        rng.choice(rows, count), rng.uniform(size=(count, 3))


def d_conditioning(p, lh, anisotropic):
    """The relative error of an isotropic build's GGX D that float32 cannot avoid (tests/test_bsdf_roughplastic.py's
    d_conditioning): from cos^2(theta_h) alone, within 32 U, D moves by 2 |1 - alpha^2| dc / (c (alpha^2 - 1) +
    1); at roughness 0's alpha 1e-3 that is 4 at the peak. The anisotropic build's D, from h's x and y, does
    not cancel."""
    if anisotropic:
        return np.zeros(len(lh))
    a2 = p["alpha_u"] ** 2
    c = np.minimum(lh[:, 2] ** 2, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(2 * abs(1 - a2) / (c * (a2 - 1) + 1) * 32 * U)


def fresnel_conditioning(p, lo, h):
    """The relative error of the dielectric Fresnel reflectance in float32 near eta = 1: its amplitudes'
    numerators eta c - c_t and c - eta c_t (c = |wo . h|, c_t the refracted cosine) cancel, each term carrying
    some 8 U of its size (the cosines' roundings, sqrt(1 - sin^2 / eta^2)), doubled by the square: 16 U (c + c_t)
    (1 / |eta c - c_t| + 1 / |c - eta c_t|). At eta 1.001 (Mitsuba's for 1 with transmission) F is 2.5e-7 and
    this some 1e-2; at 1.5, 1e-6. On the main reflection (F) and the pdf (its reflection's share, F inside or
    with spec_trans 1)."""
    c = np.abs(np.sum(lo * h, axis=1))
    eta = np.where(np.sum(lo * h, axis=1) >= 0, p["eta"], 1 / p["eta"])
    ct = np.sqrt(np.maximum(1 - (1 - c * c) / eta**2, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = 16 * U * (c + ct) * (1 / np.abs(eta * c - ct) + 1 / np.abs(c - eta * ct))
    return np.nan_to_num(rel, posinf=0.0)


def plugin_parameters(plugin):
    return {k: (np.array(v["value"]) if isinstance(v, dict) else v) for k, v in plugin.items() if k != "type"}


def mitsuba_worst(cases, material, tolerance, rng, kept_share):
    """The reference's eval and pdf against Mitsuba's recorded values (devtools/peers/mitsuba_bsdf.py's fields),
    and its pdf and weight (eval / pdf) at the directions Mitsuba's sampler drew, each within `tolerance(p, wo,
    wi, rng, anisotropic=True)` (the reference's (f, pdf, tol_f, tol_p); Mitsuba's D takes m's x and y); a
    sample Mitsuba refuses has weight 0 (its pdf may be the direction's all the same) and is left out, at most
    1 - kept_share of a case's. `material(**parameters)` is the reference's material of a plugin's parameters.
    Returns the largest error over its tolerance."""
    worst = 0.0
    for name, plugin, v in cases:
        p = material(**plugin_parameters(plugin))
        wi, wo = v["wo"].astype(float), v["wi"].astype(float)  # Mitsuba's si.wi (the viewer) is the fixture's wo
        f, pdf, tol_f, tol_p = tolerance(p, wi, wo, rng, anisotropic=True)
        ex_f = np.abs(f - v["eval"]) / tol_f
        ex_p = np.abs(pdf - v["pdf"]) / tol_p
        ok = (v["s_pdf"] > 0) & np.any(v["s_weight"] != 0, axis=1)  # a refused sample: weight 0 (its pdf may not be)
        sf, sp, tol_sf, tol_sp = tolerance(p, wi[ok], v["s_wi"][ok].astype(float), rng, anisotropic=True)
        ex_sp = np.abs(sp - v["s_pdf"][ok]) / tol_sp
        weight = sf / sp[:, None]
        tol_w = (tol_sf + np.abs(weight) * tol_sp[:, None]) / sp[:, None]
        ex_w = np.abs(weight - v["s_weight"][ok]) / tol_w
        for what, ex in (("eval", ex_f), ("pdf", ex_p), ("s_pdf", ex_sp), ("s_weight", ex_w)):
            assert np.all(ex <= 1), (name, what, float(np.max(ex)), int(np.argmax(np.max(np.atleast_2d(ex.T), 0))))
            worst = max(worst, float(np.max(ex)))
        assert ok.mean() > kept_share, (name, ok.mean())
    return worst


def check_against_reference(out, ref_f, ref_p, tol_f, tol_p, which, lo, li):
    """The kernel's f and pdf (`out`) within the reference's tolerances on every lane; most lanes with a value and
    a density, and the transmission exercised (over 100 lanes through the surface with a value above 1e-3)."""
    ex_f = np.max(np.abs(out["f"] - ref_f) / tol_f, axis=1)
    ex_p = np.abs(out["pdf"] - ref_p) / tol_p
    assert np.all(ex_f <= 1), (np.max(ex_f), np.argmax(ex_f), which[np.argmax(ex_f)])
    assert np.all(ex_p <= 1), (np.max(ex_p), np.argmax(ex_p), which[np.argmax(ex_p)])
    assert np.mean(ref_p > 0) > 0.5 and np.mean(np.any(ref_f > 0, axis=1)) > 0.5
    through = lo[:, 2] * li[:, 2] < 0
    assert np.sum(through & (ref_f[:, 0] > 1e-3)) > 100  # the transmission is exercised


def check_sample_weights(out, n, wo, valid_share, transmitted):
    """A sample's pdf is bsdf_pdf's at its direction and its weight eval / pdf, within 2e-5 relatively (plus
    1e-7); a sample without a density has weight 0; transmit is set exactly where wi crosses the surface. At
    least valid_share of the samples valid and `transmitted` of them transmitted."""
    valid = out["s_pdf"] > 0
    assert valid.mean() > valid_share, valid.mean()
    np.testing.assert_allclose(out["s_pdf"][valid], out["s_eval_pdf"][valid], rtol=2e-5)
    np.testing.assert_allclose(out["s_weight"][valid] * out["s_pdf"][valid, None], out["s_f"][valid], rtol=2e-5,
                               atol=1e-7)
    assert np.all(out["s_weight"][~valid] == 0)
    crosses = np.sum(out["s_wi"] * n, axis=1) * np.sum(wo * n, axis=1) < 0
    assert np.array_equal(out["s_transmit"][valid] == 1, crosses[valid])
    assert np.sum(out["s_transmit"]) > transmitted


def check_reciprocity(out, n, wo, wi):
    """eval(wo, wi) cos_o == eval(wi, wo) cos_i (out's f and f_swapped) where both lie above the normal, within
    2e-4 relatively plus 1e-6, away from the mirror direction (cosine 0.999: the narrow lobes' condition)."""
    co, ci = np.sum(wo * n, axis=1), np.sum(wi * n, axis=1)
    mirror = np.sum((2 * co[:, None] * n - wo) * wi, axis=1) > 0.999
    keep = (co > 0) & (ci > 0) & ~mirror
    assert keep.sum() > 1000
    a, b = out["f"][keep] * co[keep, None], out["f_swapped"][keep] * ci[keep, None]
    np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6)


def check_chi_square(out, density):
    """The valid samples' directions (out's s_wi where s_pdf > 0) against density(cos_theta, phi) renormalised
    over 16 x 32 cells, its mass the share of samples kept (within 5 binomial standard errors plus 2e-3, the
    quadrature's error of the mass), and Pearson's chi-square above devtools/chi_square.py's SIGNIFICANCE."""
    valid = out["s_pdf"] > 0
    mass = cell_integrals(density, np.linspace(-1, 1, 17), np.linspace(0, 2 * np.pi, 33)).sum()
    pval, stat, total = chi_square(out["s_wi"][valid], lambda c, phi: density(c, phi) / mass)
    kept = min(mass, 1.0)
    assert abs(valid.mean() - mass) <= 5 * np.sqrt(kept * (1 - kept) / len(valid)) + 2e-3, (valid.mean(), mass)
    assert pval > SIGNIFICANCE, (pval, stat, total)


def furnace_means(sample, reference, bound, rng, m=1 << 15):
    """The albedo from one wo at 6 angles from 0 to 85 degrees: the mean of the kernel's sample weights (green)
    over m samples (`sample(wo, u)`: the kernel's outputs s_wi, s_weight, s_pdf), against the reference's
    integral of eval estimated with the reference's own density at the kernel's directions (`reference(wo, wi)`:
    its (f, pdf)), within 5 standard errors of the difference plus 1e-4 of it, and at most `bound` (within 5
    standard errors) unless None. Returns the 6 means."""
    means = []
    for theta_o in np.radians([0, 20, 40, 60, 75, 85]):
        wo = np.repeat(f32([[np.sin(theta_o), 0.0, np.cos(theta_o)]]), m, axis=0)
        out = sample(wo, rng.uniform(size=(m, 3)))
        w = out["s_weight"][:, 1]
        valid = out["s_pdf"] > 0
        f, pdf = reference(wo[valid], out["s_wi"][valid])
        ref = np.zeros(m)
        ref[valid] = f[:, 1] / pdf
        diff = w - ref
        se = max(diff.std(ddof=1) / np.sqrt(m), 1e-7)
        assert abs(diff.mean()) <= 5 * se + 1e-4 * abs(ref.mean()), (theta_o, w.mean(), ref.mean(), se)
        mean, se_w = w.mean(), w.std(ddof=1) / np.sqrt(m)
        means.append(mean)
        if bound is not None:
            assert mean <= bound + 5 * se_w, (theta_o, mean, se_w)
    assert max(means) > 0.01
    return means


def xml_round_trip(tmp_path, toml_extra):
    """The Cornell box with `toml_extra` (materials and shapes) loaded, written as Mitsuba XML (beside its meshes)
    and read back with warnings as errors: (scene, the scene read back, the XML's text, the TOML's path)."""
    import warnings

    import raytrace
    from raytrace.scene.mitsuba_writer import to_xml
    toml = tmp_path / "cornell_box.toml"
    toml.write_text((ROOT / "scenes" / "cornell_box.toml").read_text().replace('"../assets/', f'"{ROOT / "assets"}/')
                    + toml_extra)
    scene = raytrace.load_file(toml)
    (tmp_path / "out").mkdir()
    text, extra = to_xml(scene, tmp_path / "out" / "scene.xml")
    (tmp_path / "out" / "scene.xml").write_text(text)
    for name, data in extra.items():  # the box's meshes
        (tmp_path / "out" / name).write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = raytrace.load_file(tmp_path / "out" / "scene.xml")
    return scene, back, text, toml


def eval_case(cache, anisotropic, seed, rows, table, references, frames, tolerance, count=4096):
    """An eval test's lanes, computed once per build (cache[anisotropic]) for every lane width: random_case's
    of the material rows `rows` (seed + anisotropic), in the local frames `frames(n, t, backface, which)` (rows
    x, y, z), with the references and tolerances of `tolerance(p, lo, li, rng, anisotropic)` for each row's
    reference material references[row]: (table, (n, t, backface, wo, wi, which, u), (ref_f, ref_p, tol_f,
    tol_p), lo, li)."""
    if anisotropic not in cache:
        rng = np.random.default_rng(seed + anisotropic)
        n, t, backface, wo, wi, which, u = random_case(rng, count, rows)
        fr = frames(n, t, backface, which)
        lo, li = local(fr, wo), local(fr, wi)
        ref_f, ref_p = np.zeros((len(n), 3)), np.zeros(len(n))
        tol_f, tol_p = np.zeros((len(n), 3)), np.zeros(len(n))
        for j in rows:
            s = which == j
            ref_f[s], ref_p[s], tol_f[s], tol_p[s] = tolerance(references[j], lo[s], li[s], rng, anisotropic)
        cache[anisotropic] = (table, (n, t, backface, wo, wi, which, u), (ref_f, ref_p, tol_f, tol_p), lo, li)
    return cache[anisotropic]
