"""The fuzz suite's parts (tests/test_fuzz.py runs them; Hypothesis, from the test extra, is needed):
generators of hostile scenes (scenes.py), texture and mesh files (files.py), command
lines and environments (commands.py), the contract every run must keep, checked in-process or in a child
(contract.py), and the Python API's damaged dicts, parameter edits and contract (api.py);
Mitsuba 3 XML and dict-form scenes, valid and hostile, and the contract their runs keep (mitsuba.py)."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the checkout: its assets/ hold the real files the generators damage
