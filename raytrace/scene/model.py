"""The host-side scene model, in float64: what a scene file (scene_file.py) or a Python caller describes,
before raytrace/renderer/packing.py packs it into the structs the kernel reads."""
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from . import meshes

DEFAULT_SHININESS = 16.0


def normalize(v):
    """v / |v| for any finite nonzero v: scaled by its largest component first, so that |v| neither underflows
    (a normal of [1e-200, 0, 0]) nor overflows."""
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)


# The shading models: the course's Phong model, radiometric direct lighting (Lambertian surfaces, area lights
# of a given radiance: docs/model.md) and global illumination by path tracing (docs/global-illumination.md).
SHADINGS = ("phong", "direct", "path")
# The BSDFs of the path model, with Mitsuba 3's plugin names, in the kernel's numbering (BSDF_* in
# kernels/types.h): each is declared once, its parameters and doc, in bsdfs.py. Only "diffuse" elsewhere.
BSDFS = ("diffuse", "conductor", "dielectric", "roughconductor", "thindielectric", "roughdielectric", "plastic",
         "roughplastic", "null", "principled", "principledthin")
# Mitsuba's BSDF wrappers a material can be besides a BSDF: a blend of two materials, and a mask (a blend of
# the masked material and `null` by opacity); twosided is a material's `back` (Material).
WRAPPERS = ("blendbsdf", "mask")
# Mitsuba's texture plugins a textured parameter can be (TextureLookup); their wrap modes and filter types.
LOOKUPS = ("bitmap", "checkerboard", "mesh_attribute")
WRAP_MODES = ("repeat", "mirror", "clamp")
FILTER_TYPES = ("nearest", "bilinear")
DISTRIBUTIONS = ("ggx", "beckmann")  # the microfacet distributions of the rough BSDFs, with Mitsuba's names
DEFAULT_ALPHA = 0.1  # Mitsuba's default roughness of its rough BSDFs
ENVIRONMENTS = ("constant", "envmap")  # the path model's environment emitters, with Mitsuba's names
DEFAULT_INT_IOR, DEFAULT_EXT_IOR = 1.5046, 1.000277  # Mitsuba's dielectric defaults: BK7 glass, air
RADIOMETRIC = ("direct", "path")  # the models whose lights have a radiance, emitted from their front face
# How each light sample chooses the emitter it samples (packing.py's selection sets the probabilities the kernel
# chooses by: kernels/light_selection.cl): in proportion to power, or uniformly.
LIGHT_SELECTIONS = ("power", "uniform")
RR_DEPTH = 5  # Mitsuba's rr_depth: the first path vertex at which Russian roulette may end a path
MAX_DEPTH = 1024  # path vertices at most (max_depth); -1 is unbounded, Russian roulette ending every path
SCENE_EXPECTED = "must be a raytrace.scene.Scene, from load_file, load_dict or load_string"

CAMERAS = ("perspective", "thinlens", "orthographic")  # the camera types, with Mitsuba's sensor names
RFILTERS = ("box", "tent", "gaussian", "mitchell", "lanczos")  # the film's reconstruction filters, Mitsuba's names


@dataclass(frozen=True)
class Camera:
    """docs/model.md, camera: a pinhole (perspective), a thin lens (its aperture_radius and focus_distance,
    Mitsuba's thinlens) or an orthographic view (`size`: the view's width and height in scene units; fov_deg
    None), each with clip planes at near_clip and far_clip along the view (0 and inf: none)."""
    position: np.ndarray
    look_at: np.ndarray
    ref_up: np.ndarray
    fov_deg: float | None
    focal_length: float = 1.0
    kind: str = "perspective"  # one of CAMERAS
    near_clip: float = 0.0
    far_clip: float = math.inf
    aperture_radius: float = 0.0
    focus_distance: float | None = None
    size: np.ndarray | None = None
    # Mitsuba's near_clip where its loader dropped the plane as cutting nothing (mitsuba.without_idle_clip_planes):
    # the rays start at the eye, and the depth AOV still runs from the plane, as Mitsuba's si.t does
    dropped_near_clip: float = 0.0

    def basis(self):
        """forward, right, up as docs/model.md, camera defines them (float64)."""
        forward = normalize(self.look_at - self.position)
        right = normalize(np.cross(forward, self.ref_up))
        return forward, right, np.cross(right, forward)


