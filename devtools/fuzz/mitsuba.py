"""Hostile Mitsuba 3 scenes, in its XML and in its dict form (raytrace/scene/mitsuba_xml.py and mitsuba.py read them),
and how a run on one is checked.

Valid scenes are built from the grammar of the plugins raytrace renders (PLUGINS in raytrace/scene/mitsuba.py): a
perspective, thinlens or orthographic sensor (lookat or rotated, fov with each fov_axis or a focal length, clip
planes), an hdrfilm of at most 6 x 6 pixels with a crop window or none and any rfilter, each sampler, the path,
direct and moment integrators, every BSDF raytrace declares
(raytrace/scene/bsdfs.py: diffuse, conductor, roughconductor, dielectric, thindielectric, roughdielectric, plastic,
roughplastic, principled, principledthin; in twosided or not (a transmitting principled not, a principledthin never),
by reference or inline, reflectances
as numbers, rgb and spectra, each parameter anywhere in its range: named metals and media, alpha from 1 to
float32's smallest, alpha_u != alpha_v, GGX and Beckmann, indices above, below, near and far from each other, a
principled's weights 0 to 1 with eta or specular, a principledthin's with diff_trans 0 to 2), rectangle, sphere, obj and ply shapes, area
emitters on rectangles and quad meshes, constant and envmap environments; and the XML's own: $parameters given by
<default> or -D, <include> (of a scene's objects, of one object, through <path>), <alias>, a version 0.6 file's
camelCase names. An Element tree is written as text one element a line, and the same tree is made into Mitsuba's dict
form (numpy matrices, lists, objects with .matrix) by a converter of our own (rotations about the axis as written, as
Mitsuba's).

The same, mutated (XmlMutation): attribute values replaced by bad numbers (nan, inf, 1e39, huge integers), words and
values out of each parameter's range (negative reflectance, fov 0 and 180, alpha 0, width 0, ...); hostile transform
steps (a zero scale, a singular or projective matrix, a scale in the camera's to_world, a rotation about a tiny or
huge axis); tags renamed, attributes added, removed or duplicated, elements deleted, duplicated (ids, parameters
given twice), moved where they do not belong and nested thousands deep; unsupported plugins (with and without
--ignore-unsupported); refs and aliases to nothing; includes of missing files, of the scene itself, of each other, of
broken XML, of a folder; $parameters undefined or defined (-D) to hostile values; then the text truncated, given
random bytes, another encoding, a DTD. The mesh and envmap files the scenes name are replaced by hostile ones
(devtools/fuzz/files.py's). Dict-form scenes are damaged as devtools/fuzz/api.py damages a scene dict (numpy values,
objects, itself, deep nesting) and in Mitsuba's own ways (DictDamage: a plugin that is no dict, a type that is no
plugin, a to_world of the wrong shape or kind, refs to nothing or to themselves).

The contract a Mitsuba scene's run keeps (check_run, check_convert, checked_load): contract.py's, where the one line of
an error names its source as `file:line` (the scene file, a file it includes, a mesh file; `file` alone where no
element is at fault), and where a run that succeeds prints nothing but `raytrace: warning:` lines, `raytrace: note:`
lines and its summary line."""
import contextlib
import dataclasses
import math
import os
import re
import reprlib
import tomllib
from pathlib import Path

import numpy as np
from hypothesis import event, note, reject
from hypothesis import strategies as st

from raytrace.errors import UnsupportedWarning
from raytrace.scene.bsdfs import BY_NAME
from raytrace.scene.named_materials import CONDUCTORS, IORS

from . import contract
from .api import NotOneLineError, WrongErrorSource, checked_call
from .contract import ContractBroken, StrayFiles, TracebackOnStderr, ValidInputRefused, broken, check, \
    check_inputs, escaped
from .files import BytesFile, Directory, ImageFile, TextFile, finite, hostile_files, valid_mesh_files, vectors

SCENE = "scene.xml"


# --- the XML as a tree --------------------------------------------------------------------------------------------

NEST = "__nest__"  # a pseudo-element: its one child inside `depth` copies of the element its attrs describe


@dataclasses.dataclass(frozen=True)
class Element:
    """An XML element: its tag, its attributes ((name, value), ... in order; a name may repeat) and children."""
    tag: str
    attrs: tuple = ()
    children: tuple = ()

    def get(self, name, default=None):
        return next((v for k, v in self.attrs if k == name), default)

    def with_attr(self, name, value):
        if any(k == name for k, _ in self.attrs):
            return dataclasses.replace(self, attrs=tuple((k, value if k == name else v) for k, v in self.attrs))
        return dataclasses.replace(self, attrs=self.attrs + ((name, value),))

    def without_attr(self, name):
        return dataclasses.replace(self, attrs=tuple((k, v) for k, v in self.attrs if k != name))


def el(tag, *children, **attrs):
    return Element(tag, tuple(attrs.items()), tuple(children))


def prop(tag, name, value):
    return Element(tag, (("name", name), ("value", value)))


def nest(element, tag, type_, depth):
    """`element` inside `depth` <tag type="type_"> elements (written without building them: thousands deep)."""
    return Element(NEST, (("tag", tag), ("type", type_), ("depth", str(depth))), (element,))


def quoted(value):
    """An attribute's value, quoted as XML has it (a character that XML cannot hold stays an invalid reference)."""
    out = []
    for c in value:
        if c in '&<>"' or ord(c) < 32:
            out.append(f"&#{ord(c)};")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def xml_text(root, declaration=True):
    """The tree as XML text, one element a line (so that an error's line names one element), iteratively (a
    <__nest__> is thousands deep)."""
    lines = ['<?xml version="1.0" encoding="utf-8"?>'] if declaration else []
    stack = [(root, 0)]
    while stack:
        item, depth = stack.pop()
        pad = "    " * min(depth, 12)
        if isinstance(item, str):
            lines.append(pad + item)
            continue
        if item.tag == NEST:
            n = int(item.get("depth"))
            opening = f'<{item.get("tag")} type={quoted(item.get("type"))}>'
            lines.append(pad + opening * n)
            stack.append((f'</{item.get("tag")}>' * n, depth))
            stack.extend((c, depth + 1) for c in reversed(item.children))
            continue
        attrs = "".join(f" {k}={quoted(v)}" for k, v in item.attrs)
        if not item.children:
            lines.append(f"{pad}<{item.tag}{attrs}/>")
            continue
        lines.append(f"{pad}<{item.tag}{attrs}>")
        stack.append((f"</{item.tag}>", depth))
        stack.extend((c, depth + 1) for c in reversed(item.children))
    return "\n".join(lines) + "\n"


def paths(root):
    """The path (child indices) of every element, the root's () first, not into a <__nest__>."""
    out, stack = [], [((), root)]
    while stack:
        path, e = stack.pop()
        out.append(path)
        if e.tag != NEST:
            stack.extend((path + (i,), c) for i, c in reversed(list(enumerate(e.children))))
    return out


def at(root, path):
    for i in path:
        root = root.children[i]
    return root


def replaced(root, path, new):
    """`root` with the element at `path` replaced by the elements of the list `new` (none: deleted)."""
    if not path:
        return new[0] if new else root
    parent = at(root, path[:-1])
    children = parent.children[:path[-1]] + tuple(new) + parent.children[path[-1] + 1:]
    return replaced(root, path[:-1], [dataclasses.replace(parent, children=children)])


def inserted(root, path, index, new):
    """`root` with `new` made a child of the element at `path`, at `index` (modulo the children's count + 1)."""
    parent = at(root, path)
    i = index % (len(parent.children) + 1)
    children = parent.children[:i] + (new,) + parent.children[i:]
    return replaced(root, path, [dataclasses.replace(parent, children=children)])


# --- valid scenes, from the grammar of the plugins raytrace renders ------------------------------------------------

def num(x):
    return repr(round(float(x), 4))


def triple(v, sep=", "):
    return sep.join(num(x) for x in v)


def rounded(low, high):
    return finite(low, high).map(lambda x: round(x, 4))


@st.composite
def reflectances(draw, name, low=0.0, high=1.0):
    """A colour parameter as a float, an rgb (1 or 3 values) or a spectrum (a value or wavelength:value pairs)."""
    kind = draw(st.sampled_from(["float", "rgb", "rgb1", "spectrum", "spectrum pairs"]))
    if kind == "float":
        return prop("float", name, num(draw(rounded(low, high))))
    if kind == "rgb":
        return prop("rgb", name, triple(draw(st.lists(rounded(low, high), min_size=3, max_size=3)),
                                        draw(st.sampled_from([", ", " ", ","]))))
    if kind == "rgb1":
        return prop("rgb", name, num(draw(rounded(low, high))))
    if kind == "spectrum":
        return prop("spectrum", name, num(draw(rounded(low, high))))
    wavelengths = [draw(st.integers(360, 700))]
    for step in draw(st.lists(st.integers(1, 40), min_size=1, max_size=4)):
        wavelengths.append(wavelengths[-1] + step)
    return prop("spectrum", name, ", ".join(f"{w}:{num(draw(rounded(low, high)))}" for w in wavelengths))


CONDUCTOR_NAMES = tuple(CONDUCTORS)  # every named metal, "none" (a perfect mirror) among them
IOR_NAMES = tuple(IORS)  # every named medium
XML_BSDFS = ("diffuse", "diffuse", "conductor", "roughconductor", "dielectric", "thindielectric", "roughdielectric",
             "plastic", "roughplastic", "principled", "principledthin")
PRINCIPLED_WEIGHTS = ("roughness", "anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint",
                      "clearcoat", "clearcoat_gloss")
