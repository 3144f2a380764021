"""Each BSDF of the path model declared once, as Mitsuba 3 declares a plugin in its source: its name (Mitsuba's
plugin name, the material's `type`), a paragraph of doc, its parameters with Mitsuba's names, types, ranges and
defaults (keys.py's `Key`s), the Material field each sets, and the kernel feature it is built under.

What is made from the declarations: keys.py's table of each type's keys (`materials.NAME type = "plastic"`, the
scene format's tables), the scene file's reader of them (scene_file.py's `_bsdf`), the checks of a material built
in Python (model_check.py), Mitsuba's BSDF plugins as mitsuba.py reads them (`PLUGINS`) and as mitsuba_writer.py
writes them, and the manual's page of BSDFs (docs/bsdfs.md, by `python -m devtools.docs_tables`). Adding a BSDF is
its declaration here with its name appended to model.BSDFS (the kernel's numbering), its kernel file
(kernels/bsdfs/NAME.cl) and its tests.

Names. A scene file takes Mitsuba's names beside raytrace's own older ones: `colour` is diffuse's `reflectance`,
the conductors' `specular_reflectance` and the plastics' `diffuse_reflectance`; `alpha` is the isotropic roughness,
`alpha_u` and `alpha_v` an anisotropic one (given together, as Mitsuba requires); a conductor's `material` names
its `eta` and `k`. Two names of one value in one table are an error, as Mitsuba's `alpha` beside `alpha_u` is.

Defaults are Mitsuba's, with two exceptions in the scene file, where raytrace's own came first and existing
scenes keep their meaning: diffuse's reflectance (`colour`) is required without a texture, as it always was
(Mitsuba's 0.5 is what its XML reader gives), and the rough BSDFs' `distribution` is GGX, raytrace's rough metal
before Beckmann was declared (Mitsuba's default, Beckmann, is what its XML reader gives). A material built in
Python takes model.Material's defaults, Mitsuba's glass indices among them: a plastic built so gives its
int_ior itself.

Ranges, argued where they are not simply Mitsuba's:

- `alpha`, `alpha_u`, `alpha_v` in (0, 1]. Mitsuba checks none (it takes any alpha, a texture's included).
  Open at 0: a roughness of 0 is the smooth BSDF, whose microfacet density is a delta (alpha^2 / 0 at the
  normal): the smooth types express it. Closed at 1, the bound raytrace's roughness has had: the microfacet
  terms are checked against float64 and by chi-square from alpha 0.001 to 1, and Mitsuba's own reference calls
  0.3 to 0.7 extremely rough and values far above them unrealistic; a Mitsuba scene beyond 1 is refused with one
  line (the value and its XML line) rather than rendered where nothing was tested.
- `int_ior`, `ext_ior` > 0: Mitsuba refuses negative indices only, but the BSDFs divide by them (eta =
  int_ior / ext_ior). For `roughdielectric` and `roughplastic` they must also differ, as Mitsuba requires of its
  rough interfaces (rules.py states it): at eta = 1 the half-vector of refraction, wi + eta wo, vanishes for
  the direction that passes straight through, and the microfacet transmission's density with it. The smooth
  `dielectric`, `thindielectric` and `plastic` take equal indices, as Mitsuba does (an interface that does not
  refract; a coat that reflects nothing). Their ratio is bounded by ranges.py: glass's by rule 5 (its
  refractions scale radiance by 1 / eta^2), the others' within [2^-63, 2^63] by rule 6 (the kernels square
  it), and a `plastic`'s below 3.85, where Mitsuba's fit of its coat's internal reflectance, which it copies,
  reaches 1 (rule 5 counts what the fit adds to its albedo below that).
- Reflectances (`colour` and its names, `specular_reflectance`) >= 0 with no upper bound, as `colour` always
  was: what an albedo above 1 does to a path is ranges.py's rule 5.
- `principled`'s weights (roughness, anisotropic, metallic, specular, spec_tint, sheen, sheen_tint, flatness,
  clearcoat, clearcoat_gloss, spec_trans) in [0, 1], as Mitsuba's documentation has them ("all of the parameters
  except sampling rates and eta should take values between 0.0 and 1.0"; its code checks none): they are blend
  weights, and outside [0, 1] a lobe's weight turns negative (1 - metallic, 1 - spec_trans) or anisotropic's
  aspect sqrt(1 - 0.9 a) imaginary. Roughness 0 is allowed, unlike alpha's: Mitsuba clamps the main lobe's alpha =
  roughness^2 to 1e-3 itself (principled_terms.py), which the microfacet terms are tested at. `eta` > 0 (it
  divides), and within ranges.py's rule 6 as the other indices; not with `specular`, which sets it (Mitsuba
  refuses both). The sampling rates are ratios of lobe choices: main_specular_sampling_rate in [2^-10, 2^10] so
  that the main lobes are always sampled (the reflection and transmission inside, and the front's when nothing
  else is, have no other lobe, and the probabilities' sum must not be 0), the other two in [0, 2^10]: a rate 0
  leaves its lobe to the others' samples, as Mitsuba's clearcoat_sampling_rate 0 of its documentation does; the
  bound of 2^10 on their ratio to the main one keeps a sample's weight (f / pdf, the main lobes' share of pdf at
  least 2^-20 / 3) finite.
- `principledthin`'s weights are principled's, in [0, 1], but `diff_trans` in [0, 2] (Mitsuba's documentation: the
  diffuse light's share transmitted is diff_trans / 2). Its `eta` (default 1.5) in [2^-16, 2^16]: Mitsuba checks
  none, but the transmission's roughness is (0.65 eta - 0.35) roughness, whose GGX terms square alpha and its
  product with a grazing direction's tangent (2^16: alpha^2 tan^2 within float32 at 1e-7 of the horizon); the
  Fresnel term squares 1 / eta. Its four sampling rates in [2^-10, 2^10], none 0: its lobes cover different
  directions (the glossy and the diffuse, each reflecting or transmitting), so a rate 0 leaves one with value to
  no sample at all, and at the edges of spec_trans and diff_trans the sum of the lobes' shares would be 0
  (Mitsuba's 0 / 0); the bound of 2^10 keeps a sample's weight finite as principled's does.
"""
from dataclasses import dataclass

