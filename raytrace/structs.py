"""The host's mirror of what kernels/types.h and kernels/limits.h declare: numpy dtypes of the structs, field
for field, and the constants host and kernel share (tests/test_types.py checks every one against the device's
own compiler: sizes, offsets, values)."""
import numpy as np

VEC3F = ("<f4", (3,))

# kernels/limits.h (with the others below)
ROUGH_TRANSMITTANCE_RES = 64  # entries of a roughplastic's transmittance table (Material.transmittance)
MAPS = 21  # textured parameters a material has room for (Material.maps)
WRAPPER_DEPTH = 8  # nested wrappers (blendbsdf, mask, twosided) a hit passes through, at most
PRINCIPLED_PARAMETERS = 19    # a principled or principledthin BSDF's values (Material.principled: types.h's PRINCIPLED_*)

RFILTER_NODES = 129  # the nodes of a reconstruction filter's sampling tables (Camera.rfilter_*)

CAMERA = np.dtype([("position", *VEC3F), ("forward", *VEC3F), ("right", *VEC3F), ("up", *VEC3F),
                   ("scale_x", "<f4"), ("scale_y", "<f4"), ("focal_length", "<f4"),
                   ("near_clip", "<f4"), ("far_clip", "<f4"), ("lens_radius", "<f4"), ("focus_distance", "<f4"),
                   ("film_width", "<i4"), ("film_height", "<i4"), ("crop_x", "<i4"), ("crop_y", "<i4"),
                   ("crop_width", "<i4"), ("crop_height", "<i4"), ("rfilter", "<i4"), ("rfilter_bins", "<i4"),
                   ("rfilter_border", "<i4"),
                   ("rfilter_reach", "<f4"), ("rfilter_step", "<f4"), ("rfilter_a", "<f4"), ("rfilter_b", "<f4"),
                   ("rfilter_integral", "<f4"), ("rfilter_pdf", "<f4", (RFILTER_NODES,)),
                   ("rfilter_cdf", "<f4", (RFILTER_NODES,)), ("rfilter_cumulative", "<f4", (RFILTER_NODES,)),
                   ("depth_from", "<f4")])

RECTANGLE = np.dtype([("center", *VEC3F), ("normal", *VEC3F), ("tangent", *VEC3F), ("bitangent", *VEC3F),
                      ("half_x", "<f4"), ("half_y", "<f4"), ("material", "<i4")])

TRIANGLE = np.dtype([("v0", *VEC3F), ("v1", *VEC3F), ("v2", *VEC3F), ("normal", *VEC3F), ("material", "<i4")])

TRIANGLE_NORMALS = np.dtype([("n0", *VEC3F), ("n1", *VEC3F), ("n2", *VEC3F)])

TRIANGLE_UV = np.dtype([("uv", "<f4", (6,)), ("dpdu", *VEC3F), ("dpdv", *VEC3F), ("tangent", *VEC3F)])

ELLIPSOID = np.dtype([("center", *VEC3F), ("world_to_unit", "<f4", (9,)), ("unit_to_world", "<f4", (9,)),
                      ("normal_sign", "<f4"), ("material", "<i4")])

# kernels/types.h: Disk and Cylinder, one layout (a unit shape under an affine map)
AFFINE_SHAPE = np.dtype([("center", *VEC3F), ("to_local", "<f4", (9,)), ("to_world", "<f4", (9,)),
                         ("normal_sign", "<f4"), ("material", "<i4")])

# kernels/types.h: SHAPE_*; a BVH primitive reference is index * PRIM_KINDS + kind
SHAPES = {"none": 0, "rectangle": 1, "triangle": 2, "ellipsoid": 3, "disk": 4, "cylinder": 5, "instance": 6}
INSTANCE = np.dtype([("center", *VEC3F), ("to_local", "<f4", (9,)), ("to_world", "<f4", (9,)), ("root", "<i4")])
PRIM_KIND_BITS = 3
PRIM_KINDS = 1 << PRIM_KIND_BITS

BVH_NODE = np.dtype([("lo", "<f4", (3,)), ("hi", "<f4", (3,)), ("offset", "<i4"), ("count", "<i4")])

EMITTER = np.dtype([("kind", "<i4"), ("index", "<i4"), ("count", "<i4"), ("reflects", "<i4"), ("area", "<f4"),
                    ("position", *VEC3F), ("axis", *VEC3F), ("to_local", "<f4", (9,)), ("cos_cutoff", "<f4"),
                    ("cos_beam", "<f4"), ("cutoff", "<f4"), ("inv_transition", "<f4"), ("uv_scale", "<f4", (2,)),
                    ("lookup", "<i4"), ("radiance", *VEC3F), ("selection_pdf", "<f4"),
                    ("selection_cdf", "<f4")])
