"""The ranges a scene's values keep, so that the kernel's float32 arithmetic stays finite. One rule, applied by
scene_file.py and rules.py to every value with its key:

1. Every number is a finite float32, |x| <= FLOAT32_MAX (checked as each value is read).
2. Every point the kernel computes with (the camera and what it looks at, the corners of rectangles and lights,
   an ellipsoid's bounding box, triangle and mesh vertices, points displaced by a height map) lies within
   COORDINATE_LIMIT = 2^60 of the origin on every axis: the squared distance of two such points is then at
   most 3 (2^61)^2 = 2^123.6, and the dot products and sums built from them stay below float32's 2^128.
3. A rectangle's or light's area is a normal float32 (at least 2^-126), and an ellipsoid's shortest
   semi-axis (the smallest singular value of its axes) is at least 2^-60 max(1, extent), the extent being
   the largest coordinate of rule 2: its map into unit-sphere space stretches distances by at most 1 over
   that, so unit-sphere coordinates stay below 2^62 and their squares below 2^124.
4. The brightest value a pixel can take, max(k (ambient + 2 sum L), max L) (k the largest albedo: a colour,
   or a colour map's brightest texel, which replaces it; n.l and the specular power are each at most 1), is at
   most BRIGHTEST_LIMIT = 2^62: the variance image holds squares of pixel values (2^124 at most), and a launch
   sums up to 2^16 light samples in each of up to 2^16 pixel samples (2^94 at most). The Phong and direct
   models' rule; the path model's is 5.
5. The path model. A path's sample sums what each of its vertices gathers times the throughput there.
   - A vertex gathers at most E + k (n sum L + E_env) / 2: what its BSDF's sample reaches, E (the brightest
     emitter: a light's radiance, or the environment's: its constant radiance, or its scale times its
     brightest texel), under an MIS weight of at most 1; and each of the n samples of each light of radiance
     L, and the environment's sample, at most k L / 2 or k E_env / 2 (k the largest albedo): the power
     heuristic weighs a sample by 1 / (1 + x^2), x the ratio of the two densities, which makes its value the
     BSDF sample's weight f cos / p_bsdf times x / (1 + x^2) <= 1/2, and that weight is at most k for every
     BSDF (rho, k F, k F G1(wi), glass's k or k G1 besides its 1 / eta^2 below; the delta BSDFs take no light
     samples). A plastic's weight is a colour times what its coat makes of the sampled lobe's probability:
     max(1, w / (1 - w)) / (eta^2 (1 - R)) for its base, max(1, (1 - w) / w) / F for its coat (w the coat's
     share of the samples, R its internal reflectance, F its Fresnel reflectance), above 1 exactly where that
     lobe was unlikely to be chosen; its expectation over the samples, the plastic's albedo, is at most the
     larger of its coat's specular reflectance and its base's albedo seen through the coat, d T / (1 - r) (d
     the base's colour, T the share of the base's diffuse light the coat lets out, r = R or d R with
     nonlinear: plastic_albedo). For a smooth coat T = 1 - R exactly, but R is Mitsuba's fit, which the plastic
     copies: T / (1 - R) is within 0.3% of 1 for relative indices 0.3 to 2, 2.7% at diamond's 2.4, 25% at 3,
     and grows without bound as the fit's R reaches 1 (at 3.85, beyond which 1 - R < 0: a negative colour).
     So for a plastic k is its coat's specular reflectance or its base's d T / (1 - r) where that exceeds d
     by more than FIT_SLACK (1%), else d: the fit's error below that is the rule's slack, and a coat whose
     1 - r rounds to 0 or below in float32 (the kernel divides by it) is refused, naming int_ior (or, with
     nonlinear, the colour). k bounds the throughput's expectation and, by Markov's inequality, a throughput
     k^n 2^m comes with probability at most 2^-m.
   - Each vertex multiplies the throughput by that weight, and a refraction by 1 / eta^2 (radiance, pbrt-v4
     section 9.5), which along a path through closed shapes multiply to the squared ratio of two of the
     scene's indices, at most R^2 (R the largest ratio of two of the smooth and rough dielectrics' int_ior and
     ext_ior, and of a transmitting principled's eta and 1; 1 without glass; a thin dielectric leaves radiance
     as it was). With max_depth = D the throughput is then at most G = R^2 max(1, k)^(D - 1); with D = -1
     (unbounded) k must be at most 1, and G = R^2.
   - Russian roulette divides the throughput by the probability q <= 0.95 it continues with (or sets it back
     to at most 1 where q is below 0.95), so after m continuations at 0.95 a vertex carries at most G 0.95^-m,
     and all of a path's vertices together 20 G 0.95^-m (a geometric sum). Each continuation has probability
     0.95 at most.
   So B = (E + k (n sum L + E_env) / 2) G bounds a sample but for roulette's factor. G and B are at most
   PATH_BRIGHTEST_LIMIT = 2^32 (G alone too: the throughput is formed, and glass squares eta, even where no
   light is). A sample then passes rule 4's 2^62 only after 348 continuations, with probability 0.95^348 < 2^-25
   (1.8e-8), and only where each vertex's weight keeps the throughput at 0.95 or more (an albedo of 0.95 or
   more, or glass's 1 / eta^2); its square overflows float32 only past 2^64 (0.95^375 < 5e-9). A path that
   leaves glass it did not enter (an open glass mesh, overlapping shapes) gains 1 / eta^2 anew, which R^2
   does not bound: a limit of the rule. So is a principled BSDF's k, taken as its colour's largest (the colour
   its weights blend): Disney's lobes add rather than share the light (the dielectric's reflection over the
   diffuse base, the clearcoat over both, the sheen), and Burley's retro-reflection gains energy towards
   grazing angles, so its albedo exceeds its colour's (its white furnace test measures a white one at up to 1.4
   at 85 degrees, 1.18 with the default dielectric over the diffuse, 1.28 with flatness's fake subsurface) and
   its sample weights, with the lobe choice's rates, may exceed k. A principledthin's k is the same, for the
   same reasons (up to 1.4 too, and 1.28 with flatness).
6. The relative index eta = int_ior / ext_ior of every BSDF that has one (the glass and the plastics), which
   the kernel is given as a float32 (packing.py) and squares (Fresnel's (1 - cos^2) / eta^2, the radiance's 1
   / eta^2 under a plastic's coat), lies within [2^-63, 2^63] (ETA_LIMIT): eta^2 and 1 / eta^2 are then normal
   float32 numbers. Glass's ratio rule 5 bounds within 2^16; a thin dielectric's and a plastic's this. The
   fuzz suite found a plastic of int_ior 1e-30 (eta^2 = 0 in float32: its base's (1 - F)^2 / eta^2 was 0 / 0,
   NaN) and a ratio beyond float32's range (int_ior 1, ext_ior 1e-45: eta packed as inf). A principled BSDF's
   eta (given, or from its specular: within [1, 1.8]) is held to the same bounds: its Fresnel term squares it
   and its transmission's half vector and Jacobian take eta^2."""
