"""Shared fixtures: the OpenCL device (real PoCL), and a harness that runs small test kernels over
LANES-wide inputs so every kernel function is checked at both widths the renderer uses (shared helpers
that are not fixtures are in helpers.py)."""
import pytest

from helpers import ROOT, lane_id, runnable_lane_widths
from raytrace.renderer.device import context_for, select_device
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


@pytest.fixture(params=runnable_lane_widths(), ids=lane_id)
def lanes(request):
    return request.param


@pytest.fixture
def harness(cl_env, lanes):
    """Runs small test kernels (raytrace/commands/stability/probe.py) at this lane width on the session's context."""
    return Probe(lanes, env=cl_env)

