"""The Python API's entries fuzzed: dicts for raytrace.load_dict built from generated scenes and damaged (wrong
types, keys that are not strings, deep and self-referencing nesting, numpy values, objects no TOML holds,
unknown keys: DamagedDict), and edits of raytrace.parameters(scene) (set, get and del of names made from the
scene's own, well- or ill-formed, with values of any kind: Edit), and their contract (check_refusal, checked_call,
render_tiny).

The API's contract: a call returns, or raises raytrace.InputError, whose text is one line; a KeyError only where
the Mapping protocol promises one (params[name], del params[name] and params[name] = value for a name that is
not the path of a value or of its place in the scene); no Python warning but the FeaturesChanged update() gives;
update() that refuses leaves the scene as it was (its fingerprint, its source) and discard() then gives a scene
that renders; every scene accepted renders (8 x 8, 1 sample) with no NaN or infinity zeroed."""
import collections
import copy
import dataclasses
import datetime
import decimal
import enum
import fractions
import pathlib
import traceback
import types
import warnings

import numpy as np
from hypothesis import strategies as st

import raytrace
from raytrace.parameters import FeaturesChanged

from .contract import EXAMPLE_SECONDS, ContractBroken, time_limit
from .scenes import EXTRA_KEYS, hostile_values, mutations, node_at


class Level(enum.IntEnum):
    """An int that is not one by type (an IntEnum member)."""
    HIGH = 3


class Ratio(float):
    """A float subclass."""


class Name(str):
    """A str subclass."""


def odd_object(kind, current=None):
    """A value of a type no TOML file gives (built when the example runs, so that Hypothesis prints its name)."""
    values = current if isinstance(current, list) else [1.0, 2.0, 3.0]
    return {
        "set": lambda: set(values[:3]) if all(isinstance(v, (int, float, str)) for v in values) else {1.0},
        "tuple": lambda: tuple(values), "bytes": lambda: b"\x00camera", "bytearray": lambda: bytearray(b"12"),
        "range": lambda: range(3), "complex": lambda: 1 + 2j, "decimal": lambda: decimal.Decimal("1.5"),
        "decimal nan": lambda: decimal.Decimal("NaN"), "fraction": lambda: fractions.Fraction(1, 3),
        "object": object, "none": lambda: None, "huge int": lambda: 10**400, "int enum": lambda: Level.HIGH,
        "float subclass": lambda: Ratio(0.5), "str subclass": lambda: Name("grid"),
        "date": lambda: datetime.date(2020, 1, 1),
        "datetime": lambda: datetime.datetime(2020, 1, 1, 12), "path": lambda: pathlib.Path("grid.png"),
        "mapping proxy": lambda: types.MappingProxyType({"x": 1.0}),
        "ordered dict": lambda: collections.OrderedDict(current if isinstance(current, dict) else {}),
        "user dict": lambda: collections.UserDict(current if isinstance(current, dict) else {}),
        "user list": lambda: collections.UserList(values), "generator": lambda: (v for v in values),
        "numpy str": lambda: np.str_("grid"), "numpy datetime": lambda: np.datetime64("2020-01-01"),
        "numpy void": lambda: np.void(b"\x00\x01"), "function": lambda: len,
    }[kind]()


ODD_OBJECTS = ("set", "tuple", "bytes", "bytearray", "range", "complex", "decimal", "decimal nan", "fraction", "object",
               "none", "huge int", "int enum", "float subclass", "str subclass", "date", "datetime", "path",
               "mapping proxy", "ordered dict", "user dict", "user list", "generator", "numpy str", "numpy datetime",
               "numpy void", "function")
NUMPY_KINDS = ("float64", "float32", "float16", "int64", "int32", "int8", "uint8", "uint64", "bool", "complex64",
               "object", "scalar", "0-d", "2-d", "column", "masked", "matrix", "empty", "longdouble")


