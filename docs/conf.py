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
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon",
              "sphinx_gallery.gen_gallery", "benchpages"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "bench/*.md", "gallery/*.md",
                    "gallery_examples/*.ipynb", "gallery_examples/*.py"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
autodoc_member_order = "bysource"
autodoc_typehints = "none"
# The gallery: every script of examples/gallery/ executed at each build, its figures kept
# (a failing example fails the build).
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples" / "gallery"),
    "gallery_dirs": str(HERE / "gallery_examples"),
    "filename_pattern": r"/plot_",
    "image_scrapers": ("matplotlib",),
    "abort_on_example_error": True,
    "download_all_examples": False,
    "show_memory": False,
    "run_stale_examples": True,         # executed at every build, never taken from before
}
html_theme = "alabaster"
html_static_path = []
html_theme_options = {"nosidebar": False}
suppress_warnings = []
nitpicky = False
