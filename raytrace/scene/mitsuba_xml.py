"""Mitsuba 3's XML scene format, read as Mitsuba 3 reads it (its parser, src/core/parser.cpp, is the specification)
into Mitsuba's own dict form, the one `mi.load_dict` takes: {"type": "scene", "light": {"type": "rectangle",
...}, ...}. mitsuba.py turns that form, from here or from a caller, into raytrace's scene table.

What the XML adds to the dict form is resolved here: `include` (a file's objects spliced into its parent),
`path` (folders to look for files in), `default` and `$name` (with -D name=value from the caller), `ref`,
`alias`, transforms composed in Mitsuba's order (each element applied after those before it), `rgb` and
`spectrum` values, and the upgrade of version 0.x files (camelCase names). Every object and property keeps
where it was written (`Where`), so that any later error names the file and line.
"""
import math
import os
import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

OBJECT_TAGS = ("scene", "shape", "bsdf", "emitter", "sensor", "film", "rfilter", "sampler", "integrator", "texture",
               "medium", "phase", "volume")
PROPERTY_TAGS = ("float", "integer", "boolean", "string", "point", "vector", "rgb", "spectrum", "transform")
OTHER_TAGS = ("include", "path", "default", "ref", "alias")
TRANSFORM_TAGS = ("translate", "rotate", "scale", "matrix", "lookat")
MAX_INCLUDES = 32  # include depth: a file that includes itself is refused long before
MAX_ELEMENT_DEPTH = 64  # elements within each other in one file: a scene needs 5 (scene, shape, bsdf, bsdf, rgb)
ONE_OR_THREE, NO_SUCH_ID = "must hold 1 or 3 numbers", "no object with this id before it"
_PARAMETER = re.compile(r"\$([A-Za-z0-9_]*)")


@dataclass
class Where:
    """Where an object and its properties were written: `at` is "file:line" (or the dict path of a caller's
    dict), `tag` the XML element (bsdf, shape, ...), `params` each property's own "file:line"."""
    at: str
    tag: str = ""
    params: dict = field(default_factory=dict)
    search: list = field(default_factory=list)  # the scene's: the folders of its <path> elements
    aliases: dict = field(default_factory=dict)  # the scene's: {alias: id} of its <alias> elements

    def of(self, name):
        return self.params.get(name, self.at)


WHERE = "__where__"  # the key of an object's Where in the dict form this module returns


@dataclass
class _Element:
    tag: str
    attrs: dict
    line: int
    file: str
    children: list = field(default_factory=list)

    @property
    def at(self):
        return f"{self.file}:{self.line}"


def _tokens(text, delimiters=", "):
    return [t for t in re.split(f"[{re.escape(delimiters)}]+", text) if t]


def _parse(data, file):
    """The element tree of XML `data` (bytes). DTDs are refused: an entity is a way to blow a small file up."""
    parser = xml.parsers.expat.ParserCreate()
    stack, roots = [], []

    def start(tag, attrs):
        if len(stack) >= MAX_ELEMENT_DEPTH:
            raise InputError(f"{file}:{parser.CurrentLineNumber}", f"<{tag}>", None, f"elements nested more than "
                             f"{MAX_ELEMENT_DEPTH} deep")
        element = _Element(tag, attrs, parser.CurrentLineNumber, file)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def refuse_dtd(*_):
        raise InputError(f"{file}:{parser.CurrentLineNumber}", "xml", None, "a DOCTYPE or entity declaration: "
                         "Mitsuba's scene files have none, and raytrace reads none")

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    parser.StartDoctypeDeclHandler = refuse_dtd
    parser.EntityDeclHandler = refuse_dtd
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        raise InputError(f"{file}:{e.lineno}:{e.offset + 1}", "xml", None,
                         f"{xml.parsers.expat.ErrorString(e.code)}: not well-formed XML") from None
    except (LookupError, ValueError) as e:  # an encoding Python lacks, or one expat cannot read (utf-32)
        raise InputError(file, "xml", None, f"{e}: not XML raytrace can read") from None
    return roots[0]


