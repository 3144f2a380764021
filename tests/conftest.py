"""Shared fixtures: the OpenCL device (real PoCL), and a harness that runs small test kernels over
LANES-wide inputs so every kernel function is checked at both widths the renderer uses (shared helpers
that are not fixtures are in helpers.py)."""
import pytest

from helpers import ROOT
from raytrace.renderer.cpu_target import apply_target
from raytrace.renderer.device import context_for, select_device
from raytrace.structs import LANE_WIDTHS
from raytrace.scene import load_file
from raytrace.commands.stability.probe import Probe


@pytest.fixture(scope="session")
def device():
    return select_device(None)


@pytest.fixture(scope="session")
def cl_env(device):
    return context_for(device)


@pytest.fixture(scope="session")
def cornell():
    return load_file(ROOT / "scenes" / "cornell.toml")


def runnable_lane_widths():
    """Every lane width the kernel accepts that this machine's target runs (cpu_target.py): 1, 4, 8 and, on
    AVX-512, 16."""
    target = apply_target(select_device(None))
    return [n for n in LANE_WIDTHS if n > 0 and (target is None or n <= target.lanes_max)]


@pytest.fixture(params=runnable_lane_widths(), ids=lambda n: f"lanes{n}")
def lanes(request):
    return request.param


@pytest.fixture
def harness(cl_env, lanes):
    """Runs small test kernels (raytrace/commands/stability/probe.py) at this lane width on the session's context."""
    return Probe(lanes, env=cl_env)