import math

import numpy as np

from ..numerics import COORDINATE_LIMIT, FLOAT32_MAX, FLOAT32_TINY
from ..structs import ROUGH_TRANSMITTANCE_RES
from . import bsdfs, plastic_terms, principled_terms, rough_transmittance
from .model import RADIOMETRIC, Camera, Cylinder, Disk, Ellipsoid, Light, MeshShape, Rectangle, ShapeEmitter, Triangle

MAX_IMAGE_SIDE = 16384  # pixels, the same for a scene file and the command line
MAX_SAMPLES = 1 << 16   # pixel samples and light samples
ELLIPSOID_AXIS_RATIO = 2.0 ** -60
BRIGHTEST_LIMIT = 2.0 ** 62
PATH_BRIGHTEST_LIMIT = 2.0 ** 32  # rule 5: 2^30 below BRIGHTEST_LIMIT, for Russian roulette's growth
FIT_SLACK = 0.01  # rule 5: a plastic's base albedo above its colour by Mitsuba's fit of R, below this, is ignored
ETA_LIMIT = 2.0 ** 63  # rule 6: int_ior / ext_ior within [1 / ETA_LIMIT, ETA_LIMIT]
INDEXED = bsdfs.INDEXED  # the BSDFs with indices
ETA_PROBLEM = ", beyond [2^-63, 2^63], within which float32 squares it and its reciprocal as normal numbers"


