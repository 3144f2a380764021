"""principled's textured parameters (Mitsuba 3's `principled` takes a texture for each of base_color, roughness,
anisotropic, metallic, spec_tint, sheen, sheen_tint, flatness, clearcoat, clearcoat_gloss and spec_trans; its eta
and specular are floats): base_color through the colour's lookup (MAP_COLOUR), the weights through their own
(MAP_ROUGHNESS .. MAP_SPEC_TRANS, and flatness through principledthin's MAP_FLATNESS), and the terms the host derives from them per material (principled_terms.py:
the main lobe's alphas, the clearcoat's GTR1 roughness, Mitsuba's has_spec_trans) derived per hit in the kernel
(material.cl's principled_lookups, under HAS_PRINCIPLED_LOOKUPS). The same for `principledthin` (Mitsuba's takes a
texture for every parameter but its sampling rates: besides principled's shared weights, flatness, diff_trans,
halved as Mitsuba takes it, and eta, from which with roughness and anisotropic its transmission's alphas derive),
and the conductors' eta and k (colours: material.cl's lookup_material).

(1) A constant texture (a checkerboard of two equal colours) gives what the constant parameter gives, bit for bit
(principled, principledthin, conductor and roughconductor):
each parameter's own, and all of them at once, over the shading points of whole scenes (camera rays into a wall
of panels, half of them seen from behind: a transmitting principled's inside), at every lane width: the shading
point's values and alphas, bsdf_eval_pdf's value and density towards random directions, bsdf_sample's direction,
weight and density. No tolerance is needed, and none is given: a weight's float parameter of a checkerboard is
its colour's mean, (c + c + c) (1/3) in float32, which is c exactly for the values used (checked: exact()); the
alphas and the clearcoat's roughness are the same float32 operations as the host's numpy (no fma: the kernel's
FP_CONTRACT is off there), sqrt and the division correctly rounded on pocl's CPU device (an OpenCL device
allowed 3 and 2.5 ulp there would need a tolerance of that many ulp in alpha: none is run here). The tests build
the constant and the textured scenes with their own features (the constant one without HAS_LOOKUPS), and the
textured scene's materials have their constant values (the textures' means, which the host derives its terms
from) replaced by 1/16 (blinded): only the kernel's lookups and derivations can give the constant's values.
(2) A checkerboard of two values of roughness (isotropic: the isotropic alpha) and of metallic gives each hit the
values of the constant material of its square's value, where Mitsuba's eval_1 puts the squares (its float
lookups swap the checkerboard's colours: lookup_support.checkerboard), hits within 2e-3 of a square's border
left out; and a checkerboard spec_trans of 0 and 1 makes the material transmit, whose squares of 0 seen from
inside scatter nothing (Mitsuba's has_spec_trans; types.h's PRINCIPLED_TRANSMITS).
(3) Refusals, one line each: a texture on principled's eta, specular or a sampling rate (Mitsuba takes floats
there), a weight's texture outside [0, 1] (a checkerboard colour's mean, a bitmap's luminance), principledthin's
diff_trans outside [0, 2] and eta outside [2^-16, 2^16] (a conductor's eta and k, like every texture, are
refused below 0 by textures.py), in the scene file and the XML loader; and the XML loader's mapping of each textured parameter.
(4) The corpus scenes scenes/mitsuba/principled_textures.xml, principledthin_textures.xml and
conductor_textures.xml against Mitsuba 3.9.1 are tests/test_mitsuba_corpus.py's (references in
scenes/mitsuba/references).

Mutations tried (each applied to the checkout, the file restored after; every one failed the tests named, at
every lane width unless said):
- material.cl, principled_lookups: the clearcoat's lerp with 0.01f for 0.001f:
  test_constant_texture_is_the_constant;
- material.cl: alpha_v = r2 / aspect (as alpha_u): test_constant_texture_is_the_constant;
- material.cl: the alphas not derived (roughness looked up, the host's alphas kept): test_constant_texture_is_the_
  constant and test_checkerboard_regions;
- material.cl: the FP_CONTRACT OFF pragma removed: test_constant_texture_is_the_constant (pocl's clang fuses the
  sums into fmas: the derived values differ from the host's in the last bit);
- material.cl: a lookup's value written on every lane, not only its material's (the macro's mask dropped):
  test_constant_texture_is_the_constant and test_checkerboard_regions at 4, 8 and 16 lanes (not 1: no neighbour);
- material.cl: MAP_SHEEN's value written into PRINCIPLED_SHEEN_TINT: test_constant_texture_is_the_constant;
- principled.cl: the frame's inside by the lane's (1 - metallic) spec_trans > 0 (not PRINCIPLED_TRANSMITS):
  test_textured_spec_trans_has_an_inside (and the corpus scene: 106 values over the threshold, worst |z| 6.6);
- principled.cl: the inside's transmission probability by the lane's spec_trans != 0 (not the flag):
  test_textured_spec_trans_has_an_inside (its density);
- lookups.cl: a float parameter's checkerboard without eval_1's swap: test_checkerboard_regions and
  test_textured_spec_trans_has_an_inside;
- material.cl: principledthin's transmission alphas not derived, or derived with eta 1.5 for the lane's, its
  diff_trans not halved, its flatness or eta not looked up: test_constant_texture_is_the_constant[principledthin];
- material.cl: flatness not looked up: test_constant_texture_is_the_constant[principled] (and [principledthin]);
- bsdfs.py: principled's flatness a value only (texture_slot None for it): test_refusals_and_xml_mapping;
- material.cl: a conductor's eta not looked up, its k written on every lane: test_constant_texture_is_the_constant
  [conductor, roughconductor] (the k mutation at 4, 8 and 16 lanes);
- texture_lookups.py: the [0, 1] check dropped: test_refusals_and_xml_mapping;
- mitsuba.py: a conductor's eta (k) given as a value putting Mitsuba's default k (eta) over the other's texture
  (the loader's bug that the corpus scene conductor_textures.xml found: 869 values over, |z| 17.6):
  test_refusals_and_xml_mapping;
- principled_terms.py: transmits() without the textured spec_trans: test_refusals_and_xml_mapping (the flag, and
  specular 0 taken as 1e-3).
"""
import dataclasses

