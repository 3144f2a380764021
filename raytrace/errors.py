"""The one error type a user sees: bad input, reported as one line, exit status 2; and the one line a signal
ends the command line with. The standard library's signal module only: the package binds interrupted_line
before it takes any time to import (__init__.py)."""
import signal


# Characters of a value an error line shows at most: a million-item list is not a line, but a file's path is
# what the user needs whole (a hostile megabyte-long string is still cut).
SHOWN, SHOWN_TEXT = 80, 400
API = "render()"  # the source an error names for a keyword argument of render() (the command line renames it)
POSITIVE_SECONDS = "must be a positive number of seconds"  # render()'s time_limit, converge's --montage-seconds
TRUE_OR_FALSE = "must be True or False"  # a bool from Python: a material's two_sided, render()'s denoise


class InputError(Exception):
    """Bad user input: a scene file, a texture, a command-line value.

    `source` names the file (or "command line"), `key` the offending key or option, `value` its value.
    """

    def __init__(self, source, key, value, problem):
        self.source, self.key, self.value, self.problem = str(source), key, value, problem
        shown = "" if value is None else f" = {shortened(repr(value), SHOWN_TEXT if isinstance(value, str) else SHOWN)}"
        super().__init__(f"{printable(self.source)}: {printable(shortened(str(key), SHOWN_TEXT))}{printable(shown)}: "
                         f"{printable(str(problem))}")

    def __reduce__(self):  # raised on a Dask worker, it reaches the client whole
        return InputError, (self.source, self.key, self.value, self.problem)


class UnsupportedWarning(UserWarning):
    """What a scene asks that raytrace left out (a Mitsuba plugin it does not render, with ignore_unsupported),
    or where raytrace's model differs from what the scene asks: one per kind, one line each."""


def missing_extra(command, extra, missing):
    """The InputError for `command`, which needs the package's `extra`, whose modules `missing` are not
    installed: one line naming the extra (commands.require_extra's, raytrace.denoise's)."""
    return InputError("environment", command, None, f"needs the {extra} extra ({', '.join(missing)} "
                      f"missing): pip install \"raytrace[{extra}]\", or -e \".[{extra}]\" in a checkout")


def check_path(path, source, key):
    """`path` as a str: a str or an os.PathLike that gives one (bytes are refused, not shown as "b'x.exr'" and
    called an unknown extension), with no NUL character."""
    import os  # here, as did_you_mean's difflib: the package binds interrupted_line before any other import
    fspath = os.fspath(path) if isinstance(path, (str, os.PathLike)) else None
    if not isinstance(fspath, str):
        raise InputError(source, key, path, "must be a str or os.PathLike path")
    if "\0" in fspath:
        raise InputError(source, key, fspath, "holds a NUL character, which no file name can")
    return fspath


def shortened(text, limit=SHOWN):
    """`text` cut to `limit` characters, its middle left out and marked: both ends of a value tell the most."""
    if len(text) <= limit:
        return text
    head = (limit - 5) * 2 // 3
    return f"{text[:head]} ... {text[len(text) - (limit - 5 - head):]}"


def did_you_mean(given, known, lead=",", synonyms=None):
    """", did you mean 'colour'?" when `given` is one of `synonyms` (another renderer's word for a name we
    know: {given: ours}) or close to one of `known` (difflib's ratio of at least 0.6), else "": a misspelt or
    borrowed key, name or option is the newcomer's first error."""
    import difflib  # here, not at the top: the package binds interrupted_line before any slow import
    if not isinstance(given, str):
        return ""
    close = [synonyms[given]] if given in (synonyms or {}) else difflib.get_close_matches(
        given, [str(k) for k in known], n=1)
    return f"{lead} did you mean {close[0]!r}?" if close else ""


def printable(text):
    """`text` with its control characters escaped as Python writes them ("a\\nb"): a file name or a TOML
    key may hold a newline, and the error stays one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def interrupted_line(signum, written=False):
    """The command line's one line for a signal that ended it."""
    done = "its outputs were written" if written else "nothing written"
    return f"raytrace: interrupted by {signal.Signals(signum).name}; {done}"