PRINCIPLED_RATES = ("diffuse_reflectance_sampling_rate", "main_specular_sampling_rate", "clearcoat_sampling_rate")
THIN_WEIGHTS = ("roughness", "anisotropic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "flatness")
THIN_RATES = ("diffuse_reflectance_sampling_rate", "specular_reflectance_sampling_rate",
              "specular_transmittance_sampling_rate", "diffuse_transmittance_sampling_rate")
GLASS_AND_COATS = ("dielectric", "thindielectric", "roughdielectric", "plastic", "roughplastic")
# A roughness anywhere in (0, 1], written exactly: the tested 1e-3 .. 1 and the effectively smooth region below
# packing.py's SMOOTH_ALPHA (a rough conductor or glass renders smooth there; roughplastic clamps at 1e-4).
XML_ALPHAS = ("1", "0.999", "0.5", "0.1", "0.01", "0.002", "0.0010000001", "0.001", "0.00099999", "0.0005",
              "0.0002", "0.00017", "0.0001", "0.00005", "1e-7", "1e-20", "1e-38", "1e-45")


def alpha_values():
    return st.one_of(st.sampled_from(XML_ALPHAS), finite(1e-3, 1.0).map(repr),
                     st.floats(-149.0, 0.0).map(lambda e: repr(2.0 ** e)))


@st.composite
def xml_iors(draw, kind):
    """int_ior and ext_ior properties of a BSDF of type `kind` (each perhaps left out: Mitsuba's default then):
    named media (in any case: Mitsuba lowercases them), numbers from 0.1 to 10 (int_ior above and below ext_ior,
    far from it: a ratio up to 100, which keeps a valid scene within rule 5 whatever else it holds), near it (a
    relative step of 2^-23 to 1e-2) or equal to it where the type takes equal indices (not the rough interfaces:
    Mitsuba's rule, bsdfs.py's distinct_iors). A plastic's ratio stays within 0.5 to 2.2: beyond, Mitsuba's fit of
    its coat's internal reflectance (and a rough coat's table below 0.5) makes a white base reflect more than it
    receives (raytrace/scene/ranges.py's plastic_albedo), which a valid scene at unbounded depth may not."""
    distinct, coat = BY_NAME[kind].distinct_iors, kind in ("plastic", "roughplastic")
    how = draw(st.sampled_from(["named", "numbers", "near"] + ([] if distinct else ["equal"])))
    media = [n for n in IOR_NAMES if not coat or IORS[n] < 2]  # diamond's 2.419 over air: too much for a coat
    names = st.tuples(st.sampled_from(media), st.sampled_from([str, str, str.upper])).map(lambda t: t[1](t[0]))
    if how == "named":
        pair = [draw(st.one_of(st.none(), names)), draw(st.one_of(st.none(), names))]
    elif how == "numbers" and coat:  # int_ior 0.75 to 2.2 over 1 to 1.5
        pair = [draw(st.one_of(st.none(), rounded(0.75, 2.2))),
                draw(st.one_of(st.none(), st.sampled_from([1.0, 1.000277, 1.33, 1.5])))]
    elif how == "numbers":
        pair = [draw(st.one_of(st.none(), rounded(0.1, 10.0))),
                draw(st.one_of(st.none(), st.sampled_from([1.0, 1.000277, 1.33, 1.5, 0.1, 10.0]), names))]
    elif how == "equal":
        pair = [draw(st.one_of(rounded(0.1, 10.0), names))] * 2
    else:
        ext = draw(st.sampled_from([1.0, 1.5, 0.5, 2.419]))
        step = draw(st.sampled_from([2.0**-23, 1e-6, 1e-4, 1e-2])) * draw(st.sampled_from([1.0, -1.0]))
        pair = [ext * (1 + step), ext]
    if distinct:
        declared = {p.name: p.mitsuba_default for p in BY_NAME[kind].parameters}
        given = [declared[name] if x is None else x for name, x in zip(("int_ior", "ext_ior"), pair)]
        index = [IORS[x.lower()] if isinstance(x, str) else x for x in given]
        if index[0] == index[1]:
            pair[1] = index[0] * 1.25
    return [prop("string" if isinstance(x, str) else "float", name, x if isinstance(x, str) else repr(float(x)))
            for name, x in zip(("int_ior", "ext_ior"), pair) if x is not None]


@st.composite
def bsdfs(draw, direct, ident=None):
    """A BSDF element (diffuse only for the direct integrator), perhaps in a twosided: every BSDF raytrace renders,
    each parameter given or not, anywhere in its range (reflectances 0 to 1, black bases, named metals and eta, k,
    GGX, Beckmann or Mitsuba's default, alpha from 1 down to float32's smallest or alpha_u != alpha_v, indices named
    or numbers above, below, near and far from each other, nonlinear or not, a coat's specular_reflectance 0 to 1)
    within what keeps a scene valid."""
    kind = "diffuse" if direct else draw(st.sampled_from(XML_BSDFS))
    params = []
    if kind == "diffuse":
        if draw(st.booleans()):
            params.append(draw(reflectances("reflectance")))
    elif kind in ("conductor", "roughconductor"):
        if draw(st.booleans()):
            params.append(prop("string", "material", draw(st.sampled_from(CONDUCTOR_NAMES))))
        elif draw(st.booleans()):
            params.append(prop("rgb", "eta", triple(draw(vectors(3, 0.0, 5.0)))))
            params.append(prop("rgb", "k", triple(draw(vectors(3, 0.0, 10.0)))))
        if draw(st.booleans()):
            params.append(draw(reflectances("specular_reflectance")))
    if kind in ("plastic", "roughplastic"):
        if draw(st.booleans()):
            params.append(draw(st.one_of(reflectances("diffuse_reflectance"), st.just(prop("rgb", "diffuse_reflectance",
                                                                                           "0")))))
        if draw(st.booleans()):
            params.append(prop("boolean", "nonlinear", draw(st.sampled_from(["true", "false"]))))
        if draw(st.booleans()):
            params.append(draw(st.one_of(reflectances("specular_reflectance"),
                                         st.just(prop("float", "specular_reflectance", "0")))))
    if kind in GLASS_AND_COATS:
        params += draw(xml_iors(kind))
    if kind in ("dielectric", "thindielectric", "roughdielectric") and draw(st.booleans()):
        value = num(draw(rounded(0.0, 1.0)))
        params += [prop("float", "specular_reflectance", value), prop("float", "specular_transmittance", value)]
    transmits = False
    if kind == "principled":  # each weight 0 to 1; eta (0.2 to 5) or specular, not both (Mitsuba refuses them)
        if draw(st.booleans()):
            params.append(draw(reflectances("base_color")))
        for name in PRINCIPLED_WEIGHTS:
            if draw(st.booleans()):
                value = draw(st.one_of(st.sampled_from([0.0, 1.0]), rounded(0.0, 1.0)))
                transmits |= name == "spec_trans" and value != 0
                params.append(prop("float", name, num(value)))
        which = draw(st.sampled_from(["eta", "specular", None]))
        if which == "eta":
            value = draw(st.one_of(st.sampled_from([1.0, 0.5, 1.5]), rounded(0.2, 5.0)))
            params.append(prop("float", "eta", num(value)))
        elif which == "specular":
            value = draw(st.one_of(st.sampled_from([0.0, 1.0]), rounded(0.0, 1.0)))
            params.append(prop("float", "specular", num(value)))
        for name in PRINCIPLED_RATES:
            if draw(st.booleans()):
                low = 2.0**-10 if name == "main_specular_sampling_rate" else 0.0
                params.append(prop("float", name, num(draw(st.one_of(st.just(1.0), rounded(low, 16.0).filter(
                    lambda x: x >= low))))))
    if kind == "principledthin":  # each weight 0 to 1, diff_trans 0 to 2, eta 0.2 to 5, rates 2^-10 to 16
        transmits = True  # its diffuse transmission is a lobe whether it is 0 or not: Mitsuba's twosided refuses it
        if draw(st.booleans()):
            params.append(draw(reflectances("base_color")))
        for name in THIN_WEIGHTS:
            if draw(st.booleans()):
                params.append(prop("float", name, num(draw(st.one_of(st.sampled_from([0.0, 1.0]), rounded(0.0, 1.0))))))
        if draw(st.booleans()):
            params.append(prop("float", "diff_trans", num(draw(st.one_of(st.sampled_from([0.0, 2.0]),
                                                                         rounded(0.0, 2.0))))))
        if draw(st.booleans()):
            params.append(prop("float", "eta", num(draw(st.one_of(st.sampled_from([1.0, 0.5, 1.5]), rounded(0.2, 5.0))))))
        for name in THIN_RATES:
            if draw(st.booleans()):
                params.append(prop("float", name, num(draw(st.one_of(st.just(1.0), rounded(2.0**-10, 16.0).filter(
                    lambda x: x >= 2.0**-10))))))
    if kind.startswith("rough"):
        distribution = draw(st.sampled_from(["ggx", "beckmann", "GGX", None]))
        if distribution is not None:
            params.append(prop("string", "distribution", distribution))
        if kind != "roughplastic" and draw(st.booleans()):
            params += [prop("float", "alpha_u", draw(alpha_values())), prop("float", "alpha_v", draw(alpha_values()))]
        elif draw(st.sampled_from([True, True, False])):
            params.append(prop("float", "alpha", draw(alpha_values())))
        if draw(st.integers(0, 3)) == 0:
            params.append(prop("boolean", "sample_visible", draw(st.sampled_from(["true", "false"]))))
    order = draw(st.permutations(range(len(params))))
    inner = Element("bsdf", (("type", kind),), tuple(params[i] for i in order))
    if not transmits and draw(st.booleans()):  # Mitsuba's twosided takes no transmission (a principled's)
        inner = Element("bsdf", (("type", "twosided"),), (inner,))
    return inner.with_attr("id", ident) if ident else inner


@st.composite
def placements(draw, uniform=False, reach=0.6, rigid=False):
    """A to_world: a scale, rotations and a translation (in Mitsuba's order: each after those before it), or a
    matrix, keeping a shape within about 2 of the origin."""
    steps = []
    if not rigid:
        if uniform:
            if draw(st.booleans()):
                steps.append(el("scale", value=num(draw(rounded(0.2, 1.0)))))
        elif draw(st.booleans()):
            steps.append(el("scale", x=num(draw(rounded(0.2, 1.0))), y=num(draw(rounded(0.2, 1.0)))))
    axes = [{"x": "1"}, {"y": "1"}, {"z": "1"}, {"value": "0.6 0 0.8"}]
    if not uniform and not rigid:  # Mitsuba takes the axis as written: (1, 1, 0) scales too
        axes.append({"x": "1", "y": "1"})
    for _ in range(draw(st.integers(0, 2))):
        axis = draw(st.sampled_from(axes))
        steps.append(el("rotate", **axis, angle=num(draw(rounded(-180.0, 180.0)))))
    if draw(st.booleans()):
        t = draw(vectors(3, -reach, reach))
        steps.append(draw(st.sampled_from([el("translate", x=num(t[0]), y=num(t[1]), z=num(t[2])),
                                           el("translate", value=triple(t, " ")), el("translate", z=num(t[2]))])))
    if not uniform and not rigid and draw(st.integers(0, 4)) == 0:  # a shear: a rectangle becomes two triangles
        steps.append(el("matrix", value=f"1 {num(draw(rounded(-0.5, 0.5)))} 0 0 0 1 0 0 0 0 1 0 0 0 0 1"))
    return Element("transform", (("name", "to_world"),), tuple(steps))


CAMERA_DIRECTIONS = ((0.0, -1.0, 0.3), (0.6, -0.8, 0.4), (-0.5, -0.7, 0.6), (0.1, -0.2, 1.0), (1.0, 0.2, 0.2),
                     (0.0, 1.0, 0.5))


@st.composite
def sensors(draw):
    d = np.array(draw(st.sampled_from(CAMERA_DIRECTIONS)))
    target = np.array(draw(vectors(3, -0.3, 0.3)))
    origin = target + draw(rounded(4.0, 6.0)) * d / np.linalg.norm(d)
    lookat = {"origin": triple(origin), "target": triple(target)}
    up = draw(st.sampled_from(["0, 0, 1", "0 1 0", None]))
    if up == "0 1 0" and abs(d[1]) / np.linalg.norm(d) > 0.9:
        up = "0, 0, 1"
    if up:
        lookat["up"] = up
    steps = [el("lookat", **lookat)]
    if draw(st.booleans()):  # a turn about the view before it: still rigid
        steps.insert(0, el("rotate", z="1", angle=num(draw(rounded(-180.0, 180.0)))))
    kind = draw(st.sampled_from(["perspective", "perspective", "thinlens", "orthographic"]))
    if kind == "orthographic":  # its view's extent: a scale of x and y before the rest
        steps.insert(0, el("scale", x=num(draw(rounded(0.5, 3.0))), y=num(draw(rounded(0.5, 3.0)))))
    params = [Element("transform", (("name", "to_world"),), tuple(steps))]
    if kind == "thinlens":
        params.append(prop("float", "aperture_radius", num(draw(rounded(0.001, 0.3)))))
        if draw(st.booleans()):
            params.append(prop("float", "focus_distance", num(draw(rounded(0.5, 8.0)))))
    lens = "none" if kind == "orthographic" else draw(st.sampled_from(["fov", "fov", "focal_length", "default"]))
    if lens == "fov":
        params.append(prop("float", "fov", num(draw(rounded(15.0, 100.0)))))
        if draw(st.booleans()):
            axis = draw(st.sampled_from(["x", "y", "diagonal", "smaller", "larger"]))
            params.append(prop("string", "fov_axis", axis))
    elif lens == "focal_length":
        params.append(prop("string", "focal_length", f"{draw(st.integers(20, 120))}mm"))
    if draw(st.booleans()):
        params.append(prop("float", "near_clip", num(draw(rounded(0.001, 0.1)))))
    if draw(st.booleans()):
        params.append(prop("float", "far_clip", num(draw(rounded(50.0, 1e5)))))
    sampler_type = draw(st.sampled_from(["independent", "stratified", "multijitter", "orthogonal", "ldsampler"]))
    sampler = [prop("integer", "sample_count", str(draw(st.integers(1, 4))))]
    if draw(st.booleans()):
        sampler.append(prop("integer", "seed", str(draw(st.integers(0, 1000)))))
    params.append(Element("sampler", (("type", sampler_type),), tuple(sampler)))
    width, height = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    film = [prop("integer", "width", str(width)), prop("integer", "height", str(height))]
    for name, values in (("pixel_format", ["rgb", "rgba"]), ("component_format", ["float16", "float32"]),
                         ("file_format", ["openexr"])):
        if draw(st.integers(0, 3)) == 0:
            film.append(prop("string", name, draw(st.sampled_from(values))))
    size = (width, height)
    if draw(st.integers(0, 3)) == 0:  # a crop window: the image is its size
        x, y = draw(st.integers(0, width - 1)), draw(st.integers(0, height - 1))
        size = (draw(st.integers(1, width - x)), draw(st.integers(1, height - y)))
        film += [prop("integer", "crop_offset_x", str(x)), prop("integer", "crop_offset_y", str(y)),
                 prop("integer", "crop_width", str(size[0])), prop("integer", "crop_height", str(size[1]))]
    if draw(st.integers(0, 3)) == 0:
        film.append(prop("boolean", "sample_border", draw(st.sampled_from(["true", "false"]))))
    rfilter = draw(st.sampled_from(["box", "box", "tent", "gaussian", "mitchell", "lanczos", None]))
    if rfilter is not None:  # None: hdrfilm's default, a gaussian
        film.append(el("rfilter", type=rfilter))
    params.append(Element("film", (("type", "hdrfilm"),), tuple(film)))
    order = draw(st.permutations(range(len(params))))
    return Element("sensor", (("type", kind),), tuple(params[i] for i in order)), size


QUAD_OBJ = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n"


@st.composite
def lights(draw, direct, index, files):
    """A rectangle (or a quad mesh) above the scene with an area emitter."""
    steps = (el("scale", x=num(draw(rounded(0.2, 0.6))), y=num(draw(rounded(0.2, 0.6)))),
             el("rotate", x="1", angle=draw(st.sampled_from(["180", "170", "-160"]))),
             el("translate", x=num(draw(rounded(-0.3, 0.3))), z=num(draw(rounded(1.2, 1.8)))))
    params = [Element("transform", (("name", "to_world"),), steps),
              el("emitter", draw(reflectances("radiance", 0.0, 10.0)), type="area")]
    if not direct and draw(st.booleans()):
        params.append(draw(bsdfs(direct)))
    if draw(st.integers(0, 3)) == 0:
        files.append(TextFile(f"quad{index}.obj", QUAD_OBJ))
        params.append(prop("string", "filename", f"quad{index}.obj"))
        return Element("shape", (("type", "obj"), ("id", f"light{index}")), tuple(params))
    return Element("shape", (("type", "rectangle"), ("id", f"light{index}")), tuple(params))


@st.composite
def shapes(draw, direct, index, bsdf_ids, files):
    kind = draw(st.sampled_from(["rectangle", "rectangle", "sphere", "obj/ply"]))
    params = []
    if kind == "sphere":
        if draw(st.booleans()):
            params.append(el("point", name="center", **dict(zip("xyz", map(num, draw(vectors(3, -0.4, 0.4)))))))
        params.append(prop("float", "radius", num(draw(rounded(0.1, 0.8)))))
        if draw(st.booleans()):
            params.append(draw(placements(uniform=True, reach=0.4)))
        shape = "sphere"
    elif kind == "rectangle":
        params.append(draw(placements()))
        if draw(st.booleans()):
            params.append(prop("boolean", "flip_normals", draw(st.sampled_from(["true", "false"]))))
        shape = "rectangle"
    else:
        mesh = draw(valid_mesh_files(f"mesh{index}"))
        files.append(mesh)
        shape = mesh.name.rsplit(".", 1)[1]
        params.append(prop("string", "filename", mesh.name))
        if draw(st.booleans()):
            params.append(draw(placements(uniform=True)))
        if draw(st.booleans()):
            params.append(prop("boolean", "face_normals", draw(st.sampled_from(["true", "false"]))))
    material = draw(st.sampled_from(["ref", "named ref", "inline", "none"]))
    if material in ("ref", "named ref") and bsdf_ids:
        ident = draw(st.sampled_from(bsdf_ids))
        params.append(el("ref", id=ident) if material == "ref" else el("ref", name="bsdf", id=ident))
    elif material == "inline":
        params.append(draw(bsdfs(direct)))
    order = draw(st.permutations(range(len(params))))
    return Element("shape", (("type", shape),), tuple(params[i] for i in order))


@st.composite
def environments(draw, files):
    if draw(st.booleans()):
        return el("emitter", draw(reflectances("radiance", 0.0, 2.0)), type="constant")
    image = ImageFile("sky.exr", ".exr", draw(st.integers(1, 8)), draw(st.integers(2, 4)), 3, "float",
                      tuple(draw(st.lists(rounded(0.0, 2.0), min_size=1, max_size=6))))
    files.append(image)
    params = [prop("string", "filename", image.name)]
    if draw(st.booleans()):
        params.append(prop("float", "scale", num(draw(rounded(0.1, 3.0)))))
    if draw(st.booleans()):
        params.append(Element("transform", (("name", "to_world"),),
                              (el("rotate", **draw(st.sampled_from([{"x": "1"}, {"y": "1"}, {"z": "1"}])),
                                  angle=num(draw(rounded(-180.0, 180.0)))),)))
    return Element("emitter", (("type", "envmap"),), tuple(params))


@dataclasses.dataclass(frozen=True)
class MitsubaScene:
    """A valid scene: its tree, the files it names, and its image's size."""
    root: Element
    files: tuple
    size: tuple


@st.composite
def valid_trees(draw, max_shapes=3):
    files = []
    integrator = draw(st.sampled_from(["path", "path", "direct", "moment", "default"]))
    direct = integrator == "direct"
    children = []
    if integrator == "path":
        params = []
        if draw(st.booleans()):
            params.append(prop("integer", "max_depth", str(draw(st.sampled_from([-1, 1, 2, 3, 6])))))
        if draw(st.booleans()):
            params.append(prop("integer", "rr_depth", str(draw(st.integers(1, 8)))))
        if draw(st.booleans()):
            params.append(prop("boolean", "hide_emitters", draw(st.sampled_from(["true", "false"]))))
        children.append(Element("integrator", (("type", "path"),), tuple(params)))
    elif integrator == "direct":
        counts = draw(st.sampled_from([(), ("shading_samples",), ("emitter_samples",), ("bsdf_samples",),
                                       ("emitter_samples", "bsdf_samples")]))
        params = [prop("integer", name, str(draw(st.integers(1 if name != "bsdf_samples" else 0, 2))))
                  for name in counts]
        if draw(st.booleans()):
            params.append(prop("boolean", "hide_emitters", draw(st.sampled_from(["true", "false"]))))
        children.append(Element("integrator", (("type", "direct"),), tuple(params)))
    elif integrator == "moment":
        children.append(el("integrator", el("integrator", type="path"), type="moment"))
    sensor, size = draw(sensors())
    children.append(sensor)
    bsdf_ids = [f"m{i}" for i in range(draw(st.integers(0, 2)))]
    children += [draw(bsdfs(direct, ident)) for ident in bsdf_ids]
    children += [draw(lights(direct, i, files)) for i in range(draw(st.integers(1, 2)))]
    children += [draw(shapes(direct, i, bsdf_ids, files)) for i in range(draw(st.integers(0, max_shapes)))]
    if not direct and draw(st.booleans()):
        children.append(draw(environments(files)))
    return MitsubaScene(Element("scene", (("version", "3.0.0"),), tuple(children)), tuple(files), size)


# --- what the XML adds: $parameters, includes, <path>, aliases, version 0.6's names --------------------------------

CAMEL = {"max_depth": "maxDepth", "rr_depth": "rrDepth", "sample_count": "sampleCount", "int_ior": "intIOR",
         "ext_ior": "extIOR", "fov_axis": "fovAxis", "near_clip": "nearClip", "far_clip": "farClip",
         "face_normals": "faceNormals", "flip_normals": "flipNormals", "specular_reflectance": "specularReflectance",
         "to_world": "toWorld", "emitter_samples": "emitterSamples", "focal_length": "focalLength"}


@dataclasses.dataclass(frozen=True)
class XmlExample:
    """A Mitsuba XML scene to run: the tree (written as scene.xml), the files beside it, the -D parameters
    ((name, value), ...), whether unsupported plugins are to be ignored, a damage to the text (None: none), the
    image's size (None: unknown) and whether the scene is valid (it must render)."""
    root: Element
    files: tuple = ()
    defines: tuple = ()
    ignore_unsupported: bool = False
    damage: object = None
    size: tuple = None
    valid: bool = False

    def data(self):
        text = xml_text(self.root).encode("utf-8", "surrogatepass")
        return self.damage.apply(text) if self.damage is not None else text

    def text(self):
        return self.data().decode("utf-8", "backslashreplace")

    def write(self, directory):
        """The scene and its files into `directory` (folders made as their names need)."""
        (directory / SCENE).write_bytes(self.data())
        for f in self.files:
            target = directory / f.name
            if f.name in ("", ".", SCENE) or target.exists() or ".." in Path(f.name).parts:
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            f.write(directory)

    def flags(self):
        """-D and --ignore-unsupported as the command line takes them."""
        out = [x for name, value in self.defines for x in ("-D", f"{name}={value}")]
        return out + (["--ignore-unsupported"] if self.ignore_unsupported else [])

    def sources(self):
        """What an error may name as its source: the scene, the files beside it, every file name the tree gives."""
        names = {SCENE, "command line", *(f.name for f in self.files)}
        for path in paths(self.root):
            e = at(self.root, path)
            names.update(v for k, v in e.attrs if k == "filename" or (k == "value" and (
                e.tag == "path" or e.get("name") == "filename")))
        return sorted(n for n in names if n)

    def note(self):
        text = self.text()
        note(f"{SCENE}:\n{text[:4000]}" + (f"... ({len(text)} characters)" if len(text) > 4000 else ""))
        note(f"files: {self.files!r}"[:3000])
        note(f"defines: {self.defines!r}, ignore_unsupported: {self.ignore_unsupported}, "
             f"damage: {self.damage!r}"[:2000])


def numeric_properties(root):
    """Paths of the integer and float properties (their value a $parameter can stand for)."""
    return [p for p in paths(root) if at(root, p).tag in ("integer", "float") and at(root, p).get("value") is not None]


@st.composite
def xml_features(draw, scene):
    """A valid scene written with the XML's own means, as an XmlExample (still valid)."""
    root, files, defines = scene.root, list(scene.files), []
    features = draw(st.sets(st.sampled_from(["parameter", "include", "include object", "path", "alias", "version 0.6",
                                             "mesh folder"]), max_size=3))
    if "parameter" in features:
        numeric = numeric_properties(root)
        defaults = []
        for k, path in enumerate(draw(st.lists(st.sampled_from(numeric), max_size=3, unique=True)) if numeric else []):
            value, name = at(root, path).get("value"), f"p{k}"
            root = replaced(root, path, [at(root, path).with_attr("value", f"${name}")])
            how = draw(st.sampled_from(["default", "define", "both"]))
            if how in ("default", "both"):
                defaults.append(prop("default", name, value if how == "default" else "999"))
            if how in ("define", "both"):
                defines.append((name, value))
        root = dataclasses.replace(root, children=tuple(defaults) + root.children)
    if "alias" in features:
        refs = [p for p in paths(root) if at(root, p).tag == "ref"]
        if refs:
            path = draw(st.sampled_from(refs))
            ident = at(root, path).get("id")
            root = replaced(root, path, [at(root, path).with_attr("id", ident + "_alias")])
            first = next(i for i, c in enumerate(root.children) if c.get("id") == ident)
            root = inserted(root, (), first + 1, el("alias", id=ident, **{"as": ident + "_alias"}))
    if "include" in features:
        moved = [c for c in root.children if c.tag == "bsdf"]
        if moved:
            folder = "parts/" if "path" in features else ""
            name = draw(st.sampled_from(["materials.xml", "m.XML"]))
            files.append(TextFile(folder + name, xml_text(Element("scene", (("version", "3.0.0"),), tuple(moved)))))
            first = next(i for i, c in enumerate(root.children) if c.tag == "bsdf")
            kept = tuple(c for c in root.children if c.tag != "bsdf")
            include = el("include", filename=name if "path" in features and draw(st.booleans()) else folder + name)
            root = dataclasses.replace(root, children=kept[:first] + (include,) + kept[first:])
            if folder:
                root = inserted(root, (), 0, el("path", value="parts"))
    if "include object" in features:
        sensor = next(i for i, c in enumerate(root.children) if c.tag == "sensor")
        film = next(i for i, c in enumerate(root.children[sensor].children) if c.tag == "film")
        files.append(TextFile("film.xml", xml_text(root.children[sensor].children[film])))
        root = replaced(root, (sensor, film), [el("include", filename="film.xml")])
    if "mesh folder" in features:
        meshes = [f for f in files if f.name.startswith("mesh")]
        if meshes:
            files = [dataclasses.replace(f, name="meshes/" + f.name) if f in meshes else f for f in files]
            via_path = draw(st.booleans())
            for path in paths(root):
                e = at(root, path)
                if e.get("name") == "filename" and e.get("value", "").startswith("mesh"):
                    root = replaced(root, path, [e.with_attr("value", e.get("value") if via_path
                                                             else "meshes/" + e.get("value"))])
            if via_path:
                root = inserted(root, (), 0, el("path", value="meshes"))
    if "version 0.6" in features:
        root = root.with_attr("version", "0.6.0")
        for path in paths(root):
            e = at(root, path)
            if e.get("name") in CAMEL and draw(st.booleans()):
                root = replaced(root, path, [e.with_attr("name", CAMEL[e.get("name")])])
    return XmlExample(root, tuple(files), tuple(defines), draw(st.booleans()), None, scene.size, True)


def valid_xml_scenes(max_shapes=3):
    return valid_trees(max_shapes).flatmap(xml_features)


def small_xml(*extra, width="4", height="3", damage=None, valid=False, defines=()):
    """A 4 x 3 scene (a light over a floor: the fuzz suite's small scene, in Mitsuba's XML) with `extra` elements in
    it, as an XmlExample: for the failures the suite has found, kept as explicit examples."""
    sensor = el("sensor", Element("transform", (("name", "to_world"),), (el("lookat", origin="0, -3, 1",
                                                                             target="0, 0, 0.5", up="0, 0, 1"),)),
                prop("float", "fov", "45"), el("sampler", prop("integer", "sample_count", "1"), type="independent"),
                el("film", prop("integer", "width", width), prop("integer", "height", height),
                   el("rfilter", type="box"), type="hdrfilm"), type="perspective")
    light = el("shape", Element("transform", (("name", "to_world"),), (el("scale", value="0.25"),
                                                                        el("rotate", x="1", angle="180"),
                                                                        el("translate", z="2"))),
               el("emitter", type="area"), type="rectangle")
    root = el("scene", sensor, light, el("shape", type="rectangle"), *extra, version="3.0.0")
    size = (int(width), int(height)) if valid else None
    return XmlExample(root, (), tuple(defines), False, damage, size, valid)


# --- hostile values and mutations ----------------------------------------------------------------------------------

BAD_NUMBERS = ("nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e39", "-1e39", "3.5e38", "1e308", "1.8e308", "1e400",
               "-1e400", "1e-45", "5e-324", "1e-320", "0", "-0", "0.0", "-1", "-0.5", "1", "2", "99999999999999999999",
               "-99999999999999999999", "2147483647", "2147483648", "4294967296", "9223372036854775808",
               "18446744073709551616", "1" + "0" * 400, "180", "179.99999999999997", "360", "1e-30", "0x10", "1_000",
               "1,5", "1 2", "1 2 3 4", " 1 ", "+1", "\u0663", "\uff11", "1e", ".", "-", "", "1:2", "400:nan")
BAD_WORDS = ("", " ", "x", "true", "True", "FALSE", "yes", "$", "$$", "$undefined", "\\$x", "$p0$p0", "a\nb", "a\rb",
             "\t", "\u00e9", "\u202e", "<", ">", "&", '"', "'", "]]>", "\x01", "\x00", "x" * 3000, "/", "/dev/null",
             SCENE, "mesh0.obj", "sky.exr", ".", "nothing", "m0", "m1", "light0", "none", "scene", "3.0.0", "0.6.0",
             "99.0.0", "-1.0.0", "3.0", "\ud800")
RANGE_VALUES = {
    "fov": ("0", "180", "-1", "1e-30", "179.9999999", "1e-7", "360", "-180", "1e30"),
    "alpha": ("0", "-1", "1e-30", "1e30", "1e-7", "1.0000001", "1e-46"), "alpha_u": ("0", "-1", "2", "1e-45"),
    "alpha_v": ("0", "0.7", "1.5"), "diffuse_reflectance": ("-1", "1.5", "2", "1e30", "0"),
    "nonlinear": ("1", "yes", "", "TRUE"), "sample_visible": ("2", "no"),
    "reflectance": ("-1", "-0.5", "1.5", "2", "1e30", "-1e-30", "1, -1, 0", "0.5, 0.5", "400:-1, 500:2"),
    "radiance": ("-1", "0", "1e30", "3.5e38", "-0.0", "1, 1, -1", "1e-45"),
    "width": ("0", "-1", "16385", "100000", "2147483648", "99999999999999999999", "1.5"),
    "height": ("0", "-1", "16385", "2147483648"),
    "sample_count": ("0", "-1", "65537", "2147483647", "4294967296", "3", "5", "17"),
    "max_depth": ("-2", "0", "1000000", "2147483648", "-2147483649"), "rr_depth": ("0", "-1", "99999999999999999999"),
    "radius": ("0", "-1", "1e-30", "1e30", "-0"),
    "int_ior": ("0", "-1", "1", "1e30", "nothing", "Water", "air", "3.9", "1e-30", "3.4e38", "1e-45"),
    "ext_ior": ("0", "-1", "5", "bk7", "vacuum ", "1e-45", "1e30"),
    "scale": ("-1", "0", "1e39", "1e30"), "seed": ("-1", "4294967296", "18446744073709551616"),
    "near_clip": ("0", "-1", "1e30", "100"), "far_clip": ("0", "0.001", "1", "-1"),
    "focal_length": ("0mm", "-1mm", "mm", "1e400mm", "nanmm", "infmm", "50", "1e-300mm", "50 mm", "50MM"),
    "fov_axis": ("z", "X", "", "diagonal "), "distribution": ("beckmann", "GGX", ""),
    "material": ("Xx", "none ", "au", ""), "emitter_samples": ("0", "-1", "100000"), "shading_samples": ("0", "-2"),
    "bsdf_samples": ("-1", "100000"), "hide_emitters": ("1", "yes", ""),
    "eta": ("-1", "0", "1e30"), "k": ("-1", "1e39"), "specular_reflectance": ("-1", "2", "0"),
    "specular_transmittance": ("0.5", "-1"), "pixel_format": ("xyz", "rgba", ""),
    "component_format": ("uint32", "float64"), "file_format": ("png", "jpeg"), "crop_width": ("1", "0", "-1"),
    "crop_height": ("1", "0"), "filename": ("", "missing.obj", SCENE, ".", "sky.exr", "mesh0.obj", "/dev/null"),
}
HOSTILE_STEPS = (
    el("scale", value="0"), el("scale", x="0"), el("scale", value="1e-30"), el("scale", value="1e30"),
    el("scale", value="-1"), el("scale", value="2"), el("scale", x="2"), el("scale", x="1e-200", y="1e200"),
    el("matrix", value=" ".join(["0"] * 15 + ["1"])), el("matrix", value="1 0 0 0 0 1 0 0 0 0 1 0 1 0 0 1"),
    el("matrix", value="1 2 3 4 5 6 7 8 9"), el("matrix", value="1e308 0 0 0 1e308 0 0 0 1e308"),
    el("matrix", value="1e-200 0 0 0 1e-200 0 0 0 1e-200"), el("matrix", value="nan 0 0 0 1 0 0 0 1"),
    el("matrix", value="1 0 0 0 1 0 0 0 1 0"), el("matrix", value="0 1 0 1 0 0 0 0 1"),
    el("matrix", value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 2"), el("matrix", value="1 0 0 3e38 0 1 0 0 0 0 1 0 0 0 0 1"),
    el("rotate", x="1", angle="nan"), el("rotate", x="1e-320", angle="30"), el("rotate", x="1e-200", angle="30"),
    el("rotate", x="1e200", y="1e200", z="1e200", angle="30"), el("rotate", x="1e308", y="1e308", angle="10"),
    el("rotate", x="1", angle="1e300"), el("rotate", angle="45"), el("rotate", x="0", y="0", z="0", angle="1"),
    el("translate", x="1e308"), el("translate", value="1e39"), el("translate", x="3e38"), el("translate"),
    el("lookat", origin="0 0 0", target="1e-320 0 0"), el("lookat", origin="1e308 0 0", target="-1e308 0 0"),
    el("lookat", origin="0 0 5", target="0 0 0", up="0 0 1"),
    el("lookat", origin="0 0 5", target="0 0 0", up="0 0 1e-300"),
    el("lookat", origin="0 -5 0", target="0 0 0", up="1e-320 0 1"), el("lookat", origin="0 0", target="0 0 0"),
    el("lookat", target="0 0 0"), el("lookat", origin="0 -5 0", target="0 1e-10 0"), el("unknown"),
    el("lookat", origin="0 -4 1", target="0 0 0", up="0 0 1"),
)
UNSUPPORTED = (
    el("shape", type="cube"), el("shape", type="cylinder"), el("shape", type="disk"), el("shape", el("emitter",
    type="area"), type="sphere"), el("bsdf", type="pplastic"), el("bsdf", type="principled"),
    el("emitter", type="point"), el("emitter", type="directional"), el("emitter", type="area"),
    el("sensor", type="orthographic"), el("sensor", type="perspective"), el("integrator", type="volpath"),
    el("integrator", type="path"), el("film", type="specfilm"), el("rfilter", type="gaussian"),
    el("sampler", type="sobol"), el("sampler", type="independent"), el("medium", type="homogeneous"),
    el("phase", type="hg"), el("volume", type="gridvolume"), el("texture", type="bitmap"),
    el("texture", prop("string", "filename", "sky.exr"), type="bitmap", name="reflectance"),
    el("spectrum", type="d65", name="radiance"), el("spectrum", name="reflectance", filename="missing.spd"),
    el("spectrum", name="reflectance", filename="sky.exr"), el("spectrum", name="reflectance", value="500:1, 400:1"),
    el("spectrum", name="reflectance", value="1:1, 2:1"), el("spectrum", name="reflectance", value="400:1, 400:2"),
    el("spectrum", name="reflectance"), el("rgb", name="reflectance", value="1 2"), el("point", name="center", x="1"),
    el("vector", name="center", value="1 2 3", x="1"), prop("boolean", "flip_normals", "true"),
    prop("boolean", "face_normals", "yes"), prop("float", "zoom", "1"), prop("float", "reflectance", "0.5"),
    prop("string", "filename", "mesh0.obj"), el("transform", name="to_world"),
    prop("integer", "crop_offset_x", "1"), prop("boolean", "hide_emitters", "true"), prop("integer", "jitter", "0"),
    prop("float", "principal_point_offset_x", "0.1"), prop("boolean", "sample_border", "maybe"),
    prop("string", "sample_border", "true"), el("ref", id="nothing"), el("ref", id="m0"),
    el("ref", name="bsdf", id="m0"),
    el("ref", id="light0"), el("alias", id="nothing", **{"as": "x"}), el("alias", id="m0", **{"as": "m0"}),
    el("alias", id="m0", **{"as": "light0"}), el("default", name="", value="1"), el("default", name="p0", value="$p0"),
    el("path", value="missing"), el("path", value=SCENE), el("path", value="/"), el("blob"), el("scene"),
    el("bsdf", type="diffuse", id="m0"), el("integer", name="x"), el("float", value="1"), el("string", name="s"),
)
INCLUDED = (  # the files an <include> may name, with what they hold
    ("missing.xml", None), (SCENE, None), ("loop_a.xml", TextFile("loop_a.xml", '<scene version="3.0.0"><include '
                                                                 'filename="loop_b.xml"/></scene>')),
    ("loop_b.xml", TextFile("loop_b.xml", '<scene version="3.0.0"><include filename="loop_a.xml"/></scene>')),
    ("broken.xml", TextFile("broken.xml", '<scene version="3.0.0"><bsdf type="diffuse">')),
    ("empty.xml", TextFile("empty.xml", "")), ("folder", Directory("folder")), ("/dev/null", None), ("", None),
    (".", None), ("bytes.xml", BytesFile("bytes.xml", b"\xff\xfe<\x00s\x00")), ("mesh0.obj", None),
    ("object.xml", TextFile("object.xml", '<bsdf type="diffuse" id="m0"/>')),
    ("unsupported.xml", TextFile("unsupported.xml", '<scene version="3.0.0"><shape type="disk"/></scene>')),
    ("lone.xml", TextFile("lone.xml", '<float name="fov" value="30"/>')),
    ("deep.xml", TextFile("deep.xml", '<scene version="3.0.0">' + '<bsdf type="twosided">' * 3000
                          + '<bsdf type="diffuse"/>' + "</bsdf>" * 3000 + "</scene>")),
    ("camel.xml", TextFile("camel.xml", '<scene version="0.5.0"><integrator type="path"><integer name="maxDepth" '
                           'value="2"/></integrator></scene>')),
)
WRAPPERS = (("bsdf", "twosided"), ("scene", "x"), ("shape", "rectangle"), ("integrator", "moment"), ("transform", "x"),
            ("texture", "bitmap"))
NEST_DEPTHS = (1, 2, 33, 300, 2000, 20000)
DEFINE_NAMES = ("p0", "p1", "", "a b", "$", "p0=", "x\ny", "\u00e9", "undefined")
WRONG_TAGS = ("blob", "Float", "bsdf", "shape", "float", "integer", "rgb", "ref", "include", "scene", "spectrum",
              "transform", "lookat", "emitter", "a:b", "x-y", "default", "path", "alias", "boolean", "string")
ATTRIBUTE_NAMES = ("id", "name", "type", "value", "version", "x", "filename", "angle", "foo", "as", "xmlns")


def hostile_strings():
    return st.one_of(st.sampled_from(BAD_NUMBERS), st.sampled_from(BAD_WORDS),
                     st.text(st.characters(blacklist_categories=["Cs"]), max_size=8))


@dataclasses.dataclass(frozen=True)
class XmlMutation:
    """One change to a scene's tree (or its command line): `where` picks an element (an index modulo their number),
    `op` says what is done there, with `value` (a string, an Element, an include's (name, file) or a wrapper),
    `pick` (an attribute's index, a child position, a nesting depth, a second element) and `name`."""
    op: str
    where: int
    value: object = None
    pick: int = 0
    name: str = ""

    def apply(self, example):
        root, files, defines = example.root, list(example.files), list(example.defines)
        all_paths = [p for p in paths(root) if at(root, p).tag != NEST]  # a nest's own attributes stay as written
        path = all_paths[self.where % len(all_paths)]
        e = at(root, path)
        if self.op == "attribute":
            if e.attrs:
                name = e.attrs[self.pick % len(e.attrs)][0]
                root = replaced(root, path, [e.with_attr(name, self.value)])
        elif self.op == "range":  # a value out of its parameter's range, at an element of that name
            named = [p for p in all_paths if at(root, p).get("name") in RANGE_VALUES]
            if named:
                path = named[self.where % len(named)]
                e = at(root, path)
                choices = RANGE_VALUES[e.get("name")]
                root = replaced(root, path, [e.with_attr("value", choices[self.pick % len(choices)])])
        elif self.op == "step":  # a hostile step in a transform (the camera's among them)
            transforms = [p for p in all_paths if at(root, p).tag == "transform"]
            if transforms:
                root = inserted(root, transforms[self.where % len(transforms)], self.pick, self.value)
        elif self.op == "add attribute":
            root = replaced(root, path, [dataclasses.replace(e, attrs=e.attrs + ((self.name, self.value),))])
        elif self.op == "delete attribute" and e.attrs:
            root = replaced(root, path, [e.without_attr(e.attrs[self.pick % len(e.attrs)][0])])
        elif self.op == "rename attribute" and e.attrs:
            old, value = e.attrs[self.pick % len(e.attrs)]
            root = replaced(root, path, [dataclasses.replace(e, attrs=tuple(
                (self.name if k == old else k, v) for k, v in e.attrs))])
        elif self.op == "tag" and path:
            root = replaced(root, path, [dataclasses.replace(e, tag=self.value)])
        elif self.op == "type" and e.get("type") is not None:
            root = replaced(root, path, [e.with_attr("type", self.value)])
        elif self.op == "delete" and path:
            root = replaced(root, path, [])
        elif self.op == "duplicate" and path:
            root = replaced(root, path, [e, e])
        elif self.op == "move" and path:
            rest = replaced(root, path, [])
            targets = paths(rest)
            root = inserted(rest, targets[self.pick % len(targets)], self.pick, e)
        elif self.op == "nest" and path:
            tag, type_ = self.value
            root = replaced(root, path, [nest(e, tag, type_, NEST_DEPTHS[self.pick % len(NEST_DEPTHS)])])
        elif self.op == "insert":
            root = inserted(root, path, self.pick, self.value)
        elif self.op == "include":
            name, file = self.value
            if file is not None:
                files.append(file)
                if file.name == "loop_a.xml":
                    files.append(INCLUDED[3][1])
            root = inserted(root, path, self.pick, el("include", filename=name))
        elif self.op == "parameter":  # a $parameter in a value, defined (or not) with -D to a hostile value
            numeric = numeric_properties(root)
            if numeric:
                target = numeric[self.where % len(numeric)]
                root = replaced(root, target, [at(root, target).with_attr("value", f"${self.name or 'p0'}")])
            if self.pick % 3:
                defines.append((self.name, self.value))
        elif self.op == "define":
            defines.append((self.name, self.value))
        elif self.op == "ignore":
            return dataclasses.replace(example, ignore_unsupported=not example.ignore_unsupported)
        return dataclasses.replace(example, root=root, files=tuple(files), defines=tuple(defines), valid=False)


def xml_mutations():
    where, pick = st.integers(0, 1000), st.integers(0, 1000)
    return st.lists(st.one_of(
        st.builds(XmlMutation, st.just("attribute"), where, hostile_strings(), pick),
        st.builds(XmlMutation, st.just("range"), where, st.none(), pick),
        st.builds(XmlMutation, st.just("range"), where, st.none(), pick),
        st.builds(XmlMutation, st.just("step"), where, st.sampled_from(HOSTILE_STEPS), pick),
        st.builds(XmlMutation, st.just("add attribute"), where, hostile_strings(), pick,
                  st.sampled_from(ATTRIBUTE_NAMES)),
        st.builds(XmlMutation, st.sampled_from(["delete attribute", "delete", "duplicate", "move"]), where, st.none(),
                  pick),
        st.builds(XmlMutation, st.just("rename attribute"), where, st.none(), pick, st.sampled_from(ATTRIBUTE_NAMES)),
        st.builds(XmlMutation, st.just("tag"), where, st.sampled_from(WRONG_TAGS), pick),
        st.builds(XmlMutation, st.just("type"), where, st.sampled_from(
            ["cube", "pplastic", "point", "rectangle", "diffuse", "hdrfilm", "box", "path", "perspective", "scene",
             "ref", "rgb", "spectrum", "", "twosided", "Diffuse", "envmap", "area", "constant", "moment", "obj",
             "a\nb", "x\ry", "\u2028"]), pick),
        st.builds(XmlMutation, st.just("nest"), where, st.sampled_from(WRAPPERS), pick),
        st.builds(XmlMutation, st.just("insert"), where, st.sampled_from(UNSUPPORTED), pick),
        st.builds(XmlMutation, st.just("include"), where, st.sampled_from(INCLUDED), pick),
        st.builds(XmlMutation, st.sampled_from(["parameter", "define"]), where, hostile_strings(), pick,
                  st.sampled_from(DEFINE_NAMES)),
        st.builds(XmlMutation, st.just("ignore"), where)), min_size=1, max_size=3)


@dataclasses.dataclass(frozen=True)
class TextDamage:
    """The XML's bytes damaged: `kind` says how, `at` where, `extra` with what."""
    kind: str
    at: int = 0
    extra: bytes = b""

    def apply(self, text):
        if self.kind == "truncated":
            return text[:self.at % (len(text) + 1)]
        if self.kind == "inserted":
            i = self.at % (len(text) + 1)
            return text[:i] + self.extra + text[i:]
        if self.kind == "random bytes":
            return self.extra
        if self.kind == "encoding":
            return text.replace(b'encoding="utf-8"', self.extra, 1)
        if self.kind == "prolog":  # before the root element (after the declaration)
            head, _, rest = text.partition(b"\n")
            return head + b"\n" + self.extra + rest
        if self.kind == "epilog":
            return text + self.extra
        return b""


DTDS = (b'<!DOCTYPE scene [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>\n',
        b'<!DOCTYPE scene [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n', b"<!DOCTYPE scene>\n",
        b'<!DOCTYPE scene SYSTEM "scene.dtd">\n', b"<?xml-stylesheet href='x'?>\n", b"<!-- a comment -->\n",
        b"\xef\xbb\xbf", b"<scene/>\n", b"text\n", b"<![CDATA[x]]>\n")
INSERTED = (b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x00", b"\x7f", b"\r", b"<", b"&", b"&nosuch;", b"&#0;", b"]]>",
            b"<!-- -- -->", b"</scene>", b"<scene>", b'"', b"\xef\xbb\xbf", b"<x:y/>", b"&#x110000;")
ENCODINGS = (b'encoding="latin-1"', b'encoding="utf-16"', b'encoding="bogus"', b'encoding="ascii"',
             b'encoding="utf-32"', b'encoding=""', b'encoding="UTF-8" standalone="no"')


def text_damages():
    return st.one_of(
        st.builds(TextDamage, st.just("truncated"), st.integers(0, 10**5)),
        st.builds(TextDamage, st.just("inserted"), st.integers(0, 10**5), st.sampled_from(INSERTED)),
        st.builds(TextDamage, st.just("random bytes"), st.just(0), st.binary(max_size=200)),
        st.builds(TextDamage, st.just("encoding"), st.just(0), st.sampled_from(ENCODINGS)),
        st.builds(TextDamage, st.sampled_from(["prolog", "epilog"]), st.just(0), st.sampled_from(DTDS)),
        st.just(TextDamage("empty")))


@st.composite
def hostile_xml_scenes(draw):
    """A valid scene mutated (the mutations drawn first: Hypothesis makes draws after a whole scene mostly copies of
    an earlier example's), perhaps its text damaged too."""
    changes = draw(xml_mutations())
    damage = draw(st.one_of(st.none(), st.none(), st.none(), text_damages()))
    example = draw(valid_xml_scenes())
    for change in changes:
        example = change.apply(example)
    return dataclasses.replace(example, damage=damage, valid=False)


@st.composite
def broken_xml_texts(draw):
    """A valid scene whose text is damaged (truncated, random bytes, an encoding, a DTD): refused or, where the damage
    left it XML, rendered."""
    damage = draw(text_damages())
    return dataclasses.replace(draw(valid_xml_scenes(max_shapes=2)), damage=damage, valid=False)


@st.composite
def xml_scenes_with_hostile_files(draw):
    """A valid scene naming meshes (or an environment map), the first of them replaced by a hostile file."""
    replacement = draw(hostile_files("placeholder"))
    example = draw(valid_xml_scenes())
    named = [f for f in example.files if f.name.rsplit("/", 1)[-1].startswith(("mesh", "quad", "sky"))]
    if not named:
        return example
    victim = named[draw(st.integers(0, len(named) - 1))]
    files = tuple(dataclasses.replace(replacement, name=victim.name) if f is victim else f for f in example.files)
    return dataclasses.replace(example, files=files, valid=False)


def xml_examples():
    """Every kind: valid, mutated, damaged text, hostile files."""
    return st.one_of(valid_xml_scenes(), hostile_xml_scenes(), hostile_xml_scenes(), broken_xml_texts(),
                     xml_scenes_with_hostile_files())


# --- the dict form --------------------------------------------------------------------------------------------------

class Transform:
    """As Mitsuba's ScalarTransform4f: its matrix is `.matrix`."""

    def __init__(self, matrix):
        self.matrix = matrix

    def __repr__(self):
        return f"Transform({np.asarray(self.matrix).tolist()!r})"


def look_at(origin, target, up):
    """Mitsuba's look_at, written anew: columns left, up, direction, origin."""
    d = (target - origin) / np.linalg.norm(target - origin)
    if not np.any(up):
        up = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    left = np.cross(up, d)
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


def xyz(e, default):
    if e.get("value") is not None:
        v = [float(t) for t in re.split(r"[, ]+", e.get("value").strip())]
        return v * 3 if len(v) == 1 else v
    return [float(e.get(a, default)) for a in "xyz"]


def matrix_of(transform):
    """The 4 x 4 matrix of a valid <transform>'s steps, each applied after those before it."""
    m = np.eye(4)
    for step in transform.children:
        s = np.eye(4)
        if step.tag == "translate":
            s[:3, 3] = xyz(step, 0.0)
        elif step.tag == "scale":
            s = np.diag([*xyz(step, 1.0), 1.0])
        elif step.tag == "rotate":  # about the axis as written, not normalised (as Mitsuba's Transform::rotate)
            a, t = np.array(xyz(step, 0.0)), math.radians(float(step.get("angle")))
            cross = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            s[:3, :3] = math.cos(t) * np.eye(3) + math.sin(t) * cross + (1 - math.cos(t)) * np.outer(a, a)
        elif step.tag == "matrix":
            values = [float(t) for t in step.get("value").split()]
            n = 4 if len(values) == 16 else 3
            s[:n, :n] = np.array(values).reshape(n, n)
        else:
            origin, target = (np.array([float(t) for t in re.split(r"[, ]+", step.get(k))])
                              for k in ("origin", "target"))
            up = np.array([float(t) for t in re.split(r"[, ]+", step.get("up"))]) if step.get("up") else np.zeros(3)
            s = look_at(origin, target, up)
        m = s @ m
    return m


def value_of(e, matrix_kind):
    """A valid property element's value in the dict form."""
    v = e.get("value")
    if e.tag == "float":
        return float(v)
    if e.tag == "integer":
        return int(v)
    if e.tag == "boolean":
        return v == "true"
    if e.tag == "string":
        return v
    if e.tag in ("point", "vector"):
        return xyz(e, 0.0)
    if e.tag == "rgb":
        rgb = [float(t) for t in re.split(r"[, ]+", v.strip())]
        return {"type": "rgb", "value": rgb * 3 if len(rgb) == 1 else rgb}
    if e.tag == "spectrum":
        if ":" not in v:
            return {"type": "spectrum", "value": float(v)}
        return {"type": "spectrum", "value": [tuple(float(x) for x in pair.split(":")) for pair in
                                              re.split(r"[, ]+", v.strip())]}
    m = matrix_of(e)
    return {"array": m, "list": m.tolist(), "object": Transform(m)}[matrix_kind]


def to_dict(element, matrix_kind="array", top=True):
    """Mitsuba's dict form of a valid tree (objects under their name, id or tag and a number; ids kept)."""
    node = {"type": element.get("type", "scene")}
    if element.get("id") is not None and not top:
        node["id"] = element.get("id")
    counts = {}
    for child in element.children:
        if child.tag == "ref":
            key = child.get("name") or f"ref_{len(node)}"
            node[key] = {"type": "ref", "id": child.get("id")}
        elif child.get("type") is not None:
            counts[child.tag] = counts.get(child.tag, 0) + 1
            key = child.get("name") or child.get("id") or f"{child.tag}_{counts[child.tag]}"
            node[key] = to_dict(child, matrix_kind, top=False)
        else:
            node[child.get("name")] = value_of(child, matrix_kind)
    return node


class Matrixish:
    """An object whose .matrix is whatever it was given (a string, itself, a property that raises)."""

    def __init__(self, kind):
        self.kind = kind

    @property
    def matrix(self):
        if self.kind == "raises":
            raise RuntimeError("no matrix here")
        return {"string": "eye(4)", "itself": self, "none": None, "3x3": np.eye(3), "object array":
                np.eye(4).astype(object), "nan": np.full((4, 4), np.nan), "int": np.eye(4, dtype=np.int64),
                "float16": np.eye(4, dtype=np.float16), "nested": Transform(np.eye(4))}[self.kind]

    def __repr__(self):
        return f"Matrixish({self.kind!r})"


def odd_matrix(kind):
    scaled = np.diag([2.0, 2.0, 2.0, 1.0])
    return {"3x3": np.eye(3), "zeros": np.zeros((4, 4)), "nan": np.full((4, 4), np.nan),
            "ragged": [[1, 0, 0, 0], [0, 1]], "matrix": np.eye(4).view(np.matrix), "scaled": scaled,
            "huge scale": np.diag([1e200, 1e200, 1e200, 1.0]), "flat": np.eye(4).ravel(), "string": "identity",
            "projective": np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]), "none": None,
            "bools": np.eye(4, dtype=bool), "complex": np.eye(4, dtype=complex), "huge": np.eye(4) * 1e308,
            "tiny": np.diag([1e-300, 1e-300, 1e-300, 1.0]), "float32": np.eye(4, dtype=np.float32),
            "mirror": np.diag([-1.0, 1.0, 1.0, 1.0]), "list of arrays": [np.eye(4)[i] for i in range(4)],
            "masked": np.ma.masked_array(np.eye(4), mask=np.eye(4, dtype=bool))}.get(kind, Matrixish(kind))