from .declaration import Key
from .model import BSDFS, DEFAULT_ALPHA, DEFAULT_EXT_IOR, DEFAULT_INT_IOR, DISTRIBUTIONS
from .named_materials import CONDUCTORS, IORS

SAME = object()  # a parameter whose Mitsuba default is its key's


@dataclass(frozen=True)
class Parameter:
    """One parameter of a BSDF, by Mitsuba's name. `key`: the scene file's key of that name (its type, range and
    the default a scene file gets), or None for a parameter of Mitsuba's scenes only. `fields`: the Material
    fields it sets. `mitsuba`: Mitsuba's default, where it is not the key's. `writes`: the scene table's key
    Mitsuba's XML reader writes it as ("": its own name). `together`: a key it must be given with. `note`: what
    raytrace makes of it in a Mitsuba scene."""
    name: str
    fields: tuple
    key: Key | None = None
    mitsuba: object = SAME
    writes: str = ""
    together: str = ""
    note: str = ""

    @property
    def mitsuba_default(self):
        return self.key.default if self.mitsuba is SAME else self.mitsuba

    @property
    def table_key(self):
        """The scene table's key the XML reader writes this parameter's value under."""
        return self.writes or self.name


@dataclass(frozen=True)
class BSDF:
    """A BSDF: Mitsuba's plugin name, its one-line title and doc, its parameters (Parameter, in Mitsuba's
    order), the field of raytrace.renderer.program.Features that compiles it ("": always compiled), the body of
    an example [materials.NAME] table, whether Mitsuba's plugin scatters from the front side only (a material of
    it may then be one-sided, two_sided = false, and the writer wraps a two-sided one in `twosided`), and whether
    int_ior and ext_ior must differ."""
    name: str
    title: str
    doc: str
    parameters: tuple
    feature: str
    example: str
    front_only: bool = True
    distinct_iors: bool = False
    only_default: tuple = ()  # (name, Mitsuba's default) of Mitsuba's parameters raytrace takes at that value only

    @property
    def table(self):
        """The name of keys.py's table of this type's keys."""
        return table_name(self.name)

    def keys(self):
        return [p.key for p in self.parameters if p.key is not None]

    def key_names(self):
        return [key.name for key in self.keys()]

    def parameter(self, name):
        return next(p for p in self.parameters if p.name == name)


