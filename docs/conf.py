"""Sphinx configuration of eyelab's documentation site: the guide and references in
Markdown (MyST), the API reference from the package's docstrings, and the benchmark page
generated from docs/bench/*.json at every build.

Build: ``python -m sphinx -W -b html docs docs/_build/html`` (the ``docs`` extra); CI
builds it with warnings as errors (``tests/test_docs.py``, ``tests/test_site.py``)."""

import sys
from pathlib import Path

from sphinx_gallery.sorting import ExplicitOrder

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import eyelab  # noqa: E402  (the installed package: the API reference documents it)

project = "eyelab"
author = "the eyelab maintainers"
copyright = "2026, the eyelab maintainers"
release = version = eyelab.__version__
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary",
              "sphinx.ext.napoleon", "sphinx_gallery.gen_gallery", "benchpages"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "_templates", "bench/*.md", "gallery/*.md",
                    "gallery_examples/*.ipynb", "gallery_examples/*.py",
                    "gallery_examples/**/*.ipynb", "gallery_examples/**/*.py"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
autodoc_member_order = "bysource"
autodoc_typehints = "none"
# docs/reference/api.md's autosummary tables write one stub page per object into
# docs/reference/generated/ at each build (ignored by git), from the templates of
# docs/_templates/autosummary/ where one is given.
autosummary_generate = True
templates_path = ["_templates"]
# The gallery: every script of examples/gallery/ executed at each build, its figures kept
# (a failing example fails the build). Its sections are the sub-folders of
# examples/gallery/ (each with its GALLERY_HEADER.rst), in a newcomer's order; a section
# not named here comes last. Both folders are relative to this one (docs/): with absolute
# paths the gallery's own table of contents would name its sections by absolute path.
GALLERY = "../examples/gallery"
sphinx_gallery_conf = {
    "examples_dirs": GALLERY,
    "gallery_dirs": "gallery_examples",
    "filename_pattern": r"/plot_",
    "image_scrapers": ("matplotlib",),
    "abort_on_example_error": True,
    "download_all_examples": False,
    "show_memory": False,
    "run_stale_examples": True,         # executed at every build, never taken from before
    "subsection_order": ExplicitOrder(
        [f"{GALLERY}/{s}" for s in ("first-steps", "lenses", "eyes", "myopia-control",
                                    "tools")] + ["*"]),
}

# The theme: pydata-sphinx-theme, as PyVista, NumPy, SciPy and scikit-image use it: a top
# bar with the site's five sections (docs/index.md's root toctree, in its order), the
# section's pages on the left, the page's own contents on the right, and search. Nothing
# is fetched from the network: no version switcher, no repository or source links.
html_theme = "pydata_sphinx_theme"
html_title = "eyelab"
html_static_path = ["_static"]
html_css_files = ["eyelab.css"]     # tables and code that scroll inside the content column
html_show_sourcelink = False
# No section navigation on the landing page and Getting started (pages of their own, with
# no pages under them): their text and code get the column's full width.
html_sidebars = {"index": [], "getting-started": []}
html_theme_options = {
    "logo": {"text": "eyelab"},
    "header_links_before_dropdown": 5,  # all five sections in the top bar, no "More"
    "navbar_align": "left",
    "navbar_end": ["theme-switcher"],
    "secondary_sidebar_items": ["page-toc"],
    "show_toc_level": 2,
    "show_prev_next": True,
    "use_edit_page_button": False,
    "icon_links": [],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
}
suppress_warnings = []
nitpicky = False


def _drop_stale_gallery_pages(app) -> None:
    """Remove what an earlier build generated in docs/gallery_examples/ for a script that
    no longer exists in examples/gallery/ (moved to a section or deleted), and the
    execution-times page that lists it: sphinx-gallery leaves both there, the page outside
    every table of contents and the list pointing at it."""
    src = (HERE / GALLERY).resolve()
    out = HERE / sphinx_gallery_conf["gallery_dirs"]
    for page in out.rglob("plot_*.rst"):
        if not (src / page.relative_to(out).with_suffix(".py")).exists():
            for f in [*page.parent.glob(page.stem + ".*"),
                      page.parent / "sg_execution_times.rst"]:
                f.unlink(missing_ok=True)


def _public_data_doc(app, what, name, obj, options, lines):
    """``eyelab.SCENE_NAMES`` and ``eyelab.RENDERERS`` (tuples: no docstring of their own)
    take the ``#:`` comment above their definition, in the API reference's tables and
    pages."""
    public = name.removeprefix("eyelab.")
    if what == "data" and name == f"eyelab.{public}" and public in eyelab._API:
        from sphinx.pycode import ModuleAnalyzer

        analyzer = ModuleAnalyzer.for_module(eyelab._API[public])
        lines[:] = analyzer.find_attr_docs().get(("", public), lines)


def setup(app):
    app.connect("builder-inited", _drop_stale_gallery_pages, priority=100)  # before the gallery
    # before napoleon (priority 500), which then reads the comment's Examples section
    app.connect("autodoc-process-docstring", _public_data_doc, priority=400)