ODD_MATRICES = ("3x3", "zeros", "nan", "ragged", "matrix", "scaled", "flat", "string", "projective", "none", "bools",
                "complex", "huge", "huge scale", "tiny", "float32", "mirror", "list of arrays", "masked", "itself",
                "object array", "int", "float16", "nested")  # not "raises": the caller's own exception is the caller's
NOT_PLUGINS = (None, 1, 1.5, "diffuse", [], [{"type": "diffuse"}], (), {"Type": "diffuse"}, {}, {"type": None},
               {"type": 1}, {"type": ["diffuse"]}, {"type": "ref"}, {"type": "ref", "id": 1}, {"type": "scene"},
               {"type": "rgb"}, {"type": "spectrum", "value": "x"},
               {"type": "rgb", "value": np.array([1.0, np.nan, 0])},
               {"type": "diffuse", "__where__": "x"}, b"diffuse")
PLUGIN_TYPES = ("cube", "pplastic", "point", "", "Diffuse", "scene", "ref", "rgb", "spectrum", "rectangle", "diffuse",
                "hdrfilm", "perspective", "path", "twosided", "area", "moment", "independent")


@dataclasses.dataclass(frozen=True)
class DictDamage:
    """One of Mitsuba's own ways to damage a dict-form scene: `op` at the plugin dict `where` picks (an index modulo
    their number), with `value` (the new type, an odd matrix's kind, a non-plugin)."""
    op: str  # not a plugin, type, to_world, ref, self, id
    where: int
    value: object = None

    def apply(self, scene):
        plugins = [p for p in plugin_paths(scene) if p]
        if not plugins:
            return scene
        path = plugins[self.where % len(plugins)]
        parent = scene
        for k in path[:-1]:
            parent = parent[k]
        node = parent[path[-1]]
        if self.op == "not a plugin":
            parent[path[-1]] = self.value
        elif self.op == "type":
            node["type"] = self.value
        elif self.op == "to_world":
            node["to_world"] = odd_matrix(self.value)
        elif self.op == "ref":
            parent[path[-1]] = {"type": "ref", "id": self.value if self.value is not None else path[-1]}
        elif self.op == "self":
            node[str(self.value)] = node if self.value == "itself" else scene
        elif self.op == "id":
            node["id"] = self.value
        return scene


