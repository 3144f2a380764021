"""Tools that measure and verify the renderer: bench, scaling, converge, stability, compile, probe (small test
kernels), figures and assets. They use the renderer; the renderer never imports them."""
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def child_env(env=None, **variables):
    """`env` (default this process's environment) with `variables`, for a child `python -m raytrace`: this
    checkout first on PYTHONPATH, before whatever the environment already had there (a site folder of its
    own where the packages are not installed, as .ci/gpu's --site)."""
    env = {**(os.environ if env is None else env), **variables}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env