# kernels/types.h: EMITTER_*, the delta lights' kinds (after the shapes')
EMITTER_KINDS = {"point": 8, "spot": 9, "directional": 10, "projector": 11}
EMITTER_TRIANGLE = np.dtype([("triangle", "<i4"), ("cdf", "<f4")])

LIGHT = np.dtype([("shape", RECTANGLE), ("colour", *VEC3F), ("planes_in_front", "<u4"), ("planes_behind", "<u4")])

MATERIAL = np.dtype([("colour", *VEC3F), ("shininess", "<f4"), ("colour_map", "<i4"), ("normal_map", "<i4"),
                     ("height_map", "<i4"), ("wrap", "<i4"), ("height_scale", "<f4"), ("uv_scale", "<f4", (2,)),
                     ("uv_offset", "<f4", (2,)), ("bsdf", "<i4"), ("eta", *VEC3F), ("k", *VEC3F),
                     ("alpha", "<f4"), ("alpha_v", "<f4"), ("distribution", "<i4"), ("specular", *VEC3F),
                     ("nonlinear", "<i4"), ("internal_reflectance", "<f4"), ("specular_weight", "<f4"),
                     ("transmittance", "<f4", (ROUGH_TRANSMITTANCE_RES,)), ("maps", "<i4", (MAPS,)),
                     ("back", "<i4"), ("blend", "<i4", (2,)), ("weight", "<f4"), ("bump_scale", "<f4"),
                     ("mirrored_maps", "<i4"),
                     ("principled", "<f4", (PRINCIPLED_PARAMETERS,)), ("emitter", "<i4")])

# kernels/types.h: MAP_* (Material.maps), LOOKUP_*
MAP_SLOTS = {"colour": 0, "specular": 1, "alpha": 2, "alpha_v": 3, "weight": 4, "normal": 5, "bump": 6,
             "roughness": 7, "anisotropic": 8, "metallic": 9, "spec_tint": 10, "sheen": 11, "sheen_tint": 12,
             "clearcoat": 13, "clearcoat_gloss": 14, "spec_trans": 15, "flatness": 16, "diff_trans": 17,
             "principled_eta": 18, "eta": 19, "k": 20}
LOOKUPS = {"bitmap": 0, "checkerboard": 1, "mesh_attribute": 2}
TEXTURE_LOOKUP = np.dtype([("kind", "<i4"), ("texture", "<i4"), ("wrap", "<i4"), ("filter", "<i4"),
                           ("luminance", "<i4"), ("to_uv", "<f4", (6,)), ("colour0", *VEC3F), ("colour1", *VEC3F),
                           ("attribute", "<i4"), ("scale", "<f4")])
TRIANGLE_ATTRIBUTE = np.dtype([("a0", *VEC3F), ("a1", *VEC3F), ("a2", *VEC3F)])

TEXTURE = np.dtype([("first_level", "<i4"), ("n_levels", "<i4"), ("encoding", "<i4")])

MIP_LEVEL = np.dtype([("offset", "<i4"), ("width", "<i4"), ("height", "<i4")])

# kernels/types.h: WRAP_*, TEXELS_*, FILTER_*
WRAP_MODES = {"repeat": 0, "clamp": 1, "mirror": 2}
TEXELS_SRGB8, TEXELS_UNORM8, TEXELS_FLOAT, TEXELS_QUAD8, TEXELS_QUADF, TEXELS_QUAD16 = 0, 1, 2, 3, 4, 5
TEXEL_WORDS = {TEXELS_SRGB8: 1, TEXELS_UNORM8: 1, TEXELS_FLOAT: 4, TEXELS_QUAD8: 1, TEXELS_QUADF: 4, TEXELS_QUAD16: 2}
QUAD_TEXELS = (TEXELS_QUAD8, TEXELS_QUAD16, TEXELS_QUADF)  # height maps' quads
FLOAT_TEXELS = (TEXELS_FLOAT, TEXELS_QUADF)  # float32 words, 16-byte aligned in the texel buffer
FILTERS = {"nearest": 0, "bilinear": 1, "trilinear": 2, "anisotropic": 3}
# kernels/types.h: RFILTER_*, the film's reconstruction filters (Mitsuba's rfilter plugins)
RFILTERS = {"box": 0, "tent": 1, "gaussian": 2, "mitchell": 3, "lanczos": 4}

