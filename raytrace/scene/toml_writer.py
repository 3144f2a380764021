"""Writing TOML (tomllib only reads): a scene table as a scene file lays it out (scene_toml: `raytrace convert`),
or every value inline (to_toml: the fuzz suite's hostile scenes, with NaN and infinity spelt as TOML's `nan` and
`inf`). Floats are written by repr, so that reading the text back gives the same numbers, bit for bit."""
import math
import re


BARE_KEY = re.compile(r"[A-Za-z0-9_-]+\Z")


def toml_string(text):
    escaped = []
    for ch in text:
        if ch in '"\\':
            escaped.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            escaped.append(f"\\u{ord(ch):04x}")
        else:
            escaped.append(ch)
    return '"' + "".join(escaped) + '"'


def toml_key(key):
    return key if BARE_KEY.match(key) else toml_string(key)


def toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)  # always has a '.' or an exponent: 1e+39 stays a float
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(map(toml_value, value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {value!r}")


def to_toml(table):
    """The table as TOML text, every value inline (one line per top-level key)."""
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in table.items())


def scene_toml(table):
    """A scene table as a scene file lays it out: its plain values first, then each table ([camera], ...), the
    named tables' tables ([materials.NAME]) and the arrays of tables ([[lights]], [[shapes]]), their values
    inline."""
    def body(t):
        return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in t.items())

    def tables_of(value):
        return isinstance(value, list) and value and all(isinstance(v, dict) for v in value)

    plain = {k: v for k, v in table.items() if not isinstance(v, dict) and not tables_of(v)}
    parts = [body(plain)] if plain else []
    for key, value in table.items():
        if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
            parts += [f"[{toml_key(key)}.{toml_key(name)}]\n{body(sub)}" for name, sub in value.items()]
        elif isinstance(value, dict):
            parts.append(f"[{toml_key(key)}]\n{body(value)}")
        elif tables_of(value):
            parts += [f"[[{toml_key(key)}]]\n{body(sub)}" for sub in value]
    return "\n".join(parts)