def float32_problem(x):
    """Why the number x cannot be a float32 value, or None."""
    if isinstance(x, int) and abs(x) > FLOAT32_MAX:  # a TOML integer may be beyond float64 as well
        return f"beyond float32's range (|x| <= {FLOAT32_MAX:.6g})"
    if not math.isfinite(x):
        return "must be a finite number"
    if abs(x) > FLOAT32_MAX:
        return f"beyond float32's range (|x| <= {FLOAT32_MAX:.6g})"
    return None


def camera_points(camera):
    """(key, point) of the points a camera's rays start from or aim at, with the key that places each: the eye,
    look_at, the near plane's centre, a thin lens's extent and focal point, an orthographic view's corners."""
    forward, right, up = camera.basis()
    near = camera.position + camera.near_clip * forward
    points = [("position", camera.position), ("look_at", camera.look_at), ("near_clip", near)]
    if camera.kind == "thinlens":
        lateral = camera.aperture_radius * (np.abs(right) + np.abs(up))
        points += [("aperture_radius", camera.position - lateral), ("aperture_radius", camera.position + lateral),
                   ("focus_distance", camera.position + camera.focus_distance * forward)]
    if camera.kind == "orthographic":
        half = camera.size[0] / 2 * np.abs(right) + camera.size[1] / 2 * np.abs(up)
        points += [("size", near - half), ("size", near + half)]
    return points


def corners(shape):
    """(N, 3) points bounding `shape` (a Camera, Rectangle or Light, Triangle, Ellipsoid, Disk, Cylinder or
    MeshShape)."""
    if isinstance(shape, Camera):
        return np.array([point for _, point in camera_points(shape)])
    if isinstance(shape, Rectangle):
        half = shape.size[0] / 2 * np.abs(shape.tangent) + shape.size[1] / 2 * np.abs(shape.bitangent)
        return np.array([shape.center - half, shape.center + half])
    if isinstance(shape, Ellipsoid):
        half = np.linalg.norm(shape.axes, axis=0)  # the bounding box of center + axes.T @ unit sphere
        return np.array([shape.center - half, shape.center + half])
    if isinstance(shape, (Disk, Cylinder)):  # the box of the local unit box's image
        m = shape.matrix
        half = np.abs(m[:3, :3]).sum(axis=1)
        return np.array([m[:3, 3] - half, m[:3, 3] + half])
    if isinstance(shape, Triangle):
        return shape.vertices
    if isinstance(shape, MeshShape):
        v = shape.mesh.vertices
        return np.array([v.min(axis=0), v.max(axis=0)])
    raise TypeError(shape)


def extent(points):
    return float(np.abs(points).max())


def shortest_semi_axis(ellipsoid):
    return float(np.linalg.svd(ellipsoid.axes, compute_uv=False).min())


def largest_texel(texture):
    """The largest value of a texture's colour channels (8-bit codes stand for [0, 1])."""
    level = texture.levels[0]
    return 1.0 if level.dtype == np.uint8 else float(np.abs(level[..., :3]).max())


def largest_albedo(scene, material):
    """k of rules 4 and 5 for one material: its largest colour, or the brightest texel of its colour map, which
    replaces the colour (kernels/material.cl's texture_material, docs/textures.md); for a plastic, the bound on
    its albedo of rule 5 (plastic_albedo)."""
    k = base_albedo(scene, material)
    return plastic_albedo(material, k) if material.bsdf in COATED else k


def base_albedo(scene, material):
    """A material's largest colour, or the brightest value of its colour map or of its colour's texture (the
    material keeps the texture's mean as its colour, which a brighter texel exceeds)."""
    if material.colour_map >= 0:
        return largest_texel(scene.textures[material.colour_map])
    lookup = dict(material.maps).get("colour")
    if lookup is not None:
        return largest_lookup(scene, lookup)
    return float(np.max(material.colour))