import numpy as np
import pytest

import raytrace
import lookup_support as mts
from raytrace import structs
from raytrace.errors import InputError
from raytrace.renderer.packing import material_structs, texture_tables
from raytrace.renderer.program import Features
from raytrace.renderer.scene_tables import scene_tables
from raytrace.scene.bsdfs import PRINCIPLED_SLOTS
from helpers import ROOT

WEIGHTS = (*PRINCIPLED_SLOTS, "flatness")  # principled's textured weights (flatness's slot is principledthin's too)

KERNEL = """
#include "camera.cl"
#include "bsdf.cl"
__kernel void shade(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const float *xy,
                    __global const float *wi_, __global const float *u, __global float *f, __global float *pdf,
                    __global float *s_wi, __global float *s_weight, __global float *s_pdf, __global float *alpha,
                    __global float *values, __global float *k, __global float *eta, __global float *eta_k,
                    __global float *pos, __global float *material)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 lens = {(vfloat)(0.0f), (vfloat)(0.0f)};
    vfloat tmax;
    Ray r = generate_camera_ray(camera, IN(xy), IN(xy + n), lens, &tmax);
    Hit hit = closest_hit(&s, r, (vfloat)(INFINITY));
    OUT(material, CONVERT_VFLOAT(hit.material));
    OUT3(pos, hit.p);
    ShadingPoint sp = shading_point(&s, ts, r, hit);
    const vint all = (vint)(-1) != 0;
    vec3 wo = v3_scale(r.d, -1.0f), wi = IN3(wi_);
    vfloat p;
    OUT3(f, bsdf_eval_pdf(sp, wo, wi, all, &p));
    OUT(pdf, p);
    vec2 u2 = {IN(u + n), IN(u + 2 * n)};
    BSDFSample bs = bsdf_sample(sp, wo, IN(u), u2, all);
    OUT3(s_wi, bs.wi);
    OUT3(s_weight, bs.weight);
    OUT(s_pdf, bs.pdf);
    OUT(alpha, sp.alpha);
#if HAS_MICROFACETS
    OUT(alpha + n, sp.alpha_v);
#else
    OUT(alpha + n, (vfloat)(0.0f));
#endif
    for (int j = 0; j < PRINCIPLED_PARAMETERS; ++j)
#if HAS_PRINCIPLED_VALUES
        OUT(values + j * n, sp.principled[j]);
#else
        OUT(values + j * n, (vfloat)(0.0f));
#endif
    OUT3(k, sp.k);
    OUT3(eta, sp.eta);
    OUT3(eta_k, sp.k_imag);
}
"""
OUTPUTS = {"f": 3, "pdf": 1, "s_wi": 3, "s_weight": 3, "s_pdf": 1, "alpha": 2, "values": structs.PRINCIPLED_PARAMETERS,
           "k": 3, "eta": 3, "eta_k": 3, "pos": 3, "material": 1}