@dataclass(frozen=True, eq=False)
class EnvironmentMap:
    """The path model's `envmap` emitter: an equirectangular image of linear RGB radiance (H x W x 3 float32,
    rows top to bottom) times `scale`, in Mitsuba 3's layout about the world directions `up` (the top row, the
    map's +y) and `forward` (the image's centre, its +z; made orthogonal to up): kernels/environment.cl."""
    path: str
    texels: np.ndarray
    scale: float = 1.0
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    forward: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def frame(self):
        """The world directions of the map's local x, y and z axes (float64, orthonormal, right-handed)."""
        y = normalize(np.asarray(self.up, np.float64))
        forward = normalize(np.asarray(self.forward, np.float64))
        z = normalize(forward - np.dot(forward, y) * y)
        return np.cross(y, z), y, z


@dataclass(frozen=True)
class TextureLookup:
    """How a textured parameter finds its value (Mitsuba's texture plugins): `bitmap`, an image (`texture`, an
    index into Scene.textures, read as colour or as raw data) with its wrap mode and filter (None: the render's
    texture filter; "nearest" or "bilinear": Mitsuba's filter_type, on the finest level), or `checkerboard`, colour0
    and colour1 in alternate squares. to_uv, rows (a, b, c), (d, e, f): the texture's coordinates (s, t) = (a u + b
    v + c, d u + e v + f) of the surface's (u, v), with t up the image, as the surface's v (the identity: the
    image once over the course's rectangles, as a colour map). `mesh_attribute`: a mesh's per-vertex attribute
    (`attribute`, interpolated over each triangle) times `scale`."""
    kind: str = "bitmap"
    texture: int = -1
    wrap: str = "repeat"
    filter: str | None = None
    to_uv: tuple = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    colour0: tuple = (0.4, 0.4, 0.4)
    colour1: tuple = (0.2, 0.2, 0.2)
    attribute: str = ""  # mesh_attribute: the meshes' attribute (Mesh.attributes), times scale
    scale: float = 1.0