def colour_key(reader, material):
    """The key of a material's table that gives its colour as a texture (its `colour`, `reflectance`, ...: the
    value rules 4 and 5 name), else "colour"."""
    for key, value in reader.table.items():
        if isinstance(value, dict) and (key == "colour" or (material.bsdf in bsdfs.BY_NAME and bsdfs.texture_slot(
                bsdfs.BY_NAME[material.bsdf], key) == "colour")):
            return key
    return "colour"


def largest_lookup(scene, lookup):
    """The largest value a texture (model.TextureLookup) gives: its image's brightest texel, a checkerboard's
    brighter colour, a mesh attribute's largest value on any mesh, times its scale."""
    if lookup.kind == "bitmap":
        return largest_texel(scene.textures[lookup.texture])
    if lookup.kind == "checkerboard":
        return float(max(np.max(lookup.colour0), np.max(lookup.colour1)))
    values = [float(np.max(shape.mesh.attributes[lookup.attribute])) for shape in scene.meshes
              if lookup.attribute in shape.mesh.attributes]
    return max(values, default=0.0) * lookup.scale


COATED = ("plastic", "roughplastic")
GLASS = ("dielectric", "roughdielectric")  # the BSDFs whose refraction scales radiance by 1 / eta^2 (rule 5)


def coat_transmittance(material):
    """T of rule 5: the share of the light a plastic's base scatters diffusely that leaves through its coat,
    times 1 / eta^2 as the kernel takes it, 2 int_0^1 t(mu) mu dmu / eta^2 with t the coat's transmittance
    from outside. A smooth coat's t is 1 - F(mu) (kernels/bsdfs/plastic.cl), and T = 1 - R_in, R_in the
    coat's diffuse reflectance seen from inside (the reciprocity of a smooth interface's hemispherical
    transmittances, eta^2 (1 - R_in) = 1 - R_out): each found from the side that has no total internal
    reflection, whose integrand is smooth. A rough coat's t is roughplastic.cl's table, linear between its
    entries, whose integral against mu is exact by Simpson's rule on each interval."""
    eta = float(material.int_ior) / float(material.ext_ior)
    if material.bsdf == "roughplastic":
        t = rough_transmittance.table(material).astype(np.float64)
        mu = np.linspace(0.0, 1.0, ROUGH_TRANSMITTANCE_RES)
        t0, t1, m0, m1 = t[:-1], t[1:], mu[:-1], mu[1:]
        inside = np.sum((m1 - m0) * (2 * t0 * m0 + t0 * m1 + t1 * m0 + 2 * t1 * m1) / 6)  # int t mu, t linear
        return 2 * float(inside) / eta**2
    x, w = np.polynomial.legendre.leggauss(64)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    if eta >= 1.0:
        return (1.0 - 2 * float(np.sum(w * _fresnel_dielectric(mu, eta) * mu))) / eta**2
    return 1.0 - 2 * float(np.sum(w * _fresnel_dielectric(mu, 1.0 / eta) * mu))


def _fresnel_dielectric(cos_i, eta):
    """kernels/fresnel.cl's fresnel_dielectric in float64, for eta >= 1 (no total internal reflection)."""
    ct = np.sqrt(1.0 - (1.0 - cos_i * cos_i) / (eta * eta))
    r_parl = (eta * cos_i - ct) / (eta * cos_i + ct)
    r_perp = (cos_i - eta * ct) / (cos_i + eta * ct)
    return 0.5 * (r_parl**2 + r_perp**2)


def coat_peak(material):
    """The most of the light arriving from outside that a plastic's coat lets through, over the directions: 1
    - F(1) = 4 eta / (1 + eta)^2 for a smooth coat, its table's largest entry for a rough one."""
    if material.bsdf == "roughplastic":
        return float(np.max(rough_transmittance.table(material)))
    eta = float(material.int_ior) / float(material.ext_ior)
    return 4 * eta / (1 + eta) ** 2


def plastic_excess(material, k):
    """T / (1 - r) of rule 5 for a plastic's base of albedo k (r = R, or k R with nonlinear: R the coat's
    internal reflectance as the kernel gets it, a float32), inf where 1 - r rounds to 0 or below in float32."""
    r = float(np.float32(plastic_terms.coat(material)[0]))
    r = k * r if material.nonlinear else r
    below = float(np.float32(1.0) - np.float32(r)) if math.isfinite(r) else -math.inf
    return coat_transmittance(material) / below if below > 0 else math.inf


