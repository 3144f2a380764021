"""raytrace's scenes written as Mitsuba 3 XML (`python -m raytrace convert scene.toml -o scene.xml`): the reverse of
mitsuba_xml.py and mitsuba.py, whose PLUGINS table this follows plugin for plugin, so that the reader gives the
written scene's model back. Mitsuba 3's plugin reference is the specification of the names and the defaults.

What the XML holds: the integrator of the shading model (`path` with max_depth and rr_depth, `direct` with
emitter_samples and bsdf_samples; hide_emitters);
a `perspective` sensor (fov_axis y: raytrace's fov is vertical) with an `hdrfilm` of box filter and the sampler
nearest the pixel pattern; each material something uses, as a `bsdf` with the material's name as its id and
its parameters by Mitsuba's names (raytrace/scene/bsdfs.py; a two-sided material Mitsuba scatters from the
front only inside `twosided`, a one-sided one bare; glass unwrapped, its sides being its inside and outside;
the rough ones' distribution always written, Mitsuba's default being Beckmann and raytrace's GGX); each light
a `rectangle` with an `area` emitter and a BSDF (its material, or a black diffuse: a raytrace light reflects
nothing, and Mitsuba's default BSDF would be a grey diffuse); the shapes (disks and cylinders as Mitsuba's,
under their to_world), each emitting one with its `area` emitter and a BSDF as a light's: the material it
copies (the shape's own is that material with its emitter named), or the black diffuse; the environment; the
delta lights (point, spot, directional, projector) by Mitsuba's parameters, their images as bitmap or
checkerboard textures.
Every number is written by repr(), which Python and Mitsuba's parser read back to the same float64.

Meshes raytrace holds itself (triangles and meshes written in the scene file, generated meshes, and a mesh
file under a mirroring transform: Mitsuba keeps a mirrored mesh's corner order, raytrace reverses it) are
returned as binary little-endian PLY files in world space (float32 positions, the kernel's own rounding of
them, and normals where the mesh is smooth; int32 faces), for the caller to write beside the XML. A mesh file
otherwise stays where it is, named relative to the XML's folder, under its transform.

What has no Mitsuba 3 equivalent is refused with one InputError naming the scene file and the key: the Phong
model, a material with texture maps (not written yet), an ellipsoid other than a sphere, an emitter that no
shape of the model carries (the XML has nowhere to put it). What Mitsuba
approximates (a sampler it lacks, light samples its path tracer does not take) is said in a comment beside it.
"""
import dataclasses
import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .. import aovs as aov_types
from ..errors import InputError
from . import bsdfs
from .model import RR_DEPTH, WRAPPERS, PointEmitter, ProjectorEmitter, ShapeEmitter, SpotEmitter, fingerprint
from .mitsuba import FAR_CLIP, NEAR_CLIP, RFILTER_PARAMETERS, view_depths
from .transform import mesh_matrix

# raytrace's pixel patterns and the Mitsuba sampler written for each (mitsuba.py's SAMPLER_PATTERNS reads them
# back): random is independent, the jittered grid is stratified, the low-discrepancy sequences are ldsampler
# (Mitsuba has no Halton sequence), and the course's fixed patterns, which no Mitsuba sampler has, the stratified
# sampler with the same number of samples.
SAMPLERS = {"random": "independent", "jittered": "stratified", "sobol": "ldsampler", "halton": "ldsampler",
            "grid": "stratified", "rotated-grid-cw": "stratified", "rotated-grid-ccw": "stratified",
            "center": "stratified"}
# An ellipsoid is written as a sphere where its axes' Gram matrix is radius^2 times the identity within this
# fraction of radius^2: lengths and right angles within about 5e-7, a few float32 ulps (the kernel's resolution).
SPHERE_TOLERANCE = 1e-6
ID = re.compile(r"[A-Za-z][A-Za-z0-9_.-]*\Z")  # material names written as ids as they are; others renamed


def to_xml(scene, out_path):
    """(the Mitsuba 3 XML text of raytrace Scene `scene`, {file name: bytes} of the mesh files it names) for XML
    to be written at `out_path`: the files' names, and every file the XML names, are relative to its folder.
    Raises InputError (the scene file, the key, the value) for what Mitsuba 3 has no equivalent of."""
    return _Writer(scene, Path(out_path)).write()


