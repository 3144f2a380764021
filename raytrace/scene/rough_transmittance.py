"""The roughplastic BSDF's two terms of its rough dielectric coat (kernels/bsdfs/roughplastic.cl), found once per
material as Mitsuba 3 (v3.9.1) finds them when it builds the plugin (src/bsdfs/roughplastic.cpp,
parameters_changed; microfacet.h, eval_transmittance and eval_reflectance):

- `table`: the coat's transmittance from outside, t(mu) = E_m[(1 - F(wi . m)) G1(wt, m)] over the normals m
  visible from wi = (sqrt(1 - mu^2), 0, mu), wt the direction refracted through m: the share of light arriving
  at cos(theta) = mu that reaches the diffuse base (Weidlich and Wilkie, "Arbitrarily Layered Micro-Facet
  Surfaces", GRAPHITE 2007, take the coat's transmittance as the layer's factor on both ways through it). 64
  values at mu = max(1e-6, linspace(0, 1, 64)); the kernel interpolates them linearly (Mitsuba's lerp_gather).
- `internal_reflectance`: the share of the base's diffuse light that the coat reflects back inside, 2 mean(mu
  R(mu)) over the same 64 mu, R the coat's reflectance E_m[F G1(wr, m)] seen from inside (relative index 1 /
  eta). Mitsuba takes the plain mean of the 64 samples, endpoints included, not the integral 2 int mu R dmu (about
  1% below it at eta 1.49): raytrace renders Mitsuba's scenes as Mitsuba does, so it takes the same mean.

Both are Mitsuba's quadrature, reproduced rather than a better one, so that the values are Mitsuba's: a tensor
Gauss-Legendre rule of 32 x 32 nodes (128 x 128 where the relative index is below 1: total internal reflection
makes the integrand discontinuous) over the unit square of Mitsuba's visible-normal sampler, pushed through that
sampler (Heitz's 2017 GGX routine on the concentric disk, Jakob's 2014 Newton inversion for Beckmann), so the
quadrature follows the sampler's warp. Mitsuba sums in float32; here every node is found in float64 (the nodes
and weights rounded to float32 first, as Mitsuba stores them): the values agree with Mitsuba's own to its
rounding (tests/test_bsdf_roughplastic.py, against tests/data/roughplastic_mitsuba_tables.npz).

The integrand is even in m.y (wi lies in the x-z plane, and each sampler maps the square's mirror image to the
mirrored normal: GGX's concentric disk along u.x, Beckmann's erfinv(2 u.y - 1) along u.y), and the rule's nodes
are symmetric: half the nodes, counted twice, give the same sum. A material's values are cached by
(distribution, alpha, eta): a scene of several plastics of one roughness finds them once."""
import functools
import math

import numpy as np

from ..structs import ROUGH_TRANSMITTANCE_RES

MIN_ALPHA = 1e-4  # Mitsuba's MicrofacetDistribution clamps alpha to at least this (configure())


def table(material):
    """ROUGH_TRANSMITTANCE_RES float32 values of the coat's transmittance t(mu) at mu = max(1e-6, i / (RES - 1))."""
    return _transmittance(*_key(material)).astype(np.float32)


def internal_reflectance(material):
    """Mitsuba's m_internal_reflectance of a roughplastic material: 2 mean(mu R(mu)) of the coat seen from inside."""
    distribution, alpha, eta = _key(material)
    return _internal_reflectance(distribution, alpha, eta)


def _key(material):
    alpha = max(float(material.alpha), MIN_ALPHA)
    return material.distribution, alpha, float(material.int_ior) / float(material.ext_ior)


def mu_values():
    """The cosines of the table's entries, as Mitsuba takes them: max(1e-6, linspace(0, 1, RES)) in float32."""
    return np.maximum(np.float32(1e-6), np.linspace(0, 1, ROUGH_TRANSMITTANCE_RES, dtype=np.float32)).astype(float)


@functools.lru_cache(maxsize=256)
def _transmittance(distribution, alpha, eta):
    out = _coat(distribution, alpha, eta, mu_values(), transmit=True)
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=256)
def _internal_reflectance(distribution, alpha, eta):
    mu = mu_values()
    return float(np.mean(_coat(distribution, alpha, 1.0 / eta, mu, transmit=False) * mu) * 2.0)


@functools.lru_cache(maxsize=4)
def _rule(res):
    """Half of the res x res Gauss-Legendre rule on [0, 1]^2 (u.x < 1/2 or u.y < 1/2 as `axis` says), each weight
    doubled for the mirror half: nodes (first, second) of the halved axis and the other, weights (h, res)."""
    x, w = np.polynomial.legendre.leggauss(res)
    x, w = x.astype(np.float32).astype(float), w.astype(np.float32).astype(float)  # Mitsuba's float32 rule
    u = x * 0.5 + 0.5
    half = res // 2  # res is even: no node on the mirror line
    return u[:half], u, np.outer(w[:half] * 2.0, w) * 0.25


