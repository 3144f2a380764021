"""Float64 references of Mitsuba 3's BSDFs (v3.9.1, RGB mode, TransportMode::Radiance), in numpy: what the
kernel's bsdf_eval / bsdf_sample / bsdf_pdf must reproduce. A test support module (no test module is
imported here; numpy and scipy only); tests/test_bsdf_reference.py checks it against values Mitsuba itself
computed (tests/data/mitsuba_bsdf_values.npz, recorded by devtools/peers/mitsuba_bsdf.py).

Frame and names
---------------
Every direction is a unit vector in the LOCAL shading frame: z is the shading normal, x the tangent (alpha_u's
axis), y the bitangent (alpha_v's). Arrays of directions have shape (n, 3).

  wo  the direction towards the viewer (the camera end of the path): Mitsuba's ``si.wi``;
  wi  the direction towards the light / the next vertex: Mitsuba's ``wo`` argument of eval() and pdf(), and
      the ``bs.wo`` that sample() returns.

So ``bsdf.eval(ctx, si, wo=X)`` with ``si.wi = Y`` in Mitsuba is ``eval(wo=Y, wi=X)`` here. The index of
refraction eta = int_ior / ext_ior: the normal points into the exterior (eta > 1: out of the denser medium).

What each BSDF gives
--------------------
``B = load_dict({"type": "roughconductor", "alpha": 0.1, ...})`` or ``B = RoughConductor(alpha=0.1, ...)``
(Mitsuba's plugin names, parameters and defaults; an RGB parameter is a float, three floats, or Mitsuba's
``{"type": "rgb", "value": [...]}``), then

  ``B.eval(wo, wi) -> (n, 3)``   f(wo, wi) * |cos theta_i| (Mitsuba's eval includes the cosine of wi), RGB;
                                  0 for the delta lobes;
  ``B.pdf(wo, wi) -> (n,)``      the solid-angle density of wi under B.sample(wo, ...), its non-delta parts
                                  (the lobe choice probabilities included), Mitsuba's pdf();
  ``B.delta_lobes(wo) -> [Lobe]`` for each delta lobe: its direction wi (n, 3), the probability ``prob`` (n,)
                                  with which sample() picks it and its ``weight`` (n, 3) = f cos / prob (what
                                  sample() returns); ``prob * weight`` is the lobe's coefficient. Where prob
                                  is 0 (total internal reflection, wo below a one-sided surface) wi and
                                  weight are 0. An empty list for BSDFs without delta lobes;
  ``B.sample(wo, u1, u2) -> Sample``  Mitsuba's sample() with the same random numbers (u1 (n,), u2 (n, 2)):
                                  wi, pdf (solid-angle density, or the discrete probability where ``delta``),
                                  weight = f cos / pdf, the component index Mitsuba reports, and ``valid``
                                  (False where Mitsuba masks the sample: weight 0, wi and pdf meaningless).

and the functional forms ``bsdf_eval(d, wo, wi)``, ``bsdf_pdf(d, wo, wi)``, ``bsdf_sample(d, wo, u1, u2)``,
``bsdf_delta_lobes(d, wo)`` with ``d`` the plugin's dict. The parts: ``Microfacet`` (D, smith_g1, G, pdf,
sample), ``fresnel_dielectric``, ``fresnel_conductor``, ``fresnel_diffuse_reflectance`` (and ``_exact``),
``beckmann_g1_exact``, ``roughplastic_tables`` and ``rough_interface_albedo``; for the tests, ``precision``
(the same formulas in float32) and ``mitsuba_errors`` (a recording of Mitsuba's values against these, with
each value's tolerance).

Mitsuba's conventions reproduced here (and what surprised us)
------------------------------------------------------------
* One-sided BSDFs (diffuse, conductor, roughconductor, plastic, roughplastic) give 0 (eval, pdf, sample) when
  wo or wi is below the horizon: there is no two-sided flip inside the plugin (Mitsuba's ``twosided`` adds it).
  The dielectrics are two-sided: wo.z < 0 means the viewer is inside, and eta is inverted.
* Radiance mode: a refracted sample's weight, and roughdielectric's transmission eval, carry the factor
  eta_ti^2 = (eta of the side wo is on / eta of wi's side)^2 (the "solid angle compression"; Mitsuba's
  roughdielectric.cpp: "Missing term in the original paper"). So the transmission is not reciprocal; with
  eta_wo, eta_wi the indices of the sides, eval(wo, wi) * eta_wi^2 / |cos_i| is symmetric in (wo, wi).
* Microfacet G is the separable Smith G1(wo, m) G1(wi, m) (MicrofacetDistribution::G), not the
  height-correlated form; Beckmann's G1 is Walter et al.'s rational fit (<0.35 % off the exact erf form,
  which is ``beckmann_g1_exact`` here). D(m) is 0 where D(m) cos theta_m <= 1e-20 (Mitsuba's guard) and the
  roughness is clamped to alpha >= 1e-4.
* roughdielectric picks reflection or refraction with probability F(wo . m) of the sampled microfacet normal
  m (Walter et al. 2007, section 5.3), samples m from the visible normals of wo flipped to the upper side, and
  computes the generalised half vector m = normalize(wo + eta wi) flipped to the upper side.
* plastic and roughplastic steer samples with ``specular_sampling_weight`` = s / (d + s), d and s the mean of
  the diffuse and specular reflectance's RGB values; plastic's lobe choice uses F(cos theta_o), roughplastic's
  the table of the rough interface's transmittance (1 - t(cos theta_o)).
* roughplastic's diffuse term ``diff / (1 - R_int) * t(mu_o) t(mu_i) cos_i / (pi eta^2)`` uses two values
  Mitsuba precomputes when the plugin is built (roughplastic.cpp, parameters_changed; the microfacet header's
  eval_transmittance / eval_reflectance), reproduced by ``roughplastic_tables``:
    - t(mu), 64 values at mu = max(1e-6, linspace(0, 1, 64)), then linear interpolation: the rough
      interface's transmittance E_{m ~ D_wi}[(1 - F(wi . m)) G1(wt, m)], wt the refracted direction, by a
      tensor Gauss-Legendre rule (32 x 32 nodes if eta > 1, else 128 x 128) over the unit square that Mitsuba's
      visible-normal sampler maps to m (so the quadrature follows the sampler's warp, Beckmann's Newton
      iterations included);
    - R_int, the internal diffuse reflectance: 2 * mean over the same 64 mu of mu * R(mu), R the rough
      interface's reflectance seen from inside (eta -> 1/eta), same quadrature. A plain mean of 64 equally
      spaced samples, endpoints included, is not 2 int_0^1 mu R(mu) dmu: it is (63/64) times the trapezoid
      rule plus (mu R)(1)/64, 1.4 % to 1.8 % below the integral at eta = 1.49 (0.6 % at eta = 1/1.4;
      ``rough_interface_albedo`` gives the integral, the tests measure the gap).
  The tables ignore ``sample_visible``: they always integrate over visible normals. The Gauss-Legendre rule
  over the sampler's square is itself within 2e-3 of the integral (least accurate at grazing mu).
* roughdielectric with sample_visible = False samples from D cos with alpha widened by Walter's factor 1.2 -
  0.2 sqrt(|cos theta_o|), and its pdf() says so, but sample()'s weight G (wo . m) / (cos_o cos_m) is that of
  the unwidened D: the factor D / D_widened is missing, so that weight is not eval / pdf (by 0.7x to 10x).
  sample() here returns Mitsuba's weight. Everywhere else sample()'s weight is eval / pdf at wi.
* sample() keeps the pdf of a sample it masks with weight 0 (a microfacet normal that the sampled direction
  cannot see, a reflection below the horizon); pdf() is 0 at such a direction.
* In float32 Mitsuba's visible-normal sampler takes tan theta of the stretched direction from its z (near 1
  for small alpha), so one ULP of that z moves a Beckmann alpha = 0.001 sample's pdf by up to 7e-4.
* plastic's internal diffuse reflectance is d'Eon and Irving's fit (2011) of Fdr(1/eta) (Egan and Hilgeman's
  for eta < 1), Mitsuba's fresnel_diffuse_reflectance; ``fdr_ext`` is computed but unused by Mitsuba.
* thindielectric reflects R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R) (the interreflections of a thin slab,
  R = F(|cos theta_o|, eta), T = 1 - R) and transmits 1 - R' straight through (wi = -wo); eta < 1 gives R' = 1
  past the critical angle.
* conductor's Fresnel term is the complex Fresnel reflectance of eta + i k (Mitsuba: fresnel_conductor,
  Moeller's real form; here from the complex amplitudes r_s, r_p, Born and Wolf section 14.2). The defaults
  eta = 0, k = 1 are a perfect mirror; Mitsuba's named ``material`` presets are not read here.

References
----------
* Mitsuba 3 v3.9.1: src/bsdfs/{diffuse,conductor,roughconductor,dielectric,thindielectric,roughdielectric,
  plastic,roughplastic}.cpp and the headers microfacet, fresnel, ior (include/mitsuba/render/) and warp
  (include/mitsuba/core/), https://github.com/mitsuba-renderer/mitsuba3/tree/v3.9.1.
* B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet Models for Refraction through Rough Surfaces",
  EGSR 2007 (D, G1, the generalised half vector, the Jacobians, Beckmann's rational G1).
* E. Heitz, E. d'Eon, "Importance Sampling Microfacet-Based BSDFs using the Distribution of Visible Normals",
  EGSR 2014; E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018 (and "A Simpler and
  Exact Sampling Routine for the GGX Distribution of Visible Normals", 2017); W. Jakob, "An Improved Visible
  Normal Sampling Routine for the Beckmann Distribution", 2014.
* E. d'Eon, G. Irving, "A Quantized-Diffusion Model for Rendering Translucent Materials", SIGGRAPH 2011 (the
  Fdr fit); W. Egan, T. Hilgeman, "Optical Properties of Inhomogeneous Materials", 1979.
* M. Pharr, W. Jakob, G. Humphreys, "Physically Based Rendering", 4th ed. (pbrt-v4), sections 9.3-9.7 (the
  Fresnel equations, the generalised half vector, the eta^2 radiance scaling).
"""
import contextlib
import functools
import math
from collections import namedtuple

