"""Sphinx configuration of raytrace's manual. Built strictly by tests/test_docs.py:
`python -m sphinx -W --keep-going -n -b html docs OUT` (every warning, broken link or missing anchor fails)."""
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path[:0] = [str(DOCS / "_ext"), str(DOCS.parent)]  # the local extension; the checkout, for benchmarks/

project = "raytrace"
author = "the raytrace developers"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.mathjax", "sphinxarg.ext", "raytrace_docs"]
myst_enable_extensions = ["dollarmath", "amsmath", "deflist"]
myst_heading_anchors = 3
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
html_theme = "alabaster"
html_static_path = []
nitpicky = True
# sphinx-argparse registers a domain without resolve_any_xref, which MyST asks of every domain for each
# link: a known gap of that extension (its links still resolve), the one warning let through.
suppress_warnings = ["myst.domains"]
nitpick_ignore_regex = [(r"py:.*", r"(numpy|np|pathlib|os|collections|typing)\..*"), (r"py:class", r"optional")]
