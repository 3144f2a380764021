"""Packing the scene's values into the structs of kernels/types.h (their numpy mirrors are in
raytrace/structs.py): the one place where host values become what the kernel reads. scene_tables.py gathers
them into the tables named after the kernel's parameters (kernels/scene.h)."""
import math

import numpy as np

from .. import samplers, structs
from ..errors import InputError
from ..scene import mipmap
from ..structs import CULLED_RECTANGLES, MAX_WORDS
from ..scene import bsdfs, plastic_terms, principled_terms, rough_transmittance, texture_lookups
from ..scene.course_maps import kernel_materials
from ..scene.emitter_power import emitter_power
from ..scene.model import WRAPPERS, Material, ShapeEmitter
from .culling import light_sides
from .film_filter import rfilter_tables
from .geometry import DEFAULT_UV


def camera_struct(camera, width, height, crop=None, rfilter=("box", {}), border=False):
    """The camera of a film of width x height pixels, of which the window crop = (x, y, crop width, crop height)
    is rendered (None: the whole film), with the reconstruction filter rfilter = (name, {parameter: value}),
    whose samples fall outside the window too where `border` (Mitsuba's sample_border).
    The focal length cancels in the camera's ray directions and footprints (the image plane grows with it,
    the field of view fixed): it is packed as 1, so that no value of it overflows or underflows float32."""
    forward, right, up = camera.basis()
    c = np.zeros((), structs.CAMERA)
    c["position"], c["forward"], c["right"], c["up"] = camera.position, forward, right, up
    if camera.kind == "orthographic":
        c["scale_x"], c["scale_y"] = camera.size[0] / 2, camera.size[1] / 2
    else:
        tan_half = math.tan(math.radians(camera.fov_deg) / 2)
        c["scale_x"] = width / height * tan_half
        c["scale_y"] = tan_half
    c["focal_length"] = 1.0
    c["near_clip"], c["far_clip"] = camera.near_clip, camera.far_clip
    c["depth_from"] = camera.dropped_near_clip
    if camera.kind == "thinlens":
        c["lens_radius"], c["focus_distance"] = camera.aperture_radius, camera.focus_distance
    c["film_width"], c["film_height"] = width, height
    c["crop_x"], c["crop_y"], c["crop_width"], c["crop_height"] = (0, 0, width, height) if crop is None else crop
    name, parameters = rfilter
    c["rfilter"], c["rfilter_border"] = structs.RFILTERS[name], border
    if name != "box":
        tables = rfilter_tables(name, parameters)
        c["rfilter_bins"], c["rfilter_reach"], c["rfilter_step"] = tables.bins, tables.reach, tables.step
        c["rfilter_a"], c["rfilter_b"], c["rfilter_integral"] = tables.a, tables.b, tables.integral
        n = tables.bins + 1
        c["rfilter_pdf"][:n], c["rfilter_cdf"][:n], c["rfilter_cumulative"][:n] = (tables.pdf, tables.cdf,
                                                                                 tables.cumulative)
    return c


def rectangle_structs(rects):
    a = np.zeros(max(len(rects), 1), structs.RECTANGLE)
    for s, r in zip(a, rects):
        s["center"], s["normal"], s["tangent"], s["bitangent"] = r.center, r.normal, r.tangent, r.bitangent
        s["half_x"], s["half_y"], s["material"] = r.size[0] / 2, r.size[1] / 2, r.material
    return a


def triangle_records(v, material):
    """Triangle structs of the triangles v ((F, 3, 3): v0, v1, v2 each) with their material indices."""
    a = np.zeros(max(len(v), 1), structs.TRIANGLE)
    if len(v):
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 1])
        a["v0"][:len(v)], a["v1"][:len(v)], a["v2"][:len(v)] = v[:, 0], v[:, 1], v[:, 2]
        a["normal"][:len(v)] = n / np.linalg.norm(n, axis=1, keepdims=True)
        a["material"][:len(v)] = material
    return a


def triangle_structs(tris):
    return triangle_records(np.array([t.vertices for t in tris]).reshape(-1, 3, 3), [t.material for t in tris])