@dataclass(frozen=True)
class Material:
    """A material: the course's Phong material, a Lambertian one in the radiometric models, or in the path model
    one of Mitsuba's BSDFs (bsdf, declared in bsdfs.py); textures are indices into Scene.textures (-1: none)."""
    name: str
    colour: np.ndarray
    shininess: float = DEFAULT_SHININESS
    colour_map: int = -1
    normal_map: int = -1
    height_map: int = -1
    height_scale: float = 0.0
    uv_scale: tuple = (1.0, 1.0)
    uv_offset: tuple = (0.0, 0.0)
    wrap: str = "repeat"
    bsdf: str = "diffuse"                # one of BSDFS; bsdfs.py says which fields each one reads
    eta: tuple = (0.0, 0.0, 0.0)         # conductors: the complex index of refraction eta + i k, per channel;
    k: tuple = (0.0, 0.0, 0.0)           # both 0: a perfect mirror (Mitsuba's material "none")
    int_ior: float = DEFAULT_INT_IOR     # dielectrics and plastics: the index of refraction inside (the normal
    ext_ior: float = DEFAULT_EXT_IOR     # points out) and outside; Mitsuba's glass defaults (a plastic's: bsdfs.py)
    alpha: float = DEFAULT_ALPHA         # the rough BSDFs: the roughness (alpha_u where alpha_v is given)
    alpha_v: float | None = None         # roughconductor, roughdielectric: the roughness along v (None: isotropic)
    distribution: str = "ggx"            # the rough BSDFs' microfacet distribution: one of DISTRIBUTIONS
    specular: tuple = (1.0, 1.0, 1.0)    # plastic, roughplastic: the coat's specular_reflectance (colour: the
    nonlinear: bool = False              # base's diffuse_reflectance); nonlinear: Mitsuba's colour shift
    maps: tuple = ()                     # (parameter, TextureLookup) of its textured parameters: colour, specular,
                                         # alpha, alpha_v, weight, normal (normalmap), bump (bumpmap); MAP_*
    two_sided: bool = True               # scatters on both sides; False: black from behind (Mitsuba's one-sided
                                         # BSDFs outside twosided)
    back: int = -1                       # the material of its back side (Mitsuba's twosided of two BSDFs), -1: its
                                         # own (two_sided) or black
    blend: tuple = ()                    # blendbsdf: the two materials it mixes; mask: the one it masks
    weight: float = 0.5                  # blendbsdf: the second one's share; mask: the opacity
    bump_scale: float = 1.0              # a bump map's (maps' "bump") scene units of relief per unit of height
    mirrored_maps: bool = False          # its back sees the map's normal mirrored through the surface (Mitsuba's
                                         # twosided around normalmap or bumpmap), not turned whole
    # principled, by Mitsuba's names (colour: its base_color; bsdfs.py, principled_terms.py)
    roughness: float = 0.5
    anisotropic: float = 0.0
    metallic: float = 0.0
    principled_specular: float | None = None  # its `specular` (None: 0.5, unless principled_eta is given)
    principled_eta: float | None = None       # its `eta`, int_ior / ext_ior (None: from principled_specular)
    spec_tint: float = 0.0
    sheen: float = 0.0
    sheen_tint: float = 0.0
    clearcoat: float = 0.0
    clearcoat_gloss: float = 0.0
    spec_trans: float = 0.0
    main_specular_sampling_rate: float = 1.0
    clearcoat_sampling_rate: float = 1.0
    diffuse_reflectance_sampling_rate: float = 1.0
    # principledthin's own beside those (its eta: principled_eta, None for Mitsuba's 1.5)
    flatness: float = 0.0
    diff_trans: float = 0.0
    specular_reflectance_sampling_rate: float = 1.0
    specular_transmittance_sampling_rate: float = 1.0
    diffuse_transmittance_sampling_rate: float = 1.0
    emitter: int = -1                    # the Scene.emitters entry of the one shape it is the material of (each
                                         # emitting shape has its own), -1: none


@dataclass(frozen=True)
class Rectangle:
    """Centre, full size (sx, sy), unit normal n, unit tangent t (x axis); bitangent n x t (y axis)."""
    center: np.ndarray
    size: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    material: int = 0

    @property
    def bitangent(self):
        return np.cross(self.normal, self.tangent)


@dataclass(frozen=True)
class Light(Rectangle):
    colour: np.ndarray = field(default_factory=lambda: np.ones(3))  # Phong: the course's colour; else radiance
    material: int = -1  # the path model: the material it reflects with (-1: none, black)


@dataclass(frozen=True)
class Triangle:
    vertices: np.ndarray          # 3 x 3, rows v0, v1, v2
    material: int = 0
    uv: np.ndarray | None = None  # 3 x 2 per-vertex texture coordinates, or None for (b1, b2)


@dataclass(frozen=True)
class Ellipsoid:
    """The image of the unit sphere under x -> center + axes.T @ x (rows of `axes` are a, b, c)."""
    center: np.ndarray
    axes: np.ndarray
    material: int = 0
    flip_normals: bool = False  # its front faces inwards (Mitsuba's sphere's flip_normals)

    @property
    def matrix(self):
        return self.axes.T


def frame_of(n):
    """Mitsuba 3's coordinate_system(n) (Duff et al. 2017, its signs as dr::sign and dr::mulsign): the
    (s, t) of the Frame3f its cylinder builds around its axis, which fixes where its u = 0 lies."""
    sign = 1.0 if n[2] >= 0 else -1.0
    mulsign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return (np.array([n[0] * n[0] * a * mulsign + 1.0, b * mulsign, -n[0] * mulsign]),
            np.array([b, n[1] * n[1] * a + sign, -n[1]]))