def _number(x):
    return repr(float(x))


def _numbers(values):
    return ", ".join(_number(x) for x in np.ravel(values))


def _matrix(m):
    return " ".join(_number(x) for x in np.ravel(m))


def _comment(text):
    """An XML comment's text: no "--" (XML forbids it in a comment) and no control characters."""
    text = "".join(c if c.isprintable() else " " for c in text)
    while "--" in text:
        text = text.replace("--", "- -")
    return ET.Comment(f" {text} ")


def _escaped(text):
    """A string attribute as Mitsuba's parser reads it back: $ starts a parameter there, \\$ is a dollar sign."""
    return text.replace("$", "\\$")


def ply_bytes(vertices, faces, normals=None, comment="raytrace"):
    """A binary little-endian PLY file of a triangle mesh: float32 positions (and normals), int32 faces."""
    comment = "".join(c for c in comment if c.isprintable() and c.isascii())
    header = ["ply", "format binary_little_endian 1.0", f"comment {comment}", f"element vertex {len(vertices)}",
              "property float x", "property float y", "property float z"]
    columns = [np.asarray(vertices, np.float64)]
    if normals is not None:
        header += ["property float nx", "property float ny", "property float nz"]
        columns.append(np.asarray(normals, np.float64))
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    face_records = np.zeros(len(faces), [("n", "u1"), ("i", "<i4", (3,))])
    face_records["n"], face_records["i"] = 3, faces
    return (("\n".join(header) + "\n").encode("ascii") + np.hstack(columns).astype("<f4").tobytes()
            + face_records.tobytes())


