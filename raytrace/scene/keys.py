"""Every key of a scene file: its table, type, default and accepted range, declared once (each a Key of
declaration.py; the BSDFs' own keys, with their BSDF's doc, in bsdfs.py). scene_file.py's reader takes each
key's bounds and default from here and from nowhere else, and the manual's scene-format table is generated from
here (docs/_ext/raytrace_docs.py), so that what is checked and what is documented cannot drift apart. What holds
between keys (extents, sizes, brightness) is ranges.py's; what a key must additionally satisfy (a tangent not
along the normal, a triangle with an area) is in `also`.
"""
from .. import samplers
from ..numerics import FLOAT32_MAX, FLOAT32_TINY
from ..structs import WRAP_MODES
from . import bsdfs, texture_lookups
from .declaration import REQUIRED, Key  # noqa: F401  (keys.REQUIRED: what the tests and the manual name)
from .model import (BSDFS, CAMERAS, DELTA_EMITTERS, LIGHT_SELECTIONS, RFILTERS, WRAPPERS, ENVIRONMENTS, DEFAULT_SHININESS, MAX_DEPTH,
                    RR_DEPTH, SHADINGS)
from .ranges import COORDINATE_LIMIT, MAX_IMAGE_SIDE, MAX_SAMPLES

MAX_GENERATED_TRIANGLES = 50_000_000
MAX_RFILTER_RADIUS = 16.0  # pixels: film_filter.py's tables hold 128 bins, 4 per pixel at least
SHAPE_KINDS = ("rectangle", "triangle", "mesh", "ellipsoid", "disk", "cylinder", "instance")
GENERATED_SHAPES = ("sphere", "torus", "terrain")

# The placement of a shape, declared once: a mesh's from a file or generated, and the course's rectangles,
# triangles, ellipsoids and lights, which are given as written and then placed (scene_file.py, transform.py).
TRANSFORM = [
    Key("scale", "number-or-vector", "the first transform: a number or [sx, sy, sz]", length=3,
        default=1.0, also="no component 0"),
    Key("rotate", "table", "the second transform", default=None),
    Key("translate", "vector", "the third transform", length=3, default=(0.0, 0.0, 0.0)),
    Key("matrix", "vectors", "instead of the three: a 4 x 4 affine matrix, rows acting on columns", length=4,
        count=4, default=None, also="last row 0 0 0 1, invertible; not with scale, rotate, translate; a "
        "rectangle's or light's keeps its sides at right angles (no shear)")]


def _to_world(shape):
    return Key("to_world", "vectors", f"a 4 x 4 affine matrix, rows acting on columns: the {shape} to the world "
               "(Mitsuba's to_world; default: the identity)", length=4, count=4, default=None,
               also="last row 0 0 0 1, invertible")


_FLIP_NORMALS = Key("flip_normals", "boolean", "turn the normal: the front becomes the back (Mitsuba's "
                    "flip_normals)", default=False)


def _rectangle(emission=None):
    keys = [Key("center", "vector", "the centre", length=3),
            Key("size", "vector", "the side lengths along tangent and along normal x tangent", length=2,
                also="both > 0"),
            Key("normal", "vector", "the normal (the front side)", length=3, nonzero=True),
            Key("tangent", "vector", "the first side's direction, made orthogonal to the normal", length=3,
                nonzero=True, also="not parallel to the normal")]
    return keys + ([emission] if emission else []) + TRANSFORM


_COLOUR = Key("colour", "vector", "Phong shading: the light's colour", length=3, low=0)
_RADIANCE = Key("radiance", "number-or-vector", 'shading = "direct" or "path": the emitted radiance, from the '
                "side the normal points to (one number: the same in every channel)", length=3, low=0)
_DELTA_TO_WORLD = Key("to_world", "vectors", "a 4 x 4 affine matrix, rows acting on columns: the light's frame to the "
                      "world, the light at its origin looking along its local +z (Mitsuba's to_world; default: the "
                      "identity)", length=4, count=4, default=None, also="last row 0 0 0 1, invertible")
FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")  # Mitsuba's fov_axis (a projector's)
_LIGHT_MATERIAL = Key("material", "string", "the material the light reflects with (default: none, black)",
                      default=None, also='shading = "path" only; one of the materials')

TABLES = {
    "": [Key("ambient", "vector", "Phong shading's ambient light, added once and never shadowed", length=3, low=0,
             default=(0.0, 0.0, 0.0), also='shading = "phong" only'),
         Key("camera", "table", "the camera"),
         Key("image", "table", "the image size"),
         Key("render", "table", "the render's defaults (the command line overrides them)", default={}),
         Key("lights", "tables", "rectangular area lights", default=(),
             also='one or more; none only with an environment, [[emitters]] or a shape with radiance (shading = '
             '"direct" or "path")'),
         Key("materials", "named-tables", "materials by name, one or more"),
         Key("shapes", "tables", "the shapes", default=()),
         Key("groups", "named-tables", "shape groups by name: meshes kept once, which shapes of type = \"instance\" "
             "place (Mitsuba's shapegroup)", default={}),
         Key("environment", "table", 'shading = "direct" or "path": light from every direction nothing blocks',
             default=None),
         Key("emitters", "tables", "Mitsuba's emitters that are no shape: point, spot, directional and projector "
             "lights", default=(), also='shading = "direct" or "path"')],
    "emitters[]": [Key("type", "string", "the emitter, with Mitsuba's names", choices=DELTA_EMITTERS)],
    'emitters[] type = "point"': [
        Key("position", "vector", "where the light is (default: to_world's origin)", length=3, default=None,
            also="not with to_world"),
        Key("to_world", "vectors", "a 4 x 4 affine matrix, rows acting on columns, whose origin is the light's "
            "position", length=4, count=4, default=None, also="last row 0 0 0 1"),
        Key("intensity", "number-or-vector", "the radiant intensity, per steradian (one number: the same in every "
            "channel)", length=3, low=0, default=1.0)],
    'emitters[] type = "spot"': [
        _DELTA_TO_WORLD,
        Key("intensity", "number-or-vector", "the radiant intensity along the axis, per steradian", length=3, low=0,
            default=1.0),
        Key("cutoff_angle", "number", "degrees from the axis beyond which the light is black", default=20.0, low=0,
            high=180, open_low=True, also="below 90 with texture"),
        Key("beam_width", "number", "degrees from the axis within which the intensity is whole; it falls off "
            "linearly in the angle from there to cutoff_angle (default: 3/4 of cutoff_angle)", default=None, low=0,
            high=180, also="at most cutoff_angle"),
        Key("texture", "table", "an image or checkerboard (a texture's table) projected over the cone, (u, v) = "
            "(1/2, 1/2) + (x, y) / (2 z tan(cutoff_angle)) in the light's frame, v down the image", default=None)],
    'emitters[] type = "directional"': [
        Key("direction", "vector", "the direction the light travels (default: to_world's +z)", length=3,
            nonzero=True, default=None, also="not with to_world"),
        Key("to_world", "vectors", "a 4 x 4 affine matrix, rows acting on columns, whose +z is the direction",
            length=4, count=4, default=None, also="last row 0 0 0 1, invertible"),
        Key("irradiance", "number-or-vector", "the irradiance on a surface facing the light (one number: the "
            "same in every channel)", length=3, low=0, default=1.0)],
    'emitters[] type = "projector"': [
        _DELTA_TO_WORLD,
        Key("irradiance", "number-or-vector", "the image projected: a constant, or a texture's table (an image, "
            "whose aspect ratio the projection takes; v down the image); the plane z = 1 receives pi scale times "
            "its value (Mitsuba's convention)", length=3, low=0, default=1.0),
        Key("scale", "number", "a factor on the irradiance", default=1.0, low=0, high=FLOAT32_MAX),
        Key("fov", "number", "the field of view, degrees, along fov_axis (default: from focal_length)", low=0,
            high=180, open_low=True, open_high=True, default=None, also="not with focal_length"),
        Key("fov_axis", "string", "the image axis fov spans (Mitsuba's)", default="x", choices=FOV_AXES,
            also="with fov"),
        Key("focal_length", "number", "a 35 mm film's focal length in mm, the diagonal's field of view",
            default=50.0, low=0, high=FLOAT32_MAX, open_low=True, also="not with fov")],
    "environment": [Key("type", "string", "the emitter, with Mitsuba's names: a constant radiance, or an "
                        "equirectangular image (envmap)", choices=ENVIRONMENTS),
                    Key("radiance", "number-or-vector", "constant: the radiance arriving from every direction (one "
                        "number: the same in every channel)", length=3, low=0, also='type = "constant" only'),
                    Key("filename", "path", "envmap: the image of radiance (linear RGB; EXR, HDR or any format "
                        "OpenImageIO reads, 8- and 16-bit ones sRGB-decoded), relative to the scene file",
                        also='type = "envmap" only'),
                    Key("scale", "number", "envmap: a factor on the image's radiance", default=1.0, low=0,
                        high=FLOAT32_MAX),
                    Key("up", "vector", "envmap: the direction the image's top row looks along (Mitsuba's local "
                        "+y)", length=3, nonzero=True, default=(0.0, 1.0, 0.0)),
                    Key("forward", "vector", "envmap: the direction the image's centre looks along (Mitsuba's "
                        "local +z), made orthogonal to up", length=3, nonzero=True, default=(0.0, 0.0, 1.0),
                        also="not parallel to up")],
    "camera": [Key("position", "vector", "the eye", length=3),
               Key("look_at", "vector", "the point at the image's centre", length=3,
                   also="differs from position"),
               Key("up", "vector", "the reference up direction", length=3, nonzero=True,
                   also="not parallel to the view direction"),
               Key("type", "string", "the camera, with Mitsuba's sensor names: a pinhole, a thin lens (depth of "
                   "field), or parallel rays", default="perspective", choices=CAMERAS),
               Key("fov", "number", "the vertical field of view, degrees", default=None, low=0, high=180,
                   open_low=True, open_high=True, also='required for type = "perspective" and "thinlens"; not '
                   'with "orthographic"'),
               Key("focal_length", "number", "the distance to the image plane; it cancels in the camera model",
                   default=1.0, low=0, open_low=True),
               Key("near_clip", "number", "the near clip plane's distance along the view: nearer than it, "
                   "nothing is seen (Mitsuba's: 0.01; raytrace's default: none)", default=0.0, low=0),
               Key("far_clip", "number", "the far clip plane's distance along the view: beyond it a camera ray "
                   "sees what a miss sees (Mitsuba's: 10^4; raytrace's default: none)", default=None, low=0,
                   open_low=True, high=FLOAT32_MAX, also="above near_clip"),
               Key("aperture_radius", "number", 'thinlens: the lens\'s radius (0: a pinhole, where Mitsuba takes a '
                   "radius of 1e-4 with a warning)", default=None, low=0, high=COORDINATE_LIMIT,
                   also='required for type = "thinlens"'),
               Key("focus_distance", "number", "thinlens: the distance along the view of the plane in focus",
                   default=None, low=0, open_low=True, high=COORDINATE_LIMIT, also='required for type = "thinlens"'),
               Key("size", "vector", "orthographic: the view's width and height in scene units (Mitsuba's "
                   "to_world scale: 2 sx and 2 sy height / width)", length=2, low=0, default=None,
                   also='required for type = "orthographic"; both > 0')],
    "image": [Key("width", "integer", "pixels of the film", low=1, high=MAX_IMAGE_SIDE),
              Key("height", "integer", "pixels of the film", low=1, high=MAX_IMAGE_SIDE),
              Key("crop_offset_x", "integer", "the crop window's first column: the image is that window of the "
                  "film, its pixels the film's (Mitsuba's hdrfilm crop)", default=0, low=0, high=MAX_IMAGE_SIDE - 1),
              Key("crop_offset_y", "integer", "the crop window's first row", default=0, low=0,
                  high=MAX_IMAGE_SIDE - 1),
              Key("crop_width", "integer", "the crop window's width (default: to the film's edge)", default=None,
                  low=1, high=MAX_IMAGE_SIDE, also="the window lies in the film"),
              Key("crop_height", "integer", "the crop window's height (default: to the film's edge)", default=None,
                  low=1, high=MAX_IMAGE_SIDE, also="the window lies in the film"),
              Key("rfilter", "string", "the reconstruction filter, with Mitsuba's names: box averages each pixel's "
                  "samples; the others weigh samples about the pixel (importance-sampled: docs/model.md, film)",
                  default="box", choices=RFILTERS),
              Key("rfilter_radius", "number", "tent: its radius, pixels", default=1.0, low=0, open_low=True,
                  high=MAX_RFILTER_RADIUS),
              Key("rfilter_stddev", "number", "gaussian: its standard deviation, pixels (cut off at 4 of them)",
                  default=0.5, low=0, open_low=True, high=MAX_RFILTER_RADIUS / 4),
              Key("rfilter_b", "number", "mitchell: Mitchell and Netravali's B", default=1.0 / 3.0, low=-10,
                  high=10),
              Key("rfilter_c", "number", "mitchell: Mitchell and Netravali's C", default=1.0 / 3.0, low=-10,
                  high=10),
              Key("rfilter_lobes", "integer", "lanczos: its lobes (its radius, pixels)", default=3, low=1,
                  high=int(MAX_RFILTER_RADIUS)),
              Key("sample_border", "boolean", "a filter's samples fall outside the crop window too, so that a pixel "
                  "at its edge averages its whole filter (Mitsuba's hdrfilm sample_border)", default=False)],
    "render": [Key("spp", "integer", "pixel samples", default=samplers.DEFAULT_SPP, low=1, high=MAX_SAMPLES,
                   also="1 by default with the center sampler"),
               Key("light_samples", "integer", "samples per light per pixel sample: per [[lights]] rectangle, and "
                   "for the emitting shapes and [[emitters]] together (light_selection)", default=1, low=1,
                   high=MAX_SAMPLES),
               Key("sampler", "string", "the pixel sample pattern", default="grid", choices=samplers.SAMPLERS,
                   also='center takes 1 sample, the grids a square number; the default is sobol with shading = '
                        '"direct"'),
               Key("light_sampler", "string", "the light sample pattern", default="grid",
                   choices=samplers.SAMPLERS, also='as sampler; with shading = "direct", not a single point (center, '
                                                   'or a grid of 1)'),
               Key("light_selection", "string", "how each light sample chooses the emitting shape (a [[shapes]] "
                   "table with radiance) or the [[emitters]] light it samples: in proportion to their power "
                   "(pbrt-v4's power light sampler), or uniformly (Mitsuba 3's default); light_samples are then "
                   "shared among them, while each [[lights]] rectangle takes light_samples of its own",
                   default="power", choices=LIGHT_SELECTIONS),
               Key("shading", "string", "the shading model: the course's Phong, radiometric direct lighting, or "
                   "global illumination by path tracing", default="phong", choices=SHADINGS),
               Key("max_depth", "integer", 'shading = "path": path vertices at most, Mitsuba\'s convention (1: the '
                   "emitters seen directly, 2: direct light, -1: unbounded)", default=-1, low=-1, high=MAX_DEPTH),
               Key("seed", "integer", "the seed of the random patterns' per-pixel randomisation", default=0, low=0,
                   high=2**32 - 1),
               Key("rr_depth", "integer", 'shading = "path": the first path vertex at which Russian roulette may '
                   "end a path (Mitsuba's rr_depth)", default=RR_DEPTH, low=1, high=2**31 - 1),
               Key("hide_emitters", "boolean", 'shading = "direct" or "path": camera rays do not see the lights, '
                   "the emitting shapes and the environment, but pass the emitters by (Mitsuba's hide_emitters)",
                   default=False),
               Key("bsdf_samples", "integer", 'shading = "direct": BSDF samples per pixel sample, combined with the '
                   "light_samples per light by multiple importance sampling (Mitsuba's direct bsdf_samples)",
                   default=0, low=0, high=MAX_SAMPLES),
               Key("aovs", "string", "AOVs to store beside the image, separated by commas: albedo, normal, "
                   "geo_normal, depth, position, uv, shape, or Mitsuba's name:type items (its aov integrator's "
                   "`aovs`); --aov and render(aov=...) replace them", default="")],
    "lights[]": _rectangle(_COLOUR),
    "lights[] (direct, path)": _rectangle(_RADIANCE) + [_LIGHT_MATERIAL],
    "materials.NAME": [
        Key("colour", "vector", "ka = kd = ks, the material's colour (a texture replaces it); in the path model the "
            "BSDF's reflectance, which each type's table below also names as Mitsuba does", length=3, low=0,
            default=(1.0, 1.0, 1.0), also="required without texture for type = diffuse; 0.5 for the plastics"),
        Key("shininess", "number", "the Phong exponent", default=DEFAULT_SHININESS, low=0, open_low=True),
        Key("texture", "path", "colour map (from the scene file's folder)", default=None),
        Key("normal_map", "path", "tangent-space normal map, rgb = (n + 1) / 2 (the path model's normalmap)",
            default=None),
        Key("height_map", "path", "relief >= 0 (first channel; 8-bit codes read as [0, 1]; the path model's "
            "bumpmap)", default=None,
            also="with height_scale"),
        Key("height_scale", "number", "scene units of relief per unit of the height map", default=None, low=0,
            also="with height_map"),
        Key("uv_scale", "vector", "(u, v) -> uv_scale (u, v) + uv_offset", length=2, default=(1.0, 1.0),
            low=FLOAT32_TINY, high=FLOAT32_MAX),
        Key("uv_offset", "vector", "added after uv_scale", length=2, default=(0.0, 0.0)),
        Key("wrap", "string", "how texture coordinates outside [0, 1] wrap", default="repeat",
            choices=tuple(WRAP_MODES)),
        Key("type", "string", "the BSDF, with Mitsuba 3's plugin names (docs/bsdfs.md): its parameters are the keys "
            "of its table below; or a wrapper of other materials (blendbsdf, mask)", default="diffuse",
            choices=BSDFS + WRAPPERS, also='other than diffuse with shading = "path" only'),
        Key("two_sided", "boolean", "scatter light on both sides; false: black from behind (Mitsuba's BSDFs outside "
            "twosided)", default=True, also="false only for a type that reflects only"),
        Key("back", "string", "the material of the back side (Mitsuba's twosided of two BSDFs)", default=None,
            also="a defined, two-sided material without a back of its own"),
        Key("normalmap", "table", "Mitsuba's normalmap: a texture of tangent-space normals, rgb = (n + 1) / 2 "
            "(give raw = true), tilting the BSDF's shading normal", default=None,
            also="not with bumpmap, normal_map or height_map"),
        Key("bumpmap", "table", "Mitsuba's bumpmap: a texture of heights whose gradient tilts the BSDF's shading "
            "normal", default=None, also="not with normalmap, normal_map or height_map"),
        Key("bump_scale", "number", "a bumpmap's scene units of relief per unit of its heights (Mitsuba's scale)",
            default=1.0, low=0, open_low=True),
        Key("mirrored_maps", "boolean", "the back side sees the normalmap's or bumpmap's normal mirrored through the "
            "surface (Mitsuba's twosided around the map), not turned whole (the map around twosided)",
            default=False, also="with normalmap or bumpmap")],
    "texture": texture_lookups.KEYS,  # a textured parameter's table (texture_lookups.py)
    **bsdfs.key_tables(),  # each BSDF's own keys ('materials.NAME type = "diffuse"', ...), declared in bsdfs.py
    "shapes[]": [Key("type", "string", "the kind of shape", choices=SHAPE_KINDS),
                 Key("material", "string", "a material's name", default=None,
                     also="a defined material; required but with radiance, where none is black"),
                 Key("radiance", "number-or-vector", 'shading = "direct" or "path": the shape is an area light '
                     "(Mitsuba's area emitter on it) of this radiance, emitted from its front side (one number: the "
                     "same in every channel)", length=3, low=0, default=None,
                     also='an ellipsoid must be a sphere; with shading = "direct", no material')],
    'shapes[] type = "rectangle"': _rectangle(),
    'shapes[] type = "triangle"': [
        Key("vertices", "vectors", "the corners, counter-clockwise seen from the front", length=3, count=3,
            also="a non-zero area"),
        Key("uv", "vectors", "per-vertex texture coordinates", length=2, count=3, default=None), *TRANSFORM],
    'shapes[] type = "mesh"': [
        Key("vertices", "vectors", "the vertices", length=3),
        Key("faces", "faces", "triples of vertex indices", also="indices in range, faces with an area"),
        Key("uv", "vectors", "per-vertex texture coordinates", length=2, default=None, also="one per vertex")],
    'shapes[] type = "mesh", from a file or generated': [
        Key("file", "path", "an OBJ or PLY file (ascii or binary), or a Mitsuba .serialized file, from the scene "
            "file's folder", default=None, also="exactly one of file and generate"),
        Key("shape_index", "integer", "a .serialized file: which of its shapes (0: the first; Mitsuba's shape_index)",
            default=0, low=0, high=2 ** 31 - 1, also="above 0: a .serialized file's, within its shapes"),
        Key("generate", "table", "a procedural mesh", default=None),
        *TRANSFORM,
        Key("smooth", "boolean", "interpolate vertex normals (the file's, else computed as vertex_normals says)",
            default=False),
        Key("vertex_normals", "string", "smooth = true, a file without normals: area (area-weighted over the faces "
            "around each position: no seam where a file splits a vertex) or angle (angle-weighted over the faces "
            "around each vertex of the file, as Mitsuba 3 computes them)", default="area", choices=("area", "angle")),
        Key("flip_tex_coords", "boolean", "turn the file's texture coordinates upside down: v -> 1 - v (Mitsuba's "
            "OBJ reader does by default)", default=False),
        Key("flip_normals", "boolean", "turn every face inside out: its front becomes its back, its normals turn "
            "(Mitsuba's flip_normals)", default=False)],
    "generate": [Key("shape", "string", "the procedural mesh", choices=GENERATED_SHAPES),
                 Key("triangles", "integer", "about this many triangles", low=2, high=MAX_GENERATED_TRIANGLES,
                     also="within the memory there is")],
    "rotate": [Key("axis", "vector", "the rotation axis", length=3, nonzero=True),
               Key("degrees", "number", "the angle, counter-clockwise about the axis")],
    'shapes[] type = "ellipsoid"': [
        Key("center", "vector", "the centre c", length=3),
        Key("axes", "vectors", "a, b, c: the unit sphere's image is c + [a b c] x", length=3, count=3,
            also="linearly independent"), *TRANSFORM, _FLIP_NORMALS],
    'shapes[] type = "disk"': [_to_world("unit disk x^2 + y^2 <= 1 in z = 0, normal +z,"), _FLIP_NORMALS],
    "groups.NAME": [Key("shapes", "tables", 'the group\'s meshes: [[shapes]] tables of type = "mesh", in the group\'s '
                        "own space", also="one or more")],
    'shapes[] type = "instance"': [Key("group", "string", "the shape group it places (Mitsuba's instance)",
                                       also="a defined group; no material or radiance (the group's meshes have "
                                       "theirs)"), *TRANSFORM],
    'shapes[] type = "cylinder"': [
        Key("p0", "vector", "the start of the axis, in object space", length=3, default=(0.0, 0.0, 0.0),
            also="not p1"),
        Key("p1", "vector", "the end of the axis, in object space", length=3, default=(0.0, 0.0, 1.0)),
        Key("radius", "number", "the radius, in object space", default=1.0, low=0, open_low=True),
        _to_world("open tube (no caps) around p0 -> p1, normals outwards,"), _FLIP_NORMALS],
}


def table(name):
    """{key name: Key} of the table `name` (a key of TABLES)."""
    return {key.name: key for key in TABLES[name]}