def table_name(name):
    """keys.py's table of the keys of the BSDF `name`, beside the keys every material has ("materials.NAME")."""
    return f'materials.NAME type = "{name}"'


def _reflectance(name, doc, default, mitsuba=SAME, also="not with colour"):
    """A reflectance parameter that is `colour` by Mitsuba's name."""
    return Parameter(name, ("colour",), Key(name, "number-or-vector", f"Mitsuba's name for colour: {doc}",
                                            default=default, length=3, low=0, also=also),
                     mitsuba=mitsuba, writes="colour")


def _ior(name, default, mitsuba, inside):
    where = ("inside (the side the normal points away from)" if inside else "outside (the side the normal points "
             "to)")
    return Parameter(name, (name,), Key(name, "number-or-name", f"the index of refraction {where}: a number, or "
                                        "one of Mitsuba's named media", default=default, low=0, open_low=True,
                                        named=tuple(IORS.items())), mitsuba=mitsuba)


def _iors(int_default, int_name):
    return (_ior("int_ior", int_default, int_name, True), _ior("ext_ior", DEFAULT_EXT_IOR, "air", False))


def _roughness(anisotropic):
    """The microfacet parameters: the distribution and the roughness (isotropic, or also along u and v)."""
    bound = dict(low=0, high=1, open_low=True)
    found = [Parameter("distribution", ("distribution",),
                       Key("distribution", "string", "the microfacet distribution: GGX's (Trowbridge-Reitz) or "
                           "Beckmann's", default="ggx", choices=DISTRIBUTIONS), mitsuba="beckmann"),
             Parameter("alpha", ("alpha",), Key("alpha", "number", "the roughness: the microfacets' slope spread "
                                                "(Beckmann's: their RMS slope)", default=DEFAULT_ALPHA,
                                                also="not with alpha_u, alpha_v" if anisotropic else "", **bound))]
    if anisotropic:
        found += [Parameter("alpha_u", ("alpha",), Key("alpha_u", "number", "the roughness along the tangent (u)",
                                                       default=None, also="with alpha_v; not with alpha", **bound),
                            mitsuba=DEFAULT_ALPHA, together="alpha_v"),
                  Parameter("alpha_v", ("alpha_v",), Key("alpha_v", "number", "the roughness along the bitangent (v)",
                                                         default=None, also="with alpha_u; not with alpha", **bound),
                            mitsuba=DEFAULT_ALPHA, together="alpha_u")]
    return tuple(found + [Parameter("sample_visible", (), mitsuba=True,
                                    note="noise only: raytrace samples the visible normals")])


def _conductor():
    """A conductor's index of refraction, by its parts or by a named metal, and a factor on its reflectance."""
    return (Parameter("eta", ("eta",), Key("eta", "number-or-vector", "the real part of the index of refraction, "
                                           "per channel (or a texture)", length=3, low=0, default=(0.0, 0.0, 0.0),
                                           also="with k; both 0: a perfect mirror"), mitsuba=0.0),
            Parameter("k", ("k",), Key("k", "number-or-vector", "the imaginary part (absorption), per channel (or a "
                                       "texture)", length=3, low=0, default=(0.0, 0.0, 0.0)), mitsuba=1.0),
            Parameter("material", ("eta", "k"), Key("material", "string", "a named metal, eta and k in RGB as "
                                                    "Mitsuba's rgb variants have them; none: a perfect mirror",
                                                    default="none", choices=tuple(CONDUCTORS),
                                                    also="not with eta or k (but none)")),
            _reflectance("specular_reflectance", "a factor on the reflectance", (1.0, 1.0, 1.0), mitsuba=1.0))


def _glass_colour():
    """A dielectric's reflectance and transmittance: Mitsuba's two factors, raytrace's one colour."""
    return tuple(Parameter(name, ("colour",), mitsuba=1.0, writes="colour", note=f"equal to {other} only (raytrace's "
                           "glass has one colour, the scene file's colour)")
                 for name, other in (("specular_reflectance", "specular_transmittance"),
                                     ("specular_transmittance", "specular_reflectance")))


