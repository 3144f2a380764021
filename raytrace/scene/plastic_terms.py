"""The host's per-material terms of the plastic BSDFs (kernels/bsdfs/plastic.cl, roughplastic.cl), found once
per material as Mitsuba 3 finds them at construction: the share of the diffuse base's light that the coat
reflects back inside, and the coat's share in choosing which lobe to sample."""
from . import rough_transmittance


def fresnel_diffuse_reflectance(eta):
    """The Fresnel reflectance of a dielectric interface averaged over cosine-weighted incidence from the side
    whose relative index is eta, 2 int_0^1 F(mu, eta) mu dmu, by Mitsuba 3's fit (its
    fresnel_diffuse_reflectance, the same constants): Egan and Hilgeman's (1973) below eta = 1, d'Eon and
    Irving's quintic in 1 / eta ("A Quantized-Diffusion Model for Rendering Translucent Materials", SIGGRAPH
    2011) above. Off the integral by at most 1.6e-3 for the inside of a coat of index up to 2, 1.6e-2 at 3
    (tests/test_bsdf_plastic.py measures it): the plastic copies Mitsuba's fit, errors included."""
    if eta < 1.0:
        return 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    x = 1.0 / eta
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))))


def specular_weight(material):
    """Mitsuba's m_specular_sampling_weight, s / (d + s) with d and s the means of the base's diffuse and the
    coat's specular reflectance over the RGB channels (plastic.cpp and roughplastic.cpp alike): samples go to
    the coat in proportion to what it can reflect. Where both are black Mitsuba divides 0 by 0; nothing is
    reflected then whichever lobe is chosen, and the lobes share the samples evenly."""
    d = sum(float(c) for c in material.colour) / 3.0
    s = sum(float(c) for c in material.specular) / 3.0
    return s / (d + s) if d + s > 0.0 else 0.5


def coat(material):
    """(internal_reflectance, specular_weight) of a plastic or roughplastic material (types.h's Material).
    A smooth coat's internal reflectance is plastic.cpp's m_fdr_int, the diffuse Fresnel reflectance seen from
    inside (relative index 1 / eta); a rough coat's integrates its microfacets' reflectance (roughplastic.cpp's
    m_internal_reflectance, rough_transmittance.internal_reflectance)."""
    if material.bsdf == "roughplastic":
        return rough_transmittance.internal_reflectance(material), specular_weight(material)
    return fresnel_diffuse_reflectance(material.ext_ior / material.int_ior), specular_weight(material)