@dataclass(frozen=True)
class Disk:
    """Mitsuba 3's disk: the unit disk x^2 + y^2 <= 1 in z = 0 (normal +z) under the affine 4 x 4 to_world;
    flip_normals turns its normal (its front)."""
    to_world: np.ndarray
    flip_normals: bool = False
    material: int = 0

    @property
    def matrix(self):
        """The map of the local unit disk to the world (4 x 4)."""
        return np.asarray(self.to_world, np.float64)


@dataclass(frozen=True)
class Cylinder:
    """Mitsuba 3's cylinder: the open tube of `radius` around the segment p0 -> p1 (object space) under the
    affine 4 x 4 to_world, its normals outwards unless flip_normals."""
    to_world: np.ndarray
    p0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p1: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    radius: float = 1.0
    flip_normals: bool = False
    material: int = 0

    @property
    def matrix(self):
        """The map of the local unit cylinder x^2 + y^2 = 1, 0 <= z <= 1 to the world (4 x 4): Mitsuba's
        to_world * translate(p0) * to_frame(Frame3f(axis)) * scale(radius, radius, length)."""
        p0, axis = np.asarray(self.p0, np.float64), np.asarray(self.p1, np.float64) - self.p0
        length = np.linalg.norm(axis)
        n = axis / length
        s, t = frame_of(n)
        local = np.eye(4)
        local[:3, :3] = np.column_stack([s * self.radius, t * self.radius, n * length])
        local[:3, 3] = p0
        return np.asarray(self.to_world, np.float64) @ local


@dataclass(frozen=True)
class ShapeEmitter:
    """An area emitter on a shape (Mitsuba's `area` on any shape; the radiometric models): the shape emits
    `radiance` from its front side. The shape's material (Scene.materials[material]) is its own, made for it,
    whose `emitter` names this entry: a copy of the material the shape names, or a black one where it names
    none (reflects False; Mitsuba's default BSDF of an emitting shape is black)."""
    material: int
    radiance: np.ndarray
    reflects: bool = True


DELTA_EMITTERS = ("point", "spot", "directional", "projector")  # Mitsuba's emitters that are no shape


@dataclass(frozen=True)
class PointEmitter:
    """Mitsuba's `point`: radiant intensity `intensity` (RGB, per steradian) in every direction from `position`
    (the radiometric models; kernels/emitters.cl)."""
    position: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.ones(3))

    @property
    def radiance(self):  # the Emitter table's colour (and what ranges.py bounds brightness by)
        return np.asarray(self.intensity, np.float64)


@dataclass(frozen=True)
class SpotEmitter:
    """Mitsuba's `spot`: intensity `intensity` along its axis, the local +z of the affine 4 x 4 to_world from its
    origin, falling off linearly in the angle from beam_width to cutoff_angle (degrees; beam_width None: 3/4 of
    the cutoff), times an optional texture (a TextureLookup) projected over the cone."""
    to_world: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.ones(3))
    cutoff_angle: float = 20.0
    beam_width: float | None = None
    texture: TextureLookup | None = None

    @property
    def beam(self):
        """beam_width in degrees, Mitsuba's default where none is given."""
        return self.cutoff_angle * 3 / 4 if self.beam_width is None else self.beam_width

    @property
    def radiance(self):
        return np.asarray(self.intensity, np.float64)


@dataclass(frozen=True)
class DirectionalEmitter:
    """Mitsuba's `directional`: irradiance `irradiance` (RGB, on a surface facing it) arriving along the
    direction `direction` (where the light travels to) from beyond the scene."""
    direction: np.ndarray
    irradiance: np.ndarray = field(default_factory=lambda: np.ones(3))

    @property
    def radiance(self):
        return np.asarray(self.irradiance, np.float64)