import numpy as np
from scipy import special

# Mitsuba's named indices of refraction (its ior header), for int_ior / ext_ior given as names.
IOR = {"vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277, "carbon dioxide": 1.00045,
       "water": 1.3330, "acetone": 1.36, "ethanol": 1.361, "carbon tetrachloride": 1.461, "glycerol": 1.4729,
       "benzene": 1.501, "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
       "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
       "amber": 1.55, "pet": 1.5750, "diamond": 2.419}

ULP = 2.0 ** -24  # float32's unit roundoff: a correctly rounded float32 operation is off by at most this, relatively

# roughplastic.cpp's MI_ROUGH_TRANSMITTANCE_RES: the number of mu values of the transmittance table.
TABLE_SIZE = 64

Lobe = namedtuple("Lobe", "kind component wi prob weight")
Sample = namedtuple("Sample", "wi pdf weight component delta valid")

_REAL = [np.float64]


def real():
    """The floating-point type the reference computes in: float64, or float32 inside ``precision(np.float32)``."""
    return _REAL[0]


@contextlib.contextmanager
def precision(dtype):
    """Compute in `dtype` (BSDFs built, and called, inside the block): with np.float32, the same formulas in
    float32 arithmetic, whose distance from the float64 values estimates the rounding error a float32
    implementation makes at each point (the cancellation in 1 - F at grazing angles, the sums of the
    roughplastic tables), for the tests' tolerances. Every array op keeps the type (numpy's NEP 50 rules:
    Python floats adapt to the array's type)."""
    _REAL.insert(0, dtype)
    try:
        yield
    finally:
        _REAL.pop(0)


# ----------------------------------------------------------------------------------------------------------
# Vectors, colours, warps

def dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def normalize(v):
    """v / |v|, as drjit forms it: v * (1 / sqrt(v . v)) (in float32 that rounds as Mitsuba does)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return v * (1.0 / np.sqrt(dot(v, v)))[..., None]


def mulsign(a, b):
    """a with its sign flipped where b's sign bit is set (drjit's mulsign: -0 counts as negative)."""
    return np.where(np.signbit(b), -a, a)


def _dirs(v):
    v = np.asarray(v, real())
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"directions must have shape (n, 3), not {v.shape}")
    return v


def rgb(value):
    """A colour parameter as 3 floats: a float, 3 floats, or {"type": "rgb", "value": ...}."""
    if isinstance(value, dict):
        if value.get("type") not in ("rgb", "spectrum"):
            raise ValueError(f"only rgb colours are supported, not {value!r}")
        value = value["value"]
    v = np.asarray(value, real()).ravel()
    if v.size == 1:
        v = np.repeat(v, 3)
    if v.size != 3:
        raise ValueError(f"a colour has 1 or 3 values, not {value!r}")
    return v


def ior(value):
    return IOR[value.lower()] if isinstance(value, str) else float(value)


def reflect(w):
    """Mirror reflection about the normal (local frame): (-x, -y, z)."""
    return w * np.array([-1.0, -1.0, 1.0], w.dtype)


def reflect_about(w, m):
    """Reflection of w about the unit normal m: 2 (w . m) m - w."""
    return 2.0 * dot(w, m)[:, None] * m - w


def refract_about(w, m, cos_t, eta_ti):
    """Refraction of w through a facet of normal m (pbrt-v4 section 9.3; Mitsuba's refract): the transmitted
    direction, given cos_t (signed, on the far side) and eta_ti = eta of w's side / eta of the far side."""
    return m * (dot(w, m) * eta_ti + cos_t)[:, None] - w * np.asarray(eta_ti)[..., None]


def square_to_uniform_disk_concentric(u):
    """Shirley and Chiu's concentric map of [0, 1]^2 onto the unit disk, in Mitsuba's branch-free form
    (its warp header): the same point for the same u, so sampled directions match Mitsuba's."""
    x, y = 2.0 * u[:, 0] - 1.0, 2.0 * u[:, 1] - 1.0
    q13 = np.abs(x) < np.abs(y)
    r, rp = np.where(q13, y, x), np.where(q13, x, y)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = 0.25 * np.pi * rp / r
    phi = np.where(q13, 0.5 * np.pi - phi, phi)
    phi = np.where((x == 0) & (y == 0), 0.0, phi)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def square_to_cosine_hemisphere(u):
    p = square_to_uniform_disk_concentric(u)
    return np.stack([p[:, 0], p[:, 1], np.sqrt(np.maximum(0.0, 1.0 - dot(p, p)))], axis=-1)


# ----------------------------------------------------------------------------------------------------------
# Fresnel

def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance of a dielectric interface (pbrt-v4 eq. 9.4; Mitsuba's fresnel()).
    cos_i is signed: < 0 means w is on the interior side, and the relative index flips to 1 / eta. Returns
    (F, cos_t, eta_it, eta_ti): cos_t the signed cosine of the refracted direction (on the side opposite w,
    0 under total internal reflection, where F = 1), eta_it the index ratio in the direction of travel and
    eta_ti its inverse. F = 0 when eta == 1 and F = 1 at cos_i == 0 (Mitsuba's special cases)."""
    cos_i = np.asarray(cos_i, real())
    eta = np.broadcast_to(np.asarray(eta, real()), cos_i.shape)
    outside = cos_i >= 0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = 1.0 / eta_it
    cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti
    ci = np.abs(cos_i)
    ct = np.sqrt(np.maximum(cos_t2, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    f = 0.5 * (a_s * a_s + a_p * a_p)
    f = np.where(cos_t2 <= 0, 1.0, f)
    f = np.where(ci == 0, 1.0, f)
    f = np.where(eta == 1, 0.0, f)
    return f, mulsign(-ct, cos_i), eta_it, eta_ti


def fresnel_conductor(cos_i, eta, k):
    """Unpolarised Fresnel reflectance of a conductor of complex index n = eta + i k, light arriving from
    outside (cos_i >= 0), from the complex amplitude ratios (Born and Wolf 14.2): with w = n cos_t =
    sqrt(n^2 - sin^2), r_s = (cos - w) / (cos + w), r_p = (n^2 cos - w) / (n^2 cos + w), R = (|r_s|^2 +
    |r_p|^2) / 2. cos_i (n,), eta and k broadcast against (n, 3); returns (n, 3)."""
    c = np.asarray(cos_i, real())[:, None]
    n = np.asarray(eta, real()) + 1j * np.asarray(k, real())
    n2 = n * n
    w = np.sqrt(n2 - (1.0 - c * c) + 0j)  # principal root: Re >= 0 and Im >= 0 when eta, k >= 0
    with np.errstate(invalid="ignore", divide="ignore"):
        r_s = (c - w) / (c + w)
        r_p = (n2 * c - w) / (n2 * c + w)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


def fresnel_diffuse_reflectance(eta):
    """Mitsuba's Fdr(eta), the Fresnel reflectance averaged over cosine-weighted incidence from the side the
    relative index eta faces: Egan and Hilgeman's fit for eta < 1, d'Eon and Irving's (2011) quintic in 1/eta
    otherwise (the fresnel header). ``fresnel_diffuse_reflectance_exact`` integrates the same quantity."""
    if eta < 1:
        return 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    x = 1.0 / eta
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))))


@functools.cache
def gauss_legendre(n):
    """Gauss-Legendre nodes and weights on [-1, 1] (numpy's; cached, read-only)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = w.flags.writeable = False
    return x, w


def fresnel_diffuse_reflectance_exact(eta, n=200):
    """2 int_0^1 F(mu, eta) mu dmu by Gauss-Legendre (split at the critical angle where there is one)."""
    crit = math.sqrt(max(0.0, 1.0 - eta * eta)) if eta < 1 else 0.0
    total = crit * crit  # F = 1 below the critical cosine: 2 int_0^crit mu dmu
    x, w = gauss_legendre(n)
    mu = crit + (1 - crit) * (x + 1) / 2
    return total + 2 * np.sum(w * (1 - crit) / 2 * fresnel_dielectric(mu, eta)[0] * mu)


# ----------------------------------------------------------------------------------------------------------
# Microfacet distributions

def beckmann_g1_exact(a):
    """Smith's G1 of the Beckmann distribution, a = 1 / (alpha tan theta): 2 / (1 + erf(a) + exp(-a^2) /
    (a sqrt(pi))) (Walter et al. 2007 eq. 25 with Lambda's closed form)."""
    a = np.asarray(a, np.float64)
    return 2.0 / (1.0 + special.erf(a) + np.exp(-a * a) / (a * math.sqrt(math.pi)))


class Microfacet:
    """Beckmann or GGX (Trowbridge-Reitz), anisotropic, as Mitsuba's MicrofacetDistribution (microfacet header):
    D, the separable Smith G, the visible-normal density and sampler (Heitz and d'Eon 2014; GGX by Heitz's
    2017 projection routine in slope space, Beckmann by Jakob's Newton inversion, both as Mitsuba writes them),
    or the plain D(m) cos theta_m sampler when sample_visible is False. alpha_u / alpha_v may be arrays (n,)
    (roughdielectric scales them per sample)."""

    def __init__(self, distribution, alpha_u, alpha_v=None, sample_visible=True):
        if distribution not in ("beckmann", "ggx"):
            raise ValueError(f"distribution must be 'beckmann' or 'ggx', not {distribution!r}")
        self.type = distribution
        alpha_v = alpha_u if alpha_v is None else alpha_v
        self.alpha_u = np.maximum(np.asarray(alpha_u, real()), 1e-4)
        self.alpha_v = np.maximum(np.asarray(alpha_v, real()), 1e-4)
        self.sample_visible = sample_visible
        self.rounding = None  # an rng: sample() moves its stretched direction by float32's rounding (nearby())

    def scaled(self, factor):
        scaled = Microfacet(self.type, self.alpha_u * factor, self.alpha_v * factor, self.sample_visible)
        scaled.rounding = self.rounding
        return scaled

    def nearby(self, rng):
        """A copy whose visible-normal sampler moves the stretched direction's components by up to 2 ULP
        (absolutely), the error of Mitsuba's float32 normalize: near normal incidence the sampler takes
        tan theta from that direction's z, which multiplies the error by 1 / sin^2 theta (at alpha = 0.001,
        one ULP of z is 12 % of tan theta). For ``mitsuba_errors``."""
        copy = Microfacet(self.type, self.alpha_u, self.alpha_v, self.sample_visible)
        copy.rounding = rng
        return copy

    def D(self, m):
        au, av = self.alpha_u, self.alpha_v
        x, y, z = m[:, 0], m[:, 1], m[:, 2]
        c2 = z * z
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if self.type == "beckmann":
                d = np.exp(-((x / au) ** 2 + (y / av) ** 2) / c2) / (np.pi * au * av * c2 * c2)
            else:
                d = 1.0 / (np.pi * au * av * ((x / au) ** 2 + (y / av) ** 2 + c2) ** 2)
            return np.where(d * z > 1e-20, d, 0.0)

    def smith_g1(self, v, m):
        au, av = self.alpha_u, self.alpha_v
        xy = (au * v[:, 0]) ** 2 + (av * v[:, 1]) ** 2
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            t2 = xy / (v[:, 2] * v[:, 2])
            if self.type == "beckmann":
                a = 1.0 / np.sqrt(t2)
                g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
            else:
                g = 2.0 / (1.0 + np.sqrt(1.0 + t2))
        g = np.where(xy == 0, 1.0, g)
        return np.where(dot(v, m) * v[:, 2] <= 0, 0.0, g)

    def G(self, wi, wo, m):
        return self.smith_g1(wi, m) * self.smith_g1(wo, m)

    def pdf(self, wi, m):
        """Density of m (per steradian of m) under sample(wi, .)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.sample_visible:
                return self.D(m) * self.smith_g1(wi, m) * np.abs(dot(wi, m)) / wi[:, 2]
            return self.D(m) * m[:, 2]

    def sample(self, wi, u, with_pdf=True):
        """(m, pdf) for u (n, 2) in [0, 1)^2, Mitsuba's mapping (pdf None unless with_pdf)."""
        au, av = np.broadcast_arrays(self.alpha_u, self.alpha_v, u[:, 0])[:2]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if not self.sample_visible:
                if np.all(self.alpha_u == self.alpha_v):
                    phi = 2 * np.pi * u[:, 1]
                    sin_phi, cos_phi = np.sin(phi), np.cos(phi)
                    alpha2 = au * au
                else:
                    tmp = av / au * np.tan(2 * np.pi * u[:, 1])
                    cos_phi = mulsign(1.0 / np.sqrt(tmp * tmp + 1.0), np.abs(u[:, 1] - 0.5) - 0.25)
                    sin_phi = cos_phi * tmp
                    alpha2 = 1.0 / ((cos_phi / au) ** 2 + (sin_phi / av) ** 2)
                if self.type == "beckmann":
                    cos_t = 1.0 / np.sqrt(1.0 - alpha2 * np.log(1.0 - u[:, 0]))
                    pdf = (1.0 - u[:, 0]) / (np.pi * au * av * np.maximum(cos_t ** 3, 1e-20))
                else:
                    tan2 = alpha2 * u[:, 0] / (1.0 - u[:, 0])
                    cos_t = 1.0 / np.sqrt(1.0 + tan2)
                    temp = 1.0 + tan2 / alpha2
                    pdf = 1.0 / (np.pi * au * av * np.maximum(cos_t ** 3, 1e-20) * temp * temp)
                sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
                return np.stack([cos_phi * sin_t, sin_phi * sin_t, cos_t], axis=-1), pdf
            # Visible normals: stretch wi, sample the slopes of the alpha = 1 distribution, rotate, unstretch.
            wp = normalize(np.stack([au * wi[:, 0], av * wi[:, 1], wi[:, 2]], axis=-1))
            if self.rounding is not None:
                wp = wp + 2 * ULP * self.rounding.uniform(-1, 1, wp.shape)
            s2 = wp[:, 0] ** 2 + wp[:, 1] ** 2
            inv = 1.0 / np.sqrt(s2)
            pole = s2 <= 4 * 2.0 ** -24  # Frame3f::sincos_phi's 4 Epsilon<float>
            cos_phi = np.where(pole, 1.0, np.clip(wp[:, 0] * inv, -1, 1))
            sin_phi = np.where(pole, 0.0, np.clip(wp[:, 1] * inv, -1, 1))
            sx, sy = self._sample_visible_11(wp[:, 2], u)
            sx, sy = (cos_phi * sx - sin_phi * sy) * au, (sin_phi * sx + cos_phi * sy) * av
            m = normalize(np.stack([-sx, -sy, np.ones_like(sx)], axis=-1))
            return m, (self.pdf(wi, m) if with_pdf else None)

    def _sample_visible_11(self, cos_i, u):
        """Slopes of a visible normal of the alpha = 1 distribution, seen from cos_i (the microfacet header)."""
        if self.type == "beckmann":
            # Jakob 2014: Newton's method on the CDF of the slope along the incident plane, parameterised in
            # the erf domain, from the analytic solution at theta = pi / 2.
            tan_i = np.sqrt(np.maximum(0.0, 1.0 - cos_i * cos_i)) / cos_i
            cot_i = 1.0 / tan_i
            maxval = special.erf(cot_i)
            u = np.clip(u, 1e-6, 1.0 - 1e-6)
            x = maxval - (maxval + 1.0) * special.erf(np.sqrt(-np.log(u[:, 0])))
            target = u[:, 0] * (1.0 + maxval + tan_i * np.exp(-cot_i * cot_i) / math.sqrt(math.pi))
            for _ in range(3):
                slope = special.erfinv(x)
                value = 1.0 + x + tan_i * np.exp(-slope * slope) / math.sqrt(math.pi) - target
                x = x - value / (1.0 - slope * tan_i)
            return special.erfinv(x), special.erfinv(2.0 * u[:, 1] - 1.0)
        # GGX, Heitz 2017: a uniform point on the disk, compressed onto the projected visible hemisphere.
        p = square_to_uniform_disk_concentric(u)
        s = 0.5 * (1.0 + cos_i)
        px = p[:, 0]
        py = np.sqrt(np.maximum(0.0, 1.0 - px * px)) * (1.0 - s) + p[:, 1] * s
        pz = np.sqrt(np.maximum(0.0, 1.0 - px * px - py * py))
        sin_i = np.sqrt(np.maximum(0.0, 1.0 - cos_i * cos_i))
        norm = 1.0 / (sin_i * py + cos_i * pz)
        return (cos_i * py - sin_i * pz) * norm, px * norm


# ----------------------------------------------------------------------------------------------------------
# The rough interface's albedos (roughplastic's tables)

def _interface_gl(distribution, alpha, mu, eta, kind):
    """Mitsuba's eval_transmittance / eval_reflectance (the microfacet header): for each mu, the expectation over
    visible normals m of wi (sin theta, 0, mu) of (1 - F) G1(wt, m) (refraction) or F G1(wr, m)
    (reflection), by tensor Gauss-Legendre over the sampler's unit square (32^2 nodes if eta > 1, else
    128^2)."""
    res = 32 if eta > 1 else 128
    x, w = (a.astype(real()) for a in gauss_legendre(res))
    ux, uy = np.meshgrid((x + 1) / 2, (x + 1) / 2, indexing="ij")
    wxy = np.outer(w, w).ravel() * 0.25
    u = np.stack([ux.ravel(), uy.ravel()], axis=-1)
    distr = Microfacet(distribution, alpha)
    out = np.empty(len(mu), real())
    for i, c in enumerate(mu):
        c = float(c)
        wi = np.broadcast_to(np.array([math.sqrt(1 - c * c), 0.0, c], real()), (len(u), 3))
        m = distr.sample(wi, u, with_pdf=False)[0]
        f, cos_t, _, eta_ti = fresnel_dielectric(dot(wi, m), eta)
        if kind == "transmission":
            wt = refract_about(wi, m, cos_t, eta_ti)
            g = np.where(wt[:, 2] * wi[:, 2] >= 0, 0.0, distr.smith_g1(wt, m) * (1 - f))
        else:
            wr = reflect_about(wi, m)
            g = np.where((wr[:, 2] <= 0) | (wi[:, 2] <= 0), 0.0, distr.smith_g1(wr, m) * f)
        out[i] = np.sum(g * wxy)
    return out


def roughplastic_tables(distribution, alpha, eta):
    """(t, R_int) as roughplastic.cpp's parameters_changed computes them: t (64,) the rough interface's
    transmittance from outside at mu = max(1e-6, linspace(0, 1, 64)), R_int = 2 mean(mu R(mu)) the internal
    reflectance, R seen from inside (relative index 1 / eta). See the module's docstring. Cached."""
    t, r_int = _tables(distribution, float(alpha), float(eta))
    return t.astype(real()), real()(r_int)


@functools.lru_cache(maxsize=64)
def _tables(distribution, alpha, eta):
    """Always in float64 (inside ``precision(np.float32)`` the float64 values are rounded): Mitsuba's float32
    sums are modelled by RoughPlastic.nearby instead, and computing the tables twice doubled the tests' time."""
    with precision(np.float64):
        mu = np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE))
        t = _interface_gl(distribution, alpha, mu, eta, "transmission")
        r = _interface_gl(distribution, alpha, mu, 1.0 / eta, "reflection")
    t.flags.writeable = False
    return t, float(np.mean(r * mu) * 2.0)


