"""The host's per-material terms of the principled BSDF (kernels/bsdfs/principled.cl), found once per material as
Mitsuba 3's `principled` plugin (v3.9.1, src/bsdfs/principled.cpp and principledhelpers.h) finds them at
construction, in float32 as it does: the relative index of refraction (given as `eta`, else from `specular`),
the main lobe's GGX roughness along u and v (calc_dist_params), and the parameters the kernel reads, packed in
types.h's PRINCIPLED_* order (Material.principled). The same for `principledthin` (kernels/bsdfs/principledthin.cl,
Mitsuba's principledthin.cpp): its eta (given, else 1.5), its reflection's alphas (calc_dist_params of its
roughness), its transmission's (of (0.65 eta - 0.35) roughness) and its values."""
import numpy as np

from ..structs import PRINCIPLED_PARAMETERS

f32 = np.float32
DEFAULT_SPECULAR = 0.5  # Mitsuba's, where neither specular nor eta is given
MIN_ALPHA = 1e-3        # Mitsuba's clamp of the main lobe's roughness (calc_dist_params)
THIN_ETA = 1.5          # principledthin's default eta


def transmits(material):
    """Mitsuba's has_spec_trans: spec_trans given and not 0, or given as a texture (whatever its values): the
    inside and the transmission lobe exist, and eta avoids 1."""
    return material.spec_trans != 0 or "spec_trans" in dict(material.maps)


def eta(material):
    """eta = int_ior / ext_ior: `eta` where given (1.001 for 1 with transmission: Mitsuba's plugin, as eta 1 has
    no refraction half vector), else from `specular` s, the normal-incidence reflectance over 0.08 of Schlick's
    R0 = ((eta - 1) / (eta + 1))^2 inverted: eta = 2 / (1 - sqrt(0.08 s)) - 1 (s = 0 with transmission is 1e-3,
    Mitsuba's again)."""
    if material.bsdf == "principledthin":  # taken as given (no refraction: no half vector to lose at 1)
        return float(f32(THIN_ETA if material.principled_eta is None else material.principled_eta))
    transmits_ = transmits(material)
    if material.principled_eta is not None:
        e = f32(material.principled_eta)
        return float(f32(1.001) if transmits_ and e == 1 else e)
    s = f32(DEFAULT_SPECULAR if material.principled_specular is None else material.principled_specular)
    s = f32(1e-3) if transmits_ and s == 0 else s
    return float(f32(2.0) / (f32(1.0) - np.sqrt(f32(0.08) * s)) - f32(1.0))


def alphas(material, roughness=None):
    """(alpha_u, alpha_v): roughness^2, stretched by aspect = sqrt(1 - 0.9 anisotropic) along u and shrunk along
    v (Burley 2012's mapping), each at least MIN_ALPHA; anisotropic 0 is isotropic whatever the rounding. Of the
    material's roughness unless another is given (float32). Where roughness or anisotropic is textured, the
    kernel derives them per hit in the same float32 operations (material.cl's principled_lookups), which
    give these for a constant texture (aspect 1 exactly at 0)."""
    r = f32(material.roughness) if roughness is None else f32(roughness)
    r2 = r * r
    if material.anisotropic == 0:
        a = max(f32(MIN_ALPHA), r2)
        return float(a), float(a)
    aspect = np.sqrt(f32(1.0) - f32(0.9) * f32(material.anisotropic))
    return float(max(f32(MIN_ALPHA), r2 / aspect)), float(max(f32(MIN_ALPHA), r2 * aspect))


def clearcoat_alpha(material):
    """The clearcoat's GTR1 roughness, lerp(0.1, 0.001, clearcoat_gloss) (Dr.Jit's lerp: b t + (a - a t)); the
    kernel's of a textured clearcoat_gloss rounds the same operations (material.cl's principled_lookups)."""
    t = f32(material.clearcoat_gloss)
    return float(f32(0.001) * t + (f32(0.1) - f32(0.1) * t))


def transmission_alphas(material):
    """principledthin's transmission's (alpha_u, alpha_v): alphas() of the roughness scaled by 0.65 eta - 0.35
    (Burley 2015, figure 15: a rough sheet's refraction in and out spreads less than its reflection)."""
    return alphas(material, (f32(0.65) * f32(eta(material)) - f32(0.35)) * f32(material.roughness))


def parameters(material):
    """Material.principled: the values in types.h's PRINCIPLED_* order, float32 (principled: its main rate in
    SPECULAR_RATE, its flatness, 0 in principledthin's other own; principledthin: its
    specular_reflectance_sampling_rate there, its diff_trans halved, as Mitsuba takes it, 0 for the clearcoat and
    for TRANSMITS, which principled's textures read)."""
    if material.bsdf == "principledthin":
        values = (material.roughness, 0.0, material.spec_tint, material.sheen, material.sheen_tint, 0.0, 0.0,
                  material.spec_trans, material.specular_reflectance_sampling_rate, 0.0,
                  material.diffuse_reflectance_sampling_rate, material.anisotropic, 0.0, material.flatness,
                  f32(material.diff_trans) / f32(2),
                  *transmission_alphas(material), material.specular_transmittance_sampling_rate,
                  material.diffuse_transmittance_sampling_rate)
        assert len(values) == PRINCIPLED_PARAMETERS
        return np.array(values, np.float32)
    values = (material.roughness, material.metallic, material.spec_tint, material.sheen, material.sheen_tint,
              material.clearcoat, clearcoat_alpha(material), material.spec_trans,
              material.main_specular_sampling_rate, material.clearcoat_sampling_rate,
              material.diffuse_reflectance_sampling_rate, material.anisotropic, float(transmits(material)),
              material.flatness, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert len(values) == PRINCIPLED_PARAMETERS
    return np.array(values, np.float32)