@dataclass(frozen=True)
class ProjectorEmitter:
    """Mitsuba's `projector`: a perspective camera in reverse, at the affine 4 x 4 to_world's origin looking along
    its local +z, of horizontal field of view `fov` (degrees), projecting an image (`texture`, a TextureLookup;
    None: the constant `irradiance`) times `scale`: the plane z = 1 receives pi scale times the image's value
    (Mitsuba's convention). aspect: the image's width over its height (1 without an image)."""
    to_world: np.ndarray
    fov: float
    irradiance: np.ndarray = field(default_factory=lambda: np.ones(3))
    scale: float = 1.0
    texture: TextureLookup | None = None
    aspect: float = 1.0

    @property
    def radiance(self):
        return math.pi * self.scale * np.asarray(self.irradiance, np.float64)


@dataclass(frozen=True)
class MeshShape:
    """A triangle mesh read from a file or generated (raytrace.scene.meshes.Mesh), in world space. smooth: shade
    with its per-vertex normals (the file's, else area-weighted ones) instead of each face's own."""
    mesh: meshes.Mesh
    material: int = 0
    smooth: bool = False
    dropped: int = 0  # degenerate faces left out on load
    source: str = ""  # the file it was read from, or the generator


@dataclass(frozen=True)
class ShapeGroup:
    """Mitsuba's shapegroup: meshes (MeshShape) in the group's own space, kept once under a BVH of their own,
    which instances place (kernels/instances.cl)."""
    name: str
    meshes: list

    def bounds(self):
        """(lo, hi): the group's axis-aligned box in its own space (float64)."""
        v = np.concatenate([m.mesh.vertices[m.mesh.faces].reshape(-1, 3) for m in self.meshes])
        return v.min(axis=0), v.max(axis=0)


@dataclass(frozen=True)
class Instance:
    """Mitsuba's instance: group `group` (an index into Scene.groups) placed by the affine 4 x 4 to_world."""
    group: int
    to_world: np.ndarray

    def bounds(self, group):
        """(lo, hi): the world box of the group's box's eight corners placed (float64)."""
        lo, hi = group.bounds()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        placed = corners @ self.to_world[:3, :3].T + self.to_world[:3, 3]
        return placed.min(axis=0), placed.max(axis=0)


