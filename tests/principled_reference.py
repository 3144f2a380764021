"""A float64 reference of Mitsuba 3's `principled` BSDF (v3.9.1: src/bsdfs/principled.cpp, principledhelpers.h;
Burley's "Physically Based Shading at Disney", 2012, and "Extending the Disney BRDF to a BSDF with Integrated
Subsurface Scattering", 2015), written from the plugin's source for tests/test_bsdf_principled.py and checked
there against Mitsuba's own values (tests/data/mitsuba_principled_values.npz, devtools/peers/mitsuba_principled.py).

Directions are Mitsuba's: in the local shading frame (z the outward normal), `wi` towards the viewer (raytrace's
wo) and `wo` towards the light (raytrace's wi), arrays (n, 3). A material is a dict of Mitsuba's parameter names
(PARAMETERS, with Mitsuba's defaults); `eta` None takes it from `specular`, as the plugin does. The plugin's
has_* flags (a parameter given and nonzero) are the parameters being nonzero: where they differ from Mitsuba's
they change nothing but the pdf inside a material without spec_trans, which the flag then follows as Mitsuba's
(its inside has no lobe but the main reflection there). Where Mitsuba divides 0 by 0 (the lobes' probabilities
inside an opaque material of eta 1, whose F is 0: no lobe at all) or meets a zero half vector, the reference
gives 0. flatness lerps the diffuse lobe towards Hanrahan and Krueger's fake subsurface where it is given and not 0
(Mitsuba's m_has_flatness; its lerp at flatness 0 is the diffuse itself, so the flag is the value's being nonzero).
The microfacet distribution and the dielectric Fresnel term are tests/bsdf_reference.py's (Mitsuba's
MicrofacetDistribution, GGX, visible normals; fresnel())."""
import numpy as np

import bsdf_reference as ref

PARAMETERS = {"base_color": (0.5, 0.5, 0.5), "roughness": 0.5, "anisotropic": 0.0, "metallic": 0.0, "spec_trans": 0.0,
              "eta": None, "specular": 0.5, "spec_tint": 0.0, "sheen": 0.0, "sheen_tint": 0.0, "flatness": 0.0,
              "clearcoat": 0.0, "clearcoat_gloss": 0.0, "main_specular_sampling_rate": 1.0,
              "clearcoat_sampling_rate": 1.0, "diffuse_reflectance_sampling_rate": 1.0}


def material(**given):
    """The parameters with Mitsuba's defaults, eta resolved (from specular unless given; 1.001 for 1, and
    specular 0 taken as 1e-3, where there is transmission), the main lobe's alphas and the clearcoat's."""
    assert set(given) <= set(PARAMETERS), f"not a parameter: {sorted(set(given) - set(PARAMETERS))}"
    p = dict(PARAMETERS, **given)
    p["base_color"] = np.broadcast_to(np.asarray(p["base_color"], float), (3,)).copy()
    transmits = p["spec_trans"] != 0
    if p["eta"] is None:
        s = 1e-3 if transmits and p["specular"] == 0 else p["specular"]
        p["eta"] = 2.0 / (1.0 - np.sqrt(0.08 * s)) - 1.0
    elif transmits and p["eta"] == 1:
        p["eta"] = 1.001
    r2 = p["roughness"] ** 2
    aspect = np.sqrt(1.0 - 0.9 * p["anisotropic"])
    p["alpha_u"], p["alpha_v"] = max(1e-3, r2 / aspect), max(1e-3, r2 * aspect)
    p["clearcoat_alpha"] = 0.1 + (0.001 - 0.1) * p["clearcoat_gloss"]
    return p


def dot(a, b):
    return np.sum(a * b, axis=-1)


def schlick_weight(c):
    m = np.clip(1.0 - c, 0.0, 1.0)
    return m**5


