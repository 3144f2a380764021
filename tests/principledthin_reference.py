"""A float64 reference of Mitsuba 3's `principledthin` BSDF (v3.9.1: src/bsdfs/principledthin.cpp,
principledhelpers.h; Burley's "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering", 2015),
written from the plugin's source for tests/test_bsdf_principledthin.py and checked there against Mitsuba's own
values (tests/data/mitsuba_principledthin_values.npz, devtools/peers/mitsuba_principled.py --thin).

Directions are Mitsuba's: in the local shading frame, `wi` towards the viewer (raytrace's wo) and `wo` towards
the light (raytrace's wi), arrays (n, 3), either side (the sheet is the same from both: Mitsuba turns both
directions by the sign of wi's cosine). A material is a dict of Mitsuba's parameter names (PARAMETERS, with
Mitsuba's defaults). The plugin's has_* flags (a parameter given and nonzero) are the parameters being nonzero,
which changes nothing here: each flag only skips a term that is 0 without it. The Schlick terms, the luminance
and the Burley diffuse are tests/principled_reference.py's, the microfacet distribution and the dielectric
Fresnel term tests/bsdf_reference.py's (Mitsuba's MicrofacetDistribution, GGX, visible normals; fresnel())."""
import numpy as np

import bsdf_reference as ref
import principled_reference as pr

PARAMETERS = {"base_color": (0.5, 0.5, 0.5), "roughness": 0.5, "anisotropic": 0.0, "spec_trans": 0.0, "eta": 1.5,
              "spec_tint": 0.0, "sheen": 0.0, "sheen_tint": 0.0, "flatness": 0.0, "diff_trans": 0.0,
              "diffuse_reflectance_sampling_rate": 1.0, "specular_reflectance_sampling_rate": 1.0,
              "specular_transmittance_sampling_rate": 1.0, "diffuse_transmittance_sampling_rate": 1.0}
LOBES = ("reflection", "transmission", "diffuse", "sheen", "diffuse transmission")


def alphas(roughness, anisotropic):
    """calc_dist_params: roughness^2 over and times sqrt(1 - 0.9 anisotropic), at least 1e-3."""
    r2 = roughness**2
    aspect = np.sqrt(1.0 - 0.9 * anisotropic)
    return max(1e-3, r2 / aspect), max(1e-3, r2 * aspect)


def material(**given):
    """The parameters with Mitsuba's defaults, the reflection's alphas and the transmission's (of (0.65 eta -
    0.35) roughness)."""
    assert set(given) <= set(PARAMETERS), f"not a parameter: {sorted(set(given) - set(PARAMETERS))}"
    p = dict(PARAMETERS, **given)
    p["base_color"] = np.broadcast_to(np.asarray(p["base_color"], float), (3,)).copy()
    p["alpha_u"], p["alpha_v"] = alphas(p["roughness"], p["anisotropic"])
    p["trans_alpha_u"], p["trans_alpha_v"] = alphas((0.65 * p["eta"] - 0.35) * p["roughness"], p["anisotropic"])
    return p


def probabilities(p):
    """The lobes' sampling shares (reflection, transmission, diffuse reflection, diffuse transmission)."""
    st, dt = p["spec_trans"], p["diff_trans"] / 2
    shares = np.array([st * p["specular_reflectance_sampling_rate"] / 2,
                       st * p["specular_transmittance_sampling_rate"] / 2,
                       p["diffuse_reflectance_sampling_rate"] * (1 - st) * (1 - dt),
                       p["diffuse_transmittance_sampling_rate"] * (1 - st) * dt])
    return shares / shares.sum()