@dataclass
class Scene:
    """A scene as load_file, load_dict or load_string read it, in float64: the camera, the image size, the
    render defaults (spp, light_samples, sampler, light_sampler), the ambient term, lights, materials and
    shapes (rectangles, triangles, ellipsoids, disks, cylinders, meshes), the textures the materials index, and the shading
    model. `source` is the checked table it was read from (raytrace.parameters edits it); render() checks a
    scene again if it changed since (`checked` holds the fingerprint of its last check)."""
    path: str
    camera: Camera
    width: int
    height: int
    ambient: np.ndarray
    lights: list
    materials: list
    rectangles: list = field(default_factory=list)
    triangles: list = field(default_factory=list)
    ellipsoids: list = field(default_factory=list)
    disks: list = field(default_factory=list)
    cylinders: list = field(default_factory=list)
    spp: int = 1
    light_samples: int = 1
    sampler: str = "grid"
    light_sampler: str = "grid"
    light_selection: str = "power"  # how a light sample chooses its emitter: one of LIGHT_SELECTIONS
    textures: list = field(default_factory=list)  # raytrace.textures.Texture, indexed by the materials
    meshes: list = field(default_factory=list)    # MeshShape; their triangles follow `triangles` in the kernel
    shading: str = "phong"  # one of SHADINGS
    max_depth: int = -1     # the path model's vertices per path, Mitsuba's convention (-1: unbounded)
    seed: int = 0           # the random patterns' per-pixel randomisation
    rr_depth: int = RR_DEPTH  # the path model's first vertex at which Russian roulette may end a path
    hide_emitters: bool = False  # the radiometric models: camera rays do not see the emitters (Mitsuba's)
    bsdf_samples: int = 0   # the direct model's BSDF samples, besides light_samples per light (Mitsuba's direct)
    crop_offset_x: int = 0  # the film's window rendered (hdrfilm's crop): its top-left pixel and its size
    crop_offset_y: int = 0
    crop_width: int | None = None   # None: to the film's edge
    crop_height: int | None = None
    rfilter: str = "box"    # the film's reconstruction filter, one of RFILTERS, and its parameters (Mitsuba's)
    rfilter_radius: float = 1.0    # tent
    rfilter_stddev: float = 0.5    # gaussian
    rfilter_b: float = 1.0 / 3.0   # mitchell
    rfilter_c: float = 1.0 / 3.0
    rfilter_lobes: int = 3         # lanczos
    sample_border: bool = False    # a filter's samples fall outside the crop window too (hdrfilm's)
    aovs: tuple = ()        # the AOVs a render stores beside the image: (name, type) pairs (raytrace/aovs.py)
    environment: np.ndarray | None = None  # the path model's constant environment radiance (RGB), or None
    environment_map: EnvironmentMap | None = None  # the path model's envmap emitter, or None
    emitters: list = field(default_factory=list)  # ShapeEmitter, and the delta lights (PointEmitter, ...)
    groups: list = field(default_factory=list)     # ShapeGroup: meshes kept once, which instances place
    instances: list = field(default_factory=list)  # Instance: the groups' placements
    source: dict | None = field(default=None, compare=False, repr=False)  # the checked table it was made from
    revision: int = field(default=0, compare=False, repr=False)  # counts its edits (raytrace.parameters)
    checked: str | None = field(default=None, compare=False, repr=False)  # fingerprint() when last checked

    @property
    def crop(self):
        """The window of the film rendered: (x, y, width, height), the whole film by default."""
        return (self.crop_offset_x, self.crop_offset_y,
                self.width - self.crop_offset_x if self.crop_width is None else self.crop_width,
                self.height - self.crop_offset_y if self.crop_height is None else self.crop_height)

    @property
    def triangle_count(self):
        return len(self.triangles) + sum(len(m.mesh.faces) for m in self.meshes)

    @property
    def group_triangle_count(self):
        """The groups' triangles, each kept once: they follow the scene's own in the kernel's Triangle table."""
        return sum(len(m.mesh.faces) for g in self.groups for m in g.meshes)

    def __repr__(self):  # one line: the dataclass's own repr prints every vertex of every mesh
        def counted(n, word):
            return f"{n} {word}{'s' * (n != 1)}"
        parts = [f"{self.width}x{self.height}", self.shading, counted(len(self.lights), "light"),
                 counted(len(self.materials), "material"), counted(len(self.rectangles), "rectangle"),
                 counted(len(self.ellipsoids), "ellipsoid"), counted(self.triangle_count, "triangle"),
                 *[counted(n, word) for n, word in ((len(self.disks), "disk"), (len(self.cylinders), "cylinder"))
                   if n],
                 counted(len(self.textures), "texture")]
        if self.environment is not None or self.environment_map is not None:
            parts.append("an environment")
        return f"Scene({self.path!r}: {', '.join(parts)})"


def fingerprint(scene):
    """A digest of every value of the model the kernel reads: equal digests, the same values."""
    digest = hashlib.blake2b(digest_size=16)

    def add(x):
        if isinstance(x, np.ndarray):
            digest.update(str((x.dtype, x.shape)).encode())
            digest.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, (list, tuple)):
            digest.update(b"[%d" % len(x))
            for y in x:
                add(y)
        elif isinstance(x, dict):
            digest.update(b"{%d" % len(x))
            for key in sorted(x):
                add(key)
                add(x[key])
        elif hasattr(x, "__dataclass_fields__"):
            digest.update(type(x).__name__.encode())
            for name in x.__dataclass_fields__:
                if name not in ("source", "revision", "checked", "path"):
                    add(getattr(x, name))
        else:
            digest.update(repr(x).encode())
    add(scene)
    return digest.hexdigest()
