"""What several cases share: the Row each case returns, the Env they run on, the scene files, and small helpers
(unit vectors, stored struct fields, NaN and Inf counts, the brightest possible value, closest_hit over a scene of
a few shapes)."""
import dataclasses
from pathlib import Path

import numpy as np

from .probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, Probe, planar, scene_args
from ...render import render
from ...scene import load_file

SCENES = Path(__file__).resolve().parents[3] / "scenes"
SCENE0 = SCENES / "cornell.toml"
TINY = 2.0**-126  # the smallest normal float32: results below it may be subnormal or flushed to zero


@dataclasses.dataclass
class Row:
    measured: str
    error: float
    unit: str
    bound: float
    why: str               # the bound, argued in one phrase
    nonfinite: int = 0     # NaN and Inf values seen
    known_limit: bool = False
    skipped: bool = False  # not measured, for the reason given in `measured`
    case: str = ""

    @property
    def verdict(self):
        if self.skipped:
            return "skipped"
        if not (self.error <= self.bound and self.nonfinite == 0):  # a NaN error fails too
            return "FAIL"
        return "known limit" if self.known_limit else "pass"


class Env:
    """What the cases run on: a probe at one lane width, renders at the same width, scene 0."""

    def __init__(self, lanes, device=None):
        self.lanes, self.device = lanes, device
        self.probe = Probe(lanes, device)
        self.cornell = load_file(SCENE0)

    def render(self, scene, **kwargs):
        """(image, its NaN and Inf values: render() zeroes them and counts them in its stats)."""
        image, stats = render(scene, lanes=self.lanes, device=self.device, progress=False, **kwargs)
        return image, stats.extra["nonfinite_values"]


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def stored(struct, key):
    """A field of a packed struct: the float32 values the kernel reads, in float64."""
    return np.asarray(struct[key], np.float64)


def nonfinite(*arrays):
    return int(sum(np.count_nonzero(~np.isfinite(a)) for a in arrays))


def hit_nonfinite(hit):
    """NaN and Inf in a closest_hit(): t is finite or +inf, p and n finite where t is."""
    hits = np.isfinite(hit["t"])
    return nonfinite(hit["t"][~np.isinf(hit["t"])], hit["p"][hits], hit["n"][hits])


def outside(images, limit):
    return sum(int(np.count_nonzero((a < 0) | (a > limit))) for a in images)


# ---------------------------------------------------------------------------------------------------------
# closest_hit over a scene of a few shapes

def shapes(env, rectangles=(), triangles=(), ellipsoids=(), disks=(), cylinders=()):
    """Scene 0's materials and camera with only these shapes and no lights."""
    return dataclasses.replace(env.cornell, lights=[], rectangles=list(rectangles), triangles=list(triangles),
                               ellipsoids=list(ellipsoids), disks=list(disks), cylinders=list(cylinders))


def closest_hit(env, scene, o, d):
    """The kernel's closest hit of rays (o, d), (n, 3) float32 values: {t, p, err, n}; the rays are padded
    to whole work-items by repeating the last one."""
    n = len(o)
    padded = -(-n // env.lanes) * env.lanes
    o, d = (np.concatenate([a, np.repeat(a[-1:], padded - n, axis=0)]) for a in (o, d))
    out = env.probe.run(CLOSEST_HIT, "closest", padded, {**scene_args(scene), "o": planar(o), "d": planar(d)}, CLOSEST_HIT_OUTPUTS,
                        HAS_RECTANGLES=bool(scene.rectangles), HAS_TRIANGLES=bool(scene.triangles),
                        HAS_ELLIPSOIDS=bool(scene.ellipsoids), HAS_DISKS=bool(scene.disks),
                        HAS_CYLINDERS=bool(scene.cylinders))
    return {"t": out["t"][:n], "p": out["p"].T[:n], "err": out["err"][:n], "n": out["nrm"].T[:n]}