def _plastic():
    """A plastic's diffuse base and its dielectric coat."""
    return (_reflectance("diffuse_reflectance", "the diffuse base's reflectance", (0.5, 0.5, 0.5), mitsuba=0.5),
            Parameter("nonlinear", ("nonlinear",), Key("nonlinear", "boolean", "let the light scattered inside the "
                                                       "coat shift the base's colour (darker, more saturated), as a "
                                                       "varnish does; false keeps the given colour", default=False)),
            *_iors(IORS["polypropylene"], "polypropylene"),
            Parameter("specular_reflectance", ("specular",),
                      Key("specular_reflectance", "number-or-vector", "a factor on the coat's specular reflection",
                          default=(1.0, 1.0, 1.0), length=3, low=0), mitsuba=1.0))


def _weight(name, field, doc, default=0.0, mitsuba=SAME, also="", texture=True):
    """A principled weight in [0, 1]; a number or, where `texture`, a texture (Mitsuba's, but specular's)."""
    doc = f"{doc} (a number or a texture)" if texture else doc
    return Parameter(name, (field,), Key(name, "number", doc, default=default, low=0, high=1, also=also),
                     mitsuba=mitsuba, note="a number or a texture" if texture else "")


def _principled():
    """principled's parameters, in Mitsuba's order (its doc's)."""
    rate = "share in choosing which lobe to sample (a ratio to the other rates)"
    return (_reflectance("base_color", "the diffuse base's albedo, the metal's normal-incidence reflectance, the "
                         "tints' hue", (0.5, 0.5, 0.5), mitsuba=0.5),
            _weight("roughness", "roughness", "the main lobes' roughness (their GGX alpha is its square, at "
                    "least 1e-3); also the diffuse base's retro-reflection", default=0.5),
            _weight("anisotropic", "anisotropic", "the main lobes' anisotropy: alpha along u over alpha along v is "
                    "1 / (1 - 0.9 anisotropic)"),
            _weight("metallic", "metallic", "the share of metal: a Schlick reflectance of the colour in place "
                    "of the dielectric's lobes"),
            _weight("spec_trans", "spec_trans", "the share of the dielectric that transmits (rough glass of the "
                    "colour's square root) rather than reflecting diffusely"),
            Parameter("eta", ("principled_eta",), Key("eta", "number", "the relative index of refraction, "
                                                      "inside over outside", default=None, low=0, open_low=True,
                                                      also="not with specular"), mitsuba=None),
            _weight("specular", "principled_specular", "the dielectric's normal-incidence reflectance over "
                    "0.08: sets eta = 2 / (1 - sqrt(0.08 specular)) - 1", default=None, mitsuba=0.5,
                    also="not with eta; both absent: 0.5", texture=False),
            _weight("spec_tint", "spec_tint", "the share of the dielectric's reflection tinted towards the "
                    "colour's hue"),
            _weight("sheen", "sheen", "a grazing sheen's weight (cloth)"),
            _weight("sheen_tint", "sheen_tint", "the share of the sheen tinted towards the colour's hue"),
            _weight("flatness", "flatness", "the share of the diffuse reflection that is Hanrahan and Krueger's "
                    "fake subsurface scattering (flatter, brighter towards grazing) rather than Burley's"),
            _weight("clearcoat", "clearcoat", "a second, white, glossy coat's weight (GTR1 normals)"),
            _weight("clearcoat_gloss", "clearcoat_gloss", "the coat's gloss: its GTR1 roughness from 0.1 (0) "
                    "to 0.001 (1)"),
            Parameter("diffuse_reflectance_sampling_rate", ("diffuse_reflectance_sampling_rate",),
                      Key("diffuse_reflectance_sampling_rate", "number", f"the diffuse lobe's {rate}", default=1.0,
                          low=0, high=1024)),
            Parameter("main_specular_sampling_rate", ("main_specular_sampling_rate",),
                      Key("main_specular_sampling_rate", "number", f"the main lobes' {rate}", default=1.0,
                          low=2.0 ** -10, high=1024)),
            Parameter("clearcoat_sampling_rate", ("clearcoat_sampling_rate",),
                      Key("clearcoat_sampling_rate", "number", f"the clearcoat's {rate}", default=1.0, low=0,
                          high=1024)))