def plastic_albedo(material, k):
    """Rule 5's k of a plastic of base albedo k: max(k, s), s its coat's largest specular reflectance, unless
    the albedo through the coat exceeds that by more than FIT_SLACK; inf where the kernel's 1 - r <= 0. The
    albedo from a direction at cos_o is g s + t k T / (1 - r) with t = t(cos_o) the coat's transmittance and g
    <= 1 - t its reflectance (g = F = 1 - t for a smooth coat), at most max(s, (1 - t) s + t k T / (1 - r))
    with t the coat's largest (coat_peak)."""
    s = float(np.max(material.specular))
    excess = plastic_excess(material, k)
    if excess == math.inf:
        return math.inf
    t = coat_peak(material)
    through = max(s, (1 - t) * s + t * k * excess)
    plain = max(k, s)
    return through if through > plain * (1 + FIT_SLACK) else plain


def brightest(scene):
    """An upper bound on every pixel value of the scene's Phong or direct image (rule 4); the direct model's
    environment counts as a light of its brightest radiance (each of its samples adds k L: direct_lighting.cl)."""
    k = max(largest_albedo(scene, m) for m in scene.materials)
    lights = [float(light.colour.max()) for light in scene.lights] + [float(e.radiance.max()) for e in scene.emitters]
    lights += [environment_brightest(scene)] * (scene.environment is not None or scene.environment_map is not None)
    return max(k * (float(scene.ambient.max()) + 2 * sum(lights)), *lights, 0.0)


def _far_key(shape):
    """The key of `shape`'s table that places it: its position or centre when that is beyond the limit
    itself, else what reaches out from it."""
    anchor, reach = {Camera: ("position", "look_at"), Ellipsoid: ("center", "axes"), Triangle: ("vertices",) * 2,
                     MeshShape: ("scale", "scale"), Disk: ("to_world",) * 2, Cylinder: ("to_world",) * 2}.get(type(shape), ("center", "size"))
    at = shape.position if isinstance(shape, Camera) else getattr(shape, "center", None)
    if isinstance(shape, Camera) and np.abs(at).max() <= COORDINATE_LIMIT:  # the first key whose point is beyond
        beyond = [key for key, point in camera_points(shape) if np.abs(point).max() > COORDINATE_LIMIT]
        return beyond[0] if beyond else reach
    return anchor if at is None or np.abs(at).max() > COORDINATE_LIMIT else reach


def _check_extents(places):
    """Rule 2, naming the first shape beyond it; returns the scene's extent."""
    largest = 1.0
    for reader, shape in places:
        far = extent(corners(shape))
        if far > COORDINATE_LIMIT:
            key = _far_key(shape)
            reader.fail(key, reader.raw(key), f"puts a point {far:.4g} from the origin, beyond the {COORDINATE_LIMIT:.4g} "
                        "(2^60) within which float32 arithmetic on coordinates stays finite")
        largest = max(largest, far)
    return largest


def _check_sizes(places, scale):
    """Rule 3."""
    for reader, shape in places:
        if isinstance(shape, Rectangle) and not (shape.size.min() >= FLOAT32_TINY
                                                 and shape.size.prod() >= FLOAT32_TINY):
            reader.fail("size", reader.raw("size"), f"both sides and the area must be at least {FLOAT32_TINY:.4g} "
                        "(normal float32 numbers)")
        if isinstance(shape, Ellipsoid) and shortest_semi_axis(shape) < ELLIPSOID_AXIS_RATIO * scale:
            reader.fail("axes", reader.raw("axes"), f"shortest semi-axis {shortest_semi_axis(shape):.4g} below 2^-60 "
                        f"of the scene's extent {scale:.4g}: unit-sphere coordinates would overflow float32")
        if isinstance(shape, (Disk, Cylinder)):
            _check_local_scales(reader, shape, scale)