def plugin_paths(node, prefix=(), depth=0):
    """The paths of the plugin dicts (with a type) in a dict-form scene, not deeper than 8."""
    out = [prefix] if isinstance(node, dict) and "type" in node else []
    if isinstance(node, dict) and depth < 8:
        for k, v in node.items():
            out += plugin_paths(v, prefix + (k,), depth + 1)
    return out


def dict_damages():
    where = st.integers(0, 1000)
    return st.lists(st.one_of(
        st.builds(DictDamage, st.just("not a plugin"), where, st.sampled_from(NOT_PLUGINS)),
        st.builds(DictDamage, st.just("type"), where, st.sampled_from(PLUGIN_TYPES)),
        st.builds(DictDamage, st.just("to_world"), where, st.sampled_from(ODD_MATRICES)),
        st.builds(DictDamage, st.just("to_world"), where, st.sampled_from(ODD_MATRICES)),
        st.builds(DictDamage, st.just("ref"), where, st.sampled_from([None, "nothing", "m0", "light0", "sensor_1", 1,
                                                                      ""])),
        st.builds(DictDamage, st.just("self"), where, st.sampled_from(["itself", "scene"])),
        st.builds(DictDamage, st.just("id"), where, st.sampled_from(["m0", "light0", 1, None, "", "a\nb"]))),
        min_size=0, max_size=2).map(tuple)