def _coordinate_system(n):
    """Two unit vectors completing the unit vectors n ((F, 3)) to orthonormal bases (Duff et al., JCGT 2017)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    return (np.stack([1 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], 1),
            np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], 1))


def triangle_uv_frames(v, uv):
    """dp/du and dp/dv ((F, 3) each) of the affine maps from uv ((F, 3, 2)) to the triangles v ((F, 3, 3))
    (pbrt-v4 section 6.5.4), in float64. A degenerate uv mapping (all uvs on a line) gets an orthonormal pair
    in the triangle's plane instead."""
    duv02, duv12, dp02, dp12 = uv[:, 0] - uv[:, 2], uv[:, 1] - uv[:, 2], v[:, 0] - v[:, 2], v[:, 1] - v[:, 2]
    det = duv02[:, 0] * duv12[:, 1] - duv02[:, 1] * duv12[:, 0]
    ok = np.abs(det) > 1e-9 * np.maximum(np.sum(duv02 ** 2, 1), np.sum(duv12 ** 2, 1))
    safe = np.where(ok, det, 1.0)[:, None]
    dpdu = (duv12[:, 1:] * dp02 - duv02[:, 1:] * dp12) / safe
    dpdv = (duv02[:, :1] * dp12 - duv12[:, :1] * dp02) / safe
    if not ok.all():
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 1])
        t, b = _coordinate_system(n / np.linalg.norm(n, axis=1, keepdims=True))
        dpdu[~ok], dpdv[~ok] = t[~ok], b[~ok]
    return dpdu, dpdv


def triangle_uv_records(v, uv):
    a = np.zeros(max(len(v), 1), structs.TRIANGLE_UV)
    if len(v):
        dpdu, dpdv = triangle_uv_frames(v, uv)
        a["uv"][:len(v)] = uv.reshape(-1, 6)
        a["dpdu"][:len(v)], a["dpdv"][:len(v)] = dpdu, dpdv
        a["tangent"][:len(v)] = dpdu / np.linalg.norm(dpdu, axis=1, keepdims=True)
    return a


def triangle_uv_structs(tris):
    uv = np.array([DEFAULT_UV if t.uv is None else t.uv for t in tris], np.float64).reshape(-1, 3, 2)
    return triangle_uv_records(np.array([t.vertices for t in tris]).reshape(-1, 3, 3), uv)


def triangle_normal_records(normals):
    a = np.zeros(max(len(normals), 1), structs.TRIANGLE_NORMALS)
    if len(normals):
        a["n0"][:len(normals)], a["n1"][:len(normals)], a["n2"][:len(normals)] = (normals[:, k] for k in range(3))
    return a


def shape_index_table(scene, triangle_shapes):
    """kernels/aovs.cl's shape_indices: the shape_index AOV of each primitive, 1 + the shape's place in the
    scene's order (raytrace/aovs.py's SHAPE_ORDER: its rectangles, loose triangles, meshes, ellipsoids, disks,
    cylinders, lights and instances, each list in its own order), laid out as the kernel reads it: the
    rectangles', ellipsoids', disks', cylinders', lights' and instances' numbers, then each triangle's in the
    Triangle table's order, from triangle_shapes (geometry.TriangleSoup.shape; a group's triangle: 0, its
    instance's number stands for it)."""
    counts = [len(scene.rectangles), len(scene.triangles) + len(scene.meshes), len(scene.ellipsoids),
              len(scene.disks), len(scene.cylinders), len(scene.lights), len(scene.instances)]
    first = 1 + np.concatenate([[0], np.cumsum(counts)[:-1]])  # each list's first number
    analytic = [np.arange(n) + f for k, (n, f) in enumerate(zip(counts, first)) if k != 1]
    triangles = np.where(triangle_shapes >= 0, triangle_shapes + first[1], 0)
    return np.concatenate([*analytic, triangles]).astype(np.int32)


def ellipsoid_structs(ells):
    a = np.zeros(max(len(ells), 1), structs.ELLIPSOID)
    for s, e in zip(a, ells):
        s["center"], s["material"], s["normal_sign"] = e.center, e.material, -1.0 if e.flip_normals else 1.0
        s["world_to_unit"] = np.linalg.inv(e.matrix).ravel()  # float64 inverse, rounded once
        s["unit_to_world"] = e.matrix.ravel()
    return a