def table_lookup(table, x):
    """roughplastic's lerp_gather: linear interpolation of the 64 values at x in [0, 1]."""
    x = np.nan_to_num(np.asarray(x, real())) * (len(table) - 1)
    index = np.minimum(np.maximum(x, 0).astype(np.int64), len(table) - 2)
    return table[index] + (table[index + 1] - table[index]) * (x - index.astype(x.dtype))


def rough_interface_albedo(mu, distribution, alpha, eta, kind, n_theta=384, n_phi=256):
    """An independent evaluation of the integral Mitsuba's tables approximate: for wi = (sin, 0, mu), the
    reflected (kind "reflection", F G1(wr)) or refracted ((1 - F) G1(wt)) share of a rough dielectric
    interface, integrated over the microfacet normals with the visible-normal density D(m) G1(wi, m)
    (wi . m)+ / mu directly (no sampler): theta_m = atan(alpha s), s = v / (1 - v), v by Gauss-Legendre,
    phi_m by the periodic trapezoid rule (the integrand is even in phi: [0, pi] doubled)."""
    x, w = gauss_legendre(n_theta)
    v = (x + 1) / 2
    s = v / (1 - v)
    theta = np.arctan(alpha * s)
    dtheta = w / 2 * alpha / (1 + (alpha * s) ** 2) / (1 - v) ** 2
    phi = (np.arange(n_phi) + 0.5) * np.pi / n_phi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    weight = (np.outer(dtheta, np.full(n_phi, 2 * np.pi / n_phi)) * np.sin(th)).ravel()
    m = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1).reshape(-1, 3)
    distr = Microfacet(distribution, alpha)
    out = []
    for c in np.atleast_1d(mu):
        wi = np.broadcast_to([math.sqrt(1 - c * c), 0.0, c], m.shape)
        dens = distr.D(m) * distr.smith_g1(wi, m) * np.maximum(dot(wi, m), 0) / c
        f, cos_t, _, eta_ti = fresnel_dielectric(dot(wi, m), eta)
        if kind == "transmission":
            wt = refract_about(wi, m, cos_t, eta_ti)
            g = np.where(wt[:, 2] < 0, distr.smith_g1(wt, m) * (1 - f), 0.0)
        else:
            wr = reflect_about(wi, m)
            g = np.where(wr[:, 2] > 0, distr.smith_g1(wr, m) * f, 0.0)
        out.append(np.sum(weight * dens * g))
    return np.array(out)