class _Reader:
    """The state of one load: the -D and <default> parameters, the folders of <path>, the ids seen."""

    def __init__(self, defines):
        self.parameters = dict(defines)
        self.search = []
        self.ids = {}
        self.aliases = {}
        self.files = []

    def fail(self, element, key, value, problem):
        raise InputError(element.at, key, value, problem)

    def check_attributes(self, element, required, optional=()):
        for name in element.attrs:
            if name not in required and name not in optional:
                self.fail(element, f"<{element.tag}> {name}", element.attrs[name],
                          f"is no attribute of <{element.tag}> (it takes: {', '.join((*required, *optional))})")
        for name in required:
            if name not in element.attrs:
                self.fail(element, f"<{element.tag}> {name}", None, "missing")

    def substitute(self, element):
        """$name in every attribute replaced by its parameter, longest names first as Mitsuba does; \\$ is a
        dollar sign."""
        for attr, value in element.attrs.items():
            if "$" not in value:
                continue
            for name in sorted(self.parameters, key=len, reverse=True):
                value = re.sub(r"(?<!\\)\$" + re.escape(name), lambda m: self.parameters[name], value)
            left = re.search(r"(?<!\\)" + _PARAMETER.pattern, value)
            if left:
                self.fail(element, f"<{element.tag}> {attr}", element.attrs[attr],
                          f"undefined parameter ${left.group(1)} (give it with -D {left.group(1)}=VALUE or a "
                          "<default>)")
            element.attrs[attr] = value.replace("\\$", "$")

    def resolve(self, element, name, folder):
        """A file name as Mitsuba's file resolver finds it: as given if absolute, else in the including file's
        folder, then in each <path> folder."""
        path = Path(name)
        if path.is_absolute():
            return path
        for base in (folder, *self.search):
            if (base / path).exists():
                return base / path
        return folder / path

    def file(self, path, where=None, depth=0):
        if depth > MAX_INCLUDES:
            raise InputError(where or path, "include", str(path), f"includes nested more than {MAX_INCLUDES} deep "
                             "(a file that includes itself?)")
        try:
            data = Path(path).read_bytes()
        except OSError as e:
            raise InputError(where or path, "include" if where else "file", str(path),
                             e.strerror or "cannot be read") from None
        return _parse(data, str(path))

    def number(self, element, attr, text=None):
        text = element.attrs[attr] if text is None else text
        try:
            value = float(text.strip())
        except ValueError:
            self.fail(element, f"<{element.tag}> {attr}", text, "could not parse a floating point value")
        if not math.isfinite(value):
            self.fail(element, f"<{element.tag}> {attr}", text, "must be finite")
        return value

    def xyz(self, element, default=None):
        """x, y, z of a point, vector, translate, rotate or scale, given as x/y/z or as value ("1 2 3", or one
        number for all three)."""
        attrs = element.attrs
        if "value" in attrs:
            if {"x", "y", "z"} & set(attrs):
                self.fail(element, f"<{element.tag}> value", attrs["value"], 'cannot mix "value" and "x"/"y"/"z"')
            tokens = _tokens(attrs["value"])
            if len(tokens) not in (1, 3):
                self.fail(element, f"<{element.tag}> value", attrs["value"], ONE_OR_THREE)
            return [self.number(element, "value", t) for t in (tokens * 3 if len(tokens) == 1 else tokens)]
        if default is None:
            for axis in "xyz":
                if axis not in attrs:
                    self.fail(element, f"<{element.tag}> {axis}", None, "missing")
        return [self.number(element, axis) if axis in attrs else default for axis in "xyz"]

    def vector3(self, element, attr):
        tokens = _tokens(element.attrs[attr])
        if len(tokens) != 3:
            self.fail(element, f"<{element.tag}> {attr}", element.attrs[attr], "must hold 3 numbers")
        return np.array([self.number(element, attr, t) for t in tokens])

    def transform(self, element):
        matrix = np.eye(4)
        for child in element.children:
            self.substitute(child)
            tag = child.tag
            if tag == "translate":
                self.check_attributes(child, (), ("x", "y", "z", "value"))
                step = np.eye(4)
                step[:3, 3] = self.xyz(child, 0.0)
            elif tag == "scale":
                self.check_attributes(child, (), ("x", "y", "z", "value"))
                step = np.diag([*self.xyz(child, 1.0), 1.0])
            elif tag == "rotate":
                self.check_attributes(child, ("angle",), ("x", "y", "z", "value"))
                axis = np.array(self.xyz(child, 0.0))
                if not np.any(axis):
                    self.fail(child, "<rotate> axis", axis.tolist(), "cannot be zero")
                with np.errstate(over="ignore", invalid="ignore"):
                    step = rotation(axis, self.number(child, "angle"))
            elif tag == "matrix":
                self.check_attributes(child, ("value",))
                tokens = _tokens(child.attrs["value"])
                if len(tokens) not in (9, 16):
                    self.fail(child, "<matrix> value", child.attrs["value"], f"must hold 9 or 16 numbers, not "
                              f"{len(tokens)}")
                n = 4 if len(tokens) == 16 else 3
                step = np.eye(4)
                step[:n, :n] = np.array([self.number(child, "value", t) for t in tokens]).reshape(n, n)
            elif tag == "lookat":
                self.check_attributes(child, ("origin", "target"), ("up",))
                origin, target = self.vector3(child, "origin"), self.vector3(child, "target")
                up = self.vector3(child, "up") if "up" in child.attrs else np.zeros(3)
                with np.errstate(over="ignore", invalid="ignore"):
                    step = look_at(origin, target, up)
                if step is None:
                    self.fail(child, "<lookat>", child.attrs, "invalid: origin equals target, or up is along the "
                              "view direction")
            else:
                self.fail(child, f"<{tag}>", None, f"unexpected inside <transform> (have: {', '.join(TRANSFORM_TAGS)})")
            with np.errstate(over="ignore", invalid="ignore"):
                matrix = step @ matrix
            if not np.all(np.isfinite(matrix)):
                self.fail(child, f"<{tag}>", child.attrs, "makes the transform overflow")
        return matrix

    def spectrum(self, element, folder):
        attrs = element.attrs
        self.check_attributes(element, ("name",), ("value", "filename"))
        if ("value" in attrs) == ("filename" in attrs):
            self.fail(element, f"<spectrum> {attrs['name']}", None, 'needs either "value" or "filename" (not both)')
        if "filename" in attrs:
            return {"type": "spectrum", "filename": str(self.resolve(element, attrs["filename"], folder))}
        tokens = _tokens(attrs["value"])
        if len(tokens) == 1 and ":" not in tokens[0]:
            return {"type": "spectrum", "value": self.number(element, "value", tokens[0])}
        pairs = []
        for token in tokens:
            pair = token.split(":")
            if len(pair) != 2:
                self.fail(element, f"<spectrum> {attrs['name']}", token, "expected wavelength:value pairs")
            pairs.append((self.number(element, "value", pair[0]), self.number(element, "value", pair[1])))
        return {"type": "spectrum", "value": pairs}

    def object(self, element, folder, depth, upgrade):
        """The dict of an object element (scene, shape, bsdf, ...) and its children."""
        node = {"type": element.attrs.get("type", "scene")}
        where = Where(element.at, element.tag)
        node[WHERE] = where
        counter = [0]
        for child in element.children:
            self.child(node, where, child, folder, depth, upgrade, counter)
        if upgrade:
            _upgrade(node, where)
        return node

    def add(self, node, where, name, value, at):
        if name in node:
            raise InputError(at, name, None, "given twice in one object")
        node[name] = value
        where.params[name] = at

    def child(self, node, where, child, folder, depth, upgrade, counter):
        self.substitute(child)
        tag, attrs = child.tag, child.attrs
        name = attrs.get("name")

        def unnamed():
            counter[0] += 1
            return f"_arg_{counter[0] - 1}"

        if tag in OBJECT_TAGS or (tag == "spectrum" and "type" in attrs):
            self.check_attributes(child, ("type",), ("id", "name"))
            obj = self.object(child, folder, depth, upgrade)
            obj[WHERE].tag = "texture" if tag == "spectrum" else tag
            if "id" in attrs:
                if attrs["id"] in self.ids:
                    self.fail(child, f"<{tag}> id", attrs["id"], f"duplicate id (first at {self.ids[attrs['id']][1]})")
                obj["id"] = attrs["id"]
                self.ids[attrs["id"]] = (obj, child.at)
            self.add(node, where, name or attrs.get("id") or unnamed(), obj, child.at)
        elif tag in ("float", "integer", "boolean", "string"):
            self.check_attributes(child, ("name", "value"))
            text = attrs["value"]
            if tag == "float":
                value = self.number(child, "value")
            elif tag == "integer":
                if not re.fullmatch(r"\s*[+-]?\d+\s*", text):
                    self.fail(child, f"<integer> {name}", text, "could not parse an integer value")
                value = int(text)
            elif tag == "boolean":
                if text.lower() not in ("true", "false"):
                    self.fail(child, f"<boolean> {name}", text, 'must be "true" or "false"')
                value = text.lower() == "true"
            else:
                value = text
            self.add(node, where, name, value, child.at)
        elif tag in ("point", "vector"):
            self.check_attributes(child, ("name",), ("x", "y", "z", "value"))
            self.add(node, where, name, self.xyz(child), child.at)
        elif tag == "rgb":
            self.check_attributes(child, ("name", "value"))
            tokens = _tokens(attrs["value"])
            if len(tokens) not in (1, 3):
                self.fail(child, f"<rgb> {name}", attrs["value"], ONE_OR_THREE)
            rgb = [self.number(child, "value", t) for t in tokens]
            self.add(node, where, name, {"type": "rgb", "value": rgb * 3 if len(rgb) == 1 else rgb}, child.at)
        elif tag == "spectrum":
            self.add(node, where, name, self.spectrum(child, folder), child.at)
        elif tag == "transform":
            self.check_attributes(child, ("name",))
            self.add(node, where, name, self.transform(child), child.at)
        elif tag == "ref":
            self.check_attributes(child, ("id",), ("name",))
            if attrs["id"] not in self.ids:
                self.fail(child, "<ref> id", attrs["id"], NO_SUCH_ID)
            self.add(node, where, name or unnamed(), {"type": "ref", "id": attrs["id"], WHERE: Where(child.at, "ref")},
                     child.at)
        elif tag == "alias":
            self.check_attributes(child, ("id", "as"))
            if attrs["id"] not in self.ids:
                self.fail(child, "<alias> id", attrs["id"], NO_SUCH_ID)
            if attrs["as"] in self.ids:
                self.fail(child, "<alias> as", attrs["as"], "an object with this id exists")
            self.ids[attrs["as"]] = self.ids[attrs["id"]]
            self.aliases[attrs["as"]] = attrs["id"]
        elif tag == "default":
            self.check_attributes(child, ("name", "value"))
            if not attrs["name"]:
                self.fail(child, "<default> name", "", "must not be empty")
            self.parameters.setdefault(attrs["name"], attrs["value"])
        elif tag == "path":
            self.check_attributes(child, ("value",))
            if where.tag != "scene":
                self.fail(child, "<path>", attrs["value"], "can only be a child of <scene>")
            folder_path = self.resolve(child, attrs["value"], folder)
            if not folder_path.is_dir():
                self.fail(child, "<path> value", attrs["value"], "no such folder")
            self.search.insert(0, folder_path)
        elif tag == "include":
            self.check_attributes(child, ("filename",), ("name",))
            path = self.resolve(child, attrs["filename"], folder)
            included = self.file(path, child.at, depth + 1)
            inner = self.root(included, path.parent, depth + 1, scene_root=False)
            if inner["type"] == "scene" and included.tag == "scene":
                for key, value in inner.items():
                    if key not in ("type", WHERE, "id"):
                        at = inner[WHERE].of(key)
                        self.add(node, where, unnamed() if key.startswith("_arg_") else key, value, at)
            else:
                self.add(node, where, name or unnamed(), inner, child.at)
        else:
            self.fail(child, f"<{tag}>", None, "an element Mitsuba 3's scene format does not have")

    def root(self, element, folder, depth, scene_root=True):
        if element.tag not in OBJECT_TAGS:
            self.fail(element, f"<{element.tag}>", None, "the root element must be <scene> (or an object)")
        self.substitute(element)
        self.check_attributes(element, ("version",) if scene_root else (), ("version", "type", "id", "name"))
        upgrade = False
        if "version" in element.attrs:
            version = element.attrs["version"]
            parts = re.fullmatch(r"(\d+)\.(\d+)\.(\d+)", version.strip())
            if not parts:
                self.fail(element, f"<{element.tag}> version", version, 'must be "major.minor.patch", e.g. "3.0.0"')
            upgrade = int(parts.group(1)) < 2
        if element.tag != "scene" and "type" not in element.attrs:
            self.fail(element, f"<{element.tag}> type", None, "missing")
        node = self.object(element, folder, depth, upgrade)
        node[WHERE].tag = element.tag
        return node