def schlick(r0, cos_i, eta):
    """calc_schlick: R0 + (1 - R0) Fw, Fw of |cos_i| where the incident side is the less dense, else of the
    refracted cosine. r0 (n,) or (n, 3)."""
    eta_it = np.where(cos_i >= 0, eta, 1.0 / eta)
    cos_t = np.sqrt(np.maximum(1.0 - (1.0 - cos_i**2) / eta_it**2, 0.0))
    w = np.where(eta_it > 1, schlick_weight(np.abs(cos_i)), schlick_weight(cos_t))
    w = w[:, None] if np.ndim(r0) == 2 else w
    return r0 + (1.0 - r0) * w


def gtr1(alpha, cos_h):
    a2 = alpha * alpha
    d = (a2 - 1.0) / (np.pi * np.log(a2) * (1.0 + (a2 - 1.0) * cos_h**2))
    return np.where(d * cos_h > 1e-20, d, 0.0)


def smith_ggx1(v, h, alpha):
    """principledhelpers.h's smith_ggx1 (the clearcoat's G1, alpha 0.25)."""
    c = np.abs(v[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = (1.0 - c * c) / (c * c)
        g = 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * t2))
    g = np.where(v[:, 2] == 1, 1.0, g)
    return np.where(dot(v, h) * v[:, 2] <= 0, 0.0, g)


def luminance(c):
    return 0.212671 * c[0] + 0.715160 * c[1] + 0.072169 * c[2]


def _common(p, wi, wo):
    ci, co = wi[:, 2], wo[:, 2]
    front = ci > 0
    reflect, refract = ci * co > 0, ci * co < 0
    eta = p["eta"]
    eta_path = np.where(front, eta, 1.0 / eta)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = wi + wo * np.where(reflect, 1.0, eta_path)[:, None]
        h = h / np.linalg.norm(h, axis=1, keepdims=True)
    h = h * np.where(h[:, 2] < 0, -1.0, 1.0)[:, None]
    s = np.where(ci < 0, -1.0, 1.0)[:, None]
    compat_r = (dot(wi, h * s) > 0) & (dot(wo, h * s) > 0)
    compat_t = (dot(wi, h * s) > 0) & (dot(wo, -h * s) > 0)
    f = ref.fresnel_dielectric(dot(wi, h), eta)[0]
    return ci, co, front, reflect, refract, eta_path, h, compat_r, compat_t, f


def unit_directions(v):
    """Whether every row of v is a unit vector within float32's rounding (what the tests draw)."""
    return bool(np.all(np.abs(np.linalg.norm(np.asarray(v, np.float64), axis=1) - 1.0) < 1e-5))


