"""Textured parameters in a scene file: a BSDF parameter given as a table of one of Mitsuba 3's texture plugins
instead of a value, `bitmap` (an image) or `checkerboard`, with Mitsuba's names and defaults:

    [materials.brushed]
    type = "roughconductor"
    material = "Al"
    alpha = { type = "bitmap", filename = "roughness.png", raw = true, to_uv = [[4, 0, 0], [0, 4, 0]] }

`mesh_attribute` reads a mesh's attribute by Mitsuba's name (a PLY file's properties, ply_file.attribute_groups:
"vertex_color", "face_color", "vertex_<prefix>", "face_<prefix>"), times `scale`: a vertex attribute interpolated
over each triangle, a face attribute constant over its face. Every shape of such a material must be a mesh that
has it, of a size the parameter takes (rules.py): a colour parameter one value (for all three channels) or three,
a float parameter one (Mitsuba's eval and eval_1, src/render/mesh.cpp's eval_attribute: any other size is an
exception in its scalar variants and 0 in its vectorised ones).

Which parameters take a texture: the reflectances (`colour` and Mitsuba's names of it, a plastic's
`specular_reflectance`), the conductors' `eta` and `k`, the rough conductors' and dielectrics' `alpha`, `alpha_u`
and `alpha_v`, principled's weights and principledthin's parameters, a blend's `weight` and a mask's `opacity`;
each BSDF's table in the manual says so (bsdfs.TEXTURED). A float parameter of an RGB
image takes its luminance, of a checkerboard the mean of its colour's channels, as Mitsuba's eval_1 does.

`to_uv` is the texture's coordinates (s, t) of the surface's (u, v): two rows of Mitsuba's 3 x 3 matrix, (s, t) =
((a, b, c), (d, e, f)) . (u, v, 1), with t up the image as the surface's v (the course's colour maps' convention:
Mitsuba's XML reader composes Mitsuba's own, whose t runs down the image, with that flip). The material keeps the
texture's mean as its constant value, which the host uses where a BSDF needs one number for the whole material
(a plastic's choice between its lobes, as Mitsuba's mean()), and which the range checks see.
"""
import numpy as np

from .bsdfs import PRINCIPLED_SLOTS, THIN_SLOTS
from .declaration import Key
from .mipmap import SRGB8_TO_LINEAR
from .model import FILTER_TYPES, LOOKUPS, WRAP_MODES, TextureLookup
from .. import structs

TEXTURE_TABLE = 'must be a texture\'s table (type = "bitmap" or "checkerboard")'  # where a value will not do

# A mesh attribute's name starts with one of these (Mitsuba's Mesh::add_attribute: a value per vertex, or per face)
ATTRIBUTE_KINDS = ("vertex_", "face_")

# The scene format's table of a textured parameter's keys (keys.py lists it as "texture").
KEYS = [
    Key("type", "string", "Mitsuba's texture plugin: an image, or a checkerboard", choices=LOOKUPS),
    Key("filename", "path", "bitmap: the image (from the scene file's folder)", default=None,
        also='required with type = "bitmap"'),
    Key("raw", "boolean", "bitmap: take the image's values as they are (data: roughness, opacity); false decodes "
        "an 8-bit or 16-bit image's sRGB to linear", default=False),
    Key("filter_type", "string", "bitmap: nearest or bilinear (Mitsuba's, on the image itself), or trilinear or "
        "anisotropic (its MIP pyramid, by the pixel's footprint)", default="bilinear",
        choices=FILTER_TYPES + ("trilinear", "anisotropic")),
    Key("wrap_mode", "string", "bitmap: how coordinates outside [0, 1] wrap", default="repeat", choices=WRAP_MODES),
    Key("to_uv", "vectors", "the texture's (s, t) of the surface's (u, v): rows (a, b, c), (d, e, f) of (s, t) = "
        "M (u, v, 1), t up the image", length=3, count=2, default=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))),
    Key("color0", "number-or-vector", "checkerboard: the colour of the squares at (0, 0) and (1/2, 1/2)", length=3,
        low=0, default=0.4),
    Key("color1", "number-or-vector", "checkerboard: the other squares' colour", length=3, low=0, default=0.2),
    Key("name", "string", "mesh_attribute: the meshes' attribute, as Mitsuba names it (vertex_color, face_color, "
        "vertex_PREFIX, face_PREFIX)", default=None, also='required with type = "mesh_attribute"; every shape of '
        'the material a mesh that has it'),
    Key("scale", "number", "mesh_attribute: a factor on its values", default=1.0, low=0),
]
KIND_KEYS = {"bitmap": ("type", "filename", "raw", "filter_type", "wrap_mode", "to_uv"),
             "checkerboard": ("type", "to_uv", "color0", "color1"), "mesh_attribute": ("type", "name", "scale")}
# The parameters whose value is one number (kernels/types.h's MAP_ALPHA, MAP_ALPHA_V, MAP_WEIGHT, MAP_BUMP and
# principled's weights, MAP_ROUGHNESS .. MAP_SPEC_TRANS): a lookup's luminance
FLOAT_SLOTS = ("alpha", "alpha_v", "weight", "bump", *PRINCIPLED_SLOTS, *THIN_SLOTS)
# The ranges every value of a texture must lie in, for the parameters whose kernel code needs more than a mean in
# range (ranges.py checks the mean as the material's value): principled's weights, [0, 1], but principledthin's
# diff_trans and eta (their keys' ranges). (Every texture's values are >= 0: textures.py.)
VALUE_RANGES = {**{slot: (0.0, 1.0) for slot in PRINCIPLED_SLOTS + THIN_SLOTS}, "diff_trans": (0.0, 2.0),
                "principled_eta": (2.0 ** -16, 2.0 ** 16)}