def _camel_to_snake(name):
    """Mitsuba's camel_to_underscore_case: an uppercase letter after a lowercase one starts a new word, and the
    uppercase letters that follow it join that word (intIOR -> int_ior, maxDepth -> max_depth)."""
    out, i = [], 0
    while i < len(name):
        c = name[i]
        if i > 0 and name[i - 1].islower() and c.isupper():
            out.append("_" + c.lower())
            while i + 1 < len(name) and name[i + 1].isupper():
                i += 1
                out.append(name[i].lower())
        else:
            out.append(c)
        i += 1
    return "".join(out)


def _upgrade(node, where):
    """A version 0.x object's names as version 2 and later have them (Mitsuba's upgrade_from_v1)."""
    for name in list(node):
        if name in ("type", "id", WHERE) or name.startswith("_arg_"):
            continue
        new = _camel_to_snake(name)
        if new != name:
            node[new] = node.pop(name)
            where.params[new] = where.params.pop(name, where.at)
    if node["type"] == "diffuse" and "diffuse_reflectance" in node:
        node["reflectance"] = node.pop("diffuse_reflectance")
        where.params["reflectance"] = where.params.pop("diffuse_reflectance", where.at)


def rotation(axis, degrees):
    """Mitsuba's Transform::rotate: Rodrigues' formula c I + s [a]x + (1 - c) a a^T, counter-clockwise by
    `degrees` about a unit axis a. Mitsuba does not normalise the axis, and neither does this: an axis of length
    2 also scales (Mitsuba 3.9.1 maps rotate(z = 2, 90 degrees) to [[0, -2, 0], [2, 0, 0], [0, 0, 4]])."""
    a = np.asarray(axis, np.float64)
    s, c = math.sin(math.radians(degrees)), math.cos(math.radians(degrees))
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1 - c) * np.outer(a, a)
    return m


