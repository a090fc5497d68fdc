"""Sphinx configuration of eyelab's documentation site: the guide and references in
Markdown (MyST), the API reference from the package's docstrings, and the benchmark page
generated from docs/bench/*.json at every build.

Build: ``python -m sphinx -W -b html docs docs/_build/html`` (the ``docs`` extra); CI
builds it with warnings as errors (``tests/test_docs.py``)."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import eyelab  # noqa: E402  (the installed package: the API reference documents it)

project = "eyelab"
author = "the eyelab maintainers"
release = version = eyelab.__version__
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "benchpages"]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "bench/*.md", "gallery/*.md"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
autodoc_member_order = "bysource"
autodoc_typehints = "none"
html_theme = "alabaster"
html_static_path = []
html_theme_options = {"nosidebar": False}
suppress_warnings = []
nitpicky = False
