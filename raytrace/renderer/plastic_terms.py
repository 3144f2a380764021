"""The host's per-material terms of the plastic BSDFs (kernels/bsdfs/plastic.cl, roughplastic.cl), found once
per material as Mitsuba 3 finds them at construction: the share of the diffuse base's light that the coat
reflects back inside, and the coat's share in choosing which lobe to sample."""


def coat(material):
    """(internal_reflectance, specular_weight) of a plastic or roughplastic material (types.h's Material)."""
    raise NotImplementedError("plastic_terms.coat")  # being written (issue 57)
