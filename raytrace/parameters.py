"""A loaded scene's values by name, to read and edit, as Mitsuba 3's mi.traverse gives them:

    params = raytrace.parameters(scene)
    params["materials.red.colour"] = [0.8, 0.1, 0.1]
    params["lights[0].size"] = [0.4, 0.4]
    params.update()            # the whole scene checked again; applied to `scene` in place

The names are the paths of the scene file's values (docs/scene-format.md): `camera.fov`, `image.width`,
`render.spp`, `lights[0].colour`, `materials.NAME.shininess`, `shapes[3].center`, `shapes[4].generate.triangles`.
An assignment is only staged; update() applies every staged edit to the scene's source table and reads the
result through the very checks a file's values go through (scene_file.py: types, ranges, finiteness, the
shapes' geometry, the float32 rules of ranges.py). A bad value raises InputError naming it, and the scene is
left as it was. An edit that changes what the kernel is compiled with (a texture, the shading model, smooth
normals) is reported by a FeaturesChanged warning: the next render builds that variant once.
"""
import copy
import dataclasses
import re
import warnings
from collections.abc import MutableMapping

from .errors import InputError
from .renderer.program import Features
from .scene.model import SCENE_EXPECTED, Scene
from .scene.scene_file import parse_scene, plain

_STEP = re.compile(r"\[(\d+)\]|([^.\[\]]+)")
_DELETED = object()


class FeaturesChanged(UserWarning):
    """An edit changed what the kernel is compiled with: the next render builds another program, once."""


def _steps(name):
    """`lights[0].colour` -> ["lights", 0, "colour"]; KeyError for a name that is not such a path."""
    steps = [int(index) if index else key for index, key in _STEP.findall(name)]
    if not steps or isinstance(steps[0], int) or _name(steps) != name:
        raise KeyError(name)
    return steps


def _name(steps):
    return "".join(f"[{s}]" if isinstance(s, int) else (f".{s}" if k else s) for k, s in enumerate(steps))


def _leaves(node, steps=()):
    """(steps, value) of every value that is not a table or an array of tables."""
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _leaves(value, (*steps, key))
    elif isinstance(node, list) and node and all(isinstance(v, dict) for v in node):
        for k, value in enumerate(node):
            yield from _leaves(value, (*steps, k))
    else:
        yield steps, node


class SceneParameters(MutableMapping):
    """The values of a scene loaded by load_file, load_dict or load_string, by name (see the module's text):
    params[name] reads a value (an edit once staged), params[name] = value stages an edit (a value may also be
    given for a key the scene leaves to its default), del params[name] stages its removal, update() checks
    and applies them, discard() drops them. Iterating gives the names of the values the scene's source holds."""

    def __init__(self, scene):
        if not isinstance(scene, Scene):
            raise InputError("parameters()", "scene", type(scene).__name__, SCENE_EXPECTED)
        if scene.source is None:
            raise InputError("parameters()", "scene", type(scene).__name__, "was not read by load_file, load_dict "
                             "or load_string, so it has no source to edit")
        self._scene, self._edits = scene, {}

    def _source(self):
        return self._scene.source

    def __getitem__(self, name):
        steps = _steps(name) if isinstance(name, str) else None
        if steps is None:
            raise KeyError(name)
        key = _name(steps)
        if key in self._edits:
            if self._edits[key] is _DELETED:
                raise KeyError(name)
            return copy.deepcopy(self._edits[key])
        node = self._source()
        try:
            for step in steps:
                node = node[step]
        except (KeyError, IndexError, TypeError):
            raise KeyError(name) from None
        return copy.deepcopy(node)

    def __setitem__(self, name, value):
        steps = _steps(name) if isinstance(name, str) else None
        if steps is None:
            raise KeyError(name)
        self._parent(steps, name)
        self._edits[_name(steps)] = plain(value, f"parameters({self._scene.path})", name)

    def __delitem__(self, name):
        self[name]  # KeyError if there is no such value
        self._edits[_name(_steps(name))] = _DELETED

    def _parent(self, steps, name):
        """The table an edit of `steps` goes into must exist in the source: a new key in an existing table is
        an edit (its check comes with update()), a new table is not."""
        node = self._source()
        for step in steps[:-1]:
            try:
                node = node[step]
            except (KeyError, IndexError, TypeError):
                raise KeyError(f"{name}: the scene has no {_name(steps[:steps.index(step) + 1])}") from None
        if not isinstance(node, (dict, list)) or isinstance(steps[-1], int) != isinstance(node, list):
            raise KeyError(name)  # an index into a table, a key into an array
        if isinstance(node, list) and steps[-1] > len(node):  # an edit may add the next element, no further
            raise KeyError(f"{name}: {_name(steps[:-1])} has {len(node)} elements; an edit may add "
                           f"{_name([*steps[:-1], len(node)])}")

    def __iter__(self):
        names = [_name(steps) for steps, _ in _leaves(self._source())]
        names += [k for k, v in self._edits.items() if v is not _DELETED and k not in names]
        return iter([n for n in names if self._edits.get(n) is not _DELETED])

    def __len__(self):
        return sum(1 for _ in self)

    def __repr__(self):
        return f"SceneParameters({self._scene.path}: {len(self)} values, {len(self._edits)} staged)"

    def update(self):
        """Check the scene with every staged edit, as a file holding those values would be checked, and apply
        them to the scene in place; returns the names that changed. Raises InputError (the scene unchanged
        and the edits still staged) at the first bad value."""
        if not self._edits:
            return set()
        table = copy.deepcopy(self._source())
        scene = self._scene
        for key, value in self._edits.items():
            try:
                _apply(table, _steps(key), value)
            except (KeyError, IndexError, TypeError):  # its place went with another edit (del params["camera"])
                raise InputError(f"parameters({scene.path})", key, None if value is _DELETED else value,
                                 "has no place in the edited scene: another staged edit removed or replaced "
                                 "what holds it (discard() drops the staged edits)") from None
        try:
            edited = parse_scene(table, scene.path)
        except InputError as e:
            raise InputError(f"parameters({scene.path})", e.key, e.value, e.problem) from None
        before, after = Features.of(scene, 16), Features.of(edited, 16)  # 16 lanes: every scene has a BVH
        for f in dataclasses.fields(scene):
            if f.name != "revision":
                setattr(scene, f.name, getattr(edited, f.name))
        scene.revision += 1
        changed, self._edits = set(self._edits), {}
        if before != after:
            what = ", ".join(f"{f.name} {'on' if getattr(after, f.name) else 'off'}" for f in dataclasses.fields(after)
                             if getattr(before, f.name) != getattr(after, f.name))
            warnings.warn(f"the edit changes the kernel's features ({what}): the next render builds that "
                          "variant once", FeaturesChanged, stacklevel=2)
        return changed

    def discard(self):
        """Drop every staged edit (after an update() that refused one, say); the scene is as it was."""
        self._edits = {}


def _apply(table, steps, value):
    """One staged edit applied to a copy of the source table."""
    node = table
    for step in steps[:-1]:
        node = node[step]
    if value is _DELETED:
        del node[steps[-1]]
    elif isinstance(node, list) and steps[-1] == len(node):
        node.append(value)
    else:
        node[steps[-1]] = value


def parameters(scene):
    """The editable values of `scene` by name: a SceneParameters (see its help)."""
    return SceneParameters(scene)