# The parameters a mesh attribute cannot texture: a bump map's gradient (Mitsuba's mesh_attribute has no
# eval_1_grad, which its bumpmap calls), principled(thin)'s weights (material.cl reads them by (u, v) only)
UNATTRIBUTED = ("bump", *PRINCIPLED_SLOTS, *THIN_SLOTS)


def is_texture(value):
    """Whether a parameter's value is a texture's table rather than a value."""
    return isinstance(value, dict)


def read(r, slot, textures, rgb, own_keys):
    """(TextureLookup, its mean: three numbers, or one for a float slot) of the texture table reader `r` (a
    scene_file.Reader of the "texture" table) for parameter slot `slot`; images are read through `textures` (a
    textures.TextureCache). `rgb(reader, key)` reads a colour as scene_file does, `own_keys` refuses another kind's
    keys as scene_file does."""
    r.check_keys()
    kind = r.string("type")
    own_keys(r, kind, KIND_KEYS[kind], [key.name for key in KEYS])
    rows = r.vectors("to_uv") if r.has("to_uv") else np.array(r.spec["to_uv"].default)
    to_uv = tuple(float(x) for x in rows.ravel())
    if kind == "mesh_attribute":
        if not r.has("name"):
            r.fail("name", None, 'missing (type = "mesh_attribute" reads a mesh\'s attribute)')
        if slot in UNATTRIBUTED:
            r.fail("type", kind, "cannot texture " + ("a bump map: Mitsuba's bumpmap needs its gradient, which "
                   "a mesh attribute does not give" if slot == "bump" else "a principled weight: raytrace's "
                   "kernel reads those by (u, v) only"))
        if not r.string("name").startswith(ATTRIBUTE_KINDS):
            r.fail("name", r.raw("name"), 'must start with "vertex_" or "face_", as Mitsuba\'s mesh attributes do')
        lookup = TextureLookup("mesh_attribute", to_uv=to_uv, attribute=r.string("name"), scale=r.number("scale"))
        # Unknown until the meshes are read: a mid value; a float parameter's unscaled, a roughness inside (0, 1]
        mean = np.full(3, 0.5 if slot in FLOAT_SLOTS else 0.5 * lookup.scale)
    elif kind == "checkerboard":
        c0, c1 = rgb(r, "color0"), rgb(r, "color1")
        lookup = TextureLookup("checkerboard", to_uv=to_uv, colour0=tuple(c0.tolist()), colour1=tuple(c1.tolist()))
        mean = (c0 + c1) / 2
    else:
        if not r.has("filename"):
            r.fail("filename", None, 'missing (type = "bitmap" reads an image)')
        role = "data" if r.boolean("raw") else "colour"
        index = textures.index(r.string("filename"), role, r.path, r.prefix + "filename")
        lookup = TextureLookup("bitmap", index, r.string("wrap_mode"), r.string("filter_type"), to_uv)
        mean = texture_mean(textures.textures[index])
    if slot in VALUE_RANGES and kind != "mesh_attribute":  # every value the lookup can give, not only the mean
        values = (np.mean(c0), np.mean(c1)) if kind == "checkerboard" else texture_luminances(
            textures.textures[index])
        low, high = float(np.min(values)), float(np.max(values))
        bottom, top = VALUE_RANGES[slot]
        # (white's principled weights sum to 1 within rounding; the kernel clamps to the range)
        if not (low >= bottom and high <= top * (1 + 1e-6)):
            r.fail("", r.table, f"this parameter's texture must lie in [{bottom:.6g}, {top:.6g}] (its values span "
                   f"[{low:.6g}, {high:.6g}])")
    if slot in FLOAT_SLOTS:  # Mitsuba's eval_1: an image's luminance, an rgb colour's mean
        return lookup, float(luminance(mean) if kind != "checkerboard" else np.mean(mean))
    return lookup, mean


def attribute_names(materials):
    """The mesh attributes the materials' textures read, in the order of the kernel's attribute table's blocks."""
    return list(dict.fromkeys(lookup.attribute for m in materials for _, lookup in m.maps
                              if lookup.kind == "mesh_attribute"))


LUMINANCE = (0.212671, 0.715160, 0.072169)  # Mitsuba's luminance weights (kernels/vmath.h's luminance)


def luminance(rgb):
    """Mitsuba's luminance of linear sRGB (kernels/vmath.h's)."""
    return float(np.dot(rgb, LUMINANCE))


def texture_mean(texture):
    """The mean linear RGB of a texture's finest level, as the kernel decodes its texels."""
    return texture_rgb(texture).mean(axis=0)


def texture_luminances(texture):
    """The luminance of every texel of a texture's finest level, as the kernel decodes them: the range a float
    parameter's filtered lookups stay within (their weights are convex)."""
    return texture_rgb(texture) @ np.array(LUMINANCE)


def texture_rgb(texture):
    """The linear RGB of a texture's finest level's texels, (N, 3), as the kernel decodes them."""
    level = texture.levels[0]
    if texture.encoding == structs.TEXELS_SRGB8:
        rgb = SRGB8_TO_LINEAR[level[..., :3]]
    elif texture.encoding == structs.TEXELS_UNORM8:
        rgb = level[..., :3] / 255.0
    else:
        rgb = level[..., :3].astype(np.float64)
    return rgb.reshape(-1, 3)