def _coat(distribution, alpha, eta, mu, transmit):
    """For each mu: the expectation over the normals m visible from wi = (sqrt(1 - mu^2), 0, mu) of (1 - F) G1(wt)
    (transmit) or F G1(wr), by Mitsuba's rule (the module's docstring). A few mu at a time, so that the
    temporaries stay in the processor's cache."""
    res = 32 if eta > 1 else 128
    half_u, u, weights = _rule(res)
    mu = np.asarray(mu, float)
    out = np.empty(len(mu))
    step = max(1, 8192 // weights.size)
    if distribution == "beckmann":
        slopes = _beckmann_slopes(alpha, mu, u, half_u)
    for start in range(0, len(mu), step):
        c = mu[start:start + step, None, None]
        sin = np.sqrt(1.0 - c * c)
        if distribution == "ggx":  # even in u.x: the halved axis is u.x, the first index
            mx, my, mz = _ggx_normals(alpha, sin, c, res)
        elif distribution == "beckmann":  # even in u.y: the halved axis is u.y, still the first index
            mx, my, mz = _unstretched(alpha, slopes[0][start:start + step, None, :], slopes[1][None, :, None])
        else:
            raise ValueError(f"unknown microfacet distribution {distribution!r}")
        cos_m = sin * mx + c * mz  # wi . m
        f, cos_t, eta_ti = _fresnel(cos_m, eta)
        if transmit:  # Mitsuba's refract(wi, m, cos_t, eta_ti) = m (wi.m eta_ti + cos_t) - wi eta_ti
            s = cos_m * eta_ti + cos_t
            w = (mx * s - sin * eta_ti, my * s, mz * s - c * eta_ti)
            value = np.where(w[2] * c >= 0.0, 0.0, _smith_g1(distribution, alpha, w, (mx, my, mz)) * (1.0 - f))
        else:  # reflect(wi, m) = 2 (wi . m) m - wi
            s = 2.0 * cos_m
            w = (mx * s - sin, my * s, mz * s - c)
            value = np.where(w[2] <= 0.0, 0.0, _smith_g1(distribution, alpha, w, (mx, my, mz)) * f)
        out[start:start + step] = np.einsum("kij,ij->k", value, weights)
    return out


def _fresnel(cos_i, eta):
    """Mitsuba's fresnel(cos_theta_i, eta) (fresnel.h): the reflectance, the signed cosine of the refracted
    direction and eta_ti; cos_i < 0 is the inside, where the index inverts; F = 1 at cos_i = 0."""
    outside = cos_i >= 0.0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = np.where(outside, 1.0 / eta, eta)
    cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti
    ci, ct = np.abs(cos_i), np.sqrt(np.maximum(cos_t2, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    r = np.where(ci == 0.0, 1.0, 0.5 * (a_s * a_s + a_p * a_p))
    return r, np.where(np.signbit(cos_i), ct, -ct), eta_ti


def _smith_g1(distribution, alpha, v, m):
    """Mitsuba's smith_g1(v, m): Smith's masking of the isotropic distribution, 0 where v sees m's back."""
    xy = alpha * alpha * (v[0] * v[0] + v[1] * v[1])
    with np.errstate(invalid="ignore", divide="ignore"):
        t2 = xy / (v[2] * v[2])
        if distribution == "ggx":
            g = 2.0 / (1.0 + np.sqrt(1.0 + t2))
        else:  # Walter et al.'s rational fit of Beckmann's G1 (within 0.35%), as Mitsuba takes it
            a = 1.0 / np.sqrt(t2)
            g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
    g = np.where(xy == 0.0, 1.0, g)
    return np.where((v[0] * m[0] + v[1] * m[1] + v[2] * m[2]) * v[2] <= 0.0, 0.0, g)


def _stretched_cos(alpha, sin, mu):
    """cos(theta) of wi = (sin, 0, mu) stretched to the unit-roughness configuration. Its azimuth is 0: Mitsuba's
    sincos_phi gives (sin, cos) = (0, 1) there, and at the pole too, so the slopes need no rotation."""
    x = alpha * sin
    return mu / np.sqrt(x * x + mu * mu)


def _unstretched(alpha, slope_x, slope_y):
    """The normal of the unit-roughness slopes rotated to wi's azimuth (0) and scaled by alpha."""
    sx, sy = slope_x * alpha, slope_y * alpha
    norm = np.sqrt(sx * sx + sy * sy + 1.0)
    return -sx / norm, -sy / norm, 1.0 / norm


@functools.lru_cache(maxsize=4)
def _disk(res):
    """Mitsuba's branch-free concentric map (warp.h) of the halved rule's nodes (u.x < 1/2): the points (px, py)
    of the unit disk, and sqrt(1 - px^2), the height of the disk's chord there."""
    half_u, u, _ = _rule(res)
    a, b = np.meshgrid(2.0 * half_u - 1.0, 2.0 * u - 1.0, indexing="ij")
    q13 = np.abs(a) < np.abs(b)
    r, rp = np.where(q13, b, a), np.where(q13, a, b)
    phi = 0.25 * math.pi * rp / r  # no node at the centre: res is even
    phi = np.where(q13, 0.5 * math.pi - phi, phi)
    px, py = r * np.cos(phi), r * np.sin(phi)
    return px, py, np.sqrt(np.maximum(1.0 - px * px, 0.0))


def _ggx_normals(alpha, sin, mu, res):
    """Mitsuba's GGX visible normals of the halved rule's nodes seen from wi = (sin, 0, mu) (Heitz 2017: the disk
    compressed onto the projected visible hemisphere)."""
    px, py, chord = _disk(res)
    cos_i = _stretched_cos(alpha, sin, mu)
    s = 0.5 * (1.0 + cos_i)
    py = chord * (1.0 - s) + py * s
    pz = np.sqrt(np.maximum(1.0 - px * px - py * py, 0.0))
    sin_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
    norm = 1.0 / (sin_i * py + cos_i * pz)
    return _unstretched(alpha, (cos_i * py - sin_i * pz) * norm, px * norm)


def _beckmann_slopes(alpha, mu, ux, uy):
    """The slopes of Mitsuba's Beckmann visible normals at the nodes ux (along wi's plane) and uy (across it), seen
    from wi = (sqrt(1 - mu^2), 0, mu): Jakob's Newton inversion ("An Improved Visible Normal Sampling Routine for
    the Beckmann Distribution", 2014), as microfacet.h's sample_visible_11 writes it. The slope along wi's plane
    depends on (mu, ux) only, the other on uy only: (len(mu), len(ux)) and (len(uy),) values."""
    mu = np.asarray(mu, float)[:, None]
    cos_i = _stretched_cos(alpha, np.sqrt(1.0 - mu * mu), mu)
    ux, uy = np.clip(ux, 1e-6, 1.0 - 1e-6)[None, :], np.clip(uy, 1e-6, 1.0 - 1e-6)
    with np.errstate(divide="ignore", invalid="ignore"):
        tan_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0)) / cos_i
        cot_i = 1.0 / tan_i
    maxval = _erf(cot_i)
    x = maxval - (maxval + 1.0) * _erf(np.sqrt(-np.log(ux)))
    target = ux * (1.0 + maxval + tan_i * np.exp(-cot_i * cot_i) / math.sqrt(math.pi))
    for _ in range(3):
        slope = _erfinv(x)
        value = 1.0 + x + tan_i * np.exp(-slope * slope) / math.sqrt(math.pi) - target
        x = x - value / (1.0 - slope * tan_i)
    return _erfinv(x), _erfinv(2.0 * uy - 1.0)


_erf_scalar = np.frompyfunc(math.erf, 1, 1)


def _erf(x):
    return _erf_scalar(np.asarray(x, float)).astype(float)


def _erfinv(y):
    """The inverse error function in float64 on [-1, 1]: Giles' single-precision approximation ("Approximating
    the erfinv function", GPU Computing Gems 2011; drjit's erfinv) polished by two Newton steps on math.erf."""
    y = np.asarray(y, float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        w = -np.log((1.0 - y) * (1.0 + y))
        lo = w - 2.5
        p_lo = 2.81022636e-08
        for c in (3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503, -0.00417768164,
                  0.246640727, 1.50140941):
            p_lo = c + p_lo * lo
        hi = np.sqrt(w) - 3.0
        p_hi = -0.000200214257
        for c in (0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613, 0.00943887047,
                  1.00167406, 2.83297682):
            p_hi = c + p_hi * hi
        x = np.where(w < 5.0, p_lo, p_hi) * y
        for _ in range(2):  # d erf / dx = 2 exp(-x^2) / sqrt(pi)
            x = x - (_erf(x) - y) / (2.0 / math.sqrt(math.pi) * np.exp(-x * x))
    return np.where(np.abs(y) >= 1.0, np.copysign(np.inf, y), x)