def _principledthin():
    """principledthin's parameters, in Mitsuba's order (its doc's)."""
    rate = "share in choosing which lobe to sample (a ratio to the other rates)"
    rates = [Parameter(name, (name,), Key(name, "number", f"the {what}'s {rate}", default=1.0, low=2.0 ** -10,
                                          high=1024))
             for name, what in (("diffuse_reflectance_sampling_rate", "diffuse reflection"),
                                ("specular_reflectance_sampling_rate", "glossy reflection"),
                                ("specular_transmittance_sampling_rate", "glossy transmission"),
                                ("diffuse_transmittance_sampling_rate", "diffuse transmission"))]
    return (_reflectance("base_color", "the diffuse lobes' albedo, the transmission's colour, the tints' hue",
                         (0.5, 0.5, 0.5), mitsuba=0.5),
            _weight("roughness", "roughness", "the glossy lobes' roughness (GGX alpha its square, at least 1e-3; "
                    "the transmission's of (0.65 eta - 0.35) roughness); also the diffuse's retro-reflection",
                    default=0.5),
            _weight("anisotropic", "anisotropic", "the glossy lobes' anisotropy: alpha along u over alpha along v "
                    "is 1 / (1 - 0.9 anisotropic)"),
            _weight("spec_trans", "spec_trans", "the share of the glossy lobes (a rough dielectric sheet's "
                    "reflection and its transmission, undeflected) rather than the diffuse ones"),
            Parameter("eta", ("principled_eta",), Key("eta", "number", "the sheet's relative index of refraction, "
                                                      "for its Fresnel reflectance and its transmission's "
                                                      "roughness (a number or a texture)", default=1.5,
                                                      low=2.0 ** -16, high=2.0 ** 16)),
            _weight("spec_tint", "spec_tint", "the share of the glossy reflection tinted towards the colour's hue"),
            _weight("sheen", "sheen", "a grazing sheen's weight (cloth)"),
            _weight("sheen_tint", "sheen_tint", "the share of the sheen tinted towards the colour's hue"),
            _weight("flatness", "flatness", "the share of the diffuse reflection that is Hanrahan and Krueger's "
                    "fake subsurface scattering (flatter, brighter towards grazing) rather than Burley's"),
            Parameter("diff_trans", ("diff_trans",), Key("diff_trans", "number", "the diffuse light's share "
                                                         "transmitted, times 2: 0 reflects it all, 1 half, 2 "
                                                         "transmits it all (a number or a texture)", default=0.0,
                                                         low=0, high=2)),
            *rates)