COMPARED = ("f", "pdf", "s_wi", "s_weight", "s_pdf", "alpha", "values", "k", "eta", "eta_k")
N = 4096  # camera rays per scene

# Every weight away from 0 and 1 (each lobe present; all transmit, so the panels seen from behind are insides),
# anisotropic: the tangent's frame in both builds
BASE = {"type": "principled", "base_color": [0.6, 0.4, 0.3], "roughness": 0.375, "anisotropic": 0.5,
        "metallic": 0.25, "spec_tint": 0.5, "sheen": 0.5, "sheen_tint": 0.5, "flatness": 0.25, "clearcoat": 0.75,
        "clearcoat_gloss": 0.5, "spec_trans": 0.5, "specular": 0.6}
# each textured parameter's constant value, other than BASE's
VALUES = {"base_color": [0.25, 0.5, 0.75], "roughness": 0.625, "anisotropic": 0.75, "metallic": 0.125,
          "spec_tint": 0.75, "sheen": 0.875, "sheen_tint": 0.25, "flatness": 0.625, "clearcoat": 0.5,
          "clearcoat_gloss": 0.875, "spec_trans": 0.75}
# principledthin: every weight away from 0 and 1, and its own textured parameters (flatness, diff_trans, eta)
BASE_THIN = {"type": "principledthin", "base_color": [0.6, 0.4, 0.3], "roughness": 0.375, "anisotropic": 0.5,
             "spec_trans": 0.5, "eta": 1.25, "spec_tint": 0.5, "sheen": 0.5, "sheen_tint": 0.5, "flatness": 0.25,
             "diff_trans": 0.75}
VALUES_THIN = {"base_color": [0.25, 0.5, 0.75], "roughness": 0.625, "anisotropic": 0.75, "spec_trans": 0.75,
               "eta": 1.625, "spec_tint": 0.75, "sheen": 0.875, "sheen_tint": 0.25, "flatness": 0.625,
               "diff_trans": 1.375}
# the conductors' eta and k, colours (their lookups' own values, no mean to take)
BASE_METAL = {"eta": [0.25, 0.5, 1.5], "k": [3.0, 2.5, 2.0]}
VALUES_METAL = {"eta": [1.5, 0.75, 0.125], "k": [1.25, 3.5, 4.0], "specular_reflectance": [0.875, 0.75, 0.625]}
FAMILIES = {"principled": (BASE, VALUES), "principledthin": (BASE_THIN, VALUES_THIN),
            "roughconductor": ({"type": "roughconductor", "alpha_u": 0.25, "alpha_v": 0.125, **BASE_METAL},
                               VALUES_METAL),
            "conductor": ({"type": "conductor", **BASE_METAL}, VALUES_METAL)}
TO_UV = [[3.0, 0.5, 0.25], [-0.5, 2.0, 0.0]]
CAMERA = {"position": [0.0, -2.1, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0], "fov": 40.0}  # the wall


def exact(v):
    """Whether the kernel's float parameter of a checkerboard of colour (v, v, v), (v + v + v) (1 / 3) in float32,
    is v itself."""
    x = np.float32(v)
    return np.float32(np.float32(np.float32(x + x) + x) * np.float32(1.0 / 3.0)) == x