def _check_local_scales(reader, shape, scale):
    """Rule 3 for a disk or cylinder: its local coordinates, as the ellipsoid's unit-sphere ones."""
    shortest = float(np.linalg.svd(shape.matrix[:3, :3], compute_uv=False).min())
    if shortest < ELLIPSOID_AXIS_RATIO * scale:
        reader.fail("to_world", reader.raw("to_world"), f"maps a unit length to as little as {shortest:.4g}, under "
                    f"2^-60 of the scene's extent {scale:.4g}: local coordinates would overflow float32")


def _check_heights(scene, material_readers):
    """Rule 2 for the points a height map displaces."""
    for material, reader in zip(scene.materials, material_readers):
        if material.height_map >= 0:
            reach = material.height_scale * largest_texel(scene.textures[material.height_map])
            if reach > COORDINATE_LIMIT:
                reader.fail("height_scale", material.height_scale, f"with {reader.raw('height_map')} displaces points "
                            f"by up to {reach:.4g}, beyond "
                            f"the {COORDINATE_LIMIT:.4g} (2^60) within which float32 coordinates stay finite")


def _check_brightness(scene, material_readers, light_readers, scene_reader, emitters=()):
    """Rule 4, naming the largest factor: the brightest light or emitting shape (emitters: (its reader, its
    radiance's largest channel)), the largest albedo or the ambient term."""
    value = brightest(scene)
    if value <= BRIGHTEST_LIMIT:
        return
    albedos = [largest_albedo(scene, m) for m in scene.materials]
    brightest_material = int(np.argmax(albedos))
    material = scene.materials[brightest_material]
    material_key = "texture" if material.colour_map >= 0 else colour_key(material_readers[brightest_material],
                                                                         material)
    emission = "radiance" if scene.shading in RADIOMETRIC else "colour"
    sources = [((reader, emission), float(light.colour.max())) for reader, light in zip(light_readers, scene.lights)]
    sources += [((reader, key), radiance) for reader, key, radiance, _ in emitters]
    shown = {(reader, key): given for reader, key, _, given in emitters}
    terms = {(scene_reader, "ambient"): float(scene.ambient.max()),
             **dict(sources[:1] and [max(sources, key=lambda source: source[1])]),
             (material_readers[brightest_material], material_key): max(albedos)}
    reader, key = max(terms, key=terms.get)
    reader.fail(key, shown[reader, key] if (reader, key) in shown else reader.raw(key), f"makes a pixel as bright as {value:.4g}, beyond the "
                f"{BRIGHTEST_LIMIT:.4g} (2^62) up to which float32 sums of samples and squares of pixel values stay finite")


def _shown(reader, key, fallback):
    """The value of `key` (dotted: in a sub-table) as the reader's table holds it, else `fallback`, the model's
    (a default, or a model made in Python), as a scene file would show it."""
    node = reader.table
    for part in key.split("."):
        node = node.get(part) if isinstance(node, dict) else None
    node = fallback if node is None else node
    return node.tolist() if isinstance(node, np.ndarray) else node


def environment_brightest(scene):
    """E_env of rule 5: the environment's constant radiance, or its scale times its brightest texel (the
    largest channel); 0 without one."""
    if scene.environment is not None:
        return float(np.max(scene.environment))
    if scene.environment_map is not None:
        return float(scene.environment_map.scale) * float(np.max(scene.environment_map.texels))
    return 0.0


def refracting(material):
    """{key: index} of a material's refracting interface, as rule 5 counts them: a glass's int_ior and ext_ior,
    a principled's eta (from its `eta` or `specular`) beside the outside's 1 where it transmits ((1 - metallic)
    spec_trans > 0: its refraction scales radiance by 1 / eta^2 as glass's does); {} for the others."""
    if material.bsdf in GLASS:
        return {"int_ior": material.int_ior, "ext_ior": material.ext_ior}
    if material.bsdf == "principled" and (1 - material.metallic) * material.spec_trans > 0:
        key = "specular" if material.principled_eta is None else "eta"
        return {key: principled_terms.eta(material), "": 1.0}
    return {}


def index_ratio(scene):
    """R of rule 5: the largest ratio of two of the refracting materials' indices of refraction (1 without)."""
    iors = [x for m in scene.materials for x in refracting(m).values()]
    return max(iors) / min(iors) if iors else 1.0


def _largest_albedo(scene):
    return max(largest_albedo(scene, m) for m in scene.materials)