@dataclasses.dataclass(frozen=True)
class DictExample:
    """A dict-form scene made of a valid tree (its transforms as `matrix_kind`: numpy arrays, lists or objects with
    .matrix), with `damages` (devtools/fuzz/api.py's Damage and DictDamage) applied when it is built."""
    scene: MitsubaScene
    matrix_kind: str
    damages: tuple = ()
    ignore_unsupported: bool = False

    def build(self):
        from .api import Damage
        table = to_dict(self.scene.root, self.matrix_kind)
        for damage in sorted(self.damages, key=lambda d: isinstance(d, Damage) and (d.op == "whole" or (
                d.op == "value" and d.value.kind in ("self", "nested")))):
            if not isinstance(table, dict):
                break
            table = damage.apply(table)
        return table


def dict_examples():
    from .api import damages
    return st.builds(DictExample, valid_trees(), st.sampled_from(["array", "list", "object"]),
                     st.one_of(st.just(()), damages(), dict_damages(),
                               st.tuples(damages(), dict_damages()).map(lambda t: t[0] + t[1])), st.booleans())


# --- the bugs found and not yet fixed ------------------------------------------------------------------------------
# Each open bug: a pattern of the failure it makes (its exception's type and text). While it is open, a generated
# example that fails so is set aside (an event, "open bug: NAME") so that the rest is fuzzed; its minimal input is
# an explicit example in tests/test_fuzz.py marked xfail, which fails (strict) once the bug is fixed: then delete both.