def affine_shape_structs(shapes):
    """Disk or Cylinder structs (kernels/types.h): each shape's map of its local unit shape to the world (its
    `matrix`), the linear part's float64 inverse rounded once, and its normal's sign."""
    a = np.zeros(max(len(shapes), 1), structs.AFFINE_SHAPE)
    for s, shape in zip(a, shapes):
        m = shape.matrix
        s["center"], s["material"] = m[:3, 3], shape.material
        s["to_local"] = np.linalg.inv(m[:3, :3]).ravel()
        s["to_world"] = m[:3, :3].ravel()
        s["normal_sign"] = -1.0 if shape.flip_normals else 1.0
    return a


def light_structs(lights, rectangles=(), extent=0.0):
    """Light structs; with the scene's `rectangles` and `extent` (a bound on every coordinate of its shapes,
    lights and displaced shading points), each light's bits of the rectangles whose plane it lies wholly
    in front of or behind (planes_in_front, planes_behind)."""
    a = np.zeros(max(len(lights), 1), structs.LIGHT)  # a scene without lights (the API allows one) gets a dummy
    a["shape"] = rectangle_structs(lights)
    planes = rectangle_structs(rectangles[:CULLED_RECTANGLES]) if len(rectangles) else None
    for s, light in zip(a, lights):
        s["colour"] = light.colour
        if planes is not None:
            s["planes_in_front"], s["planes_behind"] = light_sides(s["shape"], planes, extent)
    return a


# A rough conductor or dielectric smoother than this renders as the smooth one (kernels/bsdfs/conductor.cl,
# dielectric.cl), as pbrt-v4's ConductorBxDF and DielectricBxDF do where their TrowbridgeReitzDistribution is
# EffectivelySmooth (section 9.6): near the normal, float32 resolves cos^2(theta_h) in steps of 2^-24, of which
# the GGX lobe (1 - cos^2 up to about alpha^2) spans 17 at this alpha and fewer below; below alpha = 2^-63,
# alpha^2 is subnormal, then 0, and D(h) 0 / 0 (kernels/microfacet.cl). The smooth BSDF is the rough one's
# limit as alpha goes to 0. (A rough plastic keeps its own model: rough_transmittance.py.)
SMOOTH_ALPHA = 1e-3
_SMOOTH = {"roughconductor": "conductor", "roughdielectric": "dielectric"}


def instance_structs(scene, roots):
    """The Instance table (kernels/types.h): each instance's map and its inverse, rounded once each from
    float64, and its group's root node (roots, from geometry.bvh_structs; none without a BVH)."""
    a = np.zeros(max(len(scene.instances), 1), structs.INSTANCE)
    for s, inst in zip(a, scene.instances):
        m = np.asarray(inst.to_world, np.float64)
        s["center"], s["to_world"], s["to_local"] = m[:3, 3], m[:3, :3].ravel(), np.linalg.inv(m[:3, :3]).ravel()
        s["root"] = roots[inst.group] if roots else 0
    return a