def path_gain(scene, k=None):
    """G of rule 5: a bound on a path's throughput but for Russian roulette's factor; inf where there is none
    (an albedo above 1 at unbounded depth). `k`: the largest albedo, where the caller has it (a float colour
    map's takes a pass over every level)."""
    k = _largest_albedo(scene) if k is None else k
    if scene.max_depth < 0:
        return index_ratio(scene) ** 2 if k <= 1 else math.inf
    with np.errstate(over="ignore"):
        return index_ratio(scene) ** 2 * float(np.float64(max(1.0, k)) ** max(scene.max_depth - 1, 0))


def path_brightest(scene, k=None, env=None):
    """B of rule 5: a bound on a path's sample but for Russian roulette's factor (`k`, `env`: the largest
    albedo and E_env, where the caller has them)."""
    k = _largest_albedo(scene) if k is None else k
    lights = [float(light.colour.max()) for light in scene.lights] + [float(e.radiance.max()) for e in scene.emitters]
    env = environment_brightest(scene) if env is None else env
    gather = max(lights + [env]) + k * (scene.light_samples * sum(lights) + env) / 2
    return gather * path_gain(scene, k) if gather else 0.0


def _log2(x):
    return math.log2(x) if x > 0 else -math.inf


def _path_places(scene, material_readers, light_readers, scene_reader, emitters=()):
    """(log2 of its share, (reader, key, the model's value)) of rule 5's factors of G, and of B's emitter: the
    largest albedo (raised to the depth, and once in what a vertex gathers), the dielectrics' ratio of
    indices squared (named by the index furthest from 1), and the brightest emitter."""
    albedos = [largest_albedo(scene, m) for m in scene.materials]
    i = int(np.argmax(albedos))
    material, reader = scene.materials[i], material_readers[i]
    albedo = (reader, "texture", material.colour_map) if material.colour_map >= 0 else (reader, colour_key(
        reader, material), material.colour)
    if material.bsdf in COATED and not material.nonlinear and albedos[i] > max(base_albedo(scene, material),
                                                                                float(np.max(material.specular))):
        albedo = (reader, "int_ior", material.int_ior)  # the coat's index, through Mitsuba's fit of R
    places = [(max(scene.max_depth, 1) * _log2(max(1.0, albedos[i])), albedo)]
    indices = [(abs(_log2(x)), (r, key, x)) for m, r in zip(scene.materials, material_readers)
               for key, x in refracting(m).items() if key]
    if indices:
        places.append((2 * _log2(index_ratio(scene)), max(indices, key=lambda x: x[0])[1]))
    sources = [(float(light.colour.max()), (reader, "radiance", light.colour))
               for reader, light in zip(light_readers, scene.lights)]
    sources += [(radiance, (reader, key, given)) for reader, key, radiance, given in emitters]
    brightest_source, source = max(sources, key=lambda s: s[0]) if sources else (0.0, None)
    env = environment_brightest(scene)
    if source is not None and env <= brightest_source or scene.environment is None and scene.environment_map is None:
        emitter = source  # (None: nothing emits, and the bound is 0)
    elif scene.environment is not None:
        emitter = (scene_reader, "environment.radiance", scene.environment)
    elif scene.environment_map.scale >= np.max(scene.environment_map.texels):
        emitter = (scene_reader, "environment.scale", scene.environment_map.scale)
    else:
        emitter = (scene_reader, "environment.filename", scene.environment_map.path)
    return places, (_log2(max(env, brightest_source, FLOAT32_TINY)), emitter)