# ----------------------------------------------------------------------------------------------------------
# The BSDFs

class BSDF:
    """Base: no delta lobes, eval and pdf 0. Subclasses take Mitsuba's parameters as keywords."""
    name = None

    def eval(self, wo, wi):
        return np.zeros((len(_dirs(wo)), 3), real())

    def pdf(self, wo, wi):
        return np.zeros(len(_dirs(wo)), real())

    def delta_lobes(self, wo):
        return []

    def sample(self, wo, u1, u2):
        raise NotImplementedError

    def nearby(self, rng):
        """This BSDF with its precomputed values and its sampler's intermediate direction moved by their
        float32 rounding (``mitsuba_errors``)."""
        copy = object.__new__(type(self))
        copy.__dict__.update(self.__dict__)
        if hasattr(self, "distr"):
            copy.distr = self.distr.nearby(rng)
        return copy

    @staticmethod
    def _inputs(wo, u1, u2):
        wo = _dirs(wo)
        u1 = np.asarray(u1, real()).reshape(len(wo))
        u2 = np.asarray(u2, real()).reshape(len(wo), 2)
        return wo, u1, u2


def _empty_sample(n):
    return Sample(np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3)), np.zeros(n, np.int64), np.zeros(n, bool),
                  np.zeros(n, bool))


def _choose_lobe(lobes, u1):
    """The sample of a BSDF of two delta lobes (dielectric.cpp, thindielectric.cpp): the first lobe where u1 <= its
    probability, else the second, with that lobe's direction, probability, weight and component."""
    first, second = lobes
    pick = u1 <= first.prob
    ones = np.ones(len(u1), bool)
    return Sample(np.where(pick[:, None], first.wi, second.wi), np.where(pick, first.prob, second.prob),
                  np.where(pick[:, None], first.weight, second.weight),
                  np.where(pick, first.component, second.component), ones, ones)