OPEN_BUGS = {}  # none open: the ten the suite found are fixed, their inputs kept as @example in tests/test_fuzz.py


@contextlib.contextmanager
def open_bugs(explicit=False):
    """A failure of the body that an open bug makes: the example set aside (not for an `explicit` one)."""
    try:
        yield
    except ContractBroken as e:
        text = f"{type(e).__name__} {e}"
        bug = next((name for name, pattern in OPEN_BUGS.items() if re.search(pattern, text)), None)
        if bug is None or explicit:
            raise
        event(f"open bug: {bug}")
        reject()


def shown(value):
    """A dict-form scene (deep, holding itself) as a note can show it."""
    r = reprlib.Repr()
    r.maxlevel, r.maxdict, r.maxlist, r.maxstring, r.maxother = 8, 40, 20, 200, 200
    return r.repr(value)


# --- the contract, as a Mitsuba scene keeps it ---------------------------------------------------------------------

class SummaryLinesBroken(ContractBroken):
    """A run that succeeded printed a line that is no warning, note or summary (a warning of two lines)."""


class NonFiniteWritten(ContractBroken):
    """convert wrote a TOML file holding NaN or an infinity."""


class ConvertedRendersDifferently(ContractBroken):
    """The TOML convert wrote renders other bits than the XML it came from (or one renders and the other not)."""