def emitter_tables(scene, triangles):
    """The Emitter and EmitterTriangle tables (kernels/types.h) of the scene's emitting shapes (ShapeEmitter),
    given the packed Triangle records in the kernel's order: an emitter's shape is the one with its material, its
    own; a mesh's triangles are chosen by their areas, in float64 of the float32 corners the kernel meets."""
    emitters = np.zeros(max(len(scene.emitters), 1), structs.EMITTER)
    emitters["lookup"] = -1
    chosen = [np.zeros(1, structs.EMITTER_TRIANGLE)]
    lookups = emitter_lookups(scene)[0]
    mesh = triangles["material"][:scene.triangle_count]
    # each emitter's shape by its material, its own (one pass over each table, not one per emitter)
    holder = {kind: {} for kind in ("rectangles", "ellipsoids", "disks", "cylinders")}
    for kind, found in holder.items():
        for i, shape in enumerate(getattr(scene, kind)):
            found.setdefault(shape.material, i)
    by_material = np.argsort(mesh, kind="stable")  # a mesh emitter's triangles, in their order
    own = [getattr(e, "material", -1) for e in scene.emitters]  # (a delta light has none)
    bounds = np.searchsorted(mesh[by_material], own, side="left")
    ends = np.searchsorted(mesh[by_material], own, side="right")
    start = 0
    for k, (s, e) in enumerate(zip(emitters, scene.emitters)):
        if not isinstance(e, ShapeEmitter):
            delta_struct(s, e, lookups.get(k, -1))
            continue
        s["radiance"], s["reflects"], s["count"] = e.radiance, e.reflects, 1
        rectangles, spheres, disks, cylinders = ([holder[kind][e.material]] if e.material in holder[kind] else []
                                                 for kind in ("rectangles", "ellipsoids", "disks", "cylinders"))
        if disks:  # pi |dp/dx x dp/dy|, the unit disk's area under its map (its normal is the same everywhere)
            linear = scene.disks[disks[0]].matrix[:3, :3]
            s["kind"], s["index"] = structs.SHAPES["disk"], disks[0]
            s["area"] = math.pi * np.linalg.norm(np.cross(linear[:, 0], linear[:, 1]))
        elif cylinders:  # its area by the mean of |dp/dphi x dp/dz| over phi (emitters.cl samples by the point's own)
            linear = scene.cylinders[cylinders[0]].matrix[:3, :3]
            phi = np.linspace(0, 2 * math.pi, 256, endpoint=False)
            dphi = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)]) @ linear.T
            s["kind"], s["index"] = structs.SHAPES["cylinder"], cylinders[0]
            s["area"] = 2 * math.pi * np.mean(np.linalg.norm(np.cross(dphi, linear[:, 2]), axis=1))
        elif rectangles:
            s["kind"], s["index"] = structs.SHAPES["rectangle"], rectangles[0]
            s["area"] = np.prod(scene.rectangles[rectangles[0]].size)
        elif spheres:  # rules.py: a sphere; its squared radius the mean of its axes' (emitters.cl)
            s["kind"], s["index"] = structs.SHAPES["ellipsoid"], spheres[0]
            s["area"] = 4 * math.pi * np.mean(np.sum(scene.ellipsoids[spheres[0]].axes ** 2, 1))
        else:
            index = by_material[bounds[k]:ends[k]]
            v = np.stack([triangles[k][index].astype(np.float64) for k in ("v0", "v1", "v2")], 1)
            areas = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1) / 2
            table = np.zeros(len(index), structs.EMITTER_TRIANGLE)
            table["triangle"], table["cdf"] = index, np.cumsum(areas) / areas.sum()
            table["cdf"][-1] = 1.0
            s["kind"], s["index"], s["count"], s["area"] = structs.SHAPES["triangle"], start, len(index), areas.sum()
            chosen.append(table)
            start += len(index)
    triangles = np.concatenate(chosen[1:]) if len(chosen) > 1 else chosen[0]
    if scene.emitters:
        pdf, cdf = selection(scene, emitters)
        emitters["selection_pdf"], emitters["selection_cdf"] = pdf, cdf
    return emitters, triangles


def selection(scene, emitters):
    """Each emitter's probability of being a light sample's (render.light_selection; kernels/light_selection.cl)
    and the float32 cumulative probabilities the kernel chooses by: weights by power (pbrt-v4's
    PowerLightSampler, section 12.6.2), the luminance of each one's RGB power, an area emitter's pi A L (A the
    area packed for the kernel), a delta light's emitter_power.py's; or uniform, and uniform too where no
    emitter has power. The last cumulative value is 1 exactly, so that every u < 1 finds an emitter."""
    weights = np.ones(len(scene.emitters))
    if scene.light_selection == "power":
        power = np.array([math.pi * float(s["area"]) * texture_lookups.luminance(e.radiance) if isinstance(e, ShapeEmitter)
                          else emitter_power(scene, e) for s, e in zip(emitters, scene.emitters)])
        if power.sum() > 0:
            weights = power
    cdf = np.cumsum(weights / weights.sum()).astype(np.float32)
    cdf[-1] = 1.0
    # the kernel chooses by the float32 cumulative values: each probability is the width it gives its emitter
    # there (an emitter of a share below their rounding then has none, and the MIS weights it none either)
    return np.diff(cdf.astype(np.float64), prepend=0.0), cdf


def emitter_lookups(scene):
    """({emitter index: its TextureLookup's index in the kernel's table}, [those lookups]): the delta lights'
    images (a spot's texture, a projector's irradiance) follow the materials' lookups (lookup_structs)."""
    first = sum(len(m.maps) for m in material_table(kernel_materials(scene)))
    indices, lookups = {}, []
    for k, e in enumerate(scene.emitters):
        if getattr(e, "texture", None) is not None:
            indices[k] = first + len(lookups)
            lookups.append(e.texture)
    return indices, lookups