def checkerboard(c0, c1):
    return {"type": "checkerboard", "color0": c0, "color1": c1, "to_uv": TO_UV}


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def wall(names):
    """Panels in a 6 x 4 grid facing the default camera, each name twice: seen from the front and (its normal
    turned away) from behind, each a little tilted."""
    rng = np.random.default_rng(3)
    shapes = []
    for i, name in enumerate([n for n in names for _ in range(2)]):
        col, row = i % 6, i // 6
        normal = unit(np.array([rng.uniform(-0.3, 0.3), -1.0 if i % 2 == 0 else 1.0, rng.uniform(-0.3, 0.3)]))
        tangent = unit(np.array([1.0, 0.0, 0.0]) - normal[0] * normal)
        shapes.append(mts.panel(name, center=(-0.95 + 0.38 * col, 0.0, 0.57 - 0.38 * row), size=(0.36, 0.36),
                                normal=tuple(normal), tangent=tuple(tangent)))
    return shapes


def blinded(scene):
    """The scene with each textured parameter's own value (the texture's mean, which the host derives its terms
    from) replaced by another, 1/16: what the kernel then shows of the parameter it found by its lookups only."""
    materials = []
    for m in scene.materials:
        fields = {slot: (np.full(3, 0.0625) if slot in ("colour", "eta", "k") else 0.0625) for slot, _ in m.maps}
        materials.append(dataclasses.replace(m, **fields))
    return dataclasses.replace(scene, materials=materials)


def shade(harness, table, seed=0, blind=False):
    """The kernel's outputs at N random camera rays into the scene of `table` (blinded, where `blind`): {name:
    (N, components)}, the scene and its defines."""
    scene = raytrace.load_dict(table)
    scene = blinded(scene) if blind else scene
    features = Features.of(scene, harness.lanes)
    defines = {o[2:].split("=")[0]: int(o.split("=")[1]) for o in features.options()[1:]}
    rng = np.random.default_rng(seed)
    xy = np.concatenate([rng.uniform(0, scene.width, N), rng.uniform(0, scene.height, N)])
    wi = unit(rng.normal(size=(N, 3)))
    u = rng.uniform(size=(3, N))
    args = {**scene_tables(scene, scene.width, scene.height, 1, 1, "bilinear", features=features),
            **texture_tables(scene), "xy": xy.astype(np.float32), "wi_": wi.T.ravel().astype(np.float32),
            "u": u.ravel().astype(np.float32)}
    out = harness.run(KERNEL, "shade", N, args, OUTPUTS, **defines)
    out = {k: v.T if v.ndim == 2 else v[:, None] for k, v in out.items()}
    out["material"] = np.rint(out["material"][:, 0]).astype(int)
    return out, scene, defines


def same(a, b, lanes=slice(None), compared=COMPARED):
    """The names of `compared` whose outputs differ in any bit on `lanes`."""
    bits = lambda x: np.ascontiguousarray(x, np.float32).view(np.uint32)  # noqa: E731 (the outputs are float32's)
    return [k for k in compared if not np.array_equal(bits(a[k][lanes]), bits(b[k][lanes]))]


def test_values_are_exact():
    """The float values the textures below take are their checkerboards' float parameters exactly (and one that
    is not: the check can fail)."""
    assert all(exact(v) for v in [*VALUES.values(), *VALUES_THIN.values(), 0.25, 0.75, 0.125, 0.875]
               if isinstance(v, float))
    assert not exact(0.1)


