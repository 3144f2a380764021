"""Shared fixtures: the OpenCL device (real PoCL), and a harness that runs small test kernels over
LANES-wide inputs so every kernel function is checked at both widths the renderer uses."""
from pathlib import Path

import pytest

from raytrace.device import context_for, select_device
from raytrace.probe import Probe, planar  # noqa: F401 (planar: for the tests)
from raytrace.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def device():
    return select_device(None)


@pytest.fixture(scope="session")
def cl_env(device):
    return context_for(device)


@pytest.fixture(scope="session")
def cornell():
    return load_scene(ROOT / "scenes" / "cornell.toml")


@pytest.fixture(params=[1, 8], ids=["lanes1", "lanes8"])
def lanes(request):
    return request.param


@pytest.fixture
def harness(cl_env, lanes):
    """Runs small test kernels (raytrace/probe.py) at this lane width on the session's context."""
    return Probe(lanes, env=cl_env)