def eval_pdf(p, wi, wo):
    """(value with its cosine (n, 3), pdf (n,), {lobe: value (n, 3)}): Mitsuba's eval and pdf."""
    assert pr.unit_directions(wi) and pr.unit_directions(wo), "wi and wo must be unit vectors (float32 rounded)"
    k = p["base_color"]
    st, dt, eta = p["spec_trans"], p["diff_trans"] / 2, p["eta"]
    active = wi[:, 2] != 0
    s = np.where(wi[:, 2] < 0, -1.0, 1.0)[:, None]
    wi, wo = wi * s, wo * s
    ci, co = wi[:, 2], wo[:, 2]
    reflect, refract = co > 0, co < 0
    wo_r = wo * np.array([1.0, 1.0, 0.0]) + np.abs(wo * np.array([0.0, 0.0, 1.0]))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        h = wi + wo_r
        h = h / np.linalg.norm(h, axis=1, keepdims=True)
        ih, oh = pr.dot(wi, h), pr.dot(wo, h)
        compat_r = (ih > 0) & (oh > 0)
        compat_t = (ih > 0) & (oh < 0)
        f = ref.fresnel_dielectric(ih, eta)[0]
        lum = pr.luminance(k)
        tint = k / lum if lum > 0 else np.ones(3)
        f_s = pr.schlick(np.broadcast_to(tint * ((eta - 1) / (eta + 1)) ** 2, (len(f), 3)), ih, eta)
        f_thin = f[:, None] * (1 - p["spec_tint"]) + f_s * p["spec_tint"]
        distr = ref.Microfacet("ggx", p["alpha_u"], p["alpha_v"])
        trans = ref.Microfacet("ggx", p["trans_alpha_u"], p["trans_alpha_v"])
        lobes = {}
        on = active & (st > 0) & reflect & compat_r
        v = st * distr.D(h) * distr.G(wi, wo, h) / (4 * ci)
        lobes["reflection"] = np.where(on[:, None], f_thin * v[:, None], 0.0)
        on = active & (st > 0) & refract & compat_t
        v = st * (1 - f) * trans.D(h) * trans.G(wi, wo, h) / (4 * ci)
        lobes["transmission"] = np.where(on[:, None], k * v[:, None], 0.0)
        fo, fi = pr.schlick_weight(np.abs(co)), pr.schlick_weight(ci)
        rr = 2 * p["roughness"] * oh**2
        burley = (1 - 0.5 * fi) * (1 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1))
        fss = (1 + (rr / 2 - 1) * fo) * (1 + (rr / 2 - 1) * fi)
        f_ss = 1.25 * (fss * (1 / (np.abs(co) + np.abs(ci)) - 0.5) + 0.5)
        diffuse = (1 - st) * co * (1 - dt) / np.pi * (burley + (f_ss - burley) * p["flatness"])
        diffuse_on = active & reflect & (st < 1) & (dt < 1)
        lobes["diffuse"] = np.where(diffuse_on[:, None], diffuse[:, None] * k, 0.0)
        c_sheen = 1 + p["sheen_tint"] * (tint - 1)
        sh = p["sheen"] * (1 - st) * pr.schlick_weight(np.abs(oh)) * (1 - dt) * np.abs(co)
        lobes["sheen"] = np.where((diffuse_on & (p["sheen"] > 0))[:, None], sh[:, None] * c_sheen, 0.0)
        through = (1 - st) * dt / np.pi * np.abs(co)
        lobes["diffuse transmission"] = np.where((active & refract & (st < 1) & (dt > 0))[:, None],
                                                 through[:, None] * k, 0.0)
        value = sum(lobes.values())

        ps, pt, pdr, pdt = probabilities(p)
        jac = np.abs(1 / (4 * pr.dot(wo_r, h)))
        pdf = np.zeros(len(f))
        if st > 0:
            pdf = pdf + np.where(compat_r & reflect, ps * distr.pdf(wi, h) * jac, 0.0)
            pdf = pdf + np.where(compat_t & refract, pt * trans.pdf(wi, h) * jac, 0.0)
        pdf = pdf + np.where(reflect, pdr * co / np.pi, 0.0) + np.where(refract, pdt * -co / np.pi, 0.0)
    clean = lambda a: np.nan_to_num(np.where(active[:, None] if a.ndim == 2 else active, a, 0.0))  # noqa: E731
    value, pdf = clean(value), clean(pdf)
    assert np.all(pdf >= 0) and np.all(value >= 0), "a density and a value are never negative"
    return value, pdf, {name: clean(v) for name, v in lobes.items()}