@pytest.mark.parametrize("family", FAMILIES)
def test_constant_texture_is_the_constant(harness, family):
    """(1): per textured parameter and all at once, a checkerboard of two equal colours against the value, for
    principled, principledthin (whose transmission's alphas derive from its roughness, anisotropic and eta) and the
    conductors' eta and k."""
    base, values = FAMILIES[family]
    names = [*values, "all"]
    constant = {name: {**base, **({name: values[name]} if name in values else values)} for name in names}
    textured = {name: {**base, **{p: checkerboard(v, v) for p, v in values.items() if name in (p, "all")}}
                for name in names}
    a, scene_a, defines_a = shade(harness, mts.path_scene(constant, wall(names), CAMERA, width=48, height=32))
    b, scene_b, defines_b = shade(harness, mts.path_scene(textured, wall(names), CAMERA, width=48, height=32),
                                  blind=True)
    assert defines_a["HAS_LOOKUPS"] == 0 and defines_b["HAS_LOOKUPS"] == 1
    assert defines_b["HAS_PRINCIPLED_LOOKUPS"] == family.startswith("principled")
    assert defines_a["HAS_ANISOTROPIC"] == defines_b["HAS_ANISOTROPIC"] == (family != "conductor")
    slots = {"base_color": "colour", "specular_reflectance": "colour", "eta": "principled_eta"
             if family == "principledthin" else "eta"}
    assert [slot for slot, _ in scene_b.materials[names.index("all")].maps] == [slots.get(p, p) for p in values]
    assert np.array_equal(a["material"], b["material"]) and np.array_equal(a["pos"], b["pos"])
    # the blinded materials' host values differ from the constant's: only the kernel's lookups can agree
    table_a, table_b = material_structs(scene_a.materials), material_structs(scene_b.materials)
    for i, name in enumerate(names):
        field = "principled" if family.startswith("principled") and name != "eta" else "eta"
        assert not np.array_equal(table_a[i][field], table_b[i][field]) or name in ("base_color", "k",
                                                                                   "specular_reflectance")
        lanes = a["material"] == i
        assert np.count_nonzero(lanes) > 40, (name, np.count_nonzero(lanes))
        assert same(a, b, lanes) == [], (name, same(a, b, lanes))
    assert same(a, b) == []
    hit = a["material"] >= 0
    assert np.count_nonzero(hit) > 0.7 * N * len(names) / 12  # (the wall's 24 places, 2 per name)
    if family != "conductor":  # (a delta BSDF has no density to compare)
        assert np.count_nonzero(a["pdf"][hit] > 0) > 0.5 * np.count_nonzero(hit)  # the lobes are there to compare
    assert np.count_nonzero(a["s_pdf"][hit] > 0) > 0.5 * np.count_nonzero(hit)


ROWS = [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0]]  # (2)'s checkerboards: 4 x 4 periods over a panel


def two_panels(materials, names, back=False):
    """Two 1 x 1.4 panels side by side, of materials `names`, the second facing away from the camera where
    `back`."""
    return mts.path_scene(materials, [mts.panel(names[0], center=(-0.55, 0.0, 0.0), size=(1.0, 1.4)),
                                      mts.panel(names[1], center=(0.55, 0.0, 0.0), size=(1.0, 1.4),
                                                normal=(0.0, 1.0, 0.0) if back else (0.0, -1.0, 0.0))],
                          width=48, height=32)


def squares(got, index, cx, back, lo, hi):
    """The lanes of the hits on panel `index` (centred at x = cx; facing away where `back`: its v runs down) in
    the squares of a float parameter's checkerboard (lo, hi) under ROWS where Mitsuba's eval_1 gives lo, and
    where hi, each without the lanes within 2e-3 of a border."""
    lanes = np.flatnonzero(got["material"] == index)
    p = got["pos"][lanes]
    u, v = (p[:, 0] - cx) / 1.0 + 0.5, (-p[:, 2] if back else p[:, 2]) / 1.4 + 0.5
    s, t, _ = mts.mitsuba_st(ROWS, u, v)
    first = mts.checkerboard(s, t, [lo] * 3, [hi] * 3, True)[:, 0] == lo
    kept = ~(mts.near_border(s, 2, 2e-3) | mts.near_border(t, 2, 2e-3))
    assert np.count_nonzero(kept & first) > 150 and np.count_nonzero(kept & ~first) > 150
    return lanes[kept & first], lanes[kept & ~first]


def test_checkerboard_regions(harness):
    """(2): a checkerboard of roughness (0.25, 0.75; anisotropic 0: the isotropic alpha) on one panel, of metallic
    (0.125, 0.875) on another; each hit has what the constant material of its square's value has."""
    lo, hi = {"roughness": 0.25, "metallic": 0.125}, {"roughness": 0.75, "metallic": 0.875}
    base = {**BASE, "anisotropic": 0.0}
    names = ("roughness", "metallic")

    def scene(values):
        return two_panels({p: {**base, p: values[p]} for p in names}, names)

    textured = {p: {"type": "checkerboard", "color0": lo[p], "color1": hi[p], "to_uv": ROWS} for p in names}
    got, _, defines = shade(harness, scene(textured))
    assert defines["HAS_ANISOTROPIC"] == 0 and defines["HAS_PRINCIPLED_LOOKUPS"] == 1
    want_lo, _, _ = shade(harness, scene(lo))
    want_hi, _, _ = shade(harness, scene(hi))
    for index, name in enumerate(names):
        at_lo, at_hi = squares(got, index, (-0.55, 0.55)[index], False, lo[name], hi[name])
        assert same(got, want_lo, at_lo) == [] and same(got, want_hi, at_hi) == [], name