class Diffuse(BSDF):
    """Lambertian reflection (diffuse.cpp): f cos = reflectance cos_i / pi, cosine-weighted sampling."""
    name = "diffuse"

    def __init__(self, reflectance=0.5):
        self.reflectance = rgb(reflectance)

    def eval(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        return np.where(on[:, None], self.reflectance * (wi[:, 2] / np.pi)[:, None], 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        return np.where((wo[:, 2] > 0) & (wi[:, 2] > 0), wi[:, 2] / np.pi, 0.0)

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        wi = square_to_cosine_hemisphere(u2)
        pdf = wi[:, 2] / np.pi
        valid = (wo[:, 2] > 0) & (pdf > 0)
        s = _empty_sample(len(wo))
        return s._replace(wi=np.where(valid[:, None], wi, 0.0), pdf=np.where(valid, pdf, 0.0),
                          weight=np.where(valid[:, None], self.reflectance, 0.0), valid=valid)


class Conductor(BSDF):
    """A smooth conductor (conductor.cpp): one delta reflection of weight specular_reflectance F(eta + i k)."""
    name = "conductor"

    def __init__(self, eta=0.0, k=1.0, specular_reflectance=1.0):
        self.eta, self.k, self.specular = rgb(eta), rgb(k), rgb(specular_reflectance)

    def delta_lobes(self, wo):
        wo = _dirs(wo)
        on = wo[:, 2] > 0
        weight = self.specular * fresnel_conductor(np.maximum(wo[:, 2], 0), self.eta, self.k)
        return [Lobe("reflection", 0, np.where(on[:, None], reflect(wo), 0.0), on.astype(wo.dtype),
                     np.where(on[:, None], weight, 0.0))]

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        lobe = self.delta_lobes(wo)[0]
        valid = lobe.prob > 0
        return Sample(lobe.wi, lobe.prob, lobe.weight, np.zeros(len(wo), np.int64), valid, valid)


class RoughConductor(BSDF):
    """A rough conductor (roughconductor.cpp; Walter et al. 2007): f cos = F(wo . h) D(h) G1(wo, h) G1(wi, h)
    / (4 cos_o), h = normalize(wo + wi); sampled by reflecting wo about a visible normal (or a D cos normal
    when sample_visible is False); pdf = D(h) G1(wo, h) / (4 cos_o) (visible) or D(h) cos_h / (4 wi . h)."""
    name = "roughconductor"

    def __init__(self, distribution="beckmann", alpha=None, alpha_u=None, alpha_v=None, eta=0.0, k=1.0,
                 specular_reflectance=1.0, sample_visible=True):
        au, av = _alphas(alpha, alpha_u, alpha_v)
        self.distr = Microfacet(distribution, au, av, sample_visible)
        self.eta, self.k, self.specular = rgb(eta), rgb(k), rgb(specular_reflectance)

    def eval(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        h = normalize(wo + wi)
        d = self.distr.D(h)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0) & (d != 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            value = d * self.distr.G(wo, wi, h) / (4 * wo[:, 2])
        f = fresnel_conductor(np.clip(dot(wo, h), 0, 1), self.eta, self.k)
        return np.where(on[:, None], value[:, None] * f * self.specular, 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        m = normalize(wo + wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0) & (dot(wo, m) > 0) & (dot(wi, m) > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.distr.sample_visible:
                p = self.distr.D(m) * self.distr.smith_g1(wo, m) / (4 * wo[:, 2])
            else:
                p = self.distr.pdf(wo, m) / (4 * dot(wi, m))
        return np.where(on, p, 0.0)

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        up = wo[:, 2] > 0
        m, pdf = self.distr.sample(wo, u2)
        wi = reflect_about(wo, m)
        valid = up & (pdf != 0) & (wi[:, 2] > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.distr.sample_visible:
                weight = self.distr.smith_g1(wi, m)
            else:
                weight = self.distr.G(wo, wi, m) * dot(wo, m) / (wo[:, 2] * m[:, 2])
            pdf = pdf / (4 * dot(wi, m))
        weight = weight[:, None] * fresnel_conductor(np.clip(dot(wo, m), 0, 1), self.eta, self.k) * self.specular
        s = _empty_sample(len(wo))
        return s._replace(wi=np.where(up[:, None], wi, 0.0), pdf=np.where(up, pdf, 0.0),
                          weight=np.where(valid[:, None], weight, 0.0), valid=valid)


class Dielectric(BSDF):
    """A smooth dielectric interface (dielectric.cpp): reflection with probability F and weight
    specular_reflectance, refraction with probability 1 - F and weight specular_transmittance eta_ti^2
    (radiance mode), both sides."""
    name = "dielectric"

    def __init__(self, int_ior="bk7", ext_ior="air", specular_reflectance=1.0, specular_transmittance=1.0):
        self.eta = ior(int_ior) / ior(ext_ior)
        self.reflectance, self.transmittance = rgb(specular_reflectance), rgb(specular_transmittance)

    def delta_lobes(self, wo):
        wo = _dirs(wo)
        r, cos_t, _, eta_ti = fresnel_dielectric(wo[:, 2], self.eta)
        t = 1.0 - r
        wt = np.stack([-eta_ti * wo[:, 0], -eta_ti * wo[:, 1], cos_t], axis=-1)
        on = (t > 0)[:, None]
        return [Lobe("reflection", 0, reflect(wo), r, np.broadcast_to(self.reflectance, wo.shape).copy()),
                Lobe("transmission", 1, np.where(on, wt, 0.0), t,
                     np.where(on, self.transmittance * (eta_ti * eta_ti)[:, None], 0.0))]

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        return _choose_lobe(self.delta_lobes(wo), u1)


class ThinDielectric(BSDF):
    """A thin dielectric slab (thindielectric.cpp): R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R), R =
    F(|cos theta_o|, eta), the sum of the slab's interreflections; reflection with probability R' and weight
    specular_reflectance, straight transmission (wi = -wo, Mitsuba's Null component) with probability 1 - R'
    and weight specular_transmittance."""
    name = "thindielectric"

    def __init__(self, int_ior="bk7", ext_ior="air", specular_reflectance=1.0, specular_transmittance=1.0):
        self.eta = ior(int_ior) / ior(ext_ior)
        self.reflectance, self.transmittance = rgb(specular_reflectance), rgb(specular_transmittance)

    def slab_reflectance(self, cos_o):
        r = fresnel_dielectric(np.abs(cos_o), self.eta)[0]
        t = 1.0 - r
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(r < 1, r + t * t * r / (1.0 - r * r), 1.0)

    def delta_lobes(self, wo):
        wo = _dirs(wo)
        r = self.slab_reflectance(wo[:, 2])
        on = (r < 1)[:, None]
        return [Lobe("reflection", 0, reflect(wo), r, np.broadcast_to(self.reflectance, wo.shape).copy()),
                Lobe("null", 1, np.where(on, -wo, 0.0), 1.0 - r, np.where(on, self.transmittance, 0.0))]

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        return _choose_lobe(self.delta_lobes(wo), u1)


class RoughDielectric(BSDF):
    """A rough dielectric interface, Walter et al. 2007 as roughdielectric.cpp implements it, both sides:

    reflection (wo, wi on one side):  f cos = F D G / (4 |cos_o|), m = normalize(wo + wi) flipped up;
    refraction:  f cos = |eta_ti^2 (1 - F) D G eta^2 (wo . m)(wi . m) / (cos_o (wo . m + eta wi . m)^2)|,
        eta the index ratio (wi's side / wo's side), m = normalize(wo + eta wi) flipped up, eta_ti^2 = 1 /
        eta^2 the radiance scaling;
    F = F(wo . m), G = G1(wo, m) G1(wi, m). Sampling: m from the visible normals of wo flipped to the upper
    side, reflect with probability F(wo . m), else refract; pdf = D_wo(m) F |dm/dwi| or D_wo(m) (1 - F)
    |dm/dwi|, |dm/dwi| = 1 / (4 |wi . m|) or eta^2 |wi . m| / (wo . m + eta wi . m)^2. With sample_visible
    False, m ~ D cos with alpha scaled by 1.2 - 0.2 sqrt(|cos_o|) (Walter's trick) for sampling and pdf."""
    name = "roughdielectric"

    def __init__(self, distribution="beckmann", alpha=None, alpha_u=None, alpha_v=None, int_ior="bk7",
                 ext_ior="air", specular_reflectance=1.0, specular_transmittance=1.0, sample_visible=True):
        au, av = _alphas(alpha, alpha_u, alpha_v)
        self.distr = Microfacet(distribution, au, av, sample_visible)
        self.eta = ior(int_ior) / ior(ext_ior)
        if self.eta == 1:
            raise ValueError("roughdielectric: int_ior and ext_ior must differ")
        self.reflectance, self.transmittance = rgb(specular_reflectance), rgb(specular_transmittance)

    def _half(self, wo, wi):
        cos_o, cos_i = wo[:, 2], wi[:, 2]
        refl = cos_o * cos_i > 0
        eta = np.where(cos_o > 0, self.eta, 1.0 / self.eta).astype(wo.dtype)
        m = normalize(wo + wi * np.where(refl, 1.0, eta)[:, None])
        return refl, eta, mulsign(m, m[:, 2:3])

    def _sampling_distr(self, cos_o):
        if self.distr.sample_visible:
            return self.distr
        return self.distr.scaled(1.2 - 0.2 * np.sqrt(np.abs(cos_o)))

    def eval(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        cos_o = wo[:, 2]
        refl, eta, m = self._half(wo, wi)
        d = self.distr.D(m)
        f = fresnel_dielectric(dot(wo, m), self.eta)[0]
        g = self.distr.G(wo, wi, m)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = f * d * g / (4 * np.abs(cos_o))
            a, b = dot(wo, m), dot(wi, m)
            t = np.abs((1 - f) * d * g * a * b / (cos_o * (a + eta * b) ** 2))  # eta^2 / eta^2: scale cancels
        on = cos_o != 0
        out = np.where(refl[:, None], r[:, None] * self.reflectance, t[:, None] * self.transmittance)
        return np.where(on[:, None], np.nan_to_num(out), 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        cos_o, cos_i = wo[:, 2], wi[:, 2]
        refl, eta, m = self._half(wo, wi)
        a, b = dot(wo, m), dot(wi, m)
        on = (cos_o != 0) & (a * cos_o > 0) & (b * cos_i > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            jac = np.where(refl, 1.0 / (4 * b), eta * eta * b / (a + eta * b) ** 2)
            p = self._sampling_distr(cos_o).pdf(mulsign(wo, cos_o[:, None]), m)
            f = fresnel_dielectric(a, self.eta)[0]
            p = p * np.where(refl, f, 1 - f) * np.abs(jac)
        return np.where(on, np.nan_to_num(p), 0.0)

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        cos_o = wo[:, 2]
        m, pdf = self._sampling_distr(cos_o).sample(mulsign(wo, cos_o[:, None]), u2)
        valid = (cos_o != 0) & (pdf != 0)
        a = dot(wo, m)
        f, cos_t, eta_it, eta_ti = fresnel_dielectric(a, self.eta)
        pick = u1 <= f
        wi = np.where(pick[:, None], reflect_about(wo, m), refract_about(wo, m, cos_t, eta_ti))
        b = dot(wi, m)
        with np.errstate(invalid="ignore", divide="ignore"):
            jac = np.where(pick, 1.0 / (4 * b), eta_it ** 2 * b / (a + eta_it * b) ** 2)
            pdf = pdf * np.where(pick, f, 1 - f) * np.abs(jac)
            if self.distr.sample_visible:
                g = self.distr.smith_g1(wi, m)
            else:
                g = self.distr.G(wo, wi, m) * a / (cos_o * m[:, 2])
        weight = np.where(pick[:, None], self.reflectance, self.transmittance * (eta_ti ** 2)[:, None]) * g[:, None]
        s = _empty_sample(len(wo))
        return s._replace(wi=np.where(valid[:, None], wi, 0.0), pdf=np.where(valid, pdf, 0.0),
                          weight=np.where(valid[:, None], weight, 0.0), component=np.where(pick, 0, 1),
                          valid=valid)


def _diffuse_scale(diffuse, nonlinear, r_int):
    """plastic's and roughplastic's diffuse albedo: d / (1 - d R_int) if nonlinear, else d / (1 - R_int)."""
    return diffuse / (1.0 - (diffuse * r_int if nonlinear else r_int))


class Plastic(BSDF):
    """Smooth plastic (plastic.cpp): a diffuse base under a smooth dielectric coat. A delta reflection of
    coefficient F(cos_o) specular_reflectance, and the diffuse lobe
        f cos = d' (1 - F(cos_o)) (1 - F(cos_i)) cos_i / (pi eta^2),  d' = diffuse / (1 - Fdr_int) (or
        diffuse / (1 - diffuse Fdr_int) if nonlinear), Fdr_int = fresnel_diffuse_reflectance(1 / eta);
    lobe choice: p_spec = F w / (F w + (1 - F)(1 - w)), w = specular_sampling_weight; diffuse pdf = (1 -
    p_spec) cos_i / pi."""
    name = "plastic"

    def __init__(self, diffuse_reflectance=0.5, specular_reflectance=1.0, int_ior="polypropylene",
                 ext_ior="air", nonlinear=False):
        self.eta = ior(int_ior) / ior(ext_ior)
        self.diffuse, self.specular = rgb(diffuse_reflectance), rgb(specular_reflectance)
        self.nonlinear = bool(nonlinear)
        self.fdr_int = fresnel_diffuse_reflectance(1.0 / self.eta)
        self.fdr_ext = fresnel_diffuse_reflectance(self.eta)  # Mitsuba computes it and never uses it
        self.weight = self.specular.mean() / (self.diffuse.mean() + self.specular.mean())

    def _prob_specular(self, cos_o):
        f = fresnel_dielectric(cos_o, self.eta)[0]
        ps, pd = f * self.weight, (1 - f) * (1 - self.weight)
        return f, ps / (ps + pd)

    def eval(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        f_o = fresnel_dielectric(wo[:, 2], self.eta)[0]
        f_i = fresnel_dielectric(wi[:, 2], self.eta)[0]
        scale = wi[:, 2] / np.pi / self.eta ** 2 * (1 - f_o) * (1 - f_i)
        value = _diffuse_scale(self.diffuse, self.nonlinear, self.fdr_int) * scale[:, None]
        return np.where(on[:, None], value, 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        return np.where(on, wi[:, 2] / np.pi * (1 - self._prob_specular(wo[:, 2])[1]), 0.0)

    def delta_lobes(self, wo):
        wo = _dirs(wo)
        on = wo[:, 2] > 0
        f, ps = self._prob_specular(wo[:, 2])
        with np.errstate(invalid="ignore", divide="ignore"):
            weight = (f / ps)[:, None] * self.specular
        return [Lobe("reflection", 0, np.where(on[:, None], reflect(wo), 0.0), np.where(on, ps, 0.0),
                     np.where(on[:, None] & (ps > 0)[:, None], weight, 0.0))]

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        on = wo[:, 2] > 0
        f_o, ps = self._prob_specular(wo[:, 2])
        spec = u1 < ps
        wd = square_to_cosine_hemisphere(u2)
        f_i = fresnel_dielectric(wd[:, 2], self.eta)[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            w_spec = (f_o / ps)[:, None] * self.specular
            w_diff = (_diffuse_scale(self.diffuse, self.nonlinear, self.fdr_int)
                      * ((1 - f_o) * (1 - f_i) / self.eta ** 2 / (1 - ps))[:, None])
        wi = np.where(spec[:, None], reflect(wo), wd)
        pdf = np.where(spec, ps, (1 - ps) * wd[:, 2] / np.pi)
        weight = np.where(spec[:, None], w_spec, w_diff)
        return Sample(np.where(on[:, None], wi, 0.0), np.where(on, pdf, 0.0), np.where(on[:, None], weight, 0.0),
                      np.where(spec, 0, 1), spec & on, on)


class RoughPlastic(BSDF):
    """Rough plastic (roughplastic.cpp): a diffuse base under a rough dielectric coat (isotropic alpha).

        f cos = F(wo . h) D(h) G1(wo, h) G1(wi, h) / (4 cos_o) specular_reflectance
              + d' t(cos_o) t(cos_i) cos_i / (pi eta^2),   d' = diffuse / (1 - R_int) (nonlinear: / (1 - d R_int))

    t and R_int from ``roughplastic_tables``. Lobe choice: p_spec = (1 - t(cos_o)) w / ((1 - t(cos_o)) w +
    t(cos_o)(1 - w)); pdf = p_spec D(h) G1(wo, h) / (4 cos_o) + (1 - p_spec) cos_i / pi (visible; else
    p_spec D(h) cos_h / (4 wi . h) + ...); sample() returns eval / pdf at the sampled direction."""
    name = "roughplastic"

    def __init__(self, distribution="beckmann", alpha=0.1, diffuse_reflectance=0.5, specular_reflectance=1.0,
                 int_ior="polypropylene", ext_ior="air", nonlinear=False, sample_visible=True):
        self.eta = ior(int_ior) / ior(ext_ior)
        if self.eta == 1:
            raise ValueError("roughplastic: int_ior and ext_ior must differ")
        self.alpha = max(float(alpha), 1e-4)
        self.distr = Microfacet(distribution, self.alpha, self.alpha, sample_visible)
        self.diffuse, self.specular = rgb(diffuse_reflectance), rgb(specular_reflectance)
        self.nonlinear = bool(nonlinear)
        self.weight = self.specular.mean() / (self.diffuse.mean() + self.specular.mean())
        self.table, self.r_int = roughplastic_tables(distribution, self.alpha, self.eta)

    def nearby(self, rng):
        """A copy whose table values move by up to res ULP relative (res = 32 or 128, the Gauss-Legendre nodes
        per axis of their rule) and 2 ULP absolute: Mitsuba sums res^2 terms in sequence in float32, a
        random walk of res^2 roundings of about res ULP, and each term's 1 - F, near total internal
        reflection a difference of near-equal numbers, is off by up to an ULP, which where most terms are 0
        (t at grazing mu for eta < 1) is most of the value."""
        copy = super().nearby(rng)
        t_res, r_res = (32, 128) if self.eta > 1 else (128, 32)
        copy.table = (self.table * (1 + t_res * ULP * rng.uniform(-1, 1, self.table.shape))
                      + 2 * ULP * rng.uniform(-1, 1, self.table.shape))
        copy.r_int = self.r_int * (1 + r_res * ULP * rng.uniform(-1, 1)) + 2 * ULP * rng.uniform(-1, 1)
        return copy

    def _prob_specular(self, cos_o):
        t = table_lookup(self.table, cos_o)
        ps, pd = (1 - t) * self.weight, t * (1 - self.weight)
        return t, ps / (ps + pd)

    def eval(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        h = normalize(wo + wi)
        with np.errstate(invalid="ignore", divide="ignore"):
            spec = (fresnel_dielectric(dot(wo, h), self.eta)[0] * self.distr.D(h) * self.distr.G(wo, wi, h)
                    / (4 * wo[:, 2]))
        t_o, t_i = table_lookup(self.table, np.clip(wo[:, 2], 0, 1)), table_lookup(self.table, np.clip(wi[:, 2], 0, 1))
        diff = (_diffuse_scale(self.diffuse, self.nonlinear, self.r_int)
                * (wi[:, 2] / np.pi / self.eta ** 2 * t_o * t_i)[:, None])
        return np.where(on[:, None], np.nan_to_num(spec)[:, None] * self.specular + diff, 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo), _dirs(wi)
        on = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        ps = self._prob_specular(np.clip(wo[:, 2], 0, 1))[1]
        h = normalize(wo + wi)
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.distr.sample_visible:
                p = self.distr.D(h) * self.distr.smith_g1(wo, h) / (4 * wo[:, 2])
            else:
                p = self.distr.pdf(wo, h) / (4 * dot(wi, h))
        return np.where(on, np.nan_to_num(p * ps + (1 - ps) * wi[:, 2] / np.pi), 0.0)

    def sample(self, wo, u1, u2):
        wo, u1, u2 = self._inputs(wo, u1, u2)
        on = wo[:, 2] > 0
        ps = self._prob_specular(np.clip(wo[:, 2], 0, 1))[1]
        spec = u1 < ps
        wi = np.where(spec[:, None], reflect_about(wo, self.distr.sample(wo, u2)[0]), square_to_cosine_hemisphere(u2))
        pdf = self.pdf(wo, wi)
        valid = on & (pdf > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            weight = self.eval(wo, wi) / pdf[:, None]
        s = _empty_sample(len(wo))
        return s._replace(wi=np.where(on[:, None], wi, 0.0), pdf=np.where(on, pdf, 0.0),
                          weight=np.where(valid[:, None], weight, 0.0), component=np.where(spec, 0, 1), valid=valid)


def _alphas(alpha, alpha_u, alpha_v):
    """(alpha_u, alpha_v) from Mitsuba's roughness parameters: alpha, or both alpha_u and alpha_v (default
    alpha = 0.1)."""
    if alpha_u is not None or alpha_v is not None:
        if alpha is not None or alpha_u is None or alpha_v is None:
            raise ValueError("give alpha, or both alpha_u and alpha_v")
        return float(alpha_u), float(alpha_v)
    alpha = 0.1 if alpha is None else float(alpha)
    return alpha, alpha


BSDFS = {cls.name: cls for cls in (Diffuse, Conductor, RoughConductor, Dielectric, ThinDielectric,
                                     RoughDielectric, Plastic, RoughPlastic)}


def load_dict(d):
    """The reference BSDF for a Mitsuba plugin dict: {"type": "roughconductor", "alpha": 0.1, ...}."""
    params = {k: v for k, v in d.items() if k != "type"}
    return BSDFS[d["type"]](**params)


def bsdf_eval(d, wo, wi):
    return load_dict(d).eval(wo, wi)


def bsdf_pdf(d, wo, wi):
    return load_dict(d).pdf(wo, wi)


def bsdf_sample(d, wo, u1, u2):
    return load_dict(d).sample(wo, u1, u2)


def bsdf_delta_lobes(d, wo):
    return load_dict(d).delta_lobes(wo)


# ----------------------------------------------------------------------------------------------------------
# Comparison with values Mitsuba computed (devtools/peers/mitsuba_bsdf.py records them)



def _nearby(rng, x, absolute, size):
    """float32 inputs near x: each component moved by up to `size` (relatively for directions, absolutely
    for random numbers in [0, 1), whose float32 transforms such as 2 u - 1 round absolutely)."""
    step = size * rng.uniform(-1, 1, x.shape)
    moved = np.clip(x + step, 0, 1 - ULP) if absolute else x * (1 + step)
    return moved.astype(np.float32).astype(np.float64)


def mitsuba_errors(plugin, values, draws=8, seed=0):
    """Mitsuba's recorded values (``values``: the fields devtools/peers/mitsuba_bsdf.py writes) against this
    reference, quantity by quantity, each a dict of the absolute error ``err``, the tolerance ``tol``,
    ``excess`` = err / tol (> 1 fails) and ``max_rel``, the largest relative error over values above 1e-6 of
    the quantity's largest:
      "eval", "pdf"              at the uniform directions wi;
      "s_eval", "s_pdf_eval"     at the directions Mitsuba's sample() drew (in the lobe, where uniform
                                 directions miss a narrow one);
      "s_wi"                     the direction sample() draws from the same random numbers (absolute);
      "s_pdf", "s_weight"        sample()'s pdf and weight: against the delta lobe's probability and weight
                                 for a delta sample, else against pdf() and eval() / pdf() at Mitsuba's
                                 sampled direction (the sampler's own density must be pdf());
    and "components": the number of valid samples whose lobe differs from Mitsuba's (``flips``, left out of
    the sample's comparisons) and whether u1 lies within 1e-5 of the lobe choice's threshold at each.

    The tolerance of each value, with r64 the float64 reference at Mitsuba's float32 inputs x:
        tol = 8 (spread + noise) + 16 ULP |r64| + 1e-15     (directions: + 16 ULP, not 16 ULP |r64|)
    spread = max |r64(x_k) - r64(x)| over ``draws`` float32 inputs x_k whose components lie within 4 ULP of
    x's (relatively for directions, absolutely for the random numbers u2): the condition of the value, which
    float32's rounding of intermediate quantities (half vector, normalisations, 2 u - 1) turns into error;
    noise = max |r32(y_k) - r64(y_k)| over ``draws`` inputs y_k within 1e-4 of x (far enough apart that
    their roundings are unrelated), r32 the same formulas in float32 arithmetic (``precision``): the size of
    float32's own error here, the cancellation in 1 - F at grazing angles and the roughplastic tables'
    float32 sums included; 16 ULP: the roundings of a chain of some tens of operations; 1e-15: below any
    value that counts (Beckmann's D underflows in float32 where float64 still has 1e-40). Mitsuba's values
    enter only as what is compared: a wrong factor or branch moves the reference far more than rounding."""
    rng = np.random.default_rng(seed)
    v64 = {k: np.asarray(a, np.float64) for k, a in values.items()}
    b64 = load_dict(plugin)
    with precision(np.float32):
        b32 = load_dict(plugin)
    out = {}

    def compare(name, fn, inputs, absolute, got, where=None, direction=False):
        r64 = fn(b64, *inputs)
        spread, noise = np.zeros_like(r64), np.zeros_like(r64)
        for _ in range(draws):
            rk = fn(b64.nearby(rng), *(_nearby(rng, a, ab, 4 * ULP) for a, ab in zip(inputs, absolute)))
            spread = np.maximum(spread, np.nan_to_num(np.abs(rk - r64)))
            y = [_nearby(rng, a, ab, 1e-4) for a, ab in zip(inputs, absolute)]
            with precision(np.float32):
                r32 = fn(b32, *(a.astype(np.float32) for a in y)).astype(np.float64)
            noise = np.maximum(noise, np.nan_to_num(np.abs(r32 - fn(b64, *y))))
        err = np.abs(r64 - got)
        tol = 8 * (spread + noise) + 16 * ULP * (1 if direction else np.abs(r64)) + 1e-15
        if where is not None:
            err, tol, r64 = err[where], tol[where], r64[where]
        big = np.abs(r64) > 1e-6 * np.abs(r64).max(initial=0)
        rel = np.where(big, err / np.where(big, np.abs(r64), 1), 0)
        out[name] = {"err": err, "tol": tol, "excess": err / tol, "max_rel": float(rel.max(initial=0))}

    wo, wi, s_wi, u1, u2 = v64["wo"], v64["wi"], v64["s_wi"], v64["u1"], v64["u2"]
    directions = (False, False)
    compare("eval", lambda b, o, i: b.eval(o, i), (wo, wi), directions, v64["eval"])
    compare("pdf", lambda b, o, i: b.pdf(o, i), (wo, wi), directions, v64["pdf"])
    compare("s_eval", lambda b, o, i: b.eval(o, i), (wo, s_wi), directions, v64["s_eval"])
    compare("s_pdf_eval", lambda b, o, i: b.pdf(o, i), (wo, s_wi), directions, v64["s_pdf_eval"])

    s = b64.sample(wo, u1, u2)
    flips = s.valid & (s.component != values["s_component"])
    explained = all(any(b64.sample(wo[k:k + 1], u1[k:k + 1] + d, u2[k:k + 1]).component[0]
                        == values["s_component"][k] for d in (-1e-5, 1e-5)) for k in np.flatnonzero(flips))
    keep = s.valid & ~flips
    compare("s_wi", lambda b, o, u: b.sample(o, u1.astype(o.dtype), u).wi, (wo, u2), (False, True), v64["s_wi"],
            keep, direction=True)
    # sample()'s pdf and weight where the sample carries light (delta, or weight > 0 in the reference); where
    # it carries none (masked, or a microfacet normal the sampled direction cannot see), Mitsuba's weight
    # must be 0 too.
    carries = keep & (np.abs(s.weight).max(axis=1) > 0)
    for field in ("pdf", "weight"):
        compare("s_" + field, lambda b, o, u, f=field: b.sample(o, u1.astype(o.dtype), u)._asdict()[f], (wo, u2),
                (False, True), v64["s_" + field], carries)
    dark = ~(carries | flips)
    err = np.abs(v64["s_weight"][dark])
    out["s_weight_zero"] = {"err": err, "tol": np.full_like(err, 1e-15), "excess": err / 1e-15, "max_rel": 0.0}
    out["components"] = {"flips": int(flips.sum()), "flips_explained": bool(explained)}
    return out