def look_at(origin, target, up):
    """Mitsuba's Transform::look_at: the camera's local +z along the view, +y up, +x to its left (its columns are
    left, up, direction, origin). A zero up is replaced by one orthogonal to the view, as Mitsuba's parser does;
    None where no frame exists."""
    direction = target - origin
    if not 0 < np.linalg.norm(direction) < math.inf:
        return None
    direction = direction / np.linalg.norm(direction)
    if not np.any(up):
        up = np.cross(direction, [1.0, 0.0, 0.0] if abs(direction[0]) < 0.9 else [0.0, 1.0, 0.0])
    left = np.cross(up, direction)
    if not 0 < np.linalg.norm(left) < math.inf:
        return None
    left = left / np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(direction, left), direction, origin
    return m


def read(path, defines=None, text=None):
    """Mitsuba's dict form of the XML scene file at `path` (or of `text`, its files then relative to the
    current folder), with `defines` ({name: value}, as -D name=value) for its $name parameters."""
    reader = _Reader({k: str(v) for k, v in (defines or {}).items()})
    if text is None:
        element = reader.file(path)
        folder = Path(path).parent
    else:
        element = _parse(text.encode("utf-8"), str(path))
        folder = Path(os.curdir)
    try:
        scene = reader.root(element, folder, 0)
    except RecursionError:  # the files are read recursively: elements deep in includes deep in includes
        raise InputError(path, "include", None, "elements and includes nested too deeply") from None
    scene[WHERE].search, scene[WHERE].aliases = reader.search, reader.aliases
    return scene