class XmlAndDictDisagree(ContractBroken):
    """The dict form of a valid scene loads, or renders, otherwise than its XML."""


def source_pattern(sources):
    """A regular expression for an error's source: one of `sources` (as given or with control characters
    escaped), then :line or :line:column."""
    shown = sorted({s for source in sources for s in (source, repr(source)[1:-1], str(Path(source)) if source else "")
                    if s}, key=len, reverse=True)
    return re.compile("(?:" + "|".join(re.escape(s) for s in shown) + r")(?::\d+){0,2}: ")


def names_source(text, sources):
    """`text` starts with one of `sources` (source_pattern's); an event says whether with a line."""
    if not source_pattern(sources).match(text):
        return False
    event("the error names a line" if re.match(r"[^:]*:\d+", text) else "the error names no line")
    return True


def check_refused(outcome, sources, example_text):
    """contract.py's refusal (exit status 2, one line, no file left), its source a file with its line."""
    contract.check_refused(outcome, sources, example_text, names_source, listed=lambda sources: sources[:20])


SUMMARY = re.compile(r"^\S.*: \d+x\d+, .* spp .*$")


def check_summary(outcome, sources, example_text, summary=True):
    """A run that succeeded: every line on stderr a warning or a note naming one of `sources`, or the summary."""
    pattern = source_pattern(sources)
    lines = re.split(r"\r\n?|\n", outcome.stderr.rstrip("\n")) if outcome.stderr.strip() else []
    for i, line in enumerate(lines):
        if (summary and SUMMARY.match(line)) or any(line.startswith(lead) and pattern.match(line[len(lead):])
                                                    for lead in ("raytrace: warning: ", "raytrace: note: ")):
            continue
        if i and lines[i - 1].startswith("raytrace: warning: "):
            broken(SummaryLinesBroken, outcome, f"a warning continued on a second line: {line[:300]!r}", example_text)
        broken(SummaryLinesBroken, outcome, f"a line that is no warning, note or summary: {line[:300]!r}", example_text)


