"""Tools that measure and verify the renderer: bench, scaling, converge, stability, compile, probe (small test
kernels), figures and assets. They use the renderer; the renderer never imports them."""
import importlib.util
import os
from pathlib import Path

from ..errors import missing_extra

ROOT = Path(__file__).resolve().parents[2]


def require_extra(command, extra, *modules):
    """Refuse `command` before any work when a module of the package's `extra` is not installed (a plain
    `pip install .` has none): one line naming the extra, rather than a ModuleNotFoundError after minutes."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise missing_extra(command, extra, missing)


def child_env(env=None, **variables):
    """`env` (default this process's environment) with `variables`, for a child `python -m raytrace`: this
    checkout first on PYTHONPATH, before whatever the environment already had there (a site folder of its
    own where the packages are not installed, as .ci/gpu's --site)."""
    env = {**(os.environ if env is None else env), **variables}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env
