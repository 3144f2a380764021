"""The one error type a user sees: bad input, reported as one line, exit status 2; and the one line a signal
ends the command line with. The standard library's signal module only: the package binds interrupted_line
before it takes any time to import (__init__.py)."""
import signal


API = "render()"  # the source an error names for a keyword argument of render() (the command line renames it)
POSITIVE_SECONDS = "must be a positive number of seconds"  # render()'s time_limit, converge's --montage-seconds


class InputError(Exception):
    """Bad user input: a scene file, a texture, a command-line value.

    `source` names the file (or "command line"), `key` the offending key or option, `value` its value.
    """

    def __init__(self, source, key, value, problem):
        self.source, self.key, self.value, self.problem = str(source), key, value, problem
        shown = "" if value is None else f" = {value!r}"
        super().__init__(f"{printable(self.source)}: {printable(str(key))}{shown}: {printable(str(problem))}")

    def __reduce__(self):  # raised on a Dask worker, it reaches the client whole
        return InputError, (self.source, self.key, self.value, self.problem)


def printable(text):
    """`text` with its control characters escaped as Python writes them ("a\\nb"): a file name or a TOML
    key may hold a newline, and the error stays one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def interrupted_line(signum, written=False):
    """The command line's one line for a signal that ended it."""
    done = "its outputs were written" if written else "nothing written"
    return f"raytrace: interrupted by {signal.Signals(signum).name}; {done}"