def delta_struct(s, e, lookup):
    """Fill Emitter record s with delta light e (model.PointEmitter, ...; kernels/emitters.cl's sample_delta), its
    image the TextureLookup of index `lookup` (-1: none)."""
    kind = type(e).__name__.removesuffix("Emitter").lower()
    s["kind"], s["count"], s["radiance"], s["lookup"] = structs.EMITTER_KINDS[kind], 1, e.radiance, lookup
    if kind == "point":
        s["position"] = e.position
    elif kind == "directional":
        s["axis"] = np.asarray(e.direction, np.float64) / np.linalg.norm(e.direction)
    else:
        m = np.asarray(e.to_world, np.float64)
        s["position"], s["axis"], s["to_local"] = m[:3, 3], m[:3, 2], np.linalg.inv(m[:3, :3]).ravel()
    if kind == "spot":  # Mitsuba's update(): the angles in radians, (u, v) = 1/2 + (x, y) / (2 z tan(cutoff))
        cutoff, beam = math.radians(e.cutoff_angle), math.radians(e.beam)
        s["cos_cutoff"], s["cos_beam"], s["cutoff"] = math.cos(cutoff), math.cos(beam), cutoff
        s["inv_transition"] = 1 / (cutoff - beam) if cutoff > beam else 0.0  # (beam = cutoff: no ramp)
        s["uv_scale"] = 1 / math.tan(cutoff)
    elif kind == "projector":  # Mitsuba's perspective_projection: u = 1/2 - x / (2 z tan(fov / 2)), v likewise
        # by aspect / tan(fov / 2), both turned (its image's u runs along the camera's -x: lookat's left)
        tan_half = math.tan(math.radians(e.fov) / 2)
        s["uv_scale"] = (-1 / tan_half, -e.aspect / tan_half)


def packed_bsdf(material):
    """The BSDF the kernel renders `material` with: its own, but a rough conductor's or dielectric's of alpha
    (and alpha_v) below SMOOTH_ALPHA that of the smooth one."""
    alpha = max(material.alpha, material.alpha if material.alpha_v is None else material.alpha_v)
    if material.bsdf in _SMOOTH and alpha < SMOOTH_ALPHA:
        return _SMOOTH[material.bsdf]
    return material.bsdf


def material_table(materials):
    """The kernel's material table of the model's materials: each one in its place, then one `null` material where
    any is a `mask` (kernels/wrappers.cl resolves a mask as a blend of null and the masked material)."""
    masks = any(m.bsdf == "mask" for m in materials)
    return list(materials) + [Material("null", np.zeros(3), bsdf="null")] * masks


def lookup_structs(materials, triangles=0, extra=()):
    """(the TextureLookup table, each material's maps) of the materials' textured parameters, then the `extra`
    lookups (emitter_lookups'): one lookup per parameter, a float parameter's reading its lookup's luminance.
    to_uv becomes the kernel's, whose t runs down the image: t' = 1 - t. A mesh attribute's lookup starts at its
    block of `triangles` entries in the attribute table (attribute_table)."""
    table, maps, names = [], [], texture_lookups.attribute_names(materials)
    for m in materials:
        slots = np.full(structs.MAPS, -1, np.int32)
        for slot, lookup in m.maps:
            a, b, c, d, e, f = lookup.to_uv
            first = names.index(lookup.attribute) * triangles if lookup.kind == "mesh_attribute" else 0
            table.append((structs.LOOKUPS[lookup.kind], lookup.texture, structs.WRAP_MODES[lookup.wrap],
                          -1 if lookup.filter is None else structs.FILTERS[lookup.filter],
                          slot in texture_lookups.FLOAT_SLOTS, (a, b, c, -d, -e, 1.0 - f), lookup.colour0,
                          lookup.colour1, first, lookup.scale))
            slots[structs.MAP_SLOTS[slot]] = len(table) - 1
        maps.append(slots)
    for lookup in extra:
        a, b, c, d, e, f = lookup.to_uv
        table.append((structs.LOOKUPS[lookup.kind], lookup.texture, structs.WRAP_MODES[lookup.wrap],
                       -1 if lookup.filter is None else structs.FILTERS[lookup.filter], False,
                       (a, b, c, -d, -e, 1.0 - f), lookup.colour0, lookup.colour1, 0, lookup.scale))
    return np.array(table or [(0, 0, 0, 0, 0, (0.0,) * 6, (0.0,) * 3, (0.0,) * 3, 0, 1.0)],
                    structs.TEXTURE_LOOKUP), maps