DECLARED = (
    BSDF("diffuse", "smooth diffuse (Lambertian)", """\
An ideally diffuse surface: light arriving from any direction is scattered over the hemisphere with a density
proportional to the cosine, so that the surface looks the same from every direction of view. Its reflectance is
the albedo: the fraction of the light it scatters. The Phong and direct models' materials are diffuse too.""",
         (_reflectance("reflectance", "the albedo", None, mitsuba=0.5,
                       also="not with colour; one of them is required without a texture"),), "",
         'type = "diffuse"\nreflectance = [0.2, 0.25, 0.7]  # or colour'),
    BSDF("conductor", "smooth conductor (a mirror)", """\
A perfectly smooth metal: each ray is reflected about the normal, weighted by the Fresnel reflectance of the
complex index of refraction eta + i k, per channel. A named metal gives both parts as Mitsuba's rgb variants
compute them from measured spectra; eta = k = 0, the default (Mitsuba's material "none"), reflects everything.""",
         _conductor(), "conductors", 'type = "conductor"\nmaterial = "Au"  # or eta and k'),
    BSDF("dielectric", "smooth dielectric (glass)", """\
A smooth interface between two dielectrics of indices int_ior (inside, the side the normal points away from) and
ext_ior (outside), such as glass in air: each ray is reflected or refracted, chosen with the Fresnel reflectance;
beyond the critical angle inside the denser medium, reflected whole. It scatters on both sides, so a closed
shape is its medium's boundary; colour is a factor on the reflection and the transmission alike.""",
         (*_iors(DEFAULT_INT_IOR, "bk7"), *_glass_colour()), "dielectrics",
         'type = "dielectric"\nint_ior = "water"  # or a number; ext_ior is air\'s by default',
         front_only=False),
    BSDF("roughconductor", "rough conductor (microfacets)", """\
A rough metal: the surface is a distribution of tiny smooth conductor facets (microfacets), their normals spread
by the roughness alpha after GGX's or Beckmann's distribution, with Smith's masking and shadowing between them.
Roughness along the tangent and the bitangent may differ (alpha_u, alpha_v: a brushed metal), following the
surface's texture coordinates. Its eta, k and material are the smooth conductor's.""",
         (*_conductor(), *_roughness(anisotropic=True)), "rough_conductors",
         'type = "roughconductor"\nmaterial = "Cu"\ndistribution = "beckmann"\nalpha_u = 0.05  # or alpha alone, '
         'the same along both\nalpha_v = 0.3'),
    BSDF("thindielectric", "thin dielectric (a pane)", """\
A dielectric so thin that its two interfaces coincide, such as a window pane modelled as one sheet: a ray is
reflected, with the reflectance of both interfaces and of the light bouncing between them, or passes straight
through, undeflected. For closed glass, use the dielectric.""",
         (*_iors(DEFAULT_INT_IOR, "bk7"), *_glass_colour()), "thin_dielectrics",
         'type = "thindielectric"\nint_ior = 1.5', front_only=False),
    BSDF("roughdielectric", "rough dielectric (frosted glass)", """\
The rough counterpart of the dielectric: an interface of microfacets, each a smooth dielectric, their normals
spread by the roughness as the rough conductor's, reflecting and refracting after Walter et al.'s microfacet model
of refraction (2007), such as etched or ground glass. int_ior and ext_ior must differ.""",
         (*_iors(DEFAULT_INT_IOR, "bk7"), *_glass_colour(), *_roughness(anisotropic=True)), "rough_dielectrics",
         'type = "roughdielectric"\ndistribution = "ggx"\nalpha = 0.2\nint_ior = "bk7"', front_only=False,
         distinct_iors=True),
    BSDF("plastic", "smooth plastic", """\
A diffuse base under a smooth dielectric coat, such as plastic or varnished wood: the coat reflects as a mirror
with its Fresnel reflectance, and the light it transmits scatters diffusely from the base, some of it reflected
back inside the coat again and again before it leaves. nonlinear lets that internal scattering shift the base's
colour, as it does in reality; by default the colour is kept as given.""",
         _plastic(), "plastics", 'type = "plastic"\ndiffuse_reflectance = [0.1, 0.27, 0.36]\nint_ior = 1.9'),
    BSDF("roughplastic", "rough plastic", """\
The rough counterpart of the plastic: its coat is an interface of microfacets, isotropic (one roughness alpha),
reflecting glossily over the diffuse base. int_ior and ext_ior must differ.""",
         (*_plastic(), *_roughness(anisotropic=False)), "rough_plastics",
         'type = "roughplastic"\ndiffuse_reflectance = [0.8, 0.2, 0.1]\ndistribution = "beckmann"\nalpha = 0.1\n'
         'nonlinear = true', distinct_iors=True),
    BSDF("null", "no surface for light", """\
A surface that light passes straight through, unchanged, as if it were not there; what a `mask` is where its
opacity lets light through. A pass counts as a bounce (`max_depth`), as in Mitsuba's `path`; shadow rays pass
it too (Mitsuba's stop), so light behind a leaf is sampled directly, with less noise.""", (), "nulls", 'type = "null"', front_only=False),
    BSDF("principled", "principled (Disney's)", """\
Disney's principled BSDF (Burley 2012 and 2015) as Mitsuba 3 writes it: one colour and a handful of weights in
[0, 1] that blend a diffuse base with retro-reflection and sheen, a rough dielectric's reflection (optionally
tinted), a metal's, a rough transmission (spec_trans: rough glass) and a clear coat, for materials from metals
to plastics, cloth and frosted glass. Its main lobes are anisotropic GGX microfacets of alpha = roughness^2;
eta (or specular) sets the dielectric's index. An opaque principled reflects on both sides; one that transmits
has an inside, as glass does. flatness turns the diffuse base towards a fake subsurface look (Hanrahan and
Krueger's).""",
         _principled(), "principled",
         'type = "principled"\nbase_color = [0.8, 0.3, 0.2]\nroughness = 0.3\nmetallic = 0.2\nclearcoat = 0.5',
         front_only=False),
    BSDF("principledthin", "thin principled (Disney's, a sheet)", """\
Disney's principled BSDF for thin sheets (Burley 2015) as Mitsuba 3 writes it: a surface of no thickness, the
same from both sides, such as a leaf, paper, a curtain or a pane of frosted glass. One colour and a handful of
weights blend a diffuse reflection with retro-reflection and sheen (flattened towards a fake subsurface look by
flatness), a diffuse transmission (diff_trans), and a rough dielectric sheet's reflection and undeflected
transmission (spec_trans), anisotropic GGX microfacets of alpha = roughness^2; eta sets the sheet's Fresnel
reflectance and its transmission's roughness. Light passes it without bending: use it on open surfaces
(rectangles, single-sided meshes), not to bound a volume.""",
         _principledthin(), "principledthin",
         'type = "principledthin"\nbase_color = [0.3, 0.6, 0.2]\nroughness = 0.4\ndiff_trans = 0.8\n'
         'spec_trans = 0.2', front_only=False),
)
# Mitsuba's wrappers a material can be instead of a BSDF (model.WRAPPERS), with their own keys: a blend of two
# materials, and a mask of one
WRAPPER_KEYS = {
    "blendbsdf": [Key("weight", "number", "the second material's share: 0 is the first alone, 1 the second (a "
                      "number or a texture)", default=0.5, low=0, high=1),
                  Key("bsdfs", "strings", "the two materials it mixes, by name", length=2,
                      also="defined materials, not blending themselves")],
    "mask": [Key("opacity", "number", "the share of light the masked material scatters; the rest passes through "
                 "(a number or a texture)", default=0.5, low=0, high=1),
             Key("bsdf", "string", "the masked material, by name", also="a defined material")],
}


