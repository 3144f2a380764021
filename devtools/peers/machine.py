"""The machine a peer rig's record was made on (mitsuba_bsdf.py, mitsuba_spectra.py): standard library only, as
the rigs run in Mitsuba's own virtual environment, and imported as a sibling module (the rigs run as scripts)."""
import os
import platform
from pathlib import Path


def cpu():
    """The CPU's model name (/proc/cpuinfo's first), else platform.processor()."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
        return next(line.split(":", 1)[1].strip() for line in lines if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor()


def described():
    """A record's "machine": the CPU, its core count, the platform and the Python version."""
    return {"cpu": cpu(), "cpu_count": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version()}