def as_numpy(value, kind):
    """`value` (a number or a list of them, as a scene holds) as numpy gives it: an array of `kind`'s dtype, a
    numpy scalar, a 0-d, 2-d or masked array... (the value itself where numpy cannot make it so)."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if kind == "scalar":
                return np.float32(value) if isinstance(value, float) else np.int64(value) if isinstance(value, int) \
                    else np.asarray(value)[()]
            if kind == "0-d":
                return np.array(value[0] if isinstance(value, list) and value else value)
            if kind == "2-d":
                return np.asarray(value).reshape(1, -1)
            if kind == "column":
                return np.asarray(value).reshape(-1, 1)
            if kind == "masked":
                return np.ma.masked_array(np.atleast_1d(np.asarray(value, float)), mask=True)
            if kind == "matrix":
                return np.asmatrix(np.atleast_1d(np.asarray(value, float)))
            if kind == "empty":
                return np.empty((0,))
            return np.asarray(value, dtype={"bool": np.bool_, "longdouble": np.longdouble}.get(kind, kind))
        except (TypeError, ValueError, OverflowError):
            return value


def nested(depth, kind):
    value = 1.0
    for _ in range(depth):
        value = [value] if kind == "list" else {"a": value}
    return value


@dataclasses.dataclass(frozen=True)
class Value:
    """A value to put somewhere, made when the example runs from the value there now (`current`) and the whole
    table (`root`): a plain hostile one, the current one as numpy gives it, an object no TOML holds, deep
    nesting, or a table or list that holds itself (or the whole scene)."""
    kind: str  # plain, numpy, odd, nested, self
    plain: object = None
    numpy: str = "float32"
    odd: str = "set"
    depth: int = 40
    nest: str = "list"  # list, dict; for self: list, dict, root

    def make(self, current, root):
        if self.kind == "numpy":
            return as_numpy(current, self.numpy)
        if self.kind == "odd":
            return odd_object(self.odd, current)
        if self.kind == "nested":
            return nested(self.depth, self.nest)
        if self.kind == "self":
            if self.nest == "root":
                return root
            loop = [] if self.nest == "list" else {}
            loop.append(loop) if self.nest == "list" else loop.update(x=loop)
            return loop
        return copy.deepcopy(self.plain)


def values():
    return st.one_of(
        st.builds(Value, st.just("plain"), hostile_values()),
        st.builds(Value, st.just("numpy"), numpy=st.sampled_from(NUMPY_KINDS)),
        st.builds(Value, st.just("numpy"), numpy=st.sampled_from(NUMPY_KINDS)),
        st.builds(Value, st.just("odd"), odd=st.sampled_from(ODD_OBJECTS)),
        st.builds(Value, st.just("nested"), depth=st.sampled_from([2, 31, 32, 33, 34, 200, 5000]),
                  nest=st.sampled_from(["list", "dict"])),
        st.builds(Value, st.just("self"), nest=st.sampled_from(["list", "dict", "root"])))


# --- damaged dicts for load_dict -------------------------------------------------------------------------------

NON_STRING_KEYS = (0, 1.5, None, True, ("camera",), b"camera", frozenset(), -1)


@dataclasses.dataclass(frozen=True)
class Damage:
    """One change to a dict: `where` picks a node (an index modulo their number; `at`, a path of keys, names one
    instead); a hostile_scenes Mutation, a Value put there, a key that is not a string added to the nearest table
    (or a key made numpy's), or the whole dict replaced."""
    op: str  # mutation, value, non-string key, numpy key, whole
    where: int
    mutation: object = None
    value: Value = None
    key: object = 0
    at: tuple = None

    def apply(self, table):
        if self.op == "mutation":
            self.mutation.apply(table)
            return table
        paths = list(bounded_paths(table))
        path = self.at if self.at is not None else paths[self.where % len(paths)]
        node = node_at(table, path)
        if self.op in ("non-string key", "numpy key"):
            while not isinstance(node, dict):
                path = path[:-1]
                node = node_at(table, path)
            if self.op == "numpy key" and node:  # a key the table has, as numpy's str (a str) or an int64 (not one)
                first = next(iter(node))
                node[np.str_(first) if self.key else np.int64(1)] = node.pop(first)
            else:
                node[self.key] = copy.deepcopy(node[next(iter(node))]) if node else 1.0
            return table
        if self.op == "whole":
            return self.value.make(table, table)
        if not path:
            return self.value.make(table, table)
        node_at(table, path[:-1])[path[-1]] = self.value.make(node, table)
        return table


def bounded_paths(node, prefix=(), seen=None):
    """node_paths, not going round a table or list that holds itself (an earlier damage's) nor deeper than 40."""
    seen = set() if seen is None else seen
    yield prefix
    if len(prefix) > 40 or id(node) in seen or not isinstance(node, (dict, list)):
        return
    seen.add(id(node))
    for key, value in (node.items() if isinstance(node, dict) else enumerate(node)):
        yield from bounded_paths(value, prefix + (key,), seen)


@dataclasses.dataclass(frozen=True)
class DamagedDict:
    """A scene's table (SceneExample's) with `damages` applied in order, as load_dict is given it: build()."""
    table: dict
    damages: tuple

    def build(self):
        """The damaged dict; the damages that make it recursive or deep (or replace it) go last, as the others walk
        its nodes."""
        table = copy.deepcopy(self.table)
        for damage in sorted(self.damages, key=lambda d: d.op == "whole" or (
                d.op == "value" and d.value.kind in ("self", "nested"))):
            if not isinstance(table, dict):
                break
            table = damage.apply(table)
        return table


def damages():
    """Damages, mostly one: most often a Mutation or a Value (numpy ones the most), sometimes a key that is not a
    string (or a numpy one), rarely the whole dict replaced."""
    where = st.integers(0, 1008)
    damage = st.one_of(
        mutations().map(lambda ms: Damage("mutation", 0, ms[0])),
        st.builds(Damage, st.just("value"), where, value=values()),
        st.builds(Damage, st.just("value"), where, value=st.builds(Value, st.just("numpy"),
                                                                   numpy=st.sampled_from(NUMPY_KINDS))),
        st.builds(Damage, st.just("non-string key"), where, key=st.sampled_from(NON_STRING_KEYS)),
        st.builds(Damage, st.just("numpy key"), where, key=st.booleans()),
        st.builds(Damage, st.just("whole"), where, value=values()))
    return st.lists(damage, min_size=0, max_size=3).map(tuple)


# --- parameter edits ---------------------------------------------------------------------------------------------

MALFORMED_NAMES = ("", ".", "[0]", "lights[", "lights]", "lights[-1].colour", "lights[0]..colour", "camera.", ".camera",
                   "camera fov", "a\nb", "camera.fov ", " camera.fov", "lights[00].colour", "lights[\u0660].colour",
                   "lights[ 0 ]", "shapes[99999999999999999999]", "camera.fov.x", "camera[0]", "lights.0.colour",
                   "materials", "é", "\x00", "lights[0][0]", "camera..fov")
ODD_NAMES = (0, None, ("camera", "fov"), b"camera.fov", 1.5, np.str_("camera.fov"), Name("camera.fov"), ["camera"])
NAME_KINDS = ("existing", "existing", "existing", "child", "parent", "next index", "new key", "malformed", "odd")


@dataclasses.dataclass(frozen=True)
class Edit:
    """One access of a SceneParameters: `op` set, del or get of a name made (name()) from the scene's own names
    (`pick`, an index modulo their number): one of them, a name below or above it, the next element of an array
    of tables, a new key in its table, a malformed name or one of another type (or, of kind "given", `extra`
    itself); a set puts `value` there, made from the value the name holds now."""
    op: str
    kind: str
    pick: int
    extra: object
    value: Value

    def name(self, names):
        if self.kind == "given":
            return self.extra
        if self.kind == "malformed":
            return MALFORMED_NAMES[self.pick % len(MALFORMED_NAMES)]
        if self.kind == "odd":
            return ODD_NAMES[self.pick % len(ODD_NAMES)]
        name = names[self.pick % len(names)] if names else "camera.fov"
        if self.kind == "child":
            return name + [".x", "[0]", "[1]", ".colour", "[3]"][self.pick % 5]
        if self.kind == "parent":
            cut = max(name.rfind("."), name.rfind("["))
            return name[:cut] if cut > 0 else name
        if self.kind == "next index":  # lights[N] or shapes[N] (N the count: an edit may add it), or N + 1
            head = name.split("[", 1)[0].split(".", 1)[0]
            indices = {n[len(head):].split("]", 1)[0] for n in names if n.startswith(head + "[")}
            return f"{head}[{len(indices) + self.pick % 2}]"
        if self.kind == "new key":
            parent = name[:name.rfind(".")] if "." in name else name
            return f"{parent}.{self.extra}"
        return name

    def current(self, params, name):
        """What the name holds now (for a new element, the first of its array: a valid table to start from)."""
        try:
            return params[name]
        except (KeyError, TypeError):
            if self.kind == "next index":
                return params.get(name.split("[", 1)[0] + "[0]")
            return None


def edits():
    op = st.sampled_from(["set", "set", "set", "del", "get"])
    return st.lists(st.builds(Edit, op, st.sampled_from(NAME_KINDS), st.integers(0, 1000),
                              st.sampled_from(EXTRA_KEYS), values()), min_size=1, max_size=4).map(tuple)


# --- the contract ------------------------------------------------------------------------------------------------

class APIContractBroken(ContractBroken):
    pass


class UnexpectedException(APIContractBroken):
    """An exception other than InputError (or the Mapping protocol's KeyError) left the API."""


class NotOneLineError(APIContractBroken):
    pass


class WrongErrorSource(APIContractBroken):
    pass


class WarningFromTheAPI(APIContractBroken):
    pass


class SceneChangedByRefusal(APIContractBroken):
    pass


class AcceptedSceneFailsToRender(APIContractBroken):
    pass


class NonFiniteRender(APIContractBroken):
    pass


class UpdateDisagreesWithLoad(APIContractBroken):
    pass


_unexpected = {}


def _raise_unexpected(what, e):
    where = traceback.extract_tb(e.__traceback__)
    where = f"{where[-1].filename.rsplit('/', 2)[-1]}:{where[-1].lineno}" if where else "?"
    kind = _unexpected.setdefault((type(e), where), type(f"Unexpected{type(e).__name__}", (UnexpectedException,), {}))
    tail = "".join(traceback.format_exception(e, limit=-8))[-3000:]
    raise kind(f"{type(e).__name__} from {what}, raised at {where}: {str(e)[:300]}\n{tail}") from None


def checked_call(what, call, allowed=(), warned=(FeaturesChanged,), check_warning=None):
    """(result, InputError or an `allowed` exception or None) of call(); any other exception, or a Python warning
    of no category in `warned`, breaks the contract; `check_warning(w)`, where given, checks each warning of
    those categories in turn (it raises where one breaks the contract)."""
    result, error = None, None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for hidden in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
            warnings.simplefilter("ignore", hidden)
        try:
            with time_limit(EXAMPLE_SECONDS):
                result = call()
        except (raytrace.InputError, *allowed) as e:
            error = e
        except Exception as e:  # noqa: BLE001 - the contract's very question
            _raise_unexpected(what, e)
    for w in caught:
        if not issubclass(w.category, warned):
            shown = warnings.formatwarning(w.message, w.category, w.filename, w.lineno)
            raise WarningFromTheAPI(f"{what} warned: {shown}")
        if check_warning is not None:
            check_warning(w)
    return result, error


def check_refusal(what, error, sources):
    """An InputError's text is one line, and starts with one of `sources`."""
    text = str(error)
    if "\n" in text or "\r" in text:
        raise NotOneLineError(f"{what}: the InputError's text is not one line: {text!r}")
    if not any(text.startswith(f"{source}: ") for source in sources):
        raise WrongErrorSource(f"{what}: the error names none of {sorted(sources)}: {text!r}")


def render_tiny(what, scene):
    """The scene renders, 8 x 8 at 1 sample, with nothing for the renderer to zero."""
    result, error = checked_call(f"render() after {what}", lambda: raytrace.render(
        scene, width=8, height=8, spp=1, light_samples=1, progress=False))
    if error is not None:
        raise AcceptedSceneFailsToRender(f"{what} accepted a scene that render() refuses: {error}")
    image, stats = result
    if stats.extra["nonfinite_values"] != 0 or not np.isfinite(image).all():
        raise NonFiniteRender(f"{what}: the render made {stats.extra['nonfinite_values']} NaN or infinite values")


def walk(value, depth=0, seen=None):
    """(key, value) of every entry under `value` (dicts, lists, tuples; keys None in lists), not going round a
    table that holds itself nor deeper than 40."""
    seen = set() if seen is None else seen
    if depth > 40 or id(value) in seen:
        return
    if isinstance(value, dict):
        seen.add(id(value))
        for k, v in list(value.items()):
            yield k, v
            yield from walk(v, depth + 1, seen)
    elif isinstance(value, (list, tuple)):
        seen.add(id(value))
        for v in value:
            yield None, v
            yield from walk(v, depth + 1, seen)


def costly(value, name=""):
    """A generated mesh of more than 200,000 triangles under `value` (or `value` itself, put at `name`): valid,
    and only slow to build (as contract.cost_flags leaves out of the command line's examples)."""
    def big(v):
        try:
            return not isinstance(v, (str, bytes)) and float(np.asarray(v, dtype=float).max()) > 200_000
        except Exception:  # noqa: BLE001 - anything numpy cannot make a number of is no triangle count
            return False
    return (name.endswith("triangles") and big(value)) or any(k == "triangles" and big(v) for k, v in walk(value))


def strings_in(value):
    """Every string under `value`: the files an edit or a dict may name, which an error may name first."""
    return [v for _, v in walk({"": value}) if isinstance(v, str)]