class _Writer:
    def __init__(self, scene, out_path):
        self.scene, self.out_path = scene, out_path
        self.folder = out_path.parent
        self.extra = {}
        self.ids = {}        # material index -> its bsdf's id
        self.black = None    # the id of the black BSDF of lights without a material
        # the files the XML may name: a PLY file written beside it must not take one's name
        self.referenced = {os.path.abspath(m.source) for m in scene.meshes if m.source}
        if scene.environment_map is not None:
            self.referenced.add(os.path.abspath(scene.environment_map.path))

    def fail(self, key, value, problem):
        raise InputError(self.scene.path, key, value, problem)

    # -- the whole scene
    def write(self):
        scene = self.scene
        if scene.shading not in ("direct", "path"):
            self.fail("render.shading", scene.shading, "the course's Phong model has no Mitsuba 3 equivalent "
                      "(Mitsuba renders radiometric models: write the scene with shading = \"direct\" or \"path\")")
        shapes = self.shapes()
        self.check_emitters(shapes)
        used = sorted(({self.written(o.material) for _, _, objects, _ in shapes for o in objects}
                       | {light.material for light in scene.lights if light.material >= 0}
                       | {m.material for g in scene.groups for m in g.meshes}) - {-1})
        for index in used:
            self.check_material(index)
        for key, kind, objects, _ in shapes:
            if kind == "ellipsoid":
                self.sphere(key, objects[0])  # refuses one that is not a sphere before anything is written
        root = ET.Element("scene", version="3.0.0")
        root.append(_comment(f"{scene.path}, written by raytrace as Mitsuba 3 XML"))
        self.integrator(root)
        self.sensor(root)
        for index in used:
            self.material(root, index)
        if any(light.material < 0 for light in scene.lights) or not all(e.reflects for e in scene.emitters
                                                                         if isinstance(e, ShapeEmitter)):
            self.black = self.unique_id("black")
            root.append(_comment("a light or an emitting shape without a material reflects nothing in raytrace"))
            twosided = ET.SubElement(root, "bsdf", type="twosided", id=self.black)
            ET.SubElement(ET.SubElement(twosided, "bsdf", type="diffuse"), "rgb", name="reflectance",
                          value=_numbers([0.0, 0.0, 0.0]))
        self.environment(root)
        self.delta_lights(root)
        for i, light in enumerate(scene.lights):
            self.light(root, i, light)
        for key, kind, objects, table in shapes:
            self.shape(root, key, kind, objects, table)
        self.instances(root)
        ET.indent(root, space="    ")
        return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n", self.extra

    def integrator(self, root):
        scene = self.scene
        if scene.aovs:  # Mitsuba's aov integrator around the one that renders the image (named: its channels)
            root = ET.SubElement(root, "integrator", type="aov")
            ET.SubElement(root, "string", name="aovs", value=aov_types.to_string(scene.aovs))
        name = {"name": "image"} if scene.aovs else {}
        if scene.shading == "path":
            integrator = ET.SubElement(root, "integrator", type="path", **name)
            ET.SubElement(integrator, "integer", name="max_depth", value=str(int(scene.max_depth)))
            if scene.rr_depth != RR_DEPTH:
                ET.SubElement(integrator, "integer", name="rr_depth", value=str(int(scene.rr_depth)))
            if scene.light_samples != 1:
                integrator.append(_comment(f"raytrace's light_samples = {scene.light_samples}: Mitsuba's path "
                                           "tracer takes one emitter sample per vertex (the same estimate, noisier)"))
        else:
            integrator = ET.SubElement(root, "integrator", type="direct", **name)
            ET.SubElement(integrator, "integer", name="emitter_samples", value=str(int(scene.light_samples)))
            # always written: Mitsuba's default is 1, raytrace's 0 (the light samples alone)
            ET.SubElement(integrator, "integer", name="bsdf_samples", value=str(int(scene.bsdf_samples)))
        if scene.hide_emitters:
            ET.SubElement(integrator, "boolean", name="hide_emitters", value="true")

    def sensor(self, root):
        scene, camera = self.scene, self.scene.camera
        sensor = ET.SubElement(root, "sensor", type=camera.kind)
        if camera.kind != "orthographic":
            ET.SubElement(sensor, "string", name="fov_axis", value="y")
            ET.SubElement(sensor, "float", name="fov", value=_number(camera.fov_deg))
        near, far = self.clip()
        near = camera.near_clip or camera.dropped_near_clip or near
        far = camera.far_clip if camera.far_clip < math.inf else far
        if near != NEAR_CLIP:
            ET.SubElement(sensor, "float", name="near_clip", value=_number(near))
        if far != FAR_CLIP:
            ET.SubElement(sensor, "float", name="far_clip", value=_number(far))
        if camera.kind == "thinlens":
            ET.SubElement(sensor, "float", name="aperture_radius", value=_number(camera.aperture_radius))
            ET.SubElement(sensor, "float", name="focus_distance", value=_number(camera.focus_distance))
        transform = ET.SubElement(sensor, "transform", name="to_world")
        if camera.kind == "orthographic":  # Mitsuba's view spans [-sx, sx] x [-sy, sy] height / width
            ET.SubElement(transform, "scale", x=_number(camera.size[0] / 2),
                          y=_number(camera.size[1] / 2 * scene.width / scene.height))
        ET.SubElement(transform, "lookat", origin=_numbers(camera.position), target=_numbers(camera.look_at),
                      up=_numbers(camera.ref_up))
        kind = SAMPLERS[scene.sampler]
        if kind == "ldsampler" and scene.spp & (scene.spp - 1):
            sensor.append(_comment(f"Mitsuba's ldsampler rounds its sample_count up to a power of two: "
                                   f"{1 << (scene.spp - 1).bit_length()} for raytrace's spp = {scene.spp}"))
        if kind == "stratified" and math.isqrt(scene.spp) ** 2 != scene.spp:
            sensor.append(_comment(f"Mitsuba's stratified sampler rounds its sample_count up to a square: "
                                   f"{(math.isqrt(scene.spp - 1) + 1) ** 2} for raytrace's spp = {scene.spp}"))
        if scene.sampler not in ("random", "jittered", "sobol"):
            sensor.append(_comment(f"raytrace's {scene.sampler} sampler has no Mitsuba equivalent: {kind} in "
                                   "its place"))
        sampler = ET.SubElement(sensor, "sampler", type=kind)
        ET.SubElement(sampler, "integer", name="sample_count", value=str(int(scene.spp)))
        ET.SubElement(sampler, "integer", name="seed", value=str(int(scene.seed)))
        film = ET.SubElement(sensor, "film", type="hdrfilm")
        ET.SubElement(film, "integer", name="width", value=str(int(scene.width)))
        ET.SubElement(film, "integer", name="height", value=str(int(scene.height)))
        ET.SubElement(film, "string", name="pixel_format", value="rgb")
        for key in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
            if getattr(scene, key):
                ET.SubElement(film, "integer", name=key, value=str(int(getattr(scene, key))))
        if scene.sample_border:
            ET.SubElement(film, "boolean", name="sample_border", value="true")
        rfilter = ET.SubElement(film, "rfilter", type=scene.rfilter)
        for param, key, integer in RFILTER_PARAMETERS.get(scene.rfilter, ()):
            value = getattr(scene, key)
            ET.SubElement(rfilter, "integer" if integer else "float", name=param,
                          value=str(int(value)) if integer else _number(value))

    def clip(self):
        """Mitsuba's near and far clip planes for a camera without them (raytrace's default), moved from its
        defaults where those would cut the scene: near below the nearest point in front of the eye, far beyond
        the farthest."""
        depths = view_depths(self.scene)
        front = depths[depths > 0]
        near = NEAR_CLIP if not len(front) or front.min() >= NEAR_CLIP else float(front.min()) / 2
        far = FAR_CLIP if not len(depths) or depths.max() <= FAR_CLIP else 2 * float(depths.max())
        return near, far

    # -- emitting shapes
    def check_emitters(self, shapes):
        """Every emitter on a shape is written with its shape: refuse one no shape listed carries (a model built
        in Python), which the XML would drop."""
        carried = {self.scene.materials[o.material].emitter for _, _, objects, _ in shapes for o in objects}
        for i, emitter in enumerate(self.scene.emitters):
            if i not in carried and isinstance(emitter, ShapeEmitter):
                self.fail(f"emitters[{i}]", emitter.radiance.tolist(), "no shape carries this emitter (its "
                          f"material, materials[{emitter.material}], is no shape's): the XML would drop its light")

    def written(self, index):
        """The material whose BSDF is written for a shape of material `index`: itself; for an emitting shape the
        material its own copies (the same but its emitter; itself where the scene has none such), or -1 (the
        black BSDF) where it reflects nothing."""
        material = self.scene.materials[index]
        if material.emitter < 0:
            return index
        if not self.scene.emitters[material.emitter].reflects:
            return -1
        copied = fingerprint(dataclasses.replace(material, emitter=-1))
        return next((i for i, m in enumerate(self.scene.materials) if m.emitter < 0 and fingerprint(m) == copied),
                    index)

    def emitter(self, shape, index):
        """Shape element `shape`'s emitter, if its material (`index`) is an emitting shape's: an area emitter of
        its radiance (emitted from the front, as raytrace's)."""
        material = self.scene.materials[index]
        if material.emitter >= 0:
            emitter = ET.SubElement(shape, "emitter", type="area")
            ET.SubElement(emitter, "rgb", name="radiance",
                          value=_numbers(self.scene.emitters[material.emitter].radiance))

    # -- materials
    def check_material(self, index):
        material = self.scene.materials[index]
        for field, key in (("colour_map", "texture"), ("normal_map", "normal_map"), ("height_map", "height_map")):
            if getattr(material, field) >= 0:
                table = ((self.scene.source or {}).get("materials") or {}).get(material.name) or {}
                self.fail(f"materials.{material.name}.{key}", table.get(key, getattr(material, field)),
                          "a material's texture maps are not written as Mitsuba 3 XML yet")
        table = ((self.scene.source or {}).get("materials") or {}).get(material.name) or {}
        textured = next((k for k, v in table.items() if isinstance(v, dict)), "maps")
        for given, key, value in ((material.bsdf in WRAPPERS, "type", material.bsdf),
                                  (material.maps, textured, table.get(textured, "a texture")),
                                  (material.back >= 0, "back", table.get("back", material.back))):
            if given:
                self.fail(f"materials.{material.name}.{key}", value, "blends, masks, textured parameters and back "
                          "sides are not written as Mitsuba 3 XML yet")

    def unique_id(self, name):
        taken = set(self.ids.values()) | {self.black}
        while name in taken:
            name += "_"
        return name

    def material(self, root, index):
        material = self.scene.materials[index]
        name = material.name
        self.ids[index] = self.unique_id(name if ID.match(name) else f"material{index}")
        if self.ids[index] != name:
            root.append(_comment(f"material {name!r}"))
        declared = bsdfs.BY_NAME[material.bsdf]
        opaque = material.bsdf == "principled" and material.spec_trans == 0  # Mitsuba's twosided takes it
        if (declared.front_only or opaque) and material.two_sided:  # Mitsuba's are black from behind
            bsdf = ET.SubElement(ET.SubElement(root, "bsdf", type="twosided", id=self.ids[index]), "bsdf",
                                 type=material.bsdf)
        else:
            bsdf = ET.SubElement(root, "bsdf", type=material.bsdf, id=self.ids[index])
        for p in declared.parameters:
            if p.fields == ("eta",):
                self.conductor(bsdf, material)
            elif p.fields == ("colour",) or p.fields == ("specular",):
                ET.SubElement(bsdf, "rgb", name=p.name, value=_numbers(getattr(material, p.fields[0])))
            elif p.name in ("int_ior", "ext_ior") or (p.name == "alpha" and material.alpha_v is None):
                ET.SubElement(bsdf, "float", name=p.name, value=_number(getattr(material, p.name)))
            elif p.name in ("alpha_u", "alpha_v") and material.alpha_v is not None:
                ET.SubElement(bsdf, "float", name=p.name, value=_number(getattr(material, p.fields[0])))
            elif p.name == "distribution":  # always written: Mitsuba's default is Beckmann, raytrace's GGX
                ET.SubElement(bsdf, "string", name=p.name, value=material.distribution)
            elif material.bsdf in ("principled", "principledthin") and p.key is not None and p.key.kind == "number":
                if getattr(material, p.fields[0]) is not None:  # eta or specular: the one given
                    ET.SubElement(bsdf, "float", name=p.name, value=_number(getattr(material, p.fields[0])))
            elif p.name == "nonlinear":
                ET.SubElement(bsdf, "boolean", name=p.name, value=str(bool(material.nonlinear)).lower())

    def conductor(self, bsdf, material):
        """A conductor's eta and k, as rgb values: none where both are 0 (Mitsuba's default, material none, the
        perfect mirror)."""
        eta, k = np.array(material.eta, np.float64), np.array(material.k, np.float64)
        mirror = (eta == 0) & (k == 0)
        if not mirror.all():
            if mirror.any():
                bsdf.append(_comment("eta = k = 0, raytrace's perfect mirror, is eta 0, k 1 in Mitsuba (the same "
                                     "reflectance of 1, without 0 / 0 at normal incidence)"))
                k[mirror] = 1.0
            ET.SubElement(bsdf, "rgb", name="eta", value=_numbers(eta))
            ET.SubElement(bsdf, "rgb", name="k", value=_numbers(k))

    def bsdf_ref(self, element, index):
        """A reference to material `index`'s BSDF (-1: the black one)."""
        ET.SubElement(element, "ref", id=_escaped(self.ids[index] if index >= 0 else self.black))

    # -- lights, shapes, the environment
    def rectangle(self, root, r, comment=None):
        """A rectangle shape: Mitsuba's [-1, 1]^2 in z = 0 (front side +z) under a matrix whose columns are the
        tangent and bitangent times the half sides, the normal and the centre."""
        if comment:
            root.append(_comment(comment))
        shape = ET.SubElement(root, "shape", type="rectangle")
        m = np.eye(4)
        m[:3, 0], m[:3, 1] = r.tangent * (r.size[0] / 2), r.bitangent * (r.size[1] / 2)
        m[:3, 2], m[:3, 3] = r.normal, r.center
        ET.SubElement(ET.SubElement(shape, "transform", name="to_world"), "matrix", value=_matrix(m))
        return shape

    def light(self, root, i, light):
        shape = self.rectangle(root, light, f"lights[{i}]")
        emitter = ET.SubElement(shape, "emitter", type="area")
        ET.SubElement(emitter, "rgb", name="radiance", value=_numbers(light.colour))
        self.bsdf_ref(shape, light.material)

    def environment(self, root):
        scene = self.scene
        if scene.environment is not None:
            emitter = ET.SubElement(root, "emitter", type="constant")
            ET.SubElement(emitter, "rgb", name="radiance", value=_numbers(scene.environment))
        if scene.environment_map is not None:
            envmap = scene.environment_map
            emitter = ET.SubElement(root, "emitter", type="envmap")
            ET.SubElement(emitter, "string", name="filename", value=self.file_name(envmap.path))
            ET.SubElement(emitter, "float", name="scale", value=_number(envmap.scale))
            m = np.eye(4)
            m[:3, 0], m[:3, 1], m[:3, 2] = envmap.frame()
            ET.SubElement(ET.SubElement(emitter, "transform", name="to_world"), "matrix", value=_matrix(m))

    def delta_lights(self, root):
        """Each delta light (delta_lights.py) as Mitsuba's emitter of its type, by its parameters."""
        for e in self.scene.emitters:
            if isinstance(e, ShapeEmitter):
                continue
            kind = type(e).__name__.removesuffix("Emitter").lower()
            emitter = ET.SubElement(root, "emitter", type=kind)
            if isinstance(e, PointEmitter):
                ET.SubElement(emitter, "point", name="position", value=_numbers(e.position))
            elif kind == "directional":
                ET.SubElement(emitter, "vector", name="direction", value=_numbers(e.direction))
            else:
                ET.SubElement(ET.SubElement(emitter, "transform", name="to_world"), "matrix", value=_matrix(e.to_world))
            if isinstance(e, ProjectorEmitter):
                ET.SubElement(emitter, "float", name="fov", value=_number(e.fov))  # Mitsuba's default axis: x
                ET.SubElement(emitter, "float", name="scale", value=_number(e.scale))
            if isinstance(e, SpotEmitter):
                ET.SubElement(emitter, "float", name="cutoff_angle", value=_number(e.cutoff_angle))
                if e.beam_width is not None:  # (else Mitsuba's default, the same)
                    ET.SubElement(emitter, "float", name="beam_width", value=_number(e.beam_width))
            colour = "intensity" if kind in ("point", "spot") else "irradiance"
            image = getattr(e, "texture", None)
            if image is not None:
                if isinstance(e, ProjectorEmitter) and not np.all(np.asarray(e.irradiance) == 1):
                    self.fail("emitters.irradiance", np.asarray(e.irradiance).tolist(), "a projector's image "
                              "times a colour has no Mitsuba 3 equivalent (its irradiance is one or the other)")
                self.light_texture(emitter, "texture" if kind == "spot" else colour, image)
            if image is None or kind == "spot":
                ET.SubElement(emitter, "rgb", name=colour, value=_numbers(getattr(e, colour)))

    def light_texture(self, emitter, name, lookup):
        """A light's image (a TextureLookup) as Mitsuba's bitmap or checkerboard: its to_uv, of a light's (u, 1 - v)
        (delta_lights.py), turned back into Mitsuba's of (u, v) (mitsuba.py's delta_light reads it so)."""
        texture = ET.SubElement(emitter, "texture", type=lookup.kind, name=name)
        a, b, c, d, e, f = lookup.to_uv
        m = np.array([[a, -b, 0.0, c + b], [-d, e, 0.0, 1.0 - f - e], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
        if lookup.kind == "bitmap":
            image = self.scene.textures[lookup.texture]
            ET.SubElement(texture, "string", name="filename", value=self.file_name(image.path))
            ET.SubElement(texture, "boolean", name="raw", value=str(image.role != "colour").lower())
            ET.SubElement(texture, "string", name="filter_type", value=lookup.filter or "bilinear")
            ET.SubElement(texture, "string", name="wrap_mode", value=lookup.wrap)
        else:
            ET.SubElement(texture, "rgb", name="color0", value=_numbers(lookup.colour0))
            ET.SubElement(texture, "rgb", name="color1", value=_numbers(lookup.colour1))
        ET.SubElement(ET.SubElement(texture, "transform", name="to_uv"), "matrix", value=_matrix(m))

    def file_name(self, path):
        """A file's name relative to the XML's folder, with forward slashes."""
        path = os.path.abspath(path)
        return _escaped(Path(os.path.relpath(path, os.path.abspath(self.folder))).as_posix())

    def instances(self, root):
        """Each group as a shapegroup of its meshes (in its own space), each instance as an instance of it under
        its to_world."""
        ids = []
        for i, group in enumerate(self.scene.groups):
            ids.append(self.unique_id(f"group_{group.name}"))
            root.append(_comment(f"groups.{group.name}"))
            element = ET.SubElement(root, "shape", type="shapegroup", id=ids[-1])
            for k, mesh in enumerate(group.meshes):
                self.shape(element, f"groups.{group.name}.shapes[{k}]", "mesh", [mesh], None)
        for inst in self.scene.instances:
            element = ET.SubElement(root, "shape", type="instance")
            ET.SubElement(element, "ref", id=ids[inst.group])
            ET.SubElement(ET.SubElement(element, "transform", name="to_world"), "matrix",
                          value=_matrix(np.asarray(inst.to_world, np.float64)))

    def shapes(self):
        """(key, kind, the model's objects, the scene table's entry or None) of each shape, in the scene file's
        order: kind rectangle, ellipsoid, disk, cylinder, triangles (one shape's, the triangles of a mesh written
        in the file), file or mesh (a generated one, or one whose table is unknown). A scene whose table does not match its
        model (one built in Python) is listed from the model, by the model's names (rectangles[0], ...)."""
        scene = self.scene
        tables = (scene.source or {}).get("shapes", [])
        counts = {"rectangles": 0, "triangles": 0, "ellipsoids": 0, "disks": 0, "cylinders": 0, "meshes": 0}
        listed, instances = [], 0
        for i, table in enumerate(tables if isinstance(tables, list) else []):
            kind = table.get("type") if isinstance(table, dict) else None
            if kind == "instance":  # written with the groups (instances())
                instances += 1
                continue
            if kind == "rectangle":
                group, n, label = "rectangles", 1, "rectangle"
            elif kind in ("ellipsoid", "disk", "cylinder"):
                group, n, label = kind + "s", 1, kind
            elif kind == "triangle":
                group, n, label = "triangles", 1, "triangles"
            elif kind == "mesh" and ("file" in table or "generate" in table):
                group, n, label = "meshes", 1, "file" if "file" in table else "mesh"
            elif kind == "mesh":
                group, n, label = "triangles", len(table.get("faces", [])), "triangles"
            else:
                break
            objects = getattr(scene, group)[counts[group]:counts[group] + n]
            counts[group] += n
            listed.append((f"shapes[{i}]", label, objects, table))
        if counts == {group: len(getattr(scene, group)) for group in counts} and len(listed) + instances == len(tables):
            return listed
        listed = [(f"rectangles[{i}]", "rectangle", [r], None) for i, r in enumerate(scene.rectangles)]
        for group in ("ellipsoids", "disks", "cylinders"):
            listed += [(f"{group}[{i}]", group[:-1], [s], None) for i, s in enumerate(getattr(scene, group))]
        for material in sorted({t.material for t in scene.triangles}):
            listed.append((f"triangles of material {material}", "triangles",
                           [t for t in scene.triangles if t.material == material], None))
        listed += [(f"meshes[{i}]", "mesh", [m], None) for i, m in enumerate(scene.meshes)]
        return listed

    def sphere(self, key, ellipsoid):
        """(centre, radius) of an ellipsoid that is a sphere; refuses one that is not."""
        axes = np.asarray(ellipsoid.axes, np.float64)
        radius = float(np.linalg.norm(axes, axis=1).mean())
        if not np.abs(axes @ axes.T - radius ** 2 * np.eye(3)).max() <= SPHERE_TOLERANCE * radius ** 2:
            self.fail(f"{key}.axes", axes.tolist(), "Mitsuba's sphere takes no non-uniform scale: only an "
                      "ellipsoid with orthogonal axes of one length (a sphere) is written")
        return ellipsoid.center, radius

    def shape(self, root, key, kind, objects, table):
        if kind == "rectangle":
            shape = self.rectangle(root, objects[0], key)
        elif kind == "ellipsoid":
            center, radius = self.sphere(key, objects[0])
            root.append(_comment(key))
            shape = ET.SubElement(root, "shape", type="sphere")
            ET.SubElement(shape, "point", name="center", **dict(zip("xyz", map(_number, center))))
            ET.SubElement(shape, "float", name="radius", value=_number(radius))
            if objects[0].flip_normals:
                ET.SubElement(shape, "boolean", name="flip_normals", value="true")
        elif kind in ("disk", "cylinder"):  # Mitsuba's own plugins, their parameters as raytrace holds them
            s = objects[0]
            root.append(_comment(key))
            shape = ET.SubElement(root, "shape", type=kind)
            if kind == "cylinder":
                for name in ("p0", "p1"):
                    ET.SubElement(shape, "point", name=name, **dict(zip("xyz", map(_number, getattr(s, name)))))
                ET.SubElement(shape, "float", name="radius", value=_number(s.radius))
            ET.SubElement(ET.SubElement(shape, "transform", name="to_world"), "matrix", value=_matrix(s.to_world))
            if s.flip_normals:
                ET.SubElement(shape, "boolean", name="flip_normals", value="true")
        elif kind == "triangles":
            corners = np.array([t.vertices for t in objects], np.float64).reshape(-1, 3)
            faces = np.arange(len(corners)).reshape(-1, 3)
            if table is not None and table.get("type") == "mesh":  # the file's shared vertices, those used
                used, faces = np.unique(np.asarray(table["faces"]).ravel(), return_inverse=True)
                vertices = np.zeros((len(used), 3))
                vertices[faces] = corners
                corners, faces = vertices, faces.reshape(-1, 3)
            shape = self.ply(root, key, corners, faces, None)
            ET.SubElement(shape, "boolean", name="face_normals", value="true")  # raytrace's triangles are flat
        else:
            mesh_shape = objects[0]
            m = self.file_matrix(table, mesh_shape) if kind == "file" else None
            if m is None:
                mesh = mesh_shape.mesh
                shape = self.ply(root, key, mesh.vertices, mesh.faces, mesh.normals if mesh_shape.smooth else None)
            else:
                filename = self.file_name(mesh_shape.source)
                root.append(_comment(key))
                shape = ET.SubElement(root, "shape", type=Path(mesh_shape.source).suffix.lower()[1:])
                ET.SubElement(shape, "string", name="filename", value=filename)
                if table.get("shape_index", 0):  # a .serialized file's shape (Mitsuba's default: 0)
                    ET.SubElement(shape, "integer", name="shape_index", value=str(table["shape_index"]))
                ET.SubElement(ET.SubElement(shape, "transform", name="to_world"), "matrix", value=_matrix(m))
            ET.SubElement(shape, "boolean", name="face_normals", value=str(not mesh_shape.smooth).lower())
        self.emitter(shape, objects[0].material)
        self.bsdf_ref(shape, self.written(objects[0].material))

    def file_matrix(self, table, mesh_shape):
        """The to_world of a mesh file as scene_file.py's _transform makes it: the table's matrix, or its scale,
        then rotate, then translate; None where raytrace mirrors the mesh (then it is written as a PLY file in
        world space, its faces in raytrace's order) or the table does not name the model's file."""
        if Path(self.scene.path).parent / table["file"] != Path(mesh_shape.source):
            return None
        if "matrix" in table:
            m = np.array(table["matrix"], np.float64)
        else:
            scale = table.get("scale", 1.0)
            scale = np.full(3, float(scale)) if isinstance(scale, (int, float)) else np.array(scale, np.float64)
            rotate = table.get("rotate", {"axis": [0.0, 0.0, 1.0], "degrees": 0.0})
            m = mesh_matrix(scale, np.array(rotate["axis"], np.float64), float(rotate["degrees"]),
                            np.array(table.get("translate", [0.0, 0.0, 0.0]), np.float64))
        return None if np.linalg.det(m[:3, :3]) < 0 else m

    def ply(self, root, key, vertices, faces, normals):
        """A shape of a PLY file written beside the XML (world space: no to_world)."""
        name = self.ply_name()
        self.extra[name] = ply_bytes(vertices, faces, normals, f"raytrace: {key} of {Path(self.scene.path).name}")
        root.append(_comment(key))
        shape = ET.SubElement(root, "shape", type="ply")
        ET.SubElement(shape, "string", name="filename", value=_escaped(name))
        return shape

    def ply_name(self):
        k = len(self.extra)
        while True:
            name = f"{self.out_path.stem}_mesh{k}.ply"
            if os.path.abspath(self.folder / name) not in self.referenced and name not in self.extra:
                return name
            k += 1
