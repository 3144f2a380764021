"""Arbitrary output variables (AOVs): what each pixel's camera rays meet first, averaged over its samples beside
the image (kernels/aovs.cl defines each value; Mitsuba 3's `aov` integrator, src/integrators/aov.cpp, is the
model, with its type names and its channel names).

An AOV is a (name, type) pair: the name is the user's and names its channels (`NAME.R` ... in an EXR file,
`image.aovs[NAME]`), the type one of TYPES. render()'s option `aov` and a scene's `aovs` (its render table,
Mitsuba's `<integrator type="aov">`) take Mitsuba's syntax, "name:type" items separated by commas, or a list of
such items; an item without a type is one of the SHORT names, which name themselves ("albedo,normal" is
"albedo:albedo,normal:sh_normal")."""
import numpy as np

from .errors import InputError, did_you_mean

# The types, in the kernel's order (kernels/types.h's AOV_* bits and planes): each one's channel suffixes, as
# Mitsuba's aov integrator names them.
TYPES = {"albedo": ("R", "G", "B"), "sh_normal": ("X", "Y", "Z"), "geo_normal": ("X", "Y", "Z"), "depth": ("T",),
         "position": ("X", "Y", "Z"), "uv": ("U", "V"), "shape_index": ("I",)}
# Mitsuba's types raytrace does not compute (its loader refuses or skips them)
UNSUPPORTED = ("dp_du", "dp_dv", "duv_dx", "duv_dy", "prim_index")
# An item without a type: its own name, of this type
SHORT = {"albedo": "albedo", "normal": "sh_normal", "sh_normal": "sh_normal", "geo_normal": "geo_normal",
         "depth": "depth", "position": "position", "uv": "uv", "shape": "shape_index", "shape_index": "shape_index"}
# The shape_index AOV numbers the scene's shapes from 1 (0: nothing hit, as Mitsuba's scalar variants number
# theirs) in this order: its lists in the scene model, each in its own order (the file's order of that kind).
# A loose triangle (a scene file's "triangle", each face of an inline "mesh") is a shape of its own, a mesh
# file one shape, an instance one shape whatever its group holds (Mitsuba's si.instance). Mitsuba's scalar
# variants number scene->shapes() in the XML's order and its JIT variants by the shape's registry id: the
# numbers differ from Mitsuba's, the partition of the image into shapes does not.
SHAPE_ORDER = ("rectangles", "triangles", "meshes", "ellipsoids", "disks", "cylinders", "lights", "instances")


def parse(value, source, key):
    """The (name, type) pairs of `value`: a "name:type,..." string (Mitsuba's `aovs`), or a list or tuple of such
    items, or None / "" for none. InputError (one line, naming source and key) for an unknown type or short
    name (with the nearest), an empty or repeated name, or a value of another kind."""
    if value is None:
        return ()
    if isinstance(value, str):
        items = [item.strip() for item in value.split(",")] if value.strip() else []
    elif isinstance(value, (list, tuple)) and all(isinstance(item, str) for item in value):
        items = [item.strip() for item in value]
    else:
        raise InputError(source, key, value, 'must be a string of "name:type" items separated by commas, or a '
                         "list of them")
    pairs = []
    for item in items:
        name, colon, kind = item.partition(":")
        name, kind = name.strip(), kind.strip()
        if not colon:
            if name not in SHORT:
                raise InputError(source, key, value, f"unknown AOV {name!r}{did_you_mean(name, [*SHORT], ';')} "
                                 f"(have: {', '.join(SHORT)}, or name:type with a type of {', '.join(TYPES)})")
            kind = SHORT[name]
        elif kind not in TYPES:
            hint = " (raytrace does not compute it)" if kind in UNSUPPORTED else did_you_mean(kind, [*TYPES], ";")
            raise InputError(source, key, value, f"unknown AOV type {kind!r}{hint} (have: {', '.join(TYPES)})")
        if not name or any(c in name for c in " \t\n"):
            raise InputError(source, key, value, f"the AOV {item!r} needs a name without spaces before its type")
        if name in (n for n, _ in pairs):
            raise InputError(source, key, value, f"the AOV name {name!r} is given twice")
        pairs.append((name, kind))
    return tuple(pairs)


def mask(pairs):
    """HAS_AOVS: the bits of the types among `pairs` (kernels/types.h's AOV_*), 0 for none."""
    kinds = {kind for _, kind in pairs}
    return sum(1 << i for i, kind in enumerate(TYPES) if kind in kinds)


def stores(bits, kind):
    """Whether HAS_AOVS = bits stores the AOV type `kind` (the host packs the tables its kernel code reads)."""
    return bool(bits >> [*TYPES].index(kind) & 1)


def planes(bits):
    """The kernel's AOV planes for HAS_AOVS = bits: {type: slice of the planes after OUTPUT_PLANES}."""
    out, at = {}, 0
    for i, (kind, channels) in enumerate(TYPES.items()):
        if bits >> i & 1:
            out[kind] = slice(at, at + len(channels))
            at += len(channels)
    return out


def plane_count(bits):
    return sum(len(TYPES[kind]) for kind in planes(bits))


def channel_names(pairs):
    """Every AOV's EXR channels, in order: NAME.R, NAME.G, NAME.B for an albedo named NAME (Mitsuba's names)."""
    return [f"{name}.{suffix}" for name, kind in pairs for suffix in TYPES[kind]]


def images(pairs, means):
    """{name: H x W x C float32} of each AOV from `means`, the P x H x W means of the kernel's AOV planes for
    mask(pairs) (planes())."""
    at = planes(mask(pairs))
    return {name: np.ascontiguousarray(np.moveaxis(means[at[kind]], 0, -1), np.float32) for name, kind in pairs}


def to_string(pairs):
    """Mitsuba's `aovs` string of the pairs: "name:type,..."."""
    return ",".join(f"{name}:{kind}" for name, kind in pairs)


def layers(pairs, arrays):
    """The file layers of the AOVs `pairs` whose arrays {name: H x W x C} holds: (channel names, array) each,
    in the pairs' order (image_file.write_image_file's `aovs`)."""
    return [(channel_names([(name, kind)]), arrays[name]) for name, kind in pairs if name in arrays]
