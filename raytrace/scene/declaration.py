"""The declaration of one key of a scene file (Key): its type, default and accepted range. keys.py's tables of a
scene file's keys are made of them, bsdfs.py's BSDF parameters too; scene_file.py's reader checks each value
against its key's declaration, and the manual's tables are generated from them."""
import math
from dataclasses import dataclass

REQUIRED = object()


@dataclass(frozen=True)
class Key:
    """One key of a table. `kind` is one of number, integer, string, boolean, vector (`length` numbers),
    vectors (a list of `count` vectors of `length` numbers, any count when None), number-or-vector,
    number-or-name (a number, or a name of `named`, (name, number) pairs, in any case, as Mitsuba looks up its
    named media), path, faces, strings (a list of `length` names), table, tables (an array of tables) or named-tables (a
    table of tables). Numbers
    lie in [low, high] (open at an end with open_low, open_high); vectors' components are at least `low`."""
    name: str
    kind: str
    doc: str
    default: object = REQUIRED
    low: float = -math.inf
    high: float = math.inf
    open_low: bool = False
    open_high: bool = False
    length: int = 0
    count: int | None = None
    choices: tuple = ()
    nonzero: bool = False
    also: str = ""
    named: tuple = ()

    @property
    def required(self):
        return self.default is REQUIRED