def attribute_table(attributes):
    """The TriangleAttribute table of a triangle soup's attributes ({name: (F, 3, 3)}, geometry.TriangleSoup's, in
    the kernel's order of triangles), a block of F entries per attribute in attribute_names' order."""
    if not attributes:
        return np.zeros(1, structs.TRIANGLE_ATTRIBUTE)
    values = np.concatenate(list(attributes.values())).reshape(-1, 9)
    table = np.zeros(len(values), structs.TRIANGLE_ATTRIBUTE)
    table.view(np.float32).reshape(-1, 9)[:] = values
    return table


def material_structs(materials):
    materials = material_table(materials)
    a = np.zeros(len(materials), structs.MATERIAL)
    null = len(materials) - 1
    for i, (s, m, maps) in enumerate(zip(a, materials, lookup_structs(materials)[1])):
        s["maps"], s["bump_scale"], s["mirrored_maps"] = maps, m.bump_scale, m.mirrored_maps
        s["emitter"] = m.emitter
        s["back"] = m.back if m.back >= 0 else i if m.two_sided else -1
        if m.bsdf in WRAPPERS:
            s["bsdf"], s["weight"] = structs.BSDF_BLEND, m.weight
            s["blend"] = m.blend if m.bsdf == "blendbsdf" else (null, m.blend[0])
            continue
        s["colour"], s["shininess"] = m.colour, m.shininess
        s["colour_map"], s["normal_map"], s["height_map"] = m.colour_map, m.normal_map, m.height_map
        s["wrap"], s["height_scale"] = structs.WRAP_MODES[m.wrap], m.height_scale
        s["uv_scale"], s["uv_offset"] = m.uv_scale, m.uv_offset
        s["bsdf"] = structs.BSDFS[packed_bsdf(m)]
        s["eta"], s["k"] = (m.int_ior / m.ext_ior, 0.0, 0.0) if m.bsdf in bsdfs.INDEXED else m.eta, m.k
        s["alpha"] = m.alpha
        s["alpha_v"] = m.alpha if m.alpha_v is None else m.alpha_v
        s["distribution"] = structs.MICROFACETS[m.distribution]
        s["specular"], s["nonlinear"] = m.specular, m.nonlinear
        if m.bsdf in ("plastic", "roughplastic"):
            s["internal_reflectance"], s["specular_weight"] = plastic_terms.coat(m)
        if m.bsdf == "roughplastic":
            s["transmittance"] = rough_transmittance.table(m)
        if m.bsdf in ("principled", "principledthin"):  # its eta, its main lobe's alphas, its values
            s["eta"], s["distribution"] = (principled_terms.eta(m), 0.0, 0.0), structs.MICROFACETS["ggx"]
            (s["alpha"], s["alpha_v"]), s["principled"] = principled_terms.alphas(m), principled_terms.parameters(m)
    return a


def pack_textures(textures, source="scene"):
    """(texels: uint32 words, MipLevel table, Texture table) for a list of raytrace.textures.Texture.
    Words per texel as structs.TEXEL_WORDS gives them: 8-bit levels one (RGBA, r in the low byte), 16-bit
    height quads two, float levels four, 16-byte aligned."""
    chunks, level_table, texture_table, offset = [], [], [], 0
    for texture in textures:
        texture_table.append((len(level_table), len(texture.levels), texture.encoding))
        for level in texture.levels:
            words = np.ascontiguousarray(level).view("<u4").ravel()
            if texture.encoding in structs.FLOAT_TEXELS and offset % 4:
                chunks.append(np.zeros(4 - offset % 4, np.uint32))
                offset += 4 - offset % 4
            level_table.append((offset, level.shape[1], level.shape[0]))
            chunks.append(words)
            offset += words.size
    if offset > MAX_WORDS:
        raise InputError(source, "textures", f"{offset * 4} bytes", "more texture memory than one buffer can hold")
    texels = np.concatenate(chunks) if chunks else np.zeros(1, np.uint32)
    levels = np.array(level_table or [(0, 1, 1)], dtype=structs.MIP_LEVEL)
    table = np.array(texture_table or [(0, 0, 0)], dtype=structs.TEXTURE)
    return texels, levels, table


