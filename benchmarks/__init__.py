"""Developer rigs that measure the renderer, run from a checkout and never installed:
`python -m benchmarks.baseline` (this kernel against another commit's, in one process),
`python -m benchmarks.embree_anchor` (bench --scaling beside Embree), `python -m benchmarks.dask_overhead`
(what a Dask cluster costs) and `python -m benchmarks.against_reference` (our image against another
renderer's), `python -m benchmarks.record` (a bench run as a measurement record). Their dated results live
in benchmarks/results/, from which docs/performance.md is made."""
import sys

from raytrace.errors import InputError

EXIT_BAD_INPUT = 2


def run_rig(prog, function, *args, **kwargs):
    """function(*args, **kwargs) as a rig's main: bad input ends in one line naming it and exit status 2."""
    try:
        return function(*args, **kwargs) or 0
    except InputError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