# kernels/types.h: BSDF_*
BSDFS = {"diffuse": 0, "conductor": 1, "dielectric": 2, "roughconductor": 3, "thindielectric": 4, "roughdielectric": 5,
         "plastic": 6, "roughplastic": 7, "null": 8, "principled": 9, "principledthin": 10}
BSDF_BLEND = 31  # not a BSDF: a blendbsdf's or mask's node, resolved per hit (kernels/wrappers.cl)

# kernels/types.h: PRINCIPLED_*, the order of Material.principled's values
PRINCIPLED = ("roughness", "metallic", "spec_tint", "sheen", "sheen_tint", "clearcoat", "clearcoat_alpha",
              "spec_trans", "specular_rate", "clearcoat_rate", "diffuse_rate", "anisotropic", "transmits",
              "flatness", "diff_trans", "trans_alpha_u", "trans_alpha_v", "spec_trans_rate", "diff_trans_rate")

# kernels/types.h: MICROFACET_*
MICROFACETS = {"ggx": 0, "beckmann": 1}

# kernels/types.h: RANDOMIZE_*
RANDOMIZE = {"none": 0, "independent": 1, "jitter": 2, "shift": 3, "sobol": 4}

SAMPLER = np.dtype([("randomize", "<i4"), ("cell_x", "<u4"), ("cell_y", "<u4")])

RENDER_PARAMS = np.dtype([("ambient", *VEC3F), ("n_rectangles", "<i4"), ("n_triangles", "<i4"),
                          ("n_ellipsoids", "<i4"), ("n_lights", "<i4"), ("n_emitters", "<i4"),
                          ("pixel_sampler", SAMPLER),
                          ("light_sampler", SAMPLER), ("seed", "<u4"), ("light_samples", "<i4"), ("width", "<i4"), ("height", "<i4"),
                          ("texture_filter", "<i4"), ("footprint_scale", "<f4"), ("max_depth", "<i4"),
                          ("environment", *VEC3F), ("scene_extent", "<f4"),
                          ("environment_width", "<i4"), ("environment_height", "<i4"),
                          ("environment_x", *VEC3F), ("environment_y", *VEC3F), ("environment_z", *VEC3F),
                          ("n_disks", "<i4"), ("n_cylinders", "<i4"), ("n_instances", "<i4"),
                          ("rr_depth", "<i4"), ("hide_emitters", "<i4"),
                          ("bsdf_samples", "<i4")])

# name in kernels/types.h -> dtype
STRUCTS = {"Camera": CAMERA, "Rectangle": RECTANGLE, "Triangle": TRIANGLE, "TriangleUV": TRIANGLE_UV,
           "TriangleNormals": TRIANGLE_NORMALS,
           "Ellipsoid": ELLIPSOID, "Disk": AFFINE_SHAPE, "Cylinder": AFFINE_SHAPE, "Instance": INSTANCE, "Light": LIGHT, "Material": MATERIAL, "Texture": TEXTURE, "MipLevel": MIP_LEVEL,
           "TextureLookup": TEXTURE_LOOKUP, "TriangleAttribute": TRIANGLE_ATTRIBUTE,
           "Sampler": SAMPLER, "RenderParams": RENDER_PARAMS, "BVHNode": BVH_NODE, "Emitter": EMITTER,
           "EmitterTriangle": EMITTER_TRIANGLE}

# kernels/limits.h
BVH_STACK = 64                # levels of a BVH the kernel's traversal stack holds: the host refuses deeper trees
CULLED_RECTANGLES = 32        # rectangles that shadow rays may skip: one bit each in a Light's masks
LANE_WIDTHS = (1, 4, 8, 16)   # lanes (pixel samples at once) per work-item the kernel accepts


# kernels/tile.h: a work-item's lanes hold samples_at_once(...) samples of each pixel of its tile of pixels
def samples_at_once(lanes, n_samples):
    """The pixel samples of each pixel a work-item's lanes hold at once in a launch of n_samples: the
    largest power of two dividing n_samples, at most `lanes`."""
    return max(1, min(n_samples & -n_samples, lanes))


def tile_shape(lanes, n_samples):
    """(columns, rows) of a work-item's tile of pixels in a launch of n_samples pixel samples."""
    pixels = lanes // samples_at_once(lanes, n_samples)
    rows = 4 if pixels >= 16 else 2 if pixels >= 4 else 1
    return pixels // rows, rows

MAX_WORDS = (1 << 31) - 1  # the texel store's offsets are int32 words in the kernel