def check_run(outcome, directory, output, size, sources, inputs, must_render=False, example_text=None, stats=None):
    """The contract for one render of a Mitsuba scene (contract.check's, the error's source file:line)."""
    if outcome.error is None and outcome.rc == 2:
        event("exit status 2")
        check_inputs(outcome, directory, inputs, example_text)
        if must_render:
            broken(ValidInputRefused, outcome, "a valid scene was refused", example_text)
        return check_refused(outcome, sources, example_text)
    check(outcome, directory, output, size, sources, stats, must_render, example_text, inputs)
    if outcome.rc == 0:
        check_summary(outcome, sources, example_text)


def check_convert(outcome, directory, output, sources, inputs, must_convert=False, example_text=None):
    """`convert` to TOML: exit status 0 and the TOML file alone, with no NaN or infinity in it; or the refusal."""
    if outcome.error is not None:
        return escaped(outcome, example_text)
    event(f"convert: exit status {outcome.rc!r}")
    check_inputs(outcome, directory, inputs, example_text)
    if outcome.rc == 2:
        if must_convert:
            broken(ValidInputRefused, outcome, "a valid scene was refused", example_text)
        return check_refused(outcome, sources, example_text)
    if outcome.rc != 0:
        from .contract import WrongExitStatus
        return broken(WrongExitStatus, outcome, f"exit status {outcome.rc!r}", example_text)
    if "Traceback" in outcome.stderr:
        broken(TracebackOnStderr, outcome, "a traceback on stderr with exit status 0", example_text)
    check_summary(outcome, sources, example_text, summary=False)
    if outcome.new_files != {os.path.normpath(output)}:
        broken(StrayFiles, outcome, f"files written: {sorted(outcome.new_files)}, not {output} alone", example_text)
    table = tomllib.loads((directory / output).read_text(encoding="utf-8"))
    bad = [v for v in leaves(table) if isinstance(v, float) and not math.isfinite(v)]
    if bad:
        broken(NonFiniteWritten, outcome, f"the TOML holds {bad[:3]}", example_text)


def corners(rectangle):
    """The corners of a rectangle's table (center, size, normal, tangent): a square's tangent may be either edge."""
    c, (w, h) = np.array(rectangle["center"]), rectangle["size"]
    t = np.array(rectangle["tangent"])
    b = np.cross(rectangle["normal"], t)
    return [c + su * w * t + sv * h * b for su in (-0.5, 0.5) for sv in (-0.5, 0.5)]


def close_tables(a, b, rel=1e-9, tiny=1e-12):
    """Two scene tables alike: the same keys and types, their numbers equal to `rel` of their size (or `tiny`), a
    rectangle's the same corners."""
    if isinstance(a, dict) and isinstance(b, dict) and {"center", "size", "normal", "tangent"} <= a.keys() == b.keys():
        rest = [k for k in a if k not in ("size", "tangent")]
        return all(close_tables(a[k], b[k], rel, tiny) for k in rest) and all(
            any(np.allclose(p, q, rtol=rel, atol=tiny * 10) for q in corners(b)) for p in corners(a))
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=rel, abs_tol=tiny)
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(close_tables(a[k], b[k], rel, tiny) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(close_tables(x, y, rel, tiny) for x, y in zip(a, b))
    return a == b


def leaves(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from leaves(v)
    elif isinstance(value, list):
        for v in value:
            yield from leaves(v)
    else:
        yield value


def checked_load(what, call, sources):
    """(Scene or None, the InputError or None) of call(), a load (api.checked_call's): an InputError's text one
    line naming one of `sources` (file:line); UnsupportedWarning the only warning, each one line naming one of
    them. Any other exception or warning breaks the contract."""
    pattern = source_pattern(sources)

    def check_warning(w):
        text = str(w.message)
        if "\n" in text or "\r" in text:
            raise NotOneLineError(f"{what}: a warning's text is not one line: {text!r}")
        if not pattern.match(text):
            raise WrongErrorSource(f"{what}: the warning names none of {sources[:20]}: {text!r}")
    result, error = checked_call(what, call, warned=(UnsupportedWarning,), check_warning=check_warning)
    if error is not None:
        text = str(error)
        if "\n" in text or "\r" in text:
            raise NotOneLineError(f"{what}: the InputError's text is not one line: {text!r}")
        if not pattern.match(text):
            raise WrongErrorSource(f"{what}: the error names none of {sources[:20]}: {text!r}")
    return result, error


def render_cost(scene):
    """Pixel samples times the rays each takes: what a render of `scene` costs."""
    return scene.width * scene.height * scene.spp * (1 + scene.light_samples * max(1, len(scene.lights)))