BY_NAME = {bsdf.name: bsdf for bsdf in DECLARED}
# The BSDFs with indices of refraction (the kernel's eta.x is int_ior / ext_ior), and those with a microfacet
# distribution (alpha, alpha_v, distribution): read off their parameters.
INDEXED = tuple(bsdf.name for bsdf in DECLARED if "int_ior" in bsdf.key_names())
ROUGH = tuple(bsdf.name for bsdf in DECLARED if "distribution" in bsdf.key_names())
# Every key of every type's table, in the order they are first declared: a material of one type given another's
# key is refused as such (scene_file.py's own_keys), an unknown key as unknown.
KEY_NAMES = tuple(dict.fromkeys([name for bsdf in DECLARED for name in bsdf.key_names()]
                                + [key.name for keys in WRAPPER_KEYS.values() for key in keys]))
assert tuple(BY_NAME) == BSDFS, "model.BSDFS lists the declared BSDFs in the kernel's numbering"


# principled's weights that take a texture, each its own map slot of its name (its base_color is the colour's;
# its eta and specular are numbers, as in Mitsuba: a float property, not a texture)
PRINCIPLED_SLOTS = ("roughness", "anisotropic", "metallic", "spec_tint", "sheen", "sheen_tint", "clearcoat",
                    "clearcoat_gloss", "spec_trans")
THIN_SLOTS = ("flatness", "diff_trans", "principled_eta")  # principledthin's own, besides those it shares
# The kernel's map slot (kernels/types.h's MAP_*) a texture on a parameter fills, by the Material fields it sets
TEXTURED = {("colour",): "colour", ("specular",): "specular", ("alpha",): "alpha", ("alpha_v",): "alpha_v",
            ("eta",): "eta", ("k",): "k", **{(name,): name for name in PRINCIPLED_SLOTS + THIN_SLOTS}}


def texture_slot(bsdf, name):
    """The map slot a texture given for parameter `name` of `bsdf` fills, or None where it takes a value only, as
    in Mitsuba: a roughplastic's alpha (its coat's transmittance table is found for it), principled's eta."""
    p = next((p for p in bsdf.parameters if p.key is not None and p.key.name == name), None)
    if p is None or (bsdf.name, name) in (("roughplastic", "alpha"), ("principled", "eta")):
        return None
    return TEXTURED.get(p.fields)


def key_tables():
    """keys.py's tables of the BSDFs' keys, one per type in model.BSDFS's order, which the scene format's page
    lists after the keys every material has ("materials.NAME")."""
    return {bsdf.table: bsdf.keys() for bsdf in DECLARED} | {table_name(name): keys
                                                             for name, keys in WRAPPER_KEYS.items()}


def declaring(field):
    """The keys that set Material field `field`, in the order of the declarations (each type's own first
    where a caller looks for its own)."""
    return [p.key for bsdf in DECLARED for p in bsdf.parameters if p.key is not None and p.fields == (field,)]