def test_textured_spec_trans_has_an_inside(harness):
    """(2), spec_trans: a checkerboard of 0 and 1 makes the material transmit (Mitsuba's has_spec_trans), on a
    panel seen from the front and one seen from behind. Its squares of 1 have the constant spec_trans 1's values
    on both sides; its squares of 0 the constant (opaque) spec_trans 0's from the front, and from behind, inside
    a material that transmits but not there, nothing at all (Mitsuba: no lobe inside but the main reflection and
    the transmission, both weighted (1 - metallic) spec_trans), where the opaque material reflects."""
    names = ("front", "back")

    def scene(value):
        return two_panels({n: {**BASE, "spec_trans": value} for n in names}, names, back=True)

    got, _, _ = shade(harness, scene({"type": "checkerboard", "color0": 0.0, "color1": 1.0, "to_uv": ROWS}))
    transmits, _, _ = shade(harness, scene(1.0))
    opaque, _, _ = shade(harness, scene(0.0))
    flagged = {**opaque, "values": opaque["values"].copy()}  # the opaque's values but its flag: transmits
    flagged["values"][:, structs.PRINCIPLED.index("transmits")] = 1
    at_0, at_1 = squares(got, 0, -0.55, False, 0.0, 1.0)
    assert same(got, flagged, at_0) == [] and same(got, transmits, at_1) == []
    at_0, at_1 = squares(got, 1, 0.55, True, 0.0, 1.0)
    assert same(got, transmits, at_1) == []
    assert np.all(got["f"][at_0] == 0) and np.all(got["s_weight"][at_0] == 0)
    # the density inside is the lobes' (reflection F, transmission 1 - F: not of the weights), as Mitsuba's pdf
    assert same(got, transmits, at_0, ("pdf",)) == [] and np.count_nonzero(got["pdf"][at_0]) > 0.25 * len(at_0)
    assert np.count_nonzero(opaque["f"][at_0].sum(axis=1) > 0) > 0.25 * len(at_0)


def refusal(material, **scene):
    with pytest.raises(InputError) as info:
        raytrace.load_dict(mts.path_scene({"m": material}, [mts.panel("m")], **scene))
    return str(info.value)


def principled_scene(tmp_path, inner):
    """A Mitsuba XML scene of one principled rectangle, its parameters `inner` (XML text)."""
    return raytrace.load_file(mts.xml_file(tmp_path, f'<bsdf type="principled">{inner}</bsdf>'))