def texture_tables(scene):
    """The tables of all the scene's textures, named after kernels/scene.h's TEXTURE_PARAMETERS."""
    texels, levels, textures = pack_textures(scene.textures, scene.path)
    return {"textures": textures, "mip_levels": levels, "texels": texels,
            "srgb_to_linear": mipmap.SRGB8_TO_LINEAR.astype(np.float32),
            "lookups": lookup_structs(material_table(kernel_materials(scene)), scene.triangle_count,
                                      emitter_lookups(scene)[1])[0]}


def params_struct(scene, spp=1, light_samples=1, width=1, height=1, texture_filter="trilinear",
                  pixel_pattern=None, light_pattern=None, seed=0):
    """RenderParams; the patterns default to one centre sample (raytrace.samplers.Pattern)."""
    p = np.zeros((), structs.RENDER_PARAMS)
    p["ambient"] = scene.ambient
    p["n_rectangles"], p["n_triangles"] = len(scene.rectangles), scene.triangle_count
    p["n_ellipsoids"], p["n_lights"] = len(scene.ellipsoids), len(scene.lights)
    p["n_emitters"] = len(scene.emitters)
    p["n_instances"] = len(scene.instances)
    p["n_disks"], p["n_cylinders"] = len(scene.disks), len(scene.cylinders)
    center = samplers.pattern("center", 1)
    p["pixel_sampler"] = (pixel_pattern or center).sampler_struct()
    p["light_sampler"] = (light_pattern or center).sampler_struct()
    p["seed"] = seed % 2**32
    p["light_samples"], p["width"], p["height"] = light_samples, width, height
    p["max_depth"] = scene.max_depth
    p["rr_depth"], p["hide_emitters"], p["bsdf_samples"] = scene.rr_depth, scene.hide_emitters, scene.bsdf_samples
    p["environment"] = np.zeros(3) if scene.environment is None else scene.environment
    if scene.environment_map is not None:
        m = scene.environment_map
        p["environment"] = np.full(3, m.scale)
        p["environment_height"], p["environment_width"] = m.texels.shape[:2]
        p["environment_x"], p["environment_y"], p["environment_z"] = m.frame()
    p["texture_filter"] = structs.FILTERS[texture_filter]
    # Ray differentials span one sample spacing, but at least 1/8 pixel, as pbrt-v4's RayIntegrator does.
    p["footprint_scale"] = max(0.125, 1 / math.sqrt(spp))
    return p


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB primaries' Y, Mitsuba's luminance()


def environment_weights(texels):
    """The sampling weight of each of the map's w x (h - 1) cells (float64, (h - 1) x w; kernels/environment.cl):
    the luminance the bilinear radiance has on average over the cell, its two rows' mean in v, and in u its
    column weighing 3/4 and the neighbours on either side 1/8 (wrapping), so that every cell where the
    interpolated radiance is anywhere positive has a positive weight; times sin(theta) at its centre."""
    y = np.asarray(texels, np.float64) @ LUMINANCE
    y = 0.125 * np.roll(y, 1, axis=1) + 0.75 * y + 0.125 * np.roll(y, -1, axis=1)
    y = 0.5 * (y[:-1] + y[1:])
    cells = y.shape[0]
    return y * np.sin(np.pi * (np.arange(cells) + 0.5) / cells)[:, None]


def _cdf(weights):
    """Cumulative tables along the last axis, from 0 to exactly 1 (float32); a row of zero weight uniform."""
    total = weights.sum(axis=-1, keepdims=True)
    n = weights.shape[-1]
    step = np.where(total > 0, weights / np.where(total > 0, total, 1.0), 1.0 / n)
    cdf = np.concatenate([np.zeros(weights.shape[:-1] + (1,)), np.cumsum(step, axis=-1)], axis=-1)
    cdf[..., -1] = 1.0
    return cdf.astype(np.float32)


def environment_table(scene):
    """kernels/environment.cl's environment_map buffer: the texels' RGB, the marginal cumulative table over the
    rows of cells and each row's conditional one (float32), or one dummy float without a map."""
    if scene.environment_map is None:
        return np.zeros(1, np.float32)
    texels = scene.environment_map.texels
    weights = environment_weights(texels)
    marginal, conditional = _cdf(weights.sum(axis=1)), _cdf(weights)
    return np.concatenate([np.asarray(texels, np.float32).ravel(), marginal, conditional.ravel()])