def _check_path_brightness(scene, material_readers, light_readers, scene_reader, emitters=()):
    """Rule 5: an albedo above 1 at unbounded depth, the throughput's bound G, then the sample's B, each
    naming the largest factor of the bound it passes. The bounds' factors are found only for a broken rule: each
    pass over a float colour map or an environment map counts on a large one."""
    def places():
        return _path_places(scene, material_readers, light_readers, scene_reader, emitters)

    k, env = _largest_albedo(scene), environment_brightest(scene)
    if scene.max_depth < 0 and k > 1:
        reader, key, fallback = places()[0][0][1]
        reader.fail(key, _shown(reader, key, fallback), f"reflects more light than it receives (an albedo of "
                    f"{k:.4g}): with max_depth = -1 a path's throughput grows without bound; set render.max_depth")
    for value, what, with_emitter in ((path_gain(scene, k), "throughput as large", False),
                                      (path_brightest(scene, k, env), "sample as bright", True)):
        if value > PATH_BRIGHTEST_LIMIT:
            growth, emitter = places()
            factors = growth + [emitter] if with_emitter else growth
            reader, key, fallback = max(factors, key=lambda factor: factor[0])[1]
            reader.fail(key, _shown(reader, key, fallback), f"makes a path's {what} as {value:.4g}, beyond the "
                        f"{PATH_BRIGHTEST_LIMIT:.4g} (2^32) that leaves Russian roulette a factor 2^30 below the 2^62 "
                        "up to which float32 sums of samples and squares of pixel values stay finite")


def _check_indices(scene, material_readers):
    """Rule 6, naming the index further from 1 (in ratio)."""
    for material, reader in zip(scene.materials, material_readers):
        if material.bsdf == "principled":
            eta = principled_terms.eta(material)
            if not 1.0 / ETA_LIMIT <= eta <= ETA_LIMIT:
                reader.fail("eta", _shown(reader, "eta", material.principled_eta), f"makes the relative index {eta:.4g}"
                            + ETA_PROBLEM)
        if material.bsdf not in INDEXED or material.bsdf in GLASS:  # glass: rule 5's R, the tighter bound
            continue
        eta = float(material.int_ior) / float(material.ext_ior)
        if not 1.0 / ETA_LIMIT <= eta <= ETA_LIMIT:
            key = max(("int_ior", "ext_ior"), key=lambda k: abs(_log2(float(getattr(material, k)))))
            reader.fail(key, _shown(reader, key, getattr(material, key)), f"makes the relative index int_ior / "
                        f"ext_ior {eta:.4g}" + ETA_PROBLEM)
        if material.bsdf in COATED and not material.nonlinear and plastic_excess(material, 1.0) == math.inf:
            reader.fail("int_ior", _shown(reader, "int_ior", material.int_ior), f"makes the coat's internal "
                        f"reflectance (Mitsuba's fit, for int_ior / ext_ior {eta:.4g}) 1 or more: the base's light "
                        "would be divided by 1 - R <= 0 (the fit reaches 1 at a relative index of 3.85)")


def check_scene(scene, places, material_readers, light_readers, scene_reader):
    """Rules 2 to 6 for a parsed scene. `places` pairs the camera, each light and each shape with the reader
    of its table (whose fail(key, value, problem) names the file and the key); the other readers are those
    of the materials (in order), the lights (in order) and the whole file."""
    scale = _check_extents(places)
    _check_sizes(places, scale)
    _check_heights(scene, material_readers)
    _check_indices(scene, material_readers)  # before rule 5, which finds a plastic's coat terms from them
    emitting = {}  # each emitting shape's reader (an inline mesh's first triangle's), by emitter
    for reader, shape in places:
        emitter = scene.materials[shape.material].emitter if hasattr(shape, "material") and not isinstance(
            shape, Light) else -1
        if emitter >= 0:
            emitting.setdefault(emitter, reader)
    # each emitter's (reader, key, the largest channel of what ranges bound, the value shown): the emitting
    # shapes' radiance; a delta light's intensity or irradiance, named by its place among the [[emitters]]
    emitters = [(emitting[e], "radiance", float(scene.emitters[e].radiance.max()),
                 scene.emitters[e].radiance.tolist()) for e in sorted(emitting)]
    delta = [e for e in scene.emitters if not isinstance(e, ShapeEmitter)]
    for j, e in enumerate(delta):
        key = "intensity" if hasattr(e, "intensity") else "irradiance"
        emitters.append((scene_reader, f"emitters[{j}].{key}", float(e.radiance.max()),
                         np.asarray(getattr(e, key), np.float64).tolist()))
    if scene.shading == "path":
        _check_path_brightness(scene, material_readers, light_readers, scene_reader, emitters)
    else:
        _check_brightness(scene, material_readers, light_readers, scene_reader, emitters)