def test_refusals_and_xml_mapping(tmp_path):
    """(3): one-line refusals of a texture where principled takes a number, and of a weight's texture beyond
    [0, 1]; the XML loader's maps of each textured parameter (a spec_trans texture transmits whatever its values,
    as Mitsuba's has_spec_trans: two-sided, eta's has_spec_trans rules)."""
    cb = {"type": "checkerboard", "color0": 0.2, "color1": 0.4}
    for key in ("eta", "specular", "main_specular_sampling_rate", "clearcoat_sampling_rate",
                "diffuse_reflectance_sampling_rate"):
        line = refusal({"type": "principled", key: cb})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.{key} = ") and \
            'takes a value, not a texture, in type = "principled"' in line, line
    for key in WEIGHTS:
        line = refusal({"type": "principled", key: {"type": "checkerboard", "color0": [0.2, 0.4, 1.5],
                                                    "color1": [1.2, 1.2, 1.5]}})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.{key} = ") and \
            "must lie in [0, 1] (its values span [0.7, 1.3])" in line, line
    for key, value, span in (("diff_trans", (0.5, 2.5), "[0, 2] (its values span [0.5, 2.5])"),
                             ("eta", (0.0, 2.5), "[1.52588e-05, 65536] (its values span [0, 2.5])")):
        line = refusal({"type": "principledthin", key: {"type": "checkerboard", "color0": value[0],
                                                         "color1": value[1]}})
        assert "\n" not in line and line.startswith(f"load_dict(): materials.m.{key} = ") and \
            f"this parameter's texture must lie in {span}" in line, line
    sky = str(ROOT / "assets" / "textures" / "sky.exr")  # an HDR sky: luminance up to 25
    line = refusal({"type": "principled", "roughness": {"type": "bitmap", "filename": sky}})
    assert "\n" not in line and "materials.m.roughness" in line and "must lie in [0, 1]" in line, line
    grid = {"type": "bitmap", "filename": str(ROOT / "assets" / "textures" / "grid.png")}  # 8-bit: within [0, 1]
    raytrace.load_dict(mts.path_scene({"m": {"type": "principled", "metallic": grid, "sheen": {**grid, "raw": True}}},
                                      [mts.panel("m")]))

    texture = '<texture name="NAME" type="checkerboard"><float name="color0" value="0"/>' \
              '<float name="color1" value="0"/></texture>'
    for key in ("specular", "eta"):
        with pytest.raises(InputError) as info:
            principled_scene(tmp_path, texture.replace("NAME", key))
        line = str(info.value)
        assert "\n" not in line and line.startswith(f"{tmp_path / 'scene.xml'}:9: ") and \
            "takes a value here, not a texture" in line, line
    every = "".join(texture.replace("NAME", key) for key in ("base_color", *WEIGHTS))
    scene = principled_scene(tmp_path, every + '<float name="specular" value="0"/>')
    (m,) = scene.materials
    assert sorted(slot for slot, _ in m.maps) == sorted(["colour", *WEIGHTS])
    # a textured spec_trans of 0 still transmits (Mitsuba's has_spec_trans): no one-sided wrapper, the flag, and
    # specular 0 taken as 1e-3 (eta 1.0179, not 1)
    assert m.two_sided and m.spec_trans == 0
    entry = material_structs(scene.materials)[0]
    assert entry["principled"][structs.PRINCIPLED.index("transmits")] == 1
    f32 = np.float32
    assert entry["eta"][0] == f32(2) / (f32(1) - np.sqrt(f32(0.08) * f32(1e-3))) - f32(1)
    assert texture_tables(scene)["lookups"]["luminance"].tolist() == [0] + [1] * len(WEIGHTS)
    options = Features.of(scene, 8).options()
    assert "-DHAS_PRINCIPLED_LOOKUPS=1" in options and "-DHAS_ANISOTROPIC=1" in options
    # a constant principled (no textured weight) compiles none of it
    scene = principled_scene(tmp_path, texture.replace("NAME", "base_color"))
    assert "-DHAS_PRINCIPLED_LOOKUPS=0" in Features.of(scene, 8).options()
    # principledthin's own textured parameters (floats: luminance lookups), and a conductor's eta or k textured
    # beside the other given as a value: the value kept, the texture too (the loader once put Mitsuba's default
    # of the textured one over its texture)
    for bsdf, inner, maps, luminance in (
            ("principledthin", "".join(texture.replace("NAME", key) for key in ("flatness", "diff_trans")) +
             texture.replace("NAME", "eta").replace('value="0"', 'value="1.5"'),
             ["flatness", "diff_trans", "principled_eta"], [1, 1, 1]),
            ("conductor", '<rgb name="eta" value="0.2, 0.9, 1.1"/>' + texture.replace("NAME", "k"), ["k"], [0]),
            ("roughconductor", texture.replace("NAME", "eta") + '<float name="k" value="3.2"/>', ["eta"], [0])):
        scene = raytrace.load_file(str(mts.xml_file(tmp_path, f'<bsdf type="{bsdf}">{inner}</bsdf>')))
        (m,) = scene.materials
        assert sorted(slot for slot, _ in m.maps) == sorted(maps), bsdf
        assert texture_tables(scene)["lookups"]["luminance"].tolist() == luminance, bsdf
        if bsdf == "conductor":
            assert m.eta == (0.2, 0.9, 1.1), m.eta
        if bsdf == "roughconductor":
            assert m.k == (3.2, 3.2, 3.2), m.k