def eval_pdf(p, wi, wo):
    """(value with its cosine (n, 3), pdf (n,), {lobe: value (n, 3)}): Mitsuba's eval and pdf."""
    assert unit_directions(wi) and unit_directions(wo), "wi and wo must be unit vectors (float32 rounded)"
    k = p["base_color"]
    metallic, spec_trans, clearcoat, sheen = p["metallic"], p["spec_trans"], p["clearcoat"], p["sheen"]
    brdf, bsdf = (1 - metallic) * (1 - spec_trans), (1 - metallic) * spec_trans
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ci, co, front, reflect, refract, eta_path, h, compat_r, compat_t, f = _common(p, wi, wo)
        active = ci != 0
        distr = ref.Microfacet("ggx", p["alpha_u"], p["alpha_v"])
        d, g = distr.D(h), distr.G(wi, wo, h)
        lum = luminance(k)
        tint = k / lum if lum > 0 else np.ones(3)
        ih = dot(wi, h)
        eta_it = np.where(ih >= 0, p["eta"], 1.0 / p["eta"])
        r0 = ((eta_it - 1) / (eta_it + 1)) ** 2
        f_front = ((1 - metallic) * (1 - p["spec_tint"]) * f)[:, None] + metallic * schlick(
            np.broadcast_to(k, (len(f), 3)), ih, p["eta"]) + (1 - metallic) * p["spec_tint"] * schlick(
            tint * r0[:, None], ih, p["eta"])
        f_p = np.where(front[:, None], f_front, (bsdf * f)[:, None])
        on = active & reflect & compat_r & (f > 0)
        lobes = {"reflection": np.where(on[:, None], f_p * (d * g / (4 * np.abs(ci)))[:, None], 0.0)}
        oh = dot(wo, h)
        trans = bsdf * np.abs((1 - f) * d * g * ih * oh / (ci * (ih + eta_path * oh) ** 2))
        on = active & (bsdf > 0) & refract & compat_t & (f < 1)
        lobes["transmission"] = np.where(on[:, None], np.sqrt(k) * trans[:, None], 0.0)
        fcc = schlick(np.full(len(f), 0.04), ih, p["eta"])
        coat = clearcoat * 0.25 * fcc * gtr1(p["clearcoat_alpha"], h[:, 2]) * smith_ggx1(wi, h, 0.25) * \
            smith_ggx1(wo, h, 0.25) * np.abs(co)
        on = active & (clearcoat > 0) & reflect & compat_r & front
        lobes["clearcoat"] = np.where(on[:, None], coat[:, None] * np.ones(3), 0.0)
        fo, fi = schlick_weight(np.abs(co)), schlick_weight(np.abs(ci))
        rr = 2 * p["roughness"] * oh**2
        burley = (1 - 0.5 * fi) * (1 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1))
        if p["flatness"] != 0:  # Hanrahan-Krueger's fake subsurface, Fss90 flattening the retro-reflection
            fss = (1 + (rr / 2 - 1) * fo) * (1 + (rr / 2 - 1) * fi)
            f_ss = 1.25 * (fss * (1 / (np.abs(co) + np.abs(ci)) - 0.5) + 0.5)
            burley = burley + (f_ss - burley) * p["flatness"]
        diffuse = brdf * np.abs(co) / np.pi * burley
        diffuse_on = active & (brdf > 0) & reflect & front
        lobes["diffuse"] = np.where(diffuse_on[:, None], diffuse[:, None] * k, 0.0)
        c_sheen = 1 + p["sheen_tint"] * (tint - 1)
        sh = sheen * (1 - metallic) * schlick_weight(np.abs(oh)) * np.abs(co)
        on = diffuse_on & (sheen > 0) & (1 - metallic > 0)
        lobes["sheen"] = np.where(on[:, None], sh[:, None] * c_sheen, 0.0)
        value = sum(lobes.values())

        has_trans, has_coat = spec_trans != 0, clearcoat != 0
        rate = p["main_specular_sampling_rate"]
        ps = np.where(front, rate * (1 - bsdf * (1 - f)), f)
        pt = np.where(front, rate * bsdf * (1 - f), 1 - f) if has_trans else np.zeros_like(f)
        pc = np.where(front, 0.25 * clearcoat * p["clearcoat_sampling_rate"], 0.0) if has_coat else np.zeros_like(f)
        pd = np.where(front, brdf * p["diffuse_reflectance_sampling_rate"], 0.0)
        total = ps + pt + pc + pd
        ps, pt, pc, pd = ps / total, pt / total, pc / total, pd / total
        jac = np.abs(np.where(reflect, 1 / (4 * oh), eta_path**2 * oh / (ih + eta_path * oh) ** 2))
        up = wi * np.where(ci < 0, -1.0, 1.0)[:, None]
        visible = distr.pdf(up, h) * jac
        pdf = np.where(compat_r & reflect, ps * visible, 0.0)
        pdf = pdf + np.where(reflect, pd * co / np.pi, 0.0)
        pdf = pdf + np.where(compat_t & refract, pt * visible, 0.0)
        cc_pdf = np.where(h[:, 2] < 0, 0.0, h[:, 2] * gtr1(p["clearcoat_alpha"], h[:, 2]))
        pdf = pdf + np.where(compat_r & reflect, pc * cc_pdf * jac, 0.0)
    clean = lambda a: np.nan_to_num(np.where(active[:, None] if a.ndim == 2 else active, a, 0.0))  # noqa: E731
    value, pdf = clean(value), clean(pdf)
    assert np.all(pdf >= 0) and np.all(value >= 0), "a density and a value are never negative"
    return value, pdf, {name: clean(v) for name, v in lobes.items()}
